//! `s2g-geom`: meshes and their I/O, spatial queries, voxel grids, marching cubes,
//! smoothing and shape metrics for Shape2Gcode.
//!
//! nalgebra types in f64 are the vocabulary ([`Point3`], [`Vector3`]). Spatial queries run
//! on this crate's own binned-SAH BVH rather than parry3d's `TriMesh`: about twice as fast
//! on orientation-style rays (`benches/rays.rs` measures both in one run), with any-hit
//! queries and a winding-number inside test that parry does not offer. The same BVH
//! carries drop-cutter and waterline for flat, ball and bull-nose cutters ([`DropCutter`]),
//! the cutter-location queries of 3-axis finishing.

mod aabb;
mod atomic;
mod check;
mod cutter;
mod error;
mod io;
mod marching_cubes;
mod math;
mod mesh;
mod metrics;
mod normalize;
mod query;
mod sample;
mod sdf;
mod setup;
mod smooth;
mod sweep;
mod voxel;
mod voxelize;
mod winding;

pub use crate::aabb::Aabb;
pub use crate::atomic::{write_atomic, write_bytes_atomic};
pub use crate::check::{
    MeshReport, ReportOptions, drop_degenerate, merge_vertices, remove_unused_vertices, report, report_with,
};
pub use crate::cutter::{
    Ball, BullNose, Cutter, CutterShape, EndShape, Flat, Holder, Neck, Solid, Solids, TSlot,
};
pub use crate::error::{GeomError, Result};
pub use crate::io::{
    LoadOptions, MeshFormat, detect_format, load_mesh, load_mesh_with, read_3mf, read_gltf, read_mesh,
    read_obj, read_ply, read_stl, read_stl_with, save_mesh, save_mesh_as, save_step, write_3mf, write_obj,
    write_ply, write_step, write_stl,
};
pub use crate::marching_cubes::{
    McOptions, marching_cubes, marching_cubes_opt, marching_cubes_samples, marching_cubes_samples_opt,
    marching_cubes_voxels, marching_cubes_voxels_opt,
};
pub use crate::math::{Isometry3, Point3, Real, Rotation3, Similarity3, SplitMix64, UnitVector3, Vector3};
pub use crate::mesh::Mesh;
pub use crate::metrics::{MetricOptions, ShapeMetrics, chamfer_and_normals, compare, occupancy_iou};
pub use crate::normalize::{Normalization, normalize_unit_cube, unit_cube_normalization};
pub use crate::query::{
    ClosestPoint, DropCutter, DropCutterOptions, MeshIndex, OccluderCache, ParallelRays, RayHit,
    WaterlineOptions,
};
pub use crate::sample::{SurfaceSamples, sample_surface};
pub use crate::sdf::{BoxShape, SignedDistance, Sphere};
pub use crate::setup::Setup;
pub use crate::smooth::{TAUBIN_LAMBDA, TAUBIN_MU, laplacian_smooth, taubin_smooth};
pub use crate::sweep::{SweepOptions, sweep_profile};
pub use crate::voxel::{BRICK, Brick, GridSpec, VoxelGrid};
pub use crate::voxelize::{VoxelizeOptions, voxelize, voxelize_opt};
