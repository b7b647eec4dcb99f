//! Sweeps of a planar profile along a polyline into a closed tube: the paper's FDM bead
//! tubes (seed 004), and any other profile swept along a path (a bead, a wire, a tool
//! path's envelope drawn for inspection).

use crate::math::{Point3, Vector3};

/// How [`sweep_profile`] joins segments and closes loops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepOptions {
    /// A path whose last point lies within this distance of its first (and that has at
    /// least four points) is a closed ring: its tube has no end caps.
    pub loop_tolerance: f64,
    /// At a joint the profile is widened by `1 / cos(half the turn)` to keep the tube's
    /// width (a mitre), at most by this factor (`>= 1`).
    pub miter_limit: f64,
}

impl Default for SweepOptions {
    /// A loop tolerance of 1e-3 and a mitre limit of 4.
    fn default() -> Self {
        Self { loop_tolerance: 1e-3, miter_limit: 4.0 }
    }
}

/// Sweeps a closed profile along `points` into one closed tube, appended to `vertices` and
/// `triangles` (indices offset by the vertices already there).
///
/// The profile of each path point is what `profile(prev, next, ring)` writes into `ring`
/// (emptied before each call): a polygon counter-clockwise in `(u, v)` where `v` is world +Z and `u` the horizontal
/// normal of the path, with the path point at the origin; `prev` and `next` are the indices
/// of the segments before and after the point (`None` at an open path's ends). Every ring
/// must have the same number of points, at least three (a path whose rings have fewer
/// adds nothing). A ring at a joint is mitred ([`SweepOptions::
/// miter_limit`]); a closed path ([`SweepOptions::loop_tolerance`]) drops its repeated last
/// point and gets no end caps; an open one gets fan caps at both ends. A path of fewer than
/// two points adds nothing.
pub fn sweep_profile(
    points: &[Point3],
    opts: &SweepOptions,
    mut profile: impl FnMut(Option<usize>, Option<usize>, &mut Vec<[f64; 2]>),
    vertices: &mut Vec<Point3>,
    triangles: &mut Vec<[u32; 3]>,
) {
    let n = points.len();
    if n < 2 {
        return;
    }
    let closed = n >= 4 && (points[n - 1] - points[0]).norm() <= opts.loop_tolerance;
    // Ring vertices: the path points (a closed ring drops its repeated last point).
    let m_pts = if closed { n - 1 } else { n };
    let seg = |i: usize| -> usize { if closed { i % (n - 1) } else { i } };
    let up = Vector3::z();
    let normal_of = |s: usize| -> Vector3 {
        let t = points[s + 1] - points[s];
        let nrm = up.cross(&t);
        if nrm.norm() > 1e-12 * t.norm().max(1e-300) { nrm.normalize() } else { Vector3::y() }
    };
    let nseg = n - 1;
    let mut ring = Vec::new();
    let base = vertices.len() as u32;
    let mut ring_len = 0;
    for (i, p) in points.iter().enumerate().take(m_pts) {
        let (prev, next) = if closed {
            (Some((i + nseg - 1) % nseg), Some(i % nseg))
        } else {
            (i.checked_sub(1), if i < nseg { Some(i) } else { None })
        };
        let (nrm, scale) = match (prev, next) {
            (Some(a), Some(b)) => {
                let (na, nb) = (normal_of(seg(a)), normal_of(seg(b)));
                let s = na + nb;
                if s.norm() < 1e-9 {
                    (nb, 1.0)
                } else {
                    let m = s.normalize();
                    let c = m.dot(&nb).max(1.0 / opts.miter_limit);
                    (m, 1.0 / c)
                }
            }
            (Some(a), None) => (normal_of(a), 1.0),
            (None, Some(b)) => (normal_of(b), 1.0),
            (None, None) => return,
        };
        ring.clear();
        profile(prev, next, &mut ring);
        ring_len = ring.len();
        for &[u, v] in &ring {
            vertices.push(p + nrm * (u * scale) + up * v);
        }
    }
    if ring_len < 3 {
        vertices.truncate(base as usize);
        return;
    }
    let k = ring_len as u32;
    let rings = m_pts as u32;
    let links = if closed { rings } else { rings - 1 };
    for r in 0..links {
        let a0 = base + r * k;
        let b0 = base + ((r + 1) % rings) * k;
        for j in 0..k {
            let j1 = (j + 1) % k;
            triangles.push([a0 + j, a0 + j1, b0 + j1]);
            triangles.push([a0 + j, b0 + j1, b0 + j]);
        }
    }
    if !closed {
        let s0 = base;
        let e0 = base + (rings - 1) * k;
        for j in 1..k - 1 {
            triangles.push([s0, s0 + j + 1, s0 + j]);
            triangles.push([e0, e0 + j, e0 + j + 1]);
        }
    }
}
