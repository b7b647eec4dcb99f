//! FDM reconstruction (seed 004): G-code back to the printed geometry.
//!
//! parse ([`crate::gcode::parse_str`]) -> extrusion spines ([`crate::gcode::SpineBuilder`])
//! -> bead sizes ([`extract_beads`]) -> either
//!
//! * **solid** ([`solid_mesh`]): every bead deposited as voxels on a grid that resolves
//!   the bead, then marching cubes: one closed, manifold surface of the union of the beads
//!   (internal voids of sparse infill included), or
//! * **tubes** ([`tube_mesh`]): each spine swept with the chosen profile into a closed tube
//!   (the paper's output, one body per spine), with mitred joints so consecutive segments
//!   leave no gap; spines whose ends meet become closed rings.
//!
//! # Bead sizes
//!
//! `auto` layer height: the top of layer *i* is the median Z of its spines' points (layers
//! from the slicer's markers, or Z steps without markers); its height is the step from the
//! layer below (layer 0: its top above the bed at Z = 0). Steps that are not positive or
//! exceed [`FdmOptions::max_height_ratio`] times the median step are replaced by the
//! median step. `auto` width: each segment's cross-section area is its extruded volume
//! (E x filament area) over its length; the profile is sized so that its area equals that,
//! so every profile conserves the extruded volume:
//!
//! * rectangle: width `A / h`;
//! * slot (a rectangle with half-discs on both sides, the nozzle shape of the paper's
//!   Fig. 4): width `A / h + h (1 - pi / 4)` (at least `h`);
//! * circle: diameter `sqrt(4 A / pi)`, hanging below the nozzle tip.
//!
//! A fixed width or layer height overrides (the area then follows from the profile).
//! Areas are clamped to [`FdmOptions::area_clamp`] times the median either way, so that
//! rounding of E on very short moves cannot produce absurd beads.
//!
//! # Solid
//!
//! The solid's beads have the equal-area rectangle cross-section (slot: with round ends in
//! plan view, so joints and corners fill; rectangle: flat ends; circle: capsules). Voxels
//! are `res` wide in X and Y and an integer fraction of the median layer height in Z,
//! aligned to the layer boundaries; a voxel is set iff its centre is inside a bead.
//!
//! Deposition, measured (the dog-bone at 100 % infill, 18 043 beads, 2 cores; `benches/fdm.rs`):
//! [`Deposition::Raster`] (default) rasterises the horizontal beads slice by slice with
//! analytic row intervals, slices in parallel (44 ms); voxsim's additive mode
//! ([`crate::voxsim::Simulator::depositor`], general exact swept volumes, one depositor per
//! bead size quantised to [`FdmOptions::size_quantum`]) takes 1.6 s, and is still used for
//! beads that climb more than half a voxel (and for all beads with [`Deposition::Voxsim`]);
//! the two agree to within 1 % of the voxels (tested).
//!
//! Beads as sliced overlap (infill into perimeters, grid infill crossing itself), so their
//! union holds 2-7 % less than the extruded filament on the test prints (circles: 20-30 %,
//! they also overlap between layers). Real material is squeezed into the neighbouring gaps,
//! so by default ([`FdmOptions::match_volume`]) the bead widths are scaled until the voxel
//! volume matches the extruded volume (the scale is in the report).
//!
//! # Bad input
//!
//! Lines the parser rejects have no effect and each becomes a warning naming its line
//! ([`FdmOptions::strict`] turns the first into an error); a last line without a newline is
//! taken as truncated and dropped with a warning (see [`FdmOptions::drop_unterminated_last_line`]);
//! a program that extrudes nothing is [`FdmError::NoExtrusion`].

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;
use serde::Serialize;

use crate::gcode::{
    Motion, MotionSink, ParseDialect, ParseOptions, SpineBuilder, SpineOptions, SpineRule, parse_str,
};
use crate::geom::{
    Aabb, GridSpec, Mesh, Point3, SweepOptions, Vector3, VoxelGrid, marching_cubes_voxels, sweep_profile,
};
use crate::voxsim::{BeadProfile, SimOptions, Simulator};

mod raster;
mod solid;
mod tubes;

pub use self::solid::{
    Solid, deposit_beads, deposit_beads_naive, indexed_check, solid_grid_spec, solid_mesh,
};
pub use self::tubes::{sweep_spine, tube_mesh};
pub use crate::geom::{save_step, write_step};

/// How the solid's beads are turned into voxels (same voxel-centre rule either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Deposition {
    /// Horizontal beads are rasterised slice by slice (analytic row intervals, slices in
    /// parallel); beads that climb more than half a voxel go to voxsim. Default.
    #[default]
    Raster,
    /// Every bead goes through voxsim's additive mode (general exact swept volumes).
    Voxsim,
}

/// Cross-section swept along the extrusion paths (seed 004 Fig. 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BeadShape {
    /// A circle below the nozzle tip.
    Circle,
    /// A rectangle `width x height` below the nozzle tip.
    Rect,
    /// A rectangle with half-disc sides (the paper's slot, closest to a real bead). Default.
    #[default]
    Slot,
}

/// What [`reconstruct`] builds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FdmOutput {
    /// One watertight solid: the union of the beads (voxels + marching cubes). Default.
    #[default]
    Solid,
    /// One closed tube per spine (the paper's output), in one mesh.
    Tubes,
}

/// Options of the FDM reconstruction. `Default` gives the documented defaults.
#[derive(Debug, Clone, PartialEq)]
pub struct FdmOptions {
    /// Bead cross-section. Default [`BeadShape::Slot`].
    pub profile: BeadShape,
    /// Solid or tubes. Default [`FdmOutput::Solid`].
    pub output: FdmOutput,
    /// Fixed bead width (circle: diameter) in mm; `None` (default): from the extruded volume.
    pub width: Option<f64>,
    /// Fixed layer height in mm; `None` (default): from the layers' Z.
    pub layer_height: Option<f64>,
    /// Filament diameter in mm. Default 1.75.
    pub filament_diameter: f64,
    /// Voxel edge in X and Y for the solid, in mm; `None` (default): a quarter of the median
    /// bead width. Z voxels are the median layer height divided by the nearest whole number
    /// to `height / res`.
    pub resolution: Option<f64>,
    /// Deposition algorithm of the solid. Default [`Deposition::Raster`].
    pub deposition: Deposition,
    /// Scale the solid's bead widths so that the union's voxel volume matches the extruded
    /// volume (overlapping beads, e.g. infill crossing itself or the perimeters, otherwise
    /// lose the overlap: real material is squeezed into the neighbouring gaps). Default true.
    pub match_volume: bool,
    /// Relative volume mismatch at which the width scaling stops. Default 0.005.
    pub match_tolerance: f64,
    /// Most depositions spent on the width scaling. Default 6.
    pub match_iterations: usize,
    /// The width scaling stays within `[1 / m, m]`. Default 2.
    pub max_area_scale: f64,
    /// Largest voxel count of the solid's grid (error above). Default 2e9.
    pub max_voxels: u64,
    /// Which moves extrude. Default [`SpineRule::ExtrusionIncrement`].
    pub rule: SpineRule,
    /// Segments of a full circle in the circle profile (slot: half of it per side). Default 16.
    pub circle_segments: usize,
    /// Largest stretch of a mitred joint (1 / cos of half the turn). Default 4.
    pub miter_limit: f64,
    /// Bead areas are clamped to `[median / c, median * c]`. Default 4.
    pub area_clamp: f64,
    /// Layer steps above this multiple of the median step are replaced by it. Default 3.
    pub max_height_ratio: f64,
    /// Layer height used when there is nothing to measure (a single layer printed at Z <= 0). Default 0.2.
    pub fallback_layer_height: f64,
    /// Spine ends closer than this (mm) make a closed ring in tubes. Default 1e-3.
    pub loop_tolerance: f64,
    /// Bead widths and heights are rounded to multiples of this (mm) to group the solid's
    /// depositions. Default 1e-3.
    pub size_quantum: f64,
    /// Stop at the first G-code error instead of warning and skipping the line. Default false.
    pub strict: bool,
    /// Drop a last line that has no newline (a truncated file), with a warning. Default true.
    pub drop_unterminated_last_line: bool,
}

impl Default for FdmOptions {
    fn default() -> Self {
        FdmOptions {
            profile: BeadShape::Slot,
            output: FdmOutput::Solid,
            width: None,
            layer_height: None,
            filament_diameter: 1.75,
            resolution: None,
            deposition: Deposition::Raster,
            match_volume: true,
            match_tolerance: 0.005,
            match_iterations: 6,
            max_area_scale: 2.0,
            max_voxels: 2_000_000_000,
            rule: SpineRule::ExtrusionIncrement,
            circle_segments: 16,
            miter_limit: 4.0,
            area_clamp: 4.0,
            max_height_ratio: 3.0,
            fallback_layer_height: 0.2,
            loop_tolerance: 1e-3,
            size_quantum: 1e-3,
            strict: false,
            drop_unterminated_last_line: true,
        }
    }
}

impl FdmOptions {
    fn validate(&self) -> Result<(), FdmError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let bad = |m: &str| Err(FdmError::InvalidOption(m.to_string()));
        if let Some(w) = self.width
            && !pos(w)
        {
            return bad("width must be finite and > 0");
        }
        if let Some(h) = self.layer_height
            && !pos(h)
        {
            return bad("layer height must be finite and > 0");
        }
        if let Some(r) = self.resolution
            && !pos(r)
        {
            return bad("resolution must be finite and > 0");
        }
        if !pos(self.filament_diameter) {
            return bad("filament diameter must be finite and > 0");
        }
        if !(self.miter_limit.is_finite() && self.miter_limit >= 1.0) {
            return bad("miter limit must be finite and >= 1");
        }
        if !(self.area_clamp.is_finite() && self.area_clamp >= 1.0) {
            return bad("area clamp must be finite and >= 1");
        }
        if !(self.max_height_ratio.is_finite() && self.max_height_ratio >= 1.0) {
            return bad("max height ratio must be finite and >= 1");
        }
        if !pos(self.fallback_layer_height) || !pos(self.size_quantum) || !self.loop_tolerance.is_finite() {
            return bad("fallback layer height and size quantum must be > 0, loop tolerance finite");
        }
        if !(self.match_tolerance.is_finite() && self.match_tolerance > 0.0)
            || self.match_iterations == 0
            || !(self.max_area_scale.is_finite() && self.max_area_scale >= 1.0)
        {
            return bad("match tolerance must be > 0 and match iterations >= 1");
        }
        if self.circle_segments < 4 {
            return bad("circle segments must be >= 4");
        }
        Ok(())
    }
}

/// Why a reconstruction failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FdmError {
    /// An option is out of range.
    #[error("invalid option: {0}")]
    InvalidOption(String),
    /// The first G-code error, with [`FdmOptions::strict`].
    #[error("{0}")]
    Gcode(String),
    /// Reading the file failed.
    #[error("{path}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// Nothing in the program extrudes (not an FDM program, or cut before the first layer).
    #[error("no extrusion moves found ({lines} lines read, {errors} bad lines)")]
    NoExtrusion {
        /// Lines read.
        lines: u64,
        /// Lines rejected by the parser.
        errors: usize,
    },
    /// The solid's grid would be too large.
    #[error("solid grid of {voxels} voxels exceeds the limit of {limit}: use a coarser --res")]
    TooManyVoxels {
        /// Voxels needed.
        voxels: u64,
        /// [`FdmOptions::max_voxels`].
        limit: u64,
    },
    /// The deposition failed.
    #[error("deposition")]
    Sim(#[from] crate::voxsim::SimError),
    /// A geometry operation failed.
    #[error("geometry")]
    Geom(#[from] crate::geom::GeomError),
}

/// One straight piece of bead.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bead {
    /// Start (nozzle tip), mm.
    pub a: Point3,
    /// End (nozzle tip), mm.
    pub b: Point3,
    /// Cross-section area, mm^2 (clamped, see [`FdmOptions::area_clamp`]).
    pub area: f64,
    /// Layer height, mm.
    pub height: f64,
    /// Index of its spine.
    pub spine: u32,
}

impl Bead {
    /// Length, mm.
    pub fn length(&self) -> f64 {
        (self.b - self.a).norm()
    }
}

/// The extrusion of a program: spines, bead sizes and what parsing saw.
#[derive(Debug, Clone, PartialEq)]
pub struct Extrusion {
    /// Spine point lists (consecutive duplicates removed), in program order.
    pub spines: Vec<Vec<Point3>>,
    /// Layer of each spine.
    pub spine_layers: Vec<usize>,
    /// Beads (one per spine segment), in program order.
    pub beads: Vec<Bead>,
    /// Number of layers.
    pub layers: usize,
    /// Height of each layer, mm.
    pub layer_heights: Vec<f64>,
    /// Extruded filament volume, mm^3 (sum of the moves' E x filament area).
    pub extruded_volume: f64,
    /// Lines read.
    pub lines: u64,
    /// Warnings (bad or truncated lines), each naming its line.
    pub warnings: Vec<String>,
}

impl Extrusion {
    /// Median bead area, mm^2 (0 without beads).
    pub fn median_area(&self) -> f64 {
        median(self.beads.iter().map(|b| b.area).collect())
    }

    /// Median layer height, mm (0 without layers).
    pub fn median_height(&self) -> f64 {
        median(self.beads.iter().map(|b| b.height).collect())
    }
}

/// The profile's width (circle: diameter) for a cross-section `area` and `height`.
pub fn profile_width(profile: BeadShape, area: f64, height: f64) -> f64 {
    match profile {
        BeadShape::Rect => area / height,
        BeadShape::Slot => (area / height + height * (1.0 - PI / 4.0)).max(height),
        BeadShape::Circle => (4.0 * area / PI).sqrt(),
    }
}

/// The cross-section area of a profile of `width` (circle: diameter) and `height`.
pub fn profile_area(profile: BeadShape, width: f64, height: f64) -> f64 {
    match profile {
        BeadShape::Rect => width * height,
        BeadShape::Slot => (width - height).max(0.0) * height + PI * height * height / 4.0,
        BeadShape::Circle => PI * width * width / 4.0,
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return 0.0;
    }
    v.sort_unstable_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Forwards motions to a [`SpineBuilder`] and counts them.
struct Sink<'a>(&'a mut SpineBuilder);

impl MotionSink for Sink<'_> {
    type Error = std::convert::Infallible;
    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Self::Error> {
        self.0.motion(motion)
    }
}

/// Parses an FDM program and sizes its beads (see the [module docs](self)).
pub fn extract_beads(text: &str, opts: &FdmOptions) -> Result<Extrusion, FdmError> {
    opts.validate()?;
    let mut warnings = Vec::new();
    let mut body = text;
    if opts.drop_unterminated_last_line && !text.is_empty() && !text.ends_with('\n') {
        let cut = text.rfind('\n').map_or(0, |i| i + 1);
        let line_no = text[..cut].bytes().filter(|&c| c == b'\n').count() + 1;
        let last = text[cut..].trim();
        if !last.is_empty() {
            let shown: String = last.chars().take(40).collect();
            warnings
                .push(format!("line {line_no}: no newline at end of file (truncated?): \"{shown}\" ignored"));
        }
        body = &text[..cut];
    }
    let popts = ParseOptions {
        dialect: ParseDialect::Fdm,
        stop_at_first_error: opts.strict,
        ..ParseOptions::default()
    };
    let mut builder = SpineBuilder::new(SpineOptions {
        rule: opts.rule,
        filament_diameter: opts.filament_diameter,
        ..SpineOptions::default()
    });
    let summary = match parse_str(body, &popts, &mut Sink(&mut builder)) {
        Ok(s) => s,
        Err(crate::gcode::ParseError::Gcode(e)) => return Err(FdmError::Gcode(e.to_string())),
        Err(e) => return Err(FdmError::Gcode(e.to_string())),
    };
    for e in &summary.errors {
        warnings.push(format!("line {}: skipped: {}", e.line, e.kind));
    }
    if summary.dropped > 0 {
        warnings.push(format!("{} more bad lines not listed", summary.dropped));
    }
    let raw = builder.into_spines();
    let mut spines = Vec::with_capacity(raw.len());
    let mut spine_layers = Vec::with_capacity(raw.len());
    let mut vols: Vec<Vec<f64>> = Vec::with_capacity(raw.len());
    let mut extruded = 0.0;
    for s in &raw {
        extruded += s.volumes.iter().filter(|v| v.is_finite() && **v > 0.0).sum::<f64>();
        // Merge zero-length segments into their neighbour (their volume carries over).
        let mut pts: Vec<Point3> = Vec::with_capacity(s.points.len());
        let mut vv: Vec<f64> = Vec::with_capacity(s.volumes.len());
        for (i, p) in s.points.iter().enumerate() {
            let v = if i == 0 { 0.0 } else { s.volumes.get(i - 1).copied().unwrap_or(0.0).max(0.0) };
            match pts.last() {
                Some(q) if (p - q).norm() <= 1e-9 => {
                    if let Some(last) = vv.last_mut() {
                        *last += v;
                    }
                }
                _ => {
                    if !pts.is_empty() {
                        vv.push(v);
                    }
                    pts.push(*p);
                }
            }
        }
        if pts.len() >= 2 {
            spines.push(pts);
            spine_layers.push(s.layer);
            vols.push(vv);
        }
    }
    if spines.is_empty() {
        return Err(FdmError::NoExtrusion { lines: summary.lines, errors: summary.errors.len() });
    }
    let layers = spine_layers.iter().copied().max().unwrap_or(0) + 1;
    let layer_heights = match opts.layer_height {
        Some(h) => vec![h; layers],
        None => auto_heights(&spines, &spine_layers, layers, opts),
    };
    // Areas.
    let mut beads = Vec::new();
    for (si, (pts, vv)) in spines.iter().zip(&vols).enumerate() {
        let h = layer_heights[spine_layers[si]];
        for (w, v) in pts.windows(2).zip(vv) {
            let len = (w[1] - w[0]).norm();
            let area = match opts.width {
                Some(wd) => profile_area(opts.profile, wd, h),
                None => v / len,
            };
            beads.push(Bead { a: w[0], b: w[1], area, height: h, spine: si as u32 });
        }
    }
    let med = median(beads.iter().map(|b| b.area).filter(|a| *a > 0.0).collect());
    if med.is_nan() || med <= 0.0 {
        return Err(FdmError::NoExtrusion { lines: summary.lines, errors: summary.errors.len() });
    }
    for b in &mut beads {
        b.area =
            if b.area.is_finite() { b.area.clamp(med / opts.area_clamp, med * opts.area_clamp) } else { med };
    }
    Ok(Extrusion {
        spines,
        spine_layers,
        beads,
        layers,
        layer_heights,
        extruded_volume: extruded,
        lines: summary.lines,
        warnings,
    })
}

fn auto_heights(spines: &[Vec<Point3>], layer_of: &[usize], layers: usize, opts: &FdmOptions) -> Vec<f64> {
    let mut zs: Vec<Vec<f64>> = vec![Vec::new(); layers];
    for (pts, &l) in spines.iter().zip(layer_of) {
        zs[l].extend(pts.iter().map(|p| p.z));
    }
    let mut tops: Vec<f64> = zs.into_iter().map(median_or_nan).collect();
    // Layers without points (cannot happen with the builder, but be safe): previous top.
    for i in 0..tops.len() {
        if !tops[i].is_finite() {
            tops[i] = if i > 0 { tops[i - 1] } else { 0.0 };
        }
    }
    let steps: Vec<f64> = tops.windows(2).map(|w| w[1] - w[0]).filter(|s| *s > 0.0).collect();
    let first = tops.first().copied().unwrap_or(0.0);
    let med = {
        let m = median(steps);
        if m > 0.0 {
            m
        } else if first > 0.0 {
            first
        } else {
            opts.fallback_layer_height
        }
    };
    let ok = |h: f64| h > 1e-6 && h <= opts.max_height_ratio * med;
    (0..layers)
        .map(|i| {
            let h = if i == 0 { first } else { tops[i] - tops[i - 1] };
            if ok(h) { h } else { med }
        })
        .collect()
}

fn median_or_nan(v: Vec<f64>) -> f64 {
    if v.is_empty() { f64::NAN } else { median(v) }
}

/// Seconds spent in each stage of [`reconstruct`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct FdmStageSeconds {
    /// Parsing and spine extraction.
    pub parse: f64,
    /// Bead sizing.
    pub sizing: f64,
    /// Voxel deposition (solid only).
    pub deposit: f64,
    /// Marching cubes (solid) or sweeping (tubes).
    pub mesh: f64,
    /// Mesh checks (closed, manifold, volume).
    pub check: f64,
    /// Everything.
    pub total: f64,
}

/// What [`reconstruct`] measured; serialises to the CLI's JSON report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FdmReport {
    /// Solid or tubes.
    pub output: FdmOutput,
    /// Profile.
    pub profile: BeadShape,
    /// Lines read.
    pub lines: u64,
    /// Spines (continuous extrusion paths).
    pub spines: usize,
    /// Straight segments (beads).
    pub segments: usize,
    /// Layers.
    pub layers: usize,
    /// Median layer height, mm.
    pub layer_height_mm: f64,
    /// Median profile width (circle: diameter), mm.
    pub bead_width_mm: f64,
    /// Extruded filament volume, mm^3.
    pub extruded_volume_mm3: f64,
    /// Volume enclosed by the output mesh, mm^3 (tubes: sum over the tubes, overlaps counted twice).
    pub solid_volume_mm3: f64,
    /// `solid_volume_mm3 / extruded_volume_mm3 - 1`.
    pub volume_error: f64,
    /// Voxel volume of the deposited grid, mm^3 (solid only).
    pub voxel_volume_mm3: Option<f64>,
    /// Factor the solid's bead areas were scaled by to match the extruded volume (1: none).
    pub area_scale: f64,
    /// Voxel volume of the solid's beads as sliced, before width scaling, mm^3 (solid only).
    pub raw_voxel_volume_mm3: Option<f64>,
    /// Depositions run for the solid (0 for tubes).
    pub depositions: usize,
    /// Voxel edge lengths (x, y, z), mm (solid only).
    pub voxel_mm: Option<[f64; 3]>,
    /// Bounding box of the mesh: `[min, max]`.
    pub bbox: [[f64; 3]; 2],
    /// Triangles.
    pub triangles: usize,
    /// Surface components (solid: the outer bodies and every internal void's surface;
    /// tubes: one per spine).
    pub bodies: usize,
    /// Closed and manifold (tubes: every tube).
    pub watertight: bool,
    /// Warnings (bad or truncated lines), each naming its line.
    pub warnings: Vec<String>,
    /// Seconds per stage.
    pub stage_seconds: FdmStageSeconds,
}

/// A reconstruction: the mesh and its report.
#[derive(Debug, Clone)]
pub struct Reconstruction {
    /// The solid or the tubes.
    pub mesh: Mesh,
    /// Figures and timings.
    pub report: FdmReport,
    /// The spines and beads it was built from.
    pub extrusion: Extrusion,
}

/// Reads a G-code file and [`reconstruct`]s it (invalid UTF-8 is replaced, and the lines it
/// spoils become warnings).
pub fn reconstruct_file(path: impl AsRef<Path>, opts: &FdmOptions) -> Result<Reconstruction, FdmError> {
    let path = path.as_ref();
    let bytes =
        std::fs::read(path).map_err(|source| FdmError::Io { path: path.display().to_string(), source })?;
    reconstruct(&String::from_utf8_lossy(&bytes), opts)
}

/// G-code text to geometry (see the [module docs](self)).
pub fn reconstruct(text: &str, opts: &FdmOptions) -> Result<Reconstruction, FdmError> {
    let t0 = Instant::now();
    let mut times = FdmStageSeconds::default();
    let ex = extract_beads(text, opts)?;
    times.parse = t0.elapsed().as_secs_f64();
    let t = Instant::now();
    let widths = median(ex.beads.iter().map(|b| profile_width(opts.profile, b.area, b.height)).collect());
    times.sizing = t.elapsed().as_secs_f64();
    let (mut scale, mut depositions, mut raw) = (1.0, 0, None);
    let (mesh, voxel_volume, voxel, bodies, watertight, volume, check_s) = match opts.output {
        FdmOutput::Solid => {
            let solid = solid_mesh(&ex, opts)?;
            times.deposit = solid.deposit_seconds;
            times.mesh = solid.mesh_seconds;
            let t = Instant::now();
            let (ok, bodies, vol) = indexed_check(&solid.mesh);
            let v = solid.grid.spec().voxel;
            scale = solid.area_scale;
            depositions = solid.depositions;
            raw = Some(solid.raw_volume);
            (
                solid.mesh,
                Some(solid.grid.volume()),
                Some([v.x, v.y, v.z]),
                bodies,
                ok,
                vol,
                t.elapsed().as_secs_f64(),
            )
        }
        FdmOutput::Tubes => {
            let t = Instant::now();
            let mesh = tube_mesh(&ex, opts)?;
            times.mesh = t.elapsed().as_secs_f64();
            let t = Instant::now();
            // Tubes share no vertices, so the index-based check is exact per tube.
            let (ok, bodies, vol) = indexed_check(&mesh);
            (mesh, None, None, bodies, ok, vol, t.elapsed().as_secs_f64())
        }
    };
    times.check = check_s;
    let bb = mesh.bbox().unwrap_or_else(Aabb::empty);
    let report = FdmReport {
        output: opts.output,
        profile: opts.profile,
        lines: ex.lines,
        spines: ex.spines.len(),
        segments: ex.beads.len(),
        layers: ex.layers,
        layer_height_mm: ex.median_height(),
        bead_width_mm: widths,
        extruded_volume_mm3: ex.extruded_volume,
        solid_volume_mm3: volume,
        volume_error: volume / ex.extruded_volume - 1.0,
        voxel_volume_mm3: voxel_volume,
        area_scale: scale,
        raw_voxel_volume_mm3: raw,
        depositions,
        voxel_mm: voxel,
        bbox: [[bb.min.x, bb.min.y, bb.min.z], [bb.max.x, bb.max.y, bb.max.z]],
        triangles: mesh.triangles().len(),
        bodies,
        watertight,
        warnings: ex.warnings.clone(),
        stage_seconds: FdmStageSeconds { total: t0.elapsed().as_secs_f64(), ..times },
    };
    Ok(Reconstruction { mesh, report, extrusion: ex })
}

/// A top view of one layer's beads (slot/rect: their plan shape; circle: its widest chord),
/// each spine in its own colour from a fixed palette, at `px_per_mm` pixels per mm over the
/// layer's bounding box (at most 4096 pixels a side). `None` when the layer has no beads.
pub fn render_layer(
    ex: &Extrusion,
    layer: usize,
    profile: BeadShape,
    px_per_mm: f64,
) -> Option<crate::Image> {
    const PALETTE: [[u8; 3]; 8] = [
        [214, 39, 40],
        [31, 119, 180],
        [44, 160, 44],
        [255, 127, 14],
        [148, 103, 189],
        [140, 86, 75],
        [23, 190, 207],
        [188, 189, 34],
    ];
    let beads: Vec<&Bead> = ex.beads.iter().filter(|b| ex.spine_layers[b.spine as usize] == layer).collect();
    let half = |b: &Bead| {
        0.5 * if profile == BeadShape::Circle {
            profile_width(profile, b.area, b.height)
        } else {
            b.area / b.height
        }
    };
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for b in &beads {
        let r = half(b);
        for q in [b.a, b.b] {
            for k in 0..2 {
                lo[k] = lo[k].min(q[k] - r);
                hi[k] = hi[k].max(q[k] + r);
            }
        }
    }
    if beads.is_empty() || !(px_per_mm.is_finite() && px_per_mm > 0.0) {
        return None;
    }
    let scale = px_per_mm.min(4096.0 / (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9));
    let width = (((hi[0] - lo[0]) * scale).ceil() as usize).clamp(1, 4096);
    let height = (((hi[1] - lo[1]) * scale).ceil() as usize).clamp(1, 4096);
    let mut rgb = [250u8, 250, 252].repeat(width * height);
    for b in beads {
        let p = raster::Piece {
            a: [b.a.x, b.a.y],
            b: [b.b.x, b.b.y],
            r: half(b),
            round: profile != BeadShape::Rect,
        };
        let c = PALETTE[b.spine as usize % PALETTE.len()];
        let y0 = ((b.a.y.min(b.b.y) - p.r - lo[1]) * scale).floor().max(0.0) as usize;
        let y1 = (((b.a.y.max(b.b.y) + p.r - lo[1]) * scale).ceil() as usize).min(height);
        for py in y0..y1 {
            let yc = lo[1] + (py as f64 + 0.5) / scale;
            let Some((x0, x1)) = raster::interval(&p, yc) else { continue };
            let i0 = ((x0 - lo[0]) * scale - 0.5).ceil().max(0.0) as usize;
            let i1 = (((x1 - lo[0]) * scale - 0.5).floor().max(-1.0) + 1.0) as usize;
            // Image rows run top to bottom: +Y up.
            let row = height - 1 - py;
            for px in i0..i1.min(width) {
                let i = 3 * (row * width + px);
                rgb[i..i + 3].copy_from_slice(&c);
            }
        }
    }
    Some(crate::Image { width, height, rgb })
}

/// Three shaded views of a reconstruction (`panel` pixels square each); faces on the mesh's
/// bounding box grey, the others red.
pub fn render_result(mesh: &Mesh, panel: usize) -> Option<crate::Image> {
    let bb = mesh.bbox()?;
    Some(crate::render_machining(mesh, &bb, None, panel))
}
