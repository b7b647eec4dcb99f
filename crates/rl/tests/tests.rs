//! Integration tests of s2g-rl: one binary, one module per topic, small environments with
//! known optimal policies in `envs`.

mod envs;

mod checkpoint;
mod determinism;
mod dgcnn;
mod errors;
mod learning;
