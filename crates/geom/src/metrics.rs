//! Shape metrics between two meshes, as Shape2Gcode evaluates (seed 000, §4.3, following
//! CNC-Net's evaluation code): IoU and F1 of voxel-centre occupancies of the unit cube at
//! 256^3, symmetric Chamfer distance (×1000) on 8,000 area-weighted surface samples per
//! mesh, and normal consistency of those samples.

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::error::{GeomError, Result};
use crate::math::Real;
use crate::mesh::Mesh;
use crate::sample::{SurfaceSamples, sample_surface};
use crate::voxel::{GridSpec, VoxelGrid};
use crate::voxelize::voxelize;

/// Options of [`compare`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricOptions {
    /// Voxels per axis of the occupancy grid (default 256, the papers' value).
    pub resolution: usize,
    /// Surface samples per mesh for Chamfer distance and normal consistency (default 8000).
    pub samples: usize,
    /// Seed of the surface sampling (default 0); both meshes use the same seed.
    pub seed: u64,
    /// The box the occupancy grid covers (default the unit cube `[-0.5, 0.5]^3`).
    pub bounds: Aabb,
}

impl Default for MetricOptions {
    fn default() -> Self {
        Self { resolution: 256, samples: 8000, seed: 0, bounds: Aabb::unit_cube() }
    }
}

/// The metrics of one comparison (see [`compare`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapeMetrics {
    /// Intersection over union of the occupancies, in `[0, 1]`.
    pub iou: Real,
    /// F1 score of the occupancies, `2 |A ∩ B| / (|A| + |B|)`, in `[0, 1]`.
    pub f1: Real,
    /// Symmetric Chamfer distance ×1000: the mean squared distance from each sample of one
    /// mesh to the nearest sample of the other, both directions summed, times 1000.
    pub chamfer_x1000: Real,
    /// Mean absolute cosine between each sample's normal and its nearest neighbour's in the
    /// other set, averaged over both directions, in `[0, 1]`.
    pub normal_consistency: Real,
}

/// Compares mesh `a` with mesh `b` (usually the reference): occupancies by
/// [`voxelize`] on `GridSpec::new(bounds, [resolution; 3])` (voxel-centre rule), then
/// [`occupancy_iou`]; surface samples by [`sample_surface`] with `samples` and `seed`, then
/// [`chamfer_and_normals`]. The same inputs and options give bit-identical results.
///
/// Errors: [`GeomError::EmptyMesh`] when a mesh has no triangles,
/// [`GeomError::InvalidArgument`] for a zero resolution, zero samples, an invalid box or a
/// mesh of zero area, and whatever [`voxelize`] reports.
pub fn compare(a: &Mesh, b: &Mesh, opts: &MetricOptions) -> Result<ShapeMetrics> {
    if a.is_empty() || b.is_empty() {
        return Err(GeomError::EmptyMesh);
    }
    if opts.samples == 0 {
        return Err(GeomError::InvalidArgument("compare needs at least one surface sample".into()));
    }
    let spec = GridSpec::new(&opts.bounds, [opts.resolution; 3])?;
    let ((va, vb), (sa, sb)) = rayon::join(
        || rayon::join(|| voxelize(a, &spec), || voxelize(b, &spec)),
        || {
            rayon::join(
                || sample_surface(a, opts.samples, opts.seed),
                || sample_surface(b, opts.samples, opts.seed),
            )
        },
    );
    let (iou, f1) = occupancy_iou(&va?, &vb?)?;
    let (chamfer_x1000, normal_consistency) = chamfer_and_normals(&sa?, &sb?)?;
    Ok(ShapeMetrics { iou, f1, chamfer_x1000, normal_consistency })
}

/// IoU `|A ∩ B| / |A ∪ B|` and F1 `2 |A ∩ B| / (|A| + |B|)` of two occupancy grids over the
/// same spec. Two empty grids agree perfectly: `(1, 1)`.
///
/// Errors: [`GeomError::GridMismatch`] when the grids' specs differ.
pub fn occupancy_iou(a: &VoxelGrid, b: &VoxelGrid) -> Result<(Real, Real)> {
    let inter = a.count_and(b)? as Real;
    let (na, nb) = (a.count() as Real, b.count() as Real);
    if na + nb == 0.0 {
        return Ok((1.0, 1.0));
    }
    Ok((inter / (na + nb - inter), 2.0 * inter / (na + nb)))
}

/// Symmetric Chamfer distance ×1000 and normal consistency of two sample sets (see
/// [`ShapeMetrics`] for the definitions), with nearest neighbours from a kd-tree (kiddo).
/// Returns `(chamfer_x1000, normal_consistency)`. Sums are taken in sample order, so the
/// result does not depend on the number of threads.
///
/// Errors: [`GeomError::InvalidArgument`] when either set is empty or a point is not finite.
pub fn chamfer_and_normals(sa: &SurfaceSamples, sb: &SurfaceSamples) -> Result<(Real, Real)> {
    let (ab_d, ab_n) = one_way(sa, sb)?;
    let (ba_d, ba_n) = one_way(sb, sa)?;
    Ok((1000.0 * (ab_d + ba_d), 0.5 * (ab_n + ba_n)))
}

/// Mean squared nearest distance from `from` to `to`, and the mean |cos| of the normals.
fn one_way(from: &SurfaceSamples, to: &SurfaceSamples) -> Result<(Real, Real)> {
    if from.is_empty() || to.is_empty() {
        return Err(GeomError::InvalidArgument("chamfer distance needs non-empty sample sets".into()));
    }
    if from.normals.len() != from.len() || to.normals.len() != to.len() {
        return Err(GeomError::InvalidArgument("samples and normals differ in number".into()));
    }
    let finite = |s: &SurfaceSamples| s.points.iter().all(|p| p.iter().all(|c| c.is_finite()));
    if !finite(from) || !finite(to) {
        return Err(GeomError::InvalidArgument("non-finite sample point".into()));
    }
    let pts: Vec<[Real; 3]> = to.points.iter().map(|p| [p.x, p.y, p.z]).collect();
    let tree: ImmutableKdTree<Real, 3> = ImmutableKdTree::new_from_slice(&pts)
        .map_err(|e| GeomError::InvalidArgument(format!("kd-tree construction: {e}")))?;
    let per: Vec<(Real, Real)> = from
        .points
        .par_iter()
        .zip(from.normals.par_iter())
        .map(|(p, n)| {
            let nn = tree.query(&[p.x, p.y, p.z]).nearest_one::<SquaredEuclidean<Real>>().execute();
            (nn.distance, n.dot(&to.normals[nn.item as usize]).abs())
        })
        .collect();
    let k = per.len() as Real;
    let (d, c) = per.iter().fold((0.0, 0.0), |(d, c), &(dd, cc)| (d + dd, c + cc));
    Ok((d / k, c / k))
}
