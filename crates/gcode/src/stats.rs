//! [`Stats`]: a [`MotionSink`] that summarises a program (counts, extent, lengths, time).

use std::collections::BTreeSet;
use std::convert::Infallible;
use std::f64::consts::TAU;

use nalgebra::Point3;

use crate::motion::{ArcDirection, Marker, Motion, MotionSink, Plane};

/// Options of [`Stats`].
#[derive(Debug, Clone, PartialEq)]
pub struct StatsOptions {
    /// Rapid traverse rate used for the time estimate, mm/min. Default: 5000.
    pub rapid_mm_per_min: f64,
    /// Where the tool starts (work frame, mm). Default: the origin, as the parser assumes.
    pub start: Point3<f64>,
}

impl Default for StatsOptions {
    fn default() -> Self {
        Self { rapid_mm_per_min: 5000.0, start: Point3::origin() }
    }
}

/// Counts, extent, lengths and an estimated time of the motions it receives.
///
/// The time is feed length / feed rate (per move) + rapid length / rapid rate + dwells;
/// feed moves with a zero feed rate are left out of the time and counted in
/// [`Stats::untimed_length_mm`]. The bounding box covers move end points and the start
/// point (not the bulge of arcs between them).
#[derive(Debug, Clone, PartialEq)]
pub struct Stats {
    /// Options used.
    pub options: StatsOptions,
    /// Rapid moves.
    pub rapids: u64,
    /// Straight feed moves (including zero-length extrusion-only moves).
    pub linears: u64,
    /// Arc moves.
    pub arcs: u64,
    /// Tool changes.
    pub tool_changes: u64,
    /// Comments.
    pub comments: u64,
    /// Layer markers.
    pub layers: u64,
    /// Dwells.
    pub dwells: u64,
    /// Other motions (spindle, coolant, type markers, setups, end).
    pub other: u64,
    /// Bounding box of the tool positions: (min, max); `None` before the first move.
    pub bbox: Option<(Point3<f64>, Point3<f64>)>,
    /// Length of feed moves (straight and arcs, helices included), mm.
    pub feed_length_mm: f64,
    /// Length of rapid moves, mm.
    pub rapid_length_mm: f64,
    /// Feed length moved at a zero feed rate (not in the time estimate), mm.
    pub untimed_length_mm: f64,
    /// Net filament pushed (sum of extrusion amounts), mm.
    pub extruded_mm: f64,
    /// Estimated run time, seconds.
    pub time_s: f64,
    /// Tools used (tool changes), sorted.
    pub tools: BTreeSet<u32>,
    pos: Point3<f64>,
}

impl Default for Stats {
    fn default() -> Self {
        Self::new(StatsOptions::default())
    }
}

impl Stats {
    /// Empty statistics with `options`.
    pub fn new(options: StatsOptions) -> Self {
        let pos = options.start;
        Self {
            options,
            rapids: 0,
            linears: 0,
            arcs: 0,
            tool_changes: 0,
            comments: 0,
            layers: 0,
            dwells: 0,
            other: 0,
            bbox: None,
            feed_length_mm: 0.0,
            rapid_length_mm: 0.0,
            untimed_length_mm: 0.0,
            extruded_mm: 0.0,
            time_s: 0.0,
            tools: BTreeSet::new(),
            pos,
        }
    }

    /// Number of moves (rapid, linear and arc).
    pub fn moves(&self) -> u64 {
        self.rapids + self.linears + self.arcs
    }

    fn grow(&mut self, p: Point3<f64>) {
        if !p.iter().all(|v| v.is_finite()) {
            return;
        }
        let (lo, hi) = self.bbox.get_or_insert((self.pos, self.pos));
        *lo = lo.inf(&p);
        *hi = hi.sup(&p);
    }

    fn feed_time(&mut self, len: f64, feed: f64) {
        self.feed_length_mm += len;
        if feed > 0.0 && feed.is_finite() {
            self.time_s += len / feed * 60.0;
        } else {
            self.untimed_length_mm += len;
        }
    }
}

/// Length of an arc move from `from` (plane, centre, direction, extra turns, helix).
pub(crate) fn arc_move_length(
    from: Point3<f64>,
    to: Point3<f64>,
    center: Point3<f64>,
    plane: Plane,
    direction: ArcDirection,
    turns: u32,
) -> f64 {
    let (u, v, w) = match plane {
        Plane::XY => (0, 1, 2),
        Plane::ZX => (2, 0, 1),
        Plane::YZ => (1, 2, 0),
    };
    let a0 = (from[v] - center[v]).atan2(from[u] - center[u]);
    let a1 = (to[v] - center[v]).atan2(to[u] - center[u]);
    let mut sweep = match direction {
        ArcDirection::CounterClockwise => a1 - a0,
        ArcDirection::Clockwise => a0 - a1,
    };
    if sweep <= 1e-12 {
        sweep += TAU;
    }
    sweep += TAU * turns as f64;
    let r = (from[u] - center[u]).hypot(from[v] - center[v]);
    (r * sweep).hypot(to[w] - from[w])
}

impl MotionSink for Stats {
    type Error = Infallible;

    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Infallible> {
        match m {
            Motion::Rapid { to } => {
                self.rapids += 1;
                let len = (to - self.pos).norm();
                self.rapid_length_mm += len;
                if self.options.rapid_mm_per_min > 0.0 {
                    self.time_s += len / self.options.rapid_mm_per_min * 60.0;
                }
                self.grow(*to);
                self.pos = *to;
            }
            Motion::Linear { to, feed, extrude } => {
                self.linears += 1;
                let len = (to - self.pos).norm();
                self.feed_time(len, *feed);
                self.extruded_mm += extrude.unwrap_or(0.0);
                self.grow(*to);
                self.pos = *to;
            }
            Motion::Arc { to, center, plane, direction, turns, feed, extrude } => {
                self.arcs += 1;
                let len = arc_move_length(self.pos, *to, *center, *plane, *direction, *turns);
                self.feed_time(len, *feed);
                self.extruded_mm += extrude.unwrap_or(0.0);
                self.grow(*to);
                self.pos = *to;
            }
            Motion::ToolChange { tool } => {
                self.tool_changes += 1;
                self.tools.insert(*tool);
            }
            Motion::Dwell { seconds } => {
                self.dwells += 1;
                self.time_s += seconds;
            }
            Motion::Comment(_) => self.comments += 1,
            Motion::Marker(Marker::Layer { .. }) => self.layers += 1,
            _ => self.other += 1,
        }
        Ok(())
    }
}
