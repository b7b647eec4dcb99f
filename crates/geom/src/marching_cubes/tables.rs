//! The marching-cubes case table, generated once at first use rather than typed in.
//!
//! Corner `c` of a cell sits at `(c & 1, (c >> 1) & 1, (c >> 2) & 1)`; a case index has bit
//! `c` set when corner `c` is inside (value below the iso level). Edges `0..4` run along x at
//! `(dy, dz) = (0,0), (1,0), (0,1), (1,1)`, edges `4..8` along y at `(dx, dz)` in the same
//! order and edges `8..12` along z at `(dx, dy)`.
//!
//! The generator traces the polygon where the surface meets the cube's boundary: on each
//! face, every boundary crossing that leaves the inside region (walking the face
//! counter-clockwise seen from outside the cube) is joined to the crossing that entered it.
//! On an ambiguous face (two diagonal inside corners) this always separates the inside
//! corners. The rule depends on the face's four signs only, so the two cells sharing a face
//! always draw the same segments there, and the surface is watertight across cells. Each loop
//! is then triangulated without any diagonal between two points on one face (such a diagonal
//! could also be drawn by the neighbouring cell, making an edge with four triangles, and a
//! triangle with all corners on one face would be flat). Such a triangulation exists for
//! every loop of every case (a unit test checks it); among them the one with the shortest
//! total diagonal length (at edge midpoints) is kept.

use std::sync::LazyLock;

/// Number of cell edges.
pub(crate) const EDGES: usize = 12;

/// The two corners each edge joins (lower corner first).
pub(crate) const EDGE_CORNERS: [[u8; 2]; EDGES] =
    [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];

/// Marching-cubes tables for all 256 cases.
pub(crate) struct Table {
    /// `tris[offsets[c]..offsets[c + 1]]` are the triangles of case `c`.
    pub offsets: [u16; 257],
    /// Triangle corners, as edges `0..12`.
    pub tris: Vec<[u8; 3]>,
    /// Bit mask of the edges the surface crosses, per case.
    pub edge_mask: [u16; 256],
    /// Loops for which no triangulation avoided a diagonal within one face (none: tested).
    #[cfg_attr(not(test), allow(dead_code))] // Only the unit test reads it.
    pub fallback_loops: usize,
}

/// The table, built on first use.
pub(crate) static TABLE: LazyLock<Table> = LazyLock::new(build);

fn corner_pos(c: u8) -> [f64; 3] {
    [(c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64]
}

fn edge_of(a: u8, b: u8) -> usize {
    let (a, b) = (a.min(b), a.max(b));
    EDGE_CORNERS.iter().position(|&e| e == [a, b]).expect("corners of a cube edge")
}

/// The six faces, each as four corners counter-clockwise seen from outside the cube.
fn faces() -> [[u8; 4]; 6] {
    let mut out = [[0u8; 4]; 6];
    for axis in 0..3 {
        for side in 0..2u8 {
            // Tangent axes (u, v) with u x v along +axis; reversed on the low side so the
            // order is counter-clockwise seen from outside.
            let (mut u, mut v) = ((axis + 1) % 3, (axis + 2) % 3);
            if side == 0 {
                std::mem::swap(&mut u, &mut v);
            }
            let at = |du: u8, dv: u8| -> u8 { (side << axis) | (du << u) | (dv << v) };
            out[axis * 2 + side as usize] = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)];
        }
    }
    out
}

fn build() -> Table {
    let faces = faces();
    // The faces each edge lies on.
    let mut edge_faces = [[0usize; 2]; EDGES];
    let mut seen = [0usize; EDGES];
    for (f, face) in faces.iter().enumerate() {
        for s in 0..4 {
            let e = edge_of(face[s], face[(s + 1) % 4]);
            edge_faces[e][seen[e]] = f;
            seen[e] += 1;
        }
    }
    let share_face = |a: usize, b: usize| edge_faces[a].iter().any(|f| edge_faces[b].contains(f));
    let mid = |e: usize| {
        let [a, b] = EDGE_CORNERS[e].map(corner_pos);
        [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, (a[2] + b[2]) / 2.0]
    };
    let dist = |a: usize, b: usize| {
        let (p, q) = (mid(a), mid(b));
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    };

    let mut offsets = [0u16; 257];
    let mut edge_mask = [0u16; 256];
    let mut tris: Vec<[u8; 3]> = Vec::new();
    let mut fallback_loops = 0;
    for case in 0..256usize {
        let inside = |c: u8| case >> c & 1 == 1;
        // next[e]: the crossing the surface's boundary loop visits after e.
        let mut next = [usize::MAX; EDGES];
        for face in &faces {
            // Crossings in counter-clockwise order, each marked as leaving the inside or not.
            let mut cross: Vec<(usize, bool)> = Vec::new();
            for s in 0..4 {
                let (a, b) = (face[s], face[(s + 1) % 4]);
                if inside(a) != inside(b) {
                    cross.push((edge_of(a, b), inside(a)));
                }
            }
            let n = cross.len();
            for k in 0..n {
                let (e, exits) = cross[k];
                if exits {
                    // Join to the entry just before, which bounds the same inside arc.
                    let (prev, _) = cross[(k + n - 1) % n];
                    next[e] = prev;
                }
            }
        }
        for (e, &nx) in next.iter().enumerate() {
            if nx != usize::MAX {
                edge_mask[case] |= 1 << e;
            }
        }
        // Follow the loops.
        let mut done = [false; EDGES];
        for start in 0..EDGES {
            if next[start] == usize::MAX || done[start] {
                continue;
            }
            let mut poly = Vec::new();
            let mut e = start;
            while !done[e] {
                done[e] = true;
                poly.push(e);
                e = next[e];
            }
            // The loop bounds the inside patch of the cube's surface counter-clockwise seen
            // from outside; the cap closing the inside piece must run the other way.
            poly.reverse();
            let t = triangulate(&poly, &share_face, &dist).unwrap_or_else(|| {
                fallback_loops += 1;
                (1..poly.len() - 1).map(|k| [poly[0], poly[k], poly[k + 1]]).collect()
            });
            tris.extend(t.iter().map(|&[a, b, c]| [a as u8, b as u8, c as u8]));
        }
        offsets[case + 1] = tris.len() as u16;
    }
    Table { offsets, tris, edge_mask, fallback_loops }
}

/// Minimum-total-diagonal-length triangulation of a polygon without forbidden diagonals;
/// `None` when every triangulation needs one.
#[allow(clippy::needless_range_loop)] // The interval DP reads clearer with explicit indices.
fn triangulate(
    poly: &[usize],
    forbidden: &impl Fn(usize, usize) -> bool,
    length: &impl Fn(usize, usize) -> f64,
) -> Option<Vec<[usize; 3]>> {
    let n = poly.len();
    if n == 3 {
        return Some(vec![[poly[0], poly[1], poly[2]]]);
    }
    let side = |i: usize, j: usize| j == i + 1 || (i == 0 && j == n - 1);
    let weight = |i: usize, j: usize| {
        if side(i, j) {
            0.0
        } else if forbidden(poly[i], poly[j]) {
            f64::INFINITY
        } else {
            length(poly[i], poly[j])
        }
    };
    // cost[i][j]: best triangulation of the sub-polygon i..=j (closed by the chord i-j).
    let mut cost = vec![vec![0.0f64; n]; n];
    let mut split = vec![vec![0usize; n]; n];
    for gap in 2..n {
        for i in 0..n - gap {
            let j = i + gap;
            let mut best = f64::INFINITY;
            for k in i + 1..j {
                let c = cost[i][k] + cost[k][j] + weight(i, k) + weight(k, j);
                if c < best {
                    best = c;
                    split[i][j] = k;
                }
            }
            cost[i][j] = best;
        }
    }
    if !cost[0][n - 1].is_finite() {
        return None;
    }
    let mut out = Vec::new();
    let mut stack = vec![(0, n - 1)];
    while let Some((i, j)) = stack.pop() {
        if j < i + 2 {
            continue;
        }
        let k = split[i][j];
        out.push([poly[i], poly[k], poly[j]]);
        stack.push((i, k));
        stack.push((k, j));
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_crossing_edge_is_used_and_counts_are_sane() {
        let t = &*TABLE;
        assert_eq!(t.offsets[1] - t.offsets[0], 0);
        assert_eq!(t.offsets[256] - t.offsets[255], 0);
        assert_eq!(t.fallback_loops, 0, "loops without a face-diagonal-free triangulation");
        for case in 0..256 {
            let mut used = 0u16;
            for tri in &t.tris[t.offsets[case] as usize..t.offsets[case + 1] as usize] {
                for &v in tri {
                    used |= 1 << v;
                }
            }
            let expect = (0..12).filter(|&e| {
                let [a, b] = EDGE_CORNERS[e];
                (case >> a & 1) != (case >> b & 1)
            });
            let expect = expect.fold(0u16, |m, e| m | 1 << e);
            assert_eq!(t.edge_mask[case], expect, "case {case}");
            // Every crossing lies on some triangle.
            assert_eq!(used, expect, "case {case}");
        }
    }
}
