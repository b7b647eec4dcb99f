//! The toolpath of the five-axis program: the poses with their checked tool axes, and the
//! chain over each layer's poses (feed links, jumps, steps back along the way), written
//! through the program's [`Emitter`].

use s2g_geom::{Point3, Vector3};

use super::{
    Clearance, ContourPaths, Emitter, MillProgram, ProgramOptions, State, axis_of, gradient_step,
    tool_axis_angles,
};
use crate::error::Result;
use crate::milling::MillingProblem;
use crate::siren::SirenF64;

/// Groups `poses` into layers of `G` (top first) and mills each with a chain from where the
/// tool is, writing through `w` and counting into `out`; then leaves along the tool axis.
// The program's writer, counts, field, problem, options, proof and poses are all needed.
#[allow(clippy::too_many_arguments)]
pub(super) fn walk_layers(
    w: &mut Emitter,
    out: &mut MillProgram,
    g: &SirenF64,
    problem: &MillingProblem<'_>,
    options: &ProgramOptions,
    clearance: &Clearance<'_>,
    poses: &[Pose],
    with_paths: bool,
) -> Result<()> {
    // Layers, top first; a nearest-neighbour chain on each.
    let h = gradient_step(g, problem, options.layer_step);
    let g_top = poses.iter().map(|p| p.g).fold(f64::NEG_INFINITY, f64::max);
    let layer_of = |p: &Pose| ((g_top - p.g) / h).round() as i64;
    let mut by_layer: std::collections::BTreeMap<i64, Vec<usize>> = Default::default();
    for (i, p) in poses.iter().enumerate() {
        by_layer.entry(layer_of(p)).or_default().push(i);
    }
    let mut walk = Walk {
        w,
        clearance,
        options,
        poses,
        with_paths,
        high: problem.block().max.z + options.retract,
        out,
        cur: None,
        from_pose: None,
        trail: Vec::new(),
    };
    for members in by_layer.values() {
        walk.mill_layer(members)?;
    }
    walk.leave()
}

/// A pose of the program: the tool tip, `G` there, the rotary angles of its checked tool
/// axis, and its iso-curve of `P` (0 for every pose without a path field).
pub(super) struct Pose {
    tip: Point3,
    g: f64,
    tilt: f64,
    c: f64,
    vertical: bool,
    curve: i64,
}

/// The poses of `problem` with `G`, the (snapped) tool axis that passes the clearance
/// proof, and the iso-curve of `paths`; with the counts of poses skipped and of poses
/// whose axis was turned toward `+Z`.
pub(super) fn program_poses(
    g: &SirenF64,
    problem: &MillingProblem<'_>,
    options: &ProgramOptions,
    paths: Option<&ContourPaths>,
    clearance: &Clearance<'_>,
) -> (Vec<Pose>, usize, usize) {
    let nz = problem.normalization();
    let curve_step = paths.map(|p| gradient_step(&p.field, problem, p.step));
    let mut poses = Vec::new();
    let mut skipped = 0usize;
    let mut reoriented = 0usize;
    for x in problem.poses() {
        let u = nz.to_unit(x);
        let (gx, grad) = g.value_gradient([u.x, u.y, u.z]);
        let n = Vector3::new(grad[0], grad[1], grad[2]);
        let Some(n) = n.try_normalize(1e-12) else {
            skipped += 1;
            continue;
        };
        if !gx.is_finite() {
            skipped += 1;
            continue;
        }
        let Some((tilt, c, vertical, turned)) = pose_axis(clearance, options, x, &n) else {
            skipped += 1;
            continue;
        };
        reoriented += turned as usize;
        let curve = match (paths, curve_step) {
            (Some(p), Some(step)) => {
                let v = p.field.value([u.x, u.y, u.z]);
                if !v.is_finite() {
                    skipped += 1;
                    continue;
                }
                (v / step).round() as i64
            }
            _ => 0,
        };
        poses.push(Pose { tip: *x, g: gx, tilt, c, vertical, curve });
    }
    (poses, skipped, reoriented)
}

/// The tool axis at the pose `x` with layer normal `n`: the normal; if the clearance proof
/// fails there (the flutes' clearance is stricter than the loss's hinge), the normal turned
/// toward +Z by a quarter, a half, three quarters and all the way, the first that passes.
/// Its rotary angles (snapped vertical), whether it is vertical, and whether it was turned.
fn pose_axis(
    clearance: &Clearance<'_>,
    options: &ProgramOptions,
    x: &Point3,
    n: &Vector3,
) -> Option<(f64, f64, bool, bool)> {
    let axes = options.rotary;
    for (k, t) in [0.0, 0.25, 0.5, 0.75, 1.0].into_iter().enumerate() {
        let Some(axis) = (n * (1.0 - t) + Vector3::z() * t).try_normalize(1e-12) else { continue };
        let (tilt, c) = tool_axis_angles(axes, &axis);
        let vertical = tilt < options.vertical_snap_deg;
        let (tilt, c) = if vertical { (0.0, 0.0) } else { (tilt, c) };
        let s = State { tip: *x, tilt, c };
        if clearance.clear(x, &axis_of(axes, &s)) {
            return Some((tilt, c, vertical, k > 0));
        }
    }
    None
}

/// The machine state at pose `p`, its C angle unwrapped to the nearest turn of `c_ref`
/// (`c_ref` itself for a vertical tool).
fn target_of(p: &Pose, c_ref: f64) -> State {
    let unwrap = |c: f64, near: f64| c + 360.0 * ((near - c) / 360.0).round();
    State { tip: p.tip, tilt: p.tilt, c: if p.vertical { c_ref } else { unwrap(p.c, c_ref) } }
}

/// The toolpath under construction: the writer, where the tool is, and the way it came.
struct Walk<'a> {
    w: &'a mut Emitter,
    clearance: &'a Clearance<'a>,
    options: &'a ProgramOptions,
    poses: &'a [Pose],
    with_paths: bool,
    /// The height of a vertical tool's tip above the block, for jumps.
    high: f64,
    out: &'a mut MillProgram,
    cur: Option<State>,
    /// The pose the tool last reached (None after a step back along the trail).
    from_pose: Option<usize>,
    /// Every waypoint written, in order: the way back when no remaining pose can be
    /// reached from where the tool is (retracing checked moves is safe).
    trail: Vec<State>,
}

impl Walk<'_> {
    /// Mills the poses `members` of one layer: a chain of links and jumps from where the
    /// tool is, stepping back along the trail when nothing can be reached.
    fn mill_layer(&mut self, members: &[usize]) -> Result<()> {
        let mut left: Vec<usize> = members.to_vec();
        let mut milled_any = false;
        let mut backtracks = 0usize;
        while !left.is_empty() {
            let Some(from) = self.cur else {
                milled_any |= self.start(&mut left)?;
                continue;
            };
            let order = self.candidates(&from, &left);
            let Some((k, route, link)) = self.find_move(&from, &left, &order) else {
                // Nothing reachable from here: step back along the trail, or give the
                // nearest pose up.
                if backtracks < MAX_BACKTRACK && self.trail.len() >= 2 {
                    let back = self.trail[self.trail.len() - 2];
                    if self.w.check_path(self.clearance, &from, &back) {
                        self.w.feed_to(&from, &back, true)?;
                        self.trail.pop();
                        self.cur = Some(back);
                        self.from_pose = None;
                        backtracks += 1;
                        continue;
                    }
                }
                left.swap_remove(order[0]);
                self.out.poses_skipped += 1;
                backtracks = 0;
                continue;
            };
            let from_curve = self.from_pose.map(|i| self.poses[i].curve);
            let on_curve = link && self.with_paths && Some(self.poses[left[k]].curve) == from_curve;
            self.from_pose = Some(left.swap_remove(k));
            let mut prev = from;
            for s in &route {
                self.w.feed_to(&prev, s, true)?;
                prev = *s;
            }
            self.trail.extend_from_slice(&route);
            if link {
                self.out.links += 1;
                self.out.curve_links += on_curve as usize;
            } else {
                self.out.jumps += 1;
            }
            backtracks = 0;
            self.cur = Some(prev);
            self.out.poses_used += 1;
            milled_any = true;
        }
        self.out.layers += milled_any as usize;
        Ok(())
    }

    /// The start: appear above the first pose of `left` along its axis, plunge. Whether
    /// it was reached (else it is skipped).
    fn start(&mut self, left: &mut Vec<usize>) -> Result<bool> {
        let (axes, retract) = (self.options.rotary, self.options.retract);
        let i = left.swap_remove(0);
        let target = target_of(&self.poses[i], 0.0);
        let axis = axis_of(axes, &target);
        for r in [retract, 2.0 * retract, 4.0 * retract] {
            let above = State { tip: target.tip + axis * r, ..target };
            if self.clearance.clear(&above.tip, &axis) && self.w.check_move(self.clearance, &above, &target) {
                self.w.setup(&above)?;
                self.w.rapid(&above)?;
                self.w.feed_to(&above, &target, false)?;
                self.trail.extend([above, target]);
                self.from_pose = Some(i);
                self.cur = Some(target);
                self.out.poses_used += 1;
                return Ok(true);
            }
        }
        self.out.poses_skipped += 1;
        Ok(false)
    }

    /// The positions in `left` by preference from `from`: the nearest remaining poses
    /// first; with a path field, the near ones on the current iso-curve before all others
    /// (without one every pose is on curve 0 and this is the plain nearest order).
    fn candidates(&self, from: &State, left: &[usize]) -> Vec<usize> {
        let poses = self.poses;
        let link_distance = self.options.link_distance;
        let mut order: Vec<usize> = (0..left.len()).collect();
        let dist = |k: usize| (poses[left[k]].tip - from.tip).norm_squared();
        let from_curve = self.from_pose.map(|i| poses[i].curve);
        let off_curve =
            |k: usize| !(Some(poses[left[k]].curve) == from_curve && dist(k) <= link_distance.powi(2));
        order.sort_by(|&a, &b| off_curve(a).cmp(&off_curve(b)).then(dist(a).total_cmp(&dist(b))));
        order
    }

    /// The first of the [`CANDIDATES`] best of `order` that can be reached from `from`: a
    /// feed link to a neighbour, else a jump. Its position in `left`, the route's
    /// waypoints, and whether it is a link.
    fn find_move(&self, from: &State, left: &[usize], order: &[usize]) -> Option<(usize, Vec<State>, bool)> {
        for &k in order.iter().take(CANDIDATES) {
            let target = target_of(&self.poses[left[k]], from.c);
            let near = (target.tip - from.tip).norm() <= self.options.link_distance;
            if near && self.w.check_path(self.clearance, from, &target) {
                return Some((k, vec![target], true));
            }
            if let Some(route) =
                jump_route(self.w, self.clearance, from, &target, self.options.retract, self.high)
            {
                return Some((k, route, false));
            }
        }
        None
    }

    /// Leaves along the tool axis.
    fn leave(&mut self) -> Result<()> {
        let Some(s) = self.cur else { return Ok(()) };
        let axis = axis_of(self.options.rotary, &s);
        let retract = self.options.retract;
        for r in [4.0 * retract, 2.0 * retract, retract] {
            let up = State { tip: s.tip + axis * r, ..s };
            if self.w.check_path(self.clearance, &s, &up) {
                self.w.feed_to(&s, &up, true)?;
                break;
            }
        }
        Ok(())
    }
}

/// Remaining poses tried, nearest first, before stepping back along the trail.
const CANDIDATES: usize = 6;

/// Steps back along the trail before a pose is given up.
const MAX_BACKTRACK: usize = 64;

/// The waypoints of a checked jump from `from` to `to` (ending at `to`): retract along the
/// tool axis by `r`, `2 r` or `4 r`, traverse, plunge; failing those, the same retracts
/// then up to a vertical tool with its tip at height `high` (above the block, where the
/// vertical tool is clear of a part inside it), across, and down. `None` when no route
/// passes the checks.
fn jump_route(
    w: &Emitter,
    clearance: &Clearance<'_>,
    from: &State,
    to: &State,
    r: f64,
    high: f64,
) -> Option<Vec<State>> {
    let axes = w.axes;
    let ok = |route: &[State]| {
        let mut prev = *from;
        route.iter().all(|s| {
            let pass = w.check_path(clearance, &prev, s);
            prev = *s;
            pass
        })
    };
    let retracts = [r, 2.0 * r, 4.0 * r];
    for r in retracts {
        let up = State { tip: from.tip + axis_of(axes, from) * r, ..*from };
        let down = State { tip: to.tip + axis_of(axes, to) * r, ..*to };
        let route = [up, down, *to];
        if ok(&route) {
            return Some(route.to_vec());
        }
    }
    for r in retracts {
        let up = State { tip: from.tip + axis_of(axes, from) * r, ..*from };
        let down = State { tip: to.tip + axis_of(axes, to) * r, ..*to };
        let over =
            |s: &State, c: f64| State { tip: Point3::new(s.tip.x, s.tip.y, s.tip.z.max(high)), tilt: 0.0, c };
        let route = [up, over(&up, from.c), over(&down, to.c), down, *to];
        if ok(&route) {
            return Some(route.to_vec());
        }
    }
    None
}
