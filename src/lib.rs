//! `shape2gcode`: the composed Shape2Gcode pipeline.
//!
//! Mesh to G-code (`mill`) and G-code back to geometry, built from the workspace
//! crates, which are re-exported here so that one dependency gives the whole system.

pub use s2g_gcode as gcode;
pub use s2g_geom as geom;
pub use s2g_orient as orient;
pub use s2g_toolpath as toolpath;
pub use s2g_voxsim as voxsim;
