//! What a part is made of, with its parameters: the manifest's `features`.

use serde::Serialize;

/// One feature of a generated part, in the part's units (mm for the shop parts and the
/// default size). Points are `[x, y]` in the part's frame (the base centred on the z
/// axis, its bottom at `z = 0`); `z_top` is the height a cut starts from and `depth`
/// how far it goes down (a cut with `z_top - depth = 0` goes through).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
#[non_exhaustive]
pub enum Feature {
    /// The base block: a rectangle with rounded vertical edges, extruded.
    Block {
        /// Length (x), width (y), height (z).
        size: [f64; 3],
        /// Radius of the vertical edges (0: sharp).
        corner_radius: f64,
    },
    /// The base as a disc (a regular polygon of `segments` sides), extruded.
    Disc {
        /// Diameter (circumscribed).
        diameter: f64,
        /// Height.
        height: f64,
        /// Polygon sides.
        segments: usize,
    },
    /// A chamfer on the base's top edge (a lofted ring: exact).
    Chamfer {
        /// Horizontal and vertical leg.
        size: f64,
    },
    /// A fillet on the base's top edge, as `steps` lofted facets of a quarter circle.
    Fillet {
        /// Radius.
        radius: f64,
        /// Facets.
        steps: usize,
    },
    /// Drafted side walls of the base (a lofted ring: exact), narrowing upwards.
    Draft {
        /// Draft angle from vertical, degrees.
        angle_deg: f64,
    },
    /// A step: the top is lowered to `z` for `x >= x_from`.
    Step {
        /// Where the step starts along x.
        x_from: f64,
        /// Height of the lower level.
        z: f64,
    },
    /// An open slot along x across the whole part (a rectangular channel).
    OpenSlot {
        /// Centre line (y).
        center_y: f64,
        /// Width (y).
        width: f64,
        /// Depth from the top.
        depth: f64,
    },
    /// A T-slot along x across the whole part: a neck from the top and a wider head below.
    TSlot {
        /// Centre line (y).
        center_y: f64,
        /// Neck width.
        neck_width: f64,
        /// Neck depth from the top.
        neck_depth: f64,
        /// Head width.
        head_width: f64,
        /// Head height (below the neck).
        head_height: f64,
    },
    /// A rectangular pocket with rounded corners.
    Pocket {
        /// Centre.
        center: [f64; 2],
        /// Length (x) and width (y) at the top.
        size: [f64; 2],
        /// Corner radius at the top.
        corner_radius: f64,
        /// Top of the pocket.
        z_top: f64,
        /// Depth.
        depth: f64,
        /// Wall draft from vertical, degrees (0: vertical walls).
        draft_deg: f64,
    },
    /// A round pocket.
    CircularPocket {
        /// Centre.
        center: [f64; 2],
        /// Diameter.
        diameter: f64,
        /// Top of the pocket.
        z_top: f64,
        /// Depth.
        depth: f64,
    },
    /// A drilled hole, through or blind, optionally countersunk (a lofted cone).
    Hole {
        /// Centre.
        center: [f64; 2],
        /// Diameter.
        diameter: f64,
        /// Top of the hole.
        z_top: f64,
        /// Depth.
        depth: f64,
        /// Countersink leg (0: none).
        countersink: f64,
    },
    /// A counterbored hole: a hole with a wider, shallower bore on top.
    Counterbore {
        /// Centre.
        center: [f64; 2],
        /// Hole diameter.
        diameter: f64,
        /// Counterbore diameter.
        bore_diameter: f64,
        /// Counterbore depth.
        bore_depth: f64,
        /// Top of the counterbore.
        z_top: f64,
        /// Total depth (counterbore and hole).
        depth: f64,
    },
    /// An obround slot, through or blind.
    Slot {
        /// Centre.
        center: [f64; 2],
        /// Length end to end.
        length: f64,
        /// Width.
        width: f64,
        /// Whether it runs along x (else along y).
        along_x: bool,
        /// Top of the slot.
        z_top: f64,
        /// Depth.
        depth: f64,
    },
    /// A round boss standing on a face, optionally chamfered at its top.
    Boss {
        /// Centre.
        center: [f64; 2],
        /// Diameter.
        diameter: f64,
        /// Height of the face it stands on.
        z_base: f64,
        /// Height above that face.
        height: f64,
        /// Top chamfer leg (0: none).
        chamfer: f64,
    },
    /// A rib: a thin rectangular wall standing on a face.
    Rib {
        /// Centre.
        center: [f64; 2],
        /// Length (x) and thickness (y), or the reverse.
        size: [f64; 2],
        /// Height of the face it stands on.
        z_base: f64,
        /// Height above that face.
        height: f64,
    },
    /// A turned part: a profile revolved about the z axis in `segments` facets.
    Revolved {
        /// Length along z.
        length: f64,
        /// Largest diameter.
        max_diameter: f64,
        /// Facets around the axis.
        segments: usize,
    },
    /// A turned section: a cylinder of `diameter` from `z0` to `z1` (shoulders are
    /// where sections change diameter).
    Section {
        /// Bottom.
        z0: f64,
        /// Top.
        z1: f64,
        /// Diameter.
        diameter: f64,
    },
    /// A groove turned into a section.
    Groove {
        /// Centre height.
        z: f64,
        /// Width (z).
        width: f64,
        /// Diameter at the bottom of the groove.
        diameter: f64,
    },
    /// A chamfer on a turned part's end or shoulder.
    TurnedChamfer {
        /// Height of the edge.
        z: f64,
        /// Leg.
        size: f64,
    },
    /// An axial bore, through or blind from the top.
    Bore {
        /// Diameter.
        diameter: f64,
        /// Depth from the top (the length for a through bore).
        depth: f64,
    },
    /// A freeform block: a smooth height field over a rectangle, flat bottom.
    HeightField {
        /// Length (x) and width (y).
        size: [f64; 2],
        /// Base height the bumps add to.
        base_height: f64,
        /// Grid cells along x and y.
        grid: [usize; 2],
    },
    /// A Gaussian bump (or dent, with a negative height) blended into a height field.
    Bump {
        /// Centre.
        center: [f64; 2],
        /// Standard deviation.
        radius: f64,
        /// Amplitude.
        height: f64,
    },
    /// A sinusoidal wave across a height field.
    Wave {
        /// Wavelengths along x and y.
        wavelength: [f64; 2],
        /// Amplitude.
        amplitude: f64,
    },
}
