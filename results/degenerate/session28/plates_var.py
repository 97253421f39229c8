#!/usr/bin/env python3
"""plates_var.py K SEP OUT [onesided]: room 10^3 with K two-sided 6x6 plates at z=5+i*SEP"""
import sys; import os; sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from geom import Mesh, box_room
K, sep, out = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
one = len(sys.argv) > 4
m = Mesh(); box_room(m, (0, 0, 0), (10, 10, 10), n=1)
for i in range(K):
    z = 5.0 + i * sep
    p = [(2, 2, z), (8, 2, z), (8, 8, z), (2, 8, z)]
    m.poly(p)
    if not one: m.poly(p[::-1])
m.write(out, " ".join(sys.argv[1:]))
