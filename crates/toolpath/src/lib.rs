//! `s2g-toolpath`: see the crate description.
