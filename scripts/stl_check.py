#!/usr/bin/env python3
"""Check binary STL files: closed (every undirected edge used by exactly two triangles),
consistently oriented (every directed edge used once, and its reverse once), degenerate
triangles, bounding box and volume (divergence theorem). One line per file; exits 1 if any
file is not a closed, consistently oriented binary STL.

    scripts/stl_check.py FILE.stl...

Vertices are matched by their coordinates rounded to 1e-6 mm (STL stores float32, so the
copies of one vertex are bit-equal; the rounding only guards against -0.0)."""
import struct
import sys
from collections import Counter


def read_binary_stl(path):
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 84:
        raise ValueError("shorter than a binary STL header")
    (n,) = struct.unpack_from("<I", data, 80)
    if len(data) != 84 + 50 * n:
        raise ValueError(f"size {len(data)} != 84 + 50 * {n} (ASCII STL?)")
    tris = []
    for i in range(n):
        v = struct.unpack_from("<9f", data, 84 + 50 * i + 12)
        tris.append((v[0:3], v[3:6], v[6:9]))
    return tris


def check(path):
    tris = read_binary_stl(path)
    key = lambda p: tuple(round(c, 6) + 0.0 for c in p)
    undirected = Counter()
    directed = Counter()
    degenerate = 0
    vol6 = 0.0
    lo = [float("inf")] * 3
    hi = [float("-inf")] * 3
    for a, b, c in tris:
        ka, kb, kc = key(a), key(b), key(c)
        if ka == kb or kb == kc or kc == ka:
            degenerate += 1
        for p, q in ((ka, kb), (kb, kc), (kc, ka)):
            directed[(p, q)] += 1
            undirected[(min(p, q), max(p, q))] += 1
        for p in (a, b, c):
            for i in range(3):
                lo[i] = min(lo[i], p[i])
                hi[i] = max(hi[i], p[i])
        # signed volume of the tetrahedron (origin, a, b, c), times 6
        vol6 += (a[0] * (b[1] * c[2] - b[2] * c[1])
                 - a[1] * (b[0] * c[2] - b[2] * c[0])
                 + a[2] * (b[0] * c[1] - b[1] * c[0]))
    bad_edges = sum(1 for n in undirected.values() if n != 2)
    bad_orient = sum(1 for (p, q), n in directed.items() if n != 1 or directed.get((q, p)) != 1)
    verts = len({key(p) for t in tris for p in t})
    closed = bad_edges == 0
    oriented = bad_orient == 0
    # Euler characteristic V - E + F (2 per closed genus-0 shell, less 2 per handle)
    euler = verts - len(undirected) + len(tris)
    return {
        "facets": len(tris),
        "verts": verts,
        "closed": closed,
        "oriented": oriented,
        "bad_edges": bad_edges,
        "bad_orient": bad_orient,
        "degenerate": degenerate,
        "euler": euler,
        "bbox": [h - l for l, h in zip(lo, hi)],
        "lo": lo,
        "volume": vol6 / 6.0,
    }


def main(paths):
    ok = True
    for path in paths:
        try:
            r = check(path)
        except (OSError, ValueError) as e:
            print(f"{path}: ERROR {e}")
            ok = False
            continue
        good = r["closed"] and r["oriented"] and r["volume"] > 0
        ok &= good
        bb = " x ".join(f"{x:.3f}" for x in r["bbox"])
        print(f"{path}: {'closed' if good else 'NOT CLOSED'} facets={r['facets']} "
              f"verts={r['verts']} euler={r['euler']} bad_edges={r['bad_edges']} "
              f"bad_orient={r['bad_orient']} degenerate={r['degenerate']} "
              f"bbox={bb} mm volume={r['volume']:.3f} mm^3")
    return 0 if ok else 1


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1:]))
