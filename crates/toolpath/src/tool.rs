//! [`Tool`]: a milling cutter and its cutting data.

/// The cutter's end shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ToolKind {
    /// Flat end mill.
    Flat,
    /// Ball end mill (corner radius = tool radius).
    Ball,
    /// Bull-nose end mill with the given corner radius (`0 < corner <= radius`).
    BullNose {
        /// Corner radius.
        corner: f64,
    },
}

/// A milling cutter with its cutting data. The programmed point is the tool tip.
///
/// Planning treats every cutter as its enclosing cylinder of `radius` (always safe:
/// ball and bull-nose cutters then leave cusps on floors but never cut the part).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tool {
    /// Cutter radius (half the diameter), in part units.
    pub radius: f64,
    /// End shape.
    pub kind: ToolKind,
    /// Usable cutting length below the holder; planning never goes deeper than this below
    /// the stock top. `f64::INFINITY` (the paper's assumption) means unlimited.
    pub flute_length: f64,
    /// Cutting feed in units per minute.
    pub feed: f64,
    /// Feed for plunges, ramps and helices, in units per minute.
    pub plunge_feed: f64,
    /// Spindle speed (rpm, clockwise).
    pub spindle_rpm: f64,
    /// Tool number in the magazine (the T word).
    pub number: u32,
}

impl Tool {
    /// A flat end mill of the given radius with default cutting data: feed 1000/min,
    /// plunge feed 300/min, 10,000 rpm, unlimited flute length, tool number 1.
    pub fn flat(radius: f64) -> Self {
        Self {
            radius,
            kind: ToolKind::Flat,
            flute_length: f64::INFINITY,
            feed: 1000.0,
            plunge_feed: 300.0,
            spindle_rpm: 10_000.0,
            number: 1,
        }
    }

    /// A ball end mill with the defaults of [`Tool::flat`].
    pub fn ball(radius: f64) -> Self {
        Self { kind: ToolKind::Ball, ..Self::flat(radius) }
    }

    /// The diameter.
    pub fn diameter(&self) -> f64 {
        2.0 * self.radius
    }

    /// Checks that the tool can exist; the message names the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be positive and finite, got {v}"))
            }
        };
        pos("radius", self.radius)?;
        pos("feed", self.feed)?;
        pos("plunge_feed", self.plunge_feed)?;
        if !(self.spindle_rpm.is_finite() && self.spindle_rpm >= 0.0) {
            return Err(format!("spindle_rpm must be finite and not negative, got {}", self.spindle_rpm));
        }
        if !(self.flute_length > 0.0) {
            return Err(format!("flute_length must be positive, got {}", self.flute_length));
        }
        if let ToolKind::BullNose { corner } = self.kind
            && !(corner > 0.0 && corner <= self.radius)
        {
            return Err(format!("bull-nose corner radius {corner} must be in (0, radius = {}]", self.radius));
        }
        Ok(())
    }
}
