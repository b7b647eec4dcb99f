//! End-to-end tests of the whole system on the bundled sample data.

mod e2e {
    mod arcs;
    pub mod common;
    mod fdm;
    mod feature;
    mod finish;
    mod grid_space;
    #[cfg(feature = "learn")]
    mod learn;
    mod mill;
    mod shard;
    mod shop;
    mod stock;
}
