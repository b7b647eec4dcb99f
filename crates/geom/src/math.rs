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
