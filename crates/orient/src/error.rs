//! The crate's error type.

use s2g_geom::GeomError;

/// Everything orientation selection and reconstruction can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OrientError {
    /// A geometry operation (sampling, BVH, voxelisation, meshing) failed.
    #[error(transparent)]
    Geom(#[from] GeomError),
    /// An option or argument is out of its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// The mesh has no usable surface (no triangles, or all degenerate).
    #[error("the mesh has no usable surface: {0}")]
    NoSurface(String),
}

/// Shorthand for orient results.
pub type Result<T, E = OrientError> = std::result::Result<T, E>;
