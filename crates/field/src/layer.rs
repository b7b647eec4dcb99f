//! Geometric quantities of a layer field `G` (§3.2 of seed 002), as batched tensor
//! functions of its gradient `[n, 3]` and Hessian `[n, 3, 3]` (for example
//! [`Siren::forward_hessian`](crate::Siren::forward_hessian)'s output), differentiable with
//! respect to whatever produced them.
//!
//! - layer normal `n = ∇G / |∇G|` (Eq. 2) and spacing measure `|∇G|`;
//! - mean curvature (Eq. 5, Goldman 2005), here with the sign `H = ½ ∇·n =
//!   (|∇G|² tr(∇²G) - ∇Gᵀ ∇²G ∇G) / (2 |∇G|³)`: positive for a sphere whose field grows
//!   outward (Goldman's formula with the opposite sign);
//! - Gaussian curvature (Eq. 6) `K = ∇Gᵀ adj(∇²G) ∇G / |∇G|⁴`, independent of the sign;
//! - principal curvatures (Eq. 23) `κ = H ± sqrt(H² - K)`.
//!
//! Divisions by `|∇G|` are guarded by [`GRAD_EPS`]: at a singular point (`∇G = 0`) the
//! values are large but finite; losses mask such points (Eq. 52-53).

use burn::tensor::Tensor;

use crate::siren::FieldHessian;

/// Added to `|∇G|²` before any division, so singular points give finite values.
pub const GRAD_EPS: f64 = 1e-12;

/// The geometric quantities of §3.2 at a batch of points.
#[derive(Debug, Clone)]
pub struct LayerGeometry {
    /// Unit layer normal `∇G/|∇G|`, `[n, 3]` (Eq. 2).
    pub normal: Tensor<2>,
    /// `|∇G|`, `[n, 1]`: the rate of change of `G`, inversely proportional to the layer
    /// spacing.
    pub spacing: Tensor<2>,
    /// Mean curvature `H`, `[n, 1]` (Eq. 5, sign as in the module docs).
    pub mean_curvature: Tensor<2>,
    /// Gaussian curvature `K`, `[n, 1]` (Eq. 6).
    pub gaussian_curvature: Tensor<2>,
}

impl LayerGeometry {
    /// All quantities from a gradient `[n, 3]` and a Hessian `[n, 3, 3]`.
    pub fn new(gradient: Tensor<2>, hessian: Tensor<3>) -> Self {
        Self {
            normal: layer_normal(gradient.clone()),
            spacing: gradient_norm(gradient.clone()),
            mean_curvature: mean_curvature(gradient.clone(), hessian.clone()),
            gaussian_curvature: gaussian_curvature(gradient, hessian),
        }
    }

    /// All quantities from a [`Siren::forward_hessian`](crate::Siren::forward_hessian)
    /// output.
    pub fn from_field(field: &FieldHessian) -> Self {
        Self::new(field.gradient.clone(), field.hessian.clone())
    }

    /// The principal curvatures `(κ1, κ2) = H ± sqrt(max(H² - K, 0))`, each `[n, 1]`.
    pub fn principal_curvatures(&self) -> (Tensor<2>, Tensor<2>) {
        principal_curvatures(self.mean_curvature.clone(), self.gaussian_curvature.clone())
    }

    /// The larger principal curvature magnitude `|H| + sqrt(max(H² - K, 0))`, `[n, 1]`.
    pub fn max_abs_curvature(&self) -> Tensor<2> {
        max_abs_curvature(self.mean_curvature.clone(), self.gaussian_curvature.clone())
    }
}

/// `|g|`, `[n, 1]`, for `g` `[n, 3]` (guarded by [`GRAD_EPS`]).
pub fn gradient_norm(gradient: Tensor<2>) -> Tensor<2> {
    gradient.square().sum_dim(1).add_scalar(GRAD_EPS).sqrt()
}

/// The unit layer normal `∇G/|∇G|`, `[n, 3]` (Eq. 2).
pub fn layer_normal(gradient: Tensor<2>) -> Tensor<2> {
    let norm = gradient_norm(gradient.clone());
    gradient / norm
}

/// `∇²G ∇G`, `[n, 3]`.
pub fn hessian_times_gradient(gradient: Tensor<2>, hessian: Tensor<3>) -> Tensor<2> {
    let n = gradient.dims()[0];
    (hessian * gradient.reshape([n, 1, 3])).sum_dim(2).reshape([n, 3])
}

/// The row-wise cross product `a × b`, `[n, 3]`, of `a` and `b` `[n, 3]`.
pub(crate) fn cross(a: Tensor<2>, b: Tensor<2>) -> Tensor<2> {
    let c = |t: &Tensor<2>, k| t.clone().narrow(1, k, 1);
    Tensor::cat(
        vec![
            c(&a, 1) * c(&b, 2) - c(&a, 2) * c(&b, 1),
            c(&a, 2) * c(&b, 0) - c(&a, 0) * c(&b, 2),
            c(&a, 0) * c(&b, 1) - c(&a, 1) * c(&b, 0),
        ],
        1,
    )
}

/// The nine Hessian entries as `[n, 1]` columns, row-major.
fn entries(hessian: Tensor<3>) -> Vec<Tensor<2>> {
    let n = hessian.dims()[0];
    let flat = hessian.reshape([n, 9]);
    (0..9).map(|k| flat.clone().narrow(1, k, 1)).collect()
}

/// Mean curvature of the level sets, `[n, 1]` (Eq. 5; sign as in the module docs).
pub fn mean_curvature(gradient: Tensor<2>, hessian: Tensor<3>) -> Tensor<2> {
    let g2 = gradient.clone().square().sum_dim(1).add_scalar(GRAD_EPS); // [n, 1]
    let h = entries(hessian.clone());
    let trace = h[0].clone() + h[4].clone() + h[8].clone();
    let ghg = (hessian_times_gradient(gradient.clone(), hessian) * gradient).sum_dim(1);
    let num = g2.clone() * trace - ghg;
    num / (g2.clone() * g2.sqrt()).mul_scalar(2.0)
}

/// Gaussian curvature of the level sets, `[n, 1]` (Eq. 6), using the adjugate of the
/// (symmetric) Hessian.
pub fn gaussian_curvature(gradient: Tensor<2>, hessian: Tensor<3>) -> Tensor<2> {
    let h = entries(hessian);
    let g: Vec<Tensor<2>> = (0..3).map(|k| gradient.clone().narrow(1, k, 1)).collect();
    let (h00, h01, h02, h11, h12, h22) =
        (h[0].clone(), h[1].clone(), h[2].clone(), h[4].clone(), h[5].clone(), h[8].clone());
    // Cofactors of a symmetric matrix.
    let a00 = h11.clone() * h22.clone() - h12.clone().square();
    let a11 = h00.clone() * h22.clone() - h02.clone().square();
    let a22 = h00.clone() * h11.clone() - h01.clone().square();
    let a01 = h02.clone() * h12.clone() - h01.clone() * h22;
    let a02 = h01.clone() * h12.clone() - h02.clone() * h11;
    let a12 = h01 * h02 - h00 * h12;
    let gag = a00 * g[0].clone().square()
        + a11 * g[1].clone().square()
        + a22 * g[2].clone().square()
        + (a01 * g[0].clone() * g[1].clone()
            + a02 * g[0].clone() * g[2].clone()
            + a12 * g[1].clone() * g[2].clone())
        .mul_scalar(2.0);
    let g2 = gradient.square().sum_dim(1).add_scalar(GRAD_EPS);
    gag / g2.square()
}

/// `sqrt(max(H² - K, 0))`, guarded so its derivative stays finite at umbilic points.
fn discriminant_root(mean: Tensor<2>, gaussian: Tensor<2>) -> Tensor<2> {
    (mean.square() - gaussian).clamp_min(0.0).add_scalar(GRAD_EPS).sqrt()
}

/// The principal curvatures `(κ1, κ2) = H ± sqrt(max(H² - K, 0))` (Eq. 23).
pub fn principal_curvatures(mean: Tensor<2>, gaussian: Tensor<2>) -> (Tensor<2>, Tensor<2>) {
    let root = discriminant_root(mean.clone(), gaussian);
    (mean.clone() + root.clone(), mean - root)
}

/// The larger principal curvature magnitude `max(|κ1|, |κ2|) = |H| + sqrt(max(H² - K, 0))`.
pub fn max_abs_curvature(mean: Tensor<2>, gaussian: Tensor<2>) -> Tensor<2> {
    let root = discriminant_root(mean.clone(), gaussian);
    mean.abs() + root
}
