//! Undercuts cut from the side with a T-slot (disc) cutter ([`Cutter::is_t_slot`]): the
//! wings of a T-slot, a dovetail's flanks, a groove under a lip, which no end mill reaches
//! from above.
//!
//! The part is sampled as vertical columns ([`Columns`]: the heights each column of a
//! square raster is inside the part, from the crossings of its centre line with the
//! triangles). At a level `z` (the disc's bottom; its top at `z + t`, `t` its thickness)
//! the cutter's centre is free ([`free_region`]) where
//! - the disc is clear of the part: outside the union of the part's sections over
//!   `[z, z + t]` grown by the disc's radius,
//! - the neck is clear of the part above: outside the part's shadow over `[z + t, top]`
//!   grown by the neck's radius,
//!
//! each grown by a margin and a raster cell, and only where the tool can get to from
//! outside the stock at that level (the components of the free region that reach beyond
//! the stock's outline grown by the disc's radius). The neck must reach above the stock's
//! top, so the shank and holder pass over it.
//!
//! The pass ([`plan_undercut`]) cuts, at each level from the undercut's floor up in steps
//! of at most the disc's thickness to its roof, the contours of the free region around the
//! part (the disc touching the part's walls at the margin), each entered horizontally from
//! outside the stock: rapid at the clearance height to a point outside, down outside, fed in
//! along a straight line within the free region, around the contour as far as the neck
//! stays clear of the material left (the exact [`RemainingMaterial`] query), back the way it
//! came, and out. No move goes down or up inside the stock's outline.

use rayon::prelude::*;
use s2g_gcode::{Coolant, Motion, MotionSink, SpindleDirection};
use s2g_geom::{Aabb, Mesh, Point3, Setup};

use crate::error::ToolpathError;
use crate::options::DEFAULT_ARC_STEP;
use crate::plan::PlanSummary;
use crate::region::{Point2, Polyline2, Region2, RegionIndex, Vector2};
use crate::rest::RemainingMaterial;
use crate::slice::setup_triangles;
use crate::tool::Tool;

/// How an undercut pass is planned ([`plan_undercut`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UndercutOptions {
    /// The columns' raster cell, mm.
    pub cell: f64,
    /// What the disc and the neck keep from the part, mm (beyond the raster's cell).
    pub margin: f64,
    /// The step of the scan for the undercut's floor and roof, mm.
    pub scan_step: f64,
    /// The least material (mm³) at one level that makes it part of the undercut: the
    /// area of squares (1 mm, or 1.5 times the material's sample spacing where that is
    /// wider) under the part's shadow within the disc's reach from the free region that
    /// hold material, times the disc's thickness.
    pub min_volume: f64,
    /// The clearance height above the stock's top, mm.
    pub clearance: f64,
    /// Rapid feed for the time estimate, mm/min.
    pub rapid_feed: f64,
}

impl Default for UndercutOptions {
    fn default() -> Self {
        Self { cell: 0.2, margin: 0.15, scan_step: 0.5, min_volume: 1.0, clearance: 5.0, rapid_feed: 5000.0 }
    }
}

/// The part as vertical columns over a square raster: for each cell, the height intervals
/// its centre line is inside the part (crossings paired bottom up).
#[derive(Debug, Clone)]
pub struct Columns {
    origin: [f64; 2],
    cell: f64,
    dims: [usize; 2],
    spans: Vec<Vec<[f64; 2]>>,
}

impl Columns {
    /// The columns of the triangles `tris` over `[min, max]` at `cell`.
    pub fn new(tris: &[[Point3; 3]], min: Point2, max: Point2, cell: f64) -> Self {
        let nx = (((max.x - min.x) / cell).ceil().max(1.0)) as usize;
        let ny = (((max.y - min.y) / cell).ceil().max(1.0)) as usize;
        // Centres off the round numbers that meshes' vertices and edges sit on, so that a
        // centre line meets a shared edge (counted twice) hardly ever.
        let jitter = 0.000_731 * cell;
        let origin = [min.x + jitter, min.y + jitter];
        let mut hits: Vec<Vec<f64>> = vec![Vec::new(); nx * ny];
        for t in tris {
            let [a, b, c] = *t;
            let n = (b - a).cross(&(c - a));
            if n.z.abs() <= 1e-12 * n.norm() {
                continue;
            }
            let lo = |v: f64, o: f64| (((v - o) / cell - 0.5).ceil().max(0.0)) as usize;
            let hi =
                |v: f64, o: f64, m: usize| ((((v - o) / cell - 0.5).floor()) as isize).min(m as isize - 1);
            let (x0, x1) = (a.x.min(b.x).min(c.x), a.x.max(b.x).max(c.x));
            let (y0, y1) = (a.y.min(b.y).min(c.y), a.y.max(b.y).max(c.y));
            let (i0, i1) = (lo(x0, origin[0]), hi(x1, origin[0], nx));
            let (j0, j1) = (lo(y0, origin[1]), hi(y1, origin[1], ny));
            if i1 < i0 as isize || j1 < j0 as isize {
                continue;
            }
            let edge =
                |p: &Point3, q: &Point3, x: f64, y: f64| (q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x);
            for j in j0..=j1 as usize {
                let y = origin[1] + (j as f64 + 0.5) * cell;
                for i in i0..=i1 as usize {
                    let x = origin[0] + (i as f64 + 0.5) * cell;
                    let (e0, e1, e2) = (edge(&a, &b, x, y), edge(&b, &c, x, y), edge(&c, &a, x, y));
                    let inside =
                        (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0);
                    if inside {
                        hits[j * nx + i].push(a.z - (n.x * (x - a.x) + n.y * (y - a.y)) / n.z);
                    }
                }
            }
        }
        let spans = hits
            .into_iter()
            .map(|mut h| {
                h.sort_by(f64::total_cmp);
                h.chunks_exact(2).map(|p| [p[0], p[1]]).collect()
            })
            .collect();
        Self { origin, cell, dims: [nx, ny], spans }
    }

    /// Columns given directly: `spans[j * nx + i]` for the cell `(i, j)` whose lower corner
    /// is `origin + cell * (i, j)`.
    pub fn from_spans(origin: Point2, cell: f64, dims: [usize; 2], spans: Vec<Vec<[f64; 2]>>) -> Self {
        Self { origin: [origin.x, origin.y], cell, dims, spans }
    }

    /// The centre of cell `k`.
    fn centre(&self, k: usize) -> Point2 {
        let (i, j) = (k % self.dims[0], k / self.dims[0]);
        Point2::new(
            self.origin[0] + (i as f64 + 0.5) * self.cell,
            self.origin[1] + (j as f64 + 0.5) * self.cell,
        )
    }

    /// Which columns are inside the part somewhere in `[z0, z1]`.
    fn occupied(&self, z0: f64, z1: f64) -> Vec<bool> {
        self.spans.iter().map(|s| s.iter().any(|[a, b]| *a <= z1 && *b >= z0)).collect()
    }

    /// The cells of `mask` as a region (each cell's square, rows of cells joined).
    fn region(&self, mask: &[bool]) -> Region2 {
        let [nx, ny] = self.dims;
        let mut rects = Vec::new();
        for j in 0..ny {
            let y0 = self.origin[1] + j as f64 * self.cell;
            let mut i = 0;
            while i < nx {
                if !mask[j * nx + i] {
                    i += 1;
                    continue;
                }
                let s = i;
                while i < nx && mask[j * nx + i] {
                    i += 1;
                }
                let (x0, x1) = (self.origin[0] + s as f64 * self.cell, self.origin[0] + i as f64 * self.cell);
                let y1 = y0 + self.cell;
                rects.push(vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]);
            }
        }
        Region2::union_contours(rects)
    }
}

/// The cutter-centre region of a T-slot cutter at one level ([`free_region`]).
#[derive(Debug, Clone)]
pub struct FreeRegion {
    /// Where the disc is clear of the part over its thickness (the neck not considered).
    pub disc: Region2,
    /// Where the disc and the neck are clear of the part, reachable from outside the
    /// stock at the level.
    pub reachable: Region2,
}

/// The free region of `tool` (a T-slot cutter) with its disc's bottom at `z` over the part's
/// `columns` within the `stock` (setup frame): see the module's documentation. Empty where
/// the neck does not reach above the stock's top.
pub fn free_region(columns: &Columns, tool: &Tool, z: f64, stock: &Aabb, margin: f64) -> FreeRegion {
    let c = &tool.cutter;
    let (r, t) = (c.radius, c.flute_length);
    let (neck_r, reach) = c.neck.map_or((c.shank_radius, c.stickout), |n| (n.radius, n.reach));
    let empty = FreeRegion { disc: Region2::empty(), reachable: Region2::empty() };
    if z + reach < stock.max.z + margin {
        return empty;
    }
    // A cell's centre stands for its square: the part may lie a cell beyond the squares.
    let grow = margin + columns.cell;
    let band =
        columns.region(&columns.occupied(z - margin, z + t + margin)).offset(r + grow, DEFAULT_ARC_STEP);
    let above =
        columns.region(&columns.occupied(z + t, f64::INFINITY)).offset(neck_r + grow, DEFAULT_ARC_STEP);
    let out = r + 3.0;
    let domain = Region2::rect(
        Point2::new(stock.min.x - out, stock.min.y - out),
        Point2::new(stock.max.x + out, stock.max.y + out),
    );
    let disc = domain.difference(&band);
    let free = disc.difference(&above);
    // Components reaching beyond the stock's outline grown by the disc's radius.
    let beyond = r + 1.0;
    let reaches = |g: &Region2| {
        g.bbox().is_some_and(|(lo, hi)| {
            lo.x < stock.min.x - beyond
                || lo.y < stock.min.y - beyond
                || hi.x > stock.max.x + beyond
                || hi.y > stock.max.y + beyond
        })
    };
    let mut reachable = Region2::empty();
    for g in free.components().into_iter().filter(reaches) {
        reachable = reachable.union(&g);
    }
    FreeRegion { disc, reachable }
}

/// The material (mm³, estimated) a T-slot cutter takes at level `z` from the free region
/// `free`: squares under the part's shadow above the disc, within the disc's radius of the
/// free region, that hold material over the disc's thickness, times that thickness. The
/// squares are 1 mm, or 1.5 times the material's sample spacing where that is wider, so
/// that every square holds samples (at 64^3 over 100 mm, 1 mm squares held a voxel
/// centre in two of five and the T-slot block's wings counted for too little).
fn undercut_volume(
    columns: &Columns,
    tool: &Tool,
    z: f64,
    free: &Region2,
    rest: &dyn RemainingMaterial,
) -> f64 {
    if free.is_empty() {
        return 0.0;
    }
    let near = free.offset(tool.cutter.radius, DEFAULT_ARC_STEP).index();
    let shadow = columns.occupied(z + tool.cutter.flute_length, f64::INFINITY);
    squares_volume(columns, tool, z, rest, |q| shadow[q] && near.contains(&columns.centre(q)))
}

/// An upper bound on [`undercut_volume`] at level `z` for any free region: the squares
/// under the part's shadow above the disc that hold material over the disc's thickness,
/// wherever the cutter can get to. Cheap next to the free region (no region is built), so
/// that levels with too little material under the shadow for a pass are passed over.
fn undercut_volume_bound(columns: &Columns, tool: &Tool, z: f64, rest: &dyn RemainingMaterial) -> f64 {
    let shadow = columns.occupied(z + tool.cutter.flute_length, f64::INFINITY);
    squares_volume(columns, tool, z, rest, |q| shadow[q])
}

/// The squares of [`undercut_volume`] with a cell `under` accepts that hold material over
/// the disc's thickness at level `z`, times the disc's thickness.
fn squares_volume(
    columns: &Columns,
    tool: &Tool,
    z: f64,
    rest: &dyn RemainingMaterial,
    under: impl Fn(usize) -> bool,
) -> f64 {
    let t = tool.cutter.flute_length;
    // Squares of whole cells.
    let side = rest.sample_spacing().map_or(1.0, |s| (1.5 * s).max(1.0));
    let k = ((side / columns.cell).ceil() as usize).max(1);
    let [nx, ny] = columns.dims;
    let mut squares = 0usize;
    for bj in (0..ny).step_by(k) {
        for bi in (0..nx).step_by(k) {
            let mut cells =
                (bj..(bj + k).min(ny)).flat_map(|j| (bi..(bi + k).min(nx)).map(move |i| j * nx + i));
            if !cells.any(&under) {
                continue;
            }
            let x0 = columns.origin[0] + bi as f64 * columns.cell;
            let y0 = columns.origin[1] + bj as f64 * columns.cell;
            let side = k as f64 * columns.cell;
            if rest.any_in_box(&Point3::new(x0, y0, z), &Point3::new(x0 + side, y0 + side, z + t)) {
                squares += 1;
            }
        }
    }
    let side = k as f64 * columns.cell;
    squares as f64 * side * side * t
}

/// The columns of `part` in `setup`'s frame over the stock grown by the tool's reach.
pub fn part_columns(part: &Mesh, setup: &Setup, stock: &Aabb, tool: &Tool, cell: f64) -> Columns {
    let tris = setup_triangles(part, setup);
    let out = tool.cutter.radius + 3.0;
    Columns::new(
        &tris,
        Point2::new(stock.min.x - out, stock.min.y - out),
        Point2::new(stock.max.x + out, stock.max.y + out),
        cell,
    )
}

/// The levels (disc bottoms) of an undercut pass with `tool` over `columns` in `stock`, and
/// the material of the level that holds most: from the undercut's floor up in steps of at
/// most the disc's thickness, the last at its roof, where a level holds at least
/// [`UndercutOptions::min_volume`]. None where no level does, and then the material
/// reported may be an upper bound: a level whose bound ([`undercut_volume_bound`], no
/// region built) falls short of `min_volume` is not measured in its free region, its bound
/// stands for it (on the bunny, which has no undercut worth a pass, every level).
pub fn undercut_levels(
    columns: &Columns,
    tool: &Tool,
    stock: &Aabb,
    rest: &dyn RemainingMaterial,
    opts: &UndercutOptions,
) -> (Vec<f64>, f64) {
    scan_levels(columns, tool, stock, rest, opts, true)
}

/// [`undercut_levels`] measuring every level's material in its free region, none passed
/// over on its bound: the baseline the `undercut_scan` bench compares it with (the same
/// levels; the material reported the same where some level is useful).
pub fn undercut_levels_unbounded(
    columns: &Columns,
    tool: &Tool,
    stock: &Aabb,
    rest: &dyn RemainingMaterial,
    opts: &UndercutOptions,
) -> (Vec<f64>, f64) {
    scan_levels(columns, tool, stock, rest, opts, false)
}

/// The scan of [`undercut_levels`]; `bounded`: levels whose material bound
/// ([`undercut_volume_bound`]) is under [`UndercutOptions::min_volume`] are not measured.
fn scan_levels(
    columns: &Columns,
    tool: &Tool,
    stock: &Aabb,
    rest: &dyn RemainingMaterial,
    opts: &UndercutOptions,
    bounded: bool,
) -> (Vec<f64>, f64) {
    let c = &tool.cutter;
    let t = c.flute_length;
    let reach = c.neck.map_or(c.stickout, |n| n.reach);
    let lo = stock.min.z.max(stock.max.z + opts.margin - reach);
    let hi = stock.max.z - t;
    let ordered = matches!(lo.partial_cmp(&hi), Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal));
    if !ordered || opts.scan_step.is_nan() || opts.scan_step <= 0.0 {
        return (Vec::new(), 0.0);
    }
    // Where `bounded`, levels whose bound falls short are not measured (their bound
    // stands for them: no such level is useful).
    let volume = |z: f64| {
        if bounded {
            let bound = undercut_volume_bound(columns, tool, z, rest);
            if bound < opts.min_volume {
                return bound;
            }
        }
        let f = free_region(columns, tool, z, stock, opts.margin);
        undercut_volume(columns, tool, z, &f.reachable, rest)
    };
    let useful = |z: f64| volume(z) >= opts.min_volume;
    let n = ((hi - lo) / opts.scan_step).floor() as usize;
    let zs: Vec<f64> = (0..=n).map(|k| lo + k as f64 * opts.scan_step).collect();
    // Each level on its own (in order, so the same on any number of threads).
    let vols: Vec<f64> = zs.par_iter().map(|&z| volume(z)).collect();
    let Some(first) = vols.iter().position(|&v| v >= opts.min_volume) else {
        return (Vec::new(), vols.iter().copied().fold(0.0, f64::max));
    };
    let last = vols.iter().rposition(|&v| v >= opts.min_volume).unwrap_or(first);
    let most = vols.iter().copied().fold(0.0, f64::max);
    // The floor and roof to within a 64th of the scan's step.
    let refine = |mut good: f64, mut bad: f64| {
        for _ in 0..6 {
            let mid = 0.5 * (good + bad);
            if useful(mid) {
                good = mid;
            } else {
                bad = mid;
            }
        }
        good
    };
    let floor = if first > 0 { refine(zs[first], zs[first - 1]) } else { zs[first] };
    let roof = if last + 1 < zs.len() { refine(zs[last], zs[last + 1]) } else { zs[last] };
    let steps = ((roof - floor) / t).ceil().max(0.0) as usize;
    let levels = (0..=steps)
        .map(|k| if steps == 0 { floor } else { floor + (roof - floor) * k as f64 / steps as f64 })
        .collect();
    (levels, most)
}

/// Motion bookkeeping of a pass.
struct Pass<'s, S: MotionSink> {
    sink: &'s mut S,
    pos: Option<Point3>,
    summary: PlanSummary,
    rapid_feed: f64,
}

impl<S: MotionSink> Pass<'_, S> {
    fn send(&mut self, m: Motion<'_>) -> Result<(), ToolpathError<S::Error>> {
        self.sink.motion(&m).map_err(ToolpathError::Sink)
    }

    fn go(&mut self, to: Point3, feed: Option<f64>) -> Result<(), ToolpathError<S::Error>> {
        let d = self.pos.map_or(0.0, |p| (to - p).norm());
        if self.pos.is_some() && d < 1e-9 {
            return Ok(());
        }
        self.pos = Some(to);
        match feed {
            Some(f) => {
                self.summary.cutting_length += d;
                self.summary.estimated_time_s += 60.0 * d / f;
                self.send(Motion::Linear { to, feed: f, extrude: None })
            }
            None => {
                self.summary.rapid_length += d;
                self.summary.estimated_time_s += 60.0 * d / self.rapid_feed;
                self.send(Motion::Rapid { to })
            }
        }
    }
}

/// Where a contour of the free region is entered: the vertex farthest outside the stock's
/// outline, and the point beyond the outline grown by the disc's radius straight out from
/// it (along the free region), or none.
fn entry(contour: &Polyline2, free: &RegionIndex, stock: &Aabb, r: f64) -> Option<(usize, Point2)> {
    let outside = |p: &Point2| {
        let dx = (stock.min.x - p.x).max(p.x - stock.max.x).max(0.0);
        let dy = (stock.min.y - p.y).max(p.y - stock.max.y).max(0.0);
        dx.hypot(dy)
    };
    let (k, v) = contour
        .points
        .iter()
        .enumerate()
        .max_by(|a, b| outside(a.1).total_cmp(&outside(b.1)).then(b.0.cmp(&a.0)))?;
    let clamp = Point2::new(v.x.clamp(stock.min.x, stock.max.x), v.y.clamp(stock.min.y, stock.max.y));
    let d = outside(v);
    if d >= r {
        return Some((k, *v));
    }
    // The disc clear of the stock's box, no farther (its edge on the outline), where that
    // is in the free region, else a millimetre farther.
    [r, r + 1.0].into_iter().find_map(|want| beyond(v, d, clamp, stock, want, free, &outside)).map(|p| (k, p))
}

/// The point `want` outside the box `stock` straight out from `v` (`d` outside it, nearest
/// to `clamp` on it), or along an axis, reached from `v` within the region `free`.
fn beyond(
    v: &Point2,
    d: f64,
    clamp: Point2,
    stock: &Aabb,
    want: f64,
    free: &RegionIndex,
    outside: &dyn Fn(&Point2) -> f64,
) -> Option<Point2> {
    let mut points = Vec::new();
    if d > 1e-9 {
        points.push(clamp + (v - clamp) * (want / d));
    }
    for (dir, s) in [
        (Vector2::new(1.0, 0.0), stock.max.x + want - v.x),
        (Vector2::new(-1.0, 0.0), v.x - stock.min.x + want),
        (Vector2::new(0.0, 1.0), stock.max.y + want - v.y),
        (Vector2::new(0.0, -1.0), v.y - stock.min.y + want),
    ] {
        if s > 0.0 {
            points.push(v + dir * s);
        }
    }
    points.into_iter().find(|p| outside(p) >= want * (1.0 - 1e-12) && free.segment_inside(v, p, 1e-6))
}

/// An undercut pass: `tool` (a T-slot cutter) at `levels` ([`undercut_levels`]) in `setup`
/// over `columns` of the part, the `stock` box (setup frame) and the material `rest` left.
#[derive(Clone, Copy)]
pub struct Undercut<'a> {
    /// The part's columns ([`part_columns`]).
    pub columns: &'a Columns,
    /// The setup whose frame the pass is planned in.
    pub setup: &'a Setup,
    /// The T-slot cutter.
    pub tool: &'a Tool,
    /// The stock box in the setup's frame.
    pub stock: &'a Aabb,
    /// The material left before the pass.
    pub rest: &'a dyn RemainingMaterial,
    /// The disc bottoms, floor up.
    pub levels: &'a [f64],
}

/// Plans the undercut pass `u` into `sink`: tool change, spindle and coolant, the contours,
/// spindle off.
pub fn plan_undercut<S: MotionSink>(
    u: &Undercut<'_>,
    opts: &UndercutOptions,
    sink: &mut S,
) -> Result<PlanSummary, ToolpathError<S::Error>> {
    let Undercut { columns, setup, tool, stock, rest, levels } = *u;
    let c = &tool.cutter;
    let (r, t) = (c.radius, c.flute_length);
    let neck_r = c.neck.map_or(c.shank_radius, |n| n.radius);
    let clear_z = stock.max.z + opts.clearance;
    let summary = PlanSummary { layers: levels.len(), stock: Some(*stock), ..Default::default() };
    let mut pass = Pass { sink, pos: None, summary, rapid_feed: opts.rapid_feed };
    pass.send(Motion::Setup { frame: setup.frame, rotary: [None; 3] })?;
    let note = format!("s2g-toolpath: tool {} T-slot cutter radius {r} thickness {t} undercut", tool.number);
    pass.send(Motion::Comment(note.into()))?;
    pass.send(Motion::ToolChange { tool: tool.number })?;
    pass.send(Motion::Spindle { rpm: tool.spindle_rpm, direction: SpindleDirection::Clockwise })?;
    if tool.coolant != Coolant::Off {
        pass.send(Motion::Coolant(tool.coolant))?;
    }
    // The neck meets no material left over its length above the disc.
    let neck_clear = |a: &Point2, b: &Point2, z: f64| {
        !rest.any_near_segment(a, b, neck_r + opts.margin, z + t, stock.max.z + opts.clearance)
    };
    for (li, &z) in levels.iter().enumerate() {
        let f = free_region(columns, tool, z, stock, opts.margin);
        if f.reachable.is_empty() {
            pass.summary.skipped_layers += 1;
            continue;
        }
        pass.send(Motion::Marker(s2g_gcode::Marker::Layer { index: Some(li as i64), z: Some(z) }))?;
        let index = f.reachable.index();
        // The contours around the part: the free region's holes.
        for contour in f.reachable.loops().into_iter().filter(|l| l.signed_area() < 0.0) {
            let takes = contour.segments().any(|(a, b)| rest.any_near_segment(&a, &b, r, z, z + t));
            if !takes {
                continue;
            }
            let Some((k, out)) = entry(&contour, &index, stock, r) else { continue };
            let n = contour.points.len();
            let v = contour.points[k];
            if !neck_clear(&out, &v, z) {
                continue;
            }
            pass.go(Point3::new(out.x, out.y, clear_z), None)?;
            pass.go(Point3::new(out.x, out.y, z), None)?;
            pass.go(Point3::new(v.x, v.y, z), Some(tool.feed))?;
            pass.summary.lead_in_entries += 1;
            // Around the contour each way from the entry, as far as the neck is clear, and
            // back (a contour gone round whole ends at the entry); the second way stops
            // where the first one got to.
            let mut done = 0;
            for forward in [true, false] {
                let mut path = vec![v];
                let mut at = k;
                let budget = n - done;
                for _ in 0..budget {
                    let next = if forward { (at + 1) % n } else { (at + n - 1) % n };
                    let (a, b) = (contour.points[at], contour.points[next]);
                    if !neck_clear(&a, &b, z) {
                        break;
                    }
                    pass.go(Point3::new(b.x, b.y, z), Some(tool.feed))?;
                    path.push(b);
                    at = next;
                    done += 1;
                }
                if at != k {
                    for p in path.iter().rev().skip(1) {
                        pass.go(Point3::new(p.x, p.y, z), Some(tool.feed))?;
                    }
                }
            }
            pass.go(Point3::new(out.x, out.y, z), Some(tool.feed))?;
            pass.go(Point3::new(out.x, out.y, clear_z), None)?;
            pass.summary.retracts += 1;
        }
    }
    if tool.coolant != Coolant::Off {
        pass.send(Motion::Coolant(Coolant::Off))?;
    }
    pass.send(Motion::Spindle { rpm: 0.0, direction: SpindleDirection::Off })?;
    Ok(pass.summary)
}

/// Whether the undercut pass `u` cuts anything ([`plan_undercut`] into a sink that keeps
/// nothing): a level may hold material while no contour around it can be entered from
/// outside.
pub fn undercut_cuts(u: &Undercut<'_>, opts: &UndercutOptions) -> bool {
    struct Discard;
    impl MotionSink for Discard {
        type Error = std::convert::Infallible;
        fn motion(&mut self, _: &Motion<'_>) -> Result<(), Self::Error> {
            Ok(())
        }
    }
    plan_undercut(u, opts, &mut Discard).is_ok_and(|s| s.lead_in_entries > 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A T-slot along x through a 100 x 60 x 40 block whose wings (30 wide) leave the disc
    /// room across, under a 12 mm neck: the disc alone is free 2 mm off the slot's centre,
    /// but there its neck would hit the lip above, so the cutter is not; on the centre line
    /// both are clear, and the region reaches outside the stock along the slot.
    #[test]
    fn the_free_region_excludes_where_the_neck_hits_the_lip() {
        let (columns, stock, tool) = t_slot_block();
        let f = free_region(&columns, &tool, 18.2, &stock, 0.15);
        let ix = (f.disc.index(), f.reachable.index());
        let at = |x: f64, y: f64| Point2::new(x, y);
        assert!(ix.0.contains(&at(0.0, 2.0)), "the disc alone is clear 2 mm off the centre");
        assert!(!ix.1.contains(&at(0.0, 2.0)), "the neck would hit the lip there");
        assert!(ix.1.contains(&at(0.0, 0.3)) && ix.1.contains(&at(-55.0, 0.3)), "along the slot");
        assert!(!ix.0.contains(&at(0.0, 5.0)), "the disc would cut the wing's wall");
        // The disc not reaching above the stock's top with its neck: nothing is free.
        assert!(free_region(&columns, &tool, 5.0, &stock, 0.15).reachable.is_empty());
        // Below the wings' floor the disc meets the part across the slot.
        assert!(!free_region(&columns, &tool, 17.5, &stock, 0.15).reachable.index().contains(&at(0.0, 0.0)));
    }

    /// The level scan with its bound finds the levels the scan measuring every level
    /// does, on the T-slot block of the test above with its wings full of material, and
    /// none with a sliver of it; the bound is never under a level's measured material.
    #[test]
    fn levels_passed_over_on_their_bound_hold_too_little() {
        let (columns, stock, tool) = t_slot_block();
        let wings = |min: &Point3, max: &Point3| {
            let y = |v: f64| v.abs() > 6.0 && v.abs() < 15.0;
            min.x < 50.0
                && max.x > -50.0
                && min.z < 28.0
                && max.z > 18.0
                && (y(min.y) || y(max.y) || (min.y < -6.0 && max.y > 6.0))
        };
        let sliver = |min: &Point3, max: &Point3| wings(min, max) && min.x < -40.0 && max.x > -41.0;
        let opts = UndercutOptions { min_volume: 500.0, ..UndercutOptions::default() };
        for (name, rest) in [("wings", &wings as &dyn RemainingMaterial), ("sliver", &sliver)] {
            let bounded = undercut_levels(&columns, &tool, &stock, rest, &opts);
            let every = undercut_levels_unbounded(&columns, &tool, &stock, rest, &opts);
            assert_eq!(bounded.0, every.0, "{name}");
            assert_eq!(bounded.0.is_empty(), name == "sliver", "{name}: {:?}", bounded.0);
            for k in 0..40 {
                let z = 10.0 + 0.5 * k as f64;
                let f = free_region(&columns, &tool, z, &stock, opts.margin);
                let measured = undercut_volume(&columns, &tool, z, &f.reachable, rest);
                let bound = undercut_volume_bound(&columns, &tool, z, rest);
                assert!(bound >= measured, "{name} z {z}: bound {bound} under {measured}");
            }
        }
    }

    /// The T-slot block of [`the_free_region_excludes_where_the_neck_hits_the_lip`] as
    /// 0.2 mm columns, its stock and a 21 mm T-slot cutter on a 10 mm neck.
    fn t_slot_block() -> (Columns, Aabb, Tool) {
        let cell = 0.2;
        let (lo, hi) = (Point2::new(-70.0, -50.0), Point2::new(70.0, 50.0));
        let dims = [((hi.x - lo.x) / cell) as usize, ((hi.y - lo.y) / cell) as usize];
        let mut spans = Vec::new();
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let (x, y) = (lo.x + (i as f64 + 0.5) * cell, lo.y + (j as f64 + 0.5) * cell);
                spans.push(if x.abs() > 50.0 || y.abs() > 30.0 {
                    vec![]
                } else if y.abs() < 6.0 {
                    vec![[0.0, 18.0]]
                } else if y.abs() < 15.0 {
                    vec![[0.0, 18.0], [28.0, 40.0]]
                } else {
                    vec![[0.0, 40.0]]
                });
            }
        }
        let columns = Columns::from_spans(lo, cell, dims, spans);
        let stock = Aabb::new(Point3::new(-50.0, -30.0, 0.0), Point3::new(50.0, 30.0, 40.0));
        let mut tool = Tool::new(s2g_geom::Cutter::t_slot(10.5, 9.0, 5.0, 30.0));
        tool.cutter.stickout = 40.0;
        (columns, stock, tool)
    }
}
