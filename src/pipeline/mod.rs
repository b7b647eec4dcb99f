//! [`mill`]: mesh to checked, simulated and scored G-code (seed 000 Figure 2).
//!
//! load -> check -> normalise -> choose setups (orient) -> per setup: features ->
//! policy -> plan (toolpath) -> write G-code text (gcode) -> **parse the text back**
//! -> simulate every setup in the part frame (voxsim) -> score (geom metrics,
//! rewards). What is scored is what a machine would run.
//!
//! # Program layouts
//!
//! [`ProgramLayout::PerSetup`] writes one 3-axis program per setup, its fixture rotation in
//! its `SETUP` header comment; each is parsed back on its own and the simulator is told
//! the setup's frame. [`ProgramLayout::Rotary`] writes **one** 3+2 program for a
//! table-table machine: before each setup the tool rapids straight up (program +Z) to a
//! height where the whole stock can turn under it (the stock's farthest corner from the
//! rotary centre, plus the clearance), then `G0 A.. C..` (or `B.. C..`) turns the part.
//! The rotary centre is the part frame's origin (the program origin). The program is
//! parsed back in one pass with [`ParseOptions::rotary`], so the simulator learns every
//! frame from the rotary words alone.
//!
//! Rotary words fix the tool axis but not the turn about it: the part turns by the
//! kinematic rotation of its angles ([`rotary_frame`]). Each setup is still planned in
//! the frame orientation selection gave it, and its program coordinates are turned about
//! Z (and shifted by that frame's translation, zero today) into the kinematic frame as
//! they are written, so both layouts cut the same paths in the part frame.

mod api;
mod finish_scope;
mod job;
mod per_setup;
mod pipe;
mod rest_finish;
mod rotary;
mod run;
mod setup_choice;
mod stock;
mod tooling;

pub use self::api::{
    Datum, MillError, MillOptions, Milled, PartDeviation, Preset, ProgramLayout, SetupCount, SetupFinish,
    SetupProgram, Stage, StageSeconds, Stock,
};
pub use self::run::MillRun;
pub use self::setup_choice::SetupChoice;
pub use self::tooling::default_tool_library;

use crate::geom::Mesh;
use crate::policy::Policy;

/// Mills `mesh` with `policy`. See the module docs for the stages; `progress` is told
/// when each stage starts.
///
/// In the per-setup layout the policy chooses each setup's action after the earlier
/// setups were simulated, so [`SetupFeatures::removal_fraction`] is what is really left;
/// the rotary layout parses its one program in one pass, so every action is chosen
/// before the first setup is cut (see [`MillRun`]).
pub fn mill(
    mesh: &Mesh,
    policy: &mut dyn Policy,
    opts: &MillOptions,
    progress: &mut dyn FnMut(Stage),
) -> Result<Milled, MillError> {
    MillRun::new(mesh, opts, progress)?.complete(policy, progress)
}
