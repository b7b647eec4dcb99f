//! Support- and collision-free printing layers (§4.1, §4.6, §5.1, §7.1 of seed 002): a
//! layer field `G` (a [`Siren`]) whose level sets are the printed layers and whose normal
//! `d = ∇G/|∇G|` is the local printing (build) direction and the nozzle's axis, optimised
//! from planar layers by the SCF total loss (Eq. 37).
//!
//! - [`PrintProblem`]: the part (any [`SignedDistance`], e.g. [`MeshSdf`](crate::MeshSdf)),
//!   the nozzle (a [`Tool`] sampled as points, Appendix B), the platform (the plane
//!   `z = platform` with normal `+z`), the deposition poses (grid points inside the part,
//!   §6.4), the surface samples with their outward normals (the boundary minus the base) and
//!   the base samples (the region in contact with the platform).
//! - [`print_losses`]: the support-free loss (Eq. 29-30, [`support_free_loss`]), the base
//!   loss (Eq. 31, [`base_loss`]), the nozzle-part collision loss (Eq. 8, 13: a nozzle
//!   point inside the part must lie on a layer not printed yet, `G(q) > G(x)`), the
//!   nozzle-platform collision (Eq. 35-36), and the layer regularisers shared with milling
//!   (spacing Eq. 26, zero gradient Eq. 27, curvature Eq. 24 with the singularity mask),
//!   combined by [`PrintWeights`] (Table 1's SCF row, Eq. 37).
//! - [`optimize_print_layers`] runs Adam on Eq. 37 from planar layers
//!   ([`pretrain_planar_print`]), the collision weight rising as in milling, batches taking
//!   up to half their poses from those whose nozzle last collided.
//! - Measures: [`overhang_angle`] / [`overhang_stats`] (the largest overhang and the
//!   fraction of surface samples beyond the self-supporting angle), [`print_collisions`]
//!   (nozzle poses that hit printed material or the platform).
//! - [`bent_arm_mesh`]: a round arm rising from the platform and bending over by a given
//!   angle: planar layers leave its underside overhanging by that angle.
//!
//! The overhang angle of a surface point with outward normal `n_s` under the build
//! direction `d` is `asin(max(0, -n_s·d))`: the angle by which the surface leans out past
//! the vertical (`d`-parallel) wall, i.e. the angle between `n_s` and `d` minus 90° for a
//! downward-facing surface, 0° for a wall or an upward-facing surface, 90° for a ceiling.
//! Eq. 29 asks `n_s·d >= -sin(α)` on the boundary minus the base; `α = 45°` is this crate's
//! default (the usual FDM value; the seed's text lost its number).
//!
//! Coordinates: the part, nozzle and poses are in the part's units (e.g. mm); the network
//! sees them through a [`Normalization`] (the part's bounding box centred and its largest
//! side scaled to 1), so planar layers are `G = ẑ`.

use std::f64::consts::FRAC_PI_2;
use std::time::Instant;

use burn::optim::AdamConfig;
use burn::tensor::{Int, Tensor, TensorData};
use s2g_geom::{Aabb, Mesh, Normalization, Point3, SignedDistance, Vector3, sample_surface};

use crate::backend::{Backend, host_values};
use crate::error::{FieldError, Result};
use crate::layer::{LayerGeometry, layer_normal};
use crate::siren::{FieldHessian, Siren, SirenConfig, SirenF64};
use crate::tool::{Tool, place_tool, tool_points};
use crate::train::LossConstants;
use crate::train::{
    Batcher, LossLog, device_of, fit_planar_along, layer_collision, loss_values, ramp, regularisers, train,
};

/// The overhang angle in degrees (see the module docs) of a surface with outward normal
/// `surface_normal` under the build direction `build_direction` (neither needs to be unit):
/// `asin(max(0, -n̂_s·d̂))`. A zero build direction (a singular point of the field) has no
/// direction to print along and counts as 90°; so does a zero surface normal.
pub fn overhang_angle(surface_normal: &Vector3, build_direction: &Vector3) -> f64 {
    match (surface_normal.try_normalize(1e-300), build_direction.try_normalize(1e-300)) {
        (Some(n), Some(d)) => (-n.dot(&d)).clamp(0.0, 1.0).asin().to_degrees(),
        _ => 90.0,
    }
}

/// The support-free loss (Eq. 30) on a batch: `factor · mean ReLU(-n_s·d - sin(max_overhang))`
/// with `d = ∇G/|∇G|` from `gradient` `[n, 3]` and the unit outward surface normals
/// `surface_normals` `[n, 3]`; `max_overhang_deg` is the effective self-supporting angle
/// (Eq. 30's, the limit less its margin). Zero where every overhang is within it.
pub fn support_free_loss(
    gradient: Tensor<2>,
    surface_normals: Tensor<2>,
    max_overhang_deg: f64,
    factor: f64,
) -> Tensor<1> {
    let cos = (layer_normal(gradient) * surface_normals).sum_dim(1); // n_s · d, [n, 1]
    cos.neg().sub_scalar(max_overhang_deg.to_radians().sin()).clamp_min(0.0).mean().mul_scalar(factor)
}

/// The base loss (Eq. 31) on a batch: `factor · mean (1 - d·n_p)` with `d = ∇G/|∇G|` from
/// `gradient` `[n, 3]` at base points and the unit platform normal `platform_normal`: zero
/// when the bottom layer lies flat on the platform.
pub fn base_loss(gradient: Tensor<2>, platform_normal: [f64; 3], factor: f64) -> Tensor<1> {
    let n = gradient.dims()[0];
    let device = gradient.device();
    let np = platform_normal.map(|c| c as f32).to_vec();
    let np = Tensor::<2>::from_data(TensorData::new(np, [1, 3]), &device).expand([n, 3]);
    let cos = (layer_normal(gradient) * np).sum_dim(1);
    cos.neg().add_scalar(1.0).mean().mul_scalar(factor)
}

/// Weights of the support- and collision-free printing total loss (Eq. 37 of seed 002).
///
/// Table 1 gives the SCF row: layer spacing 0.02, layer curvature 0.2 and the collision
/// weight rising from 8000 to 40000. The support-free and base losses carry their own
/// intrinsic factors (25 and 2.5, [`PrintConstants`]) and enter with weight 1; the
/// zero-gradient weight is not in the table (1.0, as for milling).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrintWeights {
    /// Layer spacing (Eq. 26). Table 1: `0.02`.
    pub spacing: f64,
    /// Layer curvature (Eq. 24). Table 1: `0.2`.
    pub curvature: f64,
    /// Zero gradient (Eq. 27). Not in Table 1; default `1.0`.
    pub zero_gradient: f64,
    /// Support-free (Eq. 30). Default `1.0`.
    pub support_free: f64,
    /// Base orientation (Eq. 31). Default `1.0`.
    pub base: f64,
    /// Collision weight at the first step. Table 1: `8000`.
    pub collision_start: f64,
    /// Collision weight at the last step (linear in between). Table 1: `40000`.
    pub collision_end: f64,
}

impl Default for PrintWeights {
    fn default() -> Self {
        Self {
            spacing: 0.02,
            curvature: 0.2,
            zero_gradient: 1.0,
            support_free: 1.0,
            base: 1.0,
            collision_start: 8000.0,
            collision_end: 40000.0,
        }
    }
}

impl PrintWeights {
    /// The collision weight at `step` of `steps` (linear, §5.5).
    pub fn collision_at(&self, step: usize, steps: usize) -> f64 {
        ramp(self.collision_start, self.collision_end, step, steps)
    }
}

/// Constants inside the printing losses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrintConstants {
    /// The layer regularisers' and the collision ReLU's constants, shared with milling
    /// ([`LossConstants`]; its `part_clearance` is unused: the nozzle works inside the
    /// part's volume, its constraint is the layers').
    pub layer: LossConstants,
    /// The self-supporting angle `α` of Eq. 29, in degrees, in `(0, 90)`. Default `45`.
    pub max_overhang_deg: f64,
    /// The margin subtracted from `α` in Eq. 30 so that the loss enforces Eq. 29 strictly,
    /// in degrees, in `[0, α)`. Default `2`.
    pub overhang_margin_deg: f64,
    /// Intrinsic factor of the support-free loss (Eq. 30: 25).
    pub support_factor: f64,
    /// Intrinsic factor of the base loss (Eq. 31: 2.5).
    pub base_factor: f64,
    /// Clearance `ε` of the nozzle above the platform (Eq. 35), in part units. Default `0.5`.
    pub platform_clearance: f64,
    /// Height `h0` above the platform, in part units, within which the first layers are
    /// held as flat as the nozzle needs: at a height `h`, a layer may tilt off the platform
    /// at most as far as the problem's nozzle along its normal stays
    /// [`PrintConstants::platform_clearance`] above the platform (Eq. 35 solved for the
    /// tilt: flat at the platform, free from about the nozzle's radius up;
    /// [`first_layers_loss`] with [`PrintConstants::first_layers_factor`], added to the
    /// base term).
    /// It is taken at the base samples lifted by every 0.5 up to `h0` and the surface
    /// samples below `h0` moved 0.5 inward (where inside the part), and at the poses below
    /// `h0`: the pose grid alone rarely samples the first layers, where the part flares out
    /// over the platform. `0` leaves Eq. 31 alone. Default `3`.
    pub first_layers: f64,
    /// Intrinsic factor of the first layers' loss ([`first_layers_loss`]). Default `8`: at
    /// `25` (the support-free loss's) the bunny's first layers were held so flat that its
    /// rebuilt print overhung 0.084, 0.074 and 0.123 of planar slicing's on seeds 0-2; at
    /// `8`, 0.034, 0.051 and 0.021, with the overhanging arch, the bracket and the arm
    /// still above 0.9 IoU on every seed (README, multi-axis printing).
    pub first_layers_factor: f64,
}

impl Default for PrintConstants {
    fn default() -> Self {
        Self {
            layer: LossConstants::default(),
            max_overhang_deg: 45.0,
            overhang_margin_deg: 2.0,
            support_factor: 25.0,
            base_factor: 2.5,
            platform_clearance: 0.5,
            first_layers: 3.0,
            first_layers_factor: 8.0,
        }
    }
}

impl PrintConstants {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        let c = self.layer;
        FieldError::check_non_negative(&[
            ("constants.layer.collision_slope", c.collision_slope),
            ("constants.layer.layer_clearance", c.layer_clearance),
            ("constants.layer.max_curvature", c.max_curvature),
            ("constants.layer.curvature_factor", c.curvature_factor),
            ("constants.layer.min_gradient", c.min_gradient),
            ("constants.support_factor", self.support_factor),
            ("constants.base_factor", self.base_factor),
            ("constants.platform_clearance", self.platform_clearance),
            ("constants.first_layers", self.first_layers),
            ("constants.first_layers_factor", self.first_layers_factor),
            ("constants.overhang_margin_deg", self.overhang_margin_deg),
        ])?;
        FieldError::check_positive(&[("constants.layer.singular_gradient", c.singular_gradient)])?;
        if !(self.max_overhang_deg > 0.0 && self.max_overhang_deg < 90.0) {
            return Err(FieldError::config("constants.max_overhang_deg", "must be in (0, 90)"));
        }
        if self.overhang_margin_deg >= self.max_overhang_deg {
            return Err(FieldError::config(
                "constants.overhang_margin_deg",
                "must be below max_overhang_deg",
            ));
        }
        Ok(())
    }

    /// The effective self-supporting angle of Eq. 30, `α - margin`, in degrees.
    pub fn effective_overhang_deg(&self) -> f64 {
        self.max_overhang_deg - self.overhang_margin_deg
    }
}

/// The sample sets of a [`PrintProblem`], in the part's units.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PrintSamples {
    /// Deposition poses: points inside the part (the regularisers and the collision loss).
    pub poses: Vec<Point3>,
    /// Surface points on the boundary minus the base (the support-free loss, the overhang
    /// measures).
    pub surface: Vec<Point3>,
    /// The outward normals at `surface`, one each (need not be unit).
    pub normals: Vec<Vector3>,
    /// Points of the base, on the platform (the base loss); may be empty.
    pub base: Vec<Point3>,
}

/// The part, the nozzle, the platform and the sample points of a printing problem.
pub struct PrintProblem<'a> {
    part: &'a dyn SignedDistance,
    nozzle: Tool,
    platform: f64,
    poses: Vec<Point3>,
    surface: Vec<Point3>,
    normals: Vec<Vector3>,
    base: Vec<Point3>,
    normalization: Normalization,
}

impl std::fmt::Debug for PrintProblem<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PrintProblem")
            .field("nozzle", &self.nozzle)
            .field("platform", &self.platform)
            .field("poses", &self.poses.len())
            .field("surface", &self.surface.len())
            .field("base", &self.base.len())
            .finish_non_exhaustive()
    }
}

impl<'a> PrintProblem<'a> {
    /// The problem of printing `mesh` (whose signed distance is `part`) standing on the
    /// platform `z = min z` of its bounding box: poses on a grid of spacing `grid` over the
    /// box, inside the part; `surface_samples` area-uniform surface samples from `seed`
    /// with their face normals, split into the base (within `1e-3` of the box's largest
    /// side above the platform, facing down within 1°) and the rest.
    ///
    /// Errors: [`FieldError::EmptyMesh`]; [`FieldError::InvalidArgument`] for a bad `grid`,
    /// too few samples, or no pose or surface point; [`FieldError::InvalidConfig`] for a
    /// bad nozzle; [`FieldError::NonFinite`] for a non-finite vertex.
    pub fn from_mesh(
        part: &'a dyn SignedDistance,
        mesh: &Mesh,
        nozzle: Tool,
        grid: f64,
        surface_samples: usize,
        seed: u64,
    ) -> Result<Self> {
        nozzle.validate()?;
        let bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
        if !bbox.min.iter().chain(bbox.max.iter()).all(|c| c.is_finite()) {
            return Err(FieldError::NonFinite { what: "mesh vertex", index: 0 });
        }
        let ext = bbox.max - bbox.min;
        if !(grid.is_finite() && grid > 0.0) {
            return Err(FieldError::InvalidArgument(format!("bad pose grid {grid}")));
        }
        let counts = ext.map(|e| (e / grid).floor() as usize + 1);
        if counts.iter().product::<usize>() > 4_000_000 {
            return Err(FieldError::InvalidArgument("the pose grid is too fine (> 4M points)".into()));
        }
        if !(1..=10_000_000).contains(&surface_samples) {
            return Err(FieldError::InvalidArgument(format!("{surface_samples} surface samples")));
        }
        // The grid centred in the box, so a symmetric part gets symmetric poses.
        let start = bbox.min + (ext - counts.map(|c| (c - 1) as f64) * grid) * 0.5;
        let mut poses = Vec::new();
        for i in 0..counts.x {
            for j in 0..counts.y {
                for k in 0..counts.z {
                    let p = start + Vector3::new(i as f64, j as f64, k as f64) * grid;
                    if part.distance(&p) < 0.0 {
                        poses.push(p);
                    }
                }
            }
        }
        let samples = sample_surface(mesh, surface_samples, seed).map_err(FieldError::geom)?;
        let platform = bbox.min.z;
        let tol = 1e-3 * ext.max();
        let down = -(1.0f64.to_radians().cos());
        let mut out = PrintSamples { poses, ..PrintSamples::default() };
        for (p, n) in samples.points.iter().zip(&samples.normals) {
            if p.z - platform <= tol && n.z <= down {
                out.base.push(*p);
            } else {
                out.surface.push(*p);
                out.normals.push(*n);
            }
        }
        Self::with_samples(part, nozzle, bbox, platform, out)
    }

    /// A problem with the given samples, the platform `z = platform` (normal `+z`), and the
    /// network's unit cube fitted to `bounds` (centred, largest side 1).
    ///
    /// Errors: [`FieldError::InvalidArgument`] for no pose or surface point, a normal count
    /// that differs from the surface's, a zero normal, or degenerate bounds;
    /// [`FieldError::NonFinite`] for a non-finite point, normal or platform;
    /// [`FieldError::InvalidConfig`] for a bad nozzle.
    pub fn with_samples(
        part: &'a dyn SignedDistance,
        nozzle: Tool,
        bounds: Aabb,
        platform: f64,
        samples: PrintSamples,
    ) -> Result<Self> {
        nozzle.validate()?;
        let PrintSamples { poses, surface, normals, base } = samples;
        if poses.is_empty() {
            return Err(FieldError::InvalidArgument("no pose points (none inside the part?)".into()));
        }
        if surface.is_empty() {
            return Err(FieldError::InvalidArgument("no surface samples off the base".into()));
        }
        if normals.len() != surface.len() {
            return Err(FieldError::InvalidArgument(format!(
                "{} normals for {} surface points",
                normals.len(),
                surface.len()
            )));
        }
        let finite = |p: &Point3| p.iter().all(|c| c.is_finite());
        for (what, pts) in [("pose point", &poses), ("surface point", &surface), ("base point", &base)] {
            if let Some(i) = pts.iter().position(|p| !finite(p)) {
                return Err(FieldError::NonFinite { what, index: i });
            }
        }
        if let Some(i) = normals.iter().position(|n| !n.iter().all(|c| c.is_finite())) {
            return Err(FieldError::NonFinite { what: "surface normal", index: i });
        }
        let normals = normals
            .iter()
            .enumerate()
            .map(|(i, n)| {
                n.try_normalize(1e-12)
                    .ok_or_else(|| FieldError::InvalidArgument(format!("surface normal {i} is zero")))
            })
            .collect::<Result<Vec<_>>>()?;
        if !platform.is_finite() {
            return Err(FieldError::NonFinite { what: "platform height", index: 0 });
        }
        let extent = (bounds.max - bounds.min).max();
        if !(finite(&bounds.min) && finite(&bounds.max) && extent.is_finite() && extent > 0.0) {
            return Err(FieldError::InvalidArgument("the bounds are degenerate or not finite".into()));
        }
        let scale = 1.0 / extent;
        let center = (bounds.min.coords + bounds.max.coords) * 0.5;
        let normalization = Normalization { scale, translation: -center * scale };
        Ok(Self { part, nozzle, platform, poses, surface, normals, base, normalization })
    }

    /// The part.
    pub fn part(&self) -> &'a dyn SignedDistance {
        self.part
    }

    /// The nozzle.
    pub fn nozzle(&self) -> &Tool {
        &self.nozzle
    }

    /// The platform's height (the plane `z = platform`, normal `+z`).
    pub fn platform(&self) -> f64 {
        self.platform
    }

    /// The deposition poses.
    pub fn poses(&self) -> &[Point3] {
        &self.poses
    }

    /// The surface samples off the base.
    pub fn surface(&self) -> &[Point3] {
        &self.surface
    }

    /// Their unit outward normals.
    pub fn normals(&self) -> &[Vector3] {
        &self.normals
    }

    /// The base samples.
    pub fn base(&self) -> &[Point3] {
        &self.base
    }

    /// The map from the part's units into the layer field's unit cube.
    pub fn normalization(&self) -> Normalization {
        self.normalization
    }

    pub(crate) fn unit_tensor(
        &self,
        pts: impl Iterator<Item = Point3>,
        device: &burn::tensor::Device,
    ) -> Tensor<2> {
        let v: Vec<f32> = pts
            .flat_map(|p| {
                let u = self.normalization.to_unit(&p);
                [u.x as f32, u.y as f32, u.z as f32]
            })
            .collect();
        let n = v.len() / 3;
        Tensor::<2>::from_data(TensorData::new(v, [n, 3]), device)
    }

    pub(crate) fn build_direction(&self, g: &SirenF64, p: &Point3) -> (f64, Vector3) {
        let u = self.normalization.to_unit(p);
        let (v, grad) = g.value_gradient([u.x, u.y, u.z]);
        (v, Vector3::new(grad[0], grad[1], grad[2]))
    }
}

/// The unweighted losses of one evaluation of Eq. 37, as tensors (scalars, `[1]`).
#[derive(Debug, Clone)]
pub struct PrintLosses {
    /// Support-free (Eq. 30) on the batch's surface samples.
    pub support_free: Tensor<1>,
    /// Base orientation (Eq. 31) on all base samples (zero without any), plus the first
    /// layers' loss ([`first_layers_loss`], [`PrintConstants::first_layers`]).
    pub base: Tensor<1>,
    /// Nozzle-part collision (Eq. 13): nozzle points inside the part on printed layers.
    pub collision: Tensor<1>,
    /// Nozzle-platform collision (Eq. 36): nozzle points within the clearance of the
    /// platform, in unit-cube lengths.
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

impl PrintLosses {
    /// Eq. 37: `w_ld L_ld + w_lc L_lc + w_zg L_zg + w_sf L_sf + w_b L_b + w_c (L_c + L_p)`.
    pub fn total(&self, w: &PrintWeights, collision_weight: f64) -> Tensor<1> {
        self.spacing.clone().mul_scalar(w.spacing)
            + self.curvature.clone().mul_scalar(w.curvature)
            + self.zero_gradient.clone().mul_scalar(w.zero_gradient)
            + self.support_free.clone().mul_scalar(w.support_free)
            + self.base.clone().mul_scalar(w.base)
            + (self.collision.clone() + self.platform.clone()).mul_scalar(collision_weight)
    }

    /// The seven values, in the order of [`PrintReport::final_losses`], or
    /// [`FieldError::Diverged`] at `step`.
    fn values(&self, step: usize) -> Result<[f32; 7]> {
        loss_values(
            [
                &self.support_free,
                &self.base,
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

/// Evaluates the printing losses of `g` at the poses `poses` and the surface samples
/// `surface` (indices into the problem's) and at every base sample, with the nozzle's rings
/// rotated by `phase`.
///
/// The nozzle points `q = x + a d + u e1 + v e2` follow the build direction `d(x)` as
/// tensors; which of them are inside the part is decided on the host (the indicator of
/// Eq. 9 has no gradient); those enter Eq. 13 as `ReLU(k (ε - (G(q) - G(x))))`, through
/// both `G(q)` and `q`.
///
/// Errors: [`FieldError::InvalidArgument`] for an empty or out-of-range index list,
/// [`FieldError::InvalidConfig`] for bad constants, [`FieldError::NonFinite`] if the part's
/// distance is not finite at a nozzle point.
pub fn print_losses(
    g: &Siren,
    problem: &PrintProblem<'_>,
    poses: &[usize],
    surface: &[usize],
    phase: f64,
    constants: &PrintConstants,
) -> Result<PrintLosses> {
    constants.validate()?;
    check_indices("pose", poses, problem.poses.len())?;
    check_indices("surface sample", surface, problem.surface.len())?;
    let device = device_of(g);

    // Functional losses (Eq. 30, 31): gradients only.
    let s_unit = problem.unit_tensor(surface.iter().map(|&i| problem.surface[i]), &device);
    let ns: Vec<f32> = surface.iter().flat_map(|&i| problem.normals[i].iter().map(|&c| c as f32)).collect();
    let ns = Tensor::<2>::from_data(TensorData::new(ns, [surface.len(), 3]), &device);
    let support_free = support_free_loss(
        g.forward_gradient(s_unit).gradient,
        ns,
        constants.effective_overhang_deg(),
        constants.support_factor,
    );
    let base = if problem.base.is_empty() {
        Tensor::<1>::zeros([1], &device)
    } else {
        let b_unit = problem.unit_tensor(problem.base.iter().copied(), &device);
        base_loss(g.forward_gradient(b_unit).gradient, [0.0, 0.0, 1.0], constants.base_factor)
    };
    let low = first_layer_points(problem, constants.first_layers);
    let base = if low.is_empty() {
        base
    } else {
        let rings: Vec<(f64, f64)> =
            problem.nozzle.points(0.0).iter().map(|q| (q[0], q[1].hypot(q[2]))).collect();
        let cos: Vec<f64> = low
            .iter()
            .map(|p| platform_tilt_cos(p.z - problem.platform, &rings, constants.platform_clearance))
            .collect();
        let unit = problem.unit_tensor(low.into_iter(), &device);
        base + first_layers_loss(g.forward_gradient(unit).gradient, &cos, constants.first_layers_factor)
    };
    let terms = nozzle_terms(g, problem, poses, phase, constants)?;
    Ok(PrintLosses {
        support_free,
        base,
        collision: terms.collision,
        platform: terms.platform,
        spacing: terms.spacing,
        zero_gradient: terms.zero_gradient,
        curvature: terms.curvature,
        colliding_poses: terms.colliding_poses,
    })
}

/// The first layers' loss on a batch: `factor · mean ReLU(c_i - d_z)` with
/// `d = ∇G/|∇G|` from `gradient` `[n, 3]` and `cos_limit` the `n` cosines `c_i` of the
/// largest tilt of the layers off the platform (normal `+z`) at each point: zero where no
/// layer tilts more than its point allows.
pub fn first_layers_loss(gradient: Tensor<2>, cos_limit: &[f64], factor: f64) -> Tensor<1> {
    let n = gradient.dims()[0];
    let device = gradient.device();
    let c: Vec<f32> = cos_limit.iter().map(|&c| c as f32).collect();
    let c = Tensor::<2>::from_data(TensorData::new(c, [n, 1]), &device);
    let dz = layer_normal(gradient).narrow(1, 2, 1);
    (c - dz).clamp_min(0.0).mean().mul_scalar(factor)
}

/// The cosine of the largest tilt `φ` in `[0°, 90°]` of a nozzle whose tip is `h` above
/// the platform and whose points lie at `(axial, radius)` in `rings`, at which every point
/// stays `clearance` above it (Eq. 35 for the worst ring phase):
/// `h + a cos φ - r sin φ >= clearance`, i.e. `φ <= acos((clearance - h) / R) - β` with
/// `R = |(a, r)|`, `β = atan2(r, a)`.
fn platform_tilt_cos(h: f64, rings: &[(f64, f64)], clearance: f64) -> f64 {
    let mut phi = FRAC_PI_2;
    for &(a, r) in rings {
        let big = a.hypot(r);
        if big <= 0.0 {
            continue;
        }
        let k = (clearance - h) / big;
        let limit = if k <= -1.0 { FRAC_PI_2 } else { k.min(1.0).acos() - r.atan2(a) };
        phi = phi.min(limit.max(0.0));
    }
    phi.cos()
}

/// Where the first layers are held flat ([`PrintConstants::first_layers`]): the base
/// samples lifted by every half unit up to `band` above the platform and the surface
/// samples below `band` moved half a unit inward, where they are inside the part, and the
/// poses below `band`.
fn first_layer_points(problem: &PrintProblem<'_>, band: f64) -> Vec<Point3> {
    let steps = (band / 0.5).floor() as usize;
    let lifted =
        problem.base.iter().flat_map(|b| (1..=steps).map(move |k| b + Vector3::z() * (0.5 * k as f64)));
    // The skin near the platform, half a unit in (where the part flares out over it).
    let skin = problem.surface.iter().zip(&problem.normals).filter(|(p, _)| p.z - problem.platform < band);
    let skin = skin.map(|(p, n)| p - n * 0.5);
    let low = problem.poses.iter().filter(|p| p.z - problem.platform < band).copied();
    lifted
        .chain(skin)
        .filter(|p| p.z > problem.platform && problem.part.distance(p) < 0.0)
        .chain(low)
        .collect()
}

/// Refuses an empty index list or an index `>= len` into the problem's `what`s.
pub(crate) fn check_indices(what: &str, idx: &[usize], len: usize) -> Result<()> {
    if idx.is_empty() {
        return Err(FieldError::InvalidArgument(format!("no {what} selected")));
    }
    if let Some(&i) = idx.iter().find(|&&i| i >= len) {
        return Err(FieldError::InvalidArgument(format!("{what} index {i} out of range")));
    }
    Ok(())
}

/// The losses of a printing layer field that live at the deposition poses, shared by the
/// support-free (Eq. 37) and the direction-aligned (Eq. 38, [`crate::dac_losses`]) totals.
pub(crate) struct NozzleTerms {
    /// `G`, `∇G` and `∇²G` at the poses (unit-cube coordinates).
    pub(crate) field: FieldHessian,
    /// Nozzle-part collision (Eq. 13).
    pub(crate) collision: Tensor<1>,
    /// Nozzle-platform collision (Eq. 36).
    pub(crate) platform: Tensor<1>,
    /// Layer spacing (Eq. 26).
    pub(crate) spacing: Tensor<1>,
    /// Zero gradient (Eq. 27).
    pub(crate) zero_gradient: Tensor<1>,
    /// Curvature (Eq. 24) with the singularity mask.
    pub(crate) curvature: Tensor<1>,
    /// The poses (indices into the problem's) with a positive collision term (either).
    pub(crate) colliding_poses: Vec<usize>,
}

/// The layer regularisers (Eq. 26, 27, 24) of `g` at the poses `poses` (indices into the
/// problem's, checked) and the collision of the nozzle along the build direction with
/// printed material (Eq. 8, 13) and with the platform (Eq. 35-36), the nozzle's rings
/// rotated by `phase` (see [`print_losses`]). `constants` are not validated here.
pub(crate) fn nozzle_terms(
    g: &Siren,
    problem: &PrintProblem<'_>,
    poses: &[usize],
    phase: f64,
    constants: &PrintConstants,
) -> Result<NozzleTerms> {
    check_indices("pose", poses, problem.poses.len())?;
    let device = device_of(g);
    let scale = problem.normalization.scale;
    let lc = &constants.layer;

    // Regularisers at the poses (Eq. 26, 27, 24).
    let n = poses.len();
    let x_unit = problem.unit_tensor(poses.iter().map(|&i| problem.poses[i]), &device);
    let xw: Vec<f32> = poses.iter().flat_map(|&i| problem.poses[i].iter().map(|&c| c as f32)).collect();
    let x_world = Tensor::<2>::from_data(TensorData::new(xw, [n, 3]), &device);
    let out = g.forward_hessian(x_unit);
    let geo = LayerGeometry::new(out.gradient.clone(), out.hessian.clone());
    let (spacing, zero_gradient, curvature) = regularisers(&out, &geo, scale, lc);

    // The nozzle along the build direction (Eq. 8, 13, 35, 36).
    let (q, t) = tool_points(x_world, geo.normal.clone(), &problem.nozzle, phase);
    let m = n * t;
    let q_host = host_values(q.clone().detach())?;
    let eps_p = constants.platform_clearance;
    let (mut inside_rows, mut low_rows) = (Vec::new(), Vec::new());
    let mut hit = vec![false; n];
    for (k, c) in q_host.chunks_exact(3).enumerate() {
        let p = Point3::new(c[0] as f64, c[1] as f64, c[2] as f64);
        let d = problem.part.distance(&p);
        if !d.is_finite() {
            return Err(FieldError::NonFinite { what: "part distance at a nozzle point", index: k });
        }
        if d < 0.0 {
            inside_rows.push(k);
        }
        if p.z - problem.platform < eps_p {
            low_rows.push(k as i64);
            hit[k / t] = true;
        }
    }
    let (collision, active) = layer_collision(
        g,
        &problem.normalization,
        q.clone(),
        out.value.clone(),
        &inside_rows,
        t,
        m,
        phase,
        lc,
    )?;
    for k in active {
        hit[k] = true;
    }
    let platform = if low_rows.is_empty() {
        Tensor::<1>::zeros([1], &device)
    } else {
        let a = low_rows.len();
        let rows = Tensor::<1, Int>::from_data(TensorData::new(low_rows, [a]), &device);
        // Eq. 35-36: ReLU(k (ε - (q - p0)·n_p)) with n_p = +z, in unit-cube lengths.
        q.select(0, rows)
            .narrow(1, 2, 1)
            .neg()
            .add_scalar(problem.platform + eps_p)
            .mul_scalar(scale * lc.collision_slope)
            .clamp_min(0.0)
            .sum()
            .div_scalar(m as f64)
    };
    let colliding_poses = poses.iter().zip(&hit).filter(|(_, h)| **h).map(|(&i, _)| i).collect();
    Ok(NozzleTerms { field: out, collision, platform, spacing, zero_gradient, curvature, colliding_poses })
}

/// How [`pretrain_planar_print`] and [`optimize_print_layers`] run.
#[derive(Debug, Clone, PartialEq)]
pub struct PrintOptions {
    /// The layer field's network. Default: 3 sine layers of 64, `ω0 = 5`, `ω = 30`.
    pub network: SirenConfig,
    /// Adam steps fitting `G = ẑ` (planar layers). Default `300`.
    pub pretrain_steps: usize,
    /// The pretraining's layers lean this many degrees from `+z` toward `+x` (`G = d̂·x̂`
    /// with `d̂ = (sin β, 0, cos β)`): an asymmetric start, from which a part whose two
    /// halves would build toward each other (an arch) is built from one side over the
    /// top. Default `0` (planar layers), in `(-90, 90)`.
    pub pretrain_lean_deg: f64,
    /// Adam steps on Eq. 37. Default `300`.
    pub steps: usize,
    /// Poses per step. Default `128`.
    pub batch_size: usize,
    /// Surface samples per step. Default `256`.
    pub surface_batch: usize,
    /// Adam's learning rate. Default `2e-4`.
    pub learning_rate: f64,
    /// Loss weights. Default [`PrintWeights::default`] (Table 1's SCF row).
    pub weights: PrintWeights,
    /// Constants of the individual losses. Default [`PrintConstants::default`].
    pub constants: PrintConstants,
    /// Seed of the batches and the ring phases. Default `0`.
    pub seed: u64,
    /// The Burn backend. Default [`Backend::default`].
    pub backend: Backend,
}

impl Default for PrintOptions {
    fn default() -> Self {
        Self {
            network: SirenConfig { sine_layers: 3, width: 64, first_omega: 5.0, hidden_omega: 30.0, seed: 0 },
            pretrain_steps: 300,
            pretrain_lean_deg: 0.0,
            steps: 300,
            batch_size: 128,
            surface_batch: 256,
            learning_rate: 2e-4,
            weights: PrintWeights::default(),
            constants: PrintConstants::default(),
            seed: 0,
            backend: Backend::default(),
        }
    }
}

impl PrintOptions {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        self.network.validate()?;
        self.constants.validate()?;
        if self.batch_size == 0 {
            return Err(FieldError::config("batch_size", "must be at least 1"));
        }
        if self.surface_batch == 0 {
            return Err(FieldError::config("surface_batch", "must be at least 1"));
        }
        FieldError::check_positive(&[("learning_rate", self.learning_rate)])?;
        if self.pretrain_lean_deg.is_nan() || self.pretrain_lean_deg.abs() >= 90.0 {
            return Err(FieldError::config("pretrain_lean_deg", "must be in (-90, 90)"));
        }
        let w = self.weights;
        FieldError::check_non_negative(&[
            ("weights.spacing", w.spacing),
            ("weights.curvature", w.curvature),
            ("weights.zero_gradient", w.zero_gradient),
            ("weights.support_free", w.support_free),
            ("weights.base", w.base),
            ("weights.collision_start", w.collision_start),
            ("weights.collision_end", w.collision_end),
        ])
    }
}

/// Planar layers (`G = ẑ`, build direction `+z` everywhere; leaning toward `+x` by
/// [`PrintOptions::pretrain_lean_deg`]) for printing: a new network of `options.network`
/// fitted as [`pretrain_planar`](crate::pretrain_planar) does, on an autodiff device.
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::Diverged`].
pub fn pretrain_planar_print(options: &PrintOptions) -> Result<Siren> {
    options.validate()?;
    let (s, c) = options.pretrain_lean_deg.to_radians().sin_cos();
    fit_planar_along(&options.network, options.pretrain_steps, options.seed, options.backend, [s, 0.0, c])
}

/// What [`optimize_print_layers`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct PrintReport {
    /// Adam steps taken.
    pub steps: usize,
    /// Unweighted losses of the last step: support-free, base, collision, platform,
    /// spacing, zero gradient, curvature.
    pub final_losses: [f32; 7],
    /// Wall-clock seconds of the optimisation.
    pub seconds: f64,
}

/// Optimises the layer field `g` (on an autodiff device, e.g. from
/// [`pretrain_planar_print`]) by Adam on Eq. 37 over `problem`'s samples, the collision
/// weight rising linearly from `weights.collision_start` to `weights.collision_end`.
/// Each step takes `batch_size` poses (up to half of them among those whose nozzle last
/// collided, the rest from shuffled passes), `surface_batch` surface samples (shuffled
/// passes) and every base sample.
///
/// Deterministic for fixed options (single-threaded backend, seeded batches and phases).
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::Diverged`],
/// [`FieldError::NonFinite`] if the part's distance is not finite at a nozzle point.
pub fn optimize_print_layers(
    g: Siren,
    problem: &PrintProblem<'_>,
    options: &PrintOptions,
) -> Result<(Siren, PrintReport)> {
    options.validate()?;
    let start = Instant::now();
    let mut opt = AdamConfig::new().init();
    let mut poses = Batcher::new(problem.poses.len(), options.seed);
    let mut surface = Batcher::new(problem.surface.len(), options.seed ^ 0x5355_5246);
    let mut log = LossLog::new();
    let (mut pidx, mut sidx) = (Vec::new(), Vec::new());
    let g = train(g, &mut opt, options.learning_rate, options.steps, &mut log, |g, step| {
        poses.batch(options.batch_size, &[], &mut pidx);
        surface.batch(options.surface_batch, &[], &mut sidx);
        let phase = poses.rng.uniform(0.0, std::f64::consts::TAU);
        let losses = print_losses(g, problem, &pidx, &sidx, phase, &options.constants)?;
        let total = losses.total(&options.weights, options.weights.collision_at(step, options.steps));
        let values = losses.values(step)?;
        poses.update(&pidx, &losses.colliding_poses);
        Ok((total, values))
    })?;
    let report =
        PrintReport { steps: log.steps, final_losses: log.last, seconds: start.elapsed().as_secs_f64() };
    Ok((g, report))
}

/// Overhang measures of a layer field over a problem's surface samples (the base left
/// out).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OverhangStats {
    /// Surface samples measured.
    pub samples: usize,
    /// The largest overhang angle, degrees ([`overhang_angle`] with the layer normal).
    pub max_deg: f64,
    /// The mean overhang angle, degrees.
    pub mean_deg: f64,
    /// Samples whose overhang exceeds the threshold.
    pub over: usize,
    /// `over / samples`.
    pub fraction_over: f64,
    /// The threshold, degrees.
    pub threshold_deg: f64,
}

/// The overhang angle at every surface sample of `problem` under the build direction of
/// `g` (evaluated on the host in `f64`), in the problem's order.
pub fn overhang_angles(g: &SirenF64, problem: &PrintProblem<'_>) -> Vec<f64> {
    problem
        .surface
        .iter()
        .zip(&problem.normals)
        .map(|(p, n)| overhang_angle(n, &problem.build_direction(g, p).1))
        .collect()
}

/// The largest overhang, the mean and the samples beyond `threshold_deg` (e.g. the
/// self-supporting angle, 45°) of [`overhang_angles`].
///
/// Errors: [`FieldError::InvalidArgument`] for a threshold outside `[0, 90]`.
pub fn overhang_stats(g: &SirenF64, problem: &PrintProblem<'_>, threshold_deg: f64) -> Result<OverhangStats> {
    if !(0.0..=90.0).contains(&threshold_deg) {
        return Err(FieldError::InvalidArgument(format!(
            "overhang threshold {threshold_deg} not in [0, 90]"
        )));
    }
    let angles = overhang_angles(g, problem);
    let samples = angles.len();
    let over = angles.iter().filter(|&&a| a > threshold_deg).count();
    Ok(OverhangStats {
        samples,
        max_deg: angles.iter().copied().fold(0.0, f64::max),
        mean_deg: angles.iter().sum::<f64>() / samples as f64,
        over,
        fraction_over: over as f64 / samples as f64,
        threshold_deg,
    })
}

/// Counts of sampled nozzle poses in collision.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PrintCollisionCount {
    /// Poses evaluated.
    pub poses: usize,
    /// Poses with a nozzle point in printed material: inside the part on a layer
    /// `G(q) < G(x)` (Eq. 8).
    pub part: usize,
    /// Poses with a nozzle point below the platform (Eq. 35).
    pub platform: usize,
}

/// Counts the poses of `problem` whose nozzle, placed along the build direction of `g`
/// (evaluated on the host in `f64`) and sampled by `nozzle` (may be denser than the
/// problem's own), has a point in printed material or below the platform; with the indices
/// of the colliding poses, ascending. Poses where `∇G = 0` count as colliding with both.
///
/// Errors: [`FieldError::InvalidConfig`] for a bad nozzle.
pub fn print_collisions(
    g: &SirenF64,
    problem: &PrintProblem<'_>,
    nozzle: &Tool,
) -> Result<(PrintCollisionCount, Vec<usize>)> {
    nozzle.validate()?;
    let local = nozzle.points(0.0);
    let nz = &problem.normalization;
    let mut out = PrintCollisionCount { poses: problem.poses.len(), part: 0, platform: 0 };
    let mut bad = Vec::new();
    for (i, x) in problem.poses.iter().enumerate() {
        let (gx, grad) = problem.build_direction(g, x);
        let Some(d) = grad.try_normalize(1e-12) else {
            out.part += 1;
            out.platform += 1;
            bad.push(i);
            continue;
        };
        let (mut hit_part, mut hit_platform) = (false, false);
        for q in place_tool(x, &d, &local) {
            hit_platform |= q.z < problem.platform;
            if !hit_part && problem.part.distance(&q) < 0.0 {
                let u = nz.to_unit(&q);
                hit_part = g.value([u.x, u.y, u.z]) < gx;
            }
            if hit_part && hit_platform {
                break;
            }
        }
        out.part += hit_part as usize;
        out.platform += hit_platform as usize;
        if hit_part || hit_platform {
            bad.push(i);
        }
    }
    Ok((out, bad))
}

/// A round arm standing on the platform `z = 0` and bending over: a tube of radius
/// `radius` (`around` facets) along a centreline that rises from the origin along `+Z` for
/// `column`, bends towards `+X` on a circular arc of radius `bend_radius` through
/// `bend_deg` degrees (`along` segments), then runs straight for `arm`; flat caps at both
/// ends (the bottom one is the base).
///
/// Planar layers (build direction `+Z`) leave the underside of the straight part
/// overhanging by exactly `bend_deg` (one facet row faces straight down-outwards there);
/// layers that turn with the arm print it without support.
///
/// Errors: [`FieldError::InvalidArgument`] unless every length is finite and `> 0`,
/// `radius < bend_radius`, `0 < bend_deg < 180`, `around >= 3` and `along >= 1` (both at
/// most 100 000).
pub fn bent_arm_mesh(
    radius: f64,
    column: f64,
    bend_radius: f64,
    bend_deg: f64,
    arm: f64,
    around: usize,
    along: usize,
) -> Result<Mesh> {
    let ok = [radius, column, bend_radius, bend_deg, arm].iter().all(|v| v.is_finite() && *v > 0.0)
        && radius < bend_radius
        && bend_deg < 180.0
        && (3..=100_000).contains(&around)
        && (1..=100_000).contains(&along);
    if !ok {
        return Err(FieldError::InvalidArgument("bent arm dimensions out of range".into()));
    }
    let gamma = bend_deg.to_radians();
    // Centreline frames (centre, tangent angle t from +Z towards +X); the cross-section's
    // e1 = (cos t, 0, -sin t) points to the bend's centre (the underside once bent), e2 = Y.
    let mut frames: Vec<(Point3, f64)> = vec![(Point3::origin(), 0.0)];
    for s in 0..=along {
        let t = gamma * s as f64 / along as f64;
        let c = Point3::new(bend_radius * (1.0 - t.cos()), 0.0, column + bend_radius * t.sin());
        frames.push((c, t));
    }
    let (end, _) = frames[frames.len() - 1];
    frames.push((end + Vector3::new(gamma.sin(), 0.0, gamma.cos()) * arm, gamma));
    let mut vertices = Vec::with_capacity(frames.len() * around + 2);
    for (c, t) in &frames {
        let e1 = Vector3::new(t.cos(), 0.0, -t.sin());
        for k in 0..around {
            // Half-step offset: the facet between the last and the first vertex faces e1.
            let phi = std::f64::consts::TAU * (k as f64 + 0.5) / around as f64;
            vertices.push(c + (e1 * phi.cos() + Vector3::y() * phi.sin()) * radius);
        }
    }
    let rings = frames.len();
    let (bottom, top) = (vertices.len() as u32, vertices.len() as u32 + 1);
    vertices.push(frames[0].0);
    vertices.push(frames[rings - 1].0);
    let ring = |i: usize, k: usize| (i * around + k % around) as u32;
    let mut tris = Vec::with_capacity(2 * rings * around);
    for k in 0..around {
        tris.push([bottom, ring(0, k + 1), ring(0, k)]);
        for i in 0..rings - 1 {
            let (a, b, c, d) = (ring(i, k), ring(i, k + 1), ring(i + 1, k), ring(i + 1, k + 1));
            tris.push([a, b, d]);
            tris.push([a, d, c]);
        }
        tris.push([top, ring(rings - 1, k), ring(rings - 1, k + 1)]);
    }
    let mesh = Mesh::new(vertices, tris).map_err(FieldError::geom)?;
    Ok(if mesh.signed_volume() < 0.0 { mesh.flipped() } else { mesh })
}

#[cfg(test)]
mod tests {
    use super::*;
    use s2g_geom::Sphere;

    /// `G = cos(8x) + k z` (one sine layer of two: `sin(8x + π/2)` and `sin(0.001 z)`, read
    /// out with weights `1` and `1000 k`; the second term is `k z` within 2e-7 on the
    /// unit cube); `cos = false` drops the first term (planar layers).
    fn bowl(k: f32, cos: bool) -> Siren {
        let w0 = vec![8.0, 0.0, 0.0, 0.0, 0.0, 0.001];
        let b0 = vec![std::f32::consts::FRAC_PI_2, 0.0];
        let w1 = vec![if cos { 1.0 } else { 0.0 }, 1000.0 * k];
        let device = Backend::default().device();
        Siren::from_weights(&[3, 2, 1], vec![(w0, b0), (w1, vec![0.0])], 1.0, 30.0, &device)
    }

    /// The first layers' tilt limit agrees with a scan of the tilt: the largest `φ` (0.01°
    /// steps) at which every ring point of a nozzle with a wider carriage stays clear.
    #[test]
    fn platform_tilt_limit_matches_a_scan() {
        let rings = [(0.5, 2.5), (4.0, 2.5), (8.0, 10.0), (20.0, 10.0), (3.0, 0.0)];
        let clear = |h: f64, phi: f64| rings.iter().all(|&(a, r)| h + a * phi.cos() - r * phi.sin() >= 0.5);
        for h in [0.0, 0.3, 0.5, 0.8, 1.2, 2.0, 3.0, 5.0, 12.0] {
            let scan = (0..=9000).map(|k| (k as f64 * 0.01).to_radians()).take_while(|&p| clear(h, p)).last();
            let expected = scan.map_or(1.0, f64::cos);
            let got = platform_tilt_cos(h, &rings, 0.5);
            assert!((got.acos() - expected.acos()).to_degrees().abs() < 0.02, "h {h}: {got} vs {expected}");
        }
        // Flat at the platform for the bare nozzle, free from its radius up.
        assert!(platform_tilt_cos(3.5, &[(0.5, 2.5)], 0.5).abs() < 1e-12);
        assert!(platform_tilt_cos(0.5, &[(0.5, 2.5)], 0.5) > 0.98);
    }

    /// Layers curving up into a bowl around `x = 0` (`G = cos 8x + z/2`): a nozzle of
    /// radius 0.3 along `+z` at the origin has ring points at `x = ±0.3` on layers already
    /// printed (`cos 2.4 + 0.025 < 1`) inside the part, so Eq. 13 is positive and the pose
    /// counts as colliding; planar layers (`G = z/2`) are clear.
    #[test]
    fn ring_points_on_printed_layers_collide() {
        let ball = Sphere { center: Point3::origin(), radius: 10.0 };
        let bounds = Aabb::new(Point3::new(-0.5, -0.5, -0.5), Point3::new(0.5, 0.5, 0.5));
        let samples = PrintSamples {
            poses: vec![Point3::origin()],
            surface: vec![Point3::new(0.5, 0.0, 0.0)],
            normals: vec![Vector3::x()],
            base: vec![],
        };
        let nozzle = Tool { axial_offset: 0.05, axial_step: 0.1, ring_points: 8, ..Tool::cylinder(0.3, 0.5) };
        let problem = PrintProblem::with_samples(&ball, nozzle, bounds, -100.0, samples).unwrap();
        let constants = PrintConstants::default();
        let value = |t: Tensor<1>| -> f32 { t.into_scalar() };

        let g = bowl(0.5, true);
        let host = g.to_f64().unwrap();
        let (v, grad) = host.value_gradient([0.0, 0.0, 0.0]);
        assert!((v - 1.0).abs() < 1e-6 && grad[0].abs() < 1e-6 && (grad[2] - 0.5).abs() < 1e-6);
        let losses = print_losses(&g, &problem, &[0], &[0], 0.0, &constants).unwrap();
        assert!(value(losses.collision) > 0.0);
        assert_eq!(losses.colliding_poses, vec![0]);
        assert_eq!(value(losses.platform), 0.0);
        let (count, bad) = print_collisions(&host, &problem, &nozzle).unwrap();
        assert_eq!((count.part, count.platform, bad), (1, 0, vec![0]));

        let flat = bowl(0.5, false);
        let losses = print_losses(&flat, &problem, &[0], &[0], 0.0, &constants).unwrap();
        assert_eq!(value(losses.collision), 0.0);
        assert!(losses.colliding_poses.is_empty());
        assert_eq!(print_collisions(&flat.to_f64().unwrap(), &problem, &nozzle).unwrap().0.part, 0);
    }
}
