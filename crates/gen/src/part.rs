//! The public face of the generator: kinds, options, parts.

use std::fmt;
use std::str::FromStr;

use s2g_geom::{Mesh, SplitMix64};

use crate::error::{GenError, Result};
use crate::feature::Feature;
use crate::freeform::freeform;
use crate::random_prism::prismatic;
use crate::shop::{SHOP_PARTS, shop_prism};
use crate::turned::{TURNED_SEGMENTS, turned};

/// Which parts to generate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Kind {
    /// 2.5-D milled parts: blocks or discs with pockets, holes, slots, bosses, ribs,
    /// steps, T-slots, chamfers, fillets, drafts.
    Prismatic,
    /// Revolved profiles: sections, shoulders, grooves, chamfers, bores.
    Turned,
    /// Blocks with a smooth height-field top.
    Freeform,
    /// A mixture in the proportions [`MIX`]. The default.
    #[default]
    Mix,
    /// The five named shop parts ([`SHOP_PARTS`]); fixed, in mm, no seed or size.
    Shop,
}

impl Kind {
    /// Every kind, in the order of their names.
    pub const ALL: [Kind; 5] = [Kind::Prismatic, Kind::Turned, Kind::Freeform, Kind::Mix, Kind::Shop];

    /// The kind's name, as [`FromStr`] reads it.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Prismatic => "prismatic",
            Kind::Turned => "turned",
            Kind::Freeform => "freeform",
            Kind::Mix => "mix",
            Kind::Shop => "shop",
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Kind {
    type Err = GenError;
    fn from_str(s: &str) -> Result<Self> {
        Kind::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| GenError::UnknownKind(s.to_string()))
    }
}

/// The kind of [`Kind::Mix`] a part is drawn as, with its probability: prismatic 1/2,
/// turned 1/4, freeform 1/4.
pub const MIX: [(Kind, f64); 3] = [(Kind::Prismatic, 0.5), (Kind::Turned, 0.25), (Kind::Freeform, 0.25)];

/// The smallest `size` accepted: below it the 2^-12 grid would distort features.
pub const MIN_SIZE: f64 = 1.0;
/// The largest `size` accepted: coordinates stay exact in f32 (see [`crate::QUANTUM`]).
pub const MAX_SIZE: f64 = 1000.0;

/// Options of [`generate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GenOptions {
    /// Which parts. Default [`Kind::Mix`].
    pub kind: Kind,
    /// The longest side of a generated part, in the mesh's units (mm). Default 100;
    /// [`MIN_SIZE`] to [`MAX_SIZE`]. The shop parts ignore it.
    pub size: f64,
}

impl Default for GenOptions {
    fn default() -> Self {
        Self { kind: Kind::Mix, size: 100.0 }
    }
}

impl GenOptions {
    /// Checks the options: [`GenError::InvalidOption`] for a size that is not finite or
    /// outside [`MIN_SIZE`]..=[`MAX_SIZE`].
    pub fn validate(&self) -> Result<()> {
        if !self.size.is_finite() || !(MIN_SIZE..=MAX_SIZE).contains(&self.size) {
            return Err(GenError::InvalidOption {
                name: "size",
                reason: format!("{} is not a length from {MIN_SIZE} to {MAX_SIZE}", self.size),
            });
        }
        Ok(())
    }
}

/// One generated part.
#[derive(Debug, Clone)]
pub struct Part {
    /// A file-friendly name: `<kind>_<index>` (five digits), or the shop part's name.
    pub name: String,
    /// What was generated: prismatic, turned or freeform (never mix or shop).
    pub kind: Kind,
    /// The features and their parameters, base first.
    pub features: Vec<Feature>,
    /// The closed, manifold, outward-wound mesh. Prismatic and freeform parts have all
    /// coordinates on the 2^-12 grid, so a binary STL stores them exactly; a turned part's
    /// vertices are rounded to f32 by STL.
    pub mesh: Mesh,
    /// The exact volume by the part's own formula (slab prismatoids, polygonal
    /// revolution, height-field integral), which the mesh's signed volume matches to
    /// rounding.
    pub volume: f64,
}

/// The part `index` of the stream `seed`: a pure function of `(seed, index, options)`,
/// so part `i` is the same whatever the count, and the same bytes on every platform
/// (SplitMix64, no global state). For [`Kind::Shop`], the shop part at `index` (0-4;
/// the seed is ignored).
pub fn generate(seed: u64, index: u64, options: &GenOptions) -> Result<Part> {
    options.validate()?;
    let mut rng = SplitMix64::new(seed, index);
    let kind = match options.kind {
        Kind::Shop => return shop_part(index),
        Kind::Mix => {
            let u = rng.unit();
            let mut acc = 0.0;
            MIX.iter()
                .find(|(_, p)| {
                    acc += p;
                    u < acc
                })
                .map_or(Kind::Freeform, |m| m.0)
        }
        k => k,
    };
    let name = format!("{kind}_{index:05}");
    let size = options.size;
    match kind {
        Kind::Turned => {
            let (profile, features) = turned(&mut rng, size);
            let mesh = profile.revolve(TURNED_SEGMENTS)?;
            Ok(Part { name, kind, features, mesh, volume: profile.volume(TURNED_SEGMENTS) })
        }
        Kind::Freeform => {
            let h = freeform(&mut rng, size)?;
            Ok(Part { name, kind, features: h.features, mesh: h.mesh, volume: h.volume })
        }
        _ => {
            let prism = prismatic(&mut rng, size);
            let built = prism.build()?;
            Ok(Part {
                name,
                kind: Kind::Prismatic,
                features: prism.features,
                mesh: built.mesh,
                volume: built.volume,
            })
        }
    }
}

/// The shop part at `index` (in [`SHOP_PARTS`] order); [`GenError::InvalidOption`]
/// (`index`) past the fifth.
pub fn shop_part(index: u64) -> Result<Part> {
    let i = usize::try_from(index).unwrap_or(usize::MAX);
    let prism = shop_prism(i).ok_or_else(|| GenError::InvalidOption {
        name: "index",
        reason: format!("there are {} shop parts, {index} is past them", SHOP_PARTS.len()),
    })?;
    let built = prism.build()?;
    Ok(Part {
        name: SHOP_PARTS[i].to_string(),
        kind: Kind::Prismatic,
        features: prism.features,
        mesh: built.mesh,
        volume: built.volume,
    })
}

/// The five shop parts, in [`SHOP_PARTS`] order.
pub fn shop_parts() -> Result<Vec<Part>> {
    (0..SHOP_PARTS.len() as u64).map(shop_part).collect()
}
