//! Drop-cutter and waterline against brute force, analytic answers and moved meshes.

mod drop;
mod per_call;
mod shapes;
mod waterline;
