//! Floor levels (issue 35): the lowest height a flat tool reaches in each region a level
//! leaves it, where that lies between the regular levels.
//!
//! At a level `z` the tool's tip goes where the cutter-location height `h(x, y)` (the
//! drop-cutter height of a flat disc of the keep-out's growth) is at most `z`; the free
//! region's connected parts are the level's regions. A region whose lowest `h` lies above
//! the next level down is not entered by that level at all (a V groove narrower there than
//! the tool), and the material between the level and that lowest height stays: a floor
//! level goes there, one per such region.

use rayon::prelude::*;
use s2g_geom::{Aabb, Cutter, DropCutter, Mesh, MeshIndex, Point3};

/// A floor level sits this fraction of the growth above the lowest sampled height, so that
/// the region it opens is not a line.
const FLOOR_LIFT: f64 = 0.05;

/// At most this many samples along an axis of the stock.
const MAX_SAMPLES: usize = 512;

/// The cutter-location heights of a flat disc of radius `grow` over the part's triangles
/// `tris` (setup frame), sampled on a grid over the part's XY footprint inset by `grow`
/// (where the disc lies over the part: past its ends a groove's flat tool reaches the
/// groove's bottom edge, which says nothing of the groove): `(heights, nx, ny)`, row by
/// row, `-inf` where nothing stops the disc. `None` where the footprint is narrower than
/// the disc or the part is not a valid mesh.
fn heights(tris: &[[Point3; 3]], grow: f64) -> Option<(Vec<f64>, usize, usize)> {
    let part = Aabb::from_points(tris.iter().flatten())?;
    let (lo, hi) = ([part.min.x + grow, part.min.y + grow], [part.max.x - grow, part.max.y - grow]);
    let e = [hi[0] - lo[0], hi[1] - lo[1]];
    if !(e[0] >= 0.0 && e[1] >= 0.0 && grow > 0.0) {
        return None;
    }
    let mesh = Mesh::from_soup(tris).ok()?;
    let index = MeshIndex::new(&mesh).ok()?;
    let drop = DropCutter::new(&index, &Cutter::flat(grow, 1.0)).ok()?;
    let step = (grow / 4.0).max(e[0].max(e[1]) / MAX_SAMPLES as f64);
    let (nx, ny) = ((e[0] / step).ceil() as usize + 1, (e[1] / step).ceil() as usize + 1);
    let h = (0..nx * ny)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % nx, k / nx);
            let (x, y) = (lo[0] + (i as f64 * step).min(e[0]), lo[1] + (j as f64 * step).min(e[1]));
            drop.height(x, y).unwrap_or(f64::NEG_INFINITY)
        })
        .collect();
    Some((h, nx, ny))
}

/// The lowest height of each connected region (4-neighbours) of the samples below `z`.
fn region_floors(h: &[f64], nx: usize, ny: usize, z: f64) -> Vec<f64> {
    let mut seen = vec![false; h.len()];
    let mut floors = Vec::new();
    let mut stack = Vec::new();
    for start in 0..h.len() {
        if seen[start] || !(h[start] < z) {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        let mut low = h[start];
        while let Some(k) = stack.pop() {
            low = low.min(h[k]);
            let (i, j) = (k % nx, k / nx);
            let next = [
                (i > 0).then(|| k - 1),
                (i + 1 < nx).then_some(k + 1),
                (j > 0).then(|| k - nx),
                (j + 1 < ny).then_some(k + nx),
            ];
            for n in next.into_iter().flatten() {
                if !seen[n] && h[n] < z {
                    seen[n] = true;
                    stack.push(n);
                }
            }
        }
        floors.push(low);
    }
    floors
}

/// The floor levels of `levels` (descending, below `top`, the last at the bottom): for
/// each level (and `top`, the stock's) and each region of its free area that the next level
/// down does not enter, the region's lowest cutter-location height (`grow` the keep-out's
/// growth, `lift` the axial allowance, which the tip keeps above every face), lifted by
/// [`FLOOR_LIFT`] of `grow`, where that lies more than `tol` from the levels either side.
/// Floors closer than `merge` merge into the highest of them. Descending.
pub(crate) fn floor_levels(
    tris: &[[Point3; 3]],
    top: f64,
    levels: &[f64],
    grow: f64,
    lift: f64,
    tol: f64,
    merge: f64,
) -> Vec<f64> {
    let Some((h, nx, ny)) = heights(tris, grow) else {
        return Vec::new();
    };
    let h: Vec<f64> = h.iter().map(|v| v + lift).collect();
    let mut out: Vec<f64> = Vec::new();
    let above = std::iter::once(top).chain(levels.iter().copied());
    for (z, below) in above.zip(levels.iter().copied()) {
        for f in region_floors(&h, nx, ny, z - tol) {
            let level = f + FLOOR_LIFT * grow;
            if f > below + tol && level < z - tol {
                out.push(level);
            }
        }
    }
    out.sort_by(|a, b| b.total_cmp(a));
    let mut merged: Vec<f64> = Vec::new();
    for f in out {
        if merged.last().is_none_or(|&m| m - f > merge) {
            merged.push(f);
        }
    }
    merged
}

/// `levels` (descending) with `floors` (descending) among them, none closer than `tol`
/// to a level it joins.
pub(crate) fn with_floors(levels: &[f64], floors: &[f64], tol: f64) -> Vec<f64> {
    let mut out: Vec<f64> = levels.to_vec();
    for &f in floors {
        if out.iter().all(|&l| (l - f).abs() > tol) {
            out.push(f);
        }
    }
    out.sort_by(|a, b| b.total_cmp(a));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sides of a 40 x 20 mm block 12 mm tall (z up) with a groove along y, 2.2 mm wide
    /// from z 12 down to z 11, ending in a V down to z 10 at x = 20 (no end caps: the
    /// drop-cutter asks only for triangles).
    fn grooved() -> Vec<[Point3; 3]> {
        let profile = [
            [0., 0.],
            [40., 0.],
            [40., 12.],
            [21.1, 12.],
            [21.1, 11.],
            [20., 10.],
            [18.9, 11.],
            [18.9, 12.],
            [0., 12.],
        ];
        let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
        let mut soup = Vec::new();
        let n = profile.len();
        for k in 0..n {
            let (a, b) = (profile[k], profile[(k + 1) % n]);
            // Side quads: profile (x, z) swept along y from 0 to 20.
            soup.push([p(a[0], 0., a[1]), p(b[0], 0., b[1]), p(b[0], 20., b[1])]);
            soup.push([p(a[0], 0., a[1]), p(b[0], 20., b[1]), p(a[0], 20., a[1])]);
        }
        soup
    }

    #[test]
    fn a_floor_goes_where_a_v_groove_is_as_wide_as_the_tool() {
        let tris = grooved();
        let stock = 13.0;
        // Levels 1 mm apart from the top face: the one at 11 enters the groove, the one at
        // 10 does not (the V is 2 mm wide at z = 11 - 0.1 / 1.1).
        let levels: Vec<f64> = (0..13).map(|k| 12.0 - k as f64).collect();
        let floors = floor_levels(&tris, stock, &levels, 1.0, 0.0, 1e-7, 0.05);
        assert_eq!(floors.len(), 1, "{floors:?}");
        let reach = 11.0 - 0.2 / 2.2;
        assert!(floors[0] >= reach - 1e-9 && floors[0] < reach + 0.2, "{floors:?}, reach {reach}");
        let all = with_floors(&levels, &floors, 1e-7);
        assert_eq!(all.len(), levels.len() + 1);
        assert!(all.windows(2).all(|w| w[0] > w[1]));
        // With the axial allowance the floor rises by as much.
        let lifted = floor_levels(&tris, stock, &levels, 1.0, 0.3, 1e-7, 0.05);
        assert!(lifted.len() == 1 && (lifted[0] - floors[0] - 0.3).abs() < 1e-9, "{lifted:?}");
        // A tool wider than the groove enters it at no level: no floor.
        assert!(floor_levels(&tris, stock, &levels, 1.2, 0.0, 1e-7, 0.05).is_empty());
        // Nor where a regular level already lies below the reachable floor.
        let deeper = with_floors(&levels, &[10.95], 1e-7);
        assert!(floor_levels(&tris, stock, &deeper, 1.0, 0.0, 1e-7, 0.05).is_empty());
    }
}
