#!/usr/bin/env python3
"""gen.py KIND N OUT.obj  -- degenerate-but-plausible probe models. N ~ target polygon count."""
import sys, math, random
sys.path.insert(0, "/tmp/probe")
from geom import Mesh, grid, box_room, add, mul

def uv_sphere(m, c, r, nlat, nlon, inward):
    pts = lambda i, j: add(c, (r * math.sin(math.pi * i / nlat) * math.cos(2 * math.pi * j / nlon),
                               r * math.sin(math.pi * i / nlat) * math.sin(2 * math.pi * j / nlon),
                               r * math.cos(math.pi * i / nlat))) if 0 < i < nlat else add(c, (0, 0, r if i == 0 else -r))
    for i in range(nlat):
        for j in range(nlon):
            a, b, cc, d = pts(i, j), pts(i, j + 1), pts(i + 1, j + 1), pts(i + 1, j)
            # outward CCW: a (top), d (below), cc, b
            if i == 0: tri = [a, d, cc]
            elif i == nlat - 1: tri = [a, d, b]
            else: tri = [a, d, cc, b]
            if inward: tri = tri[::-1]
            if i == 0 or i == nlat - 1: m.poly(tri)
            else:
                m.poly([tri[0], tri[1], tri[2]]); m.poly([tri[0], tri[2], tri[3]])

def kind_sphere_room(N):
    m = Mesh(); n = max(4, int(math.sqrt(N / 2)))
    uv_sphere(m, (0, 0, 0), 5.0, n, 2 * n // 1, inward=True); return m

def kind_sphere_in_box(N):
    m = Mesh(); n = max(4, int(math.sqrt(N / 4)))
    box_room(m, (-10, -10, -10), (10, 10, 10), n=1)
    uv_sphere(m, (0, 0, 0), 4.0, n, 2 * n, inward=False); return m

def kind_grid_floor(N):
    # a box room whose floor is an n x n regular grid of quads
    m = Mesh(); n = max(2, int(math.sqrt(N)))
    box_room(m, (0, 0, 0), (20, 20, 3), n={"floor": n}); return m

def kind_grid_all(N):
    # every face a regular grid: cube lattice points (8-point cospherical sets on surfaces)
    m = Mesh(); n = max(2, int(math.sqrt(N / 6)))
    box_room(m, (0, 0, 0), (10, 10, 10), n=n); return m

def kind_grid_floor_ceil_close(N):
    # floor and ceiling grids identical in xy: many cospherical 8-tuples (cube cells of a lattice), low room
    m = Mesh(); n = max(2, int(math.sqrt(N / 2)))
    h = 20.0 / n
    box_room(m, (0, 0, 0), (20, 20, h), n={"floor": n, "ceil": n}); return m

def kind_tunnel(N):
    # long cylindrical tunnel (inward), k segments around, closed by polygon caps (cocircular caps!)
    m = Mesh(); k = max(8, N // 2); L = 100.0; r = 2.0
    ring = lambda z: [(r * math.cos(2 * math.pi * j / k), r * math.sin(2 * math.pi * j / k), z) for j in range(k)]
    a, b = ring(0), ring(L)
    for j in range(k):
        j1 = (j + 1) % k
        m.poly([a[j], a[j1], b[j1], b[j]][::-1])  # inward
    m.poly(a)            # cap z=0 normal +z: CCW from +z -> a as is
    m.poly(b[::-1]); return m

def kind_tunnel_fan(N):
    # same tunnel but caps as triangle fans around a centre vertex
    m = Mesh(); k = max(8, N // 4); L = 100.0; r = 2.0
    ring = lambda z: [(r * math.cos(2 * math.pi * j / k), r * math.sin(2 * math.pi * j / k), z) for j in range(k)]
    a, b = ring(0), ring(L)
    for j in range(k):
        j1 = (j + 1) % k
        m.poly([b[j], b[j1], a[j1], a[j]])
        m.poly([(0, 0, 0), a[j], a[j1]])
        m.poly([(0, 0, L), b[j1], b[j]])
    return m

def kind_slabs(N):
    # a room with K thin horizontal slabs (solid boxes) stacked 1e-3 apart
    m = Mesh(); K = max(1, N // 6)
    box_room(m, (0, 0, 0), (10, 10, 10), n=1)
    t = gap = min(1e-3, 8.0 / (2 * K))
    for i in range(K):
        z = 1.0 + i * (t + gap)
        box_room(m, (2, 2, z), (8, 8, z + t), inward=False)
    return m

def kind_plates(N):
    # stack of K single-sided... two-sided thin plates at separations 1e-6 (floors of zero thickness, both faces)
    m = Mesh(); K = max(1, N // 2)
    box_room(m, (0, 0, 0), (10, 10, 10), n=1)
    for i in range(K):
        z = 5.0 + i * 1e-6
        p = [(2, 2, z), (8, 2, z), (8, 8, z), (2, 8, z)]
        m.poly(p); m.poly(p[::-1])
    return m

def kind_floors_1e6(N):
    # K solid floor slabs of thickness 1e-6 separated by 1e-6 inside a room
    m = Mesh(); K = max(1, N // 6)
    box_room(m, (0, 0, 0), (10, 10, 10), n=1)
    for i in range(K):
        z = 5.0 + i * 2e-6
        box_room(m, (2, 2, z), (8, 8, z + 1e-6), inward=False)
    return m

def kind_fan(N):
    # room whose floor is one huge fan of N thin triangles around the centre (rim vertices cocircular)
    m = Mesh(); k = max(8, N)
    box_room(m, (-10, -10, 0), (10, 10, 3), n=1, skip=("floor",))
    # floor = square; fan from centre to points along the square boundary (not cocircular), k triangles
    per = k // 4; rim = []
    sq = [(-10, -10), (10, -10), (10, 10), (-10, 10)]
    for s in range(4):
        (ax, ay), (bx, by) = sq[s], sq[(s + 1) % 4]
        for i in range(per): t = i / per; rim.append((ax + (bx - ax) * t, ay + (by - ay) * t, 0))
    for i in range(len(rim)):
        m.poly([(0, 0, 0), rim[i], rim[(i + 1) % len(rim)]])
    return m

def kind_dup_coplanar(N):
    # room with the floor polygon duplicated K times (exact overlapping copies)
    m = Mesh(); K = max(1, N)
    box_room(m, (0, 0, 0), (10, 10, 3), n=1, skip=("floor",))
    p = [(0, 0, 0), (10, 0, 0), (10, 10, 0), (0, 10, 0)]
    for i in range(K): m.f.append([m.vid(q) for q in p])
    return m

def kind_overlap_coplanar(N):
    # room whose floor is covered by K overlapping random coplanar quads on top of the floor (decals)
    m = Mesh(); K = max(1, N); rnd = random.Random(1)
    box_room(m, (0, 0, 0), (10, 10, 3), n=1)
    for i in range(K):
        x, y = rnd.uniform(0, 9), rnd.uniform(0, 9); w, h = rnd.uniform(0.1, 1), rnd.uniform(0.1, 1)
        m.poly([(x, y, 0), (x + w, y, 0), (x + w, y + h, 0), (x, y + h, 0)])
    return m

def kind_slivers(N):
    # floor made of long thin sliver triangles: strip between y=0 and y=10 with vertices offset
    m = Mesh(); k = max(2, N // 2)
    box_room(m, (0, 0, 0), (10, 10, 3), n=1, skip=("floor",))
    # bottom points x_i = 10 i/k at y=0, top points at y=10; triangles spanning the whole depth
    for i in range(k):
        a0, a1 = (10 * i / k, 0, 0), (10 * (i + 1) / k, 0, 0)
        b0, b1 = (10 * i / k, 10, 0), (10 * (i + 1) / k, 10, 0)
        m.poly([a0, a1, b1]); m.poly([a0, b1, b0])
    # the walls' bottom edges are split by floor vertices -> T-junctions on y0/y1 walls
    return m

def kind_slivers_skew(N):
    # slivers: triangles (i/k,0)-(i+1/k,0)-(1 - i/k,10) crossing fans; very obtuse, no two-way sharing
    m = Mesh(); k = max(2, N // 2)
    box_room(m, (0, 0, 0), (10, 10, 3), n=1, skip=("floor",))
    bot = [(10 * i / k, 0, 0) for i in range(k + 1)]
    top = [(10 * i / k, 10, 0) for i in range(k + 1)]
    # fan from bottom-left corner to all top points, then fan from top-right to bottom points
    for i in range(k): m.poly([bot[0], top[i + 1], top[i]])
    for i in range(k): m.poly([bot[i], bot[i + 1], top[k]])
    # fill gap: region between bot[0]-top[k] diagonal is covered twice... (overlap intended: sliver fans)
    return m

def kind_shift1e6(N):
    import subprocess
    return None

def kind_holes(N):
    # two rooms sharing a perforated wall with K tiny (1 mm) square holes in a grid
    m = Mesh(); k = max(1, int(math.sqrt(N / 8)))
    box_room(m, (0, 0, 0), (10, 10, 3), n=1, skip=("x1",))
    box_room(m, (10.2, 0, 0), (20, 10, 3), n=1, skip=("x0",))
    # wall slab between x=10 and x=10.2, y in [0,10], z in [0,3]; holes through it
    # build both faces as a grid of cells; hole cells omitted and replaced by tunnel sides
    hs = 0.001
    ys = [10 * j / k for j in range(k + 1)]; zs = [3 * j / k for j in range(k + 1)]
    for xw, inward_side in ((10.0, -1), (10.2, +1)):
        for a in range(k):
            for b in range(k):
                y0, y1, z0, z1 = ys[a], ys[a + 1], zs[b], zs[b + 1]
                cy, cz = (y0 + y1) / 2, (z0 + z1) / 2
                # cell with square hole: 4 quads (frame) around [cy-hs,cy+hs]x[cz-hs,cz+hs]
                hy0, hy1, hz0, hz1 = cy - hs, cy + hs, cz - hs, cz + hs
                rects = [(y0, y1, z0, hz0), (y0, y1, hz1, z1), (y0, hy0, hz0, hz1), (hy1, y1, hz0, hz1)]
                for (ry0, ry1, rz0, rz1) in rects:
                    p = [(xw, ry0, rz0), (xw, ry1, rz0), (xw, ry1, rz1), (xw, ry0, rz1)]  # normal +x
                    m.poly(p if inward_side > 0 else p[::-1])
    # hole tunnels
    for a in range(k):
        for b in range(k):
            cy, cz = (ys[a] + ys[a + 1]) / 2, (zs[b] + zs[b + 1]) / 2
            y0, y1, z0, z1 = cy - hs, cy + hs, cz - hs, cz + hs
            X0, X1 = 10.0, 10.2
            m.poly([(X0, y0, z0), (X1, y0, z0), (X1, y0, z1), (X0, y0, z1)][::-1])  # y=y0 side, normal +y
            m.poly([(X0, y1, z0), (X1, y1, z0), (X1, y1, z1), (X0, y1, z1)])        # normal -y
            m.poly([(X0, y0, z0), (X0, y1, z0), (X1, y1, z0), (X1, y0, z0)])        # z0 side normal +z
            m.poly([(X0, y0, z1), (X0, y1, z1), (X1, y1, z1), (X1, y0, z1)][::-1])  # normal -z
    # floor/ceiling of the wall slab
    m.poly([(10, 0, 0), (10.2, 0, 0), (10.2, 10, 0), (10, 10, 0)][::-1])
    m.poly([(10, 0, 3), (10.2, 0, 3), (10.2, 10, 3), (10, 10, 3)])
    m.poly([(10, 0, 0), (10.2, 0, 0), (10.2, 0, 3), (10, 0, 3)])
    m.poly([(10, 10, 0), (10.2, 10, 0), (10.2, 10, 3), (10, 10, 3)][::-1])
    return m

def kind_collinear(N):
    # room whose walls' long edges carry N nearly-collinear vertices (jitter 1e-9 off the line)
    m = Mesh(); k = max(2, N // 4); rnd = random.Random(2)
    box_room(m, (0, 0, 0), (100, 10, 3), n=1, skip=("y0",))
    # y0 wall (normal +y) as a strip of k quads along x, bottom/top edges jittered in y? keep planar: jitter z
    xs = [100 * i / k for i in range(k + 1)]
    jb = [0.0] + [rnd.uniform(-1e-9, 1e-9) for _ in range(k - 1)] + [0.0]
    jt = [3.0] + [3.0 + rnd.uniform(-1e-9, 1e-9) for _ in range(k - 1)] + [3.0]
    for i in range(k):
        p = [(xs[i], 0, jb[i]), (xs[i + 1], 0, jb[i + 1]), (xs[i + 1], 0, jt[i + 1]), (xs[i], 0, jt[i])]
        m.poly(p[::-1])  # y0 wall normal +y: order (x,z) ... check: Z x X = +y  -> p0,(z),(x)
    return m

def kind_tjunction(N):
    # floor tessellated n x n, walls tessellated with a coprime count (mismatched seams everywhere),
    # plus floor split as quadtree-like: alternate rows with 2x resolution -> T-junctions at every row boundary
    m = Mesh(); n = max(2, int(math.sqrt(N / 3)))
    box_room(m, (0, 0, 0), (20, 20, 3), n={"ceil": n + 1, "x0": n - 1, "x1": n + 1, "y0": n - 1, "y1": n + 1}, skip=("floor",))
    for j in range(n):
        cols = n if j % 2 == 0 else 2 * n
        for i in range(cols):
            x0, x1 = 20 * i / cols, 20 * (i + 1) / cols; y0, y1 = 20 * j / n, 20 * (j + 1) / n
            m.poly([(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)])
    return m


def kind_round_room(N):
    # short round room (tower floor): k wall quads, floor and ceiling as triangle fans around centre vertices
    m = Mesh(); k = max(8, N // 3); r = 10.0; H = 3.0
    ring = lambda z: [(r * math.cos(2 * math.pi * j / k), r * math.sin(2 * math.pi * j / k), z) for j in range(k)]
    a, b = ring(0), ring(H)
    for j in range(k):
        j1 = (j + 1) % k
        m.poly([b[j], b[j1], a[j1], a[j]])
        m.poly([(0, 0, 0), a[j], a[j1]])
        m.poly([(0, 0, H), b[j1], b[j]])
    return m

def kind_round_room_poly(N):
    # same round room but floor/ceiling as single k-gons
    m = Mesh(); k = max(8, N); r = 10.0; H = 3.0
    ring = lambda z: [(r * math.cos(2 * math.pi * j / k), r * math.sin(2 * math.pi * j / k), z) for j in range(k)]
    a, b = ring(0), ring(H)
    for j in range(k):
        j1 = (j + 1) % k
        m.poly([b[j], b[j1], a[j1], a[j]])
    m.poly(a); m.poly(b[::-1])
    return m
KINDS = {k[5:]: v for k, v in globals().items() if k.startswith("kind_")}

def _square_rim(k, half=10.0):
    per = max(1, k // 4); rim = []
    sq = [(-half, -half), (half, -half), (half, half), (-half, half)]
    for s in range(4):
        (ax, ay), (bx, by) = sq[s], sq[(s + 1) % 4]
        for i in range(per): t = i / per; rim.append((ax + (bx - ax) * t, ay + (by - ay) * t, 0))
    return rim

def kind_square_ngon(N):
    # square room whose floor is ONE polygon with N vertices along its (straight) edges, walls tessellated to match
    m = Mesh(); rim = _square_rim(N); per = len(rim) // 4
    box_room(m, (-10, -10, 0), (10, 10, 3), n=1, skip=("floor", "x0", "x1", "y0", "y1"))
    m.poly(rim)
    for i in range(len(rim)):
        p, q = rim[i], rim[(i + 1) % len(rim)]
        m.poly([p, (p[0], p[1], 3.0), (q[0], q[1], 3.0), q])  # walls facing inward: check
    return m

def kind_corner_fan(N):
    # square room, floor as a fan from one corner to N points along the two far edges
    m = Mesh(); k = max(4, N // 2)
    box_room(m, (0, 0, 0), (20, 20, 3), n=1, skip=("floor",))
    rim = [(20, 20 * i / k, 0) for i in range(k)] + [(20 - 20 * i / k, 20, 0) for i in range(k + 1)]
    for i in range(len(rim) - 1): m.poly([(0, 0, 0), rim[i], rim[i + 1]])
    return m

KINDS = {k[5:]: v for k, v in globals().items() if k.startswith("kind_")}

def kind_strip_wall(N):
    # long corridor-like room 100 x 10 x 3 whose y0 wall is a strip of N/4 tall thin quads (exactly collinear edge vertices)
    m = Mesh(); k = max(2, N // 4)
    box_room(m, (0, 0, 0), (100, 10, 3), n=1, skip=("y0",))
    xs = [100 * i / k for i in range(k + 1)]
    for i in range(k):
        p = [(xs[i], 0, 0), (xs[i + 1], 0, 0), (xs[i + 1], 0, 3), (xs[i], 0, 3)]
        m.poly(p[::-1])
    return m

def kind_strip_wall_cube(N):
    # cube room 10^3 whose y0 wall is a strip of N/4 tall thin quads
    m = Mesh(); k = max(2, N // 4)
    box_room(m, (0, 0, 0), (10, 10, 10), n=1, skip=("y0",))
    xs = [10 * i / k for i in range(k + 1)]
    for i in range(k):
        p = [(xs[i], 0, 0), (xs[i + 1], 0, 0), (xs[i + 1], 0, 10), (xs[i], 0, 10)]
        m.poly(p[::-1])
    return m

KINDS = {k[5:]: v for k, v in globals().items() if k.startswith("kind_")}

def kind_grid_floor_ceil_h3(N):
    # ordinary 20x20x3 room, floor and ceiling both the same regular n x n grid
    m = Mesh(); n = max(2, int(math.sqrt(N / 2)))
    box_room(m, (0, 0, 0), (20, 20, 3), n={"floor": n, "ceil": n}); return m

def kind_grid_floor_ceil_rand(N):
    # low room as grid_floor_ceil_close, but ceiling grid shifted by a random sub-cell offset (no lattice cospherity)
    m = Mesh(); n = max(2, int(math.sqrt(N / 2))); h = 20.0 / n
    box_room(m, (0, 0, 0), (20, 20, h), n={"floor": n}, skip=("ceil",))
    # ceiling grid over same square but interior vertices jittered in xy by up to 10% of a cell
    rnd = random.Random(3); c = 20.0 / n
    P = {}
    for i in range(n + 1):
        for j in range(n + 1):
            dx = rnd.uniform(-0.1, 0.1) * c if 0 < i < n else 0.0
            dy = rnd.uniform(-0.1, 0.1) * c if 0 < j < n else 0.0
            P[i, j] = (i * c + dx, j * c + dy, h)
    for i in range(n):
        for j in range(n):
            m.poly([P[i, j], P[i, j + 1], P[i + 1, j + 1], P[i + 1, j]])
    return m

KINDS = {k[5:]: v for k, v in globals().items() if k.startswith("kind_")}

if __name__ == "__main__":
    kind, N, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    m = KINDS[kind](N)
    m.write(out, f"gen.py {kind} {N}")
