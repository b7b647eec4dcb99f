//! The T-slot (disc) cutter.

use super::flat::Flat;
use super::{EndShape, Solids};

/// T-slot cutter: a flat-faced disc (the flutes, as thick as the flute length) on a neck
/// narrower than the disc ([`Neck`](super::Neck), which [`Cutter::validate`](super::Cutter::validate)
/// requires). It cuts from the side, under an overhang: fed horizontally at a slot's
/// depth, the neck passing through the slot above. It neither plunges nor roughs from
/// above, so the roughing, rest and finishing tool choices leave it out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TSlot;

/// The disc's end is a flat end mill's: the same profile and solid.
impl EndShape for TSlot {
    fn name(&self) -> &'static str {
        "tslot"
    }

    fn corner_radius(&self, radius: f64) -> f64 {
        Flat.corner_radius(radius)
    }

    fn profile(&self, radius: f64, h: f64) -> f64 {
        Flat.profile(radius, h)
    }

    fn solids(&self, radius: f64, flute_length: f64) -> Solids {
        Flat.solids(radius, flute_length)
    }
}
