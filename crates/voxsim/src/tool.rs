//! Cutters, tool tables and bead profiles.

use std::collections::BTreeMap;

use crate::error::{Result, SimError};

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
        let bad = |m: String| Err(SimError::InvalidTool(m));
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

/// Tool numbers to cutters. A `ToolChange` to a number not in the table selects the
/// default tool (documented fallback); the default tool is active at program start.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolTable {
    /// The tool active at start and for unknown tool numbers.
    pub default: Cutter,
    /// Numbered tools.
    pub tools: BTreeMap<u32, Cutter>,
}

impl ToolTable {
    /// A table with one tool, used for every tool number.
    pub fn single(cutter: Cutter) -> Self {
        Self { default: cutter, tools: BTreeMap::new() }
    }

    /// Adds (or replaces) tool `number`.
    pub fn with(mut self, number: u32, cutter: Cutter) -> Self {
        self.tools.insert(number, cutter);
        self
    }

    /// The cutter for `number` (the default when absent).
    pub fn get(&self, number: u32) -> &Cutter {
        self.tools.get(&number).unwrap_or(&self.default)
    }

    /// Validates every cutter.
    pub fn validate(&self) -> Result<()> {
        self.default.validate()?;
        for (n, c) in &self.tools {
            c.validate().map_err(|e| SimError::InvalidTool(format!("tool {n}: {e}")))?;
        }
        Ok(())
    }
}

/// Cross-section of a deposited bead (additive mode). The bead lies below the nozzle tip:
/// heights `[tip - height, tip]` along the tool axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BeadProfile {
    /// Rectangle `width x height`, swept along the move with flat ends (volume `w h L`).
    Rectangle {
        /// Width in mm.
        width: f64,
        /// Height in mm.
        height: f64,
    },
    /// Rectangle with round ends (a stadium seen from above): every point within
    /// `width / 2` of the path horizontally (volume `w h L + pi w^2 h / 4`).
    Stadium {
        /// Width in mm.
        width: f64,
        /// Height in mm.
        height: f64,
    },
    /// A circle of the given diameter below the tip, swept with round ends (a capsule).
    Circle {
        /// Diameter in mm.
        diameter: f64,
    },
}

impl BeadProfile {
    /// Checks that the sizes are finite and positive.
    pub fn validate(&self) -> Result<()> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        let good = match *self {
            BeadProfile::Rectangle { width, height } | BeadProfile::Stadium { width, height } => {
                ok(width) && ok(height)
            }
            BeadProfile::Circle { diameter } => ok(diameter),
        };
        if good {
            Ok(())
        } else {
            Err(SimError::InvalidTool(format!("bead sizes must be finite and > 0: {self:?}")))
        }
    }
}
