//! `s2g-gen`: a deterministic generator of CAD-like parts, the test and training corpus
//! of Shape2Gcode (issue 37), and the named shop parts of issue 35.
//!
//! - **Prismatic** (2.5-D) parts are stacks of slabs, each an extrusion (or a linear
//!   loft, for chamfers, drafts, countersinks and faceted fillets) of a polygon with
//!   holes: a base with pockets at several floor depths, through and blind holes,
//!   counterbores, slots, bosses, ribs, steps, open slots and T-slots. The mesh is the
//!   slabs' side walls plus, at each slab boundary, the difference between the
//!   cross-sections below and above, triangulated (a constrained Delaunay triangulation
//!   with exact predicates). All coordinates lie on a 2^-12 grid ([`QUANTUM`]), where
//!   "this vertex lies on that edge" is decided exactly, so walls and faces share every
//!   vertex: closed, 2-manifold and outward-wound by construction, with the volume the
//!   sum of the slabs' prismatoid volumes (area times height for a straight slab).
//! - **Turned** parts revolve an `(r, z)` profile in 96 facets; their volume is the
//!   polygonal-revolution formula. No cross holes (they need a mesh boolean).
//! - **Freeform** parts are blocks with a smooth height-field top; their volume is the
//!   integral of the piecewise-linear top.
//!
//! [`generate`] is a pure function of `(seed, index, options)` built on geom's
//! SplitMix64, so the same seed gives the same parts, bit for bit.
//!
//! ```
//! use s2g_gen::{GenOptions, Kind, generate};
//! use s2g_geom::report;
//! let part = generate(7, 0, &GenOptions { kind: Kind::Prismatic, size: 80.0 }).unwrap();
//! let r = report(&part.mesh);
//! assert!(r.closed && r.manifold && r.consistently_oriented);
//! assert!((r.volume - part.volume).abs() <= 1e-9 * part.volume);
//! ```

mod error;
mod face;
mod feature;
mod freeform;
mod level;
mod part;
mod prism;
mod random_prism;
mod ring;
mod shop;
mod stack;
mod turned;

pub use crate::error::{GenError, Result};
pub use crate::feature::Feature;
pub use crate::part::{GenOptions, Kind, MAX_SIZE, MIN_SIZE, MIX, Part, generate, shop_part, shop_parts};
pub use crate::ring::{MAX_COORD, QUANTUM};
pub use crate::shop::SHOP_PARTS;
