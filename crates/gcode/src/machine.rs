//! [`MachineProfile`]: the limits of a milling machine (feeds, rapids, acceleration,
//! spindle), and [`MachineTime`], a [`MotionSink`] that estimates how long a program runs
//! on it, acceleration included.
//!
//! The estimate plans velocities the way a controller's trajectory planner does (grbl's
//! planner is the model): every straight move is a block with a nominal speed (its feed,
//! or the rapid rate, capped per axis) and an acceleration (the largest that keeps every
//! axis within its limit along the block's direction); the speed through the corner
//! between two blocks is limited by the junction-deviation rule; and a look-ahead window
//! of [`MachineProfile::lookahead`] blocks is planned backwards (every block must be able
//! to stop at the end of the window) and forwards (no block leaves faster than it can
//! accelerate to). Each block then takes the time of its trapezoidal (or triangular)
//! speed profile. Arcs are blocks along their length whose speed is also capped by the
//! centripetal limit `sqrt(a r)`; their junctions use the tangents at their ends. The
//! machine stops at tool changes, spindle and coolant changes, dwells, program stops and
//! the end.

use std::collections::VecDeque;

use nalgebra::{Point3, Vector3};

use crate::arc::{ArcSpec, plane_axes};
use crate::motion::{ArcDirection, Motion, MotionSink};

/// The limits of a milling machine that decide how fast it runs a program. Every field has
/// a documented default ([`MachineProfile::default`]: a small gantry router).
#[derive(Debug, Clone, PartialEq)]
pub struct MachineProfile {
    /// Name, for reports. Default `"generic-router"`.
    pub name: String,
    /// Largest programmed cutting feed, mm/min; higher feeds run at this. Default 5,000.
    pub max_feed: f64,
    /// Rapid rate of each axis (X, Y, Z), mm/min. Default 5,000 each.
    pub rapid: [f64; 3],
    /// Acceleration limit of each axis (X, Y, Z), mm/s². Default 500, 500, 300.
    pub accel: [f64; 3],
    /// Junction deviation, mm: how far the path may round a corner at the speed the
    /// corner is taken (grbl's `$11`). Default 0.01.
    pub junction_deviation: f64,
    /// Spindle speed range, rpm. Default 1,000 to 24,000.
    pub spindle_rpm: [f64; 2],
    /// Seconds a tool change takes (an automatic changer, or the operator). Default 10.
    pub tool_change_s: f64,
    /// Blocks the planner looks ahead (grbl plans 16, LinuxCNC more). Default 32.
    pub lookahead: usize,
}

impl Default for MachineProfile {
    fn default() -> Self {
        Self {
            name: "generic-router".into(),
            max_feed: 5000.0,
            rapid: [5000.0; 3],
            accel: [500.0, 500.0, 300.0],
            junction_deviation: 0.01,
            spindle_rpm: [1000.0, 24_000.0],
            tool_change_s: 10.0,
            lookahead: 32,
        }
    }
}

impl MachineProfile {
    /// Checks that the machine can exist; the message names the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be positive and finite, got {v}"))
            }
        };
        pos("max_feed", self.max_feed)?;
        for i in 0..3 {
            pos("rapid", self.rapid[i])?;
            pos("accel", self.accel[i])?;
        }
        pos("junction_deviation", self.junction_deviation)?;
        let [lo, hi] = self.spindle_rpm;
        if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && hi > 0.0 && lo <= hi) {
            return Err(format!("spindle_rpm must be a range 0 <= min <= max, got [{lo}, {hi}]"));
        }
        if !(self.tool_change_s.is_finite() && self.tool_change_s >= 0.0) {
            return Err(format!("tool_change_s must be finite and not negative, got {}", self.tool_change_s));
        }
        if self.lookahead == 0 {
            return Err("lookahead must be at least 1 block".into());
        }
        Ok(())
    }

    /// `rpm` within the spindle's range.
    pub fn clamp_rpm(&self, rpm: f64) -> f64 {
        rpm.clamp(self.spindle_rpm[0], self.spindle_rpm[1])
    }

    /// The fastest speed (mm/s) and acceleration (mm/s²) along unit direction `u` that keep
    /// every axis within `per_axis_speed` (mm/min) and its acceleration limit.
    fn limits_along(&self, u: &Vector3<f64>, per_axis_speed: [f64; 3]) -> (f64, f64) {
        let (mut v, mut a) = (f64::INFINITY, f64::INFINITY);
        for i in 0..3 {
            let c = u[i].abs();
            if c > 1e-12 {
                v = v.min(per_axis_speed[i] / 60.0 / c);
                a = a.min(self.accel[i] / c);
            }
        }
        (v, a)
    }
}

/// One planned move.
#[derive(Debug, Clone, Copy)]
struct Block {
    length: f64,
    /// Cruise speed, mm/s.
    nominal: f64,
    /// Acceleration along the block, mm/s².
    accel: f64,
    /// Largest speed at which the block may be entered (junction limit), mm/s.
    max_entry: f64,
    /// Planned entry speed, mm/s.
    entry: f64,
    /// Unit direction at the end (for the next junction).
    exit_dir: Vector3<f64>,
}

/// A [`MotionSink`] that estimates a program's run time on a [`MachineProfile`] (see the
/// module docs for the model). Memory is bounded by the look-ahead window.
#[derive(Debug, Clone)]
pub struct MachineTime {
    machine: MachineProfile,
    pos: Option<Point3<f64>>,
    window: VecDeque<Block>,
    /// Exit speed of the last committed block (the entry of the window's first).
    committed_exit: f64,
    /// Seconds of committed blocks, dwells and tool changes.
    seconds: f64,
    moves: u64,
}

impl MachineTime {
    /// An estimator for `machine`, the tool starting at rest at an unknown position (the
    /// first move only sets it).
    pub fn new(machine: MachineProfile) -> Self {
        Self { machine, pos: None, window: VecDeque::new(), committed_exit: 0.0, seconds: 0.0, moves: 0 }
    }

    /// The estimated time so far, in seconds, the moves still in the window planned to
    /// stop at its end.
    pub fn seconds(&self) -> f64 {
        let mut copy = self.clone();
        copy.stop();
        copy.seconds
    }

    /// Moves timed so far.
    pub fn moves(&self) -> u64 {
        self.moves
    }

    /// The machine.
    pub fn machine(&self) -> &MachineProfile {
        &self.machine
    }

    fn push(
        &mut self,
        length: f64,
        start_dir: Vector3<f64>,
        exit_dir: Vector3<f64>,
        nominal: f64,
        accel: f64,
    ) {
        if !(length > 0.0 && length.is_finite() && nominal > 0.0 && accel > 0.0) {
            return;
        }
        self.moves += 1;
        let max_entry = match self.window.back() {
            Some(prev) => junction_speed(&prev.exit_dir, &start_dir, accel, self.machine.junction_deviation)
                .min(nominal)
                .min(prev.nominal),
            // After a committed block the junction was decided when it was committed:
            // planning restarts from rest only after a stop.
            None if self.committed_exit > 0.0 => self.committed_exit.min(nominal),
            None => 0.0,
        };
        self.window.push_back(Block { length, nominal, accel, max_entry, entry: 0.0, exit_dir });
        self.plan();
        while self.window.len() > self.machine.lookahead {
            self.commit_first();
        }
    }

    /// Backward pass (each block can slow to the next block's entry, the last to rest),
    /// then forward pass (each block reaches no more than its acceleration allows).
    fn plan(&mut self) {
        let n = self.window.len();
        let mut next_entry = 0.0;
        for i in (0..n).rev() {
            let b = &mut self.window[i];
            b.entry = b.max_entry.min((next_entry * next_entry + 2.0 * b.accel * b.length).sqrt());
            next_entry = b.entry;
        }
        if let Some(first) = self.window.front_mut() {
            first.entry = first.entry.min(self.committed_exit);
        }
        for i in 0..n.saturating_sub(1) {
            let b = self.window[i];
            let reach = (b.entry * b.entry + 2.0 * b.accel * b.length).sqrt();
            let next = &mut self.window[i + 1];
            next.entry = next.entry.min(reach);
        }
    }

    fn commit_first(&mut self) {
        let Some(b) = self.window.pop_front() else { return };
        let exit = self.window.front().map_or(0.0, |n| n.entry);
        self.seconds += block_time(&b, exit);
        self.committed_exit = exit;
    }

    /// Plans the window to rest and commits it (the machine stops).
    fn stop(&mut self) {
        self.plan();
        while !self.window.is_empty() {
            self.commit_first();
        }
        self.committed_exit = 0.0;
    }

    fn straight(&mut self, to: Point3<f64>, speed: Option<f64>) {
        let Some(from) = self.pos.replace(to) else { return };
        let d = to - from;
        let length = d.norm();
        if !(length > 0.0 && length.is_finite()) {
            return;
        }
        let u = d / length;
        let (nominal, accel) = match speed {
            Some(feed) => {
                let (v, a) = self.machine.limits_along(&u, self.machine.rapid);
                (v.min(feed.min(self.machine.max_feed) / 60.0), a)
            }
            None => self.machine.limits_along(&u, self.machine.rapid),
        };
        self.push(length, u, u, nominal, accel);
    }
}

/// The speed (mm/s) through the corner from direction `a` to direction `b` (unit vectors):
/// grbl's junction-deviation rule, `v² = a δ sin(θ/2) / (1 − sin(θ/2))` with θ the angle
/// between the reversed incoming and the outgoing direction; straight on, unlimited.
pub fn junction_speed(a: &Vector3<f64>, b: &Vector3<f64>, accel: f64, deviation: f64) -> f64 {
    let cos_theta = (-a.dot(b)).clamp(-1.0, 1.0);
    if cos_theta <= -1.0 + 1e-12 {
        return f64::INFINITY;
    }
    if cos_theta >= 1.0 - 1e-12 {
        return 0.0;
    }
    let sin_half = ((1.0 - cos_theta) / 2.0).sqrt();
    (accel * deviation * sin_half / (1.0 - sin_half)).sqrt()
}

/// The time of one block entered at `b.entry` and left at `exit`: accelerate at `b.accel`
/// towards its nominal speed, cruise, decelerate (a triangle where it is too short).
fn block_time(b: &Block, exit: f64) -> f64 {
    let (v0, v1, a, l) = (b.entry, exit, b.accel, b.length);
    let vc = b.nominal;
    let d_up = (vc * vc - v0 * v0) / (2.0 * a);
    let d_down = (vc * vc - v1 * v1) / (2.0 * a);
    if d_up + d_down <= l {
        (vc - v0) / a + (vc - v1) / a + (l - d_up - d_down) / vc
    } else {
        // Peak speed where the two ramps meet: vp² = (2 a l + v0² + v1²) / 2.
        let vp = ((2.0 * a * l + v0 * v0 + v1 * v1) / 2.0).sqrt().max(v0.max(v1));
        (vp - v0) / a + (vp - v1) / a
    }
}

impl MotionSink for MachineTime {
    type Error = std::convert::Infallible;

    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Self::Error> {
        match motion {
            Motion::Rapid { to } => self.straight(*to, None),
            Motion::Linear { to, feed, .. } => self.straight(*to, Some(*feed)),
            Motion::Arc { to, feed, .. } => {
                let Some(from) = self.pos.replace(*to) else { return Ok(()) };
                let Some(arc) = ArcSpec::from_motion(from, motion) else { return Ok(()) };
                let (u, v, _) = plane_axes(arc.plane);
                let (r, length) = (arc.radius().max(arc.end_radius()), arc.length());
                if !(r > 0.0 && length.is_finite() && length > 0.0) {
                    self.pos = Some(from);
                    self.straight(*to, Some(*feed));
                    return Ok(());
                }
                // Tangents at the ends, in the arc's plane (a helix's climb is left out of
                // the junctions; the length includes it).
                let turn = match arc.direction {
                    ArcDirection::CounterClockwise => 1.0,
                    ArcDirection::Clockwise => -1.0,
                };
                let tangent = |p: &Point3<f64>| {
                    let mut t = Vector3::zeros();
                    t[u] = -(p[v] - arc.center[v]) * turn;
                    t[v] = (p[u] - arc.center[u]) * turn;
                    t.try_normalize(1e-12).unwrap_or(t)
                };
                let (t0, t1) = (tangent(&from), tangent(to));
                // Over an arc the tangent and the centripetal acceleration turn through
                // both in-plane axes, and somewhere each lies along one axis: the slower
                // axis limits speed and acceleration, and v^2 / r stays within it.
                let a = self.machine.accel[u].min(self.machine.accel[v]);
                let vmax = self.machine.rapid[u].min(self.machine.rapid[v]) / 60.0;
                let nominal = (feed.min(self.machine.max_feed) / 60.0).min(vmax).min((a * r).sqrt());
                self.push(length, t0, t1, nominal, a);
            }
            Motion::Dwell { seconds } => {
                self.stop();
                if seconds.is_finite() && *seconds > 0.0 {
                    self.seconds += seconds;
                }
            }
            Motion::ToolChange { .. } => {
                self.stop();
                self.seconds += self.machine.tool_change_s;
            }
            Motion::Spindle { .. } | Motion::Coolant(_) | Motion::Stop { .. } | Motion::End => self.stop(),
            Motion::Setup { .. } => {
                self.stop();
                self.pos = None;
            }
            // The head turns about the tip, which stays put: the turn is not timed.
            Motion::ToolAxis { .. } => self.stop(),
            Motion::Cycle(cycle) => {
                self.stop();
                let mut moves = Vec::new();
                cycle.expand(self.pos, |m| moves.push(m));
                for m in &moves {
                    self.motion(m)?;
                }
            }
            Motion::Comment(_) | Motion::Marker(_) => {}
        }
        Ok(())
    }

    fn finish(&mut self) -> Result<(), Self::Error> {
        self.stop();
        Ok(())
    }
}
