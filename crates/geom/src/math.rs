//! The geometry vocabulary: nalgebra types in f64.

/// Scalar type of all geometry.
pub type Real = f64;
/// A point in 3-D.
pub type Point3 = nalgebra::Point3<Real>;
/// A vector in 3-D.
pub type Vector3 = nalgebra::Vector3<Real>;
/// A unit vector in 3-D.
pub type UnitVector3 = nalgebra::Unit<Vector3>;
/// A rigid transform.
pub type Isometry3 = nalgebra::Isometry3<Real>;
/// A rotation.
pub type Rotation3 = nalgebra::UnitQuaternion<Real>;
/// A similarity (uniform scale, rotation, translation).
pub type Similarity3 = nalgebra::Similarity3<Real>;

/// SplitMix64 (Steele, Lea and Flood 2014): a tiny seeded generator that can be cloned with
/// what holds it (rand's `StdRng` cannot), so a copy goes on drawing the same stream. For
/// sampling in baselines and tests, not for anything secret.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`, 53 bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}
