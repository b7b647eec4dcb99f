#!/usr/bin/env python3
"""How much of an annular groove around the Z axis a vertical disc cutter sweeps at one level.

    scripts/disc_reach.py PART.stl Z T RMIN RMAX R:RHO[:MARGIN] ...

Columns of the part (scripts/iou_check.py's crossings, 0.1 mm raster over x, y in -R..R of
the part's box). At the level [Z, Z + T] (the disc's bottom and thickness) a cutter centre
is free where the disc of radius R + MARGIN is clear of the part over the band and the neck
of radius RHO + MARGIN clear of it from Z + T up; the centres are taken in the groove's
air (RMIN < r < RMAX) alone, so a pass reaches them down an opening from above. Prints the
groove's air at the level and, per cutter, the free centres and the area of the groove's
air the discs of radius R at those centres sweep (mm^2). R = RHO is an end mill on a neck
of its own width. (issue 35: example007's groove, docs/milling-log.md, `undercut14`.)
"""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from iou_check import load_stl, column_crossings  # noqa: E402

tris = load_stl(sys.argv[1])
z0, t, rmin, rmax = (float(a) for a in sys.argv[2:6])
h = 0.1
ext = max(max(abs(p[a]) for tr in tris for p in tr) for a in (0, 1)) + 0.5
n = int(math.ceil(2 * ext / h))
cols = column_crossings(tris, -ext, -ext, h, n, n)


def occupied(lo, hi):
    out = set()
    for key, z in cols.items():
        if any(z[k] <= hi and z[k + 1] >= lo for k in range(0, len(z) - 1, 2)):
            out.add(key)
    return out


def disk(rad):
    k = int(math.ceil(rad / h))
    return [(a, b) for a in range(-k, k + 1) for b in range(-k, k + 1) if (a * h) ** 2 + (b * h) ** 2 <= rad * rad]


band, above = occupied(z0, z0 + t), occupied(z0 + t, math.inf)
c = lambda i: -ext + (i + 0.5) * h  # noqa: E731
groove = {(i, j) for i in range(n) for j in range(n)
          if rmin < math.hypot(c(i), c(j)) < rmax and (i, j) not in band}
print(f"z {z0}..{z0 + t}: the groove's air {len(groove) * h * h:.1f} mm2")
for spec in sys.argv[6:]:
    r, rho, margin = ([float(v) for v in spec.split(":")] + [0.0])[:3]
    disc, neck, sweep = disk(r + margin), disk(rho + margin), disk(r)
    free = [(i, j) for (i, j) in groove
            if all((i + a, j + b) not in band for a, b in disc)
            and all((i + a, j + b) not in above for a, b in neck)]
    cut = {(i + a, j + b) for i, j in free for a, b in sweep} & groove
    print(f"  disc R {r} neck {rho} margin {margin}: {len(free)} centres, sweeps {len(cut) * h * h:.1f} mm2")
