//! Bead spacing measured on the extracted paths: each path is sampled every quarter bead
//! width, and each sample's spacing is the distance to the nearest sample of another path
//! on its layer, or of its own path more than three bead widths away along it (the next
//! line of a zig-zag; around a closed path the shorter way, so that the two sides of its
//! seam are neighbours along it, not across). Samples with no neighbour within twice the bead width (a lone
//! bead in a feature one bead wide) are counted apart.

use std::collections::HashMap;

use s2g_geom::Point3;

use super::extract::PrintLayer;

/// Bead spacing against the nominal width.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpacingStats {
    /// Path length measured (samples with a neighbour).
    pub measured_length: f64,
    /// Fraction of it whose spacing is within ±25 % of the bead width.
    pub within_25: f64,
    /// Path length with no neighbour within twice the bead width.
    pub lone_length: f64,
    /// Median spacing over the bead width.
    pub median_ratio: f64,
}

/// The spacing statistics of the module docs over `layers`, for bead width `width`.
pub fn bead_spacing(layers: &[PrintLayer], width: f64) -> SpacingStats {
    let step = 0.25 * width;
    let cell = 2.0 * width;
    let key =
        |p: &Point3| [(p.x / cell).floor() as i64, (p.y / cell).floor() as i64, (p.z / cell).floor() as i64];
    let (mut measured, mut within, mut lone) = (0usize, 0usize, 0usize);
    let mut ratios = Vec::new();
    for layer in layers {
        // (path, arc length, point); the length of each closed path (0 for an open one).
        let mut samples: Vec<(usize, f64, Point3)> = Vec::new();
        let loops: Vec<f64> = layer
            .paths
            .iter()
            .map(|p| {
                let closed = p.points.len() > 3 && (p.points[0] - p.points[p.points.len() - 1]).norm() < 1e-9;
                if closed { p.length() } else { 0.0 }
            })
            .collect();
        for (pi, path) in layer.paths.iter().enumerate() {
            let mut arc = 0.0;
            let mut next = 0.0;
            for w in path.points.windows(2) {
                let len = (w[1] - w[0]).norm();
                while next <= arc + len && len > 0.0 {
                    samples.push((pi, next, w[0] + (w[1] - w[0]) * ((next - arc) / len)));
                    next += step;
                }
                arc += len;
            }
        }
        let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for (i, s) in samples.iter().enumerate() {
            grid.entry(key(&s.2)).or_default().push(i);
        }
        for (pi, arc, p) in &samples {
            let c = key(p);
            let mut best = f64::INFINITY;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                        for &j in list {
                            let (pj, aj, q) = &samples[j];
                            let along = (aj - arc).abs();
                            let around = if loops[*pi] > 0.0 { along.min(loops[*pi] - along) } else { along };
                            if pj == pi && around <= 3.0 * width {
                                continue;
                            }
                            best = best.min((q - p).norm());
                        }
                    }
                }
            }
            if best <= 2.0 * width {
                measured += 1;
                within += ((best / width - 1.0).abs() <= 0.25) as usize;
                ratios.push(best / width);
            } else {
                lone += 1;
            }
        }
    }
    ratios.sort_by(f64::total_cmp);
    SpacingStats {
        measured_length: measured as f64 * step,
        within_25: if measured == 0 { 0.0 } else { within as f64 / measured as f64 },
        lone_length: lone as f64 * step,
        median_ratio: ratios.get(ratios.len() / 2).copied().unwrap_or(0.0),
    }
}
