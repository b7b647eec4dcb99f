//! 3+2 rotary kinematics shared by the writers and the parser, so that both agree by
//! construction.
//!
//! The conventions and what rotary words can represent are documented on [`rotary_frame`].

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

/// Rotary table kinematics for 3+2 programs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RotaryAxes {
    /// Table-table A (about X) then C (about Z).
    AC,
    /// Table-table B (about Y) then C (about Z).
    BC,
}

/// What the rotary axes of [`RotaryAxes`] turn.
///
/// - [`RotaryMount::Table`] (the default): a table-table machine turns the part; program
///   coordinates are in the turned table's frame, and rotary words make a
///   [`Motion::Setup`](crate::Motion::Setup) of [`rotary_frame`].
/// - [`RotaryMount::Head`]: a tilting head turns the tool under tool-centre-point control
///   (LinuxCNC's TCP, `G43.4`): program coordinates are the tip in the part frame whatever
///   the angles, and rotary words make a [`Motion::ToolAxis`](crate::Motion::ToolAxis) of
///   [`rotary_axis`], the same angle conventions with the head turning instead of the
///   table: the tool axis in the part frame is `R · +Z`, `R` the kinematic rotation of
///   [`rotary_frame`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum RotaryMount {
    /// Table-table: the part turns under a vertical tool.
    #[default]
    Table,
    /// Head-head with tool-centre-point control: the tool turns over a still part.
    Head,
}

/// The tool axis in the part frame of rotary angles `[A, B, C]` (degrees) under `axes`:
/// `rotary_frame(axes, angles).rotation * +Z`, for either [`RotaryMount`].
pub fn rotary_axis(axes: RotaryAxes, angles_deg: [f64; 3]) -> Vector3<f64> {
    rotary_frame(axes, angles_deg).rotation * Vector3::z()
}

/// The rotary angles `[A, B, C]` (degrees; the unused one 0) whose [`rotary_axis`] is the
/// unit `axis`: tilt `atan2(√(x² + y²), z)`, C as in [`rotary_angles`] (0 where the axis is
/// vertical).
pub fn axis_angles(axes: RotaryAxes, axis: &Vector3<f64>) -> [f64; 3] {
    let t = axis;
    // atan2 rather than acos(t.z): accurate near the vertical too.
    let h = t.x.hypot(t.y);
    let tilt = h.atan2(t.z).to_degrees();
    let c = match axes {
        RotaryAxes::AC => t.x.atan2(-t.y),
        RotaryAxes::BC => t.y.atan2(t.x),
    };
    let c = if h < VERTICAL { 0.0 } else { c.to_degrees() };
    match axes {
        RotaryAxes::AC => [tilt, 0.0, c],
        RotaryAxes::BC => [0.0, tilt, c],
    }
}

/// Horizontal tool-axis component below which the axis counts as vertical (C is then 0).
const VERTICAL: f64 = 1e-12;

/// The setup frame (program → part) that rotary angles `[A, B, C]` in degrees realise
/// under `axes`: rotation `Rz(C)·Rx(A)` ([`RotaryAxes::AC`], B ignored) or `Rz(C)·Ry(B)`
/// ([`RotaryAxes::BC`], A ignored), zero translation.
///
/// A [`Motion::Setup`](crate::Motion::Setup) frame maps program coordinates to part
/// coordinates; the tool axis in the part frame is `t = frame · +Z`. The two table-table
/// kinematics of [`RotaryAxes`] define the *kinematic rotation* of rotary angles (degrees):
///
/// - [`RotaryAxes::AC`]: `R = Rz(C) · Rx(A)`, so `t = (sin A sin C, −sin A cos C, cos A)`;
///   solved as `A = acos(t.z)` in `[0°, 180°]` (computed as `atan2(√(t.x² + t.y²), t.z)`,
///   accurate near the vertical), `C = atan2(t.x, −t.y)` in `[−180°, 180°]`.
/// - [`RotaryAxes::BC`]: `R = Rz(C) · Ry(B)`, so `t = (sin B cos C, sin B sin C, cos B)`;
///   solved as `B = acos(t.z)`, `C = atan2(t.y, t.x)`.
///
/// A vertical tool axis (`√(t.x² + t.y²) < 1e-12`) leaves C free: it is set to 0.
/// [`rotary_frame`] builds the frame of given angles (rotation `R`, zero translation),
/// [`rotary_angles`] solves the angles of a frame's tool axis, and
/// `rotary_frame(axes, rotary_angles(axes, f))` has the same tool axis as `f`.
///
/// # Which frames rotary words represent exactly
///
/// Two angles fix only the tool axis: a frame is exactly representable when its rotation
/// *is* the kinematic rotation of its angles, i.e. when [`rotary_twist`] is 0 (frames made
/// by [`rotary_frame`] are). Any other rotation equals `R · Rz(φ)` for the twist
/// `φ = rotary_twist(axes, frame)` about the tool axis. The writer then still writes the
/// kinematic angles of the tool axis (or the setup's own `rotary` values when given) and
/// the program coordinates unchanged, so the machine cuts the path rotated by `−φ` about
/// the tool axis relative to the part: planners that use rotary output should build their
/// setup frames with [`rotary_frame`] (or rotate their program coordinates by `Rz(φ)`).
/// The frame's translation is not expressed by rotary words either: it is the work offset
/// of that setup (the writer's setup comment states it), and frames read back by the
/// parser have zero translation (rotary centre at the program origin).
///
/// ```
/// use nalgebra::Vector3;
/// use s2g_gcode::{RotaryAxes, rotary_frame};
/// let f = rotary_frame(RotaryAxes::AC, [90.0, 0.0, 180.0]);
/// let t = f.rotation * Vector3::z();
/// assert!((t - Vector3::y()).norm() < 1e-12);
/// ```
pub fn rotary_frame(axes: RotaryAxes, angles_deg: [f64; 3]) -> Isometry3<f64> {
    let [a, b, c] = angles_deg;
    let tilt = match axes {
        RotaryAxes::AC => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a.to_radians()),
        RotaryAxes::BC => UnitQuaternion::from_axis_angle(&Vector3::y_axis(), b.to_radians()),
    };
    let spin = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), c.to_radians());
    Isometry3::from_parts(Translation3::identity(), spin * tilt)
}

/// The rotary angles `[A, B, C]` in degrees that put the tool axis `frame · +Z` of a
/// setup frame under `axes` (the unused angle is 0): the inverse of [`rotary_frame`] for
/// the tool axis. A non-finite frame gives non-finite angles.
pub fn rotary_angles(axes: RotaryAxes, frame: &Isometry3<f64>) -> [f64; 3] {
    axis_angles(axes, &(frame.rotation * Vector3::z()))
}

/// The twist φ in degrees, in `(−180°, 180°]`, of `frame`'s rotation about its tool axis
/// relative to the kinematic rotation of its angles: `frame.rotation = R · Rz(φ)` with
/// `R = rotary_frame(axes, rotary_angles(axes, frame)).rotation`. Zero exactly for frames
/// that rotary words represent (see [`rotary_frame`]).
pub fn rotary_twist(axes: RotaryAxes, frame: &Isometry3<f64>) -> f64 {
    let kin = rotary_frame(axes, rotary_angles(axes, frame)).rotation;
    // Both rotations map +Z to the tool axis, so the difference is a rotation about Z.
    let d = kin.inverse() * frame.rotation;
    let x = d * Vector3::x();
    x.y.atan2(x.x).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writer_convention_examples() {
        // Tool axis +Y: A = 90, C = atan2(0, -1) = 180; B = 90, C = 90.
        let f = Isometry3::rotation(Vector3::x() * (-std::f64::consts::FRAC_PI_2));
        let [a, _, c] = rotary_angles(RotaryAxes::AC, &f);
        assert!((a - 90.0).abs() < 1e-12 && (c - 180.0).abs() < 1e-12, "{a} {c}");
        let [_, b, c] = rotary_angles(RotaryAxes::BC, &f);
        assert!((b - 90.0).abs() < 1e-12 && (c - 90.0).abs() < 1e-12, "{b} {c}");
        // Rz(180)·Rx(90) maps X to -X where Rx(-90) keeps it: a half-turn twist.
        assert!((rotary_twist(RotaryAxes::AC, &f).abs() - 180.0).abs() < 1e-9);
        let k = rotary_frame(RotaryAxes::AC, [90.0, 0.0, 180.0]);
        assert!(rotary_twist(RotaryAxes::AC, &k).abs() < 1e-9);
        assert!((k.rotation * Vector3::x() + Vector3::x()).norm() < 1e-12);
        // Vertical axes: C is 0.
        assert_eq!(rotary_angles(RotaryAxes::AC, &Isometry3::identity()), [0.0, 0.0, 0.0]);
        let down = Isometry3::rotation(Vector3::y() * std::f64::consts::PI);
        assert_eq!(rotary_angles(RotaryAxes::BC, &down), [0.0, 180.0, 0.0]);
    }
}
