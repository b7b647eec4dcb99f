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
