//! The bull nose (corner radius) end mill.

use super::{Ball, EndShape, Flat, Solid, Solids};

/// Bull nose end mill: a flat bottom of radius `radius - corner_radius` rounded by a torus
/// of tube radius `corner_radius` (`0 <= corner_radius <= radius`; the extremes are a flat
/// and a ball end mill).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BullNose {
    /// Corner radius.
    pub corner_radius: f64,
}

impl EndShape for BullNose {
    fn name(&self) -> &'static str {
        "bull"
    }

    fn corner_radius(&self, _radius: f64) -> f64 {
        self.corner_radius
    }

    fn profile(&self, radius: f64, h: f64) -> f64 {
        rounded_profile(radius, self.corner_radius, h)
    }

    fn solids(&self, radius: f64, flute_length: f64) -> Solids {
        let rc = self.corner_radius;
        if rc <= 0.0 {
            Flat.solids(radius, flute_length)
        } else if rc >= radius {
            Ball.solids(radius, flute_length)
        } else {
            Solids::new(&[
                Solid::Torus { c: rc, rp: radius - rc, rc },
                Solid::Cylinder { h0: rc, h1: flute_length, r: radius },
            ])
        }
    }
}

/// The radius at height `h` of an end of `radius` rounded by a corner of radius `rc`:
/// `radius - rc + sqrt(rc^2 - (rc - h)^2)`.
pub(super) fn rounded_profile(radius: f64, rc: f64, h: f64) -> f64 {
    let d = rc - h;
    radius - rc + (rc * rc - d * d).max(0.0).sqrt()
}
