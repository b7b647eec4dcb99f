//! The training base shared by the layer- and path-field optimisations (milling Eq. 40,
//! printing Eq. 37, DAC Eq. 38, TGC Eq. 39, the path field, the neural SDF): the Adam
//! loop and its record of losses, pose batches with active-set sampling, the linear
//! weight ramps, the layer regularisers and the inter-layer collision term shared by
//! milling and printing, and planar pretraining.

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, Int, Tensor, TensorData};
use s2g_geom::{Normalization, SplitMix64};

use crate::backend::Backend;
use crate::error::{FieldError, Result};
use crate::layer::{LayerGeometry, hessian_times_gradient};
use crate::siren::{FieldHessian, Siren, SirenConfig};

/// One Adam update of `model` down the gradient of `loss` at `learning_rate`.
pub(crate) fn descend<M: Module>(
    opt: &mut ModuleOptimizer,
    model: M,
    loss: Tensor<1>,
    learning_rate: f64,
) -> M {
    let grads = GradientsParams::from_grads(loss.backward(), &model);
    opt.step(learning_rate, model, grads)
}

/// The unweighted losses of a run: how many steps were recorded, and the values of the
/// first and the last (zeros before any).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LossLog<const N: usize> {
    /// Steps recorded.
    pub(crate) steps: usize,
    /// The first step's values.
    pub(crate) initial: [f32; N],
    /// The last step's values.
    pub(crate) last: [f32; N],
}

impl<const N: usize> LossLog<N> {
    /// An empty record.
    pub(crate) fn new() -> Self {
        Self { steps: 0, initial: [0.0; N], last: [0.0; N] }
    }

    /// Records one step's values.
    pub(crate) fn record(&mut self, values: [f32; N]) {
        if self.steps == 0 {
            self.initial = values;
        }
        self.steps += 1;
        self.last = values;
    }
}

/// The Adam loop: `steps` times, `step_loss(model, step)` (with `step` the number of steps
/// `log` holds so far) gives the loss to descend and the values to record; the update is
/// [`descend`] at `learning_rate`, then the values go into `log`. `step_loss` draws its own
/// batches, so each optimisation keeps its own sampling (and its random stream).
pub(crate) fn train<M: Module, const N: usize>(
    mut model: M,
    opt: &mut ModuleOptimizer,
    learning_rate: f64,
    steps: usize,
    log: &mut LossLog<N>,
    mut step_loss: impl FnMut(&M, usize) -> Result<(Tensor<1>, [f32; N])>,
) -> Result<M> {
    for _ in 0..steps {
        let (loss, values) = step_loss(&model, log.steps)?;
        model = descend(opt, model, loss, learning_rate);
        log.record(values);
    }
    Ok(model)
}

/// The values of one step's losses on the host, in order, or [`FieldError::Diverged`] at
/// `step` (see [`crate::backend::finite_losses`]).
pub(crate) fn loss_values<const N: usize>(losses: [&Tensor<1>; N], step: usize) -> Result<[f32; N]> {
    let values = crate::backend::finite_losses(losses.iter().map(|&t| t.clone()).collect(), step)?;
    Ok(std::array::from_fn(|i| values[i]))
}

/// The device `g`'s parameters live on (the default backend's when it has none).
pub(crate) fn device_of(g: &Siren) -> Device {
    g.devices().first().cloned().unwrap_or_else(|| Backend::default().device())
}

/// Linear from `start` at step 0 to `end` at step `steps - 1` (`end` when `steps <= 1`).
pub(crate) fn ramp(start: f64, end: f64, step: usize, steps: usize) -> f64 {
    let t = if steps <= 1 { 1.0 } else { (step as f64 / (steps - 1) as f64).clamp(0.0, 1.0) };
    start + t * (end - start)
}

/// The most tool points per evaluation of the inter-layer collision term (a subsample
/// beyond that).
const LAYER_POINTS: usize = 8192;

/// The layer regularisers of `G` at a batch of points (shared by Eq. 37 and Eq. 40): the
/// spacing loss (Eq. 26, `mean |∇|∇G||²` with `∇|∇G| = ∇²G ∇G / |∇G|`), the zero-gradient
/// loss (Eq. 27) and the curvature loss (Eq. 24) with the singularity mask (Eq. 52-53).
/// `scale` maps part units to the unit cube.
pub(crate) fn regularisers(
    out: &FieldHessian,
    geo: &LayerGeometry,
    scale: f64,
    constants: &LossConstants,
) -> (Tensor<1>, Tensor<1>, Tensor<1>) {
    let grad_norm = geo.spacing.clone(); // [n, 1]
    let dnorm = hessian_times_gradient(out.gradient.clone(), out.hessian.clone()) / grad_norm.clone();
    let spacing = dnorm.square().sum_dim(1).mean();
    let zero_gradient = grad_norm.clone().neg().add_scalar(constants.min_gradient).clamp_min(0.0).mean();
    let kappa_bar = constants.max_curvature / scale; // 1 / unit-cube lengths
    let s = constants.singular_gradient;
    let mask = sigmoid(grad_norm.sub_scalar(s).div_scalar(0.1 * s)).detach();
    let curvature = (mask * geo.max_abs_curvature().sub_scalar(kappa_bar).clamp_min(0.0))
        .mean()
        .mul_scalar(constants.curvature_factor * scale); // back to 1 / part units
    (spacing, zero_gradient, curvature)
}

/// The inter-layer collision term (Eq. 13): `ReLU(k (ε - (G(p) - G(x))))` summed over the
/// tool points `rows` of `p` (`[m, 3]`, part units, `t` per pose, pose values `g_x`
/// `[n, 1]`) where material is in the way, divided by `m`. At most `LAYER_POINTS` of the
/// rows enter the graph: an even subsample, offset by the phase, rescaled to the sum over
/// all of them. Also returns the batch positions (`row / t`, ascending, distinct) of the
/// poses with a positive term.
#[allow(clippy::too_many_arguments)]
pub(crate) fn layer_collision(
    g: &Siren,
    normalization: &Normalization,
    p: Tensor<2>,
    g_x: Tensor<2>,
    rows: &[usize],
    t: usize,
    m: usize,
    phase: f64,
    constants: &LossConstants,
) -> Result<(Tensor<1>, Vec<usize>)> {
    let device = p.device();
    if rows.is_empty() {
        return Ok((Tensor::<1>::zeros([1], &device), Vec::new()));
    }
    let stride = rows.len().div_ceil(LAYER_POINTS);
    let offset =
        ((phase.rem_euclid(std::f64::consts::TAU) / std::f64::consts::TAU) * stride as f64) as usize % stride;
    let kept: Vec<usize> = rows.iter().copied().skip(offset).step_by(stride).collect();
    let weight = rows.len() as f64 / kept.len() as f64;
    let s_len = kept.len();
    let pose_of: Vec<i64> = kept.iter().map(|&k| (k / t) as i64).collect();
    let kept: Vec<i64> = kept.iter().map(|&k| k as i64).collect();
    let kept = Tensor::<1, Int>::from_data(TensorData::new(kept, [s_len]), &device);
    let pose_host = pose_of.clone();
    let pose_of = Tensor::<1, Int>::from_data(TensorData::new(pose_of, [s_len]), &device);
    let tr = normalization.translation;
    let shift =
        Tensor::<2>::from_data(TensorData::new(vec![tr.x as f32, tr.y as f32, tr.z as f32], [1, 3]), &device);
    let p_unit = p.select(0, kept).mul_scalar(normalization.scale) + shift;
    let g_p = g.forward(p_unit);
    let g_x = g_x.select(0, pose_of);
    let terms = (g_p - g_x)
        .neg()
        .add_scalar(constants.layer_clearance)
        .mul_scalar(constants.collision_slope)
        .clamp_min(0.0);
    let values = crate::backend::host_values(terms.clone().detach())?;
    let mut active: Vec<usize> =
        values.iter().zip(&pose_host).filter(|(v, _)| **v > 0.0).map(|(_, &k)| k as usize).collect();
    active.dedup();
    Ok((terms.sum().mul_scalar(weight / m as f64), active))
}

/// Fits a new network of `network` to `G(x̂) = ẑ` by `steps` Adam steps (see
/// [`pretrain_planar`]), on `backend`'s autodiff device.
pub(crate) fn fit_planar(network: &SirenConfig, steps: usize, seed: u64, backend: Backend) -> Result<Siren> {
    fit_planar_along(network, steps, seed, backend, [0.0, 0.0, 1.0])
}

/// Fits a new network of `network` to `G(x̂) = d·x̂` (planar layers normal to the unit
/// `d`) by `steps` Adam steps, as [`fit_planar`] does for `d = ẑ`.
pub(crate) fn fit_planar_along(
    network: &SirenConfig,
    steps: usize,
    seed: u64,
    backend: Backend,
    d: [f64; 3],
) -> Result<Siren> {
    let device = backend.device().autodiff();
    let d = d.map(|c| c as f32);
    let mut net = Siren::new(network, &device)?;
    let mut opt = AdamConfig::new().init();
    let mut rng = SplitMix64::new(seed, 0x504c_414e);
    let n = 512;
    for step in 0..steps {
        let pts: Vec<f32> = (0..3 * n).map(|_| rng.uniform(-0.6, 0.6) as f32).collect();
        let z: Vec<f32> = pts.chunks_exact(3).map(|c| d[0] * c[0] + d[1] * c[1] + d[2] * c[2]).collect();
        let x = Tensor::<2>::from_data(TensorData::new(pts, [n, 3]), &device);
        let target = Tensor::<2>::from_data(TensorData::new(z, [n, 1]), &device);
        let ez = Tensor::<2>::from_data(TensorData::new(d.to_vec(), [1, 3]), &device).expand([n, 3]);
        let out = net.forward_gradient(x);
        let loss = (out.value - target).square().mean() + (out.gradient - ez).square().sum_dim(1).mean();
        let v: f32 = loss.clone().into_scalar();
        if !v.is_finite() {
            return Err(FieldError::Diverged { loss: v, step });
        }
        net = descend(&mut opt, net, loss, 1e-3);
    }
    Ok(net)
}

/// Draws batches: up to half from the "hot" poses (those whose tool last came closer to
/// the part than the clearance, in turn), the rest from a shuffled pass over all poses.
pub(crate) struct Batcher {
    pub(crate) rng: SplitMix64,
    order: Vec<usize>,
    cursor: usize,
    hot: std::collections::VecDeque<usize>,
    is_hot: Vec<bool>,
}

impl Batcher {
    pub(crate) fn new(np: usize, seed: u64) -> Self {
        Self {
            rng: SplitMix64::new(seed, 0x4d49_4c4c),
            order: (0..np).collect(),
            cursor: np,
            hot: Default::default(),
            is_hot: vec![false; np],
        }
    }

    /// A batch of `size` distinct poses (fewer when there are fewer poses), `forced` first.
    pub(crate) fn batch(&mut self, size: usize, forced: &[usize], out: &mut Vec<usize>) {
        let np = self.order.len();
        let size = size.min(np);
        out.clear();
        let mut taken = vec![false; np];
        for &i in forced.iter().take(size) {
            if !taken[i] {
                taken[i] = true;
                out.push(i);
            }
        }
        let hot_quota = (size / 2).saturating_sub(out.len());
        for _ in 0..self.hot.len().min(hot_quota) {
            if let Some(i) = self.hot.pop_front() {
                self.hot.push_back(i);
                if !taken[i] {
                    taken[i] = true;
                    out.push(i);
                }
            }
        }
        let mut guard = 0;
        while out.len() < size && guard < 2 * np + 2 {
            guard += 1;
            if self.cursor == np {
                for i in (1..np).rev() {
                    self.order.swap(i, self.rng.below(i + 1));
                }
                self.cursor = 0;
            }
            let i = self.order[self.cursor];
            self.cursor += 1;
            if !taken[i] {
                taken[i] = true;
                out.push(i);
            }
        }
    }

    /// Marks the poses of `batch` hot (in `near`) or cold (not in it).
    pub(crate) fn update(&mut self, batch: &[usize], near: &[usize]) {
        for &i in batch {
            self.is_hot[i] = false;
        }
        for &i in near {
            self.is_hot[i] = true;
        }
        let is_hot = &self.is_hot;
        self.hot.retain(|&i| is_hot[i]);
        for &i in near {
            if !self.hot.contains(&i) {
                self.hot.push_back(i);
            }
        }
    }
}

/// Constants inside the individual losses. The seed's text gives their form but not all
/// their values; the defaults are this crate's choices (documented per field).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LossConstants {
    /// Slope factor of the collision ReLUs (Eq. 12), applied to distances in unit-cube
    /// lengths. Default `1.0` (the paper's value is not given; only its product with the
    /// collision weight matters).
    pub collision_slope: f64,
    /// Clearance `ε` of the tool-part constraint (Eq. 14), in part units. Default `0.3`.
    pub part_clearance: f64,
    /// Clearance `ε` of the inter-layer constraint (Eq. 13), in unit-cube `G` units.
    /// Default `0.0`.
    pub layer_clearance: f64,
    /// The curvature threshold `κ̄` of Eq. 24, in 1 / part units. Default `0.1`
    /// (a 10 mm radius).
    pub max_curvature: f64,
    /// Intrinsic factor of the curvature loss (Eq. 24: 30).
    pub curvature_factor: f64,
    /// The singularity mask (Eq. 52-53): points with `|∇G|` below this (unit-cube units)
    /// are left out of the curvature loss, by a sigmoid of width a tenth of it. Default
    /// `0.1` (the planar start has `|∇G| = 1`).
    pub singular_gradient: f64,
    /// Zero-gradient loss (Eq. 27): `mean ReLU(min_gradient - |∇G|)`. Default `0.5`.
    pub min_gradient: f64,
}

impl Default for LossConstants {
    fn default() -> Self {
        Self {
            collision_slope: 1.0,
            part_clearance: 0.3,
            layer_clearance: 0.0,
            max_curvature: 0.1,
            curvature_factor: 30.0,
            singular_gradient: 0.1,
            min_gradient: 0.5,
        }
    }
}
