//! The flat end mill.

use super::{EndShape, Solid, Solids};

/// Flat end mill: a cylinder whose bottom face is the tip plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Flat;

impl EndShape for Flat {
    fn name(&self) -> &'static str {
        "flat"
    }

    fn corner_radius(&self, _radius: f64) -> f64 {
        0.0
    }

    fn profile(&self, radius: f64, _h: f64) -> f64 {
        radius
    }

    fn solids(&self, radius: f64, flute_length: f64) -> Solids {
        Solids::new(&[Solid::Cylinder { h0: 0.0, h1: flute_length, r: radius }])
    }
}
