//! An exact mesh signed distance for the collision losses and checks: geom's
//! [`MeshIndex`] with the gradient from the same closest-point query, and the
//! winding-number sign cached on a lattice.

use std::sync::atomic::{AtomicU8, Ordering};

use s2g_geom::{Aabb, Mesh, MeshIndex, Point3, Real, SignedDistance, Vector3};

use crate::error::{FieldError, Result};

/// An exact mesh signed distance for the collision loss: geom's [`MeshIndex`] (closest
/// point, sign by the winding number), with the gradient `±(p - closest)/|p - closest|`
/// from the same closest-point query instead of the trait's six-query central
/// differences.
///
/// The winding number costs about thirty closest-point queries, so the sign is cached: a
/// lattice of nodes over the mesh's bounding box (64 steps along its longest side) holds
/// each node's inside flag, computed exactly on first use. A point farther from the surface
/// than half a lattice diagonal has the sign of its nearest node (the segment between them
/// lies in a ball free of the surface); nearer points, and points outside the lattice, get
/// the exact winding number, except points outside the bounding box, which are outside.
/// The answers are those of [`MeshIndex::signed_distance`] for closed meshes.
#[derive(Debug)]
pub struct MeshSdf {
    index: MeshIndex,
    signs: SignLattice,
}

/// The lazily filled inside flags of [`MeshSdf`]: 0 unknown, 1 outside, 2 inside.
#[derive(Debug)]
struct SignLattice {
    bbox: Aabb,
    origin: Point3,
    step: f64,
    dims: [usize; 3],
    flags: Vec<AtomicU8>,
}

impl SignLattice {
    fn new(bbox: Aabb) -> Self {
        let ext = bbox.max - bbox.min;
        let step = (ext.max() / 64.0).max(1e-9);
        let origin = bbox.min - Vector3::repeat(step);
        let dims = ext.map(|e| ((e / step).ceil() as usize).min(1 << 12) + 3);
        let flags = (0..dims[0] * dims[1] * dims[2]).map(|_| AtomicU8::new(0)).collect();
        Self { bbox, origin, step, dims: [dims.x, dims.y, dims.z], flags }
    }

    /// Whether `p`, at unsigned distance `d` from the surface, is inside.
    fn inside(&self, index: &MeshIndex, p: &Point3, d: f64) -> bool {
        let b = &self.bbox;
        if (0..3).any(|a| p[a] < b.min[a] || p[a] > b.max[a]) {
            return false;
        }
        if d > 0.87 * self.step {
            let mut ijk = [0usize; 3];
            let mut ok = true;
            for a in 0..3 {
                let f = ((p[a] - self.origin[a]) / self.step).round();
                if !(f >= 0.0 && f < self.dims[a] as f64) {
                    ok = false;
                    break;
                }
                ijk[a] = f as usize;
            }
            if ok {
                let k = (ijk[2] * self.dims[1] + ijk[1]) * self.dims[0] + ijk[0];
                let cached = self.flags[k].load(Ordering::Relaxed);
                if cached != 0 {
                    return cached == 2;
                }
                let node =
                    self.origin + Vector3::new(ijk[0] as f64, ijk[1] as f64, ijk[2] as f64) * self.step;
                let inside = index.contains(&node);
                self.flags[k].store(if inside { 2 } else { 1 }, Ordering::Relaxed);
                return inside;
            }
        }
        index.contains(p)
    }
}

impl MeshSdf {
    /// Indexes `mesh`. Errors: [`FieldError::EmptyMesh`] for a mesh without triangles.
    pub fn new(mesh: &Mesh) -> Result<Self> {
        if mesh.is_empty() {
            return Err(FieldError::EmptyMesh);
        }
        let bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
        if !(bbox.min.iter().chain(bbox.max.iter()).all(|c| c.is_finite())) {
            return Err(FieldError::NonFinite { what: "mesh vertex", index: 0 });
        }
        Ok(Self { index: MeshIndex::new(mesh).map_err(FieldError::geom)?, signs: SignLattice::new(bbox) })
    }

    /// The index.
    pub fn index(&self) -> &MeshIndex {
        &self.index
    }

    /// The signed distance and its gradient from one closest-point query.
    pub fn distance_gradient(&self, p: &Point3) -> (Real, Vector3) {
        let c = self.index.closest_point(p);
        if !c.distance.is_finite() {
            return (Real::NAN, Vector3::z());
        }
        let g = (p - c.point).try_normalize(1e-12).unwrap_or_else(Vector3::z);
        if self.signs.inside(&self.index, p, c.distance) { (-c.distance, -g) } else { (c.distance, g) }
    }
}

impl SignedDistance for MeshSdf {
    fn distance(&self, p: &Point3) -> Real {
        let c = self.index.closest_point(p);
        if !c.distance.is_finite() {
            return Real::NAN;
        }
        if self.signs.inside(&self.index, p, c.distance) { -c.distance } else { c.distance }
    }

    fn gradient(&self, p: &Point3) -> Vector3 {
        self.distance_gradient(p).1
    }

    fn contains(&self, p: &Point3) -> bool {
        self.distance(p) < 0.0
    }
}
