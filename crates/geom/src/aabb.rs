//! Axis-aligned bounding boxes.

use crate::math::{Point3, Real, Vector3};

/// An axis-aligned box `[min, max]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Point3,
    /// Upper corner.
    pub max: Point3,
}

impl Aabb {
    /// The box with the given corners (not checked; see [`Aabb::is_valid`]).
    pub fn new(min: Point3, max: Point3) -> Self {
        Self { min, max }
    }

    /// The cube `[-0.5, 0.5]^3` in which the papers evaluate.
    pub fn unit_cube() -> Self {
        Self::new(Point3::new(-0.5, -0.5, -0.5), Point3::new(0.5, 0.5, 0.5))
    }

    /// The empty box, neutral for [`Aabb::grow`].
    pub fn empty() -> Self {
        Self::new(Point3::from([Real::INFINITY; 3]), Point3::from([Real::NEG_INFINITY; 3]))
    }

    /// The smallest box holding every point; `None` for no points.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Point3>) -> Option<Self> {
        let mut b = Self::empty();
        for p in points {
            b.grow(p);
        }
        b.is_valid().then_some(b)
    }

    /// Finite and `min <= max` on every axis.
    pub fn is_valid(&self) -> bool {
        (0..3).all(|i| self.min[i].is_finite() && self.max[i].is_finite() && self.min[i] <= self.max[i])
    }

    /// Grows the box to hold `p`.
    pub fn grow(&mut self, p: &Point3) {
        self.min = self.min.inf(p);
        self.max = self.max.sup(p);
    }

    /// The union of two boxes.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb::new(self.min.inf(&other.min), self.max.sup(&other.max))
    }

    /// The box grown by `margin` on every side.
    pub fn inflated(&self, margin: Real) -> Aabb {
        let m = Vector3::repeat(margin);
        Aabb::new(self.min - m, self.max + m)
    }

    /// `max - min`.
    pub fn extent(&self) -> Vector3 {
        self.max - self.min
    }

    /// The centre.
    pub fn center(&self) -> Point3 {
        nalgebra::center(&self.min, &self.max)
    }

    /// Whether `p` lies in the closed box.
    pub fn contains(&self, p: &Point3) -> bool {
        (0..3).all(|i| self.min[i] <= p[i] && p[i] <= self.max[i])
    }

    /// Whether the closed boxes overlap.
    pub fn intersects(&self, other: &Aabb) -> bool {
        (0..3).all(|i| self.min[i] <= other.max[i] && other.min[i] <= self.max[i])
    }

    /// Corner `i` of the box, `i` in `0..8`: bit 0 of `i` picks `max.x` over `min.x`, bit
    /// 1 the y, bit 2 the z (so corner 0 is `min` and corner 7 is `max`).
    ///
    /// # Panics
    /// If `i >= 8`.
    pub fn corner(&self, i: usize) -> Point3 {
        assert!(i < 8, "a box has corners 0..8, not {i}");
        let pick = |bit: usize, axis: usize| if i & bit == 0 { self.min[axis] } else { self.max[axis] };
        Point3::new(pick(1, 0), pick(2, 1), pick(4, 2))
    }

    /// The eight corners, in the order of [`Aabb::corner`].
    pub fn corners(&self) -> [Point3; 8] {
        std::array::from_fn(|i| self.corner(i))
    }

    /// The volume (0 for an invalid box).
    pub fn volume(&self) -> Real {
        if self.is_valid() { self.extent().product() } else { 0.0 }
    }
}
