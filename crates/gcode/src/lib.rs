//! `s2g-gcode`: the machine-motion vocabulary of Shape2Gcode.
//!
//! [`Motion`] is one machine event in millimetres; a [`MotionSink`] consumes them.
//! The parser pushes into any sink, the dialect writers *are* sinks, and so are the
//! simulator and any user code.
//!
//! 3+2 programs: [`rotary_frame`] and [`rotary_angles`] convert between setup frames
//! and A/C or B/C table angles; the writers ([`WriterOptions::rotary`]) and the parser
//! ([`ParseOptions::rotary`]) both use them, so written setups read back as the same
//! kinematic frames.

mod arc;
mod dialect;
mod error;
mod expr;
mod fit;
mod machine;
mod motion;
mod parser;
mod rotary;
mod sink;
mod sink_thread;
mod spine;
mod stats;
mod writer;

/// The xorshift64 generator the crate's tests draw from: the same sequence per seed.
#[cfg(test)]
pub(crate) fn xorshift(mut state: u64) -> impl FnMut() -> u64 {
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    }
}

pub use crate::arc::{
    ArcError, ArcFitOptions, ArcFitter, ArcSpec, MAX_ARC_SEGMENTS, arc_length, linearize_arc, plane_axes,
    sweep_angle,
};
pub use crate::dialect::{
    AutoRetract, CommentStyle, Dialect, DialectSpec, DrillCycles, DwellDecimals, DwellFormat, NoRotaryAxes,
    TimeUnit, ToolChange, UnknownDialect,
};
pub use crate::error::{GcodeError, GcodeErrorKind, ParseError};
pub use crate::fit::{FitSide, PlanarFitOptions, PlanarPiece, fit_planar};
pub use crate::machine::{MachineProfile, MachineTime, junction_speed};
pub use crate::motion::{
    ArcDirection, Coolant, CycleKind, DrillCycle, Marker, Motion, MotionRecorder, MotionSink,
    PECK_CLEARANCE_MM, Plane, SpindleDirection,
};
#[doc(hidden)]
pub use crate::parser::parse_str_two_stage;
pub use crate::parser::{ParseDialect, ParseOptions, ParseSummary, parse_file, parse_reader, parse_str};
pub use crate::rotary::{
    RotaryAxes, RotaryMount, axis_angles, rotary_angles, rotary_axis, rotary_frame, rotary_twist,
};
pub use crate::sink::{Tee, Transformed};
pub use crate::sink_thread::SinkThread;
pub use crate::spine::{Spine, SpineBuilder, SpineOptions, SpineRule};
pub use crate::stats::{Stats, StatsOptions};
pub use crate::writer::{
    ExtrusionMode, FooterRetract, GcodeWriter, WriteError, WriterOptions, write_program,
};
