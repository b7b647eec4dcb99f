//! Collision-free milling layers (§4.1-4.2, §5.4, §7.4 of seed 002): a layer field `G`
//! (a [`Siren`]) whose level sets are the milling layers and whose normal is the tool
//! axis, optimised from planar layers by the milling total loss (Eq. 40).
//!
//! - [`Tool`] (`tool.rs`): a physical cutter sampled as points (Appendix B): rings of
//!   points on its stack's surface at fixed axial intervals from an offset above the
//!   tool's base point, plus points on the axis; the ring phase is perturbed every step.
//! - [`MillingProblem`]: the part (any [`SignedDistance`], e.g. [`MeshSdf`](crate::MeshSdf) for geom's
//!   exact mesh distance), the block, the tool, and the pose points (the block minus the
//!   part, offset by the tool radius).
//! - [`milling_losses`]: the tool-part collision loss (Eq. 14-15), the inter-layer
//!   collision loss (Eq. 13 read for milling), the layer-spacing loss (Eq. 26), the
//!   zero-gradient loss (Eq. 27) and the curvature loss (Eq. 24) with the singularity mask
//!   (Eq. 52-53), combined by [`MillingWeights`] (Table 1's milling row, Eq. 40).
//! - [`pretrain_planar`] starts `G` from planar layers (`G = z`), [`optimize_layers`]
//!   runs Adam on Eq. 40 with the collision weight increased gradually, sampling the
//!   colliding ("hot") poses more often, then repair rounds that check every pose with the
//!   check's tool sampling and train on the colliding ones with a growing collision
//!   weight until none is left; [`count_collisions`] / [`colliding_poses`] count the
//!   sampled tool poses that hit the part or unmilled material.
//! - The collision loss only puts the tool points within the clearance of the part into
//!   the tensor graph (elsewhere the ReLU and its gradient are zero), so a dense tool
//!   sampling (the check's: rings 2 mm apart, 24 points) costs little more than a coarse
//!   one; [`MeshSdf`](crate::MeshSdf) (`mesh_sdf.rs`) caches the winding-number sign on a lattice.
//! - The Adam loop, the batches, the weight ramp, the layer regularisers and the
//!   inter-layer collision term are the training base shared with printing (`train.rs`).
//! - [`cup_mesh`]: a cup with an inward-overhanging lip, made by revolving a profile.
//!
//! Coordinates: the part, block, tool and poses are in the part's units (e.g. mm); the
//! network sees them through a [`Normalization`] (the block's bounding box centred and its
//! largest side scaled to 1), so `G` and its derivatives are in unit-cube coordinates.

use std::time::Instant;

use burn::optim::AdamConfig;
use burn::tensor::{Int, Tensor, TensorData};
use s2g_geom::{Aabb, Mesh, Normalization, Point3, SignedDistance, Vector3};

use crate::backend::Backend;
use crate::error::{FieldError, Result};
use crate::layer::LayerGeometry;
use crate::siren::{Siren, SirenConfig, SirenF64};
use crate::tool::{Tool, place_tool, tool_points};
use crate::train::{
    Batcher, LossConstants, LossLog, device_of, fit_planar, layer_collision, loss_values, ramp, regularisers,
    train,
};

/// Weights of the milling total loss (Eq. 40 of seed 002).
///
/// Table 1 gives the milling row: layer spacing 2.0, layer curvature 0.2 and the
/// collision weight rising from 8000 to 40000. The zero-gradient weight is not in the
/// table; 1.0 is this crate's choice. The collision weight multiplies both collision
/// terms (tool-part, Eq. 15, and inter-layer, Eq. 13).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MillingWeights {
    /// Layer spacing (Eq. 26). Table 1: `2.0`.
    pub spacing: f64,
    /// Layer curvature (Eq. 24). Table 1: `0.2`.
    pub curvature: f64,
    /// Zero gradient (Eq. 27). Not in Table 1; default `1.0`.
    pub zero_gradient: f64,
    /// Collision weight at the first step. Table 1: `8000`.
    pub collision_start: f64,
    /// Collision weight at the last step (linear in between). Table 1: `40000`.
    pub collision_end: f64,
}

impl Default for MillingWeights {
    fn default() -> Self {
        Self {
            spacing: 2.0,
            curvature: 0.2,
            zero_gradient: 1.0,
            collision_start: 8000.0,
            collision_end: 40000.0,
        }
    }
}

impl MillingWeights {
    /// The collision weight at `step` of `steps`: linear from `collision_start` to
    /// `collision_end` (the "gradual weight-increasing strategy" of §5.5).
    pub fn collision_at(&self, step: usize, steps: usize) -> f64 {
        ramp(self.collision_start, self.collision_end, step, steps)
    }
}

/// The part, the block, the tool and the pose points of a milling problem.
pub struct MillingProblem<'a> {
    part: &'a dyn SignedDistance,
    block: Aabb,
    tool: Tool,
    poses: Vec<Point3>,
    normalization: Normalization,
}

impl std::fmt::Debug for MillingProblem<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MillingProblem")
            .field("block", &self.block)
            .field("tool", &self.tool)
            .field("poses", &self.poses.len())
            .finish_non_exhaustive()
    }
}

impl<'a> MillingProblem<'a> {
    /// A problem whose poses are the points of a grid of spacing `grid` over `block` that
    /// lie at least `tool.radius() + margin` outside the part (the tool centre's reachable
    /// region: the block minus the part, offset by the tool).
    ///
    /// Errors: [`FieldError::InvalidArgument`] for a degenerate or non-finite block, a bad
    /// `grid` or `margin`, or no pose points; [`FieldError::InvalidConfig`] for a bad tool.
    pub fn new(
        part: &'a dyn SignedDistance,
        block: Aabb,
        tool: Tool,
        grid: f64,
        margin: f64,
    ) -> Result<Self> {
        tool.validate()?;
        let finite = |p: &Point3| p.iter().all(|c| c.is_finite());
        let ext = block.max - block.min;
        if !(finite(&block.min) && finite(&block.max) && ext.min() > 0.0) {
            return Err(FieldError::InvalidArgument("the block is degenerate or not finite".into()));
        }
        if !(grid.is_finite() && grid > 0.0 && margin.is_finite() && margin >= 0.0) {
            return Err(FieldError::InvalidArgument(format!("bad grid {grid} or margin {margin}")));
        }
        let counts = ext.map(|e| (e / grid).floor() as usize + 1);
        if counts.iter().product::<usize>() > 4_000_000 {
            return Err(FieldError::InvalidArgument("the pose grid is too fine (> 4M points)".into()));
        }
        let mut poses = Vec::new();
        for i in 0..counts.x {
            for j in 0..counts.y {
                for k in 0..counts.z {
                    let p = block.min + Vector3::new(i as f64, j as f64, k as f64) * grid;
                    if part.distance(&p) >= tool.radius() + margin {
                        poses.push(p);
                    }
                }
            }
        }
        Self::with_poses(part, block, tool, poses)
    }

    /// A problem with the given pose points (in the part's units).
    ///
    /// Errors as for [`MillingProblem::new`], and [`FieldError::NonFinite`] for a NaN pose.
    pub fn with_poses(
        part: &'a dyn SignedDistance,
        block: Aabb,
        tool: Tool,
        poses: Vec<Point3>,
    ) -> Result<Self> {
        tool.validate()?;
        if poses.is_empty() {
            return Err(FieldError::InvalidArgument("no pose points".into()));
        }
        if let Some(i) = poses.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(FieldError::NonFinite { what: "pose point", index: i });
        }
        let extent = (block.max - block.min).max();
        if !(extent.is_finite() && extent > 0.0) {
            return Err(FieldError::InvalidArgument("the block is degenerate or not finite".into()));
        }
        let scale = 1.0 / extent;
        let center = (block.min.coords + block.max.coords) * 0.5;
        let normalization = Normalization { scale, translation: -center * scale };
        Ok(Self { part, block, tool, poses, normalization })
    }

    /// The part.
    pub fn part(&self) -> &'a dyn SignedDistance {
        self.part
    }

    /// The pose points.
    pub fn poses(&self) -> &[Point3] {
        &self.poses
    }

    /// The block.
    pub fn block(&self) -> &Aabb {
        &self.block
    }

    /// The tool.
    pub fn tool(&self) -> &Tool {
        &self.tool
    }

    /// The map from the part's units into the layer field's unit cube.
    pub fn normalization(&self) -> Normalization {
        self.normalization
    }

    fn unit(&self, p: &Point3) -> [f32; 3] {
        let u = self.normalization.to_unit(p);
        [u.x as f32, u.y as f32, u.z as f32]
    }

    fn in_block(&self, p: &Point3) -> bool {
        (0..3).all(|a| p[a] >= self.block.min[a] && p[a] <= self.block.max[a])
    }
}

/// The unweighted losses of one evaluation of Eq. 40, as tensors (scalars, `[1]`).
#[derive(Debug, Clone)]
pub struct MillingLosses {
    /// Tool-part collision (Eq. 15).
    pub part_collision: Tensor<1>,
    /// Inter-layer collision (Eq. 13 for milling: tool points inside the block must lie on
    /// layers not yet milled... i.e. `G(p) >= G(x)`, the layers milled before `x`'s).
    pub layer_collision: Tensor<1>,
    /// Layer spacing (Eq. 26): `mean |∇|∇G||²`, with `∇|∇G| = ∇²G ∇G / |∇G|`.
    pub spacing: Tensor<1>,
    /// Zero gradient (Eq. 27).
    pub zero_gradient: Tensor<1>,
    /// Curvature (Eq. 24) with the singularity mask.
    pub curvature: Tensor<1>,
    /// The poses of the evaluation (indices into the problem's) whose tool had a point
    /// closer to the part than the clearance (a positive Eq. 15 term).
    pub near_poses: Vec<usize>,
}

impl MillingLosses {
    /// Eq. 40: `w_ld L_ld + w_lc L_lc + w_zg L_zg + w_c (L_part + L_layer)`.
    pub fn total(&self, w: &MillingWeights, collision_weight: f64) -> Tensor<1> {
        self.spacing.clone().mul_scalar(w.spacing)
            + self.curvature.clone().mul_scalar(w.curvature)
            + self.zero_gradient.clone().mul_scalar(w.zero_gradient)
            + (self.part_collision.clone() + self.layer_collision.clone()).mul_scalar(collision_weight)
    }
}

/// Evaluates the milling losses of `g` at the poses `idx` of `problem`, with the tool's
/// rings rotated by `phase`.
///
/// The tool points `p = x + a n + u e1 + v e2` follow the layer normal `n(x)` as tensors;
/// the part's distance at them is linearised around their current positions,
/// `φ(p) ≈ φ(p0) + ∇φ(p0)·(p - p0)` with `φ(p0)`, `∇φ(p0)` from the host SDF (Eq. 50: the
/// derivative of the collision term is `∇φ · ∂p/∂θ`).
pub fn milling_losses(
    g: &Siren,
    problem: &MillingProblem<'_>,
    idx: &[usize],
    phase: f64,
    constants: &LossConstants,
) -> Result<MillingLosses> {
    milling_losses_with(g, problem, &problem.tool, idx, phase, constants)
}

/// [`milling_losses`] with another sampling of the tool than the problem's.
fn milling_losses_with(
    g: &Siren,
    problem: &MillingProblem<'_>,
    tool: &Tool,
    idx: &[usize],
    phase: f64,
    constants: &LossConstants,
) -> Result<MillingLosses> {
    if idx.is_empty() {
        return Err(FieldError::InvalidArgument("no poses selected".into()));
    }
    if let Some(&i) = idx.iter().find(|&&i| i >= problem.poses.len()) {
        return Err(FieldError::InvalidArgument(format!("pose index {i} out of range")));
    }
    let device = device_of(g);
    let n = idx.len();
    let scale = problem.normalization.scale;
    let xw: Vec<f32> = idx
        .iter()
        .flat_map(|&i| problem.poses[i].coords.iter().map(|&c| c as f32).collect::<Vec<_>>())
        .collect();
    let xu: Vec<f32> = idx.iter().flat_map(|&i| problem.unit(&problem.poses[i])).collect();
    let x_world = Tensor::<2>::from_data(TensorData::new(xw, [n, 3]), &device);
    let x_unit = Tensor::<2>::from_data(TensorData::new(xu, [n, 3]), &device);

    let out = g.forward_hessian(x_unit);
    let geo = LayerGeometry::new(out.gradient.clone(), out.hessian.clone());
    let (spacing, zero_gradient, curvature) = regularisers(&out, &geo, scale, constants);

    // Tool points, [n * t, 3], in the part's units.
    let (p, t) = tool_points(x_world, geo.normal.clone(), tool, phase);
    let m = n * t;

    // The part's distance at the current tool points (host SDF). Only points closer than
    // the clearance contribute to Eq. 15 (the ReLU is zero, with zero gradient, elsewhere),
    // so only those enter the tensor graph; the loss is still the mean over all `m`.
    let p_host = crate::backend::host_values(p.clone().detach())?;
    let eps = constants.part_clearance;
    let (mut part_rows, mut phi0, mut grad0, mut p0) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut layer_rows = Vec::new();
    let mut near = vec![false; n];
    for (k, c) in p_host.chunks_exact(3).enumerate() {
        let q = Point3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        let d = problem.part.distance(&q);
        if !d.is_finite() {
            return Err(FieldError::NonFinite { what: "part distance at a tool point", index: k });
        }
        if d < eps {
            let gr = problem.part.gradient(&q);
            part_rows.push(k as i64);
            phi0.push(d as f32);
            grad0.extend([gr.x as f32, gr.y as f32, gr.z as f32]);
            p0.extend_from_slice(c);
            near[k / t] = true;
        }
        // Inter-layer collisions only count in the material to be removed (inside the
        // block, outside the part: the part itself is Eq. 15's).
        if d > 0.0 && problem.in_block(&q) {
            layer_rows.push(k);
        }
    }
    let k_slope = constants.collision_slope;
    let part_collision = if part_rows.is_empty() {
        Tensor::<1>::zeros([1], &device)
    } else {
        let a = part_rows.len();
        let rows = Tensor::<1, Int>::from_data(TensorData::new(part_rows, [a]), &device);
        let phi0 = Tensor::<2>::from_data(TensorData::new(phi0, [a, 1]), &device);
        let grad0 = Tensor::<2>::from_data(TensorData::new(grad0, [a, 3]), &device);
        let p0 = Tensor::<2>::from_data(TensorData::new(p0, [a, 3]), &device);
        // φ(p) ≈ φ(p0) + ∇φ(p0)·(p - p0), differentiable through p (Eq. 50).
        let phi = phi0 + (grad0 * (p.clone().select(0, rows) - p0)).sum_dim(1);
        // Eq. 15: ReLU(k (ε - φ(p))) in unit-cube lengths.
        phi.neg().add_scalar(eps).mul_scalar(scale * k_slope).clamp_min(0.0).sum().div_scalar(m as f64)
    };

    // Eq. 13 for milling: G(p) >= G(x) + ε for tool points in the material still there.
    let (layer_collision, _) = layer_collision(
        g,
        &problem.normalization,
        p,
        out.value.clone(),
        &layer_rows,
        t,
        m,
        phase,
        constants,
    )?;
    let near_poses = idx.iter().zip(&near).filter(|(_, h)| **h).map(|(&i, _)| i).collect();

    Ok(MillingLosses { part_collision, layer_collision, spacing, zero_gradient, curvature, near_poses })
}

/// How [`pretrain_planar`] and [`optimize_layers`] run.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerOptions {
    /// The layer field's network. Default: 3 sine layers of 64, `ω0 = 3`, `ω = 30`
    /// (a low first-layer frequency: milling layers are smooth at the block's scale).
    pub network: SirenConfig,
    /// Adam steps fitting `G = z` (planar layers). Default `300`.
    pub pretrain_steps: usize,
    /// Adam steps on Eq. 40. Default `300`.
    pub steps: usize,
    /// Poses per step (a random subset of the problem's). Default `256`.
    pub batch_size: usize,
    /// Adam's learning rate for the optimisation (the pretraining uses `1e-3`). Default
    /// `1e-4` (on the cup, `5e-4` made the layers diverge and collide more).
    pub learning_rate: f64,
    /// Loss weights. Default [`MillingWeights::default`] (Table 1).
    pub weights: MillingWeights,
    /// Constants of the individual losses. Default [`LossConstants::default`].
    pub constants: LossConstants,
    /// Seed of the batches and the ring phases. Default `0`.
    pub seed: u64,
    /// Repair rounds after the steps (see [`optimize_layers`]). Default `16`; `0` skips
    /// the checks.
    pub repair_rounds: usize,
    /// Adam steps per repair round. Default `30`.
    pub repair_steps: usize,
    /// Each repair round multiplies the learning rate by this, in `(0, 1]`. Default `0.7`.
    pub repair_decay: f64,
    /// Each repair round multiplies the collision weight (from `weights.collision_end`) by
    /// this, `>= 1`. Default `1.5`.
    pub repair_weight_growth: f64,
    /// The tool sampling of the repair rounds' checks and steps; `None` (default): the
    /// problem's.
    pub check_tool: Option<Tool>,
    /// The Burn backend. Default [`Backend::default`].
    pub backend: Backend,
}

impl Default for LayerOptions {
    fn default() -> Self {
        Self {
            network: SirenConfig { sine_layers: 3, width: 64, first_omega: 3.0, hidden_omega: 30.0, seed: 0 },
            pretrain_steps: 300,
            steps: 300,
            batch_size: 256,
            learning_rate: 1e-4,
            weights: MillingWeights::default(),
            constants: LossConstants::default(),
            seed: 0,
            repair_rounds: 16,
            repair_steps: 30,
            repair_decay: 0.7,
            repair_weight_growth: 1.5,
            check_tool: None,
            backend: Backend::default(),
        }
    }
}

impl LayerOptions {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        self.network.validate()?;
        if let Some(t) = &self.check_tool {
            t.validate()?;
        }
        if !(self.repair_decay > 0.0 && self.repair_decay <= 1.0) {
            return Err(FieldError::config("repair_decay", "must be in (0, 1]"));
        }
        if !(self.repair_weight_growth.is_finite() && self.repair_weight_growth >= 1.0) {
            return Err(FieldError::config("repair_weight_growth", "must be finite and >= 1"));
        }
        if self.batch_size == 0 {
            return Err(FieldError::config("batch_size", "must be at least 1"));
        }
        FieldError::check_positive(&[("learning_rate", self.learning_rate)])?;
        let w = self.weights;
        FieldError::check_non_negative(&[
            ("weights.spacing", w.spacing),
            ("weights.curvature", w.curvature),
            ("weights.zero_gradient", w.zero_gradient),
            ("weights.collision_start", w.collision_start),
            ("weights.collision_end", w.collision_end),
        ])?;
        let c = self.constants;
        FieldError::check_non_negative(&[
            ("constants.collision_slope", c.collision_slope),
            ("constants.part_clearance", c.part_clearance),
            ("constants.layer_clearance", c.layer_clearance),
            ("constants.max_curvature", c.max_curvature),
            ("constants.curvature_factor", c.curvature_factor),
            ("constants.singular_gradient", c.singular_gradient),
            ("constants.min_gradient", c.min_gradient),
        ])?;
        if c.singular_gradient == 0.0 {
            return Err(FieldError::config("constants.singular_gradient", "must be > 0"));
        }
        Ok(())
    }
}

/// A layer field with planar layers: a [`Siren`] fitted by Adam to `G(x̂) = ẑ` (value and
/// gradient) on uniform points of the unit cube, on an autodiff device.
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::Diverged`].
pub fn pretrain_planar(options: &LayerOptions) -> Result<Siren> {
    options.validate()?;
    fit_planar(&options.network, options.pretrain_steps, options.seed, options.backend)
}

/// What [`optimize_layers`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerReport {
    /// Adam steps taken, repair steps included.
    pub steps: usize,
    /// Unweighted losses of the last step: part collision, layer collision, spacing, zero
    /// gradient, curvature.
    pub final_losses: [f32; 5],
    /// Repair rounds that ran (each after a check that found colliding poses).
    pub repair_rounds: usize,
    /// The counts of the returned field's check (with [`LayerOptions::check_tool`]), when
    /// [`LayerOptions::repair_rounds`] is above zero: zero colliding poses unless the
    /// rounds ran out (then the best check's).
    pub collisions: Option<CollisionCount>,
    /// Every check's counts, in order.
    pub checks: Vec<CollisionCount>,
    /// Wall-clock seconds of the optimisation (the checks included).
    pub seconds: f64,
}

/// Optimises the layer field `g` (on an autodiff device, e.g. from [`pretrain_planar`])
/// by Adam on Eq. 40 over `problem`'s poses, the collision weight rising linearly from
/// `weights.collision_start` to `weights.collision_end`, then repairs what a check finds.
///
/// - Each batch takes up to half its poses from the *hot* ones: poses whose tool came
///   within the clearance of the part when last evaluated (active-set sampling; the
///   collisions are rare, so uniform batches see few of them).
/// - After the steps, up to [`LayerOptions::repair_rounds`] rounds: count the colliding
///   poses with [`LayerOptions::check_tool`] ([`colliding_poses`]); if there are any, run
///   [`LayerOptions::repair_steps`] steps whose batches hold every colliding pose (then
///   those of earlier rounds, then random ones), sampling the tool with the check's own
///   points on even steps and a random ring phase on odd ones. Each round multiplies the
///   collision weight (from `weights.collision_end`) by
///   [`LayerOptions::repair_weight_growth`] and the learning rate by
///   [`LayerOptions::repair_decay`]: a penalty method on a hinge with a margin
///   ([`LossConstants::part_clearance`]), whose violation where it balances the
///   regularisers shrinks as the weight grows, until the constraint itself (distance `>= 0`
///   at every check point) holds. The report holds every check; when the rounds run out,
///   the field of the best check is returned (and [`LayerReport::collisions`] is its).
///
/// Deterministic for fixed options (single-threaded backend, seeded batches and phases).
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::Diverged`],
/// [`FieldError::NonFinite`] if the part's distance is not finite at a tool point.
pub fn optimize_layers(
    g: Siren,
    problem: &MillingProblem<'_>,
    options: &LayerOptions,
) -> Result<(Siren, LayerReport)> {
    options.validate()?;
    let start = Instant::now();
    let mut run = LayerTraining::new(problem, options);
    let g = run.main_steps(g)?;
    let mut report = LayerReport {
        steps: 0,
        final_losses: [0.0; 5],
        repair_rounds: 0,
        collisions: None,
        checks: Vec::new(),
        seconds: 0.0,
    };
    let check_tool = options.check_tool.unwrap_or(problem.tool);
    let g = run.repair(g, &check_tool, &mut report)?;
    report.steps = run.log.steps;
    report.final_losses = run.log.last;
    report.seconds = start.elapsed().as_secs_f64();
    Ok((g, report))
}

/// Eq. 40 at the poses `idx` for one Adam step: the weighted total (collision weight
/// `collision_weight`), the unweighted values in [`LayerReport::final_losses`]' order
/// ([`FieldError::Diverged`] at `step`), and the poses whose tool came closer to the part
/// than the clearance.
// The main and the repair steps differ in every argument; a struct would only rename them.
#[allow(clippy::too_many_arguments)]
fn milling_step(
    g: &Siren,
    problem: &MillingProblem<'_>,
    tool: &Tool,
    idx: &[usize],
    phase: f64,
    collision_weight: f64,
    options: &LayerOptions,
    step: usize,
) -> Result<(Tensor<1>, [f32; 5], Vec<usize>)> {
    let losses = milling_losses_with(g, problem, tool, idx, phase, &options.constants)?;
    let total = losses.total(&options.weights, collision_weight);
    let values = loss_values(
        [
            &losses.part_collision,
            &losses.layer_collision,
            &losses.spacing,
            &losses.zero_gradient,
            &losses.curvature,
        ],
        step,
    )?;
    Ok((total, values, losses.near_poses))
}

/// [`optimize_layers`]' state across its main steps and repair rounds: one Adam, one
/// batcher (its shuffles, hot poses and ring phases), one record of the losses.
struct LayerTraining<'p, 'a> {
    problem: &'p MillingProblem<'a>,
    options: &'p LayerOptions,
    opt: burn::optim::ModuleOptimizer,
    batcher: Batcher,
    idx: Vec<usize>,
    log: LossLog<5>,
}

impl<'p, 'a> LayerTraining<'p, 'a> {
    fn new(problem: &'p MillingProblem<'a>, options: &'p LayerOptions) -> Self {
        Self {
            problem,
            options,
            opt: AdamConfig::new().init(),
            batcher: Batcher::new(problem.poses.len(), options.seed),
            idx: Vec::with_capacity(options.batch_size),
            log: LossLog::new(),
        }
    }

    /// The main steps: batches with hot poses, a random ring phase per step, the collision
    /// weight on its ramp.
    fn main_steps(&mut self, g: Siren) -> Result<Siren> {
        let (problem, options) = (self.problem, self.options);
        let (batcher, idx) = (&mut self.batcher, &mut self.idx);
        train(g, &mut self.opt, options.learning_rate, options.steps, &mut self.log, |g, step| {
            batcher.batch(options.batch_size, &[], idx);
            let phase = batcher.rng.uniform(0.0, std::f64::consts::TAU);
            let wc = options.weights.collision_at(step, options.steps);
            let (total, values, near) =
                milling_step(g, problem, &problem.tool, idx, phase, wc, options, step)?;
            batcher.update(idx, &near);
            Ok((total, values))
        })
    }

    /// The repair rounds of [`optimize_layers`]: check, train on what collides, keep the
    /// best check's field; the checks go into `report`.
    fn repair(&mut self, mut g: Siren, check_tool: &Tool, report: &mut LayerReport) -> Result<Siren> {
        let (problem, options) = (self.problem, self.options);
        let mut wc = options.weights.collision_end;
        // Every pose found colliding so far stays in the repair batches, so that fixing some
        // does not undo others.
        let mut kept: Vec<usize> = Vec::new();
        let mut is_kept = vec![false; problem.poses.len()];
        let mut lr = options.learning_rate;
        // The field of the best check so far: the rounds are not monotone.
        let mut best: Option<(Siren, CollisionCount)> = None;
        for round in 0..=options.repair_rounds {
            if options.repair_rounds == 0 {
                break;
            }
            let (count, bad) = colliding_poses(&g.to_f64()?, problem, check_tool)?;
            report.collisions = Some(count);
            report.checks.push(count);
            if best
                .as_ref()
                .is_none_or(|(_, c): &(Siren, CollisionCount)| count.part + count.layer < c.part + c.layer)
            {
                best = Some((g.clone(), count));
            }
            if bad.is_empty() || round == options.repair_rounds {
                break;
            }
            for &i in &bad {
                if !is_kept[i] {
                    is_kept[i] = true;
                    kept.push(i);
                }
            }
            report.repair_rounds += 1;
            lr *= options.repair_decay;
            // A penalty with a margin: the larger its weight, the smaller the violation of
            // the margin where it balances the regularisers, down to none of the constraint
            // itself.
            wc *= options.repair_weight_growth;
            g = self.repair_steps(g, check_tool, &bad, &kept, lr, wc)?;
        }
        if let (Some((field, count)), Some(last)) = (best, report.collisions)
            && count.part + count.layer < last.part + last.layer
        {
            g = field;
            report.collisions = Some(count);
        }
        Ok(g)
    }

    /// One repair round's steps on the colliding poses `bad` (and those of earlier rounds,
    /// `kept`), at learning rate `lr` and collision weight `wc`, the check's tool sampled
    /// with its own points on even steps and a random ring phase on odd ones.
    fn repair_steps(
        &mut self,
        g: Siren,
        check_tool: &Tool,
        bad: &[usize],
        kept: &[usize],
        lr: f64,
        wc: f64,
    ) -> Result<Siren> {
        let (problem, options) = (self.problem, self.options);
        let (batcher, idx) = (&mut self.batcher, &mut self.idx);
        let (mut cursor, mut s) = (0, 0);
        train(g, &mut self.opt, lr, options.repair_steps, &mut self.log, |g, step| {
            // The colliding poses first (all when they fit, in turn otherwise), then the
            // ones that collided in earlier rounds, then random ones.
            let quota = options.batch_size.div_ceil(2).max(1);
            let mut forced: Vec<usize> = bad.iter().copied().take(quota).collect();
            if bad.len() > quota {
                forced = (0..quota).map(|k| bad[(cursor + k) % bad.len()]).collect();
                cursor = (cursor + quota) % bad.len();
            } else {
                forced.extend(kept.iter().copied().filter(|i| !bad.contains(i)).take(quota - forced.len()));
            }
            batcher.batch(options.batch_size, &forced, idx);
            let random_phase = batcher.rng.uniform(0.0, std::f64::consts::TAU);
            let phase = if s % 2 == 0 { 0.0 } else { random_phase };
            s += 1;
            let (total, values, near) = milling_step(g, problem, check_tool, idx, phase, wc, options, step)?;
            batcher.update(idx, &near);
            Ok((total, values))
        })
    }
}

/// Counts of sampled tool poses in collision.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CollisionCount {
    /// Poses evaluated.
    pub poses: usize,
    /// Poses with a tool point inside the part (distance below zero).
    pub part: usize,
    /// Poses with a tool point in the remaining material (inside the block, outside the
    /// part, on a layer `G(p) < G(x)`, i.e. not milled yet).
    pub layer: usize,
}

/// Counts the poses of `problem` whose tool, placed along the normal of the layer field
/// `g` (evaluated on the host in `f64`) and sampled by `tool` (may be denser than the
/// problem's own), has a point inside the part (`distance < 0`) or in material not yet
/// milled. Poses where `∇G = 0` count as colliding.
pub fn count_collisions(g: &SirenF64, problem: &MillingProblem<'_>, tool: &Tool) -> Result<CollisionCount> {
    Ok(colliding_poses(g, problem, tool)?.0)
}

/// [`count_collisions`] with the indices (into the problem's poses, ascending) of the
/// poses that collide with the part or with material not milled yet.
pub fn colliding_poses(
    g: &SirenF64,
    problem: &MillingProblem<'_>,
    tool: &Tool,
) -> Result<(CollisionCount, Vec<usize>)> {
    tool.validate()?;
    let local = tool.points(0.0);
    let nz = &problem.normalization;
    let mut out = CollisionCount { poses: problem.poses.len(), part: 0, layer: 0 };
    let mut bad = Vec::new();
    for (i, x) in problem.poses.iter().enumerate() {
        let u = nz.to_unit(x);
        let (gx, grad) = g.value_gradient([u.x, u.y, u.z]);
        let n = Vector3::new(grad[0], grad[1], grad[2]);
        let Some(n) = n.try_normalize(1e-12) else {
            out.part += 1;
            out.layer += 1;
            bad.push(i);
            continue;
        };
        let (mut hit_part, mut hit_layer) = (false, false);
        for p in place_tool(x, &n, &local) {
            let d = problem.part.distance(&p);
            if d < 0.0 {
                hit_part = true;
            } else if problem.in_block(&p) {
                let pu = nz.to_unit(&p);
                if g.value([pu.x, pu.y, pu.z]) < gx {
                    hit_layer = true;
                }
            }
            if hit_part && hit_layer {
                break;
            }
        }
        out.part += hit_part as usize;
        out.layer += hit_layer as usize;
        if hit_part || hit_layer {
            bad.push(i);
        }
    }
    Ok((out, bad))
}

/// A cup: a solid of revolution about `+Z` with its base on `z = 0`, outer radius
/// `outer_radius`, height `height`, a cavity of radius `cavity_radius` from
/// `z = base` up to the lip, and an inward lip of thickness `lip` at the top leaving an
/// opening of radius `opening_radius`, so the cavity overhangs: planar layers with the
/// tool along `+Z` cannot reach the cavity's rim under the lip. `segments` facets around.
///
/// Errors: [`FieldError::InvalidArgument`] unless `0 < opening_radius < cavity_radius <
/// outer_radius`, `0 < base`, `0 < lip`, `base + lip < height`, all finite, and
/// `segments >= 3`.
#[allow(clippy::too_many_arguments)]
pub fn cup_mesh(
    outer_radius: f64,
    height: f64,
    cavity_radius: f64,
    opening_radius: f64,
    base: f64,
    lip: f64,
    segments: usize,
) -> Result<Mesh> {
    let ok = [outer_radius, height, cavity_radius, opening_radius, base, lip].iter().all(|v| v.is_finite())
        && 0.0 < opening_radius
        && opening_radius < cavity_radius
        && cavity_radius < outer_radius
        && base > 0.0
        && lip > 0.0
        && base + lip < height
        && (3..=100_000).contains(&segments);
    if !ok {
        return Err(FieldError::InvalidArgument("cup dimensions out of range".into()));
    }
    // The profile (r, z), from the bottom pole to the cavity-floor pole; the solid lies to
    // the profile's right when walked in this order (counter-clockwise around it).
    let profile = [
        (outer_radius, 0.0),
        (outer_radius, height),
        (opening_radius, height),
        (opening_radius, height - lip),
        (cavity_radius, height - lip),
        (cavity_radius, base),
    ];
    let (bottom_pole, top_pole) = (Point3::new(0.0, 0.0, 0.0), Point3::new(0.0, 0.0, base));
    let mut vertices = vec![bottom_pole, top_pole];
    for &(r, z) in &profile {
        for s in 0..segments {
            let t = std::f64::consts::TAU * s as f64 / segments as f64;
            vertices.push(Point3::new(r * t.cos(), r * t.sin(), z));
        }
    }
    let ring = |i: usize, s: usize| (2 + i * segments + s % segments) as u32;
    let mut tris = Vec::new();
    let last = profile.len() - 1;
    for s in 0..segments {
        tris.push([0, ring(0, s + 1), ring(0, s)]);
        for i in 0..last {
            let (a, b, c, d) = (ring(i, s), ring(i, s + 1), ring(i + 1, s), ring(i + 1, s + 1));
            tris.push([a, b, d]);
            tris.push([a, d, c]);
        }
        tris.push([1, ring(last, s), ring(last, s + 1)]);
    }
    let mesh = Mesh::new(vertices, tris).map_err(FieldError::geom)?;
    Ok(if mesh.signed_volume() < 0.0 { mesh.flipped() } else { mesh })
}
