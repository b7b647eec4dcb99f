//! One vocabulary for a milling cutter: its end shape, flutes, shank and holder. The
//! planner (`s2g-toolpath`), the simulator (`s2g-voxsim`), feature programs and the
//! field crate's collision model all describe a physical cutter with [`Cutter`], so a
//! planned tool and a simulated one cannot drift apart.
//!
//! Along the tool axis, measured from the tip (the programmed point) towards the spindle,
//! a cutter is a stack of solids of revolution: the cutting end (flat disc, hemisphere or
//! torus-rounded disc) and flutes of [`Cutter::radius`] up to [`Cutter::flute_length`];
//! the shank of [`Cutter::shank_radius`] up to [`Cutter::stickout`]; then the holder's
//! cylinder, when one is modelled. [`Cutter::radius_at`] gives the stack's radius at any
//! height. To add an end shape, add a [`CutterShape`] variant here (its corner radius and
//! profile) and its swept primitive in voxsim's `engine.rs`.

use crate::error::{GeomError, Result};

/// The shape of a cutter's end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CutterShape {
    /// Flat end mill: a cylinder whose bottom face is the tip plane.
    Flat,
    /// Ball end mill: a hemisphere of the tool radius at the bottom, centred at
    /// `tip + radius * axis`.
    Ball,
    /// Bull nose (corner radius) end mill: a flat bottom of radius `radius - corner_radius`
    /// rounded by a torus of tube radius `corner_radius`.
    BullNose {
        /// Corner radius, `0 <= corner_radius <= radius`.
        corner_radius: f64,
    },
}

/// The tool holder: a cylinder above the tool's stick-out, used for collision checks only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Holder {
    /// Radius in mm.
    pub radius: f64,
    /// Length along the tool axis in mm, starting at the cutter's `stickout`.
    pub length: f64,
}

/// A milling cutter. The programmed point is the tool **tip**, the lowest point along the
/// tool axis; heights below are measured from the tip along the axis (tip to spindle).
///
/// Regions along the axis: flutes (cutting) on `[0, flute_length]`; shank of radius
/// `shank_radius` on `(flute_length, stickout]`; holder (if any) on
/// `[stickout, stickout + holder.length]`. Only the flutes remove material; stock met by
/// the shank or holder is reported as a holder collision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cutter {
    /// End shape.
    pub shape: CutterShape,
    /// Cutting radius in mm.
    pub radius: f64,
    /// Length of the fluted (cutting) part in mm, from the tip.
    pub flute_length: f64,
    /// Radius of the non-cutting shank in mm.
    pub shank_radius: f64,
    /// Tip to holder face in mm (`>= flute_length`).
    pub stickout: f64,
    /// Holder, if modelled.
    pub holder: Option<Holder>,
}

impl Cutter {
    fn with_shape(shape: CutterShape, radius: f64, flute_length: f64) -> Self {
        Self { shape, radius, flute_length, shank_radius: radius, stickout: 2.0 * flute_length, holder: None }
    }

    /// A flat end mill; shank radius = `radius`, stick-out = `2 * flute_length`, no holder.
    pub fn flat(radius: f64, flute_length: f64) -> Self {
        Self::with_shape(CutterShape::Flat, radius, flute_length)
    }

    /// A ball end mill; defaults as for [`Cutter::flat`].
    pub fn ball(radius: f64, flute_length: f64) -> Self {
        Self::with_shape(CutterShape::Ball, radius, flute_length)
    }

    /// A bull nose end mill; defaults as for [`Cutter::flat`].
    pub fn bull(radius: f64, corner_radius: f64, flute_length: f64) -> Self {
        Self::with_shape(CutterShape::BullNose { corner_radius }, radius, flute_length)
    }

    /// The cutting diameter.
    pub fn diameter(&self) -> f64 {
        2.0 * self.radius
    }

    /// The radius of the cutter's stack at height `h` above the tip: the end's profile
    /// (`radius - corner + sqrt(corner^2 - (corner - h)^2)` below the corner's top), the
    /// flutes' radius up to [`flute_length`](Self::flute_length), the shank's up to
    /// [`stickout`](Self::stickout), the holder's above it, and 0 outside the stack.
    pub fn radius_at(&self, h: f64) -> f64 {
        let rc = self.corner_radius();
        if h.is_nan() || h < 0.0 {
            0.0
        } else if h < rc {
            let d = rc - h;
            self.radius - rc + (rc * rc - d * d).max(0.0).sqrt()
        } else if h <= self.flute_length {
            self.radius
        } else if h <= self.stickout {
            self.shank_radius
        } else {
            match self.holder {
                Some(holder) if h <= self.stickout + holder.length => holder.radius,
                _ => 0.0,
            }
        }
    }

    /// The corner radius: 0 for flat, `radius` for ball.
    pub fn corner_radius(&self) -> f64 {
        match self.shape {
            CutterShape::Flat => 0.0,
            CutterShape::Ball => self.radius,
            CutterShape::BullNose { corner_radius } => corner_radius,
        }
    }

    /// Checks the dimensions: every length finite; `radius > 0`; `0 <= corner_radius <= radius`;
    /// `flute_length > 0` and `>= 2 * corner_radius` (the rounded end must be all flute);
    /// `shank_radius > 0`; `stickout >= flute_length`; holder radius and length `> 0`.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(GeomError::InvalidTool(m));
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !pos(self.radius) {
            return bad(format!("radius must be finite and > 0, got {}", self.radius));
        }
        let rc = self.corner_radius();
        if !(rc.is_finite() && rc >= 0.0 && rc <= self.radius) {
            return bad(format!("corner radius must be in [0, radius = {}], got {rc}", self.radius));
        }
        if !pos(self.flute_length) || self.flute_length < 2.0 * rc {
            return bad(format!(
                "flute length must be finite, > 0 and >= twice the corner radius ({}), got {}",
                2.0 * rc,
                self.flute_length
            ));
        }
        if !pos(self.shank_radius) {
            return bad(format!("shank radius must be finite and > 0, got {}", self.shank_radius));
        }
        if !(self.stickout.is_finite() && self.stickout >= self.flute_length) {
            return bad(format!(
                "stick-out must be finite and >= flute length {}, got {}",
                self.flute_length, self.stickout
            ));
        }
        if let Some(h) = self.holder
            && !(pos(h.radius) && pos(h.length))
        {
            return bad(format!("holder radius and length must be finite and > 0, got {h:?}"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stack_s_radius_follows_end_flutes_shank_and_holder() {
        let mut c = Cutter::bull(3.0, 1.0, 10.0);
        c.shank_radius = 2.5;
        c.stickout = 20.0;
        c.holder = Some(Holder { radius: 8.0, length: 30.0 });
        assert_eq!(c.radius_at(-0.1), 0.0);
        assert!((c.radius_at(0.0) - 2.0).abs() < 1e-12, "flat bottom of the bull");
        assert!((c.radius_at(1.0) - 3.0).abs() < 1e-12, "top of the corner");
        assert!((c.radius_at(0.5) - (2.0 + 0.75f64.sqrt())).abs() < 1e-12);
        assert_eq!(c.radius_at(10.0), 3.0);
        assert_eq!(c.radius_at(15.0), 2.5);
        assert_eq!(c.radius_at(49.0), 8.0);
        assert_eq!(c.radius_at(50.1), 0.0);
        let ball = Cutter::ball(2.0, 8.0);
        assert_eq!(ball.radius_at(0.0), 0.0);
        assert!((ball.radius_at(2.0) - 2.0).abs() < 1e-12);
        assert_eq!(Cutter::flat(2.0, 8.0).radius_at(0.0), 2.0);
        assert_eq!(ball.diameter(), 4.0);
    }

    #[test]
    fn impossible_cutters_are_refused_with_the_field_named() {
        assert!(Cutter::flat(1.0, 4.0).validate().is_ok());
        let msg = |c: Cutter| c.validate().unwrap_err().to_string();
        assert!(msg(Cutter::flat(f64::NAN, 4.0)).contains("radius"));
        assert!(msg(Cutter::bull(1.0, 1.5, 4.0)).contains("corner radius"));
        assert!(msg(Cutter::ball(1.0, 1.5)).contains("flute length"));
        assert!(msg(Cutter { stickout: 1.0, ..Cutter::flat(1.0, 4.0) }).contains("stick-out"));
        let holder = Some(Holder { radius: 0.0, length: 1.0 });
        assert!(msg(Cutter { holder, ..Cutter::flat(1.0, 4.0) }).contains("holder"));
    }
}
