//! Normalisation into the unit cube `[-0.5, 0.5]^3` (the papers' convention), with the
//! transform kept so results map back to part units.

use crate::error::{GeomError, Result};
use crate::math::{Point3, Real, Rotation3, Similarity3, Vector3};
use crate::mesh::Mesh;

/// A uniform scale and translation: `unit = scale * part + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normalization {
    /// Unit-cube lengths per part length.
    pub scale: Real,
    /// Added after scaling.
    pub translation: Vector3,
}

impl Normalization {
    /// The identity (scale 1, no translation).
    pub fn identity() -> Self {
        Self { scale: 1.0, translation: Vector3::zeros() }
    }

    /// A part-frame point in unit-cube coordinates.
    pub fn to_unit(&self, p: &Point3) -> Point3 {
        Point3::from(p.coords * self.scale + self.translation)
    }

    /// A unit-cube point in part coordinates.
    pub fn from_unit(&self, q: &Point3) -> Point3 {
        Point3::from((q.coords - self.translation) / self.scale)
    }

    /// A unit-cube length in part units.
    pub fn length_from_unit(&self, d: Real) -> Real {
        d / self.scale
    }

    /// A part length in unit-cube units.
    pub fn length_to_unit(&self, d: Real) -> Real {
        d * self.scale
    }

    /// The part-to-unit map as a similarity (no rotation).
    pub fn as_similarity(&self) -> Similarity3 {
        Similarity3::from_parts(self.translation.into(), Rotation3::identity(), self.scale)
    }

    /// The unit-to-part map as a similarity.
    pub fn inverse_similarity(&self) -> Similarity3 {
        self.as_similarity().inverse()
    }
}

/// The normalisation that centres `bbox`-of-`mesh` at the origin and scales its
/// largest extent to 1, so the mesh fits `[-0.5, 0.5]^3` touching two opposite faces.
///
/// Errors: [`GeomError::EmptyMesh`] without triangles, [`GeomError::InvalidArgument`]
/// when every vertex coincides (zero extent).
pub fn unit_cube_normalization(mesh: &Mesh) -> Result<Normalization> {
    if mesh.is_empty() {
        return Err(GeomError::EmptyMesh);
    }
    let bbox = mesh.bbox().ok_or(GeomError::EmptyMesh)?;
    let extent = bbox.extent().max();
    if !(extent > 0.0 && extent.is_finite()) {
        return Err(GeomError::InvalidArgument(format!(
            "cannot normalise a mesh whose largest extent is {extent}"
        )));
    }
    let scale = 1.0 / extent;
    Ok(Normalization { scale, translation: -bbox.center().coords * scale })
}

/// The mesh moved and scaled into the unit cube (see [`unit_cube_normalization`]),
/// with the normalisation that maps results back (`Normalization::from_unit`).
///
/// ```
/// use s2g_geom::{Mesh, Point3, normalize_unit_cube};
/// let tri = [[Point3::new(10.0, 0.0, 0.0), Point3::new(14.0, 0.0, 0.0), Point3::new(10.0, 2.0, 1.0)]];
/// let (unit, n) = normalize_unit_cube(&Mesh::from_soup(&tri).unwrap()).unwrap();
/// let b = unit.bbox().unwrap();
/// assert_eq!((b.min.x, b.max.x), (-0.5, 0.5)); // the longest side spans the cube
/// assert_eq!(n.scale, 0.25);
/// assert_eq!(n.from_unit(&b.max), Point3::new(14.0, 2.0, 1.0));
/// ```
pub fn normalize_unit_cube(mesh: &Mesh) -> Result<(Mesh, Normalization)> {
    let n = unit_cube_normalization(mesh)?;
    Ok((mesh.transformed(&n.as_similarity()), n))
}
