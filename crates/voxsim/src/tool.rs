//! Cutters, tool tables and bead profiles.

use std::collections::BTreeMap;

pub use s2g_geom::{Cutter, CutterShape, Holder, Neck};

use crate::error::{Result, SimError};

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
        self.default.validate().map_err(|e| tool_error(None, e))?;
        for (&n, c) in &self.tools {
            c.validate().map_err(|e| tool_error(Some(n), e))?;
        }
        Ok(())
    }
}

/// A cutter's validation error as the simulator's [`SimError::InvalidTool`] (geom's would
/// otherwise come through as [`SimError::Geom`]), `tool N: ...` for a numbered tool.
pub(crate) fn tool_error(number: Option<u32>, e: s2g_geom::GeomError) -> SimError {
    match (e, number) {
        (s2g_geom::GeomError::InvalidTool(m), None) => SimError::InvalidTool(m),
        (s2g_geom::GeomError::InvalidTool(m), Some(n)) => SimError::InvalidTool(format!("tool {n}: {m}")),
        (e, _) => e.into(),
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
