//! Which cutters a run machines with, at which feeds: the paper's planned flat end mills at
//! one feed, or the flat end mills of a shop's [`ToolLibrary`] at their cutting data in a
//! material on a machine.

use std::path::Path;
use std::sync::OnceLock;

use super::api::{MillError, MillOptions, Preset};
use crate::gcode::MachineProfile;
use crate::geom::{Aabb, CutterShape};
use crate::orient::{ReachTool, ToolReach};
use crate::toolpath::Tool;
use crate::toolpath::library::{Cutting, LibraryTool, Material, ToolLibrary};
use crate::voxsim::{Cutter, ToolTable};

/// The shipped tool library, `assets/tools/default.toml`: flat end mills of 1-12 mm, ball
/// end mills of 1-10 mm, two bull noses, four long-reach end mills and two T-slot
/// cutters, with cutting data for aluminium 6061, mild steel, POM and machining wax, on a
/// generic router.
pub fn default_tool_library() -> &'static ToolLibrary {
    static DEFAULT: OnceLock<ToolLibrary> = OnceLock::new();
    DEFAULT.get_or_init(|| {
        let text = include_str!("../../assets/tools/default.toml");
        // The file is part of the crate and a test reads it: it always parses.
        ToolLibrary::from_toml(text, Path::new("assets/tools/default.toml")).unwrap_or_default()
    })
}

/// The cutters of a run.
#[derive(Debug, Clone)]
pub(super) enum Tooling {
    /// The paper's: a flat end mill of any radius, its flutes as long as the stock's
    /// diagonal, at one feed and 12,000 rpm ([`planned_tool`]).
    Planned {
        /// The stock's diagonal (flute length).
        diag: f64,
        /// Cutting feed, mm/min.
        feed: f64,
    },
    /// A shop's: the library's flat end mills at their cutting data.
    Library(Box<Shop>),
}

/// A shop's tooling ([`Tooling::Library`]).
#[derive(Debug, Clone)]
pub(super) struct Shop {
    /// The flat end mills, by ascending radius.
    flats: Vec<LibraryTool>,
    /// Every tool of the library.
    all: Vec<LibraryTool>,
    /// The workpiece material.
    material: Material,
    /// The machine.
    machine: MachineProfile,
}

impl Shop {
    /// Library tool `t` as planned: its tool and its cutting data in the shop's material on
    /// its machine.
    fn planned(&self, t: &LibraryTool) -> Result<(Tool, Option<Cutting>), MillError> {
        Ok((
            t.tool(&self.material, &self.machine).map_err(library_error)?,
            Some(t.cutting(&self.material, &self.machine).map_err(library_error)?),
        ))
    }
}

/// A library's refusal (an unknown material, cutting data that give no feed) as an option
/// error.
fn library_error(e: crate::toolpath::library::LibraryError) -> MillError {
    MillError::InvalidOption(e.to_string())
}

impl Tooling {
    /// The tooling of `opts`: the paper preset's planned tools, or the shop preset's
    /// library ([`MillOptions::tools`], the shipped one by default) in
    /// [`MillOptions::material`].
    pub(super) fn new(opts: &MillOptions, diag: f64, feed: f64) -> Result<Self, MillError> {
        if opts.preset == Preset::Paper {
            if opts.tools.is_some() {
                return Err(MillError::InvalidOption(
                    "a tool library is for the shop preset; the paper preset machines with the paper's tools"
                        .into(),
                ));
            }
            return Ok(Self::Planned { diag, feed });
        }
        let lib = opts.library();
        let material = lib.material(&opts.material).map_err(library_error)?.clone();
        let machine = opts.machine.clone().or_else(|| lib.machine.clone()).unwrap_or_default();
        machine.validate().map_err(|e| MillError::InvalidOption(format!("machine: {e}")))?;
        let flats = flat_end_mills(lib);
        if flats.is_empty() {
            return Err(MillError::InvalidOption(
                "the tool library has no flat end mill to rough with".into(),
            ));
        }
        for t in &flats {
            t.cutting(&material, &machine).map_err(library_error)?;
        }
        Ok(Self::Library(Box::new(Shop { flats, all: lib.tools.clone(), material, machine })))
    }

    /// Every cutter the simulator must know, by tool number: the library's (finishing and
    /// rest tools included); none of the planned ones (the run adds those per radius).
    pub(super) fn library_cutters(&self) -> Vec<(u32, Cutter)> {
        match self {
            Self::Planned { .. } => Vec::new(),
            Self::Library(shop) => shop.all.iter().map(|t| (t.number, t.cutter)).collect(),
        }
    }

    /// The simulator's tool table: every tool of the action space's `radii` (in the paper
    /// preset T1 is the smallest radius) and every library tool (by its number).
    pub(super) fn tool_table(&self, radii: &[f64]) -> Result<ToolTable, MillError> {
        let first = radii.first().copied().unwrap_or(1.0);
        let mut tools = ToolTable::single(self.tool(first, 1, 0.0)?.0.cutter);
        for (i, &r) in radii.iter().enumerate() {
            let (tool, _) = self.tool(r, i as u32 + 1, 0.0)?;
            tools = tools.with(tool.number, tool.cutter);
        }
        for (number, cutter) in self.library_cutters() {
            tools = tools.with(number, cutter);
        }
        Ok(tools)
    }

    /// What a setup's tools reach below the stock's top, for orientation selection
    /// ([`ToolReach`]), tool-aware: each of the library's flat end mills (long-reach ones
    /// included) by its radius and its reach with its holder clear of the stock
    /// ([`Tool::envelope`]), which roughs, so that a narrow feature counts as reached only
    /// as deep as a tool that fits it cuts ([`ToolReach::of_tools`]); when `finishing`,
    /// its ball and bull-nose end mills, which finish, each no deeper than the deepest
    /// flat end mill. `None` for the paper's tools, whose flutes are as long as the
    /// stock's diagonal, or where the library has no such tool.
    ///
    /// Without `tool_aware` ([`MillOptions::tool_aware_reach`] false) one depth for
    /// every sample: the reach of the library's longest flat end mill (long-reach ones
    /// aside), and, when `finishing`, no deeper than its longest ball or bull-nose end mill.
    pub(super) fn reach(&self, stock: Aabb, finishing: bool, tool_aware: bool) -> Option<ToolReach> {
        let Self::Library(shop) = self else { return None };
        if !tool_aware {
            let reach = |t: &LibraryTool| Tool::new(t.cutter).envelope().length;
            let rough = shop.flats.iter().map(reach).fold(0.0, f64::max);
            let finish = shop
                .all
                .iter()
                .filter(|t| !matches!(t.cutter.shape, CutterShape::Flat(_) | CutterShape::TSlot(_)))
                .map(reach)
                .fold(0.0, f64::max);
            let depth = if finishing && finish > 0.0 { rough.min(finish) } else { rough };
            return (depth.is_finite() && depth > 0.0).then(|| ToolReach::new(stock, depth));
        }
        let reach = |t: &LibraryTool| ReachTool {
            radius: t.cutter.radius,
            depth: Tool::new(t.cutter).envelope().length,
        };
        let flats: Vec<ReachTool> =
            shop.all.iter().filter(|t| matches!(t.cutter.shape, CutterShape::Flat(_))).map(reach).collect();
        let rough = ToolReach::of_tools(stock, &flats)?;
        if !finishing {
            return Some(rough);
        }
        let rounded: Vec<ReachTool> = shop
            .all
            .iter()
            .filter(|t| !matches!(t.cutter.shape, CutterShape::Flat(_) | CutterShape::TSlot(_)))
            .map(|t| ReachTool { depth: reach(t).depth.min(rough.depth), ..reach(t) })
            .collect();
        ToolReach::of_tools(stock, &rounded).or(Some(rough))
    }

    /// Whether the library has a T-slot cutter ([`t_slot_tools`](Self::t_slot_tools)).
    pub(super) fn has_t_slot(&self) -> bool {
        matches!(self, Self::Library(shop) if shop.all.iter().any(|t| t.cutter.is_t_slot()))
    }

    /// The library's T-slot cutters with their cutting data, widest first (the lower
    /// number of equals); none in the paper preset.
    pub(super) fn t_slot_tools(&self) -> Result<Vec<(Tool, Option<Cutting>)>, MillError> {
        let Self::Library(shop) = self else { return Ok(Vec::new()) };
        let mut slots: Vec<&LibraryTool> = shop.all.iter().filter(|t| t.cutter.is_t_slot()).collect();
        slots.sort_by(|a, b| b.cutter.radius.total_cmp(&a.cutter.radius).then(a.number.cmp(&b.number)));
        slots.into_iter().map(|t| shop.planned(t)).collect()
    }

    /// The machine whose limits time the programs, where the tooling has one.
    pub(super) fn machine(&self) -> Option<&MachineProfile> {
        match self {
            Self::Planned { .. } => None,
            Self::Library(shop) => Some(&shop.machine),
        }
    }

    /// The tool of `radius`: the planned flat end mill numbered `number`, or the library's
    /// flat end mill of that radius (with the library's number; `number` is unused) with
    /// its cutting data. A library tool that cannot reach `depth` below the stock's top
    /// ([`Tool::envelope`]) gives way to the smallest larger flat end mill that can (or,
    /// where none can, the one that reaches deepest), as a machinist takes a longer tool
    /// rather than leave the setup half cut; the setup's report names the tool used. A
    /// radius the library lacks is an error that lists the radii it has.
    pub(super) fn tool(
        &self,
        radius: f64,
        number: u32,
        depth: f64,
    ) -> Result<(Tool, Option<Cutting>), MillError> {
        match self {
            Self::Planned { diag, feed } => Ok((planned_tool(radius, number, *diag, *feed), None)),
            Self::Library(shop) => {
                let flats = &shop.flats;
                let Some(i) = flats.iter().position(|t| t.cutter.radius == radius) else {
                    let have: Vec<String> =
                        flats.iter().map(|t| format!("{}", t.cutter.diameter())).collect();
                    return Err(MillError::InvalidOption(format!(
                        "the tool library has no flat end mill of diameter {} mm (it has {})",
                        2.0 * radius,
                        have.join(", ")
                    )));
                };
                let reach = |t: &LibraryTool| Tool::new(t.cutter).envelope().length;
                let t = flats[i..].iter().find(|t| reach(t) >= depth).unwrap_or_else(|| {
                    flats[i..].iter().max_by(|a, b| reach(a).total_cmp(&reach(b))).unwrap_or(&flats[i])
                });
                shop.planned(t)
            }
        }
    }
}

impl Tooling {
    /// The rest-roughing tool after roughing with a flat end mill of `radius`, in a setup
    /// whose stock is `depth` deep along its axis
    /// ([`MillOptions::rest_roughing`](super::MillOptions::rest_roughing)): of the
    /// library's flat end mills at most 0.7 times as wide, the one that reaches deepest
    /// into that depth ([`Cutter::reach`]: its flutes, a long-reach end mill's neck, a
    /// shank no wider than the flutes its stick-out; a rest pass cuts no deeper below the
    /// stock's top: `MillRun::rest_rough`), the widest of equals, a plain end mill before
    /// a long-reach one, with its cutting data; `None` in the paper preset or where the
    /// library has none that small.
    pub(super) fn rest_tool(
        &self,
        radius: f64,
        depth: f64,
    ) -> Result<Option<(Tool, Option<Cutting>)>, MillError> {
        self.ranked_rest_tool(radius, depth, |_| true)
    }

    /// Of the library's flat end mills at most 0.7 times as wide as one of `radius` that
    /// `keep` keeps, the one that reaches deepest into a stock `depth` deep ([`rest_tool`](Self::rest_tool)'s rule).
    fn ranked_rest_tool(
        &self,
        radius: f64,
        depth: f64,
        keep: impl Fn(&LibraryTool) -> bool,
    ) -> Result<Option<(Tool, Option<Cutting>)>, MillError> {
        let Self::Library(shop) = self else { return Ok(None) };
        // How deep the stack stays no wider than the flutes (`Cutter::reach`): a long-reach
        // end mill as deep as its neck. Of equals, a plain end mill (stiffer, with the
        // faster cutting data) is taken.
        let reach = |t: &LibraryTool| t.cutter.reach().min(depth);
        let Some(t) = shop
            .all
            .iter()
            .filter(|t| {
                matches!(t.cutter.shape, CutterShape::Flat(_))
                    && t.cutter.radius <= 0.7 * radius + 1e-9
                    && keep(t)
            })
            .max_by(|a, b| {
                reach(a)
                    .total_cmp(&reach(b))
                    .then(a.cutter.radius.total_cmp(&b.cutter.radius))
                    .then(b.cutter.neck.is_some().cmp(&a.cutter.neck.is_some()))
                    .then(b.number.cmp(&a.number))
            })
        else {
            return Ok(None);
        };
        shop.planned(t).map(Some)
    }

    /// A stiffer rest tool than the long-reach end mill `long`, the rest tool after one of
    /// `radius` in a stock `depth` deep ([`rest_tool`](Self::rest_tool)): of the tools that
    /// rule considers, reaching less deep than `long`, wider than it or as wide on a
    /// shorter neck, the one it would take. None where `long` has no neck (a plain end mill
    /// is the stiffest of its width) or no such tool is in the library. A rest pass takes
    /// it where it takes about as much as `long` (`MillRun::worth_a_pass`): the 2 mm end
    /// mill reaching 25 mm (T34) gives way to the plain 3 mm one on the L-bracket and the
    /// T-slot block, and to the 2 mm one reaching 12 mm in one of the turned shaft's
    /// setups.
    pub(super) fn stiffer_rest_tool(
        &self,
        radius: f64,
        depth: f64,
        long: &Tool,
    ) -> Result<Option<(Tool, Option<Cutting>)>, MillError> {
        let c = &long.cutter;
        if c.neck.is_none() {
            return Ok(None);
        }
        let deep = c.reach().min(depth);
        self.ranked_rest_tool(radius, depth, |t| {
            let wider = t.cutter.radius > c.radius;
            let as_wide_shorter = t.cutter.radius == c.radius && t.cutter.neck.is_some();
            t.cutter.reach().min(depth) < deep && (wider || as_wide_shorter)
        })
    }

    /// The finishing tool of a setup roughed with `rough` whose stock is `depth` deep along
    /// its axis. With `number`, that library tool (a ball or bull-nose end mill). Else the
    /// rule: the largest ball end mill of the library no wider than the roughing tool that
    /// reaches `depth` below the stock's top ([`Tool::envelope`]); where none reaches, the
    /// ball end mill that reaches deepest (the larger of equals), whose finishing stops at
    /// its reach. The paper preset finishes with a planned ball end mill of the roughing
    /// tool's radius, numbered 100 above it.
    pub(super) fn finishing_tool(
        &self,
        rough: &Tool,
        depth: f64,
        number: Option<u32>,
    ) -> Result<Tool, MillError> {
        let shop = match self {
            Self::Planned { diag, feed } => {
                let mut t = planned_tool(rough.radius(), rough.number + 100, *diag, *feed);
                t.cutter = Cutter::ball(rough.radius(), *diag);
                return Ok(t);
            }
            Self::Library(shop) => shop,
        };
        let rounded =
            |t: &&LibraryTool| matches!(t.cutter.shape, CutterShape::Ball(_) | CutterShape::BullNose(_));
        let reach = |t: &LibraryTool| Tool::new(t.cutter).envelope().length;
        let chosen = match number {
            Some(n) => shop.all.iter().filter(rounded).find(|t| t.number == n).ok_or_else(|| {
                MillError::InvalidOption(format!(
                    "the tool library has no ball or bull-nose end mill T{n} to finish with"
                ))
            })?,
            None => {
                let mut balls: Vec<&LibraryTool> =
                    shop.all.iter().filter(|t| matches!(t.cutter.shape, CutterShape::Ball(_))).collect();
                balls.sort_by(|a, b| {
                    b.cutter.radius.total_cmp(&a.cutter.radius).then(a.number.cmp(&b.number))
                });
                let fits = balls.iter().find(|t| t.cutter.radius <= rough.radius() && reach(t) >= depth);
                let deepest = || {
                    balls.iter().copied().max_by(|a, b| {
                        reach(a).total_cmp(&reach(b)).then(a.cutter.radius.total_cmp(&b.cutter.radius))
                    })
                };
                fits.copied().or_else(deepest).ok_or_else(|| {
                    MillError::InvalidOption("the tool library has no ball end mill to finish with".into())
                })?
            }
        };
        chosen.tool(&shop.material, &shop.machine).map_err(library_error)
    }
}

/// The flat end mills of `lib`, by ascending radius (the first of a radius kept).
pub(super) fn flat_end_mills(lib: &ToolLibrary) -> Vec<LibraryTool> {
    let mut flats: Vec<LibraryTool> =
        lib.tools.iter().filter(|t| matches!(t.cutter.shape, CutterShape::Flat(_))).cloned().collect();
    flats.sort_by(|a, b| a.cutter.radius.total_cmp(&b.cutter.radius).then(a.number.cmp(&b.number)));
    flats.dedup_by(|b, a| a.cutter.radius == b.cutter.radius);
    flats
}

/// The tool a setup is planned with in the paper preset, whose cutter the simulator cuts
/// with (tool `number` of its table): a flat end mill of `radius` with flutes as long as
/// the stock's diagonal `diag`, at the cutting `feed`, a third of it for plunges, and
/// 12,000 rpm.
pub(super) fn planned_tool(radius: f64, number: u32, diag: f64, feed: f64) -> Tool {
    Tool {
        feed,
        plunge_feed: feed / 3.0,
        spindle_rpm: 12000.0,
        number,
        ..Tool::new(Cutter::flat(radius, diag))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With the shipped library, the 2 mm end mill reaching 25 mm (T34) is the rest tool
    /// after the 4 and 5 mm end mills in a stock deeper than the others reach; the stiffer
    /// tool in its place is the plain 3 mm one after the 5 mm (wider) and the 2 mm one
    /// reaching 12 mm after the 4 mm (as wide, a shorter neck). Where the stock is no
    /// deeper than 12 mm the 12 mm one is the rest tool, and none is stiffer in the rule's
    /// sense (the plain 2 mm one is as wide, with no neck), nor than a plain end mill.
    #[test]
    fn a_long_reach_rest_tool_gives_way_to_a_stiffer_one() {
        let opts = MillOptions { preset: Preset::Shop, ..MillOptions::default() };
        let tooling = Tooling::new(&opts, 100.0, 1000.0).expect("the shop tooling");
        let rest =
            |radius: f64, depth: f64| tooling.rest_tool(radius, depth).expect("rest").expect("a tool").0;
        let stiffer = |radius: f64, depth: f64, t: &Tool| {
            tooling.stiffer_rest_tool(radius, depth, t).expect("stiffer").map(|s| s.0.number)
        };
        let after_5 = rest(2.5, 40.0);
        let after_4 = rest(2.0, 40.0);
        assert_eq!((after_5.number, after_4.number), (34, 34));
        assert_eq!(stiffer(2.5, 40.0, &after_5), Some(3));
        assert_eq!(stiffer(2.0, 40.0, &after_4), Some(32));
        let shallow = rest(2.0, 10.0);
        assert_eq!(shallow.number, 32);
        assert_eq!(stiffer(2.0, 10.0, &shallow), None);
        let plain = rest(4.0, 40.0);
        assert!(plain.cutter.neck.is_none());
        assert_eq!(stiffer(4.0, 40.0, &plain), None);
    }
}
