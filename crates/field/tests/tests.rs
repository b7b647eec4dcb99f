//! Integration tests of s2g-field: one binary, one module per topic.

mod additive;
mod aligned;
mod derivatives;
mod errors;
mod layer;
mod milling;
mod path;
mod print;
mod sdf;
