//! [`finish_setup`]: a finishing strategy's cutter-location polylines as motions, with the
//! tool change, rapids on a clearance plane, a plunge into each pass and gouge-checked
//! links at cutting height.
//!
//! Safety argument: every pass point is a drop-cutter height over the part (the finisher
//! keeps the part exactly, allowance 0), and every feed, along a pass or between passes, is
//! checked by the drop-cutter at samples [`FinishOptions::link_check_step`] apart: a chord
//! that would cut in (where the cutter-location surface jumps at a wall, or across a corner
//! of a waterline loop) becomes a step up, across and down when that is clear, else a
//! retract and a new entry, so a feed gouges at most between samples. Between passes the tool either feeds
//! straight at cutting height, when the link is short and the drop-cutter finds no
//! interference at samples [`FinishOptions::link_check_step`] apart along it, or it goes up
//! to the clearance plane, across, and down by rapid to [`FinishOptions::approach`] above
//! the next pass's start, then feeds in at the plunge feed. The approach must exceed what
//! the roughing left above the part (its allowance plus its layer steps).

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use s2g_gcode::{
    ArcSpec, Coolant, FitSide, Motion, MotionSink, PlanarFitOptions, PlanarPiece, Plane, SpindleDirection,
    fit_planar, plane_axes,
};
use s2g_geom::{Cutter, DropCutter, Mesh, MeshIndex, Point3, Setup, Similarity3};

pub use super::guard::LeftOut;
use super::guard::{Guard, RoughedStock};
use super::{FinishContext, FinishingStrategy};
use crate::error::ToolpathError;
use crate::link::book_move;
use crate::tool::Tool;

/// Options of [`finish_setup_opt`] (lengths in the mesh's units, mm for real parts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinishOptions {
    /// Scallop height allowed. Default `0.01`.
    pub scallop: f64,
    /// XY rectangle `[min, max]` of tool-centre positions to finish; `None` (default): the
    /// part's bounding box grown by the tool radius.
    pub region: Option<[[f64; 2]; 2]>,
    /// Lowest tip height finished; `None` (default): the part's lowest point.
    pub floor: Option<f64>,
    /// Height of the clearance plane above the part's top, where rapids cross. Default `5`.
    pub clearance: f64,
    /// Height above a pass's start down to which the tool rapids before feeding in.
    /// Default `1`.
    pub approach: f64,
    /// Longest link between passes fed straight at cutting height. Default `2.0`.
    pub max_link: f64,
    /// Spacing of the drop-cutter checks along such a link. Default `0.05`.
    pub link_check_step: f64,
    /// Longest link between passes (in XY) that may follow the part's surface: where the
    /// straight link is too long or not clear, the tool feeds from one pass to the next
    /// along the drop-cutter surface over the straight line between them (a short pass of
    /// its own, every chord checked as a pass's is), when that takes less time than
    /// leaving and entering again (a rise, a crossing and a plunge at the plunge feed).
    /// `0`: never. Default `25`.
    pub max_surface_link: f64,
    /// A link point may dip this far below the drop-cutter height. Default `1e-4`.
    pub link_tolerance: f64,
    /// Every pass point is raised this far above the drop-cutter height: the strategies
    /// sample the cutter-location surface to a chord tolerance (0.002 by default), and on
    /// a convex surface a chord between two points lies up to that far below it, which
    /// would cut into the part (or, checked, make the chord a lift over it). Raised by the
    /// chord tolerance, the chords stay above the surface and the finish leaves at most
    /// twice that on the part, far under a scallop. Default `0.002`.
    pub pass_lift: f64,
    /// Rapid rate for the time estimate (units per minute). Default `5000`.
    pub rapid_feed: f64,
    /// Flood coolant on during finishing. Default `true`.
    pub coolant: bool,
    /// The most material the roughing can have left on the part (its allowance and layer
    /// steps, measured along the surface's normal). With it, the tool moves by rapid only
    /// where it is at least this far from the part: it rapids down to the height over a
    /// pass's start where the cutter grown by this much touches the part and plunges from
    /// there; it leaves a pass by feeding up to that height over its end; and between two
    /// passes it crosses at the highest such height along the way (sampled every
    /// [`FinishOptions::hop_step`]) when that is below the clearance plane. `None`
    /// (default): rapids down to [`FinishOptions::approach`] above a pass's start and
    /// retracts to the clearance plane, which is safe where the passes start and end on
    /// gentle slopes (beside a steep wall the cutter's side meets the stock left on it).
    pub stock_left: Option<f64>,
    /// Sampling step of the crossing height between passes. Default `0.25`.
    pub hop_step: f64,
    /// With a filter on the points ([`finish_setup_keep`]), a run of left-out points
    /// shorter than this (along the pass) between two kept ones is machined anyway.
    /// Default `20`.
    pub max_skip_gap: f64,
    /// Fit each pass that lies in the ZX or YZ plane (parallel passes along X or Y) with
    /// G18/G19 arcs and lines within this tolerance above its points; `None` (default):
    /// every point a straight move. A piece is taken only where it lies above the pass
    /// (never nearer the part) and the drop-cutter finds it clear at samples
    /// [`link_check_step`](Self::link_check_step) apart, as a straight move must be; where
    /// the cutter-location surface bulges above a chord, an arc over it replaces the step
    /// up, across and down.
    pub arc_tolerance: Option<f64>,
    /// What the roughing left, for the shank and holder check (`finish/guard.rs`): every
    /// pass point, link, lift and crossing keeps the tool's shank and holder clear of it;
    /// pass points where they are not are left out ([`FinishSummary::guarded_points`]), and
    /// the tool crosses above it. `None` (default): no check (a tool with neither shank nor
    /// holder is never checked).
    pub holder_stock: Option<RoughedStock>,
}

impl Default for FinishOptions {
    fn default() -> Self {
        Self {
            scallop: 0.01,
            region: None,
            floor: None,
            clearance: 5.0,
            approach: 1.0,
            max_link: 2.0,
            link_check_step: 0.05,
            max_surface_link: 25.0,
            link_tolerance: 1e-4,
            pass_lift: 0.002,
            rapid_feed: 5000.0,
            coolant: true,
            max_skip_gap: 20.0,
            stock_left: None,
            hop_step: 0.25,
            arc_tolerance: None,
            holder_stock: None,
        }
    }
}

/// What [`finish_setup_opt`] emitted.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FinishSummary {
    /// Passes (polylines) machined.
    pub passes: usize,
    /// Links fed at cutting height between passes.
    pub links: usize,
    /// Retracts to the clearance plane.
    pub retracts: usize,
    /// Crossings between passes below the clearance plane ([`FinishOptions::stock_left`]).
    pub hops: usize,
    /// Length of feed moves (passes, links and plunges).
    pub cutting_length: f64,
    /// Length of rapid moves.
    pub rapid_length: f64,
    /// Machining time in seconds: feeds at the tool's feed (plunges at its plunge feed),
    /// rapids at [`FinishOptions::rapid_feed`].
    pub time_s: f64,
    /// The clearance plane's height (setup frame).
    pub clear_z: f64,
    /// Pass points left out because the tool's shank or holder would meet the stock
    /// there ([`FinishOptions::holder_stock`]).
    pub guarded_points: usize,
}

/// The part mesh, given in the part frame, in `setup`'s frame (tool axis +Z): what
/// [`finish_setup`] takes, indexed.
pub fn part_in_setup_frame(part: &Mesh, setup: &Setup) -> Mesh {
    part.transformed(&Similarity3::from_isometry(setup.frame.inverse(), 1.0))
}

/// [`finish_setup_opt`] with the default options.
pub fn finish_setup<S: MotionSink>(
    part: &MeshIndex,
    setup: &Setup,
    tool: &Tool,
    strategy: &dyn FinishingStrategy,
    sink: &mut S,
) -> Result<FinishSummary, ToolpathError<S::Error>> {
    finish_setup_opt(part, setup, tool, strategy, &FinishOptions::default(), sink)
}

/// Finishes `part` (indexed in the setup frame: see [`part_in_setup_frame`]) in `setup`
/// with `tool` and `strategy`, writing to `sink`: the setup frame, a comment, the tool
/// change, spindle and coolant on, then each pass (rapid over it on the clearance plane,
/// rapid down to [`FinishOptions::approach`] above it, plunge at the plunge feed, feed
/// along it), short gouge-free links fed at cutting height, and at the end a retract,
/// coolant and spindle off. The finisher keeps the part exactly (allowance 0).
/// [`ToolpathError::InvalidTool`] for an impossible tool, [`ToolpathError::InvalidOptions`]
/// for an option out of range, [`ToolpathError::Finish`] for a strategy that failed, [`ToolpathError::Sink`] when the
/// sink refuses a motion. Same input, same motions.
pub fn finish_setup_opt<S: MotionSink>(
    part: &MeshIndex,
    setup: &Setup,
    tool: &Tool,
    strategy: &dyn FinishingStrategy,
    opts: &FinishOptions,
    sink: &mut S,
) -> Result<FinishSummary, ToolpathError<S::Error>> {
    finish_setup_keep(part, setup, tool, strategy, opts, None, sink)
}

/// Which cutter-location points of a finishing strategy to machine ([`finish_setup_keep`]):
/// rest finishing leaves out where an earlier setup has finished the surface already.
pub trait KeepPoint: Sync {
    /// Whether to machine the tool-tip position `tip` (setup frame).
    fn keep(&self, tip: &Point3) -> bool;
}

impl<F: Fn(&Point3) -> bool + Sync> KeepPoint for F {
    fn keep(&self, tip: &Point3) -> bool {
        self(tip)
    }
}

/// [`finish_setup_opt`] machining only the strategy's points that `keep` accepts (all
/// with `None`): each pass is split where it leaves them, except across gaps shorter than
/// [`FinishOptions::max_skip_gap`] (cutting on along the finished surface costs less than
/// a retract and a new entry), and runs shorter than two points are dropped.
pub fn finish_setup_keep<S: MotionSink>(
    part: &MeshIndex,
    setup: &Setup,
    tool: &Tool,
    strategy: &dyn FinishingStrategy,
    opts: &FinishOptions,
    keep: Option<&dyn KeepPoint>,
    sink: &mut S,
) -> Result<FinishSummary, ToolpathError<S::Error>> {
    finish_setup_left_out(part, setup, tool, strategy, opts, keep, sink).map(|(sum, _)| sum)
}

/// [`finish_setup_keep`], also returning the pass points the shank and holder check left
/// out ([`FinishOptions::holder_stock`]) as stretches of the passes (tip positions, setup
/// frame; [`LeftOut`]): a measure of the finished surface does not count the surface
/// they stand for as reached (`s2g_voxsim::HeightField::leave_out`).
pub fn finish_setup_left_out<S: MotionSink>(
    part: &MeshIndex,
    setup: &Setup,
    tool: &Tool,
    strategy: &dyn FinishingStrategy,
    opts: &FinishOptions,
    keep: Option<&dyn KeepPoint>,
    sink: &mut S,
) -> Result<(FinishSummary, LeftOut), ToolpathError<S::Error>> {
    let planned = finish_paths(part, tool, strategy, opts, keep, None).map_err(ToolpathError::widen)?;
    finish_setup_paths(part, setup, tool, strategy.name(), opts, planned, sink)
}

/// A setup's finishing passes as [`finish_setup_left_out`] machines them, planned ahead
/// ([`finish_paths`]): the strategy's passes less the points `keep` and the shank and
/// holder check leave out, in machining order and direction, and what the check left out.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FinishPaths {
    /// The passes, in machining order (tool-tip points, setup frame).
    pub paths: Vec<Vec<Point3>>,
    /// The pass points the shank and holder check left out.
    pub left_out: LeftOut,
}

/// The passes [`finish_setup_left_out`] machines (see [`FinishPaths`]), planned without
/// writing a motion: the costly part of finishing (the strategy's drop-cutter sampling,
/// fill checks, filters and checks), which a caller may run on another thread while the
/// roughing before it is written and simulated; [`finish_setup_paths`] then writes them,
/// the same motions as `finish_setup_left_out`. Its errors are those of
/// `finish_setup_left_out` but the sink's, and [`ToolpathError::Cancelled`] (or the
/// strategy's [`FinishError::Cancelled`](super::FinishError::Cancelled)) once `cancel` is
/// set.
pub fn finish_paths(
    part: &MeshIndex,
    tool: &Tool,
    strategy: &dyn FinishingStrategy,
    opts: &FinishOptions,
    keep: Option<&dyn KeepPoint>,
    cancel: Option<&std::sync::atomic::AtomicBool>,
) -> Result<FinishPaths, ToolpathError<std::convert::Infallible>> {
    tool.validate().map_err(|e| ToolpathError::InvalidTool(e.to_string()))?;
    check(opts)?;
    let cutter = profile_cutter(&tool.cutter);
    let dc = DropCutter::new(part, &cutter).map_err(|e| ToolpathError::InvalidTool(e.to_string()))?;
    let (lo, hi) = dc.bounds();
    let r = tool.radius();
    let [min, max] = opts.region.unwrap_or([[lo[0] - r, lo[1] - r], [hi[0] + r, hi[1] + r]]);
    let floor = opts.floor.unwrap_or(lo[2]);
    let ctx = FinishContext {
        drop_cutter: &dc,
        cutter: &cutter,
        min,
        max,
        z_range: [floor, hi[2]],
        scallop: opts.scallop,
        cancel,
    };
    let paths = strategy.paths(&ctx).map_err(ToolpathError::Finish)?;
    if ctx.cancelled() {
        return Err(ToolpathError::Cancelled);
    }
    let paths = match keep {
        // Grown by one and a half flat stepovers, so that the edge of what is left out is
        // cut by the passes on both sides of it.
        Some(k) => {
            let grow = 1.5
                * super::stepover_for_scallop(&cutter, opts.scallop, 0.0).map_err(ToolpathError::Finish)?;
            super::strategy::split_par(paths, |p| k.keep(p), opts.max_skip_gap, grow)
        }
        None => paths,
    };
    let (paths, left_out) = match opts.holder_stock {
        Some(stock) => match Guard::new(part, &tool.cutter, stock)? {
            Some(g) => g.split(paths, opts.link_check_step),
            None => (paths, LeftOut::default()),
        },
        None => (paths, LeftOut::default()),
    };
    Ok(FinishPaths { paths: super::order::link_order(paths), left_out })
}

/// Writes `planned` (from [`finish_paths`] with the same part, tool, options and the
/// strategy named `strategy`) to `sink` as [`finish_setup_left_out`] does: the setup
/// frame, a comment naming the strategy, the tool change, each pass with its links, and the
/// end. The same motions and summary as `finish_setup_left_out`.
pub fn finish_setup_paths<S: MotionSink>(
    part: &MeshIndex,
    setup: &Setup,
    tool: &Tool,
    strategy: &str,
    opts: &FinishOptions,
    planned: FinishPaths,
    sink: &mut S,
) -> Result<(FinishSummary, LeftOut), ToolpathError<S::Error>> {
    tool.validate().map_err(|e| ToolpathError::InvalidTool(e.to_string()))?;
    check(opts)?;
    let cutter = profile_cutter(&tool.cutter);
    let dc = DropCutter::new(part, &cutter).map_err(|e| ToolpathError::InvalidTool(e.to_string()))?;
    let (lo, hi) = dc.bounds();
    let floor = opts.floor.unwrap_or(lo[2]);
    let guard = match opts.holder_stock {
        Some(stock) => Guard::new(part, &tool.cutter, stock)?,
        None => None,
    };
    let FinishPaths { paths, left_out } = planned;
    let guarded_points = left_out.points;
    // The cutter grown by the stock left: where it touches the part, the cutter itself is
    // that far from it.
    let grown = opts.stock_left.map(|t| {
        let (r, corner) = (cutter.radius + t, cutter.corner_radius() + t);
        let flutes = (cutter.flute_length + t).max(2.0 * r);
        let c = if corner >= r * (1.0 - 1e-12) {
            Cutter::ball(r, flutes)
        } else {
            Cutter::bull(r, corner, flutes)
        };
        (c, t)
    });
    let safe = match &grown {
        Some((c, t)) => {
            Some((DropCutter::new(part, c).map_err(|e| ToolpathError::InvalidTool(e.to_string()))?, *t))
        }
        None => None,
    };
    let mut em = Emitter {
        sink,
        dc: &dc,
        safe: safe.as_ref(),
        guard: guard.as_ref(),
        tool,
        opts,
        floor,
        pos: None,
        sum: FinishSummary { clear_z: hi[2] + opts.clearance, guarded_points, ..Default::default() },
    };
    em.begin(setup, strategy)?;
    for path in paths.iter().filter(|p| !p.is_empty()) {
        em.pass(path)?;
    }
    em.end()?;
    Ok((em.sum, left_out))
}

/// The cutter the drop-cutter and the scallop formulas see: `c` with an unlimited flute
/// length and stick-out (the paper's assumption, [`Tool::ball`]'s default) made finite, as
/// both read only the radius and the corner radius.
fn profile_cutter(c: &Cutter) -> Cutter {
    let mut c = *c;
    if !c.flute_length.is_finite() {
        c.flute_length = 2.0 * c.radius;
    }
    if !c.stickout.is_finite() {
        c.stickout = c.flute_length;
    }
    c
}

fn check<E>(o: &FinishOptions) -> Result<(), ToolpathError<E>> {
    let bad = |m: String| Err(ToolpathError::InvalidOptions(m));
    let positive = [
        ("scallop", o.scallop),
        ("clearance", o.clearance),
        ("approach", o.approach),
        ("link_check_step", o.link_check_step),
        ("rapid_feed", o.rapid_feed),
        ("hop_step", o.hop_step),
    ];
    for (name, v) in positive {
        if !(v.is_finite() && v > 0.0) {
            return bad(format!("{name} must be finite and > 0, got {v}"));
        }
    }
    for (name, v) in [
        ("max_link", o.max_link),
        ("max_surface_link", o.max_surface_link),
        ("link_tolerance", o.link_tolerance),
        ("pass_lift", o.pass_lift),
        ("max_skip_gap", o.max_skip_gap),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return bad(format!("{name} must be finite and >= 0, got {v}"));
        }
    }
    if let Some([a, b]) = o.region
        && !(a.iter().chain(&b).all(|v| v.is_finite()) && a[0] <= b[0] && a[1] <= b[1])
    {
        return bad(format!("region must be finite with min <= max, got {a:?} .. {b:?}"));
    }
    if o.stock_left.is_some_and(|t| !(t.is_finite() && t >= 0.0)) {
        return bad(format!("stock_left must be finite and >= 0, got {:?}", o.stock_left));
    }
    if let Some(t) = o.arc_tolerance
        && !(t.is_finite() && t > 0.0)
    {
        return bad(format!("arc_tolerance must be finite and > 0, got {t}"));
    }
    if o.floor.is_some_and(|z| !z.is_finite()) {
        return bad(format!("floor must be finite, got {:?}", o.floor));
    }
    Ok(())
}

struct Emitter<'a, S: MotionSink> {
    sink: &'a mut S,
    dc: &'a DropCutter<'a>,
    /// The grown cutter's drop-cutter and the stock left ([`FinishOptions::stock_left`]).
    safe: Option<&'a (DropCutter<'a>, f64)>,
    /// The shank and holder check ([`FinishOptions::holder_stock`]).
    guard: Option<&'a Guard<'a>>,
    tool: &'a Tool,
    opts: &'a FinishOptions,
    /// The lowest tip height finished: a link along the surface stays above it.
    floor: f64,
    pos: Option<Point3>,
    sum: FinishSummary,
}

/// A route between passes ([`Emitter::enter_route`]): its moves in order, each to a point
/// at a feed (`None`: a rapid), and whether it crosses below the clearance plane (a hop)
/// or retracts to it.
struct Route {
    legs: Vec<(Point3, Option<f64>)>,
    hop: bool,
    retract: bool,
}

impl<S: MotionSink> Emitter<'_, S> {
    fn send(&mut self, m: Motion<'_>) -> Result<(), ToolpathError<S::Error>> {
        self.sink.motion(&m).map_err(ToolpathError::Sink)
    }

    fn rapid(&mut self, to: Point3) -> Result<(), ToolpathError<S::Error>> {
        if !book_move(
            &mut self.pos,
            to,
            self.opts.rapid_feed,
            &mut self.sum.rapid_length,
            &mut self.sum.time_s,
        ) {
            return Ok(());
        }
        self.send(Motion::Rapid { to })
    }

    fn feed(&mut self, to: Point3, feed: f64) -> Result<(), ToolpathError<S::Error>> {
        if !book_move(&mut self.pos, to, feed, &mut self.sum.cutting_length, &mut self.sum.time_s) {
            return Ok(());
        }
        self.send(Motion::Linear { to, feed, extrude: None })
    }

    fn begin(&mut self, setup: &Setup, strategy: &str) -> Result<(), ToolpathError<S::Error>> {
        self.send(Motion::Setup { frame: setup.frame, rotary: [None; 3] })?;
        let c = format!(
            "s2g-toolpath: finishing tool {} radius {} strategy {} scallop {}",
            self.tool.number,
            self.tool.radius(),
            strategy,
            self.opts.scallop
        );
        self.send(Motion::Comment(c.into()))?;
        self.send(Motion::ToolChange { tool: self.tool.number })?;
        self.send(Motion::Spindle { rpm: self.tool.spindle_rpm, direction: SpindleDirection::Clockwise })?;
        if self.opts.coolant {
            self.send(Motion::Coolant(Coolant::Flood))?;
        }
        Ok(())
    }

    fn end(&mut self) -> Result<(), ToolpathError<S::Error>> {
        self.rise()?;
        self.retract()?;
        if self.opts.coolant {
            self.send(Motion::Coolant(Coolant::Off))?;
        }
        self.send(Motion::Spindle { rpm: 0.0, direction: SpindleDirection::Off })
    }

    fn retract(&mut self) -> Result<(), ToolpathError<S::Error>> {
        let clear = self.sum.clear_z;
        if let Some(p) = self.pos
            && p.z < clear
        {
            self.sum.retracts += 1;
            self.rapid(Point3::new(p.x, p.y, clear))?;
        }
        Ok(())
    }

    /// Whether the straight feed from `a` to `b` is short and gouge-free.
    fn can_link(&self, a: &Point3, b: &Point3) -> bool {
        (b - a).xy().norm() <= self.opts.max_link && self.clear(a, b, self.opts.link_tolerance)
    }

    /// Whether the drop-cutter finds no interference deeper than `tolerance` at samples
    /// [`FinishOptions::link_check_step`] apart along `a`-`b`, and the shank and holder
    /// are clear there.
    fn clear(&self, a: &Point3, b: &Point3, tolerance: f64) -> bool {
        self.clear_of(a, b, tolerance, true)
    }

    /// [`Self::clear`], the shank and holder checked only with `guard`: a chord between two
    /// neighbouring points of a pass was checked by `Guard::split` at the same samples
    /// below them (the pass lift raises both ends alike, and a guard clear at a tip height
    /// is clear above it), so it is not checked twice.
    fn clear_of(&self, a: &Point3, b: &Point3, tolerance: f64, guard: bool) -> bool {
        let d = b - a;
        // Samples by the 3-D length: a chord that drops steeply (across a jump of the
        // cutter-location surface at a wall) is short in XY but passes the wall's corner.
        let n = (d.norm() / self.opts.link_check_step).ceil();
        if !(n <= 1e7) {
            return false;
        }
        let n = n.max(1.0) as usize;
        (0..=n).all(|k| {
            let p = a + d * (k as f64 / n as f64);
            !self.dc.interferes(p.x, p.y, p.z + tolerance) && (!guard || self.guard_clear(&p))
        })
    }

    /// Whether the shank and holder are clear of the stock with the tip at `p` (always
    /// without [`FinishOptions::holder_stock`]).
    fn guard_clear(&self, p: &Point3) -> bool {
        self.guard.is_none_or(|g| g.clear(p))
    }

    /// Feeds from the current position `a` to `b`: straight when that is gouge-free; else
    /// along the surface between them when halving the chord makes it so; else up to the
    /// highest drop-cutter height along it (when that is at most
    /// [`FinishOptions::approach`] above both ends), across and down when that is; else by a
    /// retract and a new entry at `b` (a chord across a kink of the cutter-location surface,
    /// where it jumps at a wall or cuts a corner of a waterline loop).
    fn step(&mut self, a: Point3, b: Point3) -> Result<(), ToolpathError<S::Error>> {
        // `a`-`b` is a chord of a pass: `Guard::split` checked its shank and holder.
        if self.clear_of(&a, &b, self.opts.link_tolerance, false) {
            return self.feed(b, self.tool.feed);
        }
        // Where the chord sags into the surface (a bend sharper than the sampling saw),
        // follow the surface between its ends, halving the chord up to eight times.
        if let Some(route) = self.along_surface(&a, &b, 1, 8) {
            for q in route {
                self.feed(q, self.tool.feed)?;
            }
            return Ok(());
        }
        // Lift to the highest drop-cutter height along the chord (a small lift across a
        // waterline corner, the wall's top where the surface jumps), if within the approach.
        let d = b - a;
        let n = ((d.norm() / self.opts.link_check_step).ceil().clamp(1.0, 1e6)) as usize;
        let top = (0..=n)
            .filter_map(|k| {
                let p = a + d * (k as f64 / n as f64);
                self.dc.height(p.x, p.y)
            })
            .fold(a.z.max(b.z), f64::max)
            + self.opts.link_tolerance;
        if top - a.z.max(b.z) > self.opts.approach {
            return self.enter(b);
        }
        let (up, over) = (Point3::new(a.x, a.y, top), Point3::new(b.x, b.y, top));
        if self.clear(&up, &over, self.opts.link_tolerance) {
            self.feed(up, self.tool.feed)?;
            self.feed(over, self.tool.feed)?;
            return self.feed(b, self.tool.feed);
        }
        self.enter(b)
    }

    /// With a stock left, feeds straight up to the safe height over the current position
    /// ([`Self::safe_height`]), where the cutter may still touch stock; nothing without.
    fn rise(&mut self) -> Result<(), ToolpathError<S::Error>> {
        let clear = self.sum.clear_z;
        if let Some(p) = self.pos.filter(|p| p.z < clear)
            && let Some(up) = self.safe_height(p.x, p.y, p.z).filter(|&h| h > p.z)
        {
            self.feed(Point3::new(p.x, p.y, up.min(clear)), self.tool.feed)?;
        }
        Ok(())
    }

    /// The lowest tip height over `(x, y)` at which the cutter is [`FinishOptions::stock_left`]
    /// from the part (the grown cutter's drop height raised by the stock left), at least
    /// `z`; `None` without a stock left.
    fn safe_height(&self, x: f64, y: f64, z: f64) -> Option<f64> {
        let (dc, t) = self.safe?;
        let z = match self.guard.and_then(|g| g.lowest(x, y)) {
            // A small margin over the guard's exact lowest height.
            Some(g) => z.max(g + 1e-6),
            None => z,
        };
        Some(dc.height(x, y).map_or(z, |h| (h + t).max(z)))
    }

    /// The highest safe height ([`Self::safe_height`]) along `a`-`b`, sampled every
    /// [`FinishOptions::hop_step`] and raised by a margin for what lies between samples.
    fn hop_height(&self, a: &Point3, b: &Point3) -> Option<f64> {
        let d = b - a;
        let n = ((d.xy().norm() / self.opts.hop_step).ceil().min(1e6) as usize).max(1);
        (0..=n)
            .try_fold(a.z.max(b.z), |top, k| {
                let p = a + d * (k as f64 / n as f64);
                Some(top.max(self.safe_height(p.x, p.y, p.z)?))
            })
            .map(|h| h + 0.05)
    }

    /// The points after `a` of a link from `a` to `b` along the drop-cutter surface over
    /// the straight line between them (raised by the pass lift, above the floor), each
    /// chord clear as a pass's must be, when its length at the feed takes less time than
    /// `enter_s`, the time entering `b` anew takes ([`Self::enter_route`]); `None`
    /// otherwise.
    fn surface_link(&self, a: &Point3, b: &Point3, enter_s: f64) -> Option<Vec<Point3>> {
        let d = b - a;
        let l = d.xy().norm();
        if !(l <= self.opts.max_surface_link) {
            return None;
        }
        let budget = enter_s * self.tool.feed / 60.0;
        if !(l < budget) {
            return None;
        }
        // Chords a quarter of the first sampling step long, halved where one is not clear.
        let out = self.along_surface(a, b, ((l / 0.125).ceil() as usize).max(1), 6)?;
        let length: f64 = std::iter::once(a).chain(&out).zip(&out).map(|(p, q)| (q - p).norm()).sum();
        (length < budget).then_some(out)
    }

    /// The points after `a` of a feed from `a` to `b` along the drop-cutter surface over
    /// the straight line between them, raised by the pass lift and above the floor: `n`
    /// chords, each halved (to `depth` halvings) where it is not clear; `None` where that
    /// does not make every chord clear or the surface drops below the floor.
    fn along_surface(&self, a: &Point3, b: &Point3, n: usize, depth: u32) -> Option<Vec<Point3>> {
        let d = b - a;
        let at = |t: f64| {
            let (x, y) = (a.x + d.x * t, a.y + d.y * t);
            let z = self.dc.height(x, y)?;
            (z >= self.floor).then(|| Point3::new(x, y, z + self.opts.pass_lift))
        };
        let clear = |p: &Point3, q: &Point3| self.clear(p, q, self.opts.link_tolerance);
        fn refine(
            clear: &impl Fn(&Point3, &Point3) -> bool,
            at: &impl Fn(f64) -> Option<Point3>,
            (t0, p0): (f64, Point3),
            (t1, p1): (f64, Point3),
            depth: u32,
            out: &mut Vec<Point3>,
        ) -> Option<()> {
            if !clear(&p0, &p1) {
                if depth == 0 {
                    return None;
                }
                let tm = 0.5 * (t0 + t1);
                let pm = at(tm)?;
                refine(clear, at, (t0, p0), (tm, pm), depth - 1, out)?;
                return refine(clear, at, (tm, pm), (t1, p1), depth - 1, out);
            }
            out.push(p1);
            Some(())
        }
        let mut out = Vec::with_capacity(n + 1);
        let mut prev = (0.0, *a);
        for k in 1..=n {
            let t = k as f64 / n as f64;
            let p = if k == n { *b } else { at(t)? };
            refine(&clear, &at, prev, (t, p), depth, &mut out)?;
            prev = (t, p);
        }
        Some(out)
    }

    /// The route [`Self::enter`] takes from the tool's position `from` to a pass starting at
    /// `s`: with a stock left, feed straight up to the safe height over `from` (where the
    /// cutter may still touch stock), cross at the highest safe height on the way (a hop;
    /// else retract to the clearance plane and cross there), rapid down to `s`'s safe
    /// height and plunge at the plunge feed; without, retract, rapid over `s` on the
    /// clearance plane, down to the approach height, and plunge. Its time is
    /// [`Route::time`]; [`Self::follow`] emits it.
    fn enter_route(&self, from: Option<Point3>, s: Point3) -> Route {
        let clear = self.sum.clear_z;
        let mut r = Route { legs: Vec::with_capacity(6), hop: false, retract: false };
        // Where the route has taken the tool so far.
        let mut at = from;
        let go = |r: &mut Route, at: &mut Option<Point3>, to: Point3, feed: Option<f64>| {
            r.legs.push((to, feed));
            *at = Some(to);
        };
        let below = |at: Option<Point3>| at.filter(|p| p.z < clear);
        match self.safe_height(s.x, s.y, s.z) {
            Some(low) => {
                // The rise.
                if let Some(p) = below(at)
                    && let Some(up) = self.safe_height(p.x, p.y, p.z).filter(|&h| h > p.z)
                {
                    go(&mut r, &mut at, Point3::new(p.x, p.y, up.min(clear)), Some(self.tool.feed));
                }
                let hop = below(at)
                    .and_then(|p| self.hop_height(&p, &s).filter(|&h| h < clear).map(|h| (p, h.max(p.z))));
                match hop {
                    Some((p, h)) => {
                        r.hop = true;
                        go(&mut r, &mut at, Point3::new(p.x, p.y, h), None);
                        go(&mut r, &mut at, Point3::new(s.x, s.y, h), None);
                    }
                    None => {
                        if let Some(p) = below(at) {
                            r.retract = true;
                            go(&mut r, &mut at, Point3::new(p.x, p.y, clear), None);
                        }
                        go(&mut r, &mut at, Point3::new(s.x, s.y, clear), None);
                    }
                }
                go(&mut r, &mut at, Point3::new(s.x, s.y, low.min(clear)), None);
            }
            None => {
                if let Some(p) = below(at) {
                    r.retract = true;
                    go(&mut r, &mut at, Point3::new(p.x, p.y, clear), None);
                }
                go(&mut r, &mut at, Point3::new(s.x, s.y, clear), None);
                let top = (s.z + self.opts.approach).min(clear);
                go(&mut r, &mut at, Point3::new(s.x, s.y, top), None);
            }
        }
        go(&mut r, &mut at, s, Some(self.tool.plunge_feed));
        r
    }

    /// The machine's time (s) for `route` from `from`, as [`Self::follow`] books it.
    fn route_time(&self, from: Option<Point3>, route: &Route) -> f64 {
        let (mut pos, mut length, mut time) = (from, 0.0, 0.0);
        for &(to, feed) in &route.legs {
            book_move(&mut pos, to, feed.unwrap_or(self.opts.rapid_feed), &mut length, &mut time);
        }
        time
    }

    /// Emits `route` ([`Self::enter_route`]): rapids, and feeds at their feeds.
    fn follow(&mut self, route: &Route) -> Result<(), ToolpathError<S::Error>> {
        if route.hop {
            self.sum.hops += 1;
        }
        if route.retract {
            self.sum.retracts += 1;
        }
        for &(to, feed) in &route.legs {
            match feed {
                Some(f) => self.feed(to, f)?,
                None => self.rapid(to)?,
            }
        }
        Ok(())
    }

    /// Leaves the current position and enters a pass at `s` ([`Self::enter_route`]).
    fn enter(&mut self, s: Point3) -> Result<(), ToolpathError<S::Error>> {
        let route = self.enter_route(self.pos, s);
        self.follow(&route)
    }

    fn pass(&mut self, path: &[Point3]) -> Result<(), ToolpathError<S::Error>> {
        let lift = self.opts.pass_lift;
        let path: Vec<Point3> = path.iter().map(|p| Point3::new(p.x, p.y, p.z + lift)).collect();
        let s = path[0];
        match self.pos {
            Some(p) if p.z < self.sum.clear_z && self.can_link(&p, &s) => {
                self.sum.links += 1;
                self.feed(s, self.tool.feed)?;
            }
            Some(p) if p.z < self.sum.clear_z => {
                let enter = self.enter_route(Some(p), s);
                match self.surface_link(&p, &s, self.route_time(Some(p), &enter)) {
                    Some(route) => {
                        self.sum.links += 1;
                        for q in route {
                            self.feed(q, self.tool.feed)?;
                        }
                    }
                    None => self.follow(&enter)?,
                }
            }
            _ => self.enter(s)?,
        }
        self.sum.passes += 1;
        let Some((plane, fit)) = self.arc_fit(&path) else {
            for w in path.windows(2) {
                self.step(w[0], w[1])?;
            }
            return Ok(());
        };
        let (u, v, _) = plane_axes(plane);
        let pts: Vec<[f64; 2]> = path.iter().map(|p| [p[u], p[v]]).collect();
        let at = |q: &[f64; 2]| {
            let mut p = path[0];
            (p[u], p[v]) = (q[0], q[1]);
            p
        };
        let pieces =
            fit_planar(&pts, &fit, |from, piece| self.piece_clear(at(from), at(&piece.to), plane, piece));
        let mut i = 0;
        for piece in pieces {
            let to = path[piece.end];
            match piece.arc {
                None if piece.end == i + 1 => self.step(path[i], to)?,
                None => self.feed(to, self.tool.feed)?,
                Some((c, direction)) => {
                    let mut center = to;
                    (center[u], center[v]) = (c[0], c[1]);
                    self.arc(ArcSpec { start: path[i], end: to, center, plane, direction, turns: 0 })?;
                }
            }
            i = piece.end;
        }
        Ok(())
    }

    /// The plane of `path` (ZX: all points at one Y; YZ: at one X) and the fitting options
    /// that keep its pieces above it, where arcs are fitted.
    fn arc_fit(&self, path: &[Point3]) -> Option<(Plane, PlanarFitOptions)> {
        let tolerance = self.opts.arc_tolerance?;
        let (first, last) = (path.first()?, path.last()?);
        let flat = |a: usize| path.iter().all(|p| p[a] == first[a]);
        let plane = if flat(1) {
            Plane::ZX
        } else if flat(0) {
            Plane::YZ
        } else {
            return None;
        };
        let (u, v, _) = plane_axes(plane);
        // Up (+Z) in the plane's (u, v) axes, and on which side of the travel it lies.
        let up = if u == 2 { [1.0, 0.0] } else { [0.0, 1.0] };
        let d = [last[u] - first[u], last[v] - first[v]];
        let left = -d[1] * up[0] + d[0] * up[1];
        let len = d[0].hypot(d[1]);
        if !(left.abs() > 1e-6 * len) {
            return None;
        }
        let side = if left > 0.0 { FitSide::Left } else { FitSide::Right };
        Some((plane, PlanarFitOptions { tolerance, side, ..PlanarFitOptions::default() }))
    }

    /// Whether the piece from `a` to `b` is clear: the drop-cutter finds no
    /// interference at samples [`FinishOptions::link_check_step`] apart along it.
    fn piece_clear(&self, a: Point3, b: Point3, plane: Plane, piece: &PlanarPiece) -> bool {
        let Some((c, direction)) = piece.arc else { return self.clear(&a, &b, self.opts.link_tolerance) };
        let (u, v, _) = plane_axes(plane);
        let mut center = b;
        (center[u], center[v]) = (c[0], c[1]);
        let spec = ArcSpec { start: a, end: b, center, plane, direction, turns: 0 };
        let n = (spec.length() / self.opts.link_check_step).ceil();
        if !(n <= 1e7) {
            return false;
        }
        let n = n.max(1.0) as usize;
        (0..=n).all(|j| {
            let p = spec.point_at(j as f64 / n as f64);
            !self.dc.interferes(p.x, p.y, p.z + self.opts.link_tolerance) && self.guard_clear(&p)
        })
    }

    /// A feed along `spec` (from where the tool is), booked by its length.
    fn arc(&mut self, spec: ArcSpec) -> Result<(), ToolpathError<S::Error>> {
        let l = spec.length();
        self.sum.cutting_length += l;
        self.sum.time_s += l / self.tool.feed * 60.0;
        self.pos = Some(spec.end);
        let ArcSpec { end: to, center, plane, direction, .. } = spec;
        self.send(Motion::Arc { to, center, plane, direction, turns: 0, feed: self.tool.feed, extrude: None })
    }
}
