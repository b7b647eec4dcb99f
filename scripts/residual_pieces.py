#!/usr/bin/env python3
"""Where a milled part differs from its model, piece by piece (issue 35's diagnosis).

    scripts/residual_pieces.py PART.stl RESIDUAL.stl CELL_MM

Voxelises both meshes as scripts/iou_check.py does (crossing parity along Z columns) on
one grid of CELL_MM cells over their common box, and prints the volumes (mm^3) of the
part, the residual, the excess (residual cells outside the part: stock left) and the
missing (part cells outside the residual), the IoU on that grid, then the twelve largest
6-connected pieces of the excess and of the missing, each with its volume and box.
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from iou_check import load_stl, column_crossings, inside_cells  # noqa: E402
part, res, h = load_stl(sys.argv[1]), load_stl(sys.argv[2]), float(sys.argv[3])
pts = [p for t in part + res for p in t]
lo = [min(p[a] for p in pts) for a in range(3)]
hi = [max(p[a] for p in pts) for a in range(3)]
n = [max(1, int(math.ceil((hi[a] - lo[a]) / h))) for a in range(3)]
def cells(tris):
    cols = column_crossings(tris, lo[0], lo[1], h, n[0], n[1])
    return inside_cells(cols, lo[2], h, n[2])
P, R = cells(part), cells(res)
P, R = set(P), set(R)
ex, mi = R - P, P - R
def comps(s):
    s = set(s); out = []
    while s:
        c = s.pop(); stack = [c]; comp = [c]
        while stack:
            i, j, k = stack.pop()
            for d in ((1,0,0),(-1,0,0),(0,1,0),(0,-1,0),(0,0,1),(0,0,-1)):
                q = (i+d[0], j+d[1], k+d[2])
                if q in s:
                    s.remove(q); stack.append(q); comp.append(q)
        out.append(comp)
    out.sort(key=len, reverse=True)
    return out
v = h**3
print(f"part {len(P)*v:.0f} mm3 residual {len(R)*v:.0f} excess {len(ex)*v:.0f} missing {len(mi)*v:.0f} iou {len(P&R)/len(P|R):.4f}")
for name, s in (("excess", ex), ("missing", mi)):
    cs = comps(s)
    print(f"{name}: {len(cs)} pieces")
    for c in cs[:12]:
        mn = [lo[a] + h * min(p[a] for p in c) for a in range(3)]
        mx = [lo[a] + h * (max(p[a] for p in c) + 1) for a in range(3)]
        print(f"  {len(c)*v:8.0f} mm3  x {mn[0]:.1f}..{mx[0]:.1f} y {mn[1]:.1f}..{mx[1]:.1f} z {mn[2]:.1f}..{mx[2]:.1f}")
