//! Scallop height and stepover for flat, ball and bull-nose cutters on a plane.
//!
//! Two passes `s` apart (horizontally, across the passes) over a plane that rises at angle
//! `a` across them leave a ridge (the scallop, or cusp) between the cuts. In the vertical
//! plane through both cutter axes each cutter's lower outline is its profile: the tip
//! height plus `h(d)` at distance `d` from the axis, `h = 0` on the flat bottom
//! (`d <= R - r`), `r - sqrt(r^2 - (d - R + r)^2)` on the corner, a vertical wall beyond
//! `R`; the tip sits at `(R - r) tan(a) + r / cos(a) - r` above the plane at the axis (the
//! drop-cutter normal offset). The scallop is the material left between the two contact
//! points, measured normal to the plane: the outlines cross once there (one rises, the other
//! falls), and the scallop is the vertical gap at the crossing times `cos(a)`.
//!
//! Closed forms: a ball leaves `r - sqrt(r^2 - (s / (2 cos a))^2)`, so
//! `s = 2 cos(a) sqrt(2 r h - h^2)`; a bull nose on a horizontal plane
//! `s = 2 (R - r) + 2 sqrt(2 r h - h^2)`; a flat end on a horizontal plane leaves none (any
//! `s <= 2R`), on a slope a step of `s sin(a)`, so `s = h / sin(a)`. A bull nose on a slope
//! has no single closed form (the ridge lies on the corner or on the tilted flat bottom of
//! the next pass): its scallop is the crossing of the two outlines, found by bisection to
//! 1e-12 of the stepover, and the stepover for a target by bisection on that (the scallop
//! grows with the stepover).

use s2g_geom::Cutter;

use super::FinishError;

/// Bisection steps (each halves a bracket; 200 exhaust f64).
const BISECTIONS: usize = 200;

/// The cutter's radius and corner radius, checked.
fn dims(cutter: &Cutter) -> Result<(f64, f64), FinishError> {
    cutter.validate().map_err(FinishError::InvalidTool)?;
    Ok((cutter.radius, cutter.corner_radius().clamp(0.0, cutter.radius)))
}

/// `|slope|`, checked to be below a right angle.
fn slope_angle(slope: f64) -> Result<f64, FinishError> {
    let a = slope.abs();
    if !(a < std::f64::consts::FRAC_PI_2) {
        return Err(FinishError::InvalidOptions(format!(
            "slope must be finite and below 90 degrees, got {slope}"
        )));
    }
    Ok(a)
}

/// The scallop height, measured normal to the surface, between two passes `stepover`
/// apart (horizontal distance between the cutter axes, across the passes) on a plane that
/// rises at `slope` radians across the passes (0: horizontal; the sign does not matter).
/// [`FinishError::InvalidOptions`] for a stepover that is negative, not finite or so large
/// that the two cuts do not meet (material would be left standing), or a slope of 90
/// degrees or more; [`FinishError::InvalidTool`] for an impossible cutter.
pub fn scallop_height(cutter: &Cutter, stepover: f64, slope: f64) -> Result<f64, FinishError> {
    let (big, r) = dims(cutter)?;
    let a = slope_angle(slope)?;
    if !(stepover.is_finite() && stepover >= 0.0) {
        return Err(FinishError::InvalidOptions(format!("stepover must be finite and >= 0, got {stepover}")));
    }
    if stepover == 0.0 {
        return Ok(0.0);
    }
    let flat = big - r;
    let (sin, cos) = a.sin_cos();
    let tan = sin / cos;
    // Outline of a cutter whose axis is at `xc`, above the plane `z = x tan(a)`.
    let tip = |xc: f64| xc * tan + flat * tan + r / cos - r;
    let outline = |xc: f64, x: f64| {
        let d = (x - xc).abs();
        if d > big {
            return f64::INFINITY;
        }
        let e = d - flat;
        tip(xc) + if e <= 0.0 { 0.0 } else { r - (r * r - e * e).max(0.0).sqrt() }
    };
    // Contact of the first pass: where the corner's normal is the plane's (flat: its rim).
    let contact = if a == 0.0 { 0.0 } else { flat + r * sin };
    let (mut lo, mut hi) = (contact, contact + stepover);
    let diff = |x: f64| outline(0.0, x) - outline(stepover, x);
    for _ in 0..BISECTIONS {
        if hi - lo <= 1e-12 * stepover.max(1e-300) {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if diff(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let gap = |x: f64| outline(0.0, x).min(outline(stepover, x)) - x * tan;
    let h = gap(lo).max(gap(hi)) * cos;
    if !h.is_finite() {
        return Err(FinishError::InvalidOptions(format!(
            "stepover {stepover} is wider than the cutter's cut at slope {slope}: material would be left standing"
        )));
    }
    Ok(h.max(0.0))
}

/// The largest stepover (horizontal, across the passes) whose scallop on a plane rising at
/// `slope` radians across the passes is at most `height` (closed forms for ball and flat
/// ends and for a bull nose on a horizontal plane, see the module docs; bisection for a
/// bull nose on a slope). Never more than the width the cutter cuts on that plane.
/// [`FinishError::InvalidOptions`] for a height that is not finite and positive or a slope
/// of 90 degrees or more; [`FinishError::InvalidTool`] for an impossible cutter.
pub fn stepover_for_scallop(cutter: &Cutter, height: f64, slope: f64) -> Result<f64, FinishError> {
    let (big, r) = dims(cutter)?;
    let a = slope_angle(slope)?;
    if !(height.is_finite() && height > 0.0) {
        return Err(FinishError::InvalidOptions(format!(
            "scallop height must be finite and > 0, got {height}"
        )));
    }
    let flat = big - r;
    let (sin, cos) = a.sin_cos();
    // Half the chord of a circle of radius `r` at depth `h`.
    let half = |h: f64| (2.0 * r * h.min(r) - h.min(r).powi(2)).sqrt();
    if r <= 0.0 {
        // The flat end's reach on the plane is its diameter.
        return Ok(if a == 0.0 { 2.0 * big } else { (height / sin).min(2.0 * big) });
    }
    if flat <= 0.0 {
        return Ok(2.0 * cos * half(height));
    }
    if a == 0.0 {
        return Ok(2.0 * flat + 2.0 * half(height));
    }
    // Bull nose on a slope: the scallop grows with the stepover; bisect up to the widest
    // stepover whose cuts still meet.
    let (mut lo, mut hi) = (0.0, 2.0 * big);
    while scallop_height(cutter, hi, a).is_err() && hi > 1e-12 * big {
        hi *= 0.5;
    }
    if scallop_height(cutter, hi, a).is_ok_and(|h| h <= height) {
        return Ok(hi);
    }
    for _ in 0..BISECTIONS {
        if hi - lo <= 1e-12 * big {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if scallop_height(cutter, mid, a).is_ok_and(|h| h <= height) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(lo)
}
