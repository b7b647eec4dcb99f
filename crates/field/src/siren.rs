//! The SIREN network (Sitzmann et al., "Implicit neural representations with periodic
//! activation functions", NeurIPS 2020) with its input gradient and Hessian computed in the
//! forward pass.
//!
//! Layer `l` maps `h_l` to `h_{l+1} = sin(ω_l (h_l W_l + b_l))` (Eq. (51) of the
//! implicit multi-axis paper, seed 002); the last layer is linear. Derivatives with respect
//! to the input `x` are propagated forward through the layers as tensor operations, with
//! `u = J_l W_l` (the Jacobian of the pre-activation):
//!
//! - `J_{l+1} = ω cos(ω z) ⊙ u`
//! - `H_{l+1} = -ω² sin(ω z) ⊙ (u ⊗ u) + ω cos(ω z) ⊙ (H_l W_l)`
//!
//! starting from `J_0 = I`, `H_0 = 0`. Because these are ordinary tensor operations, a loss
//! on the gradient or the Hessian (Eikonal, normal alignment, curvature) needs only Burn's
//! first-order autodiff with respect to the parameters.

use burn::module::{Module, Param};
use burn::nn::Linear;
use burn::tensor::{Device, Tensor, TensorData};

use crate::error::{FieldError, Result};
use s2g_geom::SplitMix64;

/// Shape, frequencies and seed of a [`Siren`].
///
/// Every field is public and documented with its default; [`SirenConfig::validate`] (called
/// by every constructor) refuses out-of-range values with [`FieldError::InvalidConfig`].
#[derive(Debug, Clone, PartialEq)]
pub struct SirenConfig {
    /// Number of sine layers (the first layer counts), `>= 1`; a linear output layer
    /// follows them. Default `3`.
    pub sine_layers: usize,
    /// Width of every sine layer, `>= 1`. Default `64`.
    pub width: usize,
    /// `ω0`, the frequency of the first layer, finite and `> 0`, in the units of the
    /// network's input. Sitzmann et al. use 30 on `[-1, 1]^3`; §7.5.1 of seed 002 ties it to
    /// the model scale (see [`omega_for_scale`]). Default `30`.
    pub first_omega: f64,
    /// `ω`, the frequency of the other sine layers, finite and `> 0`. The hidden weights are
    /// initialised divided by it, so at initialisation it cancels (§7.5.1 keeps it equal to
    /// `ω0`, as Sitzmann et al. do). Default `30`.
    pub hidden_omega: f64,
    /// Seed of the weight initialisation. Default `0`.
    pub seed: u64,
}

impl Default for SirenConfig {
    fn default() -> Self {
        Self { sine_layers: 3, width: 64, first_omega: 30.0, hidden_omega: 30.0, seed: 0 }
    }
}

impl SirenConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        if self.sine_layers == 0 {
            return Err(FieldError::config("sine_layers", "must be at least 1"));
        }
        if self.width == 0 {
            return Err(FieldError::config("width", "must be at least 1"));
        }
        // A width this large cannot be allocated anyway; refusing it keeps `width^2`
        // products from overflowing.
        if self.width > 1 << 16 || self.sine_layers > 1 << 10 {
            return Err(FieldError::config("width", "network too large (width <= 65536, layers <= 1024)"));
        }
        FieldError::check_positive(&[("first_omega", self.first_omega), ("hidden_omega", self.hidden_omega)])
    }

    /// The layer widths, input (3) to output (1).
    pub(crate) fn widths(&self) -> Vec<usize> {
        let mut w = vec![3];
        w.extend(std::iter::repeat_n(self.width, self.sine_layers));
        w.push(1);
        w
    }
}

/// The scale-invariant first-layer frequency of §7.5.1 (seed 002): a part normalised by
/// `scale` (model units per network-input unit, e.g. 75 for a 150 mm part mapped to
/// `[-1, 1]`) gets `ω0 = omega_tilde * scale`, so that `ω0 x̂ = omega_tilde x` in the
/// part's own coordinates `x`: the field's frequency per millimetre does not depend on the
/// part's size. `omega_tilde` is thus a frequency per model unit.
pub fn omega_for_scale(omega_tilde: f64, scale: f64) -> f64 {
    omega_tilde * scale
}

/// A SIREN: `3 -> width -> ... -> width -> 1`, sine activations, linear output.
///
/// Lives on one Burn device (with or without autodiff); the forward passes take a batch of
/// points `[n, 3]` and return the field value `[n, 1]`, its gradient `[n, 3]` and, in
/// [`Siren::forward_hessian`], its Hessian `[n, 3, 3]`, all differentiable with respect to
/// the parameters.
#[derive(Module, Debug)]
pub struct Siren {
    /// The sine layers, then the linear output layer. Burn's layout: weight `[in, out]`.
    layers: Vec<Linear>,
    #[module(skip)]
    first_omega: f64,
    #[module(skip)]
    hidden_omega: f64,
}

/// A field value and its input gradient, for a batch of points.
#[derive(Debug, Clone)]
pub struct FieldGradient {
    /// `f(x)`: `[n, 1]`.
    pub value: Tensor<2>,
    /// `∇f(x)`: `[n, 3]`.
    pub gradient: Tensor<2>,
}

/// A field value with its input gradient and Hessian, for a batch of points.
#[derive(Debug, Clone)]
pub struct FieldHessian {
    /// `f(x)`: `[n, 1]`.
    pub value: Tensor<2>,
    /// `∇f(x)`: `[n, 3]`.
    pub gradient: Tensor<2>,
    /// `∇²f(x)`: `[n, 3, 3]`, entry `[k, i, j] = ∂²f / ∂x_i ∂x_j` at point `k` (symmetric).
    pub hessian: Tensor<3>,
}

impl Siren {
    /// A network with Sitzmann's initialisation drawn from `config.seed`, on `device`.
    ///
    /// First layer weights `U(-1/3, 1/3)` (`1/fan_in`), other weights (the output layer's
    /// too, as in Sitzmann's code) `U(-sqrt(6/fan_in)/ω, sqrt(6/fan_in)/ω)`, biases
    /// `U(-1/sqrt(fan_in), 1/sqrt(fan_in))` (PyTorch's `Linear` default, which Sitzmann
    /// keeps). Drawn from this crate's own generator rather than Burn's backend-wide random
    /// state, so the same seed gives the same network on every run.
    pub fn new(config: &SirenConfig, device: &Device) -> Result<Self> {
        config.validate()?;
        let mut rng = SplitMix64::new(config.seed, 0x5142_454e);
        let widths = config.widths();
        let last = widths.len() - 2;
        let mut weights = Vec::with_capacity(widths.len() - 1);
        for (l, w) in widths.windows(2).enumerate() {
            let (d_in, d_out) = (w[0], w[1]);
            let fan = d_in as f64;
            let bound = if l == 0 { 1.0 / fan } else { (6.0 / fan).sqrt() / config.hidden_omega };
            let bias_bound = 1.0 / fan.sqrt();
            let weight: Vec<f32> = (0..d_in * d_out).map(|_| rng.uniform(-bound, bound) as f32).collect();
            let bias: Vec<f32> = (0..d_out).map(|_| rng.uniform(-bias_bound, bias_bound) as f32).collect();
            weights.push((weight, bias));
        }
        debug_assert_eq!(weights.len(), last + 1);
        Ok(Self::from_weights(&widths, weights, config.first_omega, config.hidden_omega, device))
    }

    /// A network with the given per-layer `(weight [in * out, row-major], bias [out])`.
    pub(crate) fn from_weights(
        widths: &[usize],
        weights: Vec<(Vec<f32>, Vec<f32>)>,
        first_omega: f64,
        hidden_omega: f64,
        device: &Device,
    ) -> Self {
        let layers = widths
            .windows(2)
            .zip(weights)
            .map(|(w, (weight, bias))| Linear {
                weight: Param::from_data(TensorData::new(weight, [w[0], w[1]]), device),
                bias: Some(Param::from_data(TensorData::new(bias, [w[1]]), device)),
            })
            .collect();
        Self { layers, first_omega, hidden_omega }
    }

    /// `ω0`, the first layer's frequency.
    pub fn first_omega(&self) -> f64 {
        self.first_omega
    }

    /// `ω`, the other sine layers' frequency.
    pub fn hidden_omega(&self) -> f64 {
        self.hidden_omega
    }

    /// Number of sine layers.
    pub fn sine_layers(&self) -> usize {
        self.layers.len() - 1
    }

    /// Width of the sine layers.
    pub fn width(&self) -> usize {
        self.layers.first().map(|l| l.weight.dims()[1]).unwrap_or(0)
    }

    fn omega(&self, layer: usize) -> f64 {
        if layer == 0 { self.first_omega } else { self.hidden_omega }
    }

    /// Weight `[in, out]` and bias `[1, out]` of layer `l`.
    fn params(layer: &Linear) -> (Tensor<2>, Tensor<2>) {
        let w = layer.weight.val();
        let out = w.dims()[1];
        let b = match &layer.bias {
            Some(b) => b.val().reshape([1, out]),
            None => Tensor::zeros([1, out], &w.device()),
        };
        (w, b)
    }

    /// The field value only.
    ///
    /// - `x`: `[n, 3]`
    /// - output: `[n, 1]`
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let last = self.layers.len() - 1;
        let mut h = x;
        for (l, layer) in self.layers.iter().enumerate() {
            let (w, b) = Self::params(layer);
            let z = h.matmul(w) + b;
            h = if l < last { z.mul_scalar(self.omega(l)).sin() } else { z };
        }
        h
    }

    /// The field value and its exact input gradient, propagating the Jacobian `[n, 3, width]`
    /// through the layers: four matrix products per layer where [`Siren::forward`] has one.
    ///
    /// - `x`: `[n, 3]`
    /// - output: value `[n, 1]`, gradient `[n, 3]`
    pub fn forward_gradient(&self, x: Tensor<2>) -> FieldGradient {
        let n = x.dims()[0];
        let last = self.layers.len() - 1;
        let mut h = x;
        let mut jac: Option<Tensor<3>> = None; // None stands for the identity J_0.
        for (l, layer) in self.layers.iter().enumerate() {
            let (w, b) = Self::params(layer);
            let d_out = w.dims()[1];
            let z = h.matmul(w.clone()) + b;
            // u = J W: the Jacobian of the pre-activation, [n, 3, out].
            let u = match jac {
                None => w.unsqueeze_dim::<3>(0).expand([n, 3, d_out]),
                Some(j) => {
                    let d_in = j.dims()[2];
                    j.reshape([n * 3, d_in]).matmul(w).reshape([n, 3, d_out])
                }
            };
            if l == last {
                return FieldGradient { value: z, gradient: u.reshape([n, 3]) };
            }
            let omega = self.omega(l);
            let wz = z.mul_scalar(omega);
            h = wz.clone().sin();
            jac = Some(wz.cos().mul_scalar(omega).unsqueeze_dim::<3>(1) * u);
        }
        // Every constructor builds at least one sine layer and the output layer.
        unreachable!("a Siren always has an output layer")
    }

    /// The field value, its exact input gradient and its exact Hessian, propagating the
    /// Jacobian `[n, 3, width]` and the Hessian `[n, 3, 3, width]` through the layers:
    /// thirteen matrix products per layer where [`Siren::forward`] has one, and as much
    /// more memory per point.
    ///
    /// - `x`: `[n, 3]`
    /// - output: value `[n, 1]`, gradient `[n, 3]`, Hessian `[n, 3, 3]`
    pub fn forward_hessian(&self, x: Tensor<2>) -> FieldHessian {
        let n = x.dims()[0];
        let last = self.layers.len() - 1;
        let mut h = x;
        // None stands for J_0 = I and H_0 = 0.
        let mut derivs: Option<(Tensor<3>, Tensor<4>)> = None;
        for (l, layer) in self.layers.iter().enumerate() {
            let (w, b) = Self::params(layer);
            let d_out = w.dims()[1];
            let z = h.matmul(w.clone()) + b;
            // u = J W, [n, 3, out]; v = H W, [n, 3, 3, out] (absent while H is zero).
            let (u, v) = match derivs {
                None => (w.unsqueeze_dim::<3>(0).expand([n, 3, d_out]), None),
                Some((j, hess)) => {
                    let d_in = j.dims()[2];
                    let u = j.reshape([n * 3, d_in]).matmul(w.clone()).reshape([n, 3, d_out]);
                    let v = hess.reshape([n * 9, d_in]).matmul(w).reshape([n, 3, 3, d_out]);
                    (u, Some(v))
                }
            };
            if l == last {
                let hessian = match v {
                    Some(v) => v.reshape([n, 3, 3]),
                    None => Tensor::zeros([n, 3, 3], &u.device()),
                };
                return FieldHessian { value: z, gradient: u.reshape([n, 3]), hessian };
            }
            let omega = self.omega(l);
            let wz = z.mul_scalar(omega);
            let sin = wz.clone().sin();
            let cos_w = wz.cos().mul_scalar(omega); // ω cos(ωz), [n, out]
            // -ω² sin(ωz) (u_i u_j) + ω cos(ωz) v_ij
            let uu = u.clone().unsqueeze_dim::<4>(2) * u.clone().unsqueeze_dim::<4>(1);
            let mut new_h = sin.clone().mul_scalar(-omega * omega).reshape([n, 1, 1, d_out]) * uu;
            if let Some(v) = v {
                new_h = new_h + cos_w.clone().reshape([n, 1, 1, d_out]) * v;
            }
            let new_j = cos_w.unsqueeze_dim::<3>(1) * u;
            h = sin;
            derivs = Some((new_j, new_h));
        }
        // Every constructor builds at least one sine layer and the output layer.
        unreachable!("a Siren always has an output layer")
    }

    /// The weights as host data, `(weight [in * out] row-major, bias [out])` per layer.
    pub(crate) fn weights(&self) -> Result<Vec<(Vec<f32>, Vec<f32>)>> {
        self.layers
            .iter()
            .map(|layer| {
                let (w, b) = Self::params(layer);
                Ok((crate::backend::host_values(w)?, crate::backend::host_values(b)?))
            })
            .collect()
    }

    /// The layer widths, input (3) to output (1).
    pub(crate) fn widths(&self) -> Vec<usize> {
        let mut widths = vec![3];
        widths.extend(self.layers.iter().map(|l| l.weight.dims()[1]));
        widths
    }

    /// A copy of the weights evaluated on the host in `f64`, for per-point queries.
    pub fn to_f64(&self) -> Result<SirenF64> {
        let widths = self.widths();
        let layers = widths
            .windows(2)
            .zip(self.weights()?)
            .map(|(w, (weight, bias))| HostLayer { d_in: w[0], d_out: w[1], weight, bias })
            .collect();
        Ok(SirenF64 { layers, first_omega: self.first_omega, hidden_omega: self.hidden_omega })
    }
}

#[derive(Debug, Clone, PartialEq)]
struct HostLayer {
    d_in: usize,
    d_out: usize,
    /// `[d_in, d_out]` row-major, as stored (f32): the host copy keeps the exact weights so
    /// that a [`Siren`] can be rebuilt bit-identically.
    weight: Vec<f32>,
    bias: Vec<f32>,
}

/// The weights of a [`Siren`] evaluated point by point on the host in `f64`, without Burn:
/// value, gradient and Hessian by the same forward-mode recurrences. Plain data
/// (`Send + Sync + Clone`), a few microseconds per point for the default network; what
/// [`NeuralSdf`](crate::NeuralSdf) answers its queries with.
#[derive(Debug, Clone, PartialEq)]
pub struct SirenF64 {
    layers: Vec<HostLayer>,
    first_omega: f64,
    hidden_omega: f64,
}

impl SirenF64 {
    /// `ω0`, the first layer's frequency.
    pub fn first_omega(&self) -> f64 {
        self.first_omega
    }

    /// `ω`, the other sine layers' frequency.
    pub fn hidden_omega(&self) -> f64 {
        self.hidden_omega
    }

    /// The field value at `x`.
    pub fn value(&self, x: [f64; 3]) -> f64 {
        let mut h: Vec<f64> = x.to_vec();
        let last = self.layers.len() - 1;
        for (l, layer) in self.layers.iter().enumerate() {
            let omega = if l == 0 { self.first_omega } else { self.hidden_omega };
            let mut z: Vec<f64> = layer.bias.iter().map(|&b| b as f64).collect();
            for (i, &hi) in h.iter().enumerate() {
                let row = &layer.weight[i * layer.d_out..(i + 1) * layer.d_out];
                for (zk, &w) in z.iter_mut().zip(row) {
                    *zk += hi * w as f64;
                }
            }
            h = if l < last { z.iter().map(|&zk| (omega * zk).sin()).collect() } else { z };
        }
        h[0]
    }

    /// The field value and its gradient at `x`.
    pub fn value_gradient(&self, x: [f64; 3]) -> (f64, [f64; 3]) {
        let (f, g, _) = self.eval(x, false);
        (f, g)
    }

    /// The field value, its gradient and its Hessian (`[i][j] = ∂²f/∂x_i∂x_j`) at `x`.
    pub fn value_gradient_hessian(&self, x: [f64; 3]) -> (f64, [f64; 3], [[f64; 3]; 3]) {
        self.eval(x, true)
    }

    fn eval(&self, x: [f64; 3], with_hessian: bool) -> (f64, [f64; 3], [[f64; 3]; 3]) {
        let mut h: Vec<f64> = x.to_vec();
        // jac[k][i] = ∂h_k/∂x_i; hess[k][i][j] = ∂²h_k/∂x_i∂x_j.
        let mut jac: Vec<[f64; 3]> = (0..3).map(|k| std::array::from_fn(|i| (i == k) as u8 as f64)).collect();
        let mut hess: Vec<[[f64; 3]; 3]> = vec![[[0.0; 3]; 3]; 3];
        let last = self.layers.len() - 1;
        for (l, layer) in self.layers.iter().enumerate() {
            let omega = if l == 0 { self.first_omega } else { self.hidden_omega };
            let d_out = layer.d_out;
            let mut z: Vec<f64> = layer.bias.iter().map(|&b| b as f64).collect();
            let mut u = vec![[0.0f64; 3]; d_out];
            let mut v = vec![[[0.0f64; 3]; 3]; if with_hessian { d_out } else { 0 }];
            for i in 0..layer.d_in {
                let row = &layer.weight[i * d_out..(i + 1) * d_out];
                for (k, &w) in row.iter().enumerate() {
                    let w = w as f64;
                    z[k] += h[i] * w;
                    for a in 0..3 {
                        u[k][a] += jac[i][a] * w;
                    }
                    if with_hessian {
                        for a in 0..3 {
                            for b in 0..3 {
                                v[k][a][b] += hess[i][a][b] * w;
                            }
                        }
                    }
                }
            }
            if l == last {
                let hessian = if with_hessian { v[0] } else { [[0.0; 3]; 3] };
                return (z[0], u[0], hessian);
            }
            h = Vec::with_capacity(d_out);
            jac = Vec::with_capacity(d_out);
            hess = Vec::with_capacity(if with_hessian { d_out } else { 0 });
            for k in 0..d_out {
                let (s, c) = (omega * z[k]).sin_cos();
                h.push(s);
                jac.push(u[k].map(|ua| omega * c * ua));
                if with_hessian {
                    hess.push(std::array::from_fn(|a| {
                        std::array::from_fn(|b| {
                            -omega * omega * s * u[k][a] * u[k][b] + omega * c * v[k][a][b]
                        })
                    }));
                }
            }
        }
        // Every constructor builds at least one sine layer and the output layer.
        unreachable!("a Siren always has an output layer")
    }

    /// Rebuilds the Burn network on `device` (bit-identical weights).
    pub fn to_siren(&self, device: &Device) -> Siren {
        let mut widths = vec![3];
        widths.extend(self.layers.iter().map(|l| l.d_out));
        let weights = self.layers.iter().map(|l| (l.weight.clone(), l.bias.clone())).collect();
        Siren::from_weights(&widths, weights, self.first_omega, self.hidden_omega, device)
    }
}
