//! The T-slot (disc) cutter.

use super::{EndShape, Solid, Solids};

/// T-slot cutter: a flat-faced disc (the flutes, as thick as the flute length) on a neck
/// narrower than the disc ([`Neck`](super::Neck), which [`Cutter::validate`](super::Cutter::validate)
/// requires). It cuts from the side, under an overhang: fed horizontally at a slot's
/// depth, the neck passing through the slot above. It neither plunges nor roughs from
/// above, so the roughing, rest and finishing tool choices leave it out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TSlot;

impl EndShape for TSlot {
    fn name(&self) -> &'static str {
        "tslot"
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
