//! Controller dialects as data: each [`Dialect`] has one [`DialectSpec`] that says what
//! the writers do differently for that controller (comment syntax, program delimiters,
//! dwell words, tool changes, arcs, drill cycles, number format, footer, extrusion).
//! The writer ([`crate::GcodeWriter`]) branches on these fields, never on dialect names.
//!
//! # Adding a dialect
//!
//! 1. Write one file in this folder, `dialect/<name>.rs`, defining
//!    `pub(super) const SPEC: DialectSpec` (copy the closest existing dialect).
//! 2. Add one registration line to the `dialects!` list below: the variant's doc comment
//!    and `Variant => module`. That declares the module, the [`Dialect`] variant, its
//!    [`Dialect::spec`] arm and its place in [`Dialect::ALL`]; [`FromStr`] and
//!    [`fmt::Display`] then accept and print its [`DialectSpec::name`].

use std::fmt;
use std::str::FromStr;

mod spec;

pub use spec::{
    AutoRetract, CommentStyle, DialectSpec, DrillCycles, DwellDecimals, DwellFormat, TimeUnit, ToolChange,
};

/// Declares the dialect modules, [`Dialect`], [`Dialect::ALL`] and [`Dialect::spec`] from
/// one `Variant => module` line per dialect (each module defines `SPEC`).
macro_rules! dialects {
    ($($(#[doc = $doc:literal])* $variant:ident => $module:ident,)+) => {
        $(mod $module;)+

        /// Target controller family. Each has a [`DialectSpec`] ([`Dialect::spec`]);
        /// [`FromStr`] and [`fmt::Display`] use its lower-case [`DialectSpec::name`].
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Dialect {
            $($(#[doc = $doc])* $variant,)+
        }

        impl Dialect {
            /// Every dialect, in declaration order.
            pub const ALL: &'static [Dialect] = &[$(Dialect::$variant),+];

            /// What the writers do for this dialect.
            pub fn spec(&self) -> &'static DialectSpec {
                match self {
                    $(Dialect::$variant => &$module::SPEC,)+
                }
            }
        }
    };
}

dialects! {
    /// LinuxCNC / RS274NGC.
    LinuxCnc => linuxcnc,
    /// grbl 1.1 (hobby CNC): no tool changer, no multi-turn arcs.
    Grbl => grbl,
    /// Fanuc-style milling controls: `%` delimiters, O-number, points on whole numbers.
    Fanuc => fanuc,
    /// Marlin (FDM printers): E axis, `;` comments, slicer markers.
    Marlin => marlin,
}

/// The name given to [`Dialect::from_str`] is not a dialect.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown dialect {name:?} (expected one of: {})", names(Dialect::ALL.iter()))]
pub struct UnknownDialect {
    /// The name as given.
    pub name: String,
}

/// A dialect without rotary axes was asked for a rotary (3+2) program.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "dialect {dialect} has no rotary axes (dialects with rotary axes: {})",
    names(Dialect::ALL.iter().filter(|d| d.has_rotary_axes()))
)]
pub struct NoRotaryAxes {
    /// The dialect asked for.
    pub dialect: Dialect,
}

fn names<'a>(ds: impl Iterator<Item = &'a Dialect>) -> String {
    ds.map(|d| d.spec().name).collect::<Vec<_>>().join(", ")
}

impl Dialect {
    /// Whether the dialect has rotary axes for 3+2 programs (LinuxCNC and Fanuc do; grbl
    /// and Marlin do not). The one check for every caller that writes rotary words.
    pub fn has_rotary_axes(&self) -> bool {
        self.spec().rotary_axes
    }

    /// [`Self::has_rotary_axes`] as a `Result` whose error names the dialect.
    pub fn require_rotary_axes(&self) -> Result<(), NoRotaryAxes> {
        if self.has_rotary_axes() { Ok(()) } else { Err(NoRotaryAxes { dialect: *self }) }
    }
}

impl FromStr for Dialect {
    type Err = UnknownDialect;

    /// A dialect by its [`DialectSpec::name`], in any case (`linuxcnc`, `GRBL`, ...).
    fn from_str(s: &str) -> Result<Self, UnknownDialect> {
        Dialect::ALL
            .iter()
            .copied()
            .find(|d| d.spec().name.eq_ignore_ascii_case(s))
            .ok_or_else(|| UnknownDialect { name: s.to_owned() })
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.spec().name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        let want = ["linuxcnc", "grbl", "fanuc", "marlin"];
        assert_eq!(Dialect::ALL.len(), want.len());
        for (d, name) in Dialect::ALL.iter().zip(want) {
            assert_eq!(d.to_string(), name);
            assert_eq!(name.parse::<Dialect>(), Ok(*d));
            assert_eq!(name.to_ascii_uppercase().parse::<Dialect>(), Ok(*d));
            assert_eq!(d.to_string().parse::<Dialect>(), Ok(*d));
        }
        assert_eq!("LinuxCNC".parse::<Dialect>(), Ok(Dialect::LinuxCnc));
        assert_eq!("Marlin".parse::<Dialect>(), Ok(Dialect::Marlin));
        for bad in ["", "linux", "grbl ", "fanuc0", "reprap"] {
            let e = bad.parse::<Dialect>().expect_err(bad);
            assert_eq!(e.name, bad);
            assert_eq!(
                e.to_string(),
                format!("unknown dialect {bad:?} (expected one of: linuxcnc, grbl, fanuc, marlin)")
            );
        }
    }

    #[test]
    fn rotary_capability() {
        let with: Vec<Dialect> = Dialect::ALL.iter().copied().filter(Dialect::has_rotary_axes).collect();
        assert_eq!(with, [Dialect::LinuxCnc, Dialect::Fanuc]);
        assert_eq!(Dialect::Fanuc.require_rotary_axes(), Ok(()));
        let e = Dialect::Grbl.require_rotary_axes().expect_err("grbl has no rotary axes");
        assert_eq!(e, NoRotaryAxes { dialect: Dialect::Grbl });
        assert_eq!(
            e.to_string(),
            "dialect grbl has no rotary axes (dialects with rotary axes: linuxcnc, fanuc)"
        );
        assert!(Dialect::Marlin.require_rotary_axes().is_err());
    }

    #[test]
    fn specs_are_consistent() {
        for d in Dialect::ALL {
            let s = d.spec();
            assert_eq!(s.name, s.name.to_ascii_lowercase(), "{d:?}");
            assert!(s.display_name.eq_ignore_ascii_case(s.name), "{d:?}");
            // Only dialects that write an end need spindle/coolant stops before it.
            assert!(s.program_end.is_some() || s.footer_stops.is_empty(), "{d:?}");
        }
    }
}
