//! The crate's error type.

/// Everything planning can fail with; `E` is the motion sink's error.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ToolpathError<E> {
    /// The tool cannot exist (non-positive or non-finite radius, a corner radius larger
    /// than the tool radius, non-positive feeds, ...).
    #[error("invalid tool: {0}")]
    InvalidTool(String),
    /// A planning option is out of range.
    #[error("invalid option: {0}")]
    InvalidOptions(String),
    /// The part mesh has no triangles.
    #[error("the part mesh has no triangles")]
    EmptyMesh,
    /// The stock box is invalid (not finite, or min above max).
    #[error("invalid stock box: {0}")]
    InvalidStock(String),
    /// Planning was cancelled ([`PlanProgress::cancel`](crate::PlanProgress::cancel)).
    #[error("cancelled")]
    Cancelled,
    /// A finishing strategy failed (its error says why).
    #[error("finishing strategy failed")]
    Finish(#[source] crate::finish::FinishError),
    /// The motion sink refused a motion.
    #[error("the motion sink failed: {0}")]
    Sink(E),
}

impl ToolpathError<std::convert::Infallible> {
    /// The error of a planner without a sink (which cannot fail with a sink's error) as
    /// one with any sink's error type.
    pub fn widen<E>(self) -> ToolpathError<E> {
        match self {
            ToolpathError::InvalidTool(m) => ToolpathError::InvalidTool(m),
            ToolpathError::InvalidOptions(m) => ToolpathError::InvalidOptions(m),
            ToolpathError::EmptyMesh => ToolpathError::EmptyMesh,
            ToolpathError::InvalidStock(m) => ToolpathError::InvalidStock(m),
            ToolpathError::Cancelled => ToolpathError::Cancelled,
            ToolpathError::Finish(f) => ToolpathError::Finish(f),
            ToolpathError::Sink(never) => match never {},
        }
    }
}
