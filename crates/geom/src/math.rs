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

/// The increment of SplitMix64: 2^64 divided by the golden ratio, odd.
const GOLDEN_GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;

/// SplitMix64's output function for a counter value.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// SplitMix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators",
/// OOPSLA 2014): a 64-bit counter stepped by the golden gamma and passed through a mixer.
/// A tiny seeded generator that can be cloned with what holds it (rand's `StdRng` cannot),
/// so a copy goes on drawing the same stream, and a seed means the same numbers on every
/// platform and for every version of every dependency. For sampling in baselines, training
/// and tests, not for anything secret.
///
/// `SplitMix64(state)` starts from a raw state; [`SplitMix64::new`] derives one from a seed
/// and a stream number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// A generator for `seed`, decorrelated per `stream` so that one user seed can feed
    /// several independent generators: the state `mix64(seed ^ mix64(stream + γ))`.
    pub fn new(seed: u64, stream: u64) -> Self {
        Self(mix64(seed ^ mix64(stream.wrapping_add(GOLDEN_GAMMA))))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(GOLDEN_GAMMA);
        mix64(self.0)
    }

    /// Uniform in `[0, 1)`, 53 bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[0, 1)`, 53 bits: the same draw as [`SplitMix64::unit`].
    pub fn next_f64(&mut self) -> f64 {
        self.unit()
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// A uniform index in `0..n` (`n > 0`), by Lemire's multiply-shift (without the
    /// rejection step: the bias is below `n / 2^64`).
    pub fn below(&mut self, n: usize) -> usize {
        ((self.next_u64() as u128 * n as u128) >> 64) as usize
    }

    /// A standard normal `f64` (Box-Muller; one of the pair is discarded, for simplicity).
    pub fn normal(&mut self) -> f64 {
        // 1 - u lies in (0, 1], so the logarithm is finite.
        let u = 1.0 - self.next_f64();
        let v = self.next_f64();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_state_stream_is_unchanged() {
        // The first outputs of SplitMix64 from state 0 (the reference implementation's).
        let mut r = SplitMix64(0);
        assert_eq!(r.next_u64(), 0xe220_a839_7b1d_cdaf);
        assert_eq!(r.next_u64(), 0x6e78_9e6a_a1b9_65f4);
    }

    #[test]
    fn same_seed_same_stream_and_streams_differ() {
        let mut a = SplitMix64::new(7, 1);
        let mut b = SplitMix64::new(7, 1);
        let mut c = SplitMix64::new(7, 2);
        let xs: Vec<u64> = (0..8).map(|_| a.next_u64()).collect();
        let ys: Vec<u64> = (0..8).map(|_| b.next_u64()).collect();
        let zs: Vec<u64> = (0..8).map(|_| c.next_u64()).collect();
        assert_eq!(xs, ys);
        assert_ne!(xs, zs);
    }

    #[test]
    fn below_is_in_range_and_roughly_uniform() {
        let mut rng = SplitMix64::new(3, 0);
        let mut counts = [0usize; 5];
        for _ in 0..50_000 {
            counts[rng.below(5)] += 1;
        }
        for (i, &c) in counts.iter().enumerate() {
            assert!((9_000..11_000).contains(&c), "bucket {i} has {c} of 50000");
        }
        let u = rng.next_f64();
        assert!((0.0..1.0).contains(&u));
    }

    #[test]
    fn normal_has_unit_moments() {
        let mut rng = SplitMix64::new(11, 4);
        let xs: Vec<f64> = (0..40_000).map(|_| rng.normal()).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64;
        assert!(mean.abs() < 0.03 && (var - 1.0).abs() < 0.05, "mean {mean}, variance {var}");
    }
}
