#!/usr/bin/env python3
"""Independent IoU of two closed meshes, in pure Python (no code shared with s2g).

    scripts/iou_check.py PART.stl RESIDUAL.stl [N] [--cell MM] [--columns]

Both meshes are voxelised on one grid of N cells along the longest side of their common
bounding box (default 96), or of cells MM wide (`--cell`): a cell is inside a mesh when a
ray along +Z from below through the cell's centre column has crossed an odd number of the
mesh's triangles by the cell's centre. Prints `iou inside_part inside_residual` (cells).

`--columns` measures along Z exactly instead: each column (the grid's XY cells) holds the
intervals between the mesh's crossings, and the volumes are the columns' interval lengths
(part, residual and their intersection) times the cell's area; it keeps no cell sets, so a
part a few tenths of a millimetre thick can be scored at `--cell 0.05` over 200 mm. It then
prints `iou volume_part volume_residual` (mm^3 or the meshes' units). The scorer of `s2g mill` voxelises with
a generalised winding number on its own grid; this one counts crossings along columns, so
a disagreement between the two shows a scoring error rather than a machining one.
"""
import math
import struct
import sys


def load_stl(path):
    """Triangles of an ASCII or binary STL as lists of three (x, y, z) tuples."""
    data = open(path, "rb").read()
    if len(data) >= 84:
        (n,) = struct.unpack_from("<I", data, 80)
        if 84 + 50 * n == len(data):
            tris = []
            for i in range(n):
                v = struct.unpack_from("<12f", data, 84 + 50 * i)
                tris.append(((v[3], v[4], v[5]), (v[6], v[7], v[8]), (v[9], v[10], v[11])))
            return tris
    tris, cur = [], []
    for line in data.decode("ascii", "replace").splitlines():
        w = line.split()
        if w and w[0] == "vertex":
            cur.append((float(w[1]), float(w[2]), float(w[3])))
            if len(cur) == 3:
                tris.append(tuple(cur))
                cur = []
    return tris


def column_crossings(tris, x0, y0, h, nx, ny):
    """For every column (i, j) of centre (x0 + (i + .5) h, y0 + (j + .5) h), the sorted Z
    of its crossings with the triangles."""
    cols = {}
    for a, b, c in tris:
        lo_i = max(0, int(math.floor((min(a[0], b[0], c[0]) - x0) / h - 0.5)))
        hi_i = min(nx - 1, int(math.floor((max(a[0], b[0], c[0]) - x0) / h - 0.5)) + 1)
        lo_j = max(0, int(math.floor((min(a[1], b[1], c[1]) - y0) / h - 0.5)))
        hi_j = min(ny - 1, int(math.floor((max(a[1], b[1], c[1]) - y0) / h - 0.5)) + 1)
        d = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if d == 0.0:
            continue
        for i in range(lo_i, hi_i + 1):
            px = x0 + (i + 0.5) * h
            for j in range(lo_j, hi_j + 1):
                py = y0 + (j + 0.5) * h
                # Barycentric coordinates in XY; the grid's irrational shift keeps
                # column centres off shared edges, so each crossing counts once.
                u = ((b[0] - px) * (c[1] - py) - (b[1] - py) * (c[0] - px)) / d
                v = ((c[0] - px) * (a[1] - py) - (c[1] - py) * (a[0] - px)) / d
                w = 1.0 - u - v
                if u < 0 or v < 0 or w < 0:
                    continue
                z = u * a[2] + v * b[2] + w * c[2]
                cols.setdefault((i, j), []).append(z)
    for zs in cols.values():
        zs.sort()
    return cols


def inside_cells(cols, z0, h, nz):
    """The set of (i, j, k) cells whose centre lies inside by parity along the column."""
    out = set()
    for (i, j), zs in cols.items():
        for n in range(0, len(zs) - 1, 2):
            lo, hi = zs[n], zs[n + 1]
            k0 = max(0, int(math.ceil((lo - z0) / h - 0.5)))
            k1 = min(nz - 1, int(math.floor((hi - z0) / h - 0.5)))
            for k in range(k0, k1 + 1):
                out.add((i, j, k))
    return out


def intervals(zs):
    """The inside intervals of a column's sorted crossings, by parity."""
    return [(zs[n], zs[n + 1]) for n in range(0, len(zs) - 1, 2)]


def overlap(xs, ys):
    """Total length of the intersection of two sorted lists of disjoint intervals."""
    total, i, j = 0.0, 0, 0
    while i < len(xs) and j < len(ys):
        lo, hi = max(xs[i][0], ys[j][0]), min(xs[i][1], ys[j][1])
        if hi > lo:
            total += hi - lo
        if xs[i][1] < ys[j][1]:
            i += 1
        else:
            j += 1
    return total


def column_iou(ca, cb, h):
    """IoU and volumes from the columns' interval lengths (exact along Z)."""
    va = vb = vi = 0.0
    for key in set(ca) | set(cb):
        ia, ib = intervals(ca.get(key, [])), intervals(cb.get(key, []))
        va += sum(hi - lo for lo, hi in ia)
        vb += sum(hi - lo for lo, hi in ib)
        vi += overlap(ia, ib)
    union = va + vb - vi
    return (vi / union if union > 0 else 1.0), va * h * h, vb * h * h


def main():
    args = [x for x in sys.argv[1:] if x != "--columns"]
    columns = len(args) < len(sys.argv) - 1
    cell = None
    if "--cell" in args:
        at = args.index("--cell")
        if at + 1 >= len(args):
            sys.exit(__doc__)
        cell = float(args[at + 1])
        if not cell > 0:
            sys.exit("--cell must be positive")
        del args[at : at + 2]
    if len(args) < 2:
        sys.exit(__doc__)
    a, b = load_stl(args[0]), load_stl(args[1])
    n = int(args[2]) if len(args) > 2 else 96
    pts = [p for t in a + b for p in t]
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(p[k] for p in pts) for k in range(3)]
    h = cell if cell else max(hi[k] - lo[k] for k in range(3)) / n
    # A small irrational shift keeps column centres off mesh edges and vertices.
    x0, y0, z0 = lo[0] - 0.5 * h * 0.0137, lo[1] - 0.5 * h * 0.0291, lo[2]
    nx, ny, nz = (int(math.ceil((hi[k] - lo[k]) / h)) + 1 for k in range(3))
    if columns:
        ca, cb = column_crossings(a, x0, y0, h, nx, ny), column_crossings(b, x0, y0, h, nx, ny)
        iou, va, vb = column_iou(ca, cb, h)
        print(f"{iou:.4f} {va:.3f} {vb:.3f}")
        return
    ia = inside_cells(column_crossings(a, x0, y0, h, nx, ny), z0, h, nz)
    ib = inside_cells(column_crossings(b, x0, y0, h, nx, ny), z0, h, nz)
    union = len(ia | ib)
    iou = len(ia & ib) / union if union else 1.0
    print(f"{iou:.4f} {len(ia)} {len(ib)}")


if __name__ == "__main__":
    main()
