//! The [`SignedDistance`] trait: the one way the rest of the workspace asks "how far from the surface?".

use crate::math::{Point3, Real, Vector3};

/// A signed distance field: negative inside, positive outside, zero on the surface.
///
/// Only [`SignedDistance::distance`] is required; [`SignedDistance::gradient`] defaults
/// to central differences and [`SignedDistance::contains`] to the sign.
pub trait SignedDistance: Sync {
    /// Signed distance at `p`.
    fn distance(&self, p: &Point3) -> Real;

    /// Gradient of the distance at `p` (unit length for a true SDF).
    fn gradient(&self, p: &Point3) -> Vector3 {
        let h = 1e-6;
        let mut g = Vector3::zeros();
        for i in 0..3 {
            let mut a = *p;
            let mut b = *p;
            a[i] += h;
            b[i] -= h;
            g[i] = (self.distance(&a) - self.distance(&b)) / (2.0 * h);
        }
        g
    }

    /// Whether `p` is inside (distance below zero).
    fn contains(&self, p: &Point3) -> bool {
        self.distance(p) < 0.0
    }
}

impl<T: SignedDistance + ?Sized> SignedDistance for &T {
    fn distance(&self, p: &Point3) -> Real {
        (**self).distance(p)
    }
    fn gradient(&self, p: &Point3) -> Vector3 {
        (**self).gradient(p)
    }
    fn contains(&self, p: &Point3) -> bool {
        (**self).contains(p)
    }
}

/// A sphere, for tests and examples.
#[derive(Debug, Clone, Copy)]
pub struct Sphere {
    /// Centre.
    pub center: Point3,
    /// Radius.
    pub radius: Real,
}

impl SignedDistance for Sphere {
    fn distance(&self, p: &Point3) -> Real {
        (p - self.center).norm() - self.radius
    }
    fn gradient(&self, p: &Point3) -> Vector3 {
        (p - self.center).try_normalize(0.0).unwrap_or_else(Vector3::z)
    }
}

/// An axis-aligned box, for tests and examples.
#[derive(Debug, Clone, Copy)]
pub struct BoxShape {
    /// Lower corner.
    pub min: Point3,
    /// Upper corner.
    pub max: Point3,
}

impl SignedDistance for BoxShape {
    fn distance(&self, p: &Point3) -> Real {
        let c = nalgebra::center(&self.min, &self.max);
        let h = (self.max - self.min) * 0.5;
        let q = (p - c).abs() - h;
        let outside = q.sup(&Vector3::zeros()).norm();
        let inside = q.max().min(0.0);
        outside + inside
    }
}
