//! [`PlanOptions`]: what a setup is planned with besides the part and the tool.

use std::sync::Arc;

use s2g_geom::{Aabb, Point3};

use crate::strategy::ClearingStrategy;
use crate::zigzag::Zigzag;

/// Default radians per arc segment in offsets (about 63 segments per full circle).
pub const DEFAULT_ARC_STEP: f64 = 0.1;

/// How the tool enters material below the previous level.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RampOptions {
    /// Descent angle of ramps and helices, degrees from horizontal. Default 3.
    pub angle_deg: f64,
    /// Radius of the helix the tool centre follows; `None` (default) means half the tool radius.
    pub helix_radius: Option<f64>,
    /// Shortest usable ramp; `None` (default) means the tool radius. Where neither a helix
    /// nor a ramp fits, the tool plunges straight at the plunge feed.
    pub min_ramp_length: Option<f64>,
}

impl Default for RampOptions {
    fn default() -> Self {
        Self { angle_deg: 3.0, helix_radius: None, min_ramp_length: None }
    }
}

/// Planning options. Distances are in part units, in the setup frame.
#[derive(Debug, Clone)]
pub struct PlanOptions {
    /// Largest depth of cut per layer. Default 1/64 (the paper's coarsest, normalised units).
    pub layer_height: f64,
    /// Distance between neighbouring clearing passes as a fraction of the tool diameter,
    /// in (0, 1]. Default 0.5.
    pub stepover: f64,
    /// Clearing strategy, run on each layer after the contour. Default zigzag along X
    /// ([`Zigzag::default`]). Any [`ClearingStrategy`] plugs in here, the built-in ones
    /// by name through [`strategies()`](crate::strategies).
    pub strategy: Arc<dyn ClearingStrategy>,
    /// Run the contour pass along the offset keep-out before clearing (§3.3.1: the paper
    /// always does). `false` leaves it out, for ablations; the clearing passes still stay
    /// in the free region, so the program stays safe. Default true.
    pub contour: bool,
    /// Radial stock to leave: material left on the part's walls (horizontally) for a
    /// finishing pass. Default 0.
    pub finishing_allowance: f64,
    /// Axial stock to leave: the tool tip stays this far above every face of the part
    /// below it (levels snap to each horizontal face this far above it), so a finishing
    /// pass finds an even skin on floors as on walls. Default 0.
    pub axial_allowance: f64,
    /// Climb milling (with a clockwise spindle) rather than conventional. Default true.
    pub climb: bool,
    /// Height of the clearance plane above the stock top (Appendix A.1: 0.1 in normalised
    /// units). Default 0.1.
    pub clearance_height: f64,
    /// Rapid descents stop this far above the previous level before feeding in; `None`
    /// (default) means half the layer height.
    pub retract_gap: Option<f64>,
    /// The stock box in the setup frame; `None` (default) means the part's bounding box in
    /// the setup frame grown by `stock_margin`.
    pub stock: Option<Aabb>,
    /// Margin around the part for the default stock. Default 0.
    pub stock_margin: f64,
    /// The start position (Eq. 4) in the setup frame; `None` (default) means above the
    /// stock's minimum corner (outside it by the tool radius) at the clearance plane.
    pub safe_start: Option<Point3>,
    /// Entry moves.
    pub ramp: RampOptions,
    /// Radians per arc segment in offsets (chord tolerance: the sagitta is
    /// `radius * (1 - cos(arc_step / 2))`). Default [`DEFAULT_ARC_STEP`].
    pub arc_step: f64,
    /// Keep-outs are thinned (Douglas-Peucker) at `offset_eps * tool radius`, and rid of
    /// slits and spikes narrower than that, before offsetting
    /// (the offset grows by as much, so it stays conservative). Default 1e-3.
    pub offset_eps: f64,
    /// Put a layer exactly on every horizontal face's level. Default true.
    pub snap_to_flats: bool,
    /// A face is horizontal when `|n_z| >= 1 - flat_tolerance`. Default 1e-6.
    pub flat_tolerance: f64,
    /// Faces within this distance above a level do not block the tool there (its tip may
    /// rest on them); also the merge distance of flat levels. Default 1e-7.
    pub level_tolerance: f64,
    /// Lowest level to cut (setup frame z); `None` (default) means the part's lowest point
    /// (never below the stock bottom, nor deeper than the flute length below the stock top).
    pub bottom: Option<f64>,
    /// Longest link cut at feed without retracting (it must also stay in the free region);
    /// `None` (default) means two tool diameters.
    pub max_stay_down_link: Option<f64>,
    /// Rapid traverse rate for time estimates, units per minute. Default 5000.
    pub rapid_feed: f64,
    /// Cell size of the remaining-material map in rest machining; `None` (default) means
    /// the larger of half the step-over and 1/256 of the stock's larger side.
    pub rest_cell: Option<f64>,
    /// Layers planned concurrently before their motions are streamed (bounds memory).
    /// Default 32.
    pub layers_per_batch: usize,
    /// Largest axial depth of cut of a roughing layer; `None` (default) clears every layer
    /// whole, as the paper does (§3.3). With `Some(d)`, the levels are grouped top down so
    /// that each group spans at most `d`: its lowest level (the roughing level) clears the
    /// whole free region in one cut of the group's depth, and only then are the group's
    /// finer levels above it machined, each with its contour and its clearing limited to
    /// where the roughing cut's tool centres did not stand (the steps along the part's
    /// sloping walls; a level whose keep-out is the roughing level's has nothing left). The
    /// finished shape is the same; the clearing passes of all but one level per group are
    /// saved. A `d` below the layer height changes nothing.
    pub roughing_depth: Option<f64>,
    /// Faces steeper than about 89.4 degrees whose projection along the tool axis is
    /// narrower than this are left out of the keep-out regions, which are then exact to
    /// within this width; the tool-centre keep-out grows by as much more, so the tool
    /// stays as far from the part. Numerically vertical slivers (walls rounded to single
    /// precision, or cut by a boolean) otherwise make the keep-outs' boundaries grow
    /// without bound from layer to layer. `None` (default) means 1e-6 of the stock's
    /// larger horizontal side (0.1 µm on a 100 mm part).
    pub sliver_width: Option<f64>,
    /// Measure [`PlanSummary::air_cut_fraction`] in rest machining: one remaining-material
    /// query per half tool radius of path, which for a small tool on fine layers costs more
    /// than planning. Default false.
    pub measure_air_cut: bool,
    /// Enter a finer level's path (one above a roughing level, see
    /// [`roughing_depth`](Self::roughing_depth)) from the side where it can: the tool goes
    /// down in the roughing level's free region next to the path's start, where that
    /// level's cut has already removed the material, and feeds across to the start, rather
    /// than ramping down into the step beside the wall; a clearing pass that starts in
    /// material but reaches air is entered there; and between two paths of a level whose
    /// link lies in its free region the tool crosses just above the level before, where
    /// its descents stop, rather than at the clearance plane. Default false (the paper's
    /// entries and retracts).
    pub lead_in: bool,
    /// Write the passes with G2/G3 arcs (and runs that a line fits as one line) within this
    /// tolerance, `None` (default): straight moves through every planned point. The walls
    /// keep the tolerance as allowance (the tool centre keep-out grows by it), and every
    /// fitted piece lies on the part's side of the path it replaces, within the tolerance
    /// ([`s2g_gcode::fit_planar`]): it comes no nearer the part than the finishing
    /// allowance, and leaves no material the path would have cut (where a rapid or the
    /// next layer would find it). A tolerance with `fit_arcs` false plans the same paths
    /// written straight (the reference the fitted program is compared with).
    pub arc_tolerance: Option<f64>,
    /// With [`arc_tolerance`](Self::arc_tolerance): fit the pieces (default true); false
    /// writes the same plan with straight moves.
    pub fit_arcs: bool,
    /// Grow each level's tool-centre keep-out from the level above's, so that the levels'
    /// free regions nest as polygons and a rapid down to the level above meets no material
    /// (issue 35). Off by default, which keeps the paper's programs as they were: there
    /// the levels' own offsets differ from nesting by far less than a voxel, and the nested
    /// keep-outs accumulate vertices over many fine levels. On in the shop preset.
    pub nest_levels: bool,
    /// Add a floor level (`floors.rs`) in each region a level leaves the tool that the
    /// next level down does not enter: at the lowest height the tool's envelope reaches
    /// there (a V groove as wide as the tool), one per region (issue 35). Off by default;
    /// on for the shop preset's rest passes.
    pub floor_levels: bool,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            layer_height: 1.0 / 64.0,
            stepover: 0.5,
            strategy: Arc::new(Zigzag::default()),
            contour: true,
            finishing_allowance: 0.0,
            axial_allowance: 0.0,
            climb: true,
            clearance_height: 0.1,
            retract_gap: None,
            stock: None,
            stock_margin: 0.0,
            safe_start: None,
            ramp: RampOptions::default(),
            arc_step: DEFAULT_ARC_STEP,
            offset_eps: 1e-3,
            snap_to_flats: true,
            flat_tolerance: 1e-6,
            level_tolerance: 1e-7,
            bottom: None,
            max_stay_down_link: None,
            rapid_feed: 5000.0,
            rest_cell: None,
            layers_per_batch: 32,
            roughing_depth: None,
            sliver_width: None,
            measure_air_cut: false,
            lead_in: false,
            arc_tolerance: None,
            fit_arcs: true,
            nest_levels: false,
            floor_levels: false,
        }
    }
}

impl PlanOptions {
    /// What the walls keep radially: the finishing allowance and the arc tolerance.
    pub(crate) fn wall_allowance(&self) -> f64 {
        self.finishing_allowance + self.arc_tolerance.unwrap_or(0.0)
    }

    /// The tolerance arcs are fitted with, where they are.
    pub(crate) fn arc_fit(&self) -> Option<f64> {
        self.arc_tolerance.filter(|_| self.fit_arcs)
    }

    /// Checks every option and the strategy's own parameters; the message names the
    /// offending one.
    pub(crate) fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be positive and finite, got {v}"))
            }
        };
        let nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be finite and >= 0, got {v}"))
            }
        };
        pos("layer_height", self.layer_height)?;
        if !(self.stepover > 0.0 && self.stepover <= 1.0) {
            return Err(format!(
                "stepover must be in (0, 1] (fraction of the diameter), got {}",
                self.stepover
            ));
        }
        nonneg("finishing_allowance", self.finishing_allowance)?;
        nonneg("axial_allowance", self.axial_allowance)?;
        nonneg("clearance_height", self.clearance_height)?;
        nonneg("stock_margin", self.stock_margin)?;
        pos("arc_step", self.arc_step)?;
        nonneg("flat_tolerance", self.flat_tolerance)?;
        nonneg("offset_eps", self.offset_eps)?;
        nonneg("level_tolerance", self.level_tolerance)?;
        pos("rapid_feed", self.rapid_feed)?;
        if !(self.ramp.angle_deg > 0.0 && self.ramp.angle_deg <= 90.0) {
            return Err(format!("ramp angle must be in (0, 90] degrees, got {}", self.ramp.angle_deg));
        }
        for (name, v) in [
            ("retract_gap", self.retract_gap),
            ("ramp.helix_radius", self.ramp.helix_radius),
            ("ramp.min_ramp_length", self.ramp.min_ramp_length),
            ("max_stay_down_link", self.max_stay_down_link),
            ("bottom", self.bottom.map(f64::abs)),
        ] {
            if let Some(v) = v {
                nonneg(name, v)?;
            }
        }
        if let Some(c) = self.rest_cell {
            pos("rest_cell", c)?;
        }
        if let Some(w) = self.sliver_width {
            nonneg("sliver_width", w)?;
        }
        if let Some(d) = self.roughing_depth {
            pos("roughing_depth", d)?;
        }
        if let Some(t) = self.arc_tolerance {
            pos("arc_tolerance", t)?;
        }
        self.strategy.validate()?;
        if let Some(p) = self.safe_start
            && !p.iter().all(|c| c.is_finite())
        {
            return Err("safe_start must be finite".into());
        }
        Ok(())
    }
}
