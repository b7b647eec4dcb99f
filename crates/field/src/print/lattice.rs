//! Samples of the layer field and the part's signed distance on a lattice over the part's
//! box, read back by trilinear interpolation: the layers' marching cubes run on it, and
//! the collision checks of the program read "printed so far" (inside the part, on a layer
//! below the nozzle's) from it thousands of times per path.

use rayon::prelude::*;
use s2g_geom::{Aabb, Point3, SignedDistance, Vector3};

use super::LayerField;
use crate::error::{FieldError, Result};

/// The lattice: `dims` points from `origin`, `spacing` apart on every axis; values are
/// stored x fastest.
#[derive(Debug, Clone)]
pub(crate) struct Lattice {
    pub(crate) origin: Point3,
    pub(crate) spacing: f64,
    pub(crate) dims: [usize; 3],
    /// The layer field `G` at the lattice points.
    pub(crate) g: Vec<f64>,
    /// The part's signed distance at the lattice points.
    pub(crate) sdf: Vec<f64>,
}

/// Most lattice points (a 0.5 mm lattice over a 100 mm cube is 8 million).
const MAX_POINTS: usize = 16_000_000;

impl Lattice {
    /// Samples `field` and `part` over `bounds` grown by two spacings.
    ///
    /// Errors: [`FieldError::InvalidArgument`] for a bad spacing or box or a lattice of
    /// more than 16 million points; [`FieldError::NonFinite`] where a sample is not finite.
    pub(crate) fn new(
        bounds: &Aabb,
        spacing: f64,
        field: &dyn LayerField,
        part: &dyn SignedDistance,
    ) -> Result<Self> {
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(FieldError::InvalidArgument(format!("bad lattice spacing {spacing}")));
        }
        let b = bounds.inflated(2.0 * spacing);
        let ext = b.max - b.min;
        if !ext.iter().all(|e| e.is_finite() && *e > 0.0) {
            return Err(FieldError::InvalidArgument("the part's box is degenerate or not finite".into()));
        }
        let dims = [0, 1, 2].map(|a| (ext[a] / spacing).ceil() as usize + 1);
        let n = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d)).unwrap_or(usize::MAX);
        if n > MAX_POINTS {
            return Err(FieldError::InvalidArgument(format!(
                "the lattice of {spacing} over the part has {n} points (> {MAX_POINTS})"
            )));
        }
        let origin = b.min;
        let point = |i: usize| {
            let (x, rest) = (i % dims[0], i / dims[0]);
            let (y, z) = (rest % dims[1], rest / dims[1]);
            origin + Vector3::new(x as f64, y as f64, z as f64) * spacing
        };
        let pairs: Vec<(f64, f64)> = (0..n)
            .into_par_iter()
            .map(|i| (field.value_gradient(&point(i)).0, part.distance(&point(i))))
            .collect();
        if let Some(i) = pairs.iter().position(|(g, s)| !(g.is_finite() && s.is_finite())) {
            return Err(FieldError::NonFinite { what: "layer field or distance sample", index: i });
        }
        let (g, sdf) = pairs.into_iter().unzip();
        Ok(Self { origin, spacing, dims, g, sdf })
    }

    /// Trilinear interpolation of `values` at `p`; `outside` beyond the lattice.
    fn interpolate(&self, values: &[f64], p: &Point3, outside: Option<f64>) -> f64 {
        let mut base = [0usize; 3];
        let mut frac = [0.0f64; 3];
        for a in 0..3 {
            let u = (p[a] - self.origin[a]) / self.spacing;
            let top = (self.dims[a] - 1) as f64;
            if let (false, Some(v)) = ((0.0..=top).contains(&u), outside) {
                return v;
            }
            let u = if u.is_finite() { u.clamp(0.0, top) } else { 0.0 };
            let i = (u.floor() as usize).min(self.dims[a].saturating_sub(2));
            base[a] = i;
            frac[a] = (u - i as f64).clamp(0.0, 1.0);
        }
        let [nx, ny, _] = self.dims;
        let at = |x: usize, y: usize, z: usize| {
            let (x, y, z) = (x.min(nx - 1), y.min(ny - 1), z.min(self.dims[2] - 1));
            values[x + nx * (y + ny * z)]
        };
        let mut v = 0.0;
        for corner in 0..8 {
            let (dx, dy, dz) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            let w = [dx, dy, dz]
                .iter()
                .zip(frac)
                .map(|(&d, f)| if d == 1 { f } else { 1.0 - f })
                .product::<f64>();
            if w != 0.0 {
                v += w * at(base[0] + dx, base[1] + dy, base[2] + dz);
            }
        }
        v
    }

    /// The centre of the lattice's box and the radius of the sphere through its corners:
    /// everything the lattice knows of lies inside it.
    pub(crate) fn sphere(&self) -> (Point3, f64) {
        let ext =
            Vector3::new((self.dims[0] - 1) as f64, (self.dims[1] - 1) as f64, (self.dims[2] - 1) as f64)
                * self.spacing;
        (self.origin + ext * 0.5, 0.5 * ext.norm())
    }

    /// The layer field at `p` (clamped to the lattice's box).
    pub(crate) fn g_at(&self, p: &Point3) -> f64 {
        self.interpolate(&self.g, p, None)
    }

    /// The part's signed distance at `p`; positive (outside) beyond the lattice.
    pub(crate) fn sdf_at(&self, p: &Point3) -> f64 {
        self.interpolate(&self.sdf, p, Some(self.spacing))
    }
}
