"""Shared OBJ writing helpers. Polygons face free space from their front (CCW seen from the front)."""
import math
class Mesh:
    def __init__(self):
        self.v = []; self.idx = {}; self.f = []
    def vid(self, p):
        k = tuple(p)
        if k not in self.idx:
            self.idx[k] = len(self.v); self.v.append(k)
        return self.idx[k]
    def poly(self, pts):
        self.f.append([self.vid(p) for p in pts])
    def write(self, path, comment=""):
        with open(path, "w") as fh:
            if comment: fh.write("# " + comment + "\n")
            for p in self.v: fh.write("v %.17g %.17g %.17g\n" % p)
            for f in self.f: fh.write("f " + " ".join(str(i + 1) for i in f) + "\n")
        print(f"wrote {path}: {len(self.v)} verts {len(self.f)} polys")

def add(a, b): return tuple(x + y for x, y in zip(a, b))
def mul(a, s): return tuple(x * s for x in a)

def grid(m, o, u, v, nu, nv, tri=False):
    """Quads spanning o + [0,1]u + [0,1]v, front normal u x v."""
    for i in range(nu):
        for j in range(nv):
            p00 = add(o, add(mul(u, i / nu), mul(v, j / nv)))
            p10 = add(o, add(mul(u, (i + 1) / nu), mul(v, j / nv)))
            p11 = add(o, add(mul(u, (i + 1) / nu), mul(v, (j + 1) / nv)))
            p01 = add(o, add(mul(u, i / nu), mul(v, (j + 1) / nv)))
            if tri:
                m.poly([p00, p10, p11]); m.poly([p00, p11, p01])
            else:
                m.poly([p00, p10, p11, p01])

def box_room(m, lo, hi, n=1, skip=(), inward=True):
    """Box faces. inward=True: a closed room (normals point inside). inward=False: a solid block (normals outside).
    skip: names of faces to omit: floor ceil x0 x1 y0 y1."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    W, D, H = x1 - x0, y1 - y0, z1 - z0
    X, Y, Z = (W, 0, 0), (0, D, 0), (0, 0, H)
    faces = {
        "floor": ((x0, y0, z0), X, Y),   # +z
        "ceil": ((x0, y0, z1), Y, X),    # -z
        "x0": ((x0, y0, z0), Y, Z),      # +x
        "x1": ((x1, y0, z0), Z, Y),      # -x
        "y0": ((x0, y0, z0), Z, X),      # +y
        "y1": ((x0, y1, z0), X, Z),      # -y
    }
    for name, (o, u, v) in faces.items():
        if name in skip: continue
        if not inward: u, v = v, u
        nu = n if isinstance(n, int) else n.get(name, 1)
        grid(m, o, u, v, nu, nu)
