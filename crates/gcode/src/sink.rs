//! General [`MotionSink`] adapters: [`Tee`] hands every motion to two sinks, and
//! [`Transformed`] moves a program rigidly (into another work frame, or into the frame a
//! rotary placement defines) on its way to a sink.

use nalgebra::{Isometry3, Point3, Vector3};

use crate::arc::linearize_arc;
use crate::motion::{DrillCycle, Motion, MotionSink, Plane};
use crate::writer::WriterOptions;

/// Hands every motion, source line and the end to `first`, then to `second` (stopping at
/// the first error). Both sinks fail with the same error type.
#[derive(Debug, Clone, Default)]
pub struct Tee<A, B> {
    /// The sink that sees each motion first.
    pub first: A,
    /// The sink that sees it second.
    pub second: B,
}

impl<A, B> Tee<A, B> {
    /// A tee of `first` and `second`.
    pub fn new(first: A, second: B) -> Self {
        Self { first, second }
    }
}

impl<A: MotionSink, B: MotionSink<Error = A::Error>> MotionSink for Tee<A, B> {
    type Error = A::Error;

    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Self::Error> {
        self.first.motion(motion)?;
        self.second.motion(motion)
    }

    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.first.source_line(line)?;
        self.second.source_line(line)
    }

    fn finish(&mut self) -> Result<(), Self::Error> {
        self.first.finish()?;
        self.second.finish()
    }
}

/// Moves every programmed point by a rigid `transform` before `inner` sees it: rapids,
/// feeds, arc end points and centres, drill cycles.
///
/// Arcs in the XY plane and drill cycles stay what they are when the transform keeps +Z
/// (a turn about Z and any shift, the case of rotary placements and work offsets); arcs in
/// other planes, and every arc and cycle under a transform that tilts Z, become straight
/// moves (chords within [`WriterOptions::arc_tolerance`]'s default, or the
/// [`with_arc_tolerance`](Self::with_arc_tolerance) given) and cycles their expanded
/// moves. An arc with no known start point goes straight to its end, as the simulator
/// treats a zero-radius arc.
///
/// A [`Motion::Setup`] (the program's frame in the part) becomes `frame * transform⁻¹`, so
/// the moved program cuts the same part, or, with [`with_setup`](Self::with_setup), the
/// frame and rotary words given (a rotary placement's kinematic frame). A
/// [`Motion::ToolAxis`] turns with the transform (its rotary words dropped if it turns).
#[derive(Debug, Clone)]
pub struct Transformed<S> {
    inner: S,
    transform: Isometry3<f64>,
    keeps_z: bool,
    setup: Option<(Isometry3<f64>, [Option<f64>; 3])>,
    arc_tolerance: f64,
    /// The last programmed point before and after the transform.
    last_in: Option<Point3<f64>>,
    last_out: Option<Point3<f64>>,
}

impl<S: MotionSink> Transformed<S> {
    /// `inner` behind `transform`.
    pub fn new(inner: S, transform: Isometry3<f64>) -> Self {
        let keeps_z = (transform.rotation * Vector3::z() - Vector3::z()).norm() <= 1e-12;
        Self {
            inner,
            transform,
            keeps_z,
            setup: None,
            arc_tolerance: WriterOptions::default().arc_tolerance,
            last_in: None,
            last_out: None,
        }
    }

    /// Every [`Motion::Setup`] becomes this frame with these rotary words.
    pub fn with_setup(mut self, frame: Isometry3<f64>, rotary: [Option<f64>; 3]) -> Self {
        self.setup = Some((frame, rotary));
        self
    }

    /// The sagitta of the chords of arcs that become straight moves.
    pub fn with_arc_tolerance(mut self, tolerance: f64) -> Self {
        self.arc_tolerance = tolerance;
        self
    }

    /// The last programmed point `inner` received (after the transform), if any since the
    /// last setup.
    pub fn last_point(&self) -> Option<Point3<f64>> {
        self.last_out
    }

    /// The sink behind the adapter.
    pub fn into_inner(self) -> S {
        self.inner
    }

    fn straight(&mut self, m: &Motion<'_>, to: &Point3<f64>, feed: f64) -> Result<(), S::Error> {
        let mut points = Vec::new();
        let ok = self
            .last_in
            .is_some_and(|from| linearize_arc(&from, m, self.arc_tolerance, |p| points.push(p)).is_ok());
        if !ok || points.is_empty() {
            points = vec![*to];
        }
        for p in points {
            self.inner.motion(&Motion::Linear { to: self.transform * p, feed, extrude: None })?;
        }
        Ok(())
    }

    fn cycle(&mut self, c: &DrillCycle) -> Result<(), S::Error> {
        let top = c.clearance.max(c.r_plane);
        if self.keeps_z {
            let t = self.transform;
            let xy = t * Point3::new(c.x, c.y, 0.0);
            let dz = t.translation.vector.z;
            let moved = DrillCycle {
                x: xy.x,
                y: xy.y,
                clearance: c.clearance + dz,
                r_plane: c.r_plane + dz,
                bottom: c.bottom + dz,
                ..*c
            };
            self.inner.motion(&Motion::Cycle(moved))?;
            self.last_in = Some(Point3::new(moved.x, moved.y, top));
            self.last_out = Some(Point3::new(xy.x, xy.y, top + dz));
            return Ok(());
        }
        let mut moves = Vec::new();
        c.expand(self.last_in, |m| moves.push(m));
        for m in &moves {
            self.motion(m)?;
        }
        Ok(())
    }
}

impl<S: MotionSink> MotionSink for Transformed<S> {
    type Error = S::Error;

    fn motion(&mut self, m: &Motion<'_>) -> Result<(), S::Error> {
        let t = self.transform;
        match m {
            Motion::Setup { frame, rotary } => {
                let (frame, rotary) = self.setup.unwrap_or((frame * t.inverse(), *rotary));
                self.inner.motion(&Motion::Setup { frame, rotary })?;
                self.last_out = None;
            }
            Motion::ToolAxis { axis, rotary } => {
                // Rotary words name the axis in the program frame; turned, they no longer do.
                let turned = (t.rotation.angle()) > 0.0;
                let rotary = if turned { [None; 3] } else { *rotary };
                self.inner.motion(&Motion::ToolAxis { axis: t.rotation * axis, rotary })?
            }
            Motion::Rapid { to } => self.inner.motion(&Motion::Rapid { to: t * to })?,
            Motion::Linear { to, feed, extrude } => {
                self.inner.motion(&Motion::Linear { to: t * to, feed: *feed, extrude: *extrude })?
            }
            Motion::Arc { to, center, plane: Plane::XY, direction, turns, feed, extrude } if self.keeps_z => {
                self.inner.motion(&Motion::Arc {
                    to: t * to,
                    center: t * center,
                    plane: Plane::XY,
                    direction: *direction,
                    turns: *turns,
                    feed: *feed,
                    extrude: *extrude,
                })?
            }
            Motion::Arc { to, feed, .. } => self.straight(m, to, *feed)?,
            Motion::Cycle(c) => return self.cycle(c),
            other => self.inner.motion(other)?,
        }
        if let Some(p) = m.end_point() {
            self.last_in = Some(p);
            self.last_out = Some(t * p);
        }
        Ok(())
    }

    fn source_line(&mut self, line: u64) -> Result<(), S::Error> {
        self.inner.source_line(line)
    }

    fn finish(&mut self) -> Result<(), S::Error> {
        self.inner.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::{ArcDirection, CycleKind, MotionRecorder};
    use nalgebra::{Translation3, UnitQuaternion};

    fn arc(to: Point3<f64>, center: Point3<f64>, plane: Plane) -> Motion<'static> {
        Motion::Arc {
            to,
            center,
            plane,
            direction: ArcDirection::CounterClockwise,
            turns: 0,
            feed: 100.0,
            extrude: None,
        }
    }

    fn program() -> Vec<Motion<'static>> {
        vec![
            Motion::Setup { frame: Isometry3::identity(), rotary: [None; 3] },
            Motion::Rapid { to: Point3::new(1.0, 0.0, 5.0) },
            Motion::Linear { to: Point3::new(1.0, 0.0, 0.0), feed: 100.0, extrude: None },
            arc(Point3::new(0.0, 1.0, 0.0), Point3::origin(), Plane::XY),
            arc(Point3::new(0.0, 1.0, 1.0), Point3::new(0.0, 1.0, 0.5), Plane::YZ),
            Motion::Cycle(DrillCycle {
                x: 2.0,
                y: 3.0,
                clearance: 5.0,
                r_plane: 1.0,
                bottom: -2.0,
                feed: 50.0,
                kind: CycleKind::Drill,
            }),
        ]
    }

    fn run(transform: Isometry3<f64>) -> Vec<Motion<'static>> {
        let mut t = Transformed::new(MotionRecorder::default(), transform);
        for m in program() {
            t.motion(&m).unwrap();
        }
        t.into_inner().motions.into_iter().map(|(_, m)| m).collect()
    }

    #[test]
    fn a_turn_about_z_keeps_xy_arcs_and_cycles_and_moves_every_point() {
        let t = Isometry3::from_parts(
            Translation3::new(10.0, -4.0, 2.0),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.7),
        );
        let out = run(t);
        let Motion::Rapid { to } = out[1] else { panic!("{:?}", out[1]) };
        assert!((to - t * Point3::new(1.0, 0.0, 5.0)).norm() < 1e-12);
        let Motion::Arc { to, center, plane: Plane::XY, .. } = out[3] else { panic!("{:?}", out[3]) };
        assert!((to - t * Point3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
        assert!((center - t * Point3::origin()).norm() < 1e-12);
        // The YZ arc becomes chords ending at the moved end point.
        let chords: Vec<_> = out[4..out.len() - 1].iter().collect();
        assert!(chords.len() > 2, "{chords:?}");
        assert!(chords.iter().all(|m| matches!(m, Motion::Linear { .. })));
        let last = chords.last().unwrap().end_point().unwrap();
        assert!((last - t * Point3::new(0.0, 1.0, 1.0)).norm() < 1e-12);
        let Motion::Cycle(c) = out[out.len() - 1] else { panic!() };
        let xy = t * Point3::new(2.0, 3.0, 0.0);
        assert!((c.x - xy.x).abs() < 1e-12 && (c.y - xy.y).abs() < 1e-12);
        assert_eq!([c.clearance, c.r_plane, c.bottom], [7.0, 3.0, 0.0]);
        // The setup is the same part seen from the moved program.
        let Motion::Setup { frame, .. } = out[0] else { panic!() };
        assert!(((frame * t) * Point3::new(1.0, 2.0, 3.0) - Point3::new(1.0, 2.0, 3.0)).norm() < 1e-12);
    }

    #[test]
    fn a_tilt_turns_arcs_and_cycles_into_moves_at_the_moved_points() {
        let t = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 1.0),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.5),
        );
        let out = run(t);
        assert!(!out.iter().any(|m| matches!(m, Motion::Arc { .. } | Motion::Cycle(_))));
        let bottom = out
            .iter()
            .filter_map(Motion::end_point)
            .map(|p| t.inverse() * p)
            .fold(f64::MAX, |a, p| a.min(p.z));
        assert!((bottom + 2.0).abs() < 1e-9, "the drilled hole's bottom, moved back: {bottom}");
    }

    #[test]
    fn a_tee_hands_each_motion_to_both_in_order() {
        let mut tee = Tee::new(MotionRecorder::default(), MotionRecorder::default());
        for m in program() {
            tee.motion(&m).unwrap();
        }
        tee.finish().unwrap();
        assert_eq!(tee.first.motions.len(), program().len());
        assert_eq!(tee.first.motions, tee.second.motions);
    }
}
