//! The generator's one error type.

use thiserror::Error;

/// What can go wrong when generating parts.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum GenError {
    /// An option is out of its range (a size that is not finite and positive, ...).
    #[error("invalid option {name}: {reason}")]
    InvalidOption {
        /// The option's name.
        name: &'static str,
        /// Why it was refused.
        reason: String,
    },
    /// A part kind that is not one of the known names.
    #[error("unknown part kind '{0}' (expected prismatic, turned, freeform, mix or shop)")]
    UnknownKind(String),
    /// The description of a solid is not one the mesher can close exactly (rings that
    /// cross or touch, levels out of order). A generator bug, never the user's input.
    #[error("the part's description is not a valid solid: {0}")]
    Geometry(String),
    /// The mesh could not be assembled (a non-finite coordinate).
    #[error("cannot assemble the mesh")]
    Mesh(#[source] s2g_geom::GeomError),
}

/// The generator's result type.
pub type Result<T> = std::result::Result<T, GenError>;

/// A [`GenError::Geometry`] from a message.
pub(crate) fn geometry(msg: impl Into<String>) -> GenError {
    GenError::Geometry(msg.into())
}
