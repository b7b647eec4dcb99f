//! The crate's one error type.

use std::path::PathBuf;

/// Everything that can go wrong in this crate.
///
/// Bad configurations, unusable training data (empty meshes, NaN samples), unreadable
/// files and backend failures all come back as a variant of this enum; no public function
/// of this crate panics on such input.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FieldError {
    /// A configuration field is out of range.
    #[error("invalid configuration: `{field}` {reason}")]
    InvalidConfig {
        /// The offending field.
        field: &'static str,
        /// Why its value was refused.
        reason: String,
    },
    /// An argument no field can work with: no points, mismatched lengths, a degenerate box.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// An input point, normal or distance is NaN or infinite.
    #[error("{what} {index} is not finite")]
    NonFinite {
        /// What kind of value it is ("surface point", "normal", ...).
        what: &'static str,
        /// Index of the first bad value.
        index: usize,
    },
    /// The mesh has no triangles (or no area to sample).
    #[error("the mesh is empty or has no surface area")]
    EmptyMesh,
    /// Training diverged: the loss became NaN or infinite.
    #[error("training diverged: loss is {loss} at step {step}")]
    Diverged {
        /// The non-finite loss.
        loss: f32,
        /// The step at which it appeared.
        step: usize,
    },
    /// A geometry operation from `s2g-geom` failed (sampling, indexing, saving a file).
    #[error("geometry")]
    Geometry(#[source] s2g_geom::GeomError),
    /// A file could not be read or written.
    #[error("{}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A saved field is malformed or was written for another network shape.
    #[error("field file {}: {reason}", path.display())]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// The tensor backend reported a failure (reading data back, applying a record).
    #[error("tensor backend: {0}")]
    Backend(String),
    /// A written program does not parse back (the parser's first error).
    #[error("reading the program back: {0}")]
    Program(String),
    /// The G-code writer failed (an arc it could not linearise, a number not finite).
    #[error("writing the program")]
    Write(#[source] s2g_gcode::WriteError),
    /// Simulating a milling program failed (its parse or the simulator stopped it).
    #[error("simulating the program")]
    Simulation(#[source] s2g_voxsim::SimError),
}

impl FieldError {
    pub(crate) fn config(field: &'static str, reason: impl Into<String>) -> Self {
        Self::InvalidConfig { field, reason: reason.into() }
    }

    /// The first of `fields` (name, value) that is not finite and `>= 0`, as an error.
    pub(crate) fn check_non_negative(fields: &[(&'static str, f64)]) -> Result<(), Self> {
        match fields.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
            Some(&(field, v)) => Err(Self::config(field, format!("must be finite and >= 0, got {v}"))),
            None => Ok(()),
        }
    }

    /// The first of `fields` (name, value) that is not finite and `> 0`, as an error.
    pub(crate) fn check_positive(fields: &[(&'static str, f64)]) -> Result<(), Self> {
        match fields.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
            Some(&(field, v)) => Err(Self::config(field, format!("must be finite and > 0, got {v}"))),
            None => Ok(()),
        }
    }

    pub(crate) fn geom(e: s2g_geom::GeomError) -> Self {
        match e {
            s2g_geom::GeomError::EmptyMesh => Self::EmptyMesh,
            e => Self::Geometry(e),
        }
    }

    pub(crate) fn backend(e: impl std::fmt::Debug) -> Self {
        Self::Backend(format!("{e:?}"))
    }
}

/// This crate's result type.
pub type Result<T, E = FieldError> = std::result::Result<T, E>;
