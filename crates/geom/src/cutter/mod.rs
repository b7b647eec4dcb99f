//! One vocabulary for a milling cutter: its end shape, flutes, shank and holder. The
//! planner (`s2g-toolpath`), the simulator (`s2g-voxsim`), feature programs and the
//! field crate's collision model all describe a physical cutter with [`Cutter`], so a
//! planned tool and a simulated one cannot drift apart.
//!
//! Along the tool axis, measured from the tip (the programmed point) towards the spindle,
//! a cutter is a stack of solids of revolution: the cutting end (flat disc, hemisphere or
//! torus-rounded disc) and flutes of [`Cutter::radius`] up to [`Cutter::flute_length`];
//! on a long-reach (necked) end mill the relieved neck of [`Neck::radius`] up to
//! [`Neck::reach`] (a T-slot cutter is the same stack, its flutes a short disc wider than
//! the neck); the shank of [`Cutter::shank_radius`] up to [`Cutter::stickout`]; then
//! the holder's
//! cylinder, when one is modelled. [`Cutter::radius_at`] gives the stack's radius at any
//! height.
//!
//! # Adding an end shape
//!
//! 1. Write one file in this folder, `cutter/<name>.rs`, with a type implementing
//!    [`EndShape`] (its corner radius, profile and the [`Solid`]s its flutes are swept as).
//! 2. Add one line `Variant => <name>,` to the `cutter_shapes!` list in `cutter/mod.rs`.
//!
//! The simulator sweeps the shape's solids and the planners read its corner radius and
//! profile, so nothing else changes. A shape that needs a solid this vocabulary lacks (a
//! cone, for tapered and chamfer mills) needs that solid here and its exact sweep in
//! voxsim's `sweep.rs` as well.

use crate::error::{GeomError, Result};

/// One solid of revolution about the tool axis, at heights measured from the tip: what a
/// cutter's fluted part is made of, and what a simulator sweeps along a move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solid {
    /// A cylinder of radius `r` between heights `h0` and `h1`.
    Cylinder {
        /// Bottom height.
        h0: f64,
        /// Top height.
        h1: f64,
        /// Radius.
        r: f64,
    },
    /// A ball of radius `r` centred at height `c`.
    Ball {
        /// Centre height.
        c: f64,
        /// Radius.
        r: f64,
    },
    /// A disc of radius `rp` rounded by a torus of tube radius `rc`, centred at height `c`
    /// (every point within `rc` of the disc): a bull nose's end.
    Torus {
        /// Centre height of the disc.
        c: f64,
        /// Radius of the flat disc.
        rp: f64,
        /// Tube (corner) radius.
        rc: f64,
    },
}

/// The solids of a cutter's fluted part, tip first: at most [`Solids::CAPACITY`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solids {
    items: [Solid; Solids::CAPACITY],
    len: usize,
}

impl Solids {
    /// The most solids one cutter's flutes may be made of.
    pub const CAPACITY: usize = 3;

    /// The solids of `list` (at most [`Solids::CAPACITY`]; more are left out).
    pub fn new(list: &[Solid]) -> Self {
        let empty = Solid::Cylinder { h0: 0.0, h1: 0.0, r: 0.0 };
        let mut items = [empty; Self::CAPACITY];
        let len = list.len().min(Self::CAPACITY);
        items[..len].copy_from_slice(&list[..len]);
        Self { items, len }
    }

    /// The solids, tip first.
    pub fn as_slice(&self) -> &[Solid] {
        &self.items[..self.len]
    }
}

/// What a cutter's end shape says about itself: the profile planners read and the solids a
/// simulator sweeps. One implementation per file in `cutter/`, registered in the
/// `cutter_shapes!` list of this module.
pub trait EndShape {
    /// The name, lower case (`flat`, `ball`, `bull`).
    fn name(&self) -> &'static str;

    /// The radius of the arc that rounds the end's rim for a cutter of `radius`: 0 for a
    /// sharp corner, `radius` for a ball.
    fn corner_radius(&self, radius: f64) -> f64;

    /// The end's radius at height `h` above the tip, for `0 <= h <` [`corner_radius`]
    /// (where the end meets the flutes' cylinder).
    ///
    /// [`corner_radius`]: EndShape::corner_radius
    fn profile(&self, radius: f64, h: f64) -> f64;

    /// The solids of the fluted part of a cutter of `radius` whose flutes reach
    /// `flute_length` above the tip, tip first.
    fn solids(&self, radius: f64, flute_length: f64) -> Solids;

    /// Checks what the shape has beyond its corner radius (which [`Cutter::validate`]
    /// checks for every shape); the message names the field. Default: nothing to check.
    fn validate(&self, radius: f64, flute_length: f64) -> std::result::Result<(), String> {
        let _ = (radius, flute_length);
        Ok(())
    }
}

/// Declares the shape modules, [`CutterShape`] with one variant per shape, and its
/// dispatch to each shape's [`EndShape`], from one `Variant => module` line per shape (each
/// module defines the type `Variant`).
macro_rules! cutter_shapes {
    ($($(#[doc = $doc:literal])* $variant:ident => $module:ident,)+) => {
        $(mod $module;)+
        $(pub use self::$module::$variant;)+

        /// The shape of a cutter's end: one of the shapes of `cutter/`, each an
        /// [`EndShape`].
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub enum CutterShape {
            $($(#[doc = $doc])* $variant($variant),)+
        }

        impl CutterShape {
            /// The shape as an [`EndShape`].
            pub fn end(&self) -> &dyn EndShape {
                match self {
                    $(CutterShape::$variant(s) => s,)+
                }
            }
        }
    };
}

cutter_shapes! {
    /// Flat end mill: a cylinder whose bottom face is the tip plane.
    Flat => flat,
    /// Ball end mill: a hemisphere of the tool radius at the bottom.
    Ball => ball,
    /// Bull nose (corner radius) end mill: a flat bottom rounded by a torus.
    BullNose => bull,
    /// T-slot cutter: a disc (the flutes) on a narrower neck, cutting undercuts from the
    /// side.
    TSlot => tslot,
}

/// The relieved neck of a long-reach end mill: a non-cutting cylinder no wider than the
/// flutes from their top up to `reach` above the tip, so that the short flutes reach down
/// a narrow feature as deep as the neck is long, the shank staying above it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neck {
    /// Radius in mm (`> 0`, at most the cutting radius).
    pub radius: f64,
    /// Tip to the neck's top in mm (`>` the flute length, `<=` the stick-out).
    pub reach: f64,
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
/// Regions along the axis: flutes (cutting) on `[0, flute_length]`; the neck (if any) of
/// radius `neck.radius` on `(flute_length, neck.reach]`; shank of radius `shank_radius` on
/// the rest up to `stickout`; holder (if any) on `[stickout, stickout + holder.length]`.
/// Only the flutes remove material; stock met by the neck, shank or holder is reported
/// as a holder collision.
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
    /// The relieved neck of a long-reach end mill, if any.
    pub neck: Option<Neck>,
}

impl Cutter {
    fn with_shape(shape: CutterShape, radius: f64, flute_length: f64) -> Self {
        Self {
            shape,
            radius,
            flute_length,
            shank_radius: radius,
            stickout: 2.0 * flute_length,
            holder: None,
            neck: None,
        }
    }

    /// A flat end mill; shank radius = `radius`, stick-out = `2 * flute_length`, no holder.
    pub fn flat(radius: f64, flute_length: f64) -> Self {
        Self::with_shape(CutterShape::Flat(Flat), radius, flute_length)
    }

    /// A ball end mill; defaults as for [`Cutter::flat`].
    pub fn ball(radius: f64, flute_length: f64) -> Self {
        Self::with_shape(CutterShape::Ball(Ball), radius, flute_length)
    }

    /// A bull nose end mill; defaults as for [`Cutter::flat`].
    pub fn bull(radius: f64, corner_radius: f64, flute_length: f64) -> Self {
        Self::with_shape(CutterShape::BullNose(BullNose { corner_radius }), radius, flute_length)
    }

    /// A T-slot cutter: a disc of `radius` and thickness `thickness` (the flute length) on
    /// a neck of `neck_radius` up to `reach` above the tip; shank of the neck's radius to a
    /// stick-out of `reach`, no holder.
    pub fn t_slot(radius: f64, thickness: f64, neck_radius: f64, reach: f64) -> Self {
        Self {
            shank_radius: neck_radius,
            stickout: reach,
            neck: Some(Neck { radius: neck_radius, reach }),
            ..Self::with_shape(CutterShape::TSlot(TSlot), radius, thickness)
        }
    }

    /// Whether the cutter is a T-slot (disc) cutter, which cuts only from the side.
    pub fn is_t_slot(&self) -> bool {
        matches!(self.shape, CutterShape::TSlot(_))
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
            self.shape.end().profile(self.radius, h)
        } else if h <= self.flute_length {
            self.radius
        } else if let Some(neck) = self.neck.filter(|n| h <= n.reach.min(self.stickout)) {
            neck.radius
        } else if h <= self.stickout {
            self.shank_radius
        } else {
            match self.holder {
                Some(holder) if h <= self.stickout + holder.length => holder.radius,
                _ => 0.0,
            }
        }
    }

    /// Where the shank starts above the tip: the neck's reach, else the flutes' top.
    pub fn shank_start(&self) -> f64 {
        self.neck.map_or(self.flute_length, |n| n.reach.min(self.stickout))
    }

    /// How far above the tip the stack is no wider than the flutes (the height a plan of
    /// the cutting radius may take the tip below what it cut, the rest of the stack
    /// following the flutes down): the flutes' length; the neck's reach with a neck; the
    /// stick-out where the shank is no wider as well.
    pub fn reach(&self) -> f64 {
        let slim = self.neck.map_or(self.flute_length, |n| n.reach.min(self.stickout));
        if self.shank_radius <= self.radius { self.stickout.max(self.flute_length) } else { slim }
    }

    /// The corner radius: 0 for flat, `radius` for ball ([`EndShape::corner_radius`]).
    pub fn corner_radius(&self) -> f64 {
        self.shape.end().corner_radius(self.radius)
    }

    /// The solids of the fluted part, tip first ([`EndShape::solids`]): what a simulator
    /// sweeps.
    pub fn cutting_solids(&self) -> Solids {
        self.shape.end().solids(self.radius, self.flute_length)
    }

    /// Checks the dimensions: every length finite; `radius > 0`; `0 <= corner_radius <= radius`;
    /// `flute_length > 0` and `>= 2 * corner_radius` (the rounded end must be all flute);
    /// `shank_radius > 0`; `stickout >= flute_length`; holder radius and length `> 0`; the
    /// neck's radius in `(0, radius]` and its reach in `(flute_length, stickout]`; a T-slot
    /// cutter has a neck, narrower than its disc.
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
        if let Err(m) = self.shape.end().validate(self.radius, self.flute_length) {
            return bad(m);
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
        if let Some(n) = self.neck
            && !(pos(n.radius)
                && n.radius <= self.radius
                && n.reach.is_finite()
                && n.reach > self.flute_length
                && n.reach <= self.stickout)
        {
            return bad(format!(
                "neck radius must be in (0, radius = {}] and its reach in (flute length = {}, stick-out = {}], got {n:?}",
                self.radius, self.flute_length, self.stickout
            ));
        }
        if self.is_t_slot() && !self.neck.is_some_and(|n| n.radius < self.radius) {
            return bad(format!(
                "a T-slot cutter needs a neck narrower than its disc (radius {}), got {:?}",
                self.radius, self.neck
            ));
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
        // A long-reach end mill: 1 mm flutes, a neck to 6 mm, a 3 mm shank.
        let mut n = Cutter::flat(0.5, 1.0);
        n.shank_radius = 1.5;
        n.stickout = 12.0;
        n.neck = Some(Neck { radius: 0.45, reach: 6.0 });
        n.validate().expect("valid");
        assert_eq!(n.radius_at(1.0), 0.5);
        assert_eq!(n.radius_at(1.01), 0.45);
        assert_eq!(n.radius_at(6.0), 0.45);
        assert_eq!(n.radius_at(6.01), 1.5);
        assert_eq!((n.shank_start(), n.reach()), (6.0, 6.0));
        assert_eq!(Cutter { neck: None, ..n }.reach(), 1.0);
        for bad in [
            Neck { radius: 0.55, reach: 6.0 },
            Neck { radius: 0.45, reach: 0.5 },
            Neck { radius: 0.45, reach: 13.0 },
        ] {
            assert!(Cutter { neck: Some(bad), ..n }.validate().is_err(), "{bad:?}");
        }
        let ball = Cutter::ball(2.0, 8.0);
        assert_eq!(ball.radius_at(0.0), 0.0);
        assert!((ball.radius_at(2.0) - 2.0).abs() < 1e-12);
        assert_eq!(Cutter::flat(2.0, 8.0).radius_at(0.0), 2.0);
        assert_eq!(ball.diameter(), 4.0);
    }

    /// The radius of the union of `solids` at height `h`.
    fn solids_radius_at(solids: &Solids, h: f64) -> f64 {
        let cap =
            |r: f64, d: f64| if d.abs() <= r { (r * r - d * d).max(0.0).sqrt() } else { f64::NEG_INFINITY };
        solids
            .as_slice()
            .iter()
            .map(|s| match *s {
                Solid::Cylinder { h0, h1, r } if (h0..=h1).contains(&h) => r,
                Solid::Cylinder { .. } => f64::NEG_INFINITY,
                Solid::Ball { c, r } => cap(r, h - c),
                Solid::Torus { c, rp, rc } => rp + cap(rc, h - c),
            })
            .fold(0.0, f64::max)
    }

    /// Every shape's solids are its profile: the union's radius at each height of the
    /// flutes is [`Cutter::radius_at`] (what the planners read is what the simulator cuts).
    #[test]
    fn every_shape_s_solids_have_its_profile() {
        let cutters = [
            Cutter::flat(3.0, 10.0),
            Cutter::ball(3.0, 10.0),
            Cutter::bull(3.0, 1.0, 10.0),
            Cutter::bull(3.0, 0.0, 10.0),
            Cutter::bull(3.0, 3.0, 10.0),
        ];
        for c in cutters {
            assert!(c.validate().is_ok(), "{c:?}");
            let solids = c.cutting_solids();
            assert!(!solids.as_slice().is_empty());
            for i in 0..=1000 {
                let h = c.flute_length * i as f64 / 1000.0;
                let (want, got) = (c.radius_at(h), solids_radius_at(&solids, h));
                assert!(
                    (want - got).abs() < 1e-9,
                    "{}: at h = {h}: profile {want}, solids {got}",
                    c.shape.end().name()
                );
            }
        }
        assert_eq!(
            [Cutter::flat(1.0, 2.0), Cutter::ball(1.0, 2.0), Cutter::bull(1.0, 0.5, 2.0)]
                .map(|c| c.shape.end().name()),
            ["flat", "ball", "bull"]
        );
    }

    /// A T-slot cutter (DIN 851, 12 mm slot): a 21 mm disc 9 mm thick on a 10 mm neck. Its
    /// stack is the disc, then the neck to its reach, then the shank; a neck no longer
    /// than the disc, none at all or one as wide as the disc is refused.
    #[test]
    fn a_t_slot_cutter_is_a_disc_on_a_narrower_neck() {
        let mut t = Cutter::t_slot(10.5, 9.0, 5.0, 30.0);
        t.shank_radius = 6.0;
        t.stickout = 40.0;
        t.validate().expect("valid");
        assert!(t.is_t_slot() && !Cutter::flat(1.0, 2.0).is_t_slot());
        assert_eq!(t.shape.end().name(), "tslot");
        assert_eq!([t.radius_at(0.0), t.radius_at(9.0)], [10.5, 10.5]);
        assert_eq!([t.radius_at(9.01), t.radius_at(30.0)], [5.0, 5.0]);
        assert_eq!([t.radius_at(30.01), t.radius_at(40.0), t.radius_at(40.1)], [6.0, 6.0, 0.0]);
        assert_eq!(t.shank_start(), 30.0);
        let solids = t.cutting_solids();
        for h in [0.0, 4.5, 9.0] {
            assert_eq!(solids_radius_at(&solids, h), t.radius_at(h));
        }
        for neck in [
            Some(Neck { radius: 5.0, reach: 9.0 }),
            Some(Neck { radius: 5.0, reach: 6.0 }),
            Some(Neck { radius: 10.5, reach: 30.0 }),
            None,
        ] {
            assert!(Cutter { neck, ..t }.validate().is_err(), "{neck:?}");
        }
        assert!(Cutter::t_slot(10.5, 9.0, 5.0, 30.0).validate().is_ok());
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
