//! Finishing only where it is for (issue 36): a flat end mill's roughing cut to size leaves
//! a prismatic face exact (a flat floor at its height, a wall along the tool's flank), and
//! a ball finishing it buys nothing, or worse, rounds the inner corners the flat end mill
//! cut square. Per setup, before it is planned, the part's facets the setup's tool can
//! face (upward or vertical in its frame, above the finisher's floor) are sorted into
//! prismatic and sculpted ([`finish_scope`]):
//!
//! - none sculpted: the setup is roughed to size (no allowance) and not finished;
//! - at most half the area sculpted: roughed to size on the layers of a run without
//!   finishing ([`finished_whole`]), and the finisher machines only the pass points where
//!   its ball touches a sculpted face ([`FinishScope::Sculpted`],
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
        if norm.is_nan() || norm <= 0.0 || a.z.max(b.z).max(c.z) < floor {
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
    if sculpted.is_nan() || sculpted <= 1e-6 * all {
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
    if cp.distance.is_nan() || cp.distance <= 1e-9 {
        return true;
    }
    !prismatic_normal(&((c - cp.point) / cp.distance))
}

/// The largest share of `part`'s area that is prismatic along one of the frame's axes
/// (facing along it or square to it, [`prismatic_normal`]). Where it is at least
/// [`PRISMATIC_PART`](super::setup_choice::PRISMATIC_PART), the roughing, cut to size,
/// makes most of the part and the finisher only the sculpted rest: the setups are chosen
/// for the roughing tools' reach (as without finishing); below, the set chosen for the
/// shorter ball's reach is compared with it ([`choose_setups`](super::setup_choice::choose_setups)).
pub(super) fn prismatic_share(part: &Mesh) -> f64 {
    let mut areas = [0.0; 3];
    let mut all = 0.0;
    for t in part.triangle_points() {
        let [a, b, c] = t;
        let cross = (b - a).cross(&(c - a));
        let norm = cross.norm();
        if norm.is_nan() || norm <= 0.0 {
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

/// Whether a setup along `setup`'s axis is finished whole over `part` (more than half the
/// area its tool faces sculpted, no floor; [`finish_scope`]'s [`FinishScope::All`]): only
/// there does the roughing leave its staircase to the finisher, and the policy choose its
/// layers for that. A setup with no sculpted face, or at most half, is roughed to size as
/// without finishing, on the same layers: where the ball does not reach (between embossed
/// letters, under an overhang) deeper layers would leave taller steps than roughing alone.
pub(super) fn finished_whole(part: &Mesh, setup: Option<&Setup>) -> bool {
    setup.is_some_and(|setup| {
        let (sculpted, all) = reached_areas(part, setup, f64::NEG_INFINITY);
        sculpted > 0.5 * all
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Aabb, Similarity3};

    /// A 40 x 20 x 10 mm block; with `chamfer`, its top +x edge cut back 5 mm in X (a
    /// sloped face from x = 35 at the top to x = 40 at the bottom).
    fn block(chamfer: bool) -> Mesh {
        let b = Mesh::cuboid(&Aabb::new(Point3::origin(), Point3::new(40.0, 20.0, 10.0))).unwrap();
        let (mut v, t) = b.into_parts();
        if chamfer {
            v.iter_mut().filter(|p| p.x == 40.0 && p.z == 10.0).for_each(|p| p.x = 35.0);
        }
        Mesh::new(v, t).unwrap()
    }

    #[test]
    fn a_block_is_prismatic_and_a_chamfer_is_sculpted() {
        let top = Setup::top();
        let (sculpted, all) = reached_areas(&block(false), &top, f64::NEG_INFINITY);
        assert_eq!(sculpted, 0.0);
        // The top and the four walls; the bottom faces away.
        assert!((all - (800.0 + 2.0 * 400.0 + 2.0 * 200.0)).abs() < 1e-9, "{all}");
        let (sculpted, _) = reached_areas(&block(true), &top, f64::NEG_INFINITY);
        let slope = 20.0 * (5.0f64.powi(2) + 10.0f64.powi(2)).sqrt();
        assert!((sculpted - slope).abs() < 1e-9, "{sculpted} against {slope}");
        // Below the finisher's floor a face is not its to finish.
        assert_eq!(reached_areas(&block(true), &top, 10.5), (0.0, 0.0));
        assert!(!finished_whole(&block(true), Some(&top)) && !finished_whole(&block(false), Some(&top)));
    }

    #[test]
    fn the_ball_finishes_where_it_touches_a_sculpted_face_only() {
        let part = block(true);
        let index = MeshIndex::new(&part).unwrap();
        let r = 3.0;
        // Resting on the top face, and beside the -x wall (its tip below the top).
        assert!(!sculpted_contact(&index, &Point3::new(20.0, 10.0, 10.0), r));
        assert!(!sculpted_contact(&index, &Point3::new(-r, 10.0, 2.0), r));
        // Touching the chamfer, its centre a radius out along the face's normal.
        let n = Vector3::new(10.0, 0.0, 5.0).normalize();
        let q = Point3::new(37.5, 10.0, 5.0);
        let tip = q + n * r - Vector3::z() * r;
        assert!(sculpted_contact(&index, &tip, r));
    }

    #[test]
    fn the_prismatic_share_is_of_the_best_axis() {
        assert_eq!(prismatic_share(&block(false)), 1.0);
        // The chamfered block is a prism along Y.
        assert!((prismatic_share(&block(true)) - 1.0).abs() < 1e-12);
        // A cube turned off the axes keeps only two faces square to Z.
        let cube = Mesh::cuboid(&Aabb::new(Point3::origin(), Point3::new(10.0, 10.0, 10.0))).unwrap();
        let turn = crate::geom::Rotation3::from_euler_angles(0.0, 0.0, 0.5)
            * crate::geom::Rotation3::from_euler_angles(0.5, 0.0, 0.0);
        let turned = cube.transformed(&Similarity3::from_parts(Vector3::zeros().into(), turn, 1.0));
        let share = prismatic_share(&turned);
        assert!((share - 1.0 / 3.0).abs() < 1e-9, "{share}");
        // A pyramid seen from above faces only its four sloped sides: finished whole, its
        // roughing on the layers left for the ball; the turned cube's up-facing half is
        // sculpted, the rest walls: not more than half.
        let v = [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [10.0, 10.0, 0.0], [0.0, 10.0, 0.0], [5.0, 5.0, 5.0]];
        let t = vec![[0, 2, 1], [0, 3, 2], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];
        let pyramid = Mesh::new(v.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect(), t).unwrap();
        assert!(finished_whole(&pyramid, Some(&Setup::top())));
        assert!(!finished_whole(&pyramid, None) && !finished_whole(&turned, Some(&Setup::top())));
    }
}
