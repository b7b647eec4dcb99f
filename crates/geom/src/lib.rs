//! `s2g-geom`: meshes and their I/O, spatial queries, voxel grids, marching cubes,
//! smoothing and shape metrics for Shape2Gcode.
//!
//! nalgebra types in f64 are the vocabulary ([`Point3`], [`Vector3`]); parry3d is used
//! inside this crate only.

mod aabb;
mod error;
mod math;
mod mesh;
mod sdf;
mod setup;
mod voxel;

pub use crate::aabb::Aabb;
pub use crate::error::{GeomError, Result};
pub use crate::math::{Isometry3, Point3, Real, Rotation3, Similarity3, UnitVector3, Vector3};
pub use crate::mesh::Mesh;
pub use crate::sdf::{BoxShape, SignedDistance, Sphere};
pub use crate::setup::Setup;
pub use crate::voxel::{BRICK, Brick, GridSpec, VoxelGrid};
