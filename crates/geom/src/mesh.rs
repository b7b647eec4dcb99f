//! [`Mesh`]: an indexed triangle mesh in f64.

use crate::aabb::Aabb;
use crate::error::{GeomError, Result};
use crate::math::{Point3, Real, Similarity3, Vector3};

/// An indexed triangle mesh. Triangles wind counter-clockwise seen from outside.
///
/// Construction checks that every index is in range and every coordinate finite,
/// so the rest of the workspace can rely on both.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    vertices: Vec<Point3>,
    triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// A mesh from vertices and triangles, checked (see the type's docs).
    pub fn new(vertices: Vec<Point3>, triangles: Vec<[u32; 3]>) -> Result<Self> {
        if let Some(vertex) = vertices.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
            return Err(GeomError::NonFinite { vertex });
        }
        let n = vertices.len();
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&bad) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(GeomError::BadIndex { triangle: t, vertex: bad, vertices: n });
            }
        }
        Ok(Self { vertices, triangles })
    }

    /// A mesh from a triangle soup (three points per triangle), no vertex sharing.
    pub fn from_soup(triangles: &[[Point3; 3]]) -> Result<Self> {
        let vertices: Vec<Point3> = triangles.iter().flatten().copied().collect();
        let tris = (0..triangles.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        Self::new(vertices, tris)
    }

    /// The closed box `b` as a mesh: its eight [corners](Aabb::corners) and two triangles a
    /// face, wound outward. [`GeomError::InvalidArgument`] for a box that is not
    /// [valid](Aabb::is_valid) (a non-finite corner, or `min > max` on an axis, which would
    /// turn the box inside out); a box flat on an axis is valid and gives a mesh of zero
    /// volume.
    ///
    /// ```
    /// use s2g_geom::{Aabb, Mesh, Point3};
    /// let m = Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 2.0, 3.0))).unwrap();
    /// assert_eq!((m.vertices().len(), m.triangles().len()), (8, 12));
    /// assert!((m.signed_volume() - 6.0).abs() < 1e-12);
    /// assert!(Mesh::cuboid(&Aabb::new(Point3::new(1.0, 0.0, 0.0), Point3::origin())).is_err());
    /// ```
    pub fn cuboid(b: &Aabb) -> Result<Self> {
        if !b.is_valid() {
            return Err(GeomError::InvalidArgument(format!(
                "a cuboid needs finite corners with min <= max, got {:?} .. {:?}",
                b.min, b.max
            )));
        }
        // Each face's corners counter-clockwise seen from outside: -z, +z, -y, +y, -x, +x.
        const FACES: [[u32; 4]; 6] =
            [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let triangles = FACES.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
        Self::new(b.corners().to_vec(), triangles)
    }

    /// The vertices.
    pub fn vertices(&self) -> &[Point3] {
        &self.vertices
    }

    /// The triangles, as vertex indices.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Whether there is no triangle.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The corners of triangle `t`.
    pub fn triangle(&self, t: usize) -> [Point3; 3] {
        let [a, b, c] = self.triangles[t];
        [self.vertices[a as usize], self.vertices[b as usize], self.vertices[c as usize]]
    }

    /// Iterates the triangles' corners.
    pub fn triangle_points(&self) -> impl ExactSizeIterator<Item = [Point3; 3]> + '_ {
        (0..self.triangles.len()).map(|t| self.triangle(t))
    }

    /// `(b - a) x (c - a)` of triangle `t`: twice its area along its normal.
    pub fn triangle_cross(&self, t: usize) -> Vector3 {
        let [a, b, c] = self.triangle(t);
        (b - a).cross(&(c - a))
    }

    /// Unit normal of triangle `t`, `None` when it is degenerate.
    pub fn face_normal(&self, t: usize) -> Option<Vector3> {
        self.triangle_cross(t).try_normalize(0.0)
    }

    /// Total surface area.
    pub fn area(&self) -> Real {
        (0..self.triangles.len()).map(|t| 0.5 * self.triangle_cross(t).norm()).sum()
    }

    /// Signed enclosed volume by the divergence theorem (positive for an outward-wound
    /// closed mesh; meaningless for an open one).
    pub fn signed_volume(&self) -> Real {
        // Sum of signed tetrahedra against the bounding-box centre, which keeps the
        // terms small and the sum accurate for parts far from the origin.
        let o = self.bbox().map(|b| b.center()).unwrap_or_else(Point3::origin);
        self.triangle_points().map(|[a, b, c]| (a - o).dot(&(b - o).cross(&(c - o))) / 6.0).sum()
    }

    /// The bounding box; `None` for a mesh without vertices.
    pub fn bbox(&self) -> Option<Aabb> {
        Aabb::from_points(&self.vertices)
    }

    /// The mesh with every vertex mapped through `t`; a mirroring transform
    /// (negative determinant) would turn it inside out, so it is not offered here.
    pub fn transformed(&self, t: &Similarity3) -> Mesh {
        Mesh { vertices: self.vertices.iter().map(|p| t * p).collect(), triangles: self.triangles.clone() }
    }

    /// The mesh with every triangle's winding reversed.
    pub fn flipped(&self) -> Mesh {
        Mesh {
            vertices: self.vertices.clone(),
            triangles: self.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
        }
    }

    /// Appends another mesh (its vertices are not merged with ours).
    pub fn append(&mut self, other: &Mesh) {
        let off = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&other.vertices);
        self.triangles.extend(other.triangles.iter().map(|t| t.map(|i| i + off)));
    }

    /// Splits into parts: vertices and triangles, for code that rebuilds a mesh.
    pub fn into_parts(self) -> (Vec<Point3>, Vec<[u32; 3]>) {
        (self.vertices, self.triangles)
    }
}
