//! Candidate tool directions: a Fibonacci sphere plus the six principal axes, and
//! uniformly random directions for the baselines.

use rand::RngExt;
use s2g_geom::{Real, UnitVector3, Vector3};

/// Two directions whose dot product exceeds this are the same candidate.
const SAME_DIRECTION_COS: Real = 1.0 - 1e-12;

/// The six principal axes, in the order of [`s2g_geom::Setup::six_axes`]:
/// +Z, -Z, +X, -X, +Y, -Y.
pub fn principal_axes() -> [UnitVector3; 6] {
    let d = |x: Real, y: Real, z: Real| UnitVector3::new_unchecked(Vector3::new(x, y, z));
    [d(0., 0., 1.), d(0., 0., -1.), d(1., 0., 0.), d(-1., 0., 0.), d(0., 1., 0.), d(0., -1., 0.)]
}

/// `n` near-uniform directions on the unit sphere (the Fibonacci / golden-spiral
/// lattice): direction `i` has `z = 1 - (2 i + 1) / n` and azimuth `i` times the golden
/// angle. Deterministic; empty for `n == 0`.
pub fn fibonacci_sphere(n: usize) -> Vec<UnitVector3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2 * i + 1) as Real / n as Real;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as Real;
            UnitVector3::new_normalize(Vector3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

/// The candidate set: the six principal axes first (indices 0..6, order of
/// [`principal_axes`]), then the `n` Fibonacci directions that do not duplicate an
/// axis. Deterministic.
pub fn candidate_directions(n: usize) -> Vec<UnitVector3> {
    let mut out: Vec<UnitVector3> = principal_axes().to_vec();
    for d in fibonacci_sphere(n) {
        if !out.iter().any(|a| a.dot(&d) > SAME_DIRECTION_COS) {
            out.push(d);
        }
    }
    out
}

/// A direction uniformly distributed on the unit sphere (Archimedes: `z` uniform in
/// `[-1, 1]`, azimuth uniform).
pub fn random_direction(rng: &mut impl RngExt) -> UnitVector3 {
    let z: Real = 2.0 * rng.random::<Real>() - 1.0;
    let phi: Real = std::f64::consts::TAU * rng.random::<Real>();
    let r = (1.0 - z * z).max(0.0).sqrt();
    UnitVector3::new_normalize(Vector3::new(r * phi.cos(), r * phi.sin(), z))
}

/// Directions spread around `center` on a cone of half-angle `angle` (radians):
/// `count` of them, evenly spaced in azimuth starting at `phase` (radians).
pub fn cone_directions(center: &UnitVector3, angle: Real, count: usize, phase: Real) -> Vec<UnitVector3> {
    let (u, w) = orthonormal_basis(center);
    let (s, c) = angle.sin_cos();
    (0..count)
        .map(|j| {
            let t = phase + std::f64::consts::TAU * j as Real / count.max(1) as Real;
            UnitVector3::new_normalize(center.into_inner() * c + (u * t.cos() + w * t.sin()) * s)
        })
        .collect()
}

/// Two unit vectors that complete `n` to a right-handed orthonormal basis
/// (Duff et al. 2017, "Building an orthonormal basis, revisited").
pub fn orthonormal_basis(n: &UnitVector3) -> (Vector3, Vector3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let u = Vector3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let w = Vector3::new(b, sign + n.y * n.y * a, -n.y);
    (u, w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_hold_the_axes_once_and_are_unit() {
        for n in [0, 1, 6, 512, 1000] {
            let c = candidate_directions(n);
            assert!(c.len() >= 6 && c.len() <= n + 6, "n = {n}: {} candidates", c.len());
            for (i, a) in c.iter().enumerate() {
                assert!((a.norm() - 1.0).abs() < 1e-12, "n = {n}: candidate {i} not unit");
                for b in &c[i + 1..] {
                    assert!(a.dot(b) < SAME_DIRECTION_COS, "n = {n}: duplicate candidate {a:?}");
                }
            }
            for (i, axis) in principal_axes().iter().enumerate() {
                assert_eq!(c[i], *axis, "n = {n}: axis {i} not at its index");
            }
        }
        // 512 Fibonacci points contain no exact axis, so nothing is dropped.
        assert_eq!(candidate_directions(512).len(), 518);
    }

    #[test]
    fn fibonacci_is_near_uniform() {
        // Every direction of a random probe set has a lattice point within ~1.5x the mean spacing.
        let dirs = fibonacci_sphere(512);
        let spacing = (4.0 * std::f64::consts::PI / 512.0).sqrt();
        let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(7);
        for _ in 0..2000 {
            let p = random_direction(&mut rng);
            let best = dirs.iter().map(|d| d.dot(&p)).fold(-1.0, f64::max);
            assert!(
                best.clamp(-1.0, 1.0).acos() < spacing,
                "probe {p:?} is {} rad from the lattice",
                best.acos()
            );
        }
        // Mean of all directions is near zero.
        let mean: Vector3 = dirs.iter().map(|d| d.into_inner()).sum::<Vector3>() / 512.0;
        assert!(mean.norm() < 1e-2, "mean {mean:?}");
    }

    #[test]
    fn basis_is_orthonormal_and_cones_have_their_angle() {
        let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(3);
        for d in principal_axes().into_iter().chain((0..200).map(|_| random_direction(&mut rng))) {
            let (u, w) = orthonormal_basis(&d);
            assert!(u.dot(&w).abs() < 1e-12 && u.dot(&d).abs() < 1e-12 && w.dot(&d).abs() < 1e-12, "{d:?}");
            assert!((u.norm() - 1.0).abs() < 1e-12 && (w.norm() - 1.0).abs() < 1e-12, "{d:?}");
            assert!((u.cross(&w) - d.into_inner()).norm() < 1e-12, "basis not right-handed for {d:?}");
            for c in cone_directions(&d, 0.1, 7, 0.3) {
                assert!((c.dot(&d).acos() - 0.1).abs() < 1e-9, "{d:?}");
            }
        }
    }
}
