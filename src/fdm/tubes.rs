//! The paper's output: one closed tube per extrusion spine, the bead profile swept along it.

use super::*;

/// The profile polygon for `area`, `height`, counter-clockwise in (u, v) with v up and the
/// nozzle tip at the origin.
pub(super) fn profile_ring(
    profile: BeadShape,
    area: f64,
    height: f64,
    segments: usize,
    out: &mut Vec<[f64; 2]>,
) {
    out.clear();
    let w = profile_width(profile, area, height);
    match profile {
        BeadShape::Rect => {
            let hw = 0.5 * w;
            out.extend([[-hw, -height], [hw, -height], [hw, 0.0], [-hw, 0.0]]);
        }
        BeadShape::Slot => {
            let r = 0.5 * height;
            let c = (0.5 * w - r).max(0.0);
            let half = (segments / 2).max(2);
            for s in 0..=half {
                let t = -0.5 * PI + PI * s as f64 / half as f64;
                out.push([c + r * t.cos(), -r + r * t.sin()]);
            }
            for s in 0..=half {
                let t = 0.5 * PI + PI * s as f64 / half as f64;
                out.push([-c + r * t.cos(), -r + r * t.sin()]);
            }
        }
        BeadShape::Circle => {
            let r = 0.5 * w;
            for s in 0..segments {
                let t = -0.5 * PI + 2.0 * PI * s as f64 / segments as f64;
                out.push([r * t.cos(), -r + r * t.sin()]);
            }
        }
    }
}

/// The closed tube of one spine: `points` with per-segment `areas` and the layer `height`.
/// Appends vertices and triangles (indices offset by the current vertex count). The sweep
/// is geom's [`sweep_profile`](crate::geom::sweep_profile); a joint's profile has the mean
/// area of the segments it joins.
pub fn sweep_spine(
    points: &[Point3],
    areas: &[f64],
    height: f64,
    opts: &FdmOptions,
    vertices: &mut Vec<Point3>,
    triangles: &mut Vec<[u32; 3]>,
) {
    if points.len() < 2 || areas.len() + 1 != points.len() {
        return;
    }
    let sweep = SweepOptions { loop_tolerance: opts.loop_tolerance, miter_limit: opts.miter_limit };
    let profile = |prev: Option<usize>, next: Option<usize>, ring: &mut Vec<[f64; 2]>| {
        let area = match (prev, next) {
            (Some(a), Some(b)) => 0.5 * (areas[a] + areas[b]),
            (Some(a), None) | (None, Some(a)) => areas[a],
            (None, None) => return,
        };
        profile_ring(opts.profile, area, height, opts.circle_segments, ring);
    };
    sweep_profile(points, &sweep, profile, vertices, triangles);
}

/// One closed tube per spine (see the [module docs](self)), all in one mesh, in spine order.
/// Tubes are swept in parallel.
pub fn tube_mesh(ex: &Extrusion, opts: &FdmOptions) -> Result<Mesh, FdmError> {
    opts.validate()?;
    let mut first = Vec::with_capacity(ex.spines.len() + 1);
    let mut acc = 0usize;
    for s in &ex.spines {
        first.push(acc);
        acc += s.len() - 1;
    }
    let parts: Vec<(Vec<Point3>, Vec<[u32; 3]>)> = ex
        .spines
        .par_iter()
        .enumerate()
        .map(|(si, pts)| {
            let areas: Vec<f64> =
                ex.beads[first[si]..first[si] + pts.len() - 1].iter().map(|b| b.area).collect();
            let h = ex.beads[first[si]].height;
            let (mut v, mut t) = (Vec::new(), Vec::new());
            sweep_spine(pts, &areas, h, opts, &mut v, &mut t);
            (v, t)
        })
        .collect();
    let nv: usize = parts.iter().map(|p| p.0.len()).sum();
    let nt: usize = parts.iter().map(|p| p.1.len()).sum();
    let (mut vertices, mut triangles) = (Vec::with_capacity(nv), Vec::with_capacity(nt));
    for (v, t) in parts {
        let off = vertices.len() as u32;
        vertices.extend(v);
        triangles.extend(t.into_iter().map(|f| f.map(|i| i + off)));
    }
    Ok(Mesh::new(vertices, triangles)?)
}
