//! The support a planar slicer would need for a part standing on the platform: under every
//! facet whose overhang angle `asin(-n_z)` exceeds the self-supporting angle `α` (a
//! downward-facing facet steeper than `α` off vertical, as the support-free loss counts
//! it), a column down to the part below it or the platform.
//!
//! Measured on vertical lines through the centres of a square grid of cells `spacing`
//! wide (offset by an irrational fraction of a cell, so that lines miss the mesh's edges
//! and vertices): along each line the facets it crosses, in height order, alternate
//! between entering the part (downward-facing) and leaving it. Where it enters through a
//! facet that needs support, the gap from the last exit below it (or the platform) up to
//! that facet is support. The volume is the gaps' length summed over the lines, times a
//! cell's area.

use s2g_geom::{Mesh, Point3};

use crate::error::{FieldError, Result};

/// What a planar slicer would need under `mesh` standing on `z = platform` with the
/// self-supporting angle `max_overhang_deg`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarSupport {
    /// Support volume, in the part's units cubed.
    pub volume: f64,
    /// Projected area (on the platform) of the part's underside that needs support.
    pub area: f64,
}

/// A crossing of a vertical line with a facet: its height and whether the facet faces
/// down (the line enters the part there), and whether it needs support.
#[derive(Debug, Clone, Copy)]
struct Crossing {
    z: f64,
    down: bool,
    needs: bool,
}

/// The planar support of `mesh` (module docs), measured on a grid of `spacing`.
///
/// Errors: [`FieldError::InvalidArgument`] for a spacing that is not finite and `> 0`,
/// an angle outside `[0, 90)` degrees, or more than `4·10⁶` grid cells;
/// [`FieldError::EmptyMesh`].
pub fn planar_support(
    mesh: &Mesh,
    max_overhang_deg: f64,
    platform: f64,
    spacing: f64,
) -> Result<PlanarSupport> {
    if !(spacing.is_finite() && spacing > 0.0 && (0.0..90.0).contains(&max_overhang_deg)) {
        return Err(FieldError::InvalidArgument(
            "planar support: spacing must be > 0 and the angle in [0, 90)".into(),
        ));
    }
    let bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
    let nx = ((bbox.max.x - bbox.min.x) / spacing).ceil() as usize + 1;
    let ny = ((bbox.max.y - bbox.min.y) / spacing).ceil() as usize + 1;
    if nx.saturating_mul(ny) > 4_000_000 {
        return Err(FieldError::InvalidArgument(format!("planar support: {nx} x {ny} cells (> 4e6)")));
    }
    // Cell (i, j)'s line is at origin + (i, j) spacing.
    let shift = 0.5 + 1e-3 * std::f64::consts::FRAC_1_SQRT_2;
    let origin = [bbox.min.x - shift * spacing, bbox.min.y - (shift + 1.3e-4) * spacing];
    let sin = max_overhang_deg.to_radians().sin();
    let mut columns: Vec<Vec<Crossing>> = vec![Vec::new(); nx * ny];
    let vs = mesh.vertices();
    for tri in mesh.triangles() {
        let [a, b, c] = tri.map(|i| vs[i as usize]);
        let normal = (b - a).cross(&(c - a));
        let Some(n) = normal.try_normalize(1e-300) else { continue };
        if normal.z == 0.0 {
            continue;
        }
        let needs = -n.z > sin;
        let range = |lo: f64, hi: f64, o: f64, len: usize| {
            let first = ((lo - o) / spacing).ceil().max(0.0) as usize;
            let last = (((hi - o) / spacing).floor().max(-1.0) + 1.0) as usize;
            first..last.min(len)
        };
        let (xlo, xhi) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
        let (ylo, yhi) = (a.y.min(b.y).min(c.y), a.y.max(b.y).max(c.y));
        for j in range(ylo, yhi, origin[1], ny) {
            for i in range(xlo, xhi, origin[0], nx) {
                let (x, y) = (origin[0] + i as f64 * spacing, origin[1] + j as f64 * spacing);
                if let Some(z) = crossing(&a, &b, &c, x, y) {
                    columns[j * nx + i].push(Crossing { z, down: normal.z < 0.0, needs });
                }
            }
        }
    }
    let (mut length, mut cells) = (0.0, 0usize);
    for column in &mut columns {
        column.sort_by(|p, q| p.z.total_cmp(&q.z));
        let mut floor = platform;
        let mut depth = 0i32;
        for x in column.iter() {
            if x.down {
                let gap = x.z - floor;
                if depth == 0 && x.needs && gap > 1e-9 {
                    length += gap;
                    cells += 1;
                }
                depth += 1;
            } else {
                depth = (depth - 1).max(0);
                if depth == 0 {
                    floor = x.z;
                }
            }
        }
    }
    let area = spacing * spacing;
    Ok(PlanarSupport { volume: length * area, area: cells as f64 * area })
}

/// The height where the vertical line through `(x, y)` crosses the triangle `abc`, if it
/// does (a degenerate projection never).
fn crossing(a: &Point3, b: &Point3, c: &Point3, x: f64, y: f64) -> Option<f64> {
    let d = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
    if d == 0.0 {
        return None;
    }
    let u = ((x - a.x) * (c.y - a.y) - (c.x - a.x) * (y - a.y)) / d;
    let v = ((b.x - a.x) * (y - a.y) - (x - a.x) * (b.y - a.y)) / d;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0).then(|| a.z + u * (b.z - a.z) + v * (c.z - a.z))
}
