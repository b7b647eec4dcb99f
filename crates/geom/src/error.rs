//! The crate's error type.

use std::path::PathBuf;

/// Everything geom can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GeomError {
    /// Reading or writing a file failed.
    #[error("{path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// A mesh file is malformed; `line` is 1-based where the format has lines.
    #[error("{path}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The line of the defect, where the format has lines.
        line: Option<u64>,
        /// What is wrong.
        message: String,
    },
    /// The file's format is not one we read or write.
    #[error("{path}: unsupported mesh format ({reason})")]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
        /// Why it was not recognised.
        reason: String,
    },
    /// A mesh has no triangles where some are needed.
    #[error("the mesh has no triangles")]
    EmptyMesh,
    /// A coordinate is NaN or infinite.
    #[error("non-finite coordinate at vertex {vertex}")]
    NonFinite {
        /// Index of the offending vertex.
        vertex: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {vertex}, but there are only {vertices} vertices")]
    BadIndex {
        /// Index of the triangle.
        triangle: usize,
        /// The bad vertex index.
        vertex: u32,
        /// Number of vertices.
        vertices: usize,
    },
    /// An argument is out of its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// A cutter's dimensions are impossible (non-finite or non-positive size, corner radius
    /// above the radius, flute shorter than the rounded end, ...).
    #[error("invalid tool: {0}")]
    InvalidTool(String),
    /// Two voxel grids do not share the same layout.
    #[error("voxel grids differ in bounds or resolution")]
    GridMismatch,
}

/// Shorthand for geom results.
pub type Result<T, E = GeomError> = std::result::Result<T, E>;
