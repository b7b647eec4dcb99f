//! The crate's error type.

/// Everything the simulator can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// A cutter or bead description is impossible (non-finite or non-positive size, corner
    /// radius above the radius, flute shorter than the rounded end, ...).
    #[error("invalid tool: {0}")]
    InvalidTool(String),
    /// A motion carries a non-finite coordinate or frame.
    #[error("line {line}: invalid motion: {message}")]
    InvalidMotion {
        /// The source line the motion came from (0 when none was reported).
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// An option is out of its valid range.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// Stock and target grids do not share the same [`s2g_geom::GridSpec`].
    #[error("the target grid does not match the stock grid (bounds or resolution differ)")]
    GridMismatch,
    /// A geometry operation failed.
    #[error(transparent)]
    Geom(#[from] s2g_geom::GeomError),
    /// Parsing the program failed (the parser's message, with its line).
    #[error("{0}")]
    Parse(String),
}

/// Shorthand for simulator results.
pub type Result<T, E = SimError> = std::result::Result<T, E>;
