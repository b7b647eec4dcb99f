//! Linking and emission: turns layer plans into motions with safe retracts and entries.
//!
//! Safety argument (why rapids never meet material): a path start `s` lies in its layer's
//! free region, and the free regions nest: each level's tool-centre keep-out is the level
//! above's joined with the growth of what its own keep-out adds, so the same polygons,
//! not merely the same exact sets (see `Ctx::clearances` in the planner; growing each
//! level's keep-out on its own gave each level its own chords, and an entry's tool reached
//! micrometres past the cut above into the stock skin on an undercut's wall, issue 35). So
//! `s` lies in the free region `F` of the level `z_above`, which was cut before. A point `p`
//! within the radius of `s` is then either in `F`, within the radius of that level's
//! passes (the clearing covers its region; what a roughing level below cut, or what the
//! material reach left out, held no material), or beyond `F`'s boundary, crossed at `q`
//! with `|p - q| <= |p - s|`: `q` lies on the contour (or where no material lies within the
//! radius), which removed the material within the radius of `q`. So a rapid straight
//! down at a path start is safe to `z_above + gap`; below that the tool feeds in (helix,
//! ramp or plunge). Horizontal rapids run only on the clearance plane above the stock.
//!
//! With [`PlanOptions::lead_in`] (the shop's programs) three more moves rest on the same
//! argument. A rapid between two points of a level's free region, at the height a level
//! cut before stops its descents, along a segment inside that level's free region: every
//! tool centre there has cleared the material above that height (and the tool rises and
//! falls in columns it has cleared). A rapid straight down to a finer level inside the
//! free region of the roughing level below it, whose cut removed everything its tool
//! centres reach from there up through the finer levels. And a clearing pass entered
//! where it reaches air (outside the stock, or where the remaining material reports none)
//! rather than at its start. Where no level's free region holds a crossing, the tool
//! crosses a gap above the stock's top instead of at the clearance plane: no material
//! lies above the stock, and it rises and falls in the columns the retract would.

use std::f64::consts::PI;

use s2g_gcode::{
    ArcDirection, ArcSpec, Coolant, FitSide, Marker, Motion, MotionSink, PlanarFitOptions, PlanarPiece,
    Plane, SpindleDirection, fit_planar,
};
use s2g_geom::{Aabb, Point3, Setup};

use crate::clear::piece_clear;
use crate::error::ToolpathError;
use crate::layer::LayerPlan;
use crate::options::PlanOptions;
use crate::region::{Point2, Polyline2, Region2, RegionIndex};
use crate::rest::RemainingMaterial;
use crate::tool::Tool;

/// Books a move of the tool from `pos` to `to` at `feed` (units per minute): its length
/// into `length` (the cutting or the rapid total) and its time into `time_s`, and `pos`
/// becomes `to`. `false` for a move to where the tool already is (nothing to send); the
/// first move, from an unknown position, is sent but not booked.
pub(crate) fn book_move(
    pos: &mut Option<Point3>,
    to: Point3,
    feed: f64,
    length: &mut f64,
    time_s: &mut f64,
) -> bool {
    if let Some(p) = *pos {
        if p == to {
            return false;
        }
        let l = (to - p).norm();
        *length += l;
        *time_s += l / feed * 60.0;
    }
    *pos = Some(to);
    true
}

/// The feed of a helix or ramp descending `slope` (drop over run) into material: the tool's
/// cutting feed, but no faster than its descent along the axis stays within the plunge
/// feed (the axial load the plunge feed is set for). At the default 3 degrees that is the
/// cutting feed for any plunge feed above 5.2 % of it; a vertical descent (an infinite
/// or NaN slope) gets the plunge feed.
pub(crate) fn ramp_feed(tool: &Tool, slope: f64) -> f64 {
    if !(slope.is_finite() && slope > 0.0) {
        return if slope == 0.0 { tool.feed } else { tool.plunge_feed };
    }
    let sin = slope / (1.0 + slope * slope).sqrt();
    tool.feed.min(tool.plunge_feed / sin)
}

pub(crate) struct LinkParams {
    /// The least distance from a level's keep-out at which the tool centre cuts.
    pub wall: f64,
    /// How far beyond the arc tolerance a fitted piece may leave its path: it is then
    /// checked against the keep-out ([`LayerPlan::keepout`]).
    pub arc_slack: f64,
    pub clear_z: f64,
    pub gap: f64,
    pub max_link: f64,
    pub stock: Aabb,
    /// Cut a clearing pass from its end where only that end lies in air.
    pub enter_from_air: bool,
    /// Cross between two paths of a level at the height its descents stop at, where the
    /// segment between them lies in its free region.
    pub local_retract: bool,
}

#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct Stats {
    pub cutting_length: f64,
    pub rapid_length: f64,
    pub time_s: f64,
    pub retracts: usize,
    pub helix: usize,
    pub ramp: usize,
    pub plunge: usize,
    pub lead_in: usize,
    pub low_retracts: usize,
}

pub(crate) struct Emitter<'s, S: MotionSink> {
    sink: &'s mut S,
    tool: Tool,
    /// Remaining material: entries where it reports none go straight down.
    rest: Option<&'s dyn RemainingMaterial>,
    rapid_feed: f64,
    ramp_tan: f64,
    helix_radius: f64,
    min_ramp: f64,
    p: LinkParams,
    /// Arc fitting of the passes ([`PlanOptions::arc_tolerance`]): pieces on the part's side.
    fit: Option<PlanarFitOptions>,
    pos: Option<Point3>,
    stats: Stats,
    /// The levels cut so far (the last [`CROSSINGS`]): the height their descents stop at
    /// and their free region, above which every tool centre of it has cleared the
    /// material ([`LinkParams::local_retract`]).
    crossings: std::collections::VecDeque<(f64, RegionIndex)>,
}

/// How many levels cut before [`Emitter`] keeps for crossing between paths.
const CROSSINGS: usize = 8;

impl<'s, S: MotionSink> Emitter<'s, S> {
    pub fn new(
        sink: &'s mut S,
        tool: &Tool,
        opts: &PlanOptions,
        p: LinkParams,
        rest: Option<&'s dyn RemainingMaterial>,
    ) -> Self {
        let arc_slack = p.arc_slack;
        Self {
            sink,
            tool: *tool,
            rest,
            rapid_feed: opts.rapid_feed,
            ramp_tan: opts.ramp.angle_deg.to_radians().tan().max(1e-6),
            helix_radius: opts.ramp.helix_radius.unwrap_or(0.5 * tool.radius()),
            min_ramp: opts.ramp.min_ramp_length.unwrap_or(tool.radius()),
            p,
            // Climb milling runs with the part on the right of travel (contours and rings
            // alike), conventional milling with it on the left.
            fit: opts.arc_fit().map(|tolerance| PlanarFitOptions {
                tolerance: tolerance + arc_slack,
                side: if opts.climb { FitSide::Right } else { FitSide::Left },
                // Round joins, their vertices on the circle, fit from their chords' middles.
                midpoints: true,
                ..PlanarFitOptions::default()
            }),
            pos: None,
            stats: Stats::default(),
            crossings: std::collections::VecDeque::new(),
        }
    }

    pub fn stats(&self) -> Stats {
        self.stats
    }

    fn send(&mut self, m: Motion<'_>) -> Result<(), ToolpathError<S::Error>> {
        self.sink.motion(&m).map_err(ToolpathError::Sink)
    }

    fn rapid(&mut self, to: Point3) -> Result<(), ToolpathError<S::Error>> {
        if !book_move(
            &mut self.pos,
            to,
            self.rapid_feed,
            &mut self.stats.rapid_length,
            &mut self.stats.time_s,
        ) {
            return Ok(());
        }
        self.send(Motion::Rapid { to })
    }

    fn feed(&mut self, to: Point3, feed: f64) -> Result<(), ToolpathError<S::Error>> {
        if !book_move(&mut self.pos, to, feed, &mut self.stats.cutting_length, &mut self.stats.time_s) {
            return Ok(());
        }
        self.send(Motion::Linear { to, feed, extrude: None })
    }

    pub fn begin(
        &mut self,
        setup: &Setup,
        start: &Point3,
        strategy: &str,
    ) -> Result<(), ToolpathError<S::Error>> {
        self.send(Motion::Setup { frame: setup.frame, rotary: [None; 3] })?;
        let c = format!(
            "s2g-toolpath: tool {} radius {} strategy {}",
            self.tool.number,
            self.tool.radius(),
            strategy
        );
        self.send(Motion::Comment(c.into()))?;
        self.send(Motion::ToolChange { tool: self.tool.number })?;
        self.send(Motion::Spindle { rpm: self.tool.spindle_rpm, direction: SpindleDirection::Clockwise })?;
        if self.tool.coolant != Coolant::Off {
            self.send(Motion::Coolant(self.tool.coolant))?;
        }
        // Eq. (4) of the Shape2Gcode paper: G0 to the start position at a safe height.
        self.rapid(Point3::new(start.x, start.y, self.p.clear_z.max(start.z)))
    }

    fn retract(&mut self) -> Result<(), ToolpathError<S::Error>> {
        if let Some(p) = self.pos
            && p.z < self.p.clear_z
        {
            self.stats.retracts += 1;
            self.rapid(Point3::new(p.x, p.y, self.p.clear_z))?;
        }
        Ok(())
    }

    pub fn finish(&mut self) -> Result<(), ToolpathError<S::Error>> {
        self.retract()?;
        if self.tool.coolant != Coolant::Off {
            self.send(Motion::Coolant(Coolant::Off))?;
        }
        self.send(Motion::Spindle { rpm: 0.0, direction: SpindleDirection::Off })
    }

    fn outside_stock(&self, q: &Point2) -> bool {
        let s = &self.p.stock;
        let dx = (s.min.x - q.x).max(q.x - s.max.x).max(0.0);
        let dy = (s.min.y - q.y).max(q.y - s.max.y).max(0.0);
        (dx * dx + dy * dy).sqrt() >= self.tool.radius() * (1.0 - 1e-9)
    }

    pub fn layer(&mut self, plan: &LayerPlan) -> Result<(), ToolpathError<S::Error>> {
        self.send(Motion::Marker(Marker::Layer { index: Some(plan.index as i64), z: Some(plan.z) }))?;
        let index = plan.free.index();
        let roughed = plan.roughed.as_ref().map(Region2::index);
        let tol = 1e-7 * self.tool.radius();
        let z = plan.z;
        let top = (plan.z_above + self.p.gap).min(self.p.clear_z);
        let contours = plan.contour.len();
        let mut split: Vec<Polyline2> = Vec::new();
        for (k, path) in plan.contour.iter().chain(&plan.clearing).enumerate() {
            // A clearing pass (whose direction is the strategy's to choose, unlike a
            // contour's climb) that starts in material but reaches air (the stock's edge, a
            // region cleared before) or the roughing level's cut is entered there: its part
            // up to that point is cut backwards from it, then the rest from it, the tool
            // going down in air both times and feeding in from the side, with no ramp.
            let from_air = self.p.enter_from_air && k >= contours && !path.closed;
            // Where the tool can go down without a ramp: in air, or beside the roughing
            // level's cut ([`Self::lead_in`]).
            let easy = |q: &Point2| {
                self.in_air(q, z, top)
                    || roughed.as_ref().is_some_and(|done| self.lead_in(q, done, &index, tol).is_some())
            };
            let at = from_air
                .then(|| {
                    let s = path.start()?;
                    if easy(&s) {
                        return None;
                    }
                    path.points.iter().position(easy)
                })
                .flatten();
            let pieces: Vec<&Polyline2> = match at {
                Some(i) => {
                    split.clear();
                    let mut head = Polyline2::open(path.points[..=i].to_vec());
                    head.reverse();
                    split.push(head);
                    if i + 1 < path.points.len() {
                        split.push(Polyline2::open(path.points[i..].to_vec()));
                    }
                    split.iter().collect()
                }
                None => vec![path],
            };
            for path in pieces {
                self.pass(path, plan, &index, roughed.as_ref(), tol, top)?;
            }
        }
        if self.p.local_retract {
            if self.crossings.len() == CROSSINGS {
                self.crossings.pop_front();
            }
            self.crossings.push_back((top, index));
        }
        Ok(())
    }

    /// One path of `plan`'s level: linked from where the tool is (staying down when the
    /// link is short and inside the free region `index`), or entered anew (from the side
    /// where [`Self::lead_in`] finds a way, else by [`Self::enter`]), then cut.
    fn pass(
        &mut self,
        path: &Polyline2,
        plan: &LayerPlan,
        index: &RegionIndex,
        roughed: Option<&RegionIndex>,
        tol: f64,
        top: f64,
    ) -> Result<(), ToolpathError<S::Error>> {
        let z = plan.z;
        let Some(s) = path.start() else { return Ok(()) };
        let here = self.pos.filter(|p| (p.z - z).abs() <= tol);
        let stay = here.is_some_and(|p| {
            let a = Point2::new(p.x, p.y);
            (s - a).norm() <= self.p.max_link && (a == s || index.segment_inside(&a, &s, tol))
        });
        if stay {
            self.feed(Point3::new(s.x, s.y, z), self.tool.feed)?;
        } else {
            let side = roughed.and_then(|done| self.lead_in(&s, done, index, tol));
            let q = side.unwrap_or(s);
            // From this level's free region to another point of it, along a segment inside
            // it, the tool may cross at the height its descents stop at: above that height
            // every tool centre of the region has cleared the material (the invariant that
            // makes the descent to it safe, see the module docs).
            // The same holds for every level cut before (material only goes): the tool
            // rises in its own column, crosses at the lowest such height whose level's free
            // region holds the segment, and comes down in this level's region. Where none
            // does, it crosses a gap above the stock's top, over which nothing ever lies
            // (the retract's path, rising and descending in the same columns, only lower),
            // where that is below the clearance plane.
            let above_stock = self.p.stock.max.z + self.p.gap;
            let low = self.pos.filter(|_| self.p.local_retract).and_then(|p| {
                let a = Point2::new(p.x, p.y);
                let here = (top, index);
                std::iter::once((here.0, here.1))
                    .chain(self.crossings.iter().map(|(h, i)| (*h, i)))
                    .filter(|(_, i)| i.segment_inside(&a, &q, tol))
                    .map(|(h, _)| h)
                    .chain((above_stock < self.p.clear_z).then_some(above_stock))
                    .fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.min(h))))
                    .map(|h| (p, h.max(p.z)))
            });
            let top = match low {
                Some((p, h)) => {
                    self.stats.low_retracts += 1;
                    self.rapid(Point3::new(p.x, p.y, h))?;
                    self.rapid(Point3::new(q.x, q.y, h))?;
                    self.rapid(Point3::new(q.x, q.y, h.min(top)))?;
                    h.min(top)
                }
                None => {
                    self.retract()?;
                    self.rapid(Point3::new(q.x, q.y, self.p.clear_z))?;
                    self.rapid(Point3::new(q.x, q.y, top))?;
                    top
                }
            };
            if side.is_some() {
                // Down by rapid in the roughing cut's air, then across into the step.
                self.stats.lead_in += 1;
                self.rapid(Point3::new(q.x, q.y, z))?;
                self.feed(Point3::new(s.x, s.y, z), self.tool.feed)?;
            } else {
                self.enter(path, index, plan, top)?;
            }
        }
        self.along(path, z, plan)
    }

    /// Whether the tool standing at `s` between heights `z` and `top` meets no material:
    /// outside the stock, or where the remaining material reports none.
    fn in_air(&self, s: &Point2, z: f64, top: f64) -> bool {
        self.outside_stock(s)
            || self.rest.is_some_and(|rest| {
                let r = self.tool.radius();
                !rest.any_in_box(&Point3::new(s.x - r, s.y - r, z), &Point3::new(s.x + r, s.y + r, top))
            })
    }

    /// Where a path starting at `s` on a finer level may be entered from the side: `s`
    /// itself where it lies in `roughed` (the roughing level's free region, whose cut
    /// removed the material its tool centres reach up to this level), else a point just
    /// inside `roughed` within a tool radius of `s` from which the straight feed to `s`
    /// stays in this level's free region (`free`); `None` where there is none.
    fn lead_in(&self, s: &Point2, roughed: &RegionIndex, free: &RegionIndex, tol: f64) -> Option<Point2> {
        if roughed.contains(s) {
            return Some(*s);
        }
        let r = self.tool.radius();
        let b = roughed.nearest_boundary_point(s, r)?;
        let d = b - s;
        let l = d.norm();
        if !(l > 0.0) {
            return None;
        }
        let q = b + d * (0.02 * r / l);
        (roughed.contains(&q) && free.segment_inside(&q, s, tol)).then_some(q)
    }

    /// Feeds along `path` at level `z` from its start (where the tool is): through every
    /// point, or by the fitted arcs and lines where arcs are fitted.
    fn along(&mut self, path: &Polyline2, z: f64, plan: &LayerPlan) -> Result<(), ToolpathError<S::Error>> {
        let mut pts: Vec<[f64; 2]> = Vec::with_capacity(path.points.len() + 1);
        let back = path.start().filter(|_| path.closed);
        for q in path.points.iter().chain(back.as_ref()) {
            if pts.last() != Some(&[q.x, q.y]) {
                pts.push([q.x, q.y]);
            }
        }
        let feed = self.tool.feed;
        let Some(opts) = self.fit else {
            for q in pts.iter().skip(1) {
                self.feed(Point3::new(q[0], q[1], z), feed)?;
            }
            return Ok(());
        };
        // Within the arc tolerance of its path (which keeps that much more from the part)
        // a piece is safe; beyond it, it must keep the tool's distance from the keep-out.
        let tolerance = opts.tolerance - self.p.arc_slack;
        let safe = |from: &[f64; 2], piece: &PlanarPiece| {
            piece.deviation <= tolerance
                || plan.keepout.as_deref().is_some_and(|k| piece_clear(k, *from, piece, self.p.wall))
        };
        for piece in fit_planar(&pts, &opts, safe) {
            let q = piece.to;
            let to = Point3::new(q[0], q[1], z);
            match piece.arc {
                None => self.feed(to, feed)?,
                Some((c, direction)) => self.arc(to, Point3::new(c[0], c[1], z), direction, feed)?,
            }
        }
        Ok(())
    }

    /// A feed along the XY arc about `center` to `to`, booked by its length.
    fn arc(
        &mut self,
        to: Point3,
        center: Point3,
        direction: ArcDirection,
        feed: f64,
    ) -> Result<(), ToolpathError<S::Error>> {
        let Some(from) = self.pos else { return self.feed(to, feed) };
        let spec = ArcSpec { start: from, end: to, center, plane: Plane::XY, direction, turns: 0 };
        let l = spec.length();
        self.stats.cutting_length += l;
        self.stats.time_s += l / feed * 60.0;
        self.pos = Some(to);
        self.send(Motion::Arc { to, center, plane: Plane::XY, direction, turns: 0, feed, extrude: None })
    }

    /// Feeds from `top` down to the layer at the path's start: straight in air, else by
    /// helix (when its circle fits in the free region), else by a zigzag ramp along the
    /// first segment, else by a straight plunge. A descent in air runs at the cutting
    /// feed, a straight plunge into material at the plunge feed, helices and ramps at
    /// [`ramp_feed`].
    fn enter(
        &mut self,
        path: &Polyline2,
        index: &RegionIndex,
        plan: &LayerPlan,
        top: f64,
    ) -> Result<(), ToolpathError<S::Error>> {
        let Some(s) = path.start() else { return Ok(()) };
        let z = plan.z;
        let depth = top - z;
        let plunge = self.tool.plunge_feed;
        let air = self.in_air(&s, z, top);
        if air {
            // Nothing to cut on the way down: no reason to crawl at the plunge feed.
            return self.feed(Point3::new(s.x, s.y, z), self.tool.feed.max(plunge));
        }
        if depth <= 0.0 {
            self.stats.plunge += 1;
            return self.feed(Point3::new(s.x, s.y, z), plunge);
        }
        // Helix.
        let rh = self.helix_radius;
        if rh > 0.0 {
            let pitch = 2.0 * PI * rh * self.ramp_tan;
            for k in 0..8 {
                let a = k as f64 * PI / 4.0;
                let c = Point2::new(s.x + rh * a.cos(), s.y + rh * a.sin());
                if index.contains(&c) && !index.any_edge_within(&c, rh * (1.0 + 1e-6)) {
                    let revs = (depth / pitch).ceil().max(1.0);
                    let l = revs * ((2.0 * PI * rh).powi(2) + (depth / revs).powi(2)).sqrt();
                    let feed = ramp_feed(&self.tool, depth / revs / (2.0 * PI * rh));
                    self.stats.cutting_length += l;
                    self.stats.time_s += l / feed * 60.0;
                    self.stats.helix += 1;
                    let to = Point3::new(s.x, s.y, z);
                    self.pos = Some(to);
                    return self.send(Motion::Arc {
                        to,
                        center: Point3::new(c.x, c.y, top),
                        plane: Plane::XY,
                        direction: ArcDirection::CounterClockwise,
                        turns: revs as u32 - 1,
                        feed,
                        extrude: None,
                    });
                }
            }
        }
        // Ramp back and forth along the first segment.
        if let Some(&q) = path.points.get(1) {
            let seg = q - s;
            let len = seg.norm();
            if len >= self.min_ramp && len > 0.0 {
                let u = seg / len;
                let l = len.min(depth / self.ramp_tan).max(self.min_ramp.min(len));
                let legs = (depth / (l * self.ramp_tan)).ceil().max(1.0) as usize;
                let far = s + u * l;
                let feed = ramp_feed(&self.tool, depth / (legs as f64 * l));
                self.stats.ramp += 1;
                for k in 1..=legs {
                    let zk = top - depth * k as f64 / legs as f64;
                    let xy = if k % 2 == 1 { far } else { s };
                    self.feed(Point3::new(xy.x, xy.y, zk), feed)?;
                }
                return self.feed(Point3::new(s.x, s.y, z), self.tool.feed);
            }
        }
        self.stats.plunge += 1;
        self.feed(Point3::new(s.x, s.y, z), plunge)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ramp_runs_at_the_cutting_feed_unless_its_descent_outruns_the_plunge_feed() {
        // 1000 mm/min cutting, 300 plunge.
        let t = Tool::flat(1.0);
        let slope = |deg: f64| deg.to_radians().tan();
        // 3 degrees: the descent, 1000 sin 3 = 52 mm/min, is well within the plunge feed.
        assert_eq!(ramp_feed(&t, slope(3.0)), t.feed);
        // 30 degrees: at the cutting feed the tool would descend at 500 mm/min; the feed
        // drops until it descends at 300.
        let f = ramp_feed(&t, slope(30.0));
        assert!(f < t.feed && f > t.plunge_feed, "{f}");
        assert!((f * 30f64.to_radians().sin() - t.plunge_feed).abs() < 1e-9, "{f}");
        // The descent never outruns the plunge feed, and a ramp never runs slower than a
        // straight plunge would descend.
        for deg in [0.5, 3.0, 10.0, 17.0, 45.0, 80.0, 89.9] {
            let f = ramp_feed(&t, slope(deg));
            assert!(f * deg.to_radians().sin() <= t.plunge_feed * (1.0 + 1e-12), "{deg}: {f}");
            assert!(f >= t.plunge_feed && f <= t.feed, "{deg}: {f}");
        }
        // Vertical or undefined: the plunge feed; flat: the cutting feed.
        assert_eq!(ramp_feed(&t, f64::INFINITY), t.plunge_feed);
        assert_eq!(ramp_feed(&t, f64::NAN), t.plunge_feed);
        assert_eq!(ramp_feed(&t, 0.0), t.feed);
    }
}
