//! `s2g-voxsim`: see the crate description.
