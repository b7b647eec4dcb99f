//! [`Tool`]: a physical cutter ([`s2g_geom::Cutter`]) and its cutting data, and the
//! [`Envelope`] the layer planner keeps out of the part.

use s2g_gcode::Coolant;
use s2g_geom::{Ball, BullNose, Cutter, CutterShape, Flat};

/// A milling cutter with its cutting data. The programmed point is the tool tip.
///
/// The cutter itself (end shape, radius, flutes, shank, holder) is the workspace's one
/// description of a physical cutter, [`s2g_geom::Cutter`]; the simulator cuts with the
/// same value (`s2g_voxsim::ToolTable` takes a [`Cutter`]), so a planned tool and a
/// simulated one cannot drift apart. Layer planning uses the tool through its
/// [`envelope`](Self::envelope).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tool {
    /// The physical cutter. Its [`flute_length`](Cutter::flute_length) bounds planning
    /// depth: planning never goes deeper than this below the stock top; `f64::INFINITY`
    /// (the paper's assumption, and [`Tool::flat`]'s default) means unlimited.
    pub cutter: Cutter,
    /// Cutting feed in units per minute.
    pub feed: f64,
    /// Feed for plunges, ramps and helices, in units per minute.
    pub plunge_feed: f64,
    /// Spindle speed (rpm, clockwise).
    pub spindle_rpm: f64,
    /// Tool number in the magazine (the T word).
    pub number: u32,
    /// Coolant while this tool cuts: turned on after the spindle starts and off before it
    /// stops; [`Coolant::Off`] writes no coolant words.
    pub coolant: Coolant,
}

/// The solid of revolution that layer planning keeps out of the part: a cylinder of
/// `radius` from the tool tip up `length` along the tool axis.
///
/// Today's layer planner treats every cutter as its enclosing cylinder ([`Tool::envelope`]):
/// always safe, since a ball or bull-nose end lies inside the cylinder of its radius (such
/// cutters then leave cusps on floors but never cut the part). A shape-aware planner
/// (finishing with ball and bull-nose cutters) plugs in here: it reads the cutter's
/// profile ([`Cutter::radius_at`]) instead of this cylinder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// Radius of the cylinder: the tool-centre keep-out is the part grown by it.
    pub radius: f64,
    /// How far the tool reaches below the stock's top ([`Tool::envelope`]; `f64::INFINITY`
    /// when unlimited): planning never goes deeper.
    pub length: f64,
}

impl Tool {
    /// Default cutting feed of the constructors (units per minute).
    pub const DEFAULT_FEED: f64 = 1000.0;
    /// Default plunge feed of the constructors (units per minute).
    pub const DEFAULT_PLUNGE_FEED: f64 = 300.0;
    /// Default spindle speed of the constructors (rpm).
    pub const DEFAULT_SPINDLE_RPM: f64 = 10_000.0;

    /// `cutter` with default cutting data: feed [`DEFAULT_FEED`](Self::DEFAULT_FEED)
    /// (1000/min), plunge feed 300/min, 10,000 rpm, tool number 1, no coolant.
    pub fn new(cutter: Cutter) -> Self {
        Self {
            cutter,
            feed: Self::DEFAULT_FEED,
            plunge_feed: Self::DEFAULT_PLUNGE_FEED,
            spindle_rpm: Self::DEFAULT_SPINDLE_RPM,
            number: 1,
            coolant: Coolant::Off,
        }
    }

    /// A flat end mill of the given radius with the default cutting data of [`Tool::new`]
    /// and unlimited flute length: flute length and stick-out are `f64::INFINITY` (the
    /// paper's assumption: the tool reaches any depth), shank radius = `radius`, no holder.
    pub fn flat(radius: f64) -> Self {
        Self::unlimited(CutterShape::Flat(Flat), radius)
    }

    /// A ball end mill with the defaults of [`Tool::flat`].
    pub fn ball(radius: f64) -> Self {
        Self::unlimited(CutterShape::Ball(Ball), radius)
    }

    /// A bull-nose end mill with the defaults of [`Tool::flat`].
    pub fn bull(radius: f64, corner_radius: f64) -> Self {
        Self::unlimited(CutterShape::BullNose(BullNose { corner_radius }), radius)
    }

    fn unlimited(shape: CutterShape, radius: f64) -> Self {
        Self::new(Cutter {
            shape,
            radius,
            flute_length: f64::INFINITY,
            shank_radius: radius,
            stickout: f64::INFINITY,
            holder: None,
            neck: None,
        })
    }

    /// The cutting radius (half the diameter).
    pub fn radius(&self) -> f64 {
        self.cutter.radius
    }

    /// The cutting diameter.
    pub fn diameter(&self) -> f64 {
        self.cutter.diameter()
    }

    /// The usable cutting length from the tip; `f64::INFINITY` means unlimited.
    pub fn flute_length(&self) -> f64 {
        self.cutter.flute_length
    }

    /// The end shape.
    pub fn shape(&self) -> CutterShape {
        self.cutter.shape
    }

    /// What layer planning keeps out of the part: today the cutter's enclosing cylinder,
    /// of its cutting radius, whatever its end shape (see [`Envelope`]), as long as the
    /// tool can reach ([`Cutter::reach`]): its flute length, a long-reach end mill's neck's
    /// reach, or, where the shank is no wider than the flutes, its stick-out (the shank
    /// then follows the flutes down through what they cut above it, and the holder stays
    /// above the stock's top; the simulator counts any shank or holder contact as a holder
    /// collision).
    pub fn envelope(&self) -> Envelope {
        Envelope { radius: self.cutter.radius, length: self.cutter.reach() }
    }

    /// Checks that the tool can exist; the message names the offending field. The cutter
    /// is checked as [`Cutter::validate`] does, except that flute length and stick-out
    /// may be `f64::INFINITY` (unlimited).
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be positive and finite, got {v}"))
            }
        };
        pos("radius", self.radius())?;
        pos("feed", self.feed)?;
        pos("plunge_feed", self.plunge_feed)?;
        if !(self.spindle_rpm.is_finite() && self.spindle_rpm >= 0.0) {
            return Err(format!("spindle_rpm must be finite and not negative, got {}", self.spindle_rpm));
        }
        if !(self.flute_length() > 0.0) {
            return Err(format!("flute_length must be positive, got {}", self.flute_length()));
        }
        if let CutterShape::BullNose(BullNose { corner_radius }) = self.shape()
            && !(corner_radius > 0.0 && corner_radius <= self.radius())
        {
            return Err(format!(
                "bull-nose corner radius {corner_radius} must be in (0, radius = {}]",
                self.radius()
            ));
        }
        // The rest of the cutter's checks, with an unlimited length standing in as the
        // largest finite one.
        let finite = |v: f64| if v == f64::INFINITY { f64::MAX } else { v };
        let cutter = Cutter {
            flute_length: finite(self.cutter.flute_length),
            stickout: finite(self.cutter.stickout),
            ..self.cutter
        };
        cutter.validate().map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accessors_read_the_cutter() {
        let t = Tool::new(Cutter::bull(3.0, 1.0, 12.0));
        assert_eq!(t.radius(), 3.0);
        assert_eq!(t.diameter(), 6.0);
        assert_eq!(t.flute_length(), 12.0);
        assert_eq!(t.shape(), CutterShape::BullNose(BullNose { corner_radius: 1.0 }));
        // The shank is as wide as the flutes: the tool reaches down to its holder.
        assert_eq!(t.envelope(), Envelope { radius: 3.0, length: 24.0 });
        let necked = Tool::new(Cutter { shank_radius: 4.0, ..Cutter::bull(3.0, 1.0, 12.0) });
        assert_eq!(necked.envelope(), Envelope { radius: 3.0, length: 12.0 });
        assert_eq!((t.feed, t.plunge_feed, t.spindle_rpm, t.number), (1000.0, 300.0, 10_000.0, 1));
        assert!(t.validate().is_ok());
    }

    #[test]
    fn flat_and_ball_tools_have_unlimited_flutes_and_are_valid() {
        for t in [Tool::flat(0.25), Tool::ball(0.25), Tool::bull(0.25, 0.1)] {
            assert_eq!(t.radius(), 0.25, "{t:?}");
            assert_eq!(t.diameter(), 0.5, "{t:?}");
            assert_eq!(t.flute_length(), f64::INFINITY, "{t:?}");
            assert_eq!(t.cutter.stickout, f64::INFINITY, "{t:?}");
            assert_eq!(t.cutter.shank_radius, 0.25, "{t:?}");
            assert_eq!(t.envelope(), Envelope { radius: 0.25, length: f64::INFINITY }, "{t:?}");
            assert_eq!(t.validate(), Ok(()), "{t:?}");
        }
        assert_eq!(Tool::flat(1.0).shape(), CutterShape::Flat(Flat));
        assert_eq!(Tool::ball(1.0).shape(), CutterShape::Ball(Ball));
    }

    #[test]
    fn impossible_tools_name_the_field() {
        let msg = |t: Tool| t.validate().unwrap_err();
        assert!(msg(Tool::flat(-1.0)).contains("radius"));
        assert!(msg(Tool { feed: f64::NAN, ..Tool::flat(1.0) }).contains("feed"));
        assert!(msg(Tool { plunge_feed: 0.0, ..Tool::flat(1.0) }).contains("plunge_feed"));
        assert!(msg(Tool { spindle_rpm: -1.0, ..Tool::flat(1.0) }).contains("spindle_rpm"));
        assert!(msg(Tool::bull(1.0, 1.5)).contains("corner radius"));
        assert!(msg(Tool::bull(1.0, 0.0)).contains("corner radius"));
        let short =
            Tool { cutter: Cutter { flute_length: -1.0, ..Tool::flat(1.0).cutter }, ..Tool::flat(1.0) };
        assert!(msg(short).contains("flute_length"));
        let shank =
            Tool { cutter: Cutter { shank_radius: 0.0, ..Tool::flat(1.0).cutter }, ..Tool::flat(1.0) };
        assert!(msg(shank).contains("shank"));
        let ball = Tool::new(Cutter::ball(1.0, 1.5));
        assert!(msg(ball).contains("flute length"));
    }
}
