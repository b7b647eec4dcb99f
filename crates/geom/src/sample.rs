//! Area-weighted surface sampling with face normals, seeded and reproducible.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

use crate::error::{GeomError, Result};
use crate::math::{Point3, Real, Vector3};
use crate::mesh::Mesh;

/// Points drawn uniformly (by area) on a mesh's surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceSamples {
    /// The sample positions.
    pub points: Vec<Point3>,
    /// The unit normal of the triangle each sample lies on (the winding's normal).
    pub normals: Vec<Vector3>,
    /// The index of the triangle each sample lies on.
    pub triangles: Vec<u32>,
}

impl SurfaceSamples {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there is no sample.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The same samples reordered along a Morton (Z-order) curve over their bounding box,
    /// so that samples close in the list are close in space: rays or queries issued in
    /// list order then walk the same parts of a BVH one after another (cache locality).
    /// Ties keep the original order, so the result is deterministic. Non-finite points
    /// sort last. Samples whose arrays differ in length (normals, or triangle ids unless
    /// there are none) come back unchanged.
    pub fn spatially_ordered(&self) -> SurfaceSamples {
        let n = self.points.len();
        if self.normals.len() != n || !(self.triangles.len() == n || self.triangles.is_empty()) {
            return self.clone();
        }
        let finite = |p: &Point3| p.iter().all(|c| c.is_finite());
        let mut lo = Point3::from([Real::INFINITY; 3]);
        let mut hi = Point3::from([Real::NEG_INFINITY; 3]);
        for p in self.points.iter().filter(|p| finite(p)) {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let key = |p: &Point3| -> u64 {
            if !finite(p) {
                return u64::MAX;
            }
            let mut k = 0u64;
            for a in 0..3 {
                let span = hi[a] - lo[a];
                let q = if span > 0.0 { ((p[a] - lo[a]) / span * 2_097_151.0) as u64 } else { 0 };
                k |= spread_bits(q.min(2_097_151)) << a;
            }
            k
        };
        let mut order: Vec<(u64, usize)> = self.points.iter().enumerate().map(|(i, p)| (key(p), i)).collect();
        order.sort_unstable();
        SurfaceSamples {
            points: order.iter().map(|&(_, i)| self.points[i]).collect(),
            normals: order.iter().map(|&(_, i)| self.normals[i]).collect(),
            triangles: if self.triangles.is_empty() {
                Vec::new()
            } else {
                order.iter().map(|&(_, i)| self.triangles[i]).collect()
            },
        }
    }
}

/// The low 21 bits of `x` spread to every third bit (the Morton interleave).
fn spread_bits(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// Draws `n` points uniformly over the surface of `mesh`: a triangle is chosen with
/// probability proportional to its area (binary search in the cumulative areas), then
/// a point uniformly inside it (folded barycentric coordinates). Each sample carries
/// its triangle's unit normal. Degenerate (zero-area) triangles are never chosen.
///
/// The same mesh, `n` and `seed` give identical samples on every run and platform
/// (`rand`'s `StdRng` seeded by `seed_from_u64`).
///
/// Errors: [`GeomError::EmptyMesh`] for a mesh without triangles and
/// [`GeomError::InvalidArgument`] for a mesh whose total area is zero (or not finite).
/// `n == 0` gives empty samples.
///
/// ```
/// use s2g_geom::{Mesh, Point3, sample_surface};
/// // A right triangle in z = 0, wound counter-clockwise seen from +z.
/// let tri = [[Point3::origin(), Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.0)]];
/// let mesh = Mesh::from_soup(&tri).unwrap();
/// let s = sample_surface(&mesh, 100, 42).unwrap();
/// assert_eq!(s, sample_surface(&mesh, 100, 42).unwrap()); // reproducible
/// assert!(s.points.iter().all(|p| p.z == 0.0 && p.x + p.y <= 1.0));
/// assert!(s.normals.iter().all(|n| n.z == 1.0));
/// ```
pub fn sample_surface(mesh: &Mesh, n: usize, seed: u64) -> Result<SurfaceSamples> {
    if mesh.is_empty() {
        return Err(GeomError::EmptyMesh);
    }
    let tri_count = mesh.triangles().len();
    let mut cumulative = Vec::with_capacity(tri_count);
    let mut normals = Vec::with_capacity(tri_count);
    let mut total: Real = 0.0;
    for t in 0..tri_count {
        let cross = mesh.triangle_cross(t);
        let twice_area = cross.norm();
        total += 0.5 * twice_area;
        cumulative.push(total);
        normals.push(if twice_area > 0.0 { cross / twice_area } else { Vector3::zeros() });
    }
    if !(total > 0.0 && total.is_finite()) {
        return Err(GeomError::InvalidArgument(format!(
            "cannot sample a surface of area {total} ({tri_count} triangles, all degenerate)"
        )));
    }

    let mut rng = StdRng::seed_from_u64(seed);
    let mut out = SurfaceSamples::default();
    let too_many = |_| GeomError::InvalidArgument(format!("cannot allocate {n} surface samples"));
    out.points.try_reserve_exact(n).map_err(too_many)?;
    out.normals.try_reserve_exact(n).map_err(too_many)?;
    out.triangles.try_reserve_exact(n).map_err(too_many)?;
    for _ in 0..n {
        let r: Real = rng.random::<Real>() * total;
        // The first triangle whose cumulative area exceeds r; zero-area triangles
        // repeat the previous cumulative value and so are skipped.
        let t = cumulative.partition_point(|&c| c <= r).min(tri_count - 1);
        let mut u: Real = rng.random();
        let mut v: Real = rng.random();
        if u + v > 1.0 {
            u = 1.0 - u;
            v = 1.0 - v;
        }
        let [a, b, c] = mesh.triangle(t);
        out.points.push(a + (b - a) * u + (c - a) * v);
        out.normals.push(normals[t]);
        out.triangles.push(t as u32);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spatial_order_is_a_permutation_that_keeps_each_sample_whole_and_groups_neighbours() {
        let tri = [
            [Point3::origin(), Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.0)],
            [Point3::new(0.0, 0.0, 1.0), Point3::new(0.0, 1.0, 1.0), Point3::new(1.0, 0.0, 1.0)],
        ];
        let mesh = Mesh::from_soup(&tri).unwrap();
        let s = sample_surface(&mesh, 4000, 7).unwrap();
        let o = s.spatially_ordered();
        assert_eq!(o.len(), s.len());
        // Same multiset of (point, normal, triangle) triples.
        let triple = |t: &SurfaceSamples, i: usize| {
            let (p, n) = (t.points[i], t.normals[i]);
            ([p.x, p.y, p.z, n.x, n.y, n.z].map(f64::to_bits), t.triangles[i])
        };
        let mut a: Vec<_> = (0..s.len()).map(|i| triple(&s, i)).collect();
        let mut b: Vec<_> = (0..o.len()).map(|i| triple(&o, i)).collect();
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b);
        // The two triangles lie 1 apart in z: Morton order puts all of one before the other
        // (z is the top bit of the interleave), and consecutive samples are much closer
        // than in the sampler's order.
        let switches = o.triangles.windows(2).filter(|w| w[0] != w[1]).count();
        assert_eq!(switches, 1);
        let walk = |t: &SurfaceSamples| t.points.windows(2).map(|w| (w[1] - w[0]).norm()).sum::<Real>();
        assert!(walk(&o) < 0.1 * walk(&s), "ordered walk {} vs {}", walk(&o), walk(&s));
        assert_eq!(o, s.spatially_ordered(), "deterministic");
    }
}
