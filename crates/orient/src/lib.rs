//! `s2g-orient`: see the crate description.
