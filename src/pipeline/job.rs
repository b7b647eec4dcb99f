//! What a setup is planned with: a policy's action mapped to a tool, feeds and plan
//! options, and the features the policy sees.

use super::api::{MillError, MillOptions, Preset};
use crate::gcode::Coolant;
use crate::gcode::MachineProfile;
use crate::geom::{Aabb, MeshIndex, Point3, Setup, Vector3};
use crate::policy::{Action, ActionSpace, FinishChoice, SetupFeatures};
use crate::toolpath::finish::{FinishOptions, RoughedStock};
use crate::toolpath::library::Cutting;
use crate::toolpath::undercut::{Columns, UndercutOptions};
use crate::toolpath::{PlanOptions, Tool, strategies};

/// How far a finisher's shank and holder keep from the stock the roughing may have left
/// (mm; [`RoughedStock::clearance`]): ten times the programs' arc tolerance, so that what
/// the fitted and rounded programs cut differs from the plan by less than it.
const SHANK_CLEARANCE: f64 = 0.1;

/// What one setup is planned with.
#[derive(Clone)]
pub(super) struct Job {
    pub(super) setup: Setup,
    pub(super) action: Action,
    pub(super) tool: Tool,
    pub(super) popts: PlanOptions,
    /// A comment written at the top of the setup's program (the datum), if any.
    pub(super) note: Option<String>,
    /// The finishing after the roughing, if the run finishes.
    pub(super) finish: Option<FinishJob>,
    /// The stock box's upward faces in the setup frame ([`RoughedStock::faces`]).
    pub(super) stock_faces: [[f64; 4]; 3],
    /// A rest-roughing job ([`MillOptions::rest_roughing`]): the 0-based setup it machines
    /// again with a smaller tool; `None` for a setup's own.
    pub(super) rest_of: Option<usize>,
    /// An undercut pass (its tool a T-slot cutter): planned by
    /// [`plan_undercut`](crate::toolpath::undercut::plan_undercut), not layer by layer.
    pub(super) undercut: Option<UndercutJob>,
}

/// What an undercut pass's scan found and its plan reads: the part's columns in the setup's
/// frame, the levels, and the options they were found with (one computation for the scan
/// and the program).
#[derive(Clone)]
pub(super) struct UndercutJob {
    pub(super) columns: std::sync::Arc<Columns>,
    pub(super) levels: Vec<f64>,
    pub(super) opts: UndercutOptions,
}

/// What a setup is finished with.
#[derive(Clone)]
pub(super) struct FinishJob {
    pub(super) choice: FinishChoice,
    pub(super) tool: Tool,
    /// The radius of the setup's widest roughing tool, its own: below the depth its rest
    /// passes reach, the corners keep that radius (the finisher's holder check,
    /// [`RoughedStock::tool_radius`]).
    pub(super) roughed_radius: f64,
    /// Where the finisher machines ([`super::finish_scope`]).
    pub(super) scope: super::finish_scope::FinishScope,
}

impl FinishJob {
    /// The finishing tool, where it takes what the roughing left on every face it reaches
    /// ([`FinishScope::All`](super::finish_scope::FinishScope)): a rest pass is not for
    /// what it takes. `None` where it finishes only the sculpted faces of a setup roughed
    /// to size, whose rest passes are planned as without finishing.
    pub(super) fn takes_rest(&self) -> Option<Tool> {
        (self.scope == super::finish_scope::FinishScope::All).then_some(self.tool)
    }
}

impl Job {
    /// The finisher's options over a part whose tip heights in the setup frame span
    /// `[lo, hi]`: the choice's scallop; the roughing's clearance plane; down to the
    /// lowest point the finishing tool reaches below the stock's top; rapids down to
    /// above a pass by more than the roughing can have left there (the tool radius, a
    /// layer, both allowances and 0.5 more).
    pub(super) fn finish_options(&self, f: &FinishJob, [lo, hi]: [f64; 2]) -> FinishOptions {
        let top = self.popts.stock.map_or(hi, |s| s.max.z);
        let reach = f.tool.envelope().length;
        let floor = if reach.is_finite() { lo.max(top - reach) } else { lo };
        FinishOptions {
            scallop: f.choice.scallop,
            floor: Some(floor),
            clearance: (top - hi).max(0.0) + self.popts.clearance_height.max(1e-3),
            approach: f.tool.radius()
                + self.popts.layer_height
                + self.popts.finishing_allowance
                + self.popts.arc_tolerance.unwrap_or(0.0)
                + self.popts.axial_allowance
                + 0.5,
            rapid_feed: self.popts.rapid_feed,
            coolant: f.tool.coolant != Coolant::Off,
            // What the roughing can have left on the part: the finisher's rapids keep that
            // far from it, beside steep walls as over flats.
            stock_left: Some(
                self.popts.layer_height
                    + self.popts.finishing_allowance
                    + self.popts.arc_tolerance.unwrap_or(0.0)
                    + self.popts.axial_allowance
                    + 0.5,
            ),
            // Passes along X or Y as G18/G19 arcs above the cutter-location points (the
            // milling dialects all select planes).
            arc_tolerance: self.popts.arc_tolerance.filter(|_| self.popts.fit_arcs),
            // The shank and holder keep clear of what this setup's roughing left (issue 35).
            holder_stock: Some(RoughedStock {
                radial: self.popts.finishing_allowance + self.popts.arc_tolerance.unwrap_or(0.0),
                axial: self.popts.layer_height
                    + self.popts.axial_allowance
                    + self.popts.arc_tolerance.unwrap_or(0.0),
                tool_radius: f.roughed_radius,
                top: self.popts.stock.map_or(f64::INFINITY, |s| s.max.z),
                faces: self.stock_faces,
                clearance: SHANK_CLEARANCE,
            }),
            ..FinishOptions::default()
        }
    }
}

impl Job {
    /// `tool` planned with `action` in `setup`; `cutting` (a library tool's) limits the
    /// roughing depth and the stepover.
    pub(super) fn new(
        setup: &Setup,
        action: &Action,
        (tool, cutting): (Tool, Option<Cutting>),
        stock: &Aabb,
        rapid: f64,
        clearance: f64,
        opts: &MillOptions,
    ) -> Result<Self, MillError> {
        let strategy =
            strategies().get(action.strategy.name()).map_err(|e| MillError::InvalidOption(e.to_string()))?;
        let popts = PlanOptions {
            layer_height: action.layer_height,
            strategy,
            contour: opts.contour,
            // With finishing the roughing leaves the finisher's stock.
            finishing_allowance: opts.finish.map_or(0.0, |_| opts.finish_allowance[0]),
            // Arcs fitted on the part's side of the passes, within the tolerance, which
            // the walls keep as well: none comes nearer the part than the allowance.
            arc_tolerance: opts.arc_tolerance,
            fit_arcs: opts.fit_arcs,
            axial_allowance: opts.finish.map_or(0.0, |_| opts.finish_allowance[1]),
            // A library tool roughs as deep as its axial limit in the material allows.
            roughing_depth: match cutting {
                Some(c) => Some(c.max_axial_depth),
                None => (opts.roughing_depth_diameters > 0.0)
                    .then(|| opts.roughing_depth_diameters * tool.diameter()),
            },
            clearance_height: clearance,
            stock: Some(stock_in_setup(stock, setup)),
            rapid_feed: rapid,
            // A shop's finer levels are entered from the side, down in the roughing cut's
            // air, rather than by a ramp at the plunge feed into every step.
            lead_in: cutting.is_some(),
            // The shop preset's levels nest exactly (issue 35); the paper's keep their own offsets.
            nest_levels: opts.preset == Preset::Shop,
            ..PlanOptions::default()
        };
        // A library tool steps over no more than its radial limit.
        let popts = match cutting {
            Some(c) => {
                PlanOptions { stepover: popts.stepover.min(c.max_radial_depth / tool.diameter()), ..popts }
            }
            None => popts,
        };
        let stock_faces = upward_faces(stock, setup);
        Ok(Self {
            setup: *setup,
            action: *action,
            tool,
            popts,
            note: None,
            finish: None,
            stock_faces,
            rest_of: None,
            undercut: None,
        })
    }

    /// An upper estimate of the setup's toolpath length and machining time (hours): every
    /// level cleared whole over the stock's outline at the stepover, at the cutting feed.
    pub(super) fn estimate(&self) -> (f64, f64) {
        let stock = self.popts.stock.unwrap_or_else(Aabb::empty).extent();
        let depth = stock.z.min(self.tool.flute_length());
        let levels = (depth / self.popts.layer_height).ceil().max(1.0);
        let stepover = self.popts.stepover * self.tool.diameter();
        let length =
            levels * (stock.x + 2.0 * self.tool.radius()) * (stock.y + 2.0 * self.tool.radius()) / stepover;
        (length, length / self.tool.feed / 60.0)
    }
}

/// Feed and rapid rates (per minute, in planning units) of the paper's planned tools, and
/// the rapid rate of a machine's (its slowest axis).
pub(super) fn feeds(machine: Option<&MachineProfile>) -> (f64, f64) {
    // The paper's tools are planned in millimetres: 600 mm/min cutting, 5000 mm/min rapids.
    let rapid = machine.map_or(5000.0, |m| m.rapid.iter().copied().fold(f64::INFINITY, f64::min));
    (600.0, rapid)
}

/// Tool numbers follow the action space's radii: T1 is the smallest.
/// Features of one setup: for each radius, the fraction of the surface samples visible
/// from the setup that a ball of that radius touches without entering the part.
pub(super) fn setup_features(
    index: &MeshIndex,
    samples: &crate::geom::SurfaceSamples,
    setup: &Setup,
    space: &ActionSpace,
    diag: f64,
    stock: &Aabb,
    voxel: f64,
) -> SetupFeatures {
    use rayon::prelude::*;
    let axis = setup.tool_axis().into_inner();
    let eps = 1e-6 * diag;
    let visible: Vec<(Point3, Vector3)> = samples
        .points
        .par_iter()
        .zip(samples.normals.par_iter())
        .filter(|(p, n)| n.dot(&axis) > 0.0 && !index.ray_hits_any(&(*p + *n * eps), &axis, diag))
        .map(|(p, n)| (*p, *n))
        .collect();
    // Per radius: at how many visible samples the ball touching there (centre one radius
    // out along the normal) is clear of the part, all but 2 % of its radius; and all but
    // half a voxel, if that is more.
    let (reach_by_radius, reach_at_resolution) = space
        .radii
        .iter()
        .map(|&r| {
            if visible.is_empty() {
                return (0.0, 0.0);
            }
            let (clear, within_voxel) = visible
                .par_iter()
                .map(|(p, n)| {
                    let d = index.signed_distance(&(*p + *n * r));
                    (usize::from(d >= r * 0.98), usize::from(d >= r - (0.02 * r).max(0.5 * voxel)))
                })
                .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
            let n = visible.len() as f64;
            (clear as f64 / n, within_voxel as f64 / n)
        })
        .unzip();
    // The stock's extent along the tool axis: its top and bottom.
    let zs: Vec<f64> = stock.corners().iter().map(|c| c.coords.dot(&axis)).collect();
    let top = zs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let depth = top - zs.iter().copied().fold(f64::INFINITY, f64::min);
    let bins = SetupFeatures::DEPTH_BINS;
    let mut depth_histogram = vec![0.0; bins];
    if !visible.is_empty() && depth > 0.0 {
        for (p, _) in &visible {
            let h = ((top - p.coords.dot(&axis)) / depth).clamp(0.0, 1.0);
            depth_histogram[((h * bins as f64) as usize).min(bins - 1)] += 1.0;
        }
        depth_histogram.iter_mut().for_each(|b| *b /= visible.len() as f64);
    }
    let scale = 1.0 / stock.extent().max().max(f64::MIN_POSITIVE);
    let step = visible.len().div_ceil(SetupFeatures::MAX_POINTS).max(1);
    let points = visible
        .iter()
        .step_by(step)
        .map(|(p, _)| {
            let q = setup.to_setup(p);
            [(q.x * scale) as f32, (q.y * scale) as f32, (q.z * scale) as f32]
        })
        .collect();
    SetupFeatures {
        reach_by_radius,
        reach_at_resolution,
        depth,
        removal_fraction: 0.0,
        voxel,
        visible_fraction: visible.len() as f64 / samples.points.len().max(1) as f64,
        depth_histogram,
        points,
    }
}

/// The upward faces of the stock box (part frame) in `setup`'s frame, `[nx, ny, nz, d]`
/// with `nz > 0` (no stock where `n . q > d`); unused entries `[0, 0, 1, inf]`.
fn upward_faces(stock: &Aabb, setup: &Setup) -> [[f64; 4]; 3] {
    let mut faces = [[0.0, 0.0, 1.0, f64::INFINITY]; 3];
    let (r, t) = (setup.frame.rotation.inverse(), setup.frame.translation.vector);
    let mut k = 0;
    for a in 0..3 {
        for (sign, d) in [(1.0, stock.max[a]), (-1.0, -stock.min[a])] {
            let mut n = Vector3::zeros();
            n[a] = sign;
            let ns = r * n;
            if ns.z > 1e-9 && k < 3 {
                faces[k] = [ns.x, ns.y, ns.z, d - n.dot(&t)];
                k += 1;
            }
        }
    }
    faces
}

/// The stock box as seen in a setup's frame (the box around its rotated corners).
pub(super) fn stock_in_setup(stock: &Aabb, setup: &Setup) -> Aabb {
    let mut b = Aabb::empty();
    for c in stock.corners() {
        b.grow(&setup.to_setup(&c));
    }
    b
}
