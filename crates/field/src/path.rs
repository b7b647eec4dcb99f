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
//! Divisions are guarded like [`LayerGeometry`](crate::LayerGeometry)'s by
//! [`GRAD_EPS`](crate::GRAD_EPS): where
//! `∇P` is parallel to `∇G` (a singular point of the paths on the layer) the values are
//! large but finite, and the curvature loss masks such points (Eq. 52-53).

use burn::tensor::Tensor;

use crate::layer::{cross, gradient_norm, hessian_times_gradient, layer_normal};
use crate::siren::FieldHessian;

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
