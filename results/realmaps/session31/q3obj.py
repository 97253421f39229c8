#!/usr/bin/env python3
"""q3obj.py MAP.bsp OUT.obj [--patch L] -- world geometry (model 0) of a Quake 3 (IBSP 46) map as OBJ.
Planar faces (type 1) and meshes (type 3) as triangles, Bezier patches (type 2) tessellated
L x L per 3x3 patch; billboards skipped; faces whose shader is nodraw or a fog volume skipped."""
import struct, sys
path, out = sys.argv[1], sys.argv[2]
L = int(sys.argv[sys.argv.index('--patch') + 1]) if '--patch' in sys.argv else 4
b = open(path, 'rb').read()
assert b[:4] == b'IBSP', 'not a Q3 BSP'
ver = struct.unpack_from('<i', b, 4)[0]
lumps = [struct.unpack_from('<ii', b, 8 + 8 * i) for i in range(17)]
def lump(i, size):
    off, ln = lumps[i]
    return [b[off + k * size: off + (k + 1) * size] for k in range(ln // size)]
tex = [(t[:64].split(b'\0')[0].decode('latin1'), *struct.unpack_from('<ii', t, 64)) for t in lump(1, 72)]
models = [struct.unpack_from('<6f4i', m) for m in lump(7, 40)]
verts = [struct.unpack_from('<3f', v) for v in lump(10, 44)]
normals = [struct.unpack_from('<3f', v, 28) for v in lump(10, 44)]
mverts = [struct.unpack_from('<i', m)[0] for m in lump(11, 4)]
faces = [struct.unpack_from('<12i12f2i', f) for f in lump(13, 104)]
f0, nf = models[0][6], models[0][7]
V, T, N = [], [], []  # N: a front direction per vertex (Q3's vertex normals)
skipped = {'nodraw': 0, 'fog': 0, 'billboard': 0}
def bez(p0, p1, p2, t):
    a, b_, c = (1 - t) ** 2, 2 * t * (1 - t), t * t
    return tuple(a * p0[k] + b_ * p1[k] + c * p2[k] for k in range(3))
for fi in range(f0, f0 + nf):
    f = faces[fi]
    texi, _, typ, v0, nv, m0, nm = f[:7]
    name, flags, contents = tex[texi] if 0 <= texi < len(tex) else ('', 0, 0)
    if flags & 0x80:
        skipped['nodraw'] += 1; continue
    if contents & 64:
        skipped['fog'] += 1; continue
    if typ in (1, 3):
        base = len(V)
        V.extend(verts[v0:v0 + nv]); N.extend(normals[v0:v0 + nv])
        for k in range(0, nm - 2, 3):
            T.append((base + mverts[m0 + k], base + mverts[m0 + k + 1], base + mverts[m0 + k + 2]))
    elif typ == 2:
        w, h = f[-2], f[-1]
        cp = verts[v0:v0 + nv]; cn = normals[v0:v0 + nv]
        for py in range(0, h - 1, 2):
            for px in range(0, w - 1, 2):
                c = [[cp[(py + j) * w + px + i] for i in range(3)] for j in range(3)]
                cnn = [[cn[(py + j) * w + px + i] for i in range(3)] for j in range(3)]
                base = len(V)
                for j in range(L + 1):
                    rows = [bez(c[0][i], c[1][i], c[2][i], j / L) for i in range(3)]
                    nrows = [bez(cnn[0][i], cnn[1][i], cnn[2][i], j / L) for i in range(3)]
                    for i in range(L + 1):
                        V.append(bez(rows[0], rows[1], rows[2], i / L))
                        N.append(bez(nrows[0], nrows[1], nrows[2], i / L))
                for j in range(L):
                    for i in range(L):
                        a = base + j * (L + 1) + i
                        T.append((a, a + 1, a + L + 2)); T.append((a, a + L + 2, a + L + 1))
    else:
        skipped['billboard'] += 1
# Orient every triangle so its normal (right-hand rule) points to the front side that Q3's
# vertex normals give: portalfind wants polygons counter-clockwise seen from the room.
def sub(a, b): return (a[0] - b[0], a[1] - b[1], a[2] - b[2])
def cross(a, b): return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
flipped = 0
for k, (a, b_, c) in enumerate(T):
    n = cross(sub(V[b_], V[a]), sub(V[c], V[a]))
    f = tuple(N[a][i] + N[b_][i] + N[c][i] for i in range(3))
    if n[0] * f[0] + n[1] * f[1] + n[2] * f[2] < 0:
        T[k] = (a, c, b_); flipped += 1
skipped['flipped_to_front'] = flipped
with open(out, 'w') as o:
    o.write('# %s (IBSP %d): world model, %d faces, skipped %s, patches %dx%d\n' % (path.split('/')[-1], ver, nf, skipped, L, L))
    for v in V: o.write('v %r %r %r\n' % v)
    for t in T: o.write('f %d %d %d\n' % (t[0] + 1, t[1] + 1, t[2] + 1))
print(out, len(V), 'vertices', len(T), 'triangles', skipped)
