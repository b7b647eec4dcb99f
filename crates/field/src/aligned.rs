//! Direction-aligned printing layers and toolpaths (§5.2-5.3, §7.2-7.3 of seed 002).
//!
//! A prescribed direction field `d` (e.g. the maximum principal stress of a loaded part)
//! should lie in the printed layers (Eq. 18/21: the layer normal `∇G/|∇G|` across `d`) and,
//! for continuous-fibre printing, the toolpaths (iso-curves of a path field `P` on the
//! layers) should run along it (Eq. 17/20, 19/22).
//!
//! - [`AlignProblem`]: a [`PrintProblem`] (part, nozzle, platform, deposition poses) with
//!   the prescribed direction at each pose (zero where nothing is prescribed).
//! - DAC, Eq. 38 ([`dac_losses`], [`DacLosses::total`], [`optimize_dac_layers`]): the
//!   layer regularisers (spacing Eq. 26, curvature Eq. 24 with the singularity mask, zero
//!   gradient Eq. 27), the layer–direction alignment (Eq. 21) and the nozzle's collisions
//!   with printed layers (Eq. 13) and with the platform (Eq. 36), computed exactly as for
//!   Eq. 37 (the support-free terms replaced by the alignment, §5.2). Table 1's DAC row
//!   ([`DacWeights`]): layer spacing 2.0, layer curvature 0.2, the collision weight rising
//!   from 8000 to 40000.
//! - TGC, Eq. 39 ([`tgc_losses`], [`TgcLosses::total`], [`optimize_tgc`]): the layer
//!   regularisers and the layer alignment of Eq. 38, plus the toolpath regularisers (path
//!   spacing Eq. 28, path curvature Eq. 25 with the mask of Eq. 52-53) and the toolpath
//!   alignment (Eq. 20 and 22), over `G` and `P` together: one Adam over both networks'
//!   parameters ([`LayerPathFields`]), so that the layers bend to what the paths need
//!   (§7.3's co-optimisation, against [`optimize_path`](crate::optimize_path)'s sequential
//!   scheme). Table 1's TGC row ([`TgcWeights`]): layer spacing 2.0, layer curvature 0.2,
//!   path spacing 2.0, path curvature rising from 0.001 to 1.0 (§7.5.2: a curvature loss
//!   from the start would suppress the singularities the paths need), no collision term.
//! - Measures: [`layer_alignment`] (per pose, the angle between `d` and the layer's
//!   tangent plane) and [`alignment_stats`]; the nozzle collisions are
//!   [`print_collisions`](crate::print_collisions)'s and the toolpath measures
//!   [`path_stats`](crate::path_stats)'s ([`AlignProblem::unit_samples`]).
//! - [`bent_arm_axis`]: the axis direction of [`bent_arm_mesh`](crate::bent_arm_mesh)'s arm,
//!   the principal-stress-like field of a bent cantilever under an end load (bending
//!   stress runs along the axis). Planar layers cut across it: 90° in the column.
//!
//! The direction losses are those of [`direction_losses`] (non-normalised, §4.3) on the
//! networks' unit-cube gradients, with the seed's intrinsic factor 10 as their default
//! weight; Table 1 gives no separate weight for them.

use std::time::Instant;

use burn::module::Module;
use burn::optim::AdamConfig;
use burn::tensor::{Tensor, TensorData};
use s2g_geom::{Point3, Vector3};

use crate::additive::{PrintConstants, PrintProblem, check_indices, nozzle_terms};
use crate::backend::Backend;
use crate::error::{FieldError, Result};
use crate::layer::LayerGeometry;
use crate::path::{
    direction_losses, geodesic_curvature, path_curvature_loss, path_spacing, path_spacing_loss,
};
use crate::siren::{Siren, SirenConfig, SirenF64};
use crate::train::LossConstants;
use crate::train::{Batcher, LossLog, device_of, fit_planar, loss_values, ramp, regularisers, train};

/// A printing problem with a prescribed direction at each deposition pose.
#[derive(Debug)]
pub struct AlignProblem<'a> {
    print: PrintProblem<'a>,
    directions: Vec<Vector3>,
}

impl<'a> AlignProblem<'a> {
    /// `print`'s part, nozzle, platform and poses, with `directions[i]` prescribed at pose
    /// `i` (any length, normalised here; a zero vector prescribes nothing there). The
    /// directions are lines: `d` and `-d` are the same.
    ///
    /// Errors: [`FieldError::InvalidArgument`] for a direction count that differs from the
    /// pose count or no non-zero direction; [`FieldError::NonFinite`] for a non-finite one.
    pub fn new(print: PrintProblem<'a>, directions: Vec<Vector3>) -> Result<Self> {
        if directions.len() != print.poses().len() {
            return Err(FieldError::InvalidArgument(format!(
                "{} directions for {} poses",
                directions.len(),
                print.poses().len()
            )));
        }
        if let Some(index) = directions.iter().position(|d| !d.iter().all(|c| c.is_finite())) {
            return Err(FieldError::NonFinite { what: "direction", index });
        }
        let directions: Vec<Vector3> =
            directions.iter().map(|d| d.try_normalize(1e-12).unwrap_or_else(Vector3::zeros)).collect();
        if directions.iter().all(|d| *d == Vector3::zeros()) {
            return Err(FieldError::InvalidArgument("no non-zero direction".into()));
        }
        Ok(Self { print, directions })
    }

    /// [`AlignProblem::new`] with the direction `field(pose)` at each pose.
    ///
    /// Errors: as [`AlignProblem::new`]'s.
    pub fn from_field(print: PrintProblem<'a>, field: impl Fn(&Point3) -> Vector3) -> Result<Self> {
        let directions = print.poses().iter().map(field).collect();
        Self::new(print, directions)
    }

    /// The printing problem (part, nozzle, platform, poses).
    pub fn print(&self) -> &PrintProblem<'a> {
        &self.print
    }

    /// The unit (or zero) prescribed direction at each pose.
    pub fn directions(&self) -> &[Vector3] {
        &self.directions
    }

    /// The poses in the networks' unit-cube coordinates and their directions, as
    /// [`path_stats`](crate::path_stats) and [`optimize_path`](crate::optimize_path) take
    /// them.
    pub fn unit_samples(&self) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        let nz = self.print.normalization();
        self.print
            .poses()
            .iter()
            .zip(&self.directions)
            .map(|(p, d)| {
                let u = nz.to_unit(p);
                ([u.x, u.y, u.z], [d.x, d.y, d.z])
            })
            .unzip()
    }

    /// The directions at `idx` as a `[n, 3]` tensor on `device`.
    fn direction_tensor(&self, idx: &[usize], device: &burn::tensor::Device) -> Tensor<2> {
        let v: Vec<f32> = idx.iter().flat_map(|&i| self.directions[i].iter().map(|&c| c as f32)).collect();
        Tensor::<2>::from_data(TensorData::new(v, [idx.len(), 3]), device)
    }
}

/// The axis direction of [`bent_arm_mesh`](crate::bent_arm_mesh)`(_, column, bend_radius,
/// bend_deg, ..)` at `p` (unit, in the XZ plane): `+Z` below the bend (`z <= column`),
/// `(sin t, 0, cos t)` in the bend, where `t` is `p`'s angle about the bend's centre
/// `(bend_radius, ·, column)`, and the arm's direction beyond it. Continuous; the direction
/// of the bending stress of the arm loaded at its end.
///
/// Never panics: a non-finite or negative `bend_deg` is read as no bend, and a point whose
/// angle is undefined (NaN) gets `+Z`.
pub fn bent_arm_axis(p: &Point3, column: f64, bend_radius: f64, bend_deg: f64) -> Vector3 {
    let limit = if bend_deg.is_finite() { bend_deg.max(0.0).to_radians() } else { 0.0 };
    // `f64::max` / `min` drop a NaN angle (to 0); `clamp` would pass it through.
    let t = (p.z - column).atan2(bend_radius - p.x).max(0.0).min(limit);
    Vector3::new(t.sin(), 0.0, t.cos())
}

/// The angle in degrees between the prescribed direction `direction` and the tangent plane
/// of the layer with gradient `layer_gradient` (neither need be unit): `asin(|n̂·d̂|)`,
/// i.e. 90° minus the angle between the layer normal and `d`. 0° when `d` lies in the
/// layer (Eq. 18), 90° when the layer cuts straight across it. `None` for a zero
/// direction; 90° for a zero gradient (no layer to lie in).
pub fn layer_alignment(layer_gradient: &Vector3, direction: &Vector3) -> Option<f64> {
    let d = direction.try_normalize(1e-300)?;
    Some(match layer_gradient.try_normalize(1e-300) {
        Some(n) => n.dot(&d).abs().min(1.0).asin().to_degrees(),
        None => 90.0,
    })
}

/// How well a layer field's layers contain the prescribed directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlignmentStats {
    /// Poses with a prescribed direction.
    pub samples: usize,
    /// Mean [`layer_alignment`] angle, degrees.
    pub mean_deg: f64,
    /// Largest angle, degrees.
    pub max_deg: f64,
    /// Fraction of the poses within 10° of alignment.
    pub fraction_within_10: f64,
}

/// [`layer_alignment`] of `g` (evaluated on the host in `f64`) at every pose of `problem`
/// with a prescribed direction.
pub fn alignment_stats(g: &SirenF64, problem: &AlignProblem<'_>) -> AlignmentStats {
    let angles: Vec<f64> = problem
        .print
        .poses()
        .iter()
        .zip(&problem.directions)
        .filter_map(|(p, d)| layer_alignment(&problem.print.build_direction(g, p).1, d))
        .collect();
    let n = angles.len().max(1) as f64;
    AlignmentStats {
        samples: angles.len(),
        mean_deg: angles.iter().sum::<f64>() / n,
        max_deg: angles.iter().copied().fold(0.0, f64::max),
        fraction_within_10: angles.iter().filter(|&&a| a <= 10.0).count() as f64 / n,
    }
}

/// Weights of the DAC total loss (Eq. 38 of seed 002).
///
/// Table 1's DAC row: layer spacing 2.0, layer curvature 0.2, the collision weight rising
/// from 8000 to 40000. The alignment (Eq. 21) enters with the seed's intrinsic factor 10.
/// The zero-gradient weight is not in the table; it is 10 here (1 for milling and
/// printing): where the layers cannot turn (the nozzle would hit the platform), Eq. 21
/// would otherwise be lowered by flattening `G` (`10 (∇G·d)²` and `w ReLU(0.5 - |∇G|)`
/// balance at `|∇G| = w / 20` along `d`: 0.05 for `w = 1`, Eq. 27's bound 0.5 for `w = 10`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DacWeights {
    /// Layer spacing (Eq. 26). Table 1: `2.0`.
    pub spacing: f64,
    /// Layer curvature (Eq. 24). Table 1: `0.2`.
    pub curvature: f64,
    /// Zero gradient (Eq. 27). Not in Table 1; default `10` (see above).
    pub zero_gradient: f64,
    /// Layer–direction alignment (Eq. 21). Default `10` (the intrinsic factor of §4.3).
    pub alignment: f64,
    /// Collision weight (Eq. 13 and 36) at the first step. Table 1: `8000`.
    pub collision_start: f64,
    /// Collision weight at the last step (linear in between). Table 1: `40000`.
    pub collision_end: f64,
}

impl Default for DacWeights {
    fn default() -> Self {
        Self {
            spacing: 2.0,
            curvature: 0.2,
            zero_gradient: 10.0,
            alignment: 10.0,
            collision_start: 8000.0,
            collision_end: 40000.0,
        }
    }
}

impl DacWeights {
    /// The collision weight at `step` of `steps` (linear, §5.5).
    pub fn collision_at(&self, step: usize, steps: usize) -> f64 {
        ramp(self.collision_start, self.collision_end, step, steps)
    }

    fn validate(&self) -> Result<()> {
        FieldError::check_non_negative(&[
            ("weights.spacing", self.spacing),
            ("weights.curvature", self.curvature),
            ("weights.zero_gradient", self.zero_gradient),
            ("weights.alignment", self.alignment),
            ("weights.collision_start", self.collision_start),
            ("weights.collision_end", self.collision_end),
        ])
    }
}

/// The unweighted losses of one evaluation of Eq. 38, as tensors (scalars, `[1]`).
#[derive(Debug, Clone)]
pub struct DacLosses {
    /// Layer–direction alignment (Eq. 21): `mean (∇G · d)²` (unit-cube `∇G`, unit `d`).
    pub alignment: Tensor<1>,
    /// Nozzle–printed-layer collision (Eq. 13).
    pub collision: Tensor<1>,
    /// Nozzle–platform collision (Eq. 36).
    pub platform: Tensor<1>,
    /// Layer spacing (Eq. 26).
    pub spacing: Tensor<1>,
    /// Zero gradient (Eq. 27).
    pub zero_gradient: Tensor<1>,
    /// Curvature (Eq. 24) with the singularity mask.
    pub curvature: Tensor<1>,
    /// The poses of the evaluation (indices into the problem's) with a positive collision
    /// term (either).
    pub colliding_poses: Vec<usize>,
}

impl DacLosses {
    /// Eq. 38: `w_ld L_ld + w_lc L_lc + w_zg L_zg + w_a L_a + w_c (L_c + L_p)`.
    pub fn total(&self, w: &DacWeights, collision_weight: f64) -> Tensor<1> {
        self.spacing.clone().mul_scalar(w.spacing)
            + self.curvature.clone().mul_scalar(w.curvature)
            + self.zero_gradient.clone().mul_scalar(w.zero_gradient)
            + self.alignment.clone().mul_scalar(w.alignment)
            + (self.collision.clone() + self.platform.clone()).mul_scalar(collision_weight)
    }

    /// The six values, in the order of [`DacReport::final_losses`], or
    /// [`FieldError::Diverged`] at `step`.
    fn values(&self, step: usize) -> Result<[f32; 6]> {
        loss_values(
            [
                &self.alignment,
                &self.collision,
                &self.platform,
                &self.spacing,
                &self.zero_gradient,
                &self.curvature,
            ],
            step,
        )
    }
}

/// Evaluates the DAC losses (Eq. 38) of `g` at the poses `poses` (indices into the
/// problem's), the nozzle's rings rotated by `phase`: the regularisers and the collision
/// terms of [`print_losses`](crate::print_losses) at the poses, and the alignment of the
/// layers with the prescribed directions there. `constants`' support-free fields are
/// unused.
///
/// Errors: [`FieldError::InvalidArgument`] for an empty or out-of-range index list,
/// [`FieldError::InvalidConfig`] for bad constants, [`FieldError::NonFinite`] if the part's
/// distance is not finite at a nozzle point.
pub fn dac_losses(
    g: &Siren,
    problem: &AlignProblem<'_>,
    poses: &[usize],
    phase: f64,
    constants: &PrintConstants,
) -> Result<DacLosses> {
    constants.validate()?;
    let terms = nozzle_terms(g, &problem.print, poses, phase, constants)?;
    let device = terms.field.gradient.device();
    let d = problem.direction_tensor(poses, &device);
    // Eq. 21 only: G's part of the direction losses (the path field is not involved).
    let alignment = (terms.field.gradient.clone() * d).sum_dim(1).square().mean();
    Ok(DacLosses {
        alignment,
        collision: terms.collision,
        platform: terms.platform,
        spacing: terms.spacing,
        zero_gradient: terms.zero_gradient,
        curvature: terms.curvature,
        colliding_poses: terms.colliding_poses,
    })
}

/// How [`pretrain_planar_dac`] and [`optimize_dac_layers`] run.
#[derive(Debug, Clone, PartialEq)]
pub struct DacOptions {
    /// The layer field's network. Default: 3 sine layers of 64, `ω0 = 5`, `ω = 30` (as
    /// for printing).
    pub network: SirenConfig,
    /// Adam steps fitting `G = ẑ` (planar layers). Default `300`.
    pub pretrain_steps: usize,
    /// Adam steps on Eq. 38. Default `300`.
    pub steps: usize,
    /// Poses per step. Default `128`.
    pub batch_size: usize,
    /// Adam's learning rate. Default `5e-4`.
    pub learning_rate: f64,
    /// Loss weights. Default [`DacWeights::default`] (Table 1's DAC row).
    pub weights: DacWeights,
    /// Constants of the layer and nozzle losses (the support-free ones unused). Default
    /// [`PrintConstants::default`].
    pub constants: PrintConstants,
    /// Seed of the batches and the ring phases. Default `0`.
    pub seed: u64,
    /// The Burn backend. Default [`Backend::default`].
    pub backend: Backend,
}

impl Default for DacOptions {
    fn default() -> Self {
        Self {
            network: SirenConfig { sine_layers: 3, width: 64, first_omega: 5.0, hidden_omega: 30.0, seed: 0 },
            pretrain_steps: 300,
            steps: 300,
            batch_size: 128,
            learning_rate: 5e-4,
            weights: DacWeights::default(),
            constants: PrintConstants::default(),
            seed: 0,
            backend: Backend::default(),
        }
    }
}

impl DacOptions {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        self.network.validate()?;
        self.constants.validate()?;
        if self.steps == 0 {
            return Err(FieldError::config("steps", "must be at least 1"));
        }
        if self.batch_size == 0 {
            return Err(FieldError::config("batch_size", "must be at least 1"));
        }
        FieldError::check_positive(&[("learning_rate", self.learning_rate)])?;
        self.weights.validate()
    }
}

/// Planar layers (`G = ẑ`) for [`optimize_dac_layers`]: a new network of
/// `options.network` fitted as [`pretrain_planar`](crate::pretrain_planar) does, on an
/// autodiff device.
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::Diverged`].
pub fn pretrain_planar_dac(options: &DacOptions) -> Result<Siren> {
    options.validate()?;
    fit_planar(&options.network, options.pretrain_steps, options.seed, options.backend)
}

/// What [`optimize_dac_layers`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct DacReport {
    /// Adam steps taken.
    pub steps: usize,
    /// Unweighted losses of the first step: alignment, collision, platform, spacing, zero
    /// gradient, curvature.
    pub initial_losses: [f32; 6],
    /// Unweighted losses of the last step, in the same order.
    pub final_losses: [f32; 6],
    /// Wall-clock seconds of the optimisation.
    pub seconds: f64,
}

/// Optimises the layer field `g` (on an autodiff device, e.g. from
/// [`pretrain_planar_dac`]) by Adam on Eq. 38 over `problem`'s poses, the collision weight
/// rising linearly from `weights.collision_start` to `weights.collision_end`; each batch
/// takes up to half its poses among those whose nozzle last collided (as
/// [`optimize_print_layers`](crate::optimize_print_layers) does).
///
/// Deterministic for fixed options (single-threaded backend, seeded batches and phases).
///
/// Errors: [`FieldError::InvalidConfig`] for bad options,
/// [`FieldError::Diverged`], [`FieldError::NonFinite`] if the part's distance is not finite
/// at a nozzle point.
pub fn optimize_dac_layers(
    g: Siren,
    problem: &AlignProblem<'_>,
    options: &DacOptions,
) -> Result<(Siren, DacReport)> {
    options.validate()?;
    let start = Instant::now();
    let mut opt = AdamConfig::new().init();
    let mut poses = Batcher::new(problem.print.poses().len(), options.seed);
    let mut log = LossLog::new();
    let mut idx = Vec::new();
    let g = train(g, &mut opt, options.learning_rate, options.steps, &mut log, |g, step| {
        poses.batch(options.batch_size, &[], &mut idx);
        let phase = poses.rng.uniform(0.0, std::f64::consts::TAU);
        let losses = dac_losses(g, problem, &idx, phase, &options.constants)?;
        let total = losses.total(&options.weights, options.weights.collision_at(step, options.steps));
        let values = losses.values(step)?;
        poses.update(&idx, &losses.colliding_poses);
        Ok((total, values))
    })?;
    let report = DacReport {
        steps: log.steps,
        initial_losses: log.initial,
        final_losses: log.last,
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((g, report))
}

/// The layer field `G` and the path field `P`, trained together by [`optimize_tgc`]: one
/// Burn module, so that one Adam holds the moments of both networks' parameters.
#[derive(Module, Debug)]
pub struct LayerPathFields {
    /// `G`: its level sets are the layers, its normal the build direction.
    pub layer: Siren,
    /// `P`: its iso-curves on each layer are the toolpaths.
    pub path: Siren,
}

/// Weights of the TGC total loss (Eq. 39 of seed 002).
///
/// Table 1's TGC row: layer spacing 2.0, layer curvature 0.2, path spacing 2.0 and the
/// path curvature weight rising from 0.001 to 1.0 (§5.5, §7.5.2); no collision term. The
/// three direction losses (Eq. 20-22) enter with the seed's intrinsic factor 10; the
/// zero-gradient weight, not in the table, is 10 as in [`DacWeights`] (for the same reason).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TgcWeights {
    /// Layer spacing (Eq. 26). Table 1: `2.0`.
    pub spacing: f64,
    /// Layer curvature (Eq. 24). Table 1: `0.2`.
    pub curvature: f64,
    /// Zero gradient (Eq. 27). Not in Table 1; default `10`.
    pub zero_gradient: f64,
    /// Layer–direction alignment (Eq. 21). Default `10`.
    pub alignment: f64,
    /// Path spacing (Eq. 28). Table 1: `2.0`.
    pub path_spacing: f64,
    /// Path curvature (Eq. 25) at the first step. Table 1: `0.001`.
    pub path_curvature_start: f64,
    /// Path curvature at the last step (linear in between). Table 1: `1.0`.
    pub path_curvature_end: f64,
    /// Toolpath–direction alignment (Eq. 20). Default `10`.
    pub path_alignment: f64,
    /// Path continuity along the directions (Eq. 22). Default `10`.
    pub path_continuity: f64,
}

impl Default for TgcWeights {
    fn default() -> Self {
        Self {
            spacing: 2.0,
            curvature: 0.2,
            zero_gradient: 10.0,
            alignment: 10.0,
            path_spacing: 2.0,
            path_curvature_start: 0.001,
            path_curvature_end: 1.0,
            path_alignment: 10.0,
            path_continuity: 10.0,
        }
    }
}

impl TgcWeights {
    /// The path curvature weight at `step` of `steps` (linear, §7.5.2).
    pub fn path_curvature_at(&self, step: usize, steps: usize) -> f64 {
        ramp(self.path_curvature_start, self.path_curvature_end, step, steps)
    }

    fn validate(&self) -> Result<()> {
        FieldError::check_non_negative(&[
            ("weights.spacing", self.spacing),
            ("weights.curvature", self.curvature),
            ("weights.zero_gradient", self.zero_gradient),
            ("weights.alignment", self.alignment),
            ("weights.path_spacing", self.path_spacing),
            ("weights.path_curvature_start", self.path_curvature_start),
            ("weights.path_curvature_end", self.path_curvature_end),
            ("weights.path_alignment", self.path_alignment),
            ("weights.path_continuity", self.path_continuity),
        ])
    }
}

/// Constants inside the TGC losses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TgcConstants {
    /// The layer regularisers' constants ([`LossConstants`]; the collision fields unused).
    pub layer: LossConstants,
    /// The target of `|∇_s P|` (Eq. 28), per unit-cube length. Default `1`.
    pub target_spacing: f64,
    /// `κ̄` of the path curvature loss (Eq. 25), in 1 / part units. Default `0` (§7.3's
    /// "minimum (zero) geodesic curvature").
    pub max_path_curvature: f64,
    /// Intrinsic factor of the path curvature loss (Eq. 25: 10).
    pub path_curvature_factor: f64,
    /// `ε` of the path curvature loss's mask (Eq. 52-53), in `|∇_s P|` units. Default
    /// `0.05`.
    pub singular_spacing: f64,
}

impl Default for TgcConstants {
    fn default() -> Self {
        Self {
            layer: LossConstants::default(),
            target_spacing: 1.0,
            max_path_curvature: 0.0,
            path_curvature_factor: 10.0,
            singular_spacing: 0.05,
        }
    }
}

impl TgcConstants {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        let c = self.layer;
        FieldError::check_non_negative(&[
            ("constants.layer.max_curvature", c.max_curvature),
            ("constants.layer.curvature_factor", c.curvature_factor),
            ("constants.layer.min_gradient", c.min_gradient),
            ("constants.max_path_curvature", self.max_path_curvature),
            ("constants.path_curvature_factor", self.path_curvature_factor),
        ])?;
        FieldError::check_positive(&[
            ("constants.layer.singular_gradient", c.singular_gradient),
            ("constants.target_spacing", self.target_spacing),
            ("constants.singular_spacing", self.singular_spacing),
        ])
    }
}

/// The unweighted losses of one evaluation of Eq. 39, as tensors (scalars, `[1]`).
#[derive(Debug, Clone)]
pub struct TgcLosses {
    /// Layer–direction alignment (Eq. 21).
    pub alignment: Tensor<1>,
    /// Layer spacing (Eq. 26).
    pub spacing: Tensor<1>,
    /// Zero gradient (Eq. 27).
    pub zero_gradient: Tensor<1>,
    /// Layer curvature (Eq. 24) with the singularity mask.
    pub curvature: Tensor<1>,
    /// Path spacing (Eq. 28).
    pub path_spacing: Tensor<1>,
    /// Path curvature (Eq. 25) with the mask of Eq. 52-53, times its intrinsic factor,
    /// in 1 / part units.
    pub path_curvature: Tensor<1>,
    /// Toolpath–direction alignment (Eq. 20).
    pub path_alignment: Tensor<1>,
    /// Path continuity along the directions (Eq. 22).
    pub path_continuity: Tensor<1>,
}

impl TgcLosses {
    /// Eq. 39: the layer terms of Eq. 38 without the collision (Table 1), plus
    /// `w_pd L_pd + w_pc L_pc + w_dir L_dir + w_cont L_cont`, the path curvature weighted
    /// by `path_curvature_weight` (see [`TgcWeights::path_curvature_at`]).
    pub fn total(&self, w: &TgcWeights, path_curvature_weight: f64) -> Tensor<1> {
        self.spacing.clone().mul_scalar(w.spacing)
            + self.curvature.clone().mul_scalar(w.curvature)
            + self.zero_gradient.clone().mul_scalar(w.zero_gradient)
            + self.alignment.clone().mul_scalar(w.alignment)
            + self.path_spacing.clone().mul_scalar(w.path_spacing)
            + self.path_curvature.clone().mul_scalar(path_curvature_weight)
            + self.path_alignment.clone().mul_scalar(w.path_alignment)
            + self.path_continuity.clone().mul_scalar(w.path_continuity)
    }

    /// The eight values, in the order of [`TgcReport::final_losses`], or
    /// [`FieldError::Diverged`] at `step`.
    fn values(&self, step: usize) -> Result<[f32; 8]> {
        loss_values(
            [
                &self.alignment,
                &self.spacing,
                &self.zero_gradient,
                &self.curvature,
                &self.path_spacing,
                &self.path_curvature,
                &self.path_alignment,
                &self.path_continuity,
            ],
            step,
        )
    }
}

/// Evaluates the TGC losses (Eq. 39) of `fields` at the poses `poses` (indices into the
/// problem's): both networks' Hessians at the poses, the layer regularisers as for Eq. 37
/// and 38, and the path losses of [`optimize_path`](crate::optimize_path) with `G` a
/// variable rather than a constant.
///
/// Errors: [`FieldError::InvalidArgument`] for an empty or out-of-range index list,
/// [`FieldError::InvalidConfig`] for bad constants.
pub fn tgc_losses(
    fields: &LayerPathFields,
    problem: &AlignProblem<'_>,
    poses: &[usize],
    constants: &TgcConstants,
) -> Result<TgcLosses> {
    constants.validate()?;
    let print = &problem.print;
    check_indices("pose", poses, print.poses().len())?;
    let device = device_of(&fields.layer);
    let scale = print.normalization().scale;
    let x = print.unit_tensor(poses.iter().map(|&i| print.poses()[i]), &device);
    let g = fields.layer.forward_hessian(x.clone());
    let p = fields.path.forward_hessian(x);
    let geo = LayerGeometry::new(g.gradient.clone(), g.hessian.clone());
    let (spacing, zero_gradient, curvature) = regularisers(&g, &geo, scale, &constants.layer);
    let d = problem.direction_tensor(poses, &device);
    let dir = direction_losses(g.gradient.clone(), p.gradient.clone(), d);
    let s = path_spacing(g.gradient.clone(), p.gradient.clone());
    let kappa = geodesic_curvature(g.gradient, g.hessian, p.gradient, p.hessian);
    // κ_g in 1 / unit-cube lengths; the bound and the loss in 1 / part units, as Eq. 24's.
    let path_curvature = path_curvature_loss(
        kappa,
        s.clone(),
        constants.max_path_curvature / scale,
        constants.singular_spacing,
    )?
    .mul_scalar(constants.path_curvature_factor * scale);
    Ok(TgcLosses {
        alignment: dir.layer,
        spacing,
        zero_gradient,
        curvature,
        path_spacing: path_spacing_loss(s, constants.target_spacing),
        path_curvature,
        path_alignment: dir.alignment,
        path_continuity: dir.continuity,
    })
}

/// How [`init_tgc_fields`] and [`optimize_tgc`] run.
#[derive(Debug, Clone, PartialEq)]
pub struct TgcOptions {
    /// The layer field's network. Default: 3 sine layers of 64, `ω0 = 5`, `ω = 30`.
    pub layer_network: SirenConfig,
    /// The path field's network, started from Sitzmann's random initialisation (§7.5.3:
    /// its singularities are easier kept than created). Default: 3 sine layers of 64,
    /// `ω0 = 8`, `ω = 30`, seed `1` (a higher frequency than `G`'s, as §7.5.3 sets it).
    pub path_network: SirenConfig,
    /// Adam steps fitting `G = ẑ` (planar layers) before the co-optimisation. Default `300`.
    pub pretrain_steps: usize,
    /// Adam steps on Eq. 39. Default `300`.
    pub steps: usize,
    /// Poses per step. Default `128`.
    pub batch_size: usize,
    /// Adam's learning rate (both networks). Default `5e-4`.
    pub learning_rate: f64,
    /// Loss weights. Default [`TgcWeights::default`] (Table 1's TGC row).
    pub weights: TgcWeights,
    /// Constants of the losses. Default [`TgcConstants::default`].
    pub constants: TgcConstants,
    /// Seed of the batches and of the planar fit. Default `0`.
    pub seed: u64,
    /// The Burn backend. Default [`Backend::default`].
    pub backend: Backend,
}

impl Default for TgcOptions {
    fn default() -> Self {
        Self {
            layer_network: SirenConfig {
                sine_layers: 3,
                width: 64,
                first_omega: 5.0,
                hidden_omega: 30.0,
                seed: 0,
            },
            path_network: SirenConfig {
                sine_layers: 3,
                width: 64,
                first_omega: 8.0,
                hidden_omega: 30.0,
                seed: 1,
            },
            pretrain_steps: 300,
            steps: 300,
            batch_size: 128,
            learning_rate: 5e-4,
            weights: TgcWeights::default(),
            constants: TgcConstants::default(),
            seed: 0,
            backend: Backend::default(),
        }
    }
}

impl TgcOptions {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        self.layer_network.validate()?;
        self.path_network.validate()?;
        self.constants.validate()?;
        if self.steps == 0 {
            return Err(FieldError::config("steps", "must be at least 1"));
        }
        if self.batch_size == 0 {
            return Err(FieldError::config("batch_size", "must be at least 1"));
        }
        FieldError::check_positive(&[("learning_rate", self.learning_rate)])?;
        self.weights.validate()
    }
}

/// The starting fields of [`optimize_tgc`]: planar layers (`G = ẑ`, fitted as
/// [`pretrain_planar`](crate::pretrain_planar) does) and a randomly initialised path field,
/// on `options.backend`'s autodiff device.
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::Diverged`].
pub fn init_tgc_fields(options: &TgcOptions) -> Result<LayerPathFields> {
    options.validate()?;
    let layer = fit_planar(&options.layer_network, options.pretrain_steps, options.seed, options.backend)?;
    let path = Siren::new(&options.path_network, &options.backend.device().autodiff())?;
    Ok(LayerPathFields { layer, path })
}

/// What [`optimize_tgc`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct TgcReport {
    /// Adam steps taken.
    pub steps: usize,
    /// Unweighted losses of the first step: layer alignment, layer spacing, zero gradient,
    /// layer curvature, path spacing, path curvature, path alignment, path continuity.
    pub initial_losses: [f32; 8],
    /// Unweighted losses of the last step, in the same order.
    pub final_losses: [f32; 8],
    /// Wall-clock seconds of the optimisation.
    pub seconds: f64,
}

/// Co-optimises the layer and path fields (`fields`, on an autodiff device, e.g. from
/// [`init_tgc_fields`]) by one Adam over both networks' parameters on Eq. 39 at
/// `problem`'s poses (shuffled passes), the path curvature weight rising linearly from
/// `weights.path_curvature_start` to `weights.path_curvature_end`.
///
/// Deterministic for fixed options (single-threaded backend, seeded batches).
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::Diverged`].
pub fn optimize_tgc(
    fields: LayerPathFields,
    problem: &AlignProblem<'_>,
    options: &TgcOptions,
) -> Result<(LayerPathFields, TgcReport)> {
    options.validate()?;
    let start = Instant::now();
    let mut opt = AdamConfig::new().init();
    let mut poses = Batcher::new(problem.print.poses().len(), options.seed ^ 0x5447_4321);
    let mut log = LossLog::new();
    let mut idx = Vec::new();
    let fields = train(fields, &mut opt, options.learning_rate, options.steps, &mut log, |fields, step| {
        poses.batch(options.batch_size, &[], &mut idx);
        let losses = tgc_losses(fields, problem, &idx, &options.constants)?;
        let total = losses.total(&options.weights, options.weights.path_curvature_at(step, options.steps));
        Ok((total, losses.values(step)?))
    })?;
    let report = TgcReport {
        steps: log.steps,
        initial_losses: log.initial,
        final_losses: log.last,
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((fields, report))
}
