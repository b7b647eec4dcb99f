//! `s2g-gcode`: the machine-motion vocabulary of Shape2Gcode.
//!
//! [`Motion`] is one machine event in millimetres; a [`MotionSink`] consumes them.
//! The parser pushes into any sink, the dialect writers *are* sinks, and so are the
//! simulator and any user code.

mod motion;

pub use crate::motion::{
    ArcDirection, Coolant, Marker, Motion, MotionRecorder, MotionSink, Plane, SpindleDirection,
};
