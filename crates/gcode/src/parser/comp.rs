//! Cutter radius compensation (`G40`, `G41`, `G42`, `G41.1`, `G42.1`) as LinuxCNC's
//! interpreter makes it (`convert_straight_comp1`/`2`, `convert_arc_comp1`/`2` of
//! `interp_convert.cc` and the move queue of `interp_queue.cc`).
//!
//! The compensated path is computed in the plane's two coordinates (`G17`: X, Y;
//! `G18`: Z, X). The first move after `G41`/`G42` is the entry: a straight line tangent
//! to the tool's circle at the current point, or an arc through the programmed end. Every
//! later move ends one tool radius beside its programmed end; the move before it is
//! held back (queued) until the corner between the two is known: at a convex corner an
//! arc of the tool radius about the programmed corner is inserted, at a concave one the
//! held move is shortened to where the two offset paths meet. `G40`, `M0`-`M2` and `M30`
//! send the held move as it is; what else the program emits meanwhile (comments, dwells,
//! spindle changes) is held with it, in order. A program that ends without them loses
//! the held move, as in `rs274`.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::Point3;

use super::interp::{Fail, Interp, Res, hyp};
use crate::error::GcodeErrorKind;
use crate::motion::{ArcDirection, Motion, MotionSink, Plane};

/// LinuxCNC `TOLERANCE_CONCAVE_CORNER`: corners within this angle (radians) of straight
/// need neither an arc nor a cut back.
const SMALL: f64 = 0.05;
/// LinuxCNC `TOLERANCE_EQUAL`.
const EQUAL: f64 = 0.0001;

/// Which side of the programmed path the tool runs on, looking along the motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Side {
    Left,
    Right,
}

/// A move held back until the next one shows its corner; coordinates are the plane's
/// (first, second) pair, and the third axis.
#[derive(Debug, Clone)]
enum Queued {
    Straight {
        line: u64,
        rapid: bool,
        feed: f64,
        /// The programmed direction, to detect a cut back past the move's start.
        dir: [f64; 2],
        end: [f64; 3],
    },
    Arc {
        line: u64,
        feed: f64,
        /// The sweep (length, signed) as queued, to detect a cut back past its start.
        original_turns: f64,
        end: [f64; 3],
        center: [f64; 2],
        /// The third axis at the arc's start.
        start3: f64,
        /// Counter-clockwise turns, negative for clockwise (LinuxCNC's `turn`).
        turn: i32,
    },
    Other {
        line: u64,
        motion: Motion<'static>,
    },
}

/// The compensation state: LinuxCNC's `cutter_comp_*` settings, the programmed point
/// and the move queue.
#[derive(Debug, Clone)]
pub(super) struct Comp {
    pub(super) side: Option<Side>,
    /// Tool radius, mm (never negative: a negative diameter swaps the side).
    pub(super) radius: f64,
    /// Lathe tool orientation (`G41.1 L`, `G18` only); 0 for mills.
    orientation: i32,
    /// The next move is the entry move.
    pub(super) first: bool,
    /// The programmed end of the last compensated move, work coordinates (mm).
    pub(super) program: [f64; 3],
    /// The move after `G40` must be straight.
    pub(super) arc_not_allowed: bool,
    /// Where `G40` left the tool (work coordinates, mm) while the interpreter's point is
    /// the programmed one, until the next move: `M6` takes the machine's position back,
    /// as LinuxCNC re-reads it after a tool change.
    pub(super) tool_at: Option<[f64; 3]>,
    /// A `G41`/`G42` tool without a diameter was reported.
    warned_no_diameter: bool,
    queue: Vec<Queued>,
    endpoint: [f64; 2],
    endpoint_valid: bool,
}

impl Default for Comp {
    fn default() -> Self {
        Self {
            side: None,
            radius: 0.0,
            orientation: 0,
            first: true,
            program: [0.0; 3],
            arc_not_allowed: false,
            tool_at: None,
            warned_no_diameter: false,
            queue: Vec::new(),
            endpoint: [0.0; 2],
            endpoint_valid: false,
        }
    }
}

impl Comp {
    /// Compensation moves the tool: on, with a radius.
    #[inline]
    pub(super) fn active(&self) -> bool {
        self.side.is_some() && self.radius > 0.0
    }

    /// Moves are held back: what is emitted meanwhile is held with them.
    #[inline]
    pub(super) fn holding(&self) -> bool {
        !self.queue.is_empty()
    }

    fn tool_inside_arc(&self, turn: i32) -> bool {
        matches!((self.side, turn > 0), (Some(Side::Left), true) | (Some(Side::Right), false))
    }

    fn set_endpoint(&mut self, x: f64, y: f64) {
        self.endpoint = [x, y];
        self.endpoint_valid = true;
    }

    /// The front move, when it is an arc: (centre, end, turn).
    fn front_arc(&self) -> Option<([f64; 2], [f64; 2], i32)> {
        match self.queue.first() {
            Some(Queued::Arc { center, end, turn, .. }) => Some((*center, [end[0], end[1]], *turn)),
            _ => None,
        }
    }
}

/// An error of compensation, or of a code it does not allow.
#[cold]
pub(super) fn comp_refused<E>(col: usize, what: &str) -> Fail<E> {
    Fail::Line(col, GcodeErrorKind::CutterComp(what.into()))
}

/// LinuxCNC `find_turn`: the signed angle swept from `p1` to `p2` about `c` (radians,
/// counter-clockwise positive).
fn find_turn(p1: [f64; 2], c: [f64; 2], turn: i32, p2: [f64; 2]) -> f64 {
    if turn == 0 {
        return 0.0;
    }
    let mut alpha = (p1[1] - c[1]).atan2(p1[0] - c[0]);
    let mut beta = (p2[1] - c[1]).atan2(p2[0] - c[0]);
    if turn > 0 {
        if beta <= alpha {
            beta += TAU;
        }
        beta - alpha + (turn - 1) as f64 * TAU
    } else {
        if alpha <= beta {
            alpha += TAU;
        }
        beta - alpha + (turn + 1) as f64 * TAU
    }
}

impl Interp<'_> {
    /// Work coordinates to the compensation plane's (first, second, third).
    fn in_plane(&self, w: [f64; 3]) -> [f64; 3] {
        match self.plane {
            Plane::ZX => [w[2], w[0], w[1]],
            _ => w,
        }
    }

    fn out_of_plane(&self, p: [f64; 3]) -> [f64; 3] {
        match self.plane {
            Plane::ZX => [p[1], p[2], p[0]],
            _ => p,
        }
    }

    fn comp_current(&self) -> [f64; 3] {
        self.in_plane([self.work(0), self.work(1), self.work(2)])
    }

    fn comp_set_current(&mut self, p: [f64; 3]) {
        let w = self.out_of_plane(p);
        self.set_work(w);
    }

    fn comp_set_programmed(&mut self, p: [f64; 3]) {
        self.comp.program = self.out_of_plane(p);
    }

    /// `G41`/`G42` (`code` 410, 420: the tool table's diameter of tool `D`, or of the
    /// tool in the spindle) and `G41.1`/`G42.1` (411, 421: the diameter `D`, lathe
    /// orientation `L` under `G18`).
    pub(super) fn comp_on<E>(&mut self, code: u16, col: usize) -> Res<(), E> {
        let name =
            if code.is_multiple_of(10) { format!("G{}", code / 10) } else { format!("G{}.1", code / 10) };
        if self.plane == Plane::YZ {
            return Err(comp_refused(col, "cutter radius compensation allowed only in XY, XZ planes"));
        }
        if self.comp.side.is_some() {
            return Err(comp_refused(col, "cannot turn cutter radius comp on when on"));
        }
        let (radius, orientation) = if code % 10 == 1 {
            let Some(d) = self.block.get(b'd') else {
                return Err(comp_refused(col, &format!("{name} with no D word")));
            };
            let orientation = match self.block.get(b'l') {
                Some(_) if self.plane != Plane::ZX => {
                    return Err(comp_refused(col, &format!("{name} with L word, but plane is not G18")));
                }
                Some(l) => l as i32,
                None => 0,
            };
            (d * self.scale() / 2.0, orientation)
        } else {
            let tool = match self.block.get(b'd') {
                None => self.spindle_tool,
                Some(d) => {
                    let t = (d + 0.5).floor();
                    if (t - d).abs() >= 0.0001 {
                        return Err(comp_refused(
                            col,
                            &format!("{name} requires D word to be a whole number"),
                        ));
                    }
                    if t < 0.0 {
                        return Err(comp_refused(col, "negative D word tool radius index used"));
                    }
                    t.min(u32::MAX as f64) as u32
                }
            };
            let diameter = self.opts.tool_diameters.get(&tool).copied();
            if diameter.is_none() && !self.comp.warned_no_diameter {
                self.comp.warned_no_diameter = true;
                let what = format!(
                    "{name}: tool {tool} has no diameter in the tool table (ParseOptions::tool_diameters): \
                     compensation by 0, the programmed path (warned once)"
                );
                self.warn(col, GcodeErrorKind::CutterComp(what));
            }
            (diameter.unwrap_or(0.0) / 2.0, 0)
        };
        if !radius.is_finite() {
            return Err(comp_refused(col, "tool diameter is not finite"));
        }
        let side = if code / 10 == 41 { Side::Left } else { Side::Right };
        let side = match (radius < 0.0, side) {
            (true, Side::Left) => Side::Right,
            (true, Side::Right) => Side::Left,
            (false, s) => s,
        };
        self.comp.radius = radius.abs();
        self.comp.orientation = orientation;
        self.comp.side = Some(side);
        Ok(())
    }

    /// `G40`: the held move goes out as it is; the programmed point becomes the current
    /// one (no move), and the next move must be straight.
    pub(super) fn comp_off<S: MotionSink>(&mut self, sink: &mut S) -> Res<(), S::Error> {
        if self.comp.active() && !self.comp.first {
            let c = self.comp_current();
            self.move_endpoint_and_flush(c[0], c[1], sink)?;
            self.dequeue(sink)?;
            let p = self.comp.program;
            self.comp.tool_at = Some([self.work(0), self.work(1), self.work(2)]);
            self.set_work(p);
            self.comp.arc_not_allowed = true;
        }
        self.comp.side = None;
        self.comp.first = true;
        Ok(())
    }

    /// `M0`, `M1`, `M2`, `M30`, `M60`: the held move goes out; `M2` and `M30` also end
    /// compensation (the tool stays where it is).
    pub(super) fn comp_stop<S: MotionSink>(&mut self, end: bool, sink: &mut S) -> Res<(), S::Error> {
        if self.comp.holding() {
            let c = self.comp_current();
            self.move_endpoint_and_flush(c[0], c[1], sink)?;
            self.dequeue(sink)?;
        }
        if end {
            self.comp.side = None;
            self.comp.first = true;
        }
        Ok(())
    }

    /// Holds a non-move emission behind the held moves.
    #[cold]
    pub(super) fn comp_hold(&mut self, m: &Motion<'_>) {
        let line = self.lineno;
        self.comp.queue.push(Queued::Other { line, motion: m.clone().into_owned() });
    }

    /// Sends every held move and emission (LinuxCNC `dequeue_canons`).
    fn dequeue<S: MotionSink>(&mut self, sink: &mut S) -> Res<(), S::Error> {
        self.comp.endpoint_valid = false;
        let queue = std::mem::take(&mut self.comp.queue);
        for q in &queue {
            match q {
                Queued::Straight { line, rapid, feed, end, .. } => {
                    let w = self.lathe_origin(self.out_of_plane(*end));
                    let to = Point3::new(w[0], w[1], w[2]);
                    let m = if *rapid {
                        Motion::Rapid { to }
                    } else {
                        Motion::Linear { to, feed: *feed, extrude: None }
                    };
                    self.emit_at(*line, sink, &m)?;
                }
                Queued::Arc { line, feed, end, center, start3, turn, .. } => {
                    let w = self.lathe_origin(self.out_of_plane(*end));
                    let c = self.lathe_origin(self.out_of_plane([center[0], center[1], *start3]));
                    let direction =
                        if *turn > 0 { ArcDirection::CounterClockwise } else { ArcDirection::Clockwise };
                    let m = Motion::Arc {
                        to: Point3::new(w[0], w[1], w[2]),
                        center: Point3::new(c[0], c[1], c[2]),
                        plane: self.plane,
                        direction,
                        turns: turn.unsigned_abs().saturating_sub(1),
                        feed: *feed,
                        extrude: None,
                    };
                    self.emit_at(*line, sink, &m)?;
                }
                Queued::Other { line, motion } => self.emit_at(*line, sink, motion)?,
            }
        }
        let mut queue = queue;
        queue.clear();
        self.comp.queue = queue;
        Ok(())
    }

    /// Lathe tools (`G18`, orientation 1-8): the controlled point is the tool nose's
    /// centre, the reported one its origin (LinuxCNC `latheorigin_x`/`_z`).
    fn lathe_origin(&self, mut w: [f64; 3]) -> [f64; 3] {
        if self.plane != Plane::ZX {
            return w;
        }
        let (o, r) = (self.comp.orientation, self.comp.radius);
        if matches!(o, 2 | 6 | 1) {
            w[0] -= r;
        }
        if matches!(o, 3 | 8 | 4) {
            w[0] += r;
        }
        if matches!(o, 2 | 7 | 3) {
            w[2] -= r;
        }
        if matches!(o, 1 | 5 | 4) {
            w[2] += r;
        }
        w
    }

    /// Moves the end of every held move to `(x, y)` and sends them (LinuxCNC
    /// `move_endpoint_and_flush`), refusing a move that the new end would reverse.
    fn move_endpoint_and_flush<S: MotionSink>(&mut self, x: f64, y: f64, sink: &mut S) -> Res<(), S::Error> {
        if self.comp.queue.is_empty() {
            return Ok(());
        }
        let s = self.scale();
        let (ep, valid) = (self.comp.endpoint, self.comp.endpoint_valid);
        for q in &mut self.comp.queue {
            match q {
                Queued::Arc { original_turns, end, center, turn, .. } => {
                    let r1 = hyp(end[0] - center[0], end[1] - center[1]);
                    let r2 = hyp(x - center[0], y - center[1]);
                    let l2 = find_turn(ep, *center, *turn, [x, y]);
                    if (r1 - r2).abs() > 0.01 * s {
                        return Err(comp_refused(
                            0,
                            "cutter compensation has generated an invalid arc with mismatched radii",
                        ));
                    }
                    if *original_turns != 0.0 && valid && l2.abs() > original_turns.abs() + 0.001 {
                        return Err(comp_refused(
                            0,
                            "arc move in concave corner cannot be reached by the tool without gouging",
                        ));
                    }
                    end[0] = x;
                    end[1] = y;
                }
                Queued::Straight { rapid, dir, end, .. } => {
                    let dot = dir[0] * (x - ep[0]) + dir[1] * (y - ep[1]);
                    if valid && dot < 0.0 {
                        let what = if *rapid { "straight traverse" } else { "straight feed" };
                        return Err(comp_refused(
                            0,
                            &format!(
                                "{what} in concave corner cannot be reached by the tool without gouging"
                            ),
                        ));
                    }
                    end[0] = x;
                    end[1] = y;
                }
                Queued::Other { .. } => {}
            }
        }
        self.dequeue(sink)?;
        self.comp.set_endpoint(x, y);
        Ok(())
    }

    fn enqueue_straight(&mut self, rapid: bool, feed: f64, dir: [f64; 2], end: [f64; 3]) {
        let line = self.lineno;
        self.comp.queue.push(Queued::Straight { line, rapid, feed, dir, end });
    }

    #[allow(clippy::too_many_arguments)] // LinuxCNC's `enqueue_ARC_FEED`, argument for argument.
    fn enqueue_arc(
        &mut self,
        feed: f64,
        original_turns: f64,
        end: [f64; 3],
        center: [f64; 2],
        start3: f64,
        turn: i32,
    ) {
        let line = self.lineno;
        self.comp.queue.push(Queued::Arc { line, feed, original_turns, end, center, start3, turn });
    }

    /// A straight move under compensation to the programmed point `t` (work coordinates).
    pub(super) fn comp_straight<S: MotionSink>(
        &mut self,
        rapid: bool,
        feed: f64,
        t: [f64; 3],
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let p = self.in_plane(t);
        if self.comp.first {
            self.straight_comp1(rapid, feed, p)
        } else {
            self.straight_comp2(rapid, feed, p, sink)
        }
    }

    fn straight_comp1<E>(&mut self, rapid: bool, feed: f64, p: [f64; 3]) -> Res<(), E> {
        let c = self.comp_current();
        let r = self.comp.radius;
        if hyp(p[0] - c[0], p[1] - c[1]) <= r {
            return Err(comp_refused(
                0,
                "length of cutter compensation entry move is not greater than the tool radius",
            ));
        }
        let left = self.comp.side == Some(Side::Left);
        let alpha = (p[1] - c[1]).atan2(p[0] - c[0]) + if left { FRAC_PI_2 } else { -FRAC_PI_2 };
        let end = [p[0] + r * alpha.cos(), p[1] + r * alpha.sin(), p[2]];
        self.comp.set_endpoint(c[0], c[1]);
        self.enqueue_straight(rapid, feed, [alpha.cos(), alpha.sin()], end);
        self.comp.first = false;
        self.comp_set_current(end);
        self.comp_set_programmed(p);
        Ok(())
    }

    fn straight_comp2<S: MotionSink>(
        &mut self,
        rapid: bool,
        feed: f64,
        p: [f64; 3],
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let c = self.comp_current();
        let op = self.in_plane(self.comp.program);
        let dir3 = [p[0] - op[0], p[1] - op[1]];
        if p[1] == op[1] && p[0] == op[0] {
            // No motion in the plane: straight along the third axis, held with the rest.
            self.enqueue_straight(rapid, feed, dir3, [c[0], c[1], p[2]]);
            self.comp_set_current([c[0], c[1], p[2]]);
            self.comp_set_programmed(p);
            return Ok(());
        }
        let left = self.comp.side == Some(Side::Left);
        let r = self.comp.radius;
        let mut theta = (c[1] - op[1]).atan2(c[0] - op[0]);
        let mut alpha = (p[1] - op[1]).atan2(p[0] - op[0]);
        let (beta, gamma) = if left {
            if theta < alpha {
                theta += TAU;
            }
            (theta - alpha - FRAC_PI_2, FRAC_PI_2)
        } else {
            if alpha < theta {
                alpha += TAU;
            }
            (alpha - theta - FRAC_PI_2, -FRAC_PI_2)
        };
        let end = [p[0] + r * (alpha + gamma).cos(), p[1] + r * (alpha + gamma).sin()];
        let mid = [op[0] + r * (alpha + gamma).cos(), op[1] + r * (alpha + gamma).sin()];
        let h_shape = self.comp.front_arc().is_some_and(|(_, _, turn)| !self.comp.tool_inside_arc(turn));
        let concave = !(-SMALL..=PI + SMALL).contains(&beta) || (beta > PI - SMALL && h_shape);
        if !concave && beta > SMALL {
            // Convex: an arc about the programmed corner (a straight traverse for G0).
            self.move_endpoint_and_flush(c[0], c[1], sink)?;
            if rapid {
                self.enqueue_straight(true, feed, [0.0, 0.0], [mid[0], mid[1], c[2]]);
            } else {
                let turn = if left { -1 } else { 1 };
                self.enqueue_arc(feed, 0.0, [mid[0], mid[1], c[2]], [op[0], op[1]], c[2], turn);
            }
            self.dequeue(sink)?;
            self.comp.set_endpoint(mid[0], mid[1]);
        } else if concave {
            let corner = match self.comp.front_arc() {
                None => {
                    // Line to line: back along the held line to where the offsets meet.
                    let half = (beta + PI) / 2.0;
                    if half == 0.0 {
                        return Err(comp_refused(
                            0,
                            "zero degree inside corner is invalid for cutter compensation",
                        ));
                    }
                    let retreat = r / half.tan();
                    [c[0] + retreat * (theta + gamma).cos(), c[1] + retreat * (theta + gamma).sin()]
                }
                Some((pc, pe, pturn)) => self.arc_line_corner(p, op, pc, pe, pturn)?,
            };
            self.move_endpoint_and_flush(corner[0], corner[1], sink)?;
        } else {
            // Straight on, or tangent from an arc.
            self.dequeue(sink)?;
            self.comp.set_endpoint(c[0], c[1]);
        }
        self.enqueue_straight(rapid, feed, dir3, [end[0], end[1], p[2]]);
        self.comp_set_current([end[0], end[1], p[2]]);
        self.comp_set_programmed(p);
        Ok(())
    }

    /// Where a held (compensated) arc meets the offset of the new line in a concave corner.
    fn arc_line_corner<E>(
        &self,
        p: [f64; 3],
        op: [f64; 3],
        pc: [f64; 2],
        pe: [f64; 2],
        pturn: i32,
    ) -> Res<[f64; 2], E> {
        let r = self.comp.radius;
        let oldrad = hyp(pc[1] - pe[1], pc[0] - pe[0]);
        let base_dir = (p[1] - op[1]).atan2(p[0] - op[0]);
        let theta = if pturn > 0 { base_dir + FRAC_PI_2 } else { base_dir - FRAC_PI_2 };
        let phi = (pc[1] - op[1]).atan2(pc[0] - op[0]);
        let inside = self.comp.tool_inside_arc(pturn);
        let oldrad_uncomp = if inside { oldrad + r } else { oldrad - r };
        let d = oldrad_uncomp * (theta - phi).cos();
        let l = if inside { (d - r) / oldrad } else { (d + r) / oldrad };
        if !(-1.0..=1.0).contains(&l) {
            return Err(comp_refused(
                0,
                "arc to straight motion makes a corner the compensated tool can't fit in without gouging",
            ));
        }
        let angle = (if inside == (pturn > 0) { -l.acos() } else { l.acos() }) + theta + PI;
        Ok([pc[0] + oldrad * angle.cos(), pc[1] + oldrad * angle.sin()])
    }

    /// An arc under compensation: programmed end `t` (work coordinates), centre (work
    /// coordinates of the plane's axes, from the programmed start), turn.
    pub(super) fn comp_arc<S: MotionSink>(
        &mut self,
        feed: f64,
        t: [f64; 3],
        center: [f64; 2],
        turn: i32,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let p = self.in_plane(t);
        if self.comp.first {
            self.arc_comp1(feed, p, center, turn)
        } else {
            self.arc_comp2(feed, p, center, turn, sink)
        }
    }

    fn arc_comp1<E>(&mut self, feed: f64, p: [f64; 3], center: [f64; 2], turn: i32) -> Res<(), E> {
        let c = self.comp_current();
        let r = self.comp.radius;
        if hyp(p[0] - c[0], p[1] - c[1]) <= r {
            return Err(comp_refused(
                0,
                "radius of cutter compensation entry arc is not greater than the tool radius",
            ));
        }
        if self.comp.tool_inside_arc(turn) && hyp(center[0] - c[0], center[1] - c[1]) <= r {
            return Err(comp_refused(0, "tool radius not less than arc radius with comp"));
        }
        let gamma = if self.comp.tool_inside_arc(turn) {
            (center[1] - p[1]).atan2(center[0] - p[0])
        } else {
            (p[1] - center[1]).atan2(p[0] - center[0])
        };
        self.comp.first = false;
        self.comp_set_programmed(p);
        let end = [p[0] + r * gamma.cos(), p[1] + r * gamma.sin(), p[2]];
        // The centre of the arc from the tool's point through the moved end, on the line
        // from the end to the programmed centre.
        let b_len = hyp(c[1] - end[1], c[0] - end[0]) / 2.0;
        let ab_ang = (center[1] - end[1]).atan2(center[0] - end[0]);
        let a_ang = (c[1] - end[1]).atan2(c[0] - end[0]) - ab_ang;
        if a_ang.cos().abs() < EQUAL {
            return Err(comp_refused(0, "tool radius not less than arc radius with comp"));
        }
        let c_len = b_len / a_ang.cos();
        let nc = [end[0] + c_len * ab_ang.cos(), end[1] + c_len * ab_ang.sin()];
        let spiral = self.opts.arc_tolerance_mm * if self.inch { 2.54 } else { 1.0 };
        let mismatch = (hyp(nc[0] - end[0], nc[1] - end[1]) - hyp(nc[0] - c[0], nc[1] - c[1])).abs();
        if mismatch.is_nan() || mismatch > spiral {
            return Err(comp_refused(0, "bug in tool radius comp"));
        }
        if self.comp.orientation != 0 && self.comp.orientation != 9 {
            // A lathe tool's origin moves first, or the arc is not one.
            self.enqueue_straight(false, feed, [0.0, 0.0], c);
            self.comp.set_endpoint(c[0], c[1]);
        }
        let sweep = find_turn([c[0], c[1]], nc, turn, [end[0], end[1]]);
        self.enqueue_arc(feed, sweep, end, nc, c[2], turn);
        self.comp_set_current(end);
        Ok(())
    }

    fn arc_comp2<S: MotionSink>(
        &mut self,
        feed: f64,
        p: [f64; 3],
        ctr: [f64; 2],
        turn: i32,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        let op = self.in_plane(self.comp.program);
        let c = self.comp_current();
        let left = self.comp.side == Some(Side::Left);
        let r = self.comp.radius;
        let arc_radius = hyp(ctr[0] - p[0], ctr[1] - p[1]);
        let theta = (c[1] - op[1]).atan2(c[0] - op[0]);
        let theta = if left { theta - FRAC_PI_2 } else { theta + FRAC_PI_2 };
        let mut delta = (ctr[1] - op[1]).atan2(ctr[0] - op[0]);
        let alpha = if turn > 0 { delta - FRAC_PI_2 } else { delta + FRAC_PI_2 };
        let beta = if left { theta - alpha } else { alpha - theta };
        let beta = if beta > 1.5 * PI {
            beta - TAU
        } else if beta < -FRAC_PI_2 {
            beta + TAU
        } else {
            beta
        };
        let inside = self.comp.tool_inside_arc(turn);
        let gamma = if inside {
            if arc_radius <= r {
                return Err(comp_refused(0, "tool radius not less than arc radius with comp"));
            }
            (ctr[1] - p[1]).atan2(ctr[0] - p[0])
        } else {
            delta += PI;
            (p[1] - ctr[1]).atan2(p[0] - ctr[0])
        };
        let new_end = [p[0] + r * gamma.cos(), p[1] + r * gamma.sin(), p[2]];
        let sweep = find_turn([op[0], op[1]], ctr, turn, [p[0], p[1]]);
        if !(-SMALL..=PI + SMALL).contains(&beta) || ((beta - PI).abs() < SMALL && !inside) {
            // Concave: cut the held move back to where it meets this arc's offset.
            let mid = match self.comp.front_arc() {
                None => self.line_arc_corner(ctr, arc_radius, beta, theta, turn)?,
                Some((pc, pe, pturn)) => self.arc_arc_corner(ctr, arc_radius, turn, pc, pe, pturn)?,
            };
            self.move_endpoint_and_flush(mid[0], mid[1], sink)?;
        } else if beta > SMALL {
            // Convex: an arc about the programmed corner first.
            let mid = [op[0] + r * delta.cos(), op[1] + r * delta.sin()];
            self.dequeue(sink)?;
            let t = if left { -1 } else { 1 };
            self.enqueue_arc(feed, 0.0, [mid[0], mid[1], c[2]], [op[0], op[1]], c[2], t);
            self.dequeue(sink)?;
            self.comp.set_endpoint(mid[0], mid[1]);
        } else {
            self.dequeue(sink)?;
            self.comp.set_endpoint(c[0], c[1]);
        }
        let start3 = c[2];
        self.enqueue_arc(feed, sweep, new_end, ctr, start3, turn);
        self.comp_set_programmed(p);
        self.comp_set_current(new_end);
        Ok(())
    }

    /// A held line meeting this arc's offset in a concave corner.
    fn line_arc_corner<E>(
        &self,
        ctr: [f64; 2],
        arc_radius: f64,
        beta: f64,
        theta: f64,
        turn: i32,
    ) -> Res<[f64; 2], E> {
        let r = self.comp.radius;
        let cy = arc_radius * (beta - FRAC_PI_2).sin();
        let inside = self.comp.tool_inside_arc(turn);
        let (dist, toward) = if inside { (arc_radius - r, cy + r) } else { (arc_radius + r, cy - r) };
        let l = toward / dist;
        if !(-1.0..=1.0).contains(&l) {
            return Err(comp_refused(
                0,
                "arc move in concave corner cannot be reached by the tool without gouging",
            ));
        }
        let angle = match (inside, turn > 0) {
            (true, true) => theta + l.asin(),
            (true, false) => theta - l.asin(),
            (false, true) => theta + PI - l.asin(),
            (false, false) => theta + PI + l.asin(),
        };
        Ok([ctr[0] + dist * angle.cos(), ctr[1] + dist * angle.sin()])
    }

    /// A held arc meeting this arc's offset in a concave corner.
    fn arc_arc_corner<E>(
        &self,
        ctr: [f64; 2],
        arc_radius: f64,
        turn: i32,
        pc: [f64; 2],
        pe: [f64; 2],
        pturn: i32,
    ) -> Res<[f64; 2], E> {
        let r = self.comp.radius;
        let oldrad = hyp(pc[1] - pe[1], pc[0] - pe[0]);
        let newrad = if self.comp.tool_inside_arc(turn) { arc_radius - r } else { arc_radius + r };
        let arc_cc = hyp(pc[1] - ctr[1], pc[0] - ctr[0]);
        if oldrad == 0.0 || arc_cc == 0.0 {
            return Err(comp_refused(
                0,
                "arc to arc motion is invalid because the arcs have the same center",
            ));
        }
        let a = (oldrad * oldrad + arc_cc * arc_cc - newrad * newrad) / (2.0 * oldrad * arc_cc);
        if !(-1.0..=1.0).contains(&a) {
            return Err(comp_refused(
                0,
                "arc to arc motion makes a corner the compensated tool can't fit in without gouging",
            ));
        }
        let pullback = a.acos();
        let cc_dir = (ctr[1] - pc[1]).atan2(ctr[0] - pc[0]);
        let plus = self.comp.tool_inside_arc(pturn) == (turn > 0);
        let dir = if plus { cc_dir + pullback } else { cc_dir - pullback };
        Ok([pc[0] + oldrad * dir.cos(), pc[1] + oldrad * dir.sin()])
    }
}
