//! The paper's contour method, kept as a named baseline for comparison (seed 000 §3.3.1,
//! Eqs. 5-6): grid points of a layer whose signed distance to the shape is within `eps`
//! of the tool radius, ordered by repeated nearest neighbour from a start point.

use s2g_geom::{Point3, SignedDistance};

use crate::region::Point2;

/// Eq. (5) of the Shape2Gcode paper on a `grid`-spaced lattice over `[min, max]` at height
/// `z`, ordered by nearest neighbour from `start` (Eq. 6 visits them in this order).
/// Quadratic in the number of band points, as in the paper.
// One argument per quantity of the paper's Eqs. (5)-(6), kept flat for the comparison.
#[allow(clippy::too_many_arguments)]
pub fn paper_contour(
    sdf: &dyn SignedDistance,
    z: f64,
    min: Point2,
    max: Point2,
    grid: f64,
    radius: f64,
    eps: f64,
    start: Point2,
) -> Vec<Point2> {
    if !(grid > 0.0) || !grid.is_finite() {
        return Vec::new();
    }
    let nx = ((max.x - min.x) / grid).floor().max(0.0) as usize + 1;
    let ny = ((max.y - min.y) / grid).floor().max(0.0) as usize + 1;
    let mut band = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let p = Point2::new(min.x + i as f64 * grid, min.y + j as f64 * grid);
            if (sdf.distance(&Point3::new(p.x, p.y, z)) - radius).abs() < eps {
                band.push(p);
            }
        }
    }
    let mut out = Vec::with_capacity(band.len());
    let mut cur = start;
    while !band.is_empty() {
        let i = crate::region::nearest_index(&band, &cur);
        cur = band.swap_remove(i);
        out.push(cur);
    }
    out
}
