//! Feature-based CNC programs on a prismatic block (seed 001): rectangular closed pockets
//! with corner radii, straight slots (closed or through) and holes (drilled with a canned
//! cycle or helically milled).
//!
//! # Frame
//! The block occupies `X ∈ [0, length]`, `Y ∈ [0, width]`, `Z ∈ [-height, 0]`: program
//! zero is the corner of the top face where the seed puts its axes (§II.A), +Z points out of
//! the top face and every feature is cut from the top (depth measured down from `Z = 0`).
//! A pocket is placed by its lower-left corner (the seed's "program zero" `X0`, `Y0` of the
//! feature), a slot by the two end points of its centre line, a hole by its centre.
//!
//! # Rules (seed §II.C-E)
//! The seed's equations (1)-(6) are missing from its text; these are the rules that reproduce
//! its worked example (50 x 35 x 5 mm pocket, 10 mm tool, `S` = 0.4 mm: `d` = 2.5, `m` = 2,
//! `N` = 4, `Q` = 8.067), with their bounds as [`FeatureOptions`] fields:
//!
//! - **Depth of cut** (Eqs. 1-2): `m = ceil(h / (k_d R))`, `d = h / m`: the fewest equal cuts
//!   no deeper than `k_d R` ([`FeatureOptions::max_depth_ratio`] `k_d`, default 0.5, a
//!   quarter of the tool diameter). Example: `h = 5`, `R = 5`: `m = ceil(2) = 2`, `d = 2.5`.
//! - **Step-over** (Eqs. 3-4): the tool centre rows span `s = W - 2R - 2S` (the finishing
//!   allowance `S` stays on both walls); `N = ceil(s / (k_q 2R)) + 1` rows,
//!   `Q = s / (N - 1)`: the fewest rows whose step-over does not exceed `k_q` tool diameters
//!   ([`FeatureOptions::max_stepover_ratio`] `k_q`, default 0.9; the worked example gives
//!   `N = 4` for any `k_q` in `[0.807, 1.21)`). Example: `s = 24.2`, `N = 4`, `Q = 8.0667`.
//!   When `s <= 0` one row runs along the middle.
//! - **Coordinates** (Eqs. 5-6): row `i` of cut `j` lies at `Y = Y0 + R + S + (i - 1) Q`,
//!   `Z = -j d`, from `X0 + R + S` to `X0 + L - R - S`, alternating direction (zigzag).
//!
//! **Roughing pass length.** The seed's Table 1 moves 38.4 mm per pass, but its finishing
//! contour (`X17.5` to `X57.5`, i.e. `L - 2R` = 40 mm between tool centres) implies that a
//! pass leaving the allowance `S` on the end walls is `L - 2R - 2S` = 39.2 mm; 38.4 mm
//! (`L - 2R - 4S`) would leave `2S` on the end walls but `S` on the side walls (whose rows
//! span `W - 2R - 2S` = 3 Q = 24.2 exactly). We use **39.2 mm**: the same allowance on all
//! four walls, consistent with both the step-over and the finishing pass. Likewise the
//! seed's roughing start (`X12.5 Y12.5`, the pocket corner) and its finishing moves to
//! `Y12.5` would put the tool centre on the wall (a gouge of one radius): our roughing
//! starts at `X0 + R + S`, `Y0 + R + S` (17.9, 17.9) and the finishing contour runs at the
//! tool radius from the walls (`X17.5..57.5`, `Y17.5..42.5`).
//!
//! With a corner radius `r_c > R + S` the rows near the ends are clipped to the rounded
//! tool-centre region (its corner radius is `r_c - R - S`), so no roughing row cuts into the
//! corner allowance.
//!
//! # Operations
//! - **Pocket**: per cut, rapid to the row start at the clearance plane, plunge (`G1`) to
//!   `-j d`, zigzag rows, retract (`G0`). Then (after `M1`) the finishing tool plunges at
//!   the pocket centre to full depth, feeds to the middle of the lower wall and runs the
//!   contour counter-clockwise (climb milling with `M3`), arcs of radius `r_c - R_f` in
//!   the corners, back to the centre. Requires `R <= r_c` and `R_f <= r_c` (the tool must
//!   fit the corner).
//! - **Slot**: the same rules across the slot width, rows along the slot. A *closed* slot is
//!   a stadium (round ends, radius `width / 2`) around its centre line; its rows are
//!   clipped to the stadium of radius `width/2 - R - S` and it is finished by the stadium
//!   contour at `R_f` from the walls. A *through* slot is open at both ends: its end points
//!   must lie on or outside the block, rows run [`FeatureOptions::overrun`] plus `R` past
//!   them (plunges happen outside the block) and it is finished by one pass along each wall.
//!   A slot as wide as the tool is one centre row per cut, without finishing pass.
//! - **Hole**, drilled (tool diameter = hole diameter): `G98 G81` (or `G82 P` dwell, or
//!   `G83 Q` peck; automatic choice: `G83` with a one-diameter peck when deeper than three
//!   diameters) from the clearance plane with the R plane at [`FeatureOptions::r_plane`].
//!   The drill is modelled as a flat cutter: the hole depth is the depth of its tip.
//! - **Hole**, helical (hole larger than the tool): per cut one helical turn at radius
//!   `D/2 - R` down to `-j d`, a flat full circle, then concentric circles inward (step-over
//!   rule across the remaining core, innermost circle at `R/2` or less) so that the core does
//!   not stay as a slug, and back out; cut to size in one operation, without finishing
//!   allowance.
//!
//! Moves between features go through the clearance plane ([`FeatureOptions::clearance`],
//! the seed's `Z3`); a tool change happens only when the tool number changes. The program
//! ends at `X0 Y0` at the clearance plane with `M9`, `M5`, `M30`.

use std::borrow::Cow;
use std::f64::consts::TAU;

use nalgebra::Point3;
use s2g_gcode::{ArcDirection, Coolant, CycleKind, DrillCycle, Motion, MotionSink, Plane, SpindleDirection};

use crate::tool::Tool;

/// Tolerance on lengths when comparing sizes (mm).
const EPS: f64 = 1e-9;

/// Options of the feature programs. Every field documents its default.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureOptions {
    /// `k_d`: the depth of cut is at most `k_d` tool radii. Default 0.5.
    pub max_depth_ratio: f64,
    /// `k_q`: the step-over is at most `k_q` tool diameters. Default 0.9.
    pub max_stepover_ratio: f64,
    /// Z of the clearance plane for rapids (mm above the top face). Default 3 (the seed's `Z3`).
    pub clearance: f64,
    /// Z of the drilling cycles' R plane (mm above the top face). Default 1.
    pub r_plane: f64,
    /// How far past a through slot's ends its passes run, beyond the tool radius (mm). Default 2.
    pub overrun: f64,
    /// Write drilling as canned cycles ([`Motion::Cycle`]); `false` expands them into rapids,
    /// feeds and dwells (for sinks that do not know cycles). Default true.
    pub canned_cycles: bool,
    /// Optional stop (`M1`) before each finishing operation. Default true.
    pub optional_stop: bool,
    /// Flood coolant on after each tool change. Default true.
    pub coolant: bool,
    /// Comments naming features, cuts and passes. Default true.
    pub comments: bool,
    /// Dwell of `G82` holes when the job gives none (s). Default 0.5.
    pub default_dwell: f64,
}

impl Default for FeatureOptions {
    fn default() -> Self {
        FeatureOptions {
            max_depth_ratio: 0.5,
            max_stepover_ratio: 0.9,
            clearance: 3.0,
            r_plane: 1.0,
            overrun: 2.0,
            canned_cycles: true,
            optional_stop: true,
            coolant: true,
            comments: true,
            default_dwell: 0.5,
        }
    }
}

/// The prismatic block: `X ∈ [0, length]`, `Y ∈ [0, width]`, `Z ∈ [-height, 0]` (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    /// Size along X.
    pub length: f64,
    /// Size along Y.
    pub width: f64,
    /// Size along Z.
    pub height: f64,
}

/// How a hole is made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum HoleMethod {
    /// Drilled when the tool has the hole's diameter (`G81`, or `G83` with a one-diameter
    /// peck when deeper than three diameters), helical when the hole is larger.
    Auto,
    /// `G81`.
    Drill,
    /// `G82` with this dwell (s), or [`FeatureOptions::default_dwell`].
    Dwell(Option<f64>),
    /// `G83` with this peck (mm), or one tool diameter.
    Peck(Option<f64>),
    /// Helical milling (hole larger than the tool).
    Helical,
}

/// The shape of a feature.
#[derive(Debug, Clone, PartialEq)]
pub enum FeatureKind {
    /// Rectangular closed pocket with rounded corners, sides parallel to X and Y.
    Pocket {
        /// Lower-left corner X (the feature's program zero `X0`).
        x: f64,
        /// Lower-left corner Y (`Y0`).
        y: f64,
        /// Size along X.
        length: f64,
        /// Size along Y.
        width: f64,
        /// Corner radius (at least the tool radius).
        corner_radius: f64,
    },
    /// Straight slot along the centre line `start`-`end`.
    Slot {
        /// Centre line start `[x, y]`.
        start: [f64; 2],
        /// Centre line end `[x, y]`.
        end: [f64; 2],
        /// Slot width (at least the tool diameter).
        width: f64,
        /// Open at both ends (the end points lie on or outside the block); otherwise closed
        /// with round ends.
        through: bool,
    },
    /// Round hole.
    Hole {
        /// Centre X.
        x: f64,
        /// Centre Y.
        y: f64,
        /// Diameter.
        diameter: f64,
        /// How it is made.
        method: HoleMethod,
    },
}

/// One machining feature of a job.
#[derive(Debug, Clone, PartialEq)]
pub struct Feature {
    /// Name used in comments, reports and errors.
    pub name: String,
    /// Shape and position.
    pub kind: FeatureKind,
    /// Depth below the top face (mm), at most the block height.
    pub depth: f64,
    /// Roughing (or only) tool number.
    pub tool: u32,
    /// Finishing tool number (pockets and slots); `None`: the roughing tool finishes.
    pub finish_tool: Option<u32>,
}

/// A feature job: block, finishing allowance, tools and features (in machining order).
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureJob {
    /// The block.
    pub block: Block,
    /// Finishing allowance `S` left on pocket and slot walls by roughing (mm).
    pub allowance: f64,
    /// Tools: each a [`Tool`] whose number is the `T` word (and `H` for its length offset),
    /// whose cutter's diameter is the cutting diameter (mm), with its spindle speed (rev/min),
    /// cutting feed and plunge (Z) feed (mm/min). Planning reads only those: flute length,
    /// shank and holder are the caller's to set for simulation.
    pub tools: Vec<Tool>,
    /// Features.
    pub features: Vec<Feature>,
}

/// Why a job cannot be programmed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FeatureError {
    /// A feature is impossible as given.
    #[error("feature '{feature}': {reason}")]
    Feature {
        /// The feature's name.
        feature: String,
        /// What is wrong.
        reason: String,
    },
    /// The job as a whole is wrong (block, allowance, tools, options).
    #[error("job: {0}")]
    Job(String),
}

/// What the program does for one feature (the numbers of the seed's rules).
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureSummary {
    /// Feature name.
    pub name: String,
    /// `pocket`, `slot`, `through slot`, `drilled hole` or `helical hole`.
    pub kind: &'static str,
    /// Operation, e.g. `G81`, `zigzag + contour`.
    pub operation: String,
    /// Depth of cut `d` (helix pitch for helical holes, peck for `G83`, the depth for drilling).
    pub depth_of_cut: f64,
    /// Number of cuts `m` (pecks for `G83`).
    pub cuts: usize,
    /// Step-over `Q` (0 with a single pass).
    pub stepover: f64,
    /// Passes per cut `N` (rows; concentric circles + 1 for helical holes).
    pub passes: usize,
    /// Length of one full roughing row (mm; 0 for holes).
    pub pass_length: f64,
    /// Roughing tool.
    pub tool: u32,
    /// Finishing tool, when there is a finishing operation.
    pub finish_tool: Option<u32>,
    /// Smallest tool-tip coordinates over the feature's moves (rapids included).
    pub min: [f64; 3],
    /// Largest tool-tip coordinates over the feature's moves (rapids included).
    pub max: [f64; 3],
}

/// A generated feature program: its motions and per-feature summaries.
#[derive(Debug, Clone, PartialEq)]
pub struct FeaturePlan {
    /// The motions, from the first tool change to [`Motion::End`].
    pub motions: Vec<Motion<'static>>,
    /// One summary per feature, in job order.
    pub summaries: Vec<FeatureSummary>,
}

impl FeaturePlan {
    /// Sends every motion to `sink`, then calls its `finish`.
    pub fn emit<S: MotionSink>(&self, sink: &mut S) -> Result<(), S::Error> {
        for m in &self.motions {
            sink.motion(m)?;
        }
        sink.finish()
    }
}

/// Depth rule (Eqs. 1-2): `(d, m)` with `m = ceil(h / (k_d R))`, `d = h / m`.
pub fn depth_rule(depth: f64, tool_radius: f64, max_depth_ratio: f64) -> (f64, usize) {
    let max_d = max_depth_ratio * tool_radius;
    if !(depth > 0.0) || !(max_d > 0.0) || !depth.is_finite() {
        return (depth.max(0.0), 1);
    }
    let m = ((depth / max_d) - 1e-9).ceil().max(1.0);
    (depth / m, m as usize)
}

/// Step-over rule (Eqs. 3-4): `(Q, N)` across `width` with allowance `S`: the rows span
/// `s = width - 2R - 2S`, `N = ceil(s / (k_q 2R)) + 1`, `Q = s / (N - 1)`; `(0, 1)` when `s <= 0`.
pub fn stepover_rule(width: f64, allowance: f64, tool_radius: f64, max_stepover_ratio: f64) -> (f64, usize) {
    let span = width - 2.0 * tool_radius - 2.0 * allowance;
    let max_q = max_stepover_ratio * 2.0 * tool_radius;
    if !(span > EPS) || !(max_q > 0.0) || !span.is_finite() {
        return (0.0, 1);
    }
    let gaps = ((span / max_q) - 1e-9).ceil().max(1.0);
    (span / gaps, gaps as usize + 1)
}

impl Feature {
    /// 2-D signed distance (mm) from `(x, y)` to the feature's outline (negative inside).
    pub fn outline_distance(&self, x: f64, y: f64) -> f64 {
        match self.kind {
            FeatureKind::Pocket { x: x0, y: y0, length, width, corner_radius } => {
                let (cx, cy) = (x0 + 0.5 * length, y0 + 0.5 * width);
                let r = corner_radius.clamp(0.0, 0.5 * length.min(width));
                let qx = (x - cx).abs() - (0.5 * length - r);
                let qy = (y - cy).abs() - (0.5 * width - r);
                qx.max(0.0).hypot(qy.max(0.0)) + qx.max(qy).min(0.0) - r
            }
            FeatureKind::Slot { start, end, width, through } => {
                let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
                let len2 = dx * dx + dy * dy;
                let (px, py) = (x - start[0], y - start[1]);
                let t = if len2 > 0.0 { (px * dx + py * dy) / len2 } else { 0.0 };
                let t = if through { t } else { t.clamp(0.0, 1.0) };
                (px - t * dx).hypot(py - t * dy) - 0.5 * width
            }
            FeatureKind::Hole { x: cx, y: cy, diameter, .. } => (x - cx).hypot(y - cy) - 0.5 * diameter,
        }
    }

    /// Whether the point lies in the volume the feature removes (its outline from `Z = 0`
    /// down to `-depth`; everything above the top face counts as inside).
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        p.z >= -self.depth && self.outline_distance(p.x, p.y) <= 0.0
    }

    /// A bound on the distance (mm) from `p` to the feature's volume: 0 inside; used to
    /// tell "near the walls or floor" from "far from them".
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        let d2 = self.outline_distance(p.x, p.y).max(0.0);
        let dz = (-self.depth - p.z).max(0.0);
        d2.hypot(dz)
    }
}

impl FeatureJob {
    /// Whether `p` lies in the volume removed by any feature.
    pub fn removed(&self, p: &Point3<f64>) -> bool {
        self.features.iter().any(|f| f.contains(p))
    }

    fn tool(&self, feature: &Feature, number: u32) -> Result<&Tool, FeatureError> {
        self.tools.iter().find(|t| t.number == number).ok_or_else(|| FeatureError::Feature {
            feature: feature.name.clone(),
            reason: format!("tool T{number} is not in the job's tool list"),
        })
    }

    /// Checks the whole job: block, allowance, tools and every feature's geometry against
    /// the block and its tools.
    pub fn validate(&self, opts: &FeatureOptions) -> Result<(), FeatureError> {
        let b = &self.block;
        for (what, v) in [("length", b.length), ("width", b.width), ("height", b.height)] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(FeatureError::Job(format!("block {what} must be positive, got {v}")));
            }
        }
        if !(self.allowance >= 0.0 && self.allowance.is_finite()) {
            return Err(FeatureError::Job(format!(
                "finishing allowance must be zero or positive, got {}",
                self.allowance
            )));
        }
        for (what, v, lo) in [
            ("max_depth_ratio", opts.max_depth_ratio, 0.0),
            ("max_stepover_ratio", opts.max_stepover_ratio, 0.0),
            ("clearance", opts.clearance, 0.0),
            ("overrun", opts.overrun, -EPS),
            ("default_dwell", opts.default_dwell, -EPS),
        ] {
            if !(v > lo && v.is_finite()) {
                return Err(FeatureError::Job(format!("option {what} out of range: {v}")));
            }
        }
        if !(opts.r_plane > 0.0 && opts.r_plane <= opts.clearance) {
            return Err(FeatureError::Job(format!(
                "option r_plane must be in (0, clearance = {}], got {}",
                opts.clearance, opts.r_plane
            )));
        }
        for (i, t) in self.tools.iter().enumerate() {
            for (what, v) in [
                ("diameter", t.diameter()),
                ("rpm", t.spindle_rpm),
                ("feed", t.feed),
                ("plunge_feed", t.plunge_feed),
            ] {
                if !(v > 0.0 && v.is_finite()) {
                    return Err(FeatureError::Job(format!(
                        "tool T{}: {what} must be positive, got {v}",
                        t.number
                    )));
                }
            }
            if self.tools[..i].iter().any(|o| o.number == t.number) {
                return Err(FeatureError::Job(format!("tool T{} is listed twice", t.number)));
            }
        }
        if self.features.is_empty() {
            return Err(FeatureError::Job("the job has no features".into()));
        }
        for (i, f) in self.features.iter().enumerate() {
            if f.name.trim().is_empty() {
                return Err(FeatureError::Job(format!("feature {} has an empty name", i + 1)));
            }
            if self.features[..i].iter().any(|o| o.name == f.name) {
                return Err(FeatureError::Job(format!("feature name '{}' is used twice", f.name)));
            }
            self.validate_feature(f, opts)?;
        }
        Ok(())
    }

    fn validate_feature(&self, f: &Feature, opts: &FeatureOptions) -> Result<(), FeatureError> {
        let bad = |reason: String| FeatureError::Feature { feature: f.name.clone(), reason };
        let b = &self.block;
        if !(f.depth > 0.0 && f.depth.is_finite()) {
            return Err(bad(format!("depth must be positive, got {}", f.depth)));
        }
        if f.depth > b.height + EPS {
            return Err(bad(format!("depth {} is beyond the block (height {})", f.depth, b.height)));
        }
        let tool = self.tool(f, f.tool)?;
        let r = tool.radius();
        let finish = match f.finish_tool {
            Some(n) => Some(self.tool(f, n)?),
            None => None,
        };
        let rf = finish.map_or(r, |t| t.radius());
        let inside = |x0: f64, y0: f64, x1: f64, y1: f64| inside_block(b, [x0, y0, x1, y1]);
        let finite = |vs: &[f64]| vs.iter().all(|v| v.is_finite());
        match f.kind {
            FeatureKind::Pocket { x, y, length, width, corner_radius } => {
                if !(finite(&[x, y, length, width, corner_radius]) && length > 0.0 && width > 0.0) {
                    return Err(bad("pocket position and size must be finite and positive".into()));
                }
                if !inside(x, y, x + length, y + width) {
                    return Err(bad(format!(
                        "pocket X{x}..{} Y{y}..{} is outside the block ({} x {})",
                        x + length,
                        y + width,
                        b.length,
                        b.width
                    )));
                }
                if corner_radius + EPS < r.max(rf) {
                    return Err(bad(format!(
                        "corner radius {corner_radius} is below the tool radius {} (the tool cannot reach the corner)",
                        r.max(rf)
                    )));
                }
                if 2.0 * corner_radius > length.min(width) + EPS {
                    return Err(bad(format!(
                        "corner radius {corner_radius} is more than half the pocket's smaller side"
                    )));
                }
                if 2.0 * r.max(rf) > length.min(width) + EPS {
                    return Err(bad(format!("tool diameter {} is wider than the pocket", 2.0 * r.max(rf))));
                }
            }
            FeatureKind::Slot { start, end, width, through } => {
                check_slot(b, [start, end], width, through, r.max(rf)).map_err(bad)?;
            }
            FeatureKind::Hole { x, y, diameter, method } => {
                if !finite(&[x, y, diameter]) || !(diameter > 0.0) {
                    return Err(bad("hole centre and diameter must be finite, diameter positive".into()));
                }
                let h = 0.5 * diameter;
                if !inside(x - h, y - h, x + h, y + h) {
                    return Err(bad(format!(
                        "hole at X{x} Y{y} (diameter {diameter}) is outside the block ({} x {})",
                        b.length, b.width
                    )));
                }
                check_hole_method(tool, diameter, method, f.depth).map_err(bad)?;
            }
        }
        // Guard against absurd programs (a tiny tool in a huge feature): rows x cuts.
        let (_, m) = depth_rule(f.depth, r.min(rf), opts.max_depth_ratio);
        let span = match f.kind {
            FeatureKind::Pocket { length, width, .. } => length.max(width),
            FeatureKind::Slot { width, .. } => width,
            FeatureKind::Hole { diameter, .. } => diameter,
        };
        let rows = span / (opts.max_stepover_ratio * r.min(rf)) + 1.0;
        if m as f64 * rows > MAX_ROWS {
            return Err(bad(format!(
                "about {:.0} passes for a {} mm tool: too many (limit {MAX_ROWS}); use a larger tool",
                m as f64 * rows,
                2.0 * r.min(rf)
            )));
        }
        Ok(())
    }
}

/// Whether the box `[x0, y0, x1, y1]` lies in the block's top face.
fn inside_block(b: &Block, [x0, y0, x1, y1]: [f64; 4]) -> bool {
    x0 >= -EPS && y0 >= -EPS && x1 <= b.length + EPS && y1 <= b.width + EPS
}

/// Checks a slot along `[start, end]` of `width` against the block `b` and the larger of
/// its tools' radii `r_max`; the reason when it is impossible.
fn check_slot(
    b: &Block,
    [start, end]: [[f64; 2]; 2],
    width: f64,
    through: bool,
    r_max: f64,
) -> Result<(), String> {
    if ![start[0], start[1], end[0], end[1], width].iter().all(|v| v.is_finite()) || !(width > 0.0) {
        return Err("slot ends and width must be finite, width positive".into());
    }
    let len = (end[0] - start[0]).hypot(end[1] - start[1]);
    if !(len > EPS) {
        return Err("slot start and end coincide".into());
    }
    if 2.0 * r_max > width + EPS {
        return Err(format!("tool diameter {} is wider than the slot ({width})", 2.0 * r_max));
    }
    let h = 0.5 * width;
    if through {
        let on_or_out =
            |p: [f64; 2]| p[0] <= EPS || p[1] <= EPS || p[0] >= b.length - EPS || p[1] >= b.width - EPS;
        if !on_or_out(start) || !on_or_out(end) {
            return Err("a through slot's ends must lie on or outside the block's sides".into());
        }
        // The slot's band must cross the block: its centre line within the block
        // somewhere, and its sides inside the block where the slot is.
        let axis_x = (end[1] - start[1]).abs() < EPS;
        let axis_y = (end[0] - start[0]).abs() < EPS;
        let ok = if axis_x {
            start[1] - h >= -EPS && start[1] + h <= b.width + EPS
        } else if axis_y {
            start[0] - h >= -EPS && start[0] + h <= b.length + EPS
        } else {
            false
        };
        if !ok {
            return Err("a through slot must run parallel to X or Y with its width inside the block".into());
        }
    } else {
        let (x0, x1) = (start[0].min(end[0]) - h, start[0].max(end[0]) + h);
        let (y0, y1) = (start[1].min(end[1]) - h, start[1].max(end[1]) + h);
        if !inside_block(b, [x0, y0, x1, y1]) {
            return Err(format!(
                "slot X{x0}..{x1} Y{y0}..{y1} is outside the block ({} x {})",
                b.length, b.width
            ));
        }
    }
    Ok(())
}

/// Checks that `tool` can make a hole of `diameter` and `depth` by `method`; the reason when
/// it cannot.
fn check_hole_method(tool: &Tool, diameter: f64, method: HoleMethod, depth: f64) -> Result<(), String> {
    let same = (tool.diameter() - diameter).abs() <= 1e-6;
    match method {
        HoleMethod::Helical | HoleMethod::Auto if !same => {
            if tool.diameter() > diameter {
                return Err(format!("tool diameter {} is wider than the hole ({diameter})", tool.diameter()));
            }
            if diameter - tool.diameter() < 0.02 {
                return Err(format!(
                    "hole diameter {diameter} is within 0.02 mm of the tool's: drill it instead"
                ));
            }
        }
        HoleMethod::Helical => {
            return Err("a helical hole needs a tool smaller than the hole".into());
        }
        _ if !same => {
            return Err(format!(
                "drilling needs a tool of the hole's diameter {diameter}, T{} is {}",
                tool.number,
                tool.diameter()
            ));
        }
        HoleMethod::Dwell(Some(s)) if !(s >= 0.0 && s.is_finite()) => {
            return Err(format!("dwell must be zero or positive, got {s}"));
        }
        HoleMethod::Peck(Some(q)) if !(q > 0.0 && q.is_finite()) || q * 1000.0 < depth => {
            return Err(format!("peck must be positive and at least depth / 1000, got {q}"));
        }
        _ => {}
    }
    Ok(())
}

/// Most passes x cuts a feature may need (guards against a tiny tool in a huge feature).
const MAX_ROWS: f64 = 1e6;

/// Collects motions, tracks the position and each feature's extents.
struct Builder<'o> {
    opts: &'o FeatureOptions,
    out: Vec<Motion<'static>>,
    pos: Option<Point3<f64>>,
    active_tool: Option<u32>,
    min: [f64; 3],
    max: [f64; 3],
}

impl Builder<'_> {
    fn grow(&mut self, p: &Point3<f64>) {
        for i in 0..3 {
            self.min[i] = self.min[i].min(p[i]);
            self.max[i] = self.max[i].max(p[i]);
        }
    }

    fn comment(&mut self, text: String) {
        if self.opts.comments {
            self.out.push(Motion::Comment(Cow::Owned(text)));
        }
    }

    fn rapid(&mut self, to: Point3<f64>) {
        if self.pos == Some(to) {
            return;
        }
        self.grow(&to);
        self.out.push(Motion::Rapid { to });
        self.pos = Some(to);
    }

    fn feed(&mut self, to: Point3<f64>, feed: f64) {
        if self.pos == Some(to) {
            return;
        }
        self.grow(&to);
        self.out.push(Motion::Linear { to, feed, extrude: None });
        self.pos = Some(to);
    }

    /// Counter-clockwise XY arc (or helix when `to.z` differs) about `(cx, cy)`.
    fn arc_ccw(&mut self, to: Point3<f64>, cx: f64, cy: f64, feed: f64) {
        let Some(from) = self.pos else {
            self.feed(to, feed);
            return;
        };
        let r = (from.x - cx).hypot(from.y - cy);
        // Extents: the arc's axis extremes within its sweep (a full turn when it closes).
        let a0 = (from.y - cy).atan2(from.x - cx);
        let a1 = (to.y - cy).atan2(to.x - cx);
        let mut sweep = (a1 - a0).rem_euclid(TAU);
        if sweep <= 1e-12 {
            sweep = TAU;
        }
        for k in 0..4 {
            let a = k as f64 * 0.25 * TAU;
            if (a - a0).rem_euclid(TAU) <= sweep {
                self.grow(&Point3::new(cx + r * a.cos(), cy + r * a.sin(), to.z));
            }
        }
        self.grow(&to);
        self.out.push(Motion::Arc {
            to,
            center: Point3::new(cx, cy, from.z),
            plane: Plane::XY,
            direction: ArcDirection::CounterClockwise,
            turns: 0,
            feed,
            extrude: None,
        });
        self.pos = Some(to);
    }

    fn clearance(&self) -> f64 {
        self.opts.clearance
    }

    /// Retract to the clearance plane.
    fn retract(&mut self) {
        if let Some(p) = self.pos
            && p.z < self.clearance()
        {
            self.rapid(Point3::new(p.x, p.y, self.clearance()));
        }
    }

    /// Tool change when `tool` is not active, then spindle and coolant; rapid to `(x, y)`
    /// at the clearance plane.
    fn start_op(&mut self, tool: &Tool, label: &str, x: f64, y: f64) {
        self.retract();
        let change = self.active_tool != Some(tool.number);
        if change {
            self.comment(format!("{label} tool T{} D{}", tool.number, fmt(tool.diameter())));
            self.out.push(Motion::ToolChange { tool: tool.number });
            self.out.push(Motion::Spindle { rpm: tool.spindle_rpm, direction: SpindleDirection::Clockwise });
            self.active_tool = Some(tool.number);
        }
        self.rapid(Point3::new(x, y, self.clearance()));
        if change && self.opts.coolant {
            self.out.push(Motion::Coolant(Coolant::Flood));
        }
    }
}

/// Short number text for comments.
fn fmt(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// Zigzag rows, each `(a, b)` from `a` to `b` (already alternating), cut at `z`.
fn zigzag(bld: &mut Builder<'_>, rows: &[([f64; 2], [f64; 2])], z: f64, tool: &Tool, cut: usize) {
    let Some(first) = rows.first() else { return };
    bld.rapid(Point3::new(first.0[0], first.0[1], bld.clearance()));
    bld.comment(format!("cut {cut}: depth {}", fmt(-z)));
    bld.feed(Point3::new(first.0[0], first.0[1], z), tool.plunge_feed);
    for (i, (a, b)) in rows.iter().enumerate() {
        if i > 0 {
            bld.comment(format!("step-over {i}"));
            bld.feed(Point3::new(a[0], a[1], z), tool.feed);
        }
        bld.comment(format!("pass {}", i + 1));
        bld.feed(Point3::new(b[0], b[1], z), tool.feed);
    }
    bld.retract();
}

/// Rows across a convex region: `offsets` are the row positions across (the `v`
/// coordinate), `extent(v)` the `(u0, u1)` range of the row, `map(u, v)` the XY point.
fn rows_of(
    offsets: &[f64],
    extent: impl Fn(f64) -> (f64, f64),
    map: impl Fn(f64, f64) -> [f64; 2],
) -> Vec<([f64; 2], [f64; 2])> {
    offsets
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let (u0, u1) = extent(v);
            if i % 2 == 0 { (map(u0, v), map(u1, v)) } else { (map(u1, v), map(u0, v)) }
        })
        .collect()
}

/// Row offsets from `lo` by `q`, `n` rows (centred when `n == 1`).
fn row_offsets(lo: f64, hi: f64, q: f64, n: usize) -> Vec<f64> {
    if n <= 1 {
        return vec![0.5 * (lo + hi)];
    }
    (0..n).map(|i| if i + 1 == n { hi } else { lo + i as f64 * q }).collect()
}

/// Half-width of a rounded rectangle's row at `v` (distance `dv` beyond the straight part
/// of the side into the corner band of radius `c`).
fn corner_inset(dv: f64, c: f64) -> f64 {
    if dv <= 0.0 || c <= 0.0 { 0.0 } else { c - (c * c - dv.min(c) * dv.min(c)).max(0.0).sqrt() }
}

/// What the operations of one feature share: its tools, the depth rule's cuts and the
/// finishing allowance.
struct Cuts<'a> {
    feature: &'a Feature,
    /// Roughing (or only) tool and its radius `R`.
    tool: &'a Tool,
    r: f64,
    /// Finishing tool and its radius `R_f`.
    ftool: &'a Tool,
    rf: f64,
    /// Depth of cut `d` and number of cuts `m` (Eqs. 1-2).
    d: f64,
    m: usize,
    /// The cuts' levels, `-j d` down to the feature's depth.
    levels: Vec<f64>,
    /// Finishing allowance `S`.
    allowance: f64,
}

impl<'a> Cuts<'a> {
    fn new(job: &'a FeatureJob, f: &'a Feature, opts: &FeatureOptions) -> Result<Self, FeatureError> {
        let tool = job.tool(f, f.tool)?;
        let r = tool.radius();
        let ftool = match f.finish_tool {
            Some(n) => job.tool(f, n)?,
            None => tool,
        };
        let rf = ftool.radius();
        let (d, m) = depth_rule(f.depth, r, opts.max_depth_ratio);
        let levels: Vec<f64> = (1..=m).map(|j| if j == m { -f.depth } else { -(j as f64) * d }).collect();
        Ok(Cuts { feature: f, tool, r, ftool, rf, d, m, levels, allowance: job.allowance })
    }

    /// The summary before the operation fills in its part (a pocket's, by default).
    fn summary(&self) -> FeatureSummary {
        FeatureSummary {
            name: self.feature.name.clone(),
            kind: "pocket",
            operation: String::new(),
            depth_of_cut: self.d,
            cuts: self.m,
            stepover: 0.0,
            passes: 1,
            pass_length: 0.0,
            tool: self.tool.number,
            finish_tool: None,
            min: [0.0; 3],
            max: [0.0; 3],
        }
    }
}

/// Builds the program for `job`: validation, rules, motions and summaries.
pub fn plan_features(job: &FeatureJob, opts: &FeatureOptions) -> Result<FeaturePlan, FeatureError> {
    job.validate(opts)?;
    let mut bld = Builder {
        opts,
        out: Vec::new(),
        pos: None,
        active_tool: None,
        min: [f64::INFINITY; 3],
        max: [f64::NEG_INFINITY; 3],
    };
    let mut summaries = Vec::with_capacity(job.features.len());
    for f in &job.features {
        bld.min = [f64::INFINITY; 3];
        bld.max = [f64::NEG_INFINITY; 3];
        let cuts = Cuts::new(job, f, opts)?;
        let mut summary = cuts.summary();
        match f.kind {
            FeatureKind::Pocket { x, y, length, width, corner_radius } => {
                pocket(&mut bld, &cuts, &mut summary, [x, y, length, width, corner_radius]);
            }
            FeatureKind::Slot { start, end, width, through } => {
                slot(&mut bld, &cuts, &mut summary, [start, end], width, through);
            }
            FeatureKind::Hole { x, y, diameter, method } => {
                let same = (cuts.tool.diameter() - diameter).abs() <= 1e-6;
                let helical =
                    matches!(method, HoleMethod::Helical) || (matches!(method, HoleMethod::Auto) && !same);
                if helical {
                    helical_hole(&mut bld, &cuts, &mut summary, [x, y, diameter]);
                } else {
                    drilled_hole(&mut bld, &cuts, &mut summary, [x, y, diameter], method);
                }
            }
        }
        summary.min = bld.min;
        summary.max = bld.max;
        summaries.push(summary);
    }
    bld.retract();
    bld.rapid(Point3::new(0.0, 0.0, opts.clearance));
    if opts.coolant {
        bld.out.push(Motion::Coolant(Coolant::Off));
    }
    bld.out.push(Motion::Spindle { rpm: 0.0, direction: SpindleDirection::Off });
    bld.out.push(Motion::End);
    Ok(FeaturePlan { motions: bld.out, summaries })
}

/// A pocket at `(x, y)` of `length` x `width` with `corner_radius`: zigzag roughing per cut,
/// then the finishing contour.
fn pocket(
    bld: &mut Builder<'_>,
    c: &Cuts<'_>,
    summary: &mut FeatureSummary,
    [x, y, length, width, corner_radius]: [f64; 5],
) {
    let (tool, ftool, r, rf, d, m, s, f) = (c.tool, c.ftool, c.r, c.rf, c.d, c.m, c.allowance, c.feature);
    let levels = &c.levels;
    let opts = bld.opts;
    let (q, n) = stepover_rule(width, s, r, opts.max_stepover_ratio);
    let off = r + s;
    // Tool-centre region for roughing: the pocket inset by R + S.
    let (u0, u1) = (x + off, x + length - off);
    let (v0, v1) = (y + off, y + width - off);
    // A pocket no wider than the tool plus allowance collapses to its centre line.
    let mid = |a: f64, b: f64| if b < a { (0.5 * (a + b), 0.5 * (a + b)) } else { (a, b) };
    let ((u0, u1), (v0, v1)) = (mid(u0, u1), mid(v0, v1));
    let c = (corner_radius - off).max(0.0).min(0.5 * (u1 - u0)).min(0.5 * (v1 - v0));
    let offsets = row_offsets(v0, v1, q, n);
    let extent = |v: f64| {
        let dv = (v0 + c - v).max(v - (v1 - c));
        let ins = corner_inset(dv, c);
        (u0 + ins, u1 - ins)
    };
    let rows = rows_of(&offsets, extent, |u, v| [u, v]);
    summary.stepover = q;
    summary.passes = n;
    summary.pass_length = u1 - u0;
    summary.operation = "zigzag roughing + contour finishing".into();
    summary.finish_tool = Some(ftool.number);
    bld.comment(format!(
        "pocket {}: {} x {} x {} R{} at X{} Y{}; d={} m={} Q={} N={}",
        f.name,
        fmt(length),
        fmt(width),
        fmt(f.depth),
        fmt(corner_radius),
        fmt(x),
        fmt(y),
        fmt(d),
        m,
        fmt(q),
        n
    ));
    let (sx, sy) = rows.first().map_or((u0, v0), |r| (r.0[0], r.0[1]));
    bld.start_op(tool, "roughing", sx, sy);
    bld.comment("roughing start".into());
    for (j, &z) in levels.iter().enumerate() {
        zigzag(bld, &rows, z, tool, j + 1);
    }
    // Finishing contour at R_f from the walls, counter-clockwise (climb).
    if opts.optional_stop {
        bld.out.push(Motion::Stop { optional: true });
    }
    let (cx, cy) = (x + 0.5 * length, y + 0.5 * width);
    bld.start_op(ftool, "finishing", cx, cy);
    bld.comment("finishing start: rapid to pocket centre".into());
    let z = -f.depth;
    bld.feed(Point3::new(cx, cy, z), ftool.plunge_feed);
    let (a0, a1, b0, b1) = (x + rf, x + length - rf, y + rf, y + width - rf);
    let k = (corner_radius - rf).max(0.0);
    let fd = ftool.feed;
    let p = |u: f64, v: f64| Point3::new(u, v, z);
    bld.feed(p(cx, b0), fd);
    let corners = [
        // (line end, arc end, arc centre)
        ((a1 - k, b0), (a1, b0 + k), (a1 - k, b0 + k)),
        ((a1, b1 - k), (a1 - k, b1), (a1 - k, b1 - k)),
        ((a0 + k, b1), (a0, b1 - k), (a0 + k, b1 - k)),
        ((a0, b0 + k), (a0 + k, b0), (a0 + k, b0 + k)),
    ];
    for (le, ae, ac) in corners {
        bld.feed(p(le.0, le.1), fd);
        if k > 1e-6 {
            bld.arc_ccw(p(ae.0, ae.1), ac.0, ac.1, fd);
        }
    }
    bld.feed(p(cx, b0), fd);
    bld.feed(p(cx, cy), fd);
    bld.retract();
}

/// A slot along the centre line `[start, end]`: zigzag roughing per cut, then its walls.
fn slot(
    bld: &mut Builder<'_>,
    c: &Cuts<'_>,
    summary: &mut FeatureSummary,
    [start, end]: [[f64; 2]; 2],
    width: f64,
    through: bool,
) {
    let (tool, ftool, r, rf, d, m, s, f) = (c.tool, c.ftool, c.r, c.rf, c.d, c.m, c.allowance, c.feature);
    let levels = &c.levels;
    let opts = bld.opts;
    let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
    let len = dx.hypot(dy);
    let (ux, uy) = (dx / len, dy / len);
    // Left normal: +v is to the left of the direction start -> end.
    let (nx, ny) = (-uy, ux);
    let map = |u: f64, v: f64| [start[0] + u * ux + v * nx, start[1] + u * uy + v * ny];
    let (q, n) = stepover_rule(width, s, r, opts.max_stepover_ratio);
    let a = (0.5 * width - r - s).max(0.0);
    let (lo, hi) = if n == 1 { (0.0, 0.0) } else { (-a, a) };
    let offsets = row_offsets(lo, hi, q, n);
    let ext = r + opts.overrun;
    let rows = if through {
        rows_of(&offsets, |_| (-ext, len + ext), map)
    } else {
        rows_of(
            &offsets,
            |v| {
                let e = (a * a - v * v).max(0.0).sqrt();
                (-e, len + e)
            },
            map,
        )
    };
    summary.kind = if through { "through slot" } else { "slot" };
    summary.stepover = q;
    summary.passes = n;
    summary.pass_length = rows.first().map_or(0.0, |r| (r.1[0] - r.0[0]).hypot(r.1[1] - r.0[1]));
    let finishing = 0.5 * width - rf > 1e-6;
    summary.operation =
        if finishing { "zigzag roughing + wall finishing".into() } else { "centre-line passes".into() };
    summary.finish_tool = finishing.then_some(ftool.number);
    bld.comment(format!(
        "{} {}: width {} depth {} from X{} Y{} to X{} Y{}; d={} m={} Q={} N={}",
        summary.kind,
        f.name,
        fmt(width),
        fmt(f.depth),
        fmt(start[0]),
        fmt(start[1]),
        fmt(end[0]),
        fmt(end[1]),
        fmt(d),
        m,
        fmt(q),
        n
    ));
    let (sx, sy) = rows.first().map_or((start[0], start[1]), |r| (r.0[0], r.0[1]));
    bld.start_op(tool, "roughing", sx, sy);
    for (j, &z) in levels.iter().enumerate() {
        zigzag(bld, &rows, z, tool, j + 1);
    }
    if finishing {
        if opts.optional_stop {
            bld.out.push(Motion::Stop { optional: true });
        }
        let z = -f.depth;
        let w = 0.5 * width - rf;
        let fd = ftool.feed;
        let p = |u: f64, v: f64| {
            let q = map(u, v);
            Point3::new(q[0], q[1], z)
        };
        if through {
            // Right wall forward, left wall back (interior on the left: climb).
            let s0 = map(-ext, -w);
            bld.start_op(ftool, "finishing", s0[0], s0[1]);
            bld.comment("finishing: both walls".into());
            bld.feed(p(-ext, -w), ftool.plunge_feed);
            bld.feed(p(len + ext, -w), fd);
            bld.feed(p(len + ext, w), fd);
            bld.feed(p(-ext, w), fd);
        } else {
            let mid = map(0.5 * len, 0.0);
            bld.start_op(ftool, "finishing", mid[0], mid[1]);
            bld.comment("finishing: contour".into());
            bld.feed(p(0.5 * len, 0.0), ftool.plunge_feed);
            bld.feed(p(0.5 * len, -w), fd);
            bld.feed(p(len, -w), fd);
            let e = map(len, 0.0);
            bld.arc_ccw(p(len, w), e[0], e[1], fd);
            bld.feed(p(0.0, w), fd);
            let s0 = map(0.0, 0.0);
            bld.arc_ccw(p(0.0, -w), s0[0], s0[1], fd);
            bld.feed(p(0.5 * len, -w), fd);
            bld.feed(p(0.5 * len, 0.0), fd);
        }
        bld.retract();
    }
}

/// A hole of `diameter` at `(x, y)` larger than the tool: one helical turn per cut, then
/// concentric circles inward.
fn helical_hole(
    bld: &mut Builder<'_>,
    c: &Cuts<'_>,
    summary: &mut FeatureSummary,
    [x, y, diameter]: [f64; 3],
) {
    let (tool, r, d, m, f) = (c.tool, c.r, c.d, c.m, c.feature);
    let levels = &c.levels;
    let opts = bld.opts;
    let rh = 0.5 * diameter - r;
    let r_in = 0.5 * r;
    let (q, rings) = if rh > r_in {
        let k = ((rh - r_in) / (opts.max_stepover_ratio * 2.0 * r) - 1e-9).ceil().max(1.0);
        ((rh - r_in) / k, k as usize)
    } else {
        (0.0, 0)
    };
    summary.kind = "helical hole";
    summary.operation = "helical interpolation + concentric circles".into();
    summary.stepover = q;
    summary.passes = rings + 1;
    bld.comment(format!(
        "helical hole {}: D{} depth {} at X{} Y{}; pitch d={} m={} circles={}",
        f.name,
        fmt(diameter),
        fmt(f.depth),
        fmt(x),
        fmt(y),
        fmt(d),
        m,
        rings + 1
    ));
    bld.start_op(tool, "milling", x + rh, y);
    bld.feed(Point3::new(x + rh, y, 0.0), tool.plunge_feed);
    for (j, &z) in levels.iter().enumerate() {
        bld.comment(format!("helix {}: down to {}", j + 1, fmt(-z)));
        bld.arc_ccw(Point3::new(x + rh, y, z), x, y, tool.plunge_feed);
        bld.arc_ccw(Point3::new(x + rh, y, z), x, y, tool.feed);
        for i in 1..=rings {
            let ri = rh - i as f64 * q;
            bld.feed(Point3::new(x + ri, y, z), tool.feed);
            if ri > 1e-6 {
                bld.arc_ccw(Point3::new(x + ri, y, z), x, y, tool.feed);
            }
        }
        bld.feed(Point3::new(x + rh, y, z), tool.feed);
    }
    bld.feed(Point3::new(x, y, -f.depth), tool.feed);
    bld.retract();
}

/// A hole of `diameter` at `(x, y)` drilled with a canned cycle (or its expanded moves).
fn drilled_hole(
    bld: &mut Builder<'_>,
    c: &Cuts<'_>,
    summary: &mut FeatureSummary,
    [x, y, diameter]: [f64; 3],
    method: HoleMethod,
) {
    let (tool, f) = (c.tool, c.feature);
    let opts = bld.opts;
    let kind = match method {
        HoleMethod::Dwell(sec) => CycleKind::Dwell { seconds: sec.unwrap_or(opts.default_dwell) },
        HoleMethod::Peck(p) => CycleKind::Peck { peck: p.unwrap_or(diameter) },
        HoleMethod::Auto if f.depth > 3.0 * diameter => CycleKind::Peck { peck: diameter },
        _ => CycleKind::Drill,
    };
    let (code, dc, cuts) = match kind {
        CycleKind::Drill => ("G81", f.depth, 1),
        CycleKind::Dwell { .. } => ("G82", f.depth, 1),
        CycleKind::Peck { peck } => {
            ("G83", peck, ((f.depth + opts.r_plane) / peck - 1e-9).ceil().max(1.0) as usize)
        }
    };
    summary.kind = "drilled hole";
    summary.operation = code.into();
    summary.depth_of_cut = dc;
    summary.cuts = cuts;
    bld.comment(format!(
        "drilled hole {}: D{} depth {} at X{} Y{} ({code})",
        f.name,
        fmt(diameter),
        fmt(f.depth),
        fmt(x),
        fmt(y)
    ));
    bld.start_op(tool, "drilling", x, y);
    let cyc = DrillCycle {
        kind,
        x,
        y,
        clearance: bld.clearance(),
        r_plane: opts.r_plane,
        bottom: -f.depth,
        feed: tool.plunge_feed,
    };
    let mut lo = Point3::new(x, y, -f.depth);
    bld.grow(&lo);
    if opts.canned_cycles {
        bld.out.push(Motion::Cycle(cyc));
    } else {
        let mut ms = Vec::new();
        cyc.expand(bld.pos, |m| ms.push(m));
        for m in ms {
            match m {
                Motion::Rapid { to } => bld.rapid(to),
                Motion::Linear { to, feed, .. } => bld.feed(to, feed),
                other => bld.out.push(other),
            }
        }
    }
    lo.z = bld.clearance();
    bld.pos = Some(lo);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tool(number: u32, diameter: f64) -> Tool {
        Tool { number, spindle_rpm: 1200.0, feed: 90.0, plunge_feed: 90.0, ..Tool::flat(0.5 * diameter) }
    }

    fn seed_job() -> FeatureJob {
        FeatureJob {
            block: Block { length: 75.0, width: 60.0, height: 15.0 },
            allowance: 0.4,
            tools: vec![tool(1, 10.0), tool(2, 10.0)],
            features: vec![Feature {
                name: "pocket".into(),
                kind: FeatureKind::Pocket { x: 12.5, y: 12.5, length: 50.0, width: 35.0, corner_radius: 5.0 },
                depth: 5.0,
                tool: 1,
                finish_tool: Some(2),
            }],
        }
    }

    #[test]
    fn seed_rules() {
        let (d, m) = depth_rule(5.0, 5.0, 0.5);
        assert!((d - 2.5).abs() < 1e-12 && m == 2, "depth rule gave d={d} m={m}");
        let (q, n) = stepover_rule(35.0, 0.4, 5.0, 0.9);
        assert!((q - 8.0667).abs() < 1e-4 && n == 4, "step-over rule gave Q={q} N={n}");
        for k in [0.81, 1.0, 1.2] {
            assert_eq!(stepover_rule(35.0, 0.4, 5.0, k).1, 4, "k_q = {k}");
        }
        // Exact multiples do not add a cut or a row.
        assert_eq!(depth_rule(10.0, 5.0, 0.5).1, 4);
        assert_eq!(stepover_rule(10.0, 0.0, 5.0, 0.9), (0.0, 1));
    }

    #[test]
    fn seed_program_moves() {
        let plan = plan_features(&seed_job(), &FeatureOptions::default()).expect("plans");
        let s = &plan.summaries[0];
        assert!((s.pass_length - 39.2).abs() < 1e-9, "pass length {}", s.pass_length);
        assert!((s.stepover - 24.2 / 3.0).abs() < 1e-9);
        // Feed moves along X during roughing are exactly the pass length; the tool centre never
        // comes closer than R to a wall.
        let mut prev: Option<Point3<f64>> = None;
        let mut passes = 0;
        for m in &plan.motions {
            if let Motion::Linear { to, .. } = m {
                if let Some(p) = prev
                    && (p.y - to.y).abs() < 1e-12
                    && (p.z - to.z).abs() < 1e-12
                    && ((p.x - to.x).abs() - 39.2).abs() < 1e-9
                {
                    passes += 1;
                }
                assert!(to.x >= 17.5 - 1e-9 && to.x <= 57.5 + 1e-9, "X {} leaves the pocket", to.x);
                assert!(to.y >= 17.5 - 1e-9 && to.y <= 42.5 + 1e-9, "Y {} leaves the pocket", to.y);
            }
            if let Some(e) = m.end_point() {
                prev = Some(e);
            }
        }
        assert_eq!(passes, 8, "4 passes per cut, 2 cuts");
        assert_eq!(plan.motions.last(), Some(&Motion::End));
    }

    #[test]
    fn bad_jobs_name_the_feature() {
        let opts = FeatureOptions::default();
        let mut j = seed_job();
        if let FeatureKind::Pocket { x, .. } = &mut j.features[0].kind {
            *x = 40.0;
        }
        let e = plan_features(&j, &opts).expect_err("outside").to_string();
        assert!(e.contains("'pocket'") && e.contains("outside"), "{e}");
        let mut j = seed_job();
        j.features[0].depth = 20.0;
        let e = plan_features(&j, &opts).expect_err("deep").to_string();
        assert!(e.contains("'pocket'") && e.contains("beyond the block"), "{e}");
        let mut j = seed_job();
        if let FeatureKind::Pocket { corner_radius, .. } = &mut j.features[0].kind {
            *corner_radius = 3.0;
        }
        let e = plan_features(&j, &opts).expect_err("corner").to_string();
        assert!(e.contains("'pocket'") && e.contains("corner radius"), "{e}");
        let mut j = seed_job();
        j.features[0] = Feature {
            name: "slot A".into(),
            kind: FeatureKind::Slot { start: [10.0, 10.0], end: [40.0, 10.0], width: 8.0, through: false },
            depth: 2.0,
            tool: 1,
            finish_tool: None,
        };
        let e = plan_features(&j, &opts).expect_err("narrow").to_string();
        assert!(e.contains("'slot A'") && e.contains("wider than the slot"), "{e}");
        let mut j = seed_job();
        j.tools = vec![tool(1, 0.004), tool(2, 0.004)];
        if let FeatureKind::Pocket { corner_radius, .. } = &mut j.features[0].kind {
            *corner_radius = 0.01;
        }
        let e = plan_features(&j, &opts).expect_err("tiny tool").to_string();
        assert!(e.contains("'pocket'") && e.contains("too many"), "{e}");
        let mut j = seed_job();
        j.features[0].depth = f64::NAN;
        assert!(plan_features(&j, &opts).is_err());
        j.features[0].depth = 5.0;
        j.features[0].tool = 9;
        let e = plan_features(&j, &opts).expect_err("tool").to_string();
        assert!(e.contains("T9"), "{e}");
    }

    /// The plan streamed straight into the simulator (cycles expanded, no G-code text): no
    /// gouge outside the feature volumes, no rapid through material, nothing left more than a
    /// voxel inside any feature.
    #[test]
    fn motions_cut_exactly_the_features_in_voxsim() {
        use s2g_geom::{Aabb, GridSpec, VoxelGrid};
        use s2g_voxsim::{Cutter, SimOptions, Simulator, ToolTable};
        let job = FeatureJob {
            block: Block { length: 80.0, width: 50.0, height: 8.0 },
            allowance: 0.5,
            tools: vec![tool(1, 10.0), tool(2, 6.0), tool(3, 4.0)],
            features: vec![
                Feature {
                    name: "rounded pocket".into(),
                    kind: FeatureKind::Pocket {
                        x: 4.0,
                        y: 4.0,
                        length: 36.0,
                        width: 26.0,
                        corner_radius: 9.0,
                    },
                    depth: 3.0,
                    tool: 1,
                    finish_tool: Some(2),
                },
                Feature {
                    name: "slanted slot".into(),
                    kind: FeatureKind::Slot {
                        start: [50.0, 8.0],
                        end: [70.0, 20.0],
                        width: 9.0,
                        through: false,
                    },
                    depth: 2.5,
                    tool: 2,
                    finish_tool: None,
                },
                Feature {
                    name: "big bore".into(),
                    kind: FeatureKind::Hole { x: 60.0, y: 38.0, diameter: 18.0, method: HoleMethod::Auto },
                    depth: 4.0,
                    tool: 3,
                    finish_tool: None,
                },
                Feature {
                    name: "peck".into(),
                    kind: FeatureKind::Hole {
                        x: 20.0,
                        y: 42.0,
                        diameter: 4.0,
                        method: HoleMethod::Peck(None),
                    },
                    depth: 8.0,
                    tool: 3,
                    finish_tool: None,
                },
            ],
        };
        let opts = FeatureOptions { canned_cycles: false, ..Default::default() };
        let plan = plan_features(&job, &opts).expect("plans");
        assert_eq!(
            plan.summaries[2].passes, 3,
            "bore: helix + 2 circles (radii 7, 4, 1): {:?}",
            plan.summaries[2]
        );
        assert_eq!(
            (plan.summaries[3].operation.as_str(), plan.summaries[3].cuts),
            ("G83", 3),
            "peck 4 from R1 to -8"
        );
        assert!(!plan.motions.iter().any(|m| matches!(m, Motion::Cycle(_))), "cycles expanded");
        let h = 0.5;
        let bounds = Aabb::new(Point3::new(0.0, 0.0, -8.0), Point3::new(80.0, 50.0, 0.0));
        let spec = GridSpec::new(&bounds, [160, 100, 16]).expect("grid");
        let mut target = VoxelGrid::new(spec);
        target.set_where(|p| !job.removed(p));
        let mut tools = ToolTable::single(Cutter::flat(5.0, 20.0));
        for t in &job.tools {
            tools = tools.with(t.number, Cutter::flat(t.radius(), 20.0));
        }
        let mut sim = Simulator::new(VoxelGrid::full(spec), tools, SimOptions::default())
            .and_then(|s| s.with_target(&target))
            .expect("simulator");
        plan.emit(&mut sim).expect("simulates");
        let sim = sim.into_simulation().expect("result");
        let rep = sim.report();
        assert_eq!(rep.gouge_voxels, 0, "gouges");
        assert_eq!(rep.rapid_collision_voxels, 0, "rapid collisions");
        let res = sim.residual();
        for f in &job.features {
            let mut left = 0;
            for k in 0..16 {
                for j in 0..100 {
                    for i in 0..160 {
                        let p = spec.center(i, j, k);
                        if res.get(i, j, k) && f.outline_distance(p.x, p.y) <= -h && p.z >= -f.depth + h {
                            left += 1;
                        }
                    }
                }
            }
            assert_eq!(left, 0, "{}: voxels left inside", f.name);
        }
    }

    /// Every tool position below the top face (sampled along lines, arcs and helices) keeps
    /// the whole tool disc inside the feature's outline: no gouge, for any valid feature.
    fn assert_inside(job: &FeatureJob, plan: &FeaturePlan) -> Result<(), String> {
        let f = &job.features[0];
        let mut r = 0.0;
        let mut pos: Option<Point3<f64>> = None;
        for m in &plan.motions {
            if let Motion::ToolChange { tool } = m {
                r = job.tools.iter().find(|t| t.number == *tool).map_or(0.0, |t| t.radius());
            }
            let Some(to) = m.end_point() else { continue };
            let from = pos.unwrap_or(to);
            pos = Some(to);
            for i in 0..=32 {
                let t = i as f64 / 32.0;
                let p = match m {
                    Motion::Arc { center, .. } => {
                        let a0 = (from.y - center.y).atan2(from.x - center.x);
                        let a1 = (to.y - center.y).atan2(to.x - center.x);
                        let mut sweep = (a1 - a0).rem_euclid(TAU);
                        if sweep <= 1e-12 {
                            sweep = TAU;
                        }
                        let rr = (from.x - center.x).hypot(from.y - center.y);
                        let a = a0 + t * sweep;
                        Point3::new(
                            center.x + rr * a.cos(),
                            center.y + rr * a.sin(),
                            from.z + t * (to.z - from.z),
                        )
                    }
                    _ => from + t * (to - from),
                };
                let b = job.block;
                let in_block = p.x >= 0.0 && p.y >= 0.0 && p.x <= b.length && p.y <= b.width;
                if p.z < -1e-9 && in_block && f.outline_distance(p.x, p.y) > -r + 1e-6 {
                    return Err(format!("{}: tool at {p:?} (R {r}) leaves the outline", f.name));
                }
                if p.z < -f.depth - 1e-9 {
                    return Err(format!("{}: tool at {p:?} below the floor", f.name));
                }
            }
        }
        Ok(())
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(300))]
        #[test]
        fn random_features_never_gouge(
            kind in 0usize..4,
            a in 0.0f64..1.0, b in 0.0f64..1.0, c in 0.0f64..1.0, e in 0.0f64..1.0,
            dia in 1.0f64..12.0, allowance in 0.0f64..1.0, depth in 0.1f64..20.0,
        ) {
            let block = Block { length: 100.0, width: 80.0, height: 20.0 };
            let r = 0.5 * dia;
            let kind = match kind {
                0 => {
                    let length = 2.0 * r + a * 60.0;
                    let width = 2.0 * r + b * 50.0;
                    let rc = r + c * (0.5 * length.min(width) - r);
                    FeatureKind::Pocket { x: e * (100.0 - length), y: 0.5 * (80.0 - width), length, width, corner_radius: rc }
                }
                1 => {
                    let width = 2.0 * r + a * 10.0;
                    let start = [20.0 + b * 10.0, 20.0 + c * 30.0];
                    FeatureKind::Slot { start, end: [70.0 - e * 10.0, 60.0 - b * 20.0], width, through: false }
                }
                2 => {
                    let width = 2.0 * r + a * 10.0;
                    FeatureKind::Slot { start: [0.0, 40.0 + b], end: [100.0, 40.0 + b], width, through: true }
                }
                _ => FeatureKind::Hole {
                    x: 50.0,
                    y: 40.0,
                    diameter: if a < 0.3 { dia } else { dia + 0.05 + a * 30.0 },
                    method: HoleMethod::Auto,
                },
            };
            let job = FeatureJob {
                block,
                allowance,
                tools: vec![Tool {
                    number: 7,
                    spindle_rpm: 1000.0,
                    feed: 100.0,
                    plunge_feed: 50.0,
                    ..Tool::flat(0.5 * dia)
                }],
                features: vec![Feature { name: "random".into(), kind, depth, tool: 7, finish_tool: None }],
            };
            let opts = FeatureOptions { canned_cycles: false, ..Default::default() };
            let plan = plan_features(&job, &opts).map_err(|e| proptest::test_runner::TestCaseError::fail(e.to_string()))?;
            assert_inside(&job, &plan).map_err(proptest::test_runner::TestCaseError::fail)?;
            let s = &plan.summaries[0];
            proptest::prop_assert!(s.depth_of_cut <= opts.max_depth_ratio * r + 1e-9 || s.kind == "drilled hole");
            proptest::prop_assert!(s.stepover <= opts.max_stepover_ratio * 2.0 * r + 1e-9);
        }
    }

    #[test]
    fn outline_distances() {
        let j = seed_job();
        let f = &j.features[0];
        assert!((f.outline_distance(37.5, 30.0) + 17.5).abs() < 1e-12);
        assert!((f.outline_distance(12.5, 12.5) - (50f64.sqrt() - 5.0)).abs() < 1e-12);
        assert!(f.contains(&Point3::new(20.0, 20.0, -4.9)));
        assert!(!f.contains(&Point3::new(20.0, 20.0, -5.1)));
    }
}
