//! The path field `P` (§3.2, §4.3-4.5 of seed 002): a second scalar field whose iso-curves
//! on each layer (iso-surface of the layer field `G`) are the toolpaths.
//!
//! Its geometry, as batched tensor functions of the two fields' forward-propagated
//! gradients `[n, 3]` and Hessians `[n, 3, 3]` (for example
//! [`Siren::forward_hessian`](crate::Siren::forward_hessian)'s output), differentiable with
//! respect to whatever produced them:
//!
//! - toolpath tangent (Eq. 3) `t = n × ∇P / |n × ∇P|`, with the layer normal
//!   `n = ∇G / |∇G|` ([`path_tangent`]);
//! - the projected gradient `∇_s P = ∇P - (∇P·n) n` (Eq. 4) and its norm, the path-spacing
//!   measure: adjacent iso-curves `P = c` and `P = c + δ` lie `δ / |∇_s P|` apart on the
//!   layer ([`projected_path_gradient`], [`path_spacing`]);
//! - the geodesic curvature of the toolpath (Eq. 7, Appendix A) `κ_g = (dt/ds) · (n × t)`,
//!   from first and second derivatives only ([`geodesic_curvature`]). With `a = ∇G`,
//!   `b = ∇P`, `u = a × b` (so `t = u/|u|`) and the derivative of `u` along `t`,
//!   `∂_t u = (∇²G t) × b + a × (∇²P t)`:
//!   `κ_g = (∂_t u · (n × t)) / |u|` (the component of `dt/ds` along `t` vanishes and
//!   `n × t ⟂ t`). Its sign: positive where the path turns left seen against the normal
//!   (counter-clockwise about `n`); `G = z`, `P = sqrt(x² + y²)` gives `t = θ̂` and
//!   `κ_g = 1/r`.
//!
//! The losses on `P` (§4.3-4.5), as tensors differentiable with respect to both fields:
//! path spacing (Eq. 28, [`path_spacing_loss`]), direction alignment with a prescribed
//! direction field (Eq. 17-22, [`direction_losses`]) and the toolpath curvature (Eq. 25
//! with the singularity mask of Eq. 52-53, [`path_curvature_loss`]). [`optimize_path`]
//! fits a path field on a fixed layer field by Adam on their weighted sum (the sequential
//! scheme of §7.3), and [`path_stats`] measures a pair of fields. [`fit_contour_paths`]
//! fits the path field of contour-parallel milling toolpaths (§7.4) over a
//! [`MillingProblem`]'s poses.
//!
//! Divisions are guarded like [`LayerGeometry`](crate::LayerGeometry)'s by
//! [`GRAD_EPS`](crate::GRAD_EPS): where
//! `∇P` is parallel to `∇G` (a singular point of the paths on the layer) the values are
//! large but finite, and the curvature loss masks such points (Eq. 52-53).

use std::time::Instant;

use burn::optim::AdamConfig;
use burn::tensor::activation::sigmoid;
use burn::tensor::{Tensor, TensorData};
use s2g_geom::{SplitMix64, Vector3};

use crate::backend::{Backend, host_values};
use crate::error::{FieldError, Result};
use crate::layer::{cross, gradient_norm, hessian_times_gradient, layer_normal};
use crate::milling::MillingProblem;
use crate::siren::{FieldHessian, Siren, SirenConfig, SirenF64};
use crate::train::{LossLog, loss_values, train};

/// The toolpath quantities of §3.2 at a batch of points.
#[derive(Debug, Clone)]
pub struct PathGeometry {
    /// Unit toolpath tangent `t = n × ∇P / |n × ∇P|`, `[n, 3]` (Eq. 3).
    pub tangent: Tensor<2>,
    /// `∇_s P = ∇P - (∇P·n) n`, `[n, 3]`: `∇P` projected on the layer's tangent plane
    /// (Eq. 4), pointing across the paths.
    pub projected_gradient: Tensor<2>,
    /// `|∇_s P|`, `[n, 1]`: the rate of change of `P` across the paths within the layer,
    /// inversely proportional to the path spacing.
    pub spacing: Tensor<2>,
    /// Geodesic curvature `κ_g` of the toolpath, `[n, 1]` (Eq. 7, Appendix A; sign as in
    /// the module docs); `None` when built from gradients only ([`PathGeometry::new`]).
    pub geodesic_curvature: Option<Tensor<2>>,
}

impl PathGeometry {
    /// Tangent, projected gradient and spacing from the layer field's gradient
    /// `layer_gradient` `[n, 3]` and the path field's `path_gradient` `[n, 3]`; no
    /// curvature (it needs the Hessians, see [`PathGeometry::from_fields`]).
    pub fn new(layer_gradient: Tensor<2>, path_gradient: Tensor<2>) -> Self {
        let projected = projected_path_gradient(layer_gradient.clone(), path_gradient.clone());
        Self {
            tangent: path_tangent(layer_gradient, path_gradient),
            spacing: gradient_norm(projected.clone()),
            projected_gradient: projected,
            geodesic_curvature: None,
        }
    }

    /// Every quantity, the geodesic curvature included, from the layer field's and the
    /// path field's [`Siren::forward_hessian`](crate::Siren::forward_hessian) outputs at
    /// the same points.
    pub fn from_fields(layer: &FieldHessian, path: &FieldHessian) -> Self {
        let mut geo = Self::new(layer.gradient.clone(), path.gradient.clone());
        geo.geodesic_curvature = Some(geodesic_curvature(
            layer.gradient.clone(),
            layer.hessian.clone(),
            path.gradient.clone(),
            path.hessian.clone(),
        ));
        geo
    }
}

/// The unit toolpath tangent `t = n × ∇P / |n × ∇P|`, `[n, 3]` (Eq. 3), from `∇G` and `∇P`
/// `[n, 3]`.
pub fn path_tangent(layer_gradient: Tensor<2>, path_gradient: Tensor<2>) -> Tensor<2> {
    layer_normal(cross(layer_normal(layer_gradient), path_gradient))
}

/// `∇_s P = ∇P - (∇P·n) n`, `[n, 3]` (Eq. 4): `∇P` projected on the layer, from `∇G` and
/// `∇P` `[n, 3]`.
pub fn projected_path_gradient(layer_gradient: Tensor<2>, path_gradient: Tensor<2>) -> Tensor<2> {
    let n = layer_normal(layer_gradient);
    let along = (path_gradient.clone() * n.clone()).sum_dim(1); // [n, 1]
    path_gradient - n * along
}

/// The path-spacing measure `|∇_s P|`, `[n, 1]` (Eq. 4), from `∇G` and `∇P` `[n, 3]`
/// (guarded by [`GRAD_EPS`](crate::GRAD_EPS)).
pub fn path_spacing(layer_gradient: Tensor<2>, path_gradient: Tensor<2>) -> Tensor<2> {
    gradient_norm(projected_path_gradient(layer_gradient, path_gradient))
}

/// The geodesic curvature `κ_g` of the iso-curves of `P` on the iso-surfaces of `G`,
/// `[n, 1]` (Eq. 7, Appendix A), from both fields' gradients `[n, 3]` and Hessians
/// `[n, 3, 3]`: `κ_g = (((∇²G t) × ∇P + ∇G × (∇²P t)) · (n × t)) / |∇G × ∇P|` (module docs).
pub fn geodesic_curvature(
    layer_gradient: Tensor<2>,
    layer_hessian: Tensor<3>,
    path_gradient: Tensor<2>,
    path_hessian: Tensor<3>,
) -> Tensor<2> {
    let u = cross(layer_gradient.clone(), path_gradient.clone());
    let u_norm = gradient_norm(u.clone()); // [n, 1]
    let t = u / u_norm.clone();
    let n = layer_normal(layer_gradient.clone());
    let du = cross(hessian_times_gradient(t.clone(), layer_hessian), path_gradient)
        + cross(layer_gradient, hessian_times_gradient(t.clone(), path_hessian));
    let side = cross(n, t);
    (du * side).sum_dim(1) / u_norm
}

/// Path spacing (Eq. 28): `mean (|∇_s P| - target)²` over the batch, from the spacing
/// measure `[n, 1]` ([`PathGeometry::spacing`]). The paper's target is `1`; the iso-curves
/// `P = k δ` then lie `δ` apart on every layer.
pub fn path_spacing_loss(spacing: Tensor<2>, target: f64) -> Tensor<1> {
    spacing.sub_scalar(target).square().mean()
}

/// The direction-alignment losses of §4.3 (Eq. 20-22), unweighted, each a mean over the
/// batch (`[1]`).
#[derive(Debug, Clone)]
pub struct DirectionLosses {
    /// Eq. 17/20, the non-normalised alignment of the toolpath with the direction field
    /// `d`: `mean |(∇G × ∇P) × d|²`. Zero when `t ∥ d` (then also Eq. 18 and 19 hold) or
    /// where `∇G × ∇P = 0` (a singular point, which the loss allows).
    pub alignment: Tensor<1>,
    /// Eq. 18/21, `d` in the layer's tangent plane: `mean (∇G · d)²` (a loss on `G` only).
    pub layer: Tensor<1>,
    /// Eq. 19/22, `P` constant along `d` (the path continues along it): `mean (∇P · d)²`.
    pub continuity: Tensor<1>,
}

/// The direction-alignment losses (Eq. 17-22) of `∇G` and `∇P` `[n, 3]` against the
/// prescribed directions `direction` `[n, 3]` (any length; a zero row prescribes nothing
/// there). Directions are lines, not arrows: `d` and `-d` give the same losses.
pub fn direction_losses(
    layer_gradient: Tensor<2>,
    path_gradient: Tensor<2>,
    direction: Tensor<2>,
) -> DirectionLosses {
    let u = cross(layer_gradient.clone(), path_gradient.clone());
    DirectionLosses {
        alignment: cross(u, direction.clone()).square().sum_dim(1).mean(),
        layer: (layer_gradient * direction.clone()).sum_dim(1).square().mean(),
        continuity: (path_gradient * direction).sum_dim(1).square().mean(),
    }
}

/// The toolpath curvature loss (Eq. 25) with the singularity mask (Eq. 52-53):
/// `mean σ((|∇_s P| - ε) / 0.1 ε) · max(|κ_g| - κ̄, 0)`, from the geodesic curvature and the
/// spacing measure `[n, 1]` ([`PathGeometry`]), the curvature bound `max_curvature` (`κ̄`,
/// `>= 0`) and the singular spacing `singular_spacing` (`ε`, `> 0`), both in the units of
/// the fields' input. The mask (a detached sigmoid) drops points where the paths are
/// ill-defined (`|∇_s P| < ε`), whose curvature would dominate the loss.
///
/// Errors: [`FieldError::InvalidConfig`] for a negative or non-finite bound or a
/// non-positive `singular_spacing`.
pub fn path_curvature_loss(
    geodesic_curvature: Tensor<2>,
    spacing: Tensor<2>,
    max_curvature: f64,
    singular_spacing: f64,
) -> Result<Tensor<1>> {
    FieldError::check_non_negative(&[("max_curvature", max_curvature)])?;
    FieldError::check_positive(&[("singular_spacing", singular_spacing)])?;
    let mask = sigmoid(spacing.sub_scalar(singular_spacing).div_scalar(0.1 * singular_spacing)).detach();
    Ok((mask * geodesic_curvature.abs().sub_scalar(max_curvature).clamp_min(0.0)).mean())
}

/// Weights of the path losses in [`optimize_path`]'s total.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathWeights {
    /// Path spacing (Eq. 28). Default `1`.
    pub spacing: f64,
    /// Direction alignment (Eq. 20). Default `10` (the paper's intrinsic factor).
    pub alignment: f64,
    /// Continuity along the directions (Eq. 22). Default `10`.
    pub continuity: f64,
    /// Toolpath curvature (Eq. 25). Default `0` (off: the loss needs `P`'s Hessian, about
    /// three times the cost of a step).
    pub curvature: f64,
}

impl Default for PathWeights {
    fn default() -> Self {
        Self { spacing: 1.0, alignment: 10.0, continuity: 10.0, curvature: 0.0 }
    }
}

/// How [`optimize_path`] runs.
#[derive(Debug, Clone, PartialEq)]
pub struct PathOptions {
    /// The path field's network. Default: 2 sine layers of 32, `ω0 = 4`, `ω = 30`, seed
    /// `0` (paths smooth at the scale of the unit cube, with room for singularities).
    pub network: SirenConfig,
    /// Adam steps. Default `300`.
    pub steps: usize,
    /// Points per step (drawn from the samples). Default `256`.
    pub batch_size: usize,
    /// Adam's learning rate. Default `1e-3`.
    pub learning_rate: f64,
    /// The target of `|∇_s P|` (Eq. 28). Default `1`.
    pub target_spacing: f64,
    /// `κ̄` of the curvature loss, in inverse input units. Default `0`.
    pub max_curvature: f64,
    /// `ε` of the curvature loss's mask. Default `0.05`.
    pub singular_spacing: f64,
    /// Loss weights. Default [`PathWeights::default`].
    pub weights: PathWeights,
    /// Seed of the batches. Default `0`.
    pub seed: u64,
    /// The Burn backend. Default [`Backend::default`].
    pub backend: Backend,
}

impl Default for PathOptions {
    fn default() -> Self {
        Self {
            network: SirenConfig { sine_layers: 2, width: 32, first_omega: 4.0, hidden_omega: 30.0, seed: 0 },
            steps: 300,
            batch_size: 256,
            learning_rate: 1e-3,
            target_spacing: 1.0,
            max_curvature: 0.0,
            singular_spacing: 0.05,
            weights: PathWeights::default(),
            seed: 0,
            backend: Backend::default(),
        }
    }
}

impl PathOptions {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        self.network.validate()?;
        if self.steps == 0 {
            return Err(FieldError::config("steps", "must be at least 1"));
        }
        if self.batch_size == 0 {
            return Err(FieldError::config("batch_size", "must be at least 1"));
        }
        FieldError::check_positive(&[
            ("learning_rate", self.learning_rate),
            ("target_spacing", self.target_spacing),
            ("singular_spacing", self.singular_spacing),
        ])?;
        let w = self.weights;
        FieldError::check_non_negative(&[
            ("max_curvature", self.max_curvature),
            ("weights.spacing", w.spacing),
            ("weights.alignment", w.alignment),
            ("weights.continuity", w.continuity),
            ("weights.curvature", w.curvature),
        ])
    }
}

/// What [`optimize_path`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct PathReport {
    /// Adam steps taken.
    pub steps: usize,
    /// Unweighted losses of the first step: spacing, alignment, continuity, curvature
    /// (`0` while its weight is `0`).
    pub initial_losses: [f32; 4],
    /// Unweighted losses of the last step, in the same order.
    pub final_losses: [f32; 4],
    /// Weighted totals of the first and the last step.
    pub totals: [f32; 2],
    /// Wall-clock seconds of the optimisation.
    pub seconds: f64,
}

/// Refuses empty, mismatched or non-finite samples.
fn check_samples(points: &[[f64; 3]], directions: &[[f64; 3]]) -> Result<()> {
    if points.is_empty() {
        return Err(FieldError::InvalidArgument("no sample point".into()));
    }
    if directions.len() != points.len() {
        return Err(FieldError::InvalidArgument(format!(
            "{} directions for {} points",
            directions.len(),
            points.len()
        )));
    }
    if let Some(index) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(FieldError::NonFinite { what: "sample point", index });
    }
    if let Some(index) = directions.iter().position(|d| !d.iter().all(|c| c.is_finite())) {
        return Err(FieldError::NonFinite { what: "direction", index });
    }
    Ok(())
}

/// `[n, 3]` rows of `values` at `idx`, on `device`.
fn rows3(values: &[[f64; 3]], idx: &[usize], device: &burn::tensor::Device) -> Tensor<2> {
    let data: Vec<f32> = idx.iter().flat_map(|&i| values[i].map(|c| c as f32)).collect();
    Tensor::<2>::from_data(TensorData::new(data, [idx.len(), 3]), device)
}

/// Fits a path field `P` (a new [`Siren`] of `options.network`, on `options.backend`'s
/// autodiff device) on the fixed layer field `layer` (`G`, the sequential scheme of §7.3)
/// by Adam on `w_pd L_pd + w_dir L_dir + w_cont L_cont + w_pc L_pc` (Eq. 28, 20, 22, 25)
/// at the sample `points` (the networks' input coordinates), aligning the toolpaths with
/// `directions` (one per point; a zero row prescribes only the spacing there).
///
/// Deterministic for `options.network.seed` and `options.seed`.
///
/// Errors: [`FieldError::InvalidConfig`] for bad options; [`FieldError::InvalidArgument`]
/// for no points or a direction count that differs from the point count;
/// [`FieldError::NonFinite`] for a non-finite point or direction; [`FieldError::Diverged`].
pub fn optimize_path(
    layer: &SirenF64,
    points: &[[f64; 3]],
    directions: &[[f64; 3]],
    options: &PathOptions,
) -> Result<(Siren, PathReport)> {
    options.validate()?;
    check_samples(points, directions)?;
    let start = Instant::now();
    let device = options.backend.device().autodiff();
    let with_curvature = options.weights.curvature > 0.0;
    // G is fixed: its derivatives at the samples are constants of the optimisation.
    let layer_derivs: Vec<([f64; 3], [[f64; 3]; 3])> = points
        .iter()
        .map(|&p| {
            let (_, g, h) = layer.value_gradient_hessian(p);
            (g, h)
        })
        .collect();
    let layer_gradients: Vec<[f64; 3]> = layer_derivs.iter().map(|d| d.0).collect();
    let net = Siren::new(&options.network, &device)?;
    let mut opt = AdamConfig::new().init();
    let mut rng = SplitMix64::new(options.seed, 0x5041_5448);
    let batch = options.batch_size.min(points.len());
    let w = options.weights;
    // The four losses, then the weighted total.
    let mut log = LossLog::<5>::new();
    let mut idx = Vec::with_capacity(batch);
    let net = train(net, &mut opt, options.learning_rate, options.steps, &mut log, |net, step| {
        idx.clear();
        idx.extend((0..batch).map(|_| rng.below(points.len())));
        let x = rows3(points, &idx, &device);
        let gg = rows3(&layer_gradients, &idx, &device);
        let d = rows3(directions, &idx, &device);
        let (path_gradient, curvature) = if with_curvature {
            let hess: Vec<f32> =
                idx.iter().flat_map(|&i| layer_derivs[i].1.concat()).map(|c| c as f32).collect();
            let gh = Tensor::<3>::from_data(TensorData::new(hess, [idx.len(), 3, 3]), &device);
            let out = net.forward_hessian(x);
            let k = geodesic_curvature(gg.clone(), gh, out.gradient.clone(), out.hessian);
            (out.gradient, Some(k))
        } else {
            (net.forward_gradient(x).gradient, None)
        };
        let spacing = path_spacing(gg.clone(), path_gradient.clone());
        let dir = direction_losses(gg, path_gradient, d);
        let curvature = match curvature {
            Some(k) => {
                path_curvature_loss(k, spacing.clone(), options.max_curvature, options.singular_spacing)?
            }
            None => Tensor::zeros([1], &device),
        };
        let spacing = path_spacing_loss(spacing, options.target_spacing);
        let total = spacing.clone().mul_scalar(w.spacing)
            + dir.alignment.clone().mul_scalar(w.alignment)
            + dir.continuity.clone().mul_scalar(w.continuity)
            + curvature.clone().mul_scalar(w.curvature);
        let values = loss_values([&spacing, &dir.alignment, &dir.continuity, &curvature, &total], step)?;
        Ok((total, values))
    })?;
    let (first, last) = (log.initial, log.last);
    let report = PathReport {
        steps: options.steps,
        initial_losses: [first[0], first[1], first[2], first[3]],
        final_losses: [last[0], last[1], last[2], last[3]],
        totals: [first[4], last[4]],
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((net, report))
}

/// Measured path quantities of a layer and a path field at a set of points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathStats {
    /// Mean angle in degrees between the toolpath tangent and the prescribed direction
    /// (as lines, in `[0, 90]`), over the points with a non-zero direction; `NaN` if none.
    pub mean_angle_deg: f64,
    /// Mean of `|∇_s P|` (Eq. 4).
    pub spacing_mean: f64,
    /// Standard deviation of `|∇_s P|` over its mean: how uneven the path spacing is.
    pub spacing_cv: f64,
    /// Mean `|κ_g|` (Eq. 7) over the points where `|∇_s P|` is at least a tenth of its mean
    /// (away from singular points).
    pub mean_abs_curvature: f64,
}

/// Measures the toolpaths of `layer` (`G`) and `path` (`P`) at `points` against
/// `directions` (as for [`optimize_path`]), evaluating both networks' tensor forward passes
/// on `backend` in batches.
///
/// Errors: as [`optimize_path`]'s for the samples; [`FieldError::Backend`].
pub fn path_stats(
    layer: &SirenF64,
    path: &SirenF64,
    points: &[[f64; 3]],
    directions: &[[f64; 3]],
    backend: Backend,
) -> Result<PathStats> {
    check_samples(points, directions)?;
    let device = backend.device();
    let (g, p) = (layer.to_siren(&device), path.to_siren(&device));
    let (mut tangent, mut spacing, mut curvature) = (Vec::new(), Vec::new(), Vec::new());
    let all: Vec<usize> = (0..points.len()).collect();
    for chunk in all.chunks(1024) {
        let x = rows3(points, chunk, &device);
        let geo = PathGeometry::from_fields(&g.forward_hessian(x.clone()), &p.forward_hessian(x));
        tangent.extend(host_values(geo.tangent)?);
        spacing.extend(host_values(geo.spacing)?);
        if let Some(k) = geo.geodesic_curvature {
            curvature.extend(host_values(k)?);
        }
    }
    let (mut angle_sum, mut angle_count) = (0.0, 0usize);
    for (t, d) in tangent.chunks_exact(3).zip(directions) {
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if len > 0.0 {
            let cos = (0..3).map(|a| t[a] as f64 * d[a]).sum::<f64>().abs() / len;
            angle_sum += cos.min(1.0).acos().to_degrees();
            angle_count += 1;
        }
    }
    let n = spacing.len() as f64;
    let mean = spacing.iter().map(|&s| s as f64).sum::<f64>() / n;
    let var = spacing.iter().map(|&s| (s as f64 - mean).powi(2)).sum::<f64>() / n;
    let regular: Vec<f64> = spacing
        .iter()
        .zip(&curvature)
        .filter(|(s, _)| **s as f64 >= 0.1 * mean)
        .map(|(_, k)| k.abs() as f64)
        .collect();
    Ok(PathStats {
        mean_angle_deg: if angle_count > 0 { angle_sum / angle_count as f64 } else { f64::NAN },
        spacing_mean: mean,
        spacing_cv: if mean > 0.0 { var.sqrt() / mean } else { f64::NAN },
        mean_abs_curvature: if regular.is_empty() {
            f64::NAN
        } else {
            regular.iter().sum::<f64>() / regular.len() as f64
        },
    })
}

/// The contour-parallel direction field of a milling problem at its poses: `n × ∇d`, the
/// layer normal `n` of `layer` crossed with the gradient of the part's distance `d`, the
/// direction along the part's outline within the layer (unit length; zero where `∇d` is
/// along `n`, e.g. over the top of the part, or where either is undefined). Returns the
/// poses in unit-cube coordinates and the directions.
pub fn contour_directions(layer: &SirenF64, problem: &MillingProblem<'_>) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let nz = problem.normalization();
    problem
        .poses()
        .iter()
        .map(|x| {
            let u = nz.to_unit(x);
            let (_, g) = layer.value_gradient([u.x, u.y, u.z]);
            let n = Vector3::new(g[0], g[1], g[2]);
            let d = n.cross(&problem.part().gradient(x));
            let d = d
                .try_normalize(1e-6)
                .filter(|d| d.iter().all(|c| c.is_finite()))
                .unwrap_or_else(Vector3::zeros);
            ([u.x, u.y, u.z], [d.x, d.y, d.z])
        })
        .unzip()
}

/// Fits the path field of contour-parallel toolpaths on the layer field `layer` over
/// `problem`'s poses: [`optimize_path`] with the directions of [`contour_directions`], so
/// that the iso-curves of `P` on each layer run parallel to the part's outline, spaced
/// evenly (`|∇_s P| → options.target_spacing` per unit-cube length). For
/// [`mill_program_with_paths`](crate::mill_program_with_paths).
///
/// Errors: as [`optimize_path`]'s.
pub fn fit_contour_paths(
    layer: &SirenF64,
    problem: &MillingProblem<'_>,
    options: &PathOptions,
) -> Result<(Siren, PathReport)> {
    let (points, directions) = contour_directions(layer, problem);
    optimize_path(layer, &points, &directions, options)
}
