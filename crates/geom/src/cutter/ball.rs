//! The ball end mill.

use super::{EndShape, Solid, Solids};

/// Ball end mill: a hemisphere of the tool radius at the bottom, centred at
/// `tip + radius * axis`, below a cylinder.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Ball;

impl EndShape for Ball {
    fn name(&self) -> &'static str {
        "ball"
    }

    fn corner_radius(&self, radius: f64) -> f64 {
        radius
    }

    fn profile(&self, radius: f64, h: f64) -> f64 {
        super::bull::rounded_profile(radius, radius, h)
    }

    fn solids(&self, radius: f64, flute_length: f64) -> Solids {
        Solids::new(&[Solid::Ball { c: radius, r: radius }, Solid::Cylinder { h0: radius, h1: flute_length, r: radius }])
    }
}
