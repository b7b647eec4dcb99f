//! Finishing only where it is for (issue 36): a flat end mill's roughing cut to size leaves
//! a prismatic face exact (a flat floor at its height, a wall along the tool's flank), and
//! a ball finishing it buys nothing, or worse, rounds the inner corners the flat end mill
//! cut square. Per setup, before it is planned, the part's facets the setup's tool can
//! face (upward or vertical in its frame, above the finisher's floor) are sorted into
//! prismatic and sculpted ([`finish_scope`]):
//!
//! - none sculpted: the setup is roughed to size (no allowance) and not finished;
//! - at most half the area sculpted: roughed to size, and the finisher machines only the
//!   pass points where its ball touches a sculpted face ([`FinishScope::Sculpted`],
//!   [`sculpted_contact`]);
//! - more: roughed with the allowance and finished whole, as before ([`FinishScope::All`]).

use super::job::Job;
use crate::geom::{Mesh, MeshIndex, Point3, Setup, Vector3};

/// Within this angle (degrees) of the tool axis, or of square to it, a face is prismatic.
/// A flat end mill stepping down a wall leaning `a` off the axis on layers `h` apart
/// leaves steps `h tan a` wide: 2 mm layers, 0.1 degrees, 3.5 um, below any scallop
/// target the finisher is given.
const PRISMATIC_TOL_DEG: f64 = 0.1;

/// Where a setup's finisher machines ([`FinishJob::scope`](super::job::FinishJob)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum FinishScope {
    /// Every point its strategy gives (the roughing leaves the allowance).
    All,
    /// Only where its ball touches a sculpted face (the roughing cut to size).
    Sculpted,
}

/// Whether a face of unit normal `n` (setup frame) is prismatic: facing along the tool
/// axis or square to it, within [`PRISMATIC_TOL_DEG`].
pub(super) fn prismatic_normal(n: &Vector3) -> bool {
    let (s, c) = PRISMATIC_TOL_DEG.to_radians().sin_cos();
    n.z >= c || n.z.abs() < s
}

/// The sculpted and the whole area (mm^2) of `part`'s facets that a tool along `setup`'s
/// axis can face: upward or vertical in its frame, reaching above `floor` (setup frame).
pub(super) fn reached_areas(part: &Mesh, setup: &Setup, floor: f64) -> (f64, f64) {
    let s = PRISMATIC_TOL_DEG.to_radians().sin();
    part.triangle_points().fold((0.0, 0.0), |(sculpted, all), t| {
        let [a, b, c] = t.map(|p| setup.to_setup(&p));
        let cross = (b - a).cross(&(c - a));
        let norm = cross.norm();
        if !(norm > 0.0) || a.z.max(b.z).max(c.z) < floor {
            return (sculpted, all);
        }
        let n = cross / norm;
        if n.z <= -s {
            return (sculpted, all);
        }
        let area = 0.5 * norm;
        (if prismatic_normal(&n) { sculpted } else { sculpted + area }, all + area)
    })
}

/// Where setup `job` is finished over `part` (part frame): `None` where every face its
/// tool reaches is prismatic (nothing for a ball to do), else [`FinishScope::Sculpted`]
/// where at most half of that area is sculpted, [`FinishScope::All`] otherwise.
pub(super) fn finish_scope(part: &Mesh, job: &Job) -> Option<FinishScope> {
    let f = job.finish.as_ref()?;
    let zs = part.vertices().iter().map(|v| job.setup.to_setup(v).z);
    let (lo, hi) = zs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), z| (a.min(z), b.max(z)));
    let floor = job.finish_options(f, [lo, hi]).floor.unwrap_or(lo);
    let (sculpted, all) = reached_areas(part, &job.setup, floor);
    if !(sculpted > 1e-6 * all) {
        None
    } else if sculpted <= 0.5 * all {
        Some(FinishScope::Sculpted)
    } else {
        Some(FinishScope::All)
    }
}

/// Decides `job`'s finishing over `part` ([`finish_scope`]): drops it where the setup has
/// nothing sculpted, and roughs to size (no allowance) where the finisher machines only
/// the sculpted faces or none.
pub(super) fn scope_finishing(job: &mut Job, part: &Mesh) {
    if job.finish.is_none() {
        return;
    }
    let scope = finish_scope(part, job);
    match scope {
        Some(FinishScope::All) => return,
        Some(s) => {
            if let Some(f) = &mut job.finish {
                f.scope = s;
            }
        }
        None => job.finish = None,
    }
    job.popts.finishing_allowance = 0.0;
    job.popts.axial_allowance = 0.0;
}

/// Whether the ball of radius `radius` with its tip at `tip` touches `part` (setup frame)
/// on a sculpted face: the direction from the part's closest point to its centre is the
/// surface's normal there. A centre on the surface or an empty part counts as sculpted.
pub(super) fn sculpted_contact(part: &MeshIndex, tip: &Point3, radius: f64) -> bool {
    let c = Point3::new(tip.x, tip.y, tip.z + radius);
    let cp = part.closest_point(&c);
    if !(cp.distance > 1e-9) {
        return true;
    }
    !prismatic_normal(&((c - cp.point) / cp.distance))
}

/// The largest share of `part`'s area that is prismatic along one of the frame's axes
/// (facing along it or square to it, [`prismatic_normal`]). Where it is at least half,
/// the roughing, cut to size, makes most of the part and the finisher only the sculpted
/// rest: the setups are chosen for the roughing tools' reach (as without finishing), not
/// the shorter ball's (`MillRun::new`).
pub(super) fn prismatic_share(part: &Mesh) -> f64 {
    let mut areas = [0.0; 3];
    let mut all = 0.0;
    for t in part.triangle_points() {
        let [a, b, c] = t;
        let cross = (b - a).cross(&(c - a));
        let norm = cross.norm();
        if !(norm > 0.0) {
            continue;
        }
        all += 0.5 * norm;
        let n = cross / norm;
        for (k, area) in areas.iter_mut().enumerate() {
            let along = Vector3::new(n[(k + 1) % 3], n[(k + 2) % 3], n[k].abs());
            if prismatic_normal(&along) {
                *area += 0.5 * norm;
            }
        }
    }
    if all > 0.0 { areas.iter().fold(0.0f64, |m, a| m.max(a / all)) } else { 0.0 }
}

/// Whether a setup along `setup`'s axis has any sculpted face over `part` (no floor):
/// where it has none, the policy chooses its roughing as without finishing.
pub(super) fn has_sculpted(part: &Mesh, setup: &Setup) -> bool {
    let (sculpted, all) = reached_areas(part, setup, f64::NEG_INFINITY);
    sculpted > 1e-6 * all
}
