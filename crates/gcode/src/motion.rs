//! The machine-motion vocabulary shared by every crate: [`Motion`] and [`MotionSink`].

use std::borrow::Cow;

use nalgebra::{Isometry3, Point3, Vector3};

/// Active arc plane (G17 / G18 / G19).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Plane {
    /// G17: arcs in XY, helix along Z.
    #[default]
    XY,
    /// G18: arcs in ZX, helix along Y.
    ZX,
    /// G19: arcs in YZ, helix along X.
    YZ,
}

/// Arc direction seen from the positive end of the plane's normal axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ArcDirection {
    /// G2.
    Clockwise,
    /// G3.
    CounterClockwise,
}

/// Spindle state (M3 / M4 / M5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SpindleDirection {
    /// M3.
    Clockwise,
    /// M4.
    CounterClockwise,
    /// M5.
    Off,
}

/// Coolant state (M7 / M8 / M9).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Coolant {
    /// M7.
    Mist,
    /// M8.
    Flood,
    /// M9.
    Off,
}

/// One machine event. Positions are in millimetres in the program's work frame
/// (after units, offsets and incremental mode are resolved); feeds in mm/min.
///
/// The programmed point of a cutting tool is its tip (the lowest point of the
/// cutter along the tool axis).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Motion<'a> {
    /// G0: traverse at the machine's rapid rate to `to`.
    Rapid {
        /// End point.
        to: Point3<f64>,
    },
    /// G1: straight feed move to `to`.
    Linear {
        /// End point.
        to: Point3<f64>,
        /// Feed rate in mm/min.
        feed: f64,
        /// Filament pushed during the move, in mm of filament (relative, after
        /// M82/M83 and `G92 E` are resolved); `None` on machines without an E axis.
        /// Negative values are retractions.
        extrude: Option<f64>,
    },
    /// G2 / G3: circular or helical feed move.
    Arc {
        /// End point (the helix axis coordinate may differ from the start).
        to: Point3<f64>,
        /// Absolute arc centre; its coordinate along the plane normal is the start's.
        center: Point3<f64>,
        /// Arc plane.
        plane: Plane,
        /// Direction.
        direction: ArcDirection,
        /// Extra full turns beyond the first partial or full revolution (LinuxCNC `P` minus one).
        turns: u32,
        /// Feed rate in mm/min.
        feed: f64,
        /// Filament pushed during the move, as for [`Motion::Linear`].
        extrude: Option<f64>,
    },
    /// M6 (with the preceding T word): the active tool becomes `tool`.
    ToolChange {
        /// Tool number.
        tool: u32,
    },
    /// Spindle speed and direction.
    Spindle {
        /// Revolutions per minute.
        rpm: f64,
        /// Direction, or off.
        direction: SpindleDirection,
    },
    /// Coolant change.
    Coolant(Coolant),
    /// G4: pause.
    Dwell {
        /// Seconds.
        seconds: f64,
    },
    /// A program comment, without its delimiters.
    Comment(Cow<'a, str>),
    /// A slicer annotation: layer change (`;LAYER:n`, `;LAYER_CHANGE`, `;Z:`) or feature type (`;TYPE:`).
    Marker(Marker<'a>),
    /// A new setup: from now on, program coordinates map to the part frame through
    /// `frame` (so the tool axis in the part frame is `frame * +Z`). Emitted by the
    /// planner for each orientation and by the parser for rotary-axis words under a
    /// machine kinematics.
    Setup {
        /// Program frame to part frame.
        frame: Isometry3<f64>,
        /// Rotary axis values (A, B, C in degrees) that realise `frame`, when known.
        rotary: [Option<f64>; 3],
    },
    /// A tilting head under tool-centre-point control turns: from now on the tool axis is
    /// `axis` (unit, in the program frame: the part frame turned by the last
    /// [`Motion::Setup`], if any), while program coordinates stay the tip's. Emitted by the parser for
    /// rotary-axis words under [`RotaryMount::Head`](crate::RotaryMount::Head) and by
    /// planners for head machines; a sink that cannot follow a tilted tool (a 3-axis
    /// simulator) returns an error for an axis off `+Z` rather than cut along the wrong one.
    ToolAxis {
        /// Tool axis (tip toward the spindle), unit, in the program frame.
        axis: Vector3<f64>,
        /// Rotary axis values (A, B, C in degrees) that realise `axis`, when known.
        rotary: [Option<f64>; 3],
    },
    /// M2 / M30: end of program.
    End,
    /// G81 / G82 / G83: one canned drilling cycle (see [`DrillCycle`]). Sinks that do not
    /// know cycles can replay [`DrillCycle::expand`] instead.
    Cycle(DrillCycle),
    /// M0 (`optional: false`) or M1 (`optional: true`): program stop.
    Stop {
        /// M1: stop only when the operator's optional-stop switch is on.
        optional: bool,
    },
}

/// Which canned drilling cycle a [`DrillCycle`] is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CycleKind {
    /// G81: feed to the bottom, rapid out.
    Drill,
    /// G82: feed to the bottom, dwell `seconds`, rapid out.
    Dwell {
        /// Dwell at the bottom in seconds.
        seconds: f64,
    },
    /// G83: peck drilling, feeding `peck` mm at a time with a rapid retract to the R plane
    /// after each peck (full chip clearing).
    Peck {
        /// Peck depth in mm (`Q`), positive.
        peck: f64,
    },
}

/// One canned drilling cycle in the XY plane along -Z, retracting to the initial level
/// (`G98`): from the current position the tool rapids up (or down) to `clearance`, then to
/// `x`, `y`, down to `r_plane`, feeds to `bottom` (in pecks for [`CycleKind::Peck`]) and
/// rapids back to `clearance`, where it ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrillCycle {
    /// Cycle kind.
    pub kind: CycleKind,
    /// Hole position X.
    pub x: f64,
    /// Hole position Y.
    pub y: f64,
    /// Initial level (Z) the cycle starts from and returns to; at or above `r_plane`.
    pub clearance: f64,
    /// Retract (R) plane Z, where feeding starts.
    pub r_plane: f64,
    /// Hole bottom Z (below `r_plane`).
    pub bottom: f64,
    /// Feed rate in mm/min.
    pub feed: f64,
}

/// Most pecks [`DrillCycle::expand`] writes for one hole.
const MAX_PECKS: f64 = 10_000.0;

/// LinuxCNC's G83 rapid stop above the previous peck (0.010 inch), used by [`DrillCycle::expand`].
pub const PECK_CLEARANCE_MM: f64 = 0.254;

impl DrillCycle {
    /// The cycle as plain moves (rapids, feeds, dwells), in LinuxCNC's order: `from` is the
    /// tool position before the cycle (when known, it moves to `clearance` first). A peck so
    /// small that the hole would need more than 10 000 pecks is raised to depth / 10 000.
    pub fn expand(&self, from: Option<Point3<f64>>, mut out: impl FnMut(Motion<'static>)) {
        let top = self.clearance.max(self.r_plane);
        if let Some(p) = from {
            out(Motion::Rapid { to: Point3::new(p.x, p.y, top) });
        }
        let at = |z: f64| Point3::new(self.x, self.y, z);
        out(Motion::Rapid { to: at(top) });
        out(Motion::Rapid { to: at(self.r_plane) });
        match self.kind {
            CycleKind::Peck { peck } if peck > 0.0 && peck.is_finite() => {
                // At most MAX_PECKS pecks (a smaller peck is raised to that count's size).
                let peck = peck.max((self.r_plane - self.bottom) / MAX_PECKS);
                let mut depth = self.r_plane;
                while depth > self.bottom {
                    if depth < self.r_plane {
                        out(Motion::Rapid { to: at((depth + PECK_CLEARANCE_MM).min(self.r_plane)) });
                    }
                    depth = (depth - peck).max(self.bottom);
                    out(Motion::Linear { to: at(depth), feed: self.feed, extrude: None });
                    if depth > self.bottom {
                        out(Motion::Rapid { to: at(self.r_plane) });
                    }
                }
            }
            _ => {
                out(Motion::Linear { to: at(self.bottom), feed: self.feed, extrude: None });
                if let CycleKind::Dwell { seconds } = self.kind {
                    out(Motion::Dwell { seconds });
                }
            }
        }
        out(Motion::Rapid { to: at(top) });
    }
}

/// Slicer annotations surfaced by the parser.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Marker<'a> {
    /// A new layer begins; `index` when the slicer numbered it.
    Layer {
        /// Zero-based layer index, if stated.
        index: Option<i64>,
        /// Layer height (Z) if stated.
        z: Option<f64>,
    },
    /// A new feature type (`;TYPE:WALL-OUTER`, `;TYPE:Perimeter`, ...).
    Type(Cow<'a, str>),
}

/// A consumer of motions: the G-code writers, the simulator, statistics, user code.
///
/// Only [`MotionSink::motion`] is required. The parser also reports the source line
/// of the motions that follow through [`MotionSink::source_line`], so that sinks can
/// name the offending line in their reports.
pub trait MotionSink {
    /// What the sink can fail with.
    type Error;

    /// Receives one motion.
    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Self::Error>;

    /// The 1-based source line that the following motions come from. Default: ignored.
    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        let _ = line;
        Ok(())
    }

    /// No more motions follow. Default: nothing to do.
    fn finish(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

impl<S: MotionSink + ?Sized> MotionSink for &mut S {
    type Error = S::Error;
    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Self::Error> {
        (**self).motion(motion)
    }
    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        (**self).source_line(line)
    }
    fn finish(&mut self) -> Result<(), Self::Error> {
        (**self).finish()
    }
}

/// Collects owned motions (with their source lines); handy in tests and small tools.
#[derive(Debug, Clone, Default)]
pub struct MotionRecorder {
    /// `(source line, motion)` pairs in order; the line is 0 when none was reported.
    pub motions: Vec<(u64, Motion<'static>)>,
    line: u64,
}

impl Motion<'_> {
    /// A copy that owns its text.
    pub fn into_owned(self) -> Motion<'static> {
        match self {
            Motion::Comment(c) => Motion::Comment(Cow::Owned(c.into_owned())),
            Motion::Marker(Marker::Type(t)) => Motion::Marker(Marker::Type(Cow::Owned(t.into_owned()))),
            Motion::Marker(Marker::Layer { index, z }) => Motion::Marker(Marker::Layer { index, z }),
            Motion::Rapid { to } => Motion::Rapid { to },
            Motion::Linear { to, feed, extrude } => Motion::Linear { to, feed, extrude },
            Motion::Arc { to, center, plane, direction, turns, feed, extrude } => {
                Motion::Arc { to, center, plane, direction, turns, feed, extrude }
            }
            Motion::ToolChange { tool } => Motion::ToolChange { tool },
            Motion::Spindle { rpm, direction } => Motion::Spindle { rpm, direction },
            Motion::Coolant(c) => Motion::Coolant(c),
            Motion::Dwell { seconds } => Motion::Dwell { seconds },
            Motion::Setup { frame, rotary } => Motion::Setup { frame, rotary },
            Motion::ToolAxis { axis, rotary } => Motion::ToolAxis { axis, rotary },
            Motion::End => Motion::End,
            Motion::Cycle(c) => Motion::Cycle(c),
            Motion::Stop { optional } => Motion::Stop { optional },
        }
    }

    /// The end point of a move (rapid, linear or arc), if this is one.
    pub fn end_point(&self) -> Option<Point3<f64>> {
        match self {
            Motion::Rapid { to } | Motion::Linear { to, .. } | Motion::Arc { to, .. } => Some(*to),
            _ => None,
        }
    }
}

impl MotionSink for MotionRecorder {
    type Error = std::convert::Infallible;
    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Self::Error> {
        self.motions.push((self.line, motion.clone().into_owned()));
        Ok(())
    }
    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.line = line;
        Ok(())
    }
}

#[cfg(test)]
mod cycle_tests {
    use super::*;

    #[test]
    fn tiny_pecks_are_bounded() {
        let c = DrillCycle {
            kind: CycleKind::Peck { peck: 1e-12 },
            x: 0.0,
            y: 0.0,
            clearance: 2.0,
            r_plane: 1.0,
            bottom: -9.0,
            feed: 10.0,
        };
        let mut n = 0usize;
        let mut lowest = f64::INFINITY;
        c.expand(None, |m| {
            n += 1;
            if let Some(p) = m.end_point() {
                lowest = lowest.min(p.z);
            }
        });
        assert!(n <= 3 * 10_000 + 4, "{n} moves");
        assert_eq!(lowest, -9.0, "reaches the bottom");
    }
}
