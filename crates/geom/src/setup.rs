//! [`Setup`]: a machining setup, a rigid frame whose +Z is the tool axis.

use crate::math::{Isometry3, Point3, Real, Rotation3, UnitVector3, Vector3};

/// One fixture orientation. Toolpaths are planned in the setup frame, where the tool
/// points down along -Z (it approaches from +Z); `frame` maps setup coordinates to
/// part coordinates, so the tool axis (from tip towards spindle) in the part frame is
/// `frame * +Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Setup {
    /// Setup frame to part frame.
    pub frame: Isometry3,
}

impl Setup {
    /// The setup whose tool approaches along `-direction`, i.e. whose tool axis
    /// (tip to spindle) is `direction` in the part frame. The frame is a pure rotation
    /// chosen deterministically: the shortest arc from +Z, or a half turn about +X for -Z.
    pub fn from_direction(direction: &UnitVector3) -> Self {
        let z = Vector3::z();
        let rot = Rotation3::rotation_between(&z, direction).unwrap_or_else(|| {
            // Anti-parallel: any half turn about an axis perpendicular to Z works; X is the convention.
            Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
        Self { frame: Isometry3::from_parts(nalgebra::Translation3::identity(), rot) }
    }

    /// The identity setup: tool axis +Z.
    pub fn top() -> Self {
        Self { frame: Isometry3::identity() }
    }

    /// The tool axis (tip towards spindle) in the part frame.
    pub fn tool_axis(&self) -> UnitVector3 {
        UnitVector3::new_normalize(self.frame * Vector3::z())
    }

    /// A part-frame point in setup coordinates.
    pub fn to_setup(&self, p: &Point3) -> Point3 {
        self.frame.inverse_transform_point(p)
    }

    /// A setup-frame point in part coordinates.
    pub fn to_part(&self, p: &Point3) -> Point3 {
        self.frame * p
    }

    /// The six principal-axis setups (+Z, -Z, +X, -X, +Y, -Y).
    pub fn six_axes() -> [Setup; 6] {
        let d = |x: Real, y: Real, z: Real| {
            Setup::from_direction(&UnitVector3::new_normalize(Vector3::new(x, y, z)))
        };
        [d(0., 0., 1.), d(0., 0., -1.), d(1., 0., 0.), d(-1., 0., 0.), d(0., 1., 0.), d(0., -1., 0.)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tool_axis_round_trips_for_every_principal_direction() {
        for s in Setup::six_axes() {
            let a = s.tool_axis();
            let again = Setup::from_direction(&a);
            assert!((again.tool_axis().into_inner() - a.into_inner()).norm() < 1e-12);
            let p = Point3::new(0.3, -1.2, 2.5);
            assert!((s.to_part(&s.to_setup(&p)) - p).norm() < 1e-12);
            // The setup's +Z maps onto the tool axis.
            assert!((s.frame * Vector3::z() - a.into_inner()).norm() < 1e-12);
        }
    }
}
