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
