//! Measuring a signed distance field against a reference on held-out points.

use s2g_geom::{Aabb, Point3, Real, SignedDistance, SurfaceSamples, Vector3};

use crate::error::{FieldError, Result};
use s2g_geom::SplitMix64;

/// How one signed distance field differs from a reference on a set of points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SdfError {
    /// Number of points compared.
    pub points: usize,
    /// Mean of `|a(p) - b(p)|`.
    pub mean_abs: Real,
    /// Root mean square of `a(p) - b(p)`.
    pub rms: Real,
    /// Largest `|a(p) - b(p)|`.
    pub max_abs: Real,
}

/// Compares `field` with `reference` at `points` (in their shared units).
///
/// Errors: [`FieldError::InvalidArgument`] for no points, [`FieldError::NonFinite`] for a
/// non-finite point or a non-finite distance from either field.
pub fn sdf_error(
    field: &dyn SignedDistance,
    reference: &dyn SignedDistance,
    points: &[Point3],
) -> Result<SdfError> {
    if points.is_empty() {
        return Err(FieldError::InvalidArgument("no points to compare at".into()));
    }
    let (mut sum, mut sq, mut max) = (0.0, 0.0, 0.0f64);
    for (i, p) in points.iter().enumerate() {
        if !p.iter().all(|c| c.is_finite()) {
            return Err(FieldError::NonFinite { what: "point", index: i });
        }
        let e = field.distance(p) - reference.distance(p);
        if !e.is_finite() {
            return Err(FieldError::NonFinite { what: "distance difference", index: i });
        }
        sum += e.abs();
        sq += e * e;
        max = max.max(e.abs());
    }
    let n = points.len() as Real;
    Ok(SdfError { points: points.len(), mean_abs: sum / n, rms: (sq / n).sqrt(), max_abs: max })
}

/// Held-out points for [`sdf_error`]: `near` points each a random surface sample moved by
/// a normal-distributed offset of standard deviation `sigma` per axis, and `uniform`
/// points uniform in `bbox`, from `seed` (use a different seed, or different samples, from
/// training to keep them held out).
///
/// Errors: [`FieldError::InvalidArgument`] for near points without samples, a negative or
/// non-finite `sigma`, or an invalid box with uniform points requested.
pub fn validation_points(
    samples: &SurfaceSamples,
    near: usize,
    sigma: Real,
    bbox: &Aabb,
    uniform: usize,
    seed: u64,
) -> Result<Vec<Point3>> {
    if near > 0 && samples.is_empty() {
        return Err(FieldError::InvalidArgument("near-surface points need surface samples".into()));
    }
    if !(sigma.is_finite() && sigma >= 0.0) {
        return Err(FieldError::InvalidArgument(format!("sigma must be finite and >= 0, got {sigma}")));
    }
    let finite = |p: &Point3| p.iter().all(|c| c.is_finite());
    if uniform > 0 && !(finite(&bbox.min) && finite(&bbox.max) && (0..3).all(|a| bbox.min[a] <= bbox.max[a]))
    {
        return Err(FieldError::InvalidArgument("uniform points need a valid, finite box".into()));
    }
    let mut rng = SplitMix64::new(seed, 0x4556_414c);
    let mut out = Vec::with_capacity(near + uniform);
    for _ in 0..near {
        let p = samples.points[rng.below(samples.len())];
        out.push(p + Vector3::new(rng.normal(), rng.normal(), rng.normal()) * sigma);
    }
    for _ in 0..uniform {
        out.push(Point3::new(
            rng.uniform(bbox.min.x, bbox.max.x),
            rng.uniform(bbox.min.y, bbox.max.y),
            rng.uniform(bbox.min.z, bbox.max.z),
        ));
    }
    Ok(out)
}
