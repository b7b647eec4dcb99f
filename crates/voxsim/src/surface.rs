//! The machined surface of a 3-axis setup as a height field, and its deviation from the
//! part's surface (issue 36: at 256^3 a voxel is bigger than any scallop, so finishing is
//! measured on columns instead).
//!
//! [`HeightField`] is a [`MotionSink`]: a grid of vertical columns, each holding the
//! lowest height any cutter reached in it. Every move (rapids too, as in the simulator)
//! sweeps its cutter's primitives along the segment and lowers each column within reach
//! to the bottom of the swept volume on the column's line, in closed form per primitive
//! (the dexel carver's column intervals: exact in Z for flat and ball ends, the bull nose's
//! torus to machine precision), so the field is exact at its columns whatever their
//! spacing. [`surface_deviation`] compares it with the part's surface.

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use rayon::prelude::*;
use s2g_gcode::{ArcSpec, Motion, MotionSink};
use s2g_geom::{Cutter, DropCutter, Isometry3, MeshIndex, Point3, Solids, Vector3};

use crate::columns::{ColumnTests, box_gap, rect_segment_distance, rect_segment_distance_roots};
use crate::engine::ToolPrims;
use crate::error::{Result, SimError};
use crate::sweep::{Prim, Seg};
use crate::tool::{ToolTable, tool_error};

/// Options of [`HeightField::new_opt`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeightFieldOptions {
    /// Distance between neighbouring columns, in X and Y. Default `0.05`.
    pub spacing: f64,
    /// Largest chord sagitta of arcs, which are swept as chords. Default `0.001`.
    pub arc_tolerance: f64,
    /// The most columns a field may have (an error beyond). Default `400_000_000`.
    pub max_columns: usize,
    /// Where the tool passed: a feed move (not a rapid) marks every column within this
    /// horizontal distance of its tip's path with the lowest tip height there
    /// ([`HeightField::passed`]), so that the deviation counts only the surface a pass
    /// went over (a finisher's passes left out where its shank would meet the stock leave
    /// a strip their neighbours only brush, and the tool lifted over it). Half the
    /// finisher's pass spacing or a little more. `None` (default): no marks, and every
    /// column counts as passed.
    pub pass_width: Option<f64>,
}

impl Default for HeightFieldOptions {
    fn default() -> Self {
        Self { spacing: 0.05, arc_tolerance: 0.001, max_columns: 400_000_000, pass_width: None }
    }
}

/// The lowest height every column of a grid was cut to, in the part frame (see the module
/// docs). Columns are at `min + (i, j) spacing`; a column never reached holds `+inf`.
/// Tool changes select the cutter from the tool table; setup motions must keep the tool
/// axis along +Z of the part frame (a 3-axis setup), else the move is refused with
/// [`SimError::InvalidMotion`].
#[derive(Debug, Clone)]
pub struct HeightField {
    min: [f64; 2],
    spacing: f64,
    nx: usize,
    ny: usize,
    top: Vec<f64>,
    /// The lowest tip height of a feed whose path passed within
    /// [`HeightFieldOptions::pass_width`] of each column (`+inf`: none; empty without a
    /// width).
    passed: Vec<f64>,
    pass_width: Option<f64>,
    /// What the finisher left out ([`HeightField::leave_out`]).
    left_out: LeftOut,
    tools: ToolTable,
    prims: ToolPrims,
    /// The current cutter's radius and corner radius: its tip profile bounds from below
    /// how low a move can cut a column, so columns already lower are skipped.
    profile: (f64, f64),
    frame: Isometry3,
    pos: Option<Point3>,
    arc_tolerance: f64,
    /// The highest `top` of every [`TILE`] x [`TILE`] block of columns (row-major over
    /// the blocks): a move whose lower bound over a block is at least this cannot lower
    /// any of its columns, so the block is passed over without visiting them.
    tile_max: Vec<f64>,
    /// Sweep every column of the move's box ([`HeightField::sweep_reference`]), the
    /// baseline the tiled sweep is tested and benched against.
    reference: bool,
    /// Decide every column's mark and floor by their square roots and every block's
    /// distance by six (the tiled sweep's baseline before [`ColumnTests`] and
    /// [`rect_segment_distance`]).
    exact_tests: bool,
    /// Compute every block's distance from the path, without first passing over the
    /// blocks that the gap between the block's box and the path's decides (the tiled
    /// sweep's baseline before [`HeightField::sweep`]'s box test).
    every_distance: bool,
    /// A move whose box holds more columns than this is swept on rayon's threads
    /// ([`HeightField::set_parallel_columns`]).
    parallel_columns: usize,
}

/// [`HeightField::set_parallel_columns`]'s default.
const PARALLEL_COLUMNS: usize = 4096;

/// Columns along each side of a block of [`HeightField::tile_max`].
const TILE: usize = 8;

/// A run of columns (rows of cut heights, marks or block maxima) a sweep writes.
type Cols<'a> = &'a mut [f64];

impl HeightField {
    /// [`HeightField::new_opt`] with the default options.
    pub fn new(min: [f64; 2], max: [f64; 2], tools: ToolTable) -> Result<Self> {
        Self::new_opt(min, max, tools, &HeightFieldOptions::default())
    }

    /// A field over the rectangle `[min, max]` (part frame) cut by `tools` (the default
    /// tool until a tool change). [`SimError::InvalidOption`] for a rectangle that is not
    /// finite and ordered, a spacing or tolerance that is not finite and positive, or too
    /// many columns; [`SimError::InvalidTool`] for an impossible tool.
    pub fn new_opt(min: [f64; 2], max: [f64; 2], tools: ToolTable, o: &HeightFieldOptions) -> Result<Self> {
        tools.validate()?;
        let ok = min.iter().chain(&max).all(|v| v.is_finite()) && min[0] <= max[0] && min[1] <= max[1];
        let width_ok = o.pass_width.is_none_or(|w| w.is_finite() && w >= 0.0);
        if !(ok && o.spacing.is_finite() && o.spacing > 0.0 && o.arc_tolerance > 0.0 && width_ok) {
            return Err(SimError::InvalidOption(format!(
                "height field over {min:?} .. {max:?} at spacing {} (arc tolerance {}, pass width {:?})",
                o.spacing, o.arc_tolerance, o.pass_width
            )));
        }
        let n = |a: usize| ((max[a] - min[a]) / o.spacing + 1e-9).floor() + 1.0;
        if n(0) * n(1) > o.max_columns as f64 {
            return Err(SimError::InvalidOption(format!(
                "{} columns, more than {}",
                n(0) * n(1),
                o.max_columns
            )));
        }
        let (nx, ny) = (n(0) as usize, n(1) as usize);
        let prims = ToolPrims::cutter(&tools.default);
        let profile = (tools.default.radius, tools.default.corner_radius());
        Ok(Self {
            min,
            spacing: o.spacing,
            nx,
            ny,
            top: vec![f64::INFINITY; nx * ny],
            passed: if o.pass_width.is_some() { vec![f64::INFINITY; nx * ny] } else { Vec::new() },
            pass_width: o.pass_width,
            left_out: LeftOut::default(),
            tools,
            prims,
            profile,
            frame: Isometry3::identity(),
            pos: None,
            arc_tolerance: o.arc_tolerance,
            tile_max: vec![f64::INFINITY; nx.div_ceil(TILE) * ny.div_ceil(TILE)],
            reference: false,
            exact_tests: false,
            every_distance: false,
            parallel_columns: PARALLEL_COLUMNS,
        })
    }

    /// Columns along X and Y.
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// The XY position of column `(i, j)`.
    pub fn column(&self, i: usize, j: usize) -> [f64; 2] {
        [self.min[0] + i as f64 * self.spacing, self.min[1] + j as f64 * self.spacing]
    }

    /// The lowest height column `(i, j)` was cut to (`+inf` when never reached; `None`
    /// outside the grid).
    pub fn top(&self, i: usize, j: usize) -> Option<f64> {
        (i < self.nx && j < self.ny).then(|| self.top[j * self.nx + i])
    }

    /// Whether a feed's tip path passed within [`HeightFieldOptions::pass_width`] of the
    /// column nearest `(x, y)` with the tip at most `z` there (always `true` without a
    /// width; `false` outside the grid).
    pub fn passed(&self, x: f64, y: f64, z: f64) -> bool {
        if self.pass_width.is_none() {
            return true;
        }
        let fx = ((x - self.min[0]) / self.spacing).round();
        let fy = ((y - self.min[1]) / self.spacing).round();
        if !(fx >= 0.0 && fy >= 0.0 && fx < self.nx as f64 && fy < self.ny as f64) {
            return false;
        }
        self.passed[fy as usize * self.nx + fx as usize] <= z
    }

    /// Marks the finisher's left-out pass stretches (tip positions, setup frame: each a
    /// segment between two consecutive pass points it left out, or one point twice), with
    /// the `width` of the strip each stands for (half the stepover: the columns nearer it
    /// than the passes beside it). A column whose ball rests on the surface with its tip
    /// within `width` of one (in XY, at about its height) is not passed over: the finisher
    /// left it out on purpose (its shank or holder would have met the stock), even where
    /// a pass beside the stretch came within the pass width. Replaces earlier marks.
    pub fn leave_out(&mut self, segments: &[[Point3; 2]], width: f64) {
        self.left_out = LeftOut::new(segments, width);
    }

    /// [`HeightFieldOptions::pass_width`].
    pub fn pass_width(&self) -> Option<f64> {
        self.pass_width
    }

    /// Every column's cut height and pass mark, row-major (the marks empty without a pass
    /// width): for comparing the tiled sweep with the reference.
    #[doc(hidden)]
    pub fn columns(&self) -> (&[f64], &[f64]) {
        (&self.top, &self.passed)
    }

    /// Sweeps every later move with [`HeightField::sweep_reference`] (every column of the
    /// move's box visited) instead of the tiled sweep; the results are the same bit for
    /// bit. For tests and benches.
    #[doc(hidden)]
    pub fn use_reference_sweep(&mut self) {
        self.reference = true;
    }

    /// Makes the tiled sweep decide every column's mark and floor, and every block's
    /// distance, by square roots as it did before [`ColumnTests`]: the baseline its bench
    /// and test compare against (the field is the same bit for bit).
    #[doc(hidden)]
    pub fn use_exact_column_tests(&mut self) {
        self.exact_tests = true;
    }

    /// Makes the tiled sweep compute every block's distance from the path, as it did
    /// before the box test passed most far blocks over first: the baseline its bench and
    /// test compare against (the field is the same bit for bit).
    #[doc(hidden)]
    pub fn use_every_block_distance(&mut self) {
        self.every_distance = true;
    }

    /// Sweeps a move whose box holds more than `columns` columns on rayon's threads (in
    /// rows of blocks), any other on the calling thread; default 4096. `usize::MAX`: every
    /// move on the calling thread, for a field fed on a thread of its own beside other
    /// work (each parallel sweep costs a hand-off to the pool and back). The field is the
    /// same bit for bit either way: each column is computed by the same expressions, by
    /// one thread.
    pub fn set_parallel_columns(&mut self, columns: usize) {
        self.parallel_columns = columns;
    }

    /// What a move from `a` to `b` (`feed`: a feed, which marks the columns it passes over)
    /// sweeps over: its segment, the tool's lower primitives, the mark width, and the
    /// columns within the primitives' (or the marks') reach of it; `None` when none is.
    fn reach(&self, a: Point3, b: Point3, feed: bool) -> Option<Reach> {
        let seg = Seg::new(a, b, Vector3::z());
        let (lower, n) = lower_prims(&self.prims);
        let width = self.pass_width.filter(|_| feed);
        let reach = lower[..n].iter().map(|p| p.bound().2).fold(width.unwrap_or(0.0), f64::max);
        let (s, min) = (self.spacing, self.min);
        let range = |lo: f64, hi: f64, m: f64, n: usize| {
            let i0 = ((lo - reach - m) / s).ceil().max(0.0);
            let i1 = ((hi + reach - m) / s).floor().min(n as f64 - 1.0);
            (i0 <= i1).then_some((i0 as usize, i1 as usize))
        };
        let (i0, i1) = range(a.x.min(b.x), a.x.max(b.x), min[0], self.nx)?;
        let (j0, j1) = range(a.y.min(b.y), a.y.max(b.y), min[1], self.ny)?;
        Some(Reach { seg, lower, n, width, cols: [i0, i1, j0, j1] })
    }

    /// Lowers the columns the cutter swept from `a` to `b` (part frame, axis +Z) reaches,
    /// and marks those a feed's tip path passes near ([`HeightField::passed`]): the
    /// columns of [`HeightField::sweep_reference`] in blocks of [`TILE`] x [`TILE`], a
    /// block left out where its highest column lies no higher than the cutter's lowest
    /// possible reach over the block (the tip profile at the block's nearest distance from
    /// the path) and no mark can fall in it. A column it skips the reference skips too, and
    /// every other column is computed by the same expressions, so the field is the same
    /// bit for bit. Most blocks it passes over are decided first on the gap between the
    /// block's box and the path's, a lower bound of that distance (one square root instead
    /// of the distance's six squared distances, and divisions): `floor` is monotone, so a
    /// block the bound passes over the distance passes over too, and only the others have
    /// their distance computed.
    fn sweep(&mut self, a: Point3, b: Point3, feed: bool) {
        if self.reference {
            return self.sweep_reference(a, b, feed);
        }
        let Some(Reach { seg, lower, n, width, cols: [i0, i1, j0, j1] }) = self.reach(a, b, feed) else {
            return;
        };
        let prims = &lower[..n];
        let (s, nx, ny, min) = (self.spacing, self.nx, self.ny, self.min);
        let w = width.unwrap_or(-1.0);
        let (zmin, ab) = (a.z.min(b.z), (b - a).xy());
        let path_box = [a.x.min(b.x), a.x.max(b.x), a.y.min(b.y), a.y.max(b.y)];
        let box_test = !self.every_distance;
        let tests = ColumnTests::new(self.profile, zmin, w, !self.exact_tests);
        let rect_distance =
            if self.exact_tests { rect_segment_distance_roots } else { rect_segment_distance };
        let floor = move |rho: f64| tests.floor(rho);
        let ab2 = ab.norm_squared();
        let tnx = nx.div_ceil(TILE);
        let (tj0, tj1) = (j0 / TILE, j1 / TILE);
        // One row of blocks: its columns' rows, its blocks' maxima and its marks (empty
        // without marks).
        let block_row = |tj: usize, rows: &mut [f64], tmax: &mut [f64], mark: &mut [f64]| {
            let (r0, r1) = ((tj * TILE).max(j0), (tj * TILE + TILE - 1).min(j1));
            let y = |j: usize| min[1] + j as f64 * s;
            for (ti, high) in tmax.iter_mut().enumerate().take(i1 / TILE + 1).skip(i0 / TILE) {
                let (c0, c1) = ((ti * TILE).max(i0), (ti * TILE + TILE - 1).min(i1));
                let (lo, hi) = ([min[0] + c0 as f64 * s, y(r0)], [min[0] + c1 as f64 * s, y(r1)]);
                // The gap between the block's and the path's boxes, less twice the margin
                // below: at most `near`, so where it passes the block over, so would `near`.
                if box_test {
                    let gap = box_gap(lo, hi, path_box);
                    if gap > w && *high <= zmin + floor(gap) {
                        continue;
                    }
                }
                // The block's nearest distance from the path, less a margin far above the
                // rounding of either distance, so its bound is at most every column's.
                let near = rect_distance(lo, hi, [a.x, a.y], [b.x, b.y]);
                let near = (near - 1e-9).max(0.0);
                if near > w && *high <= zmin + floor(near) {
                    continue;
                }
                let mut lowered = false;
                // No mark falls in a block farther than the mark width from the path.
                let marks = near <= w;
                for j in r0..=r1 {
                    let off = (j - tj * TILE) * nx;
                    let row = &mut rows[off..off + nx];
                    // The block's row, passed over as the block would be on its own box
                    // gap: no column of it is marked or lowered.
                    if box_test {
                        let gap = box_gap([lo[0], y(j)], [hi[0], y(j)], path_box);
                        let top = row[c0..=c1].iter().fold(f64::NEG_INFINITY, |m, &t| m.max(t));
                        if gap > w && top <= zmin + floor(gap) {
                            continue;
                        }
                    }
                    for (i, t) in row.iter_mut().enumerate().take(c1 + 1).skip(c0) {
                        // A column at most `zmin` is left as it is (`floor` is never
                        // negative), and without marks nothing else is done to it.
                        if !marks && *t <= zmin {
                            continue;
                        }
                        let base = Point3::new(min[0] + i as f64 * s, y(j), 0.0);
                        let ap = nalgebra::Vector2::new(base.x - a.x, base.y - a.y);
                        let u = if ab2 > 0.0 { (ap.dot(&ab) / ab2).clamp(0.0, 1.0) } else { 0.0 };
                        // The squared distance from the path: `rho` is its square root.
                        let rho2 = (ap - ab * u).norm_squared();
                        if tests.marks(rho2) {
                            let m = &mut mark[off + i];
                            *m = m.min(a.z + (b.z - a.z) * u);
                        }
                        // `floor` is never negative, so a column at most `zmin` is skipped
                        // without it.
                        if *t <= zmin || tests.above(*t, rho2) {
                            continue;
                        }
                        for p in prims {
                            if let Some(lo) = p.column_low(&seg, &base) {
                                let old = *t;
                                *t = t.min(lo);
                                lowered |= *t != old;
                            }
                        }
                    }
                }
                if lowered {
                    let (x0, x1) = (ti * TILE, (ti * TILE + TILE).min(nx));
                    *high =
                        rows.chunks(nx).flat_map(|r| &r[x0..x1]).fold(f64::NEG_INFINITY, |m, &t| m.max(t));
                }
            }
        };
        let (top0, top1) = (tj0 * TILE * nx, ((tj1 + 1) * TILE).min(ny) * nx);
        let rows = &mut self.top[top0..top1];
        let tmax = &mut self.tile_max[tj0 * tnx..(tj1 + 1) * tnx];
        let parallel = (i1 - i0 + 1) * (j1 - j0 + 1) > self.parallel_columns;
        let chunk = TILE * nx;
        match width {
            Some(_) => {
                let marks = &mut self.passed[top0..top1];
                let it =
                    |(k, ((r, m), t)): (usize, ((Cols<'_>, Cols<'_>), Cols<'_>))| block_row(tj0 + k, r, t, m);
                if parallel {
                    rows.par_chunks_mut(chunk)
                        .zip(marks.par_chunks_mut(chunk))
                        .zip(tmax.par_chunks_mut(tnx))
                        .enumerate()
                        .for_each(it);
                } else {
                    rows.chunks_mut(chunk)
                        .zip(marks.chunks_mut(chunk))
                        .zip(tmax.chunks_mut(tnx))
                        .enumerate()
                        .for_each(it);
                }
            }
            None => {
                let it = |(k, (r, t)): (usize, (&mut [f64], &mut [f64]))| block_row(tj0 + k, r, t, &mut []);
                if parallel {
                    rows.par_chunks_mut(chunk).zip(tmax.par_chunks_mut(tnx)).enumerate().for_each(it);
                } else {
                    rows.chunks_mut(chunk).zip(tmax.chunks_mut(tnx)).enumerate().for_each(it);
                }
            }
        }
    }

    /// The sweep of every column in the move's box, one row at a time: the baseline of
    /// [`HeightField::sweep`].
    fn sweep_reference(&mut self, a: Point3, b: Point3, feed: bool) {
        let Some(Reach { seg, lower, n, width, cols: [i0, i1, j0, j1] }) = self.reach(a, b, feed) else {
            return;
        };
        let prims = &lower[..n];
        let (s, nx, min) = (self.spacing, self.nx, self.min);
        let rows = &mut self.top[j0 * nx..(j1 + 1) * nx];
        let mut no_marks = [];
        let marks: &mut [f64] = match width {
            Some(_) => &mut self.passed[j0 * nx..(j1 + 1) * nx],
            None => &mut no_marks,
        };
        let w = width.unwrap_or(-1.0);
        // Every cutter point at horizontal distance rho from the axis lies at least
        // `floor(rho)` above the tip (its end's profile, the corner radius beyond the
        // radius, where only the shank and holder are): a column farther than rho from the
        // segment's XY path is cut no lower than the segment's lowest tip plus that.
        let (radius, rc) = self.profile;
        let floor = |rho: f64| {
            let d = rho.min(radius) - (radius - rc);
            if d <= 0.0 { 0.0 } else { rc - (rc * rc - d * d).max(0.0).sqrt() }
        };
        let (zmin, ab) = (a.z.min(b.z), (b - a).xy());
        let ab2 = ab.norm_squared();
        let row = |(dj, (row, mark)): (usize, (&mut [f64], &mut [f64]))| {
            let y = min[1] + (j0 + dj) as f64 * s;
            for (i, t) in row.iter_mut().enumerate().take(i1 + 1).skip(i0) {
                let base = Point3::new(min[0] + i as f64 * s, y, 0.0);
                let ap = nalgebra::Vector2::new(base.x - a.x, base.y - a.y);
                let u = if ab2 > 0.0 { (ap.dot(&ab) / ab2).clamp(0.0, 1.0) } else { 0.0 };
                let rho = (ap - ab * u).norm();
                if rho <= w {
                    mark[i] = mark[i].min(a.z + (b.z - a.z) * u);
                }
                if *t <= zmin + floor(rho) {
                    continue;
                }
                for p in prims {
                    if let Some((lo, _)) = p.column(&seg, &base) {
                        *t = t.min(lo);
                    }
                }
            }
        };
        // Without marks, every row gets an empty slice of them.
        let mark_rows: Vec<&mut [f64]> = if marks.is_empty() {
            (0..=j1 - j0).map(|_| <&mut [f64]>::default()).collect()
        } else {
            marks.chunks_mut(nx).collect()
        };
        if (i1 - i0 + 1) * (j1 - j0 + 1) > self.parallel_columns {
            rows.par_chunks_mut(nx).zip(mark_rows).enumerate().for_each(row);
        } else {
            rows.chunks_mut(nx).zip(mark_rows).enumerate().for_each(row);
        }
    }

    fn move_to(&mut self, to: Point3, line: u64) -> Result<()> {
        self.move_feed(to, line, true)
    }

    fn move_feed(&mut self, to: Point3, line: u64, feed: bool) -> Result<()> {
        let p = self.frame * to;
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(SimError::InvalidMotion { line, message: format!("non-finite point {p}") });
        }
        let from = self.pos.unwrap_or(p);
        self.sweep(from, p, feed);
        self.pos = Some(p);
        Ok(())
    }
}

/// What a move sweeps over ([`HeightField::reach`]).
struct Reach {
    seg: Seg,
    /// The tool's lower primitives, `lower[..n]`.
    lower: [Prim; Solids::CAPACITY],
    n: usize,
    /// The width of the marks a feed leaves.
    width: Option<f64>,
    /// The columns `[i0, i1]` by `[j0, j1]`.
    cols: [usize; 4],
}

/// The cutting primitives that can be lowest in a column: a cylinder of the flutes above a
/// ball or rounded-disc end at least as wide, starting no lower than the end's centre,
/// contains its bottom disc in the end's sweep, so it never reaches lower and is left out.
fn lower_prims(t: &ToolPrims) -> ([Prim; Solids::CAPACITY], usize) {
    let cut = &t.cut[..t.ncut];
    let covered = |h0: f64, r: f64| {
        cut.iter().any(|q| match *q {
            Prim::Capsule { c, r: rq } => c <= h0 && rq >= r,
            Prim::RDisc { c, rp, rc } => c <= h0 && rp + rc >= r,
            _ => false,
        })
    };
    let mut out = t.cut;
    let mut n = 0;
    for p in cut {
        if !matches!(*p, Prim::Cyl { h0, r, .. } if covered(h0, r)) {
            out[n] = *p;
            n += 1;
        }
    }
    (out, n)
}

impl MotionSink for HeightField {
    type Error = SimError;

    fn motion(&mut self, m: &Motion<'_>) -> Result<()> {
        match m {
            Motion::Rapid { to } => self.move_feed(*to, 0, false),
            Motion::Linear { to, .. } => self.move_to(*to, 0),
            Motion::Arc { to, .. } => {
                let start = self.pos.map(|p| self.frame.inverse() * p);
                let Some(spec) = start.and_then(|s| ArcSpec::from_motion(s, m)) else {
                    return self.move_to(*to, 0);
                };
                let mut pts = Vec::new();
                spec.linearize(self.arc_tolerance, |p| pts.push(p))
                    .map_err(|e| SimError::InvalidMotion { line: 0, message: e.to_string() })?;
                pts.into_iter().try_for_each(|p| self.move_to(p, 0))?;
                self.move_to(*to, 0)
            }
            Motion::Cycle(c) => {
                let from = self.pos.map(|p| self.frame.inverse() * p);
                let mut moves = Vec::new();
                c.expand(from, |mv| moves.push(mv));
                moves.iter().try_for_each(|mv| self.motion(mv))
            }
            Motion::ToolChange { tool } => {
                let c = self.tools.get(*tool);
                c.validate().map_err(|e| tool_error(Some(*tool), e))?;
                self.prims = ToolPrims::cutter(c);
                self.profile = (c.radius, c.corner_radius());
                Ok(())
            }
            Motion::Setup { frame, .. } => {
                let axis = frame * Vector3::z();
                if !(axis.z > 1.0 - 1e-9) {
                    return Err(SimError::InvalidMotion {
                        line: 0,
                        message: format!(
                            "a height field needs a 3-axis setup (tool axis +Z), got axis {axis}"
                        ),
                    });
                }
                self.frame = *frame;
                self.pos = None;
                Ok(())
            }
            Motion::ToolAxis { axis, .. } if (axis - Vector3::z()).norm() > 1e-9 => {
                Err(SimError::InvalidMotion {
                    line: 0,
                    message: format!(
                        "a height field needs a 3-axis setup (tool axis +Z), got a head's axis {axis}"
                    ),
                })
            }
            _ => Ok(()),
        }
    }
}

/// Options of [`surface_deviation_opt`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviationOptions {
    /// A column counts as reached when its cut height is at most this far above the
    /// part's top at the column. Default `1.0`.
    pub reach: f64,
    /// A cut point this close to the part's surface is on it (neither a gouge nor, for the
    /// ray that finds the part below, inside). Default `1e-6`.
    pub on_surface: f64,
    /// Count a column only where a ball of this radius can touch the part's surface
    /// straight below it: the ball resting on that point along its normal is clear of the
    /// part and lowered along the axis it stops there (the drop-cutter height over its
    /// centre is its tip's, to 0.1 % of its radius). A concave corner tighter than the
    /// finishing ball, or a point under an overhang, is not a region it reaches.
    /// `None` (default): every column within `reach`.
    pub ball_radius: Option<f64>,
    /// Count a column only where the finisher can touch the part's surface straight below
    /// it with its tip at or above this height: the lowest tip height a finisher went to (a
    /// tool that reaches only so deep below the stock's top finishes nothing lower); with
    /// [`ball_radius`](Self::ball_radius), the tip of the ball resting on that point along
    /// its normal, else the point itself. `None` (default): any height.
    pub floor: Option<f64>,
    /// The part is closed and consistently wound (`s2g_geom::check::report`'s `closed`
    /// and `consistently_oriented`): its winding number is 0 wherever a ray straight up
    /// leaves it without crossing it, so a cut point with nothing of the part above it is
    /// outside without its winding number being summed (the gouge test's answer is the
    /// same, found sooner). Default `false`: every cut point's winding number is summed.
    pub closed_part: bool,
}

impl Default for DeviationOptions {
    fn default() -> Self {
        Self { reach: 1.0, on_surface: 1e-6, ball_radius: None, floor: None, closed_part: false }
    }
}

/// How far a machined height field lies from the part's surface.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SurfaceDeviation {
    /// Largest distance from the part's surface of a reached column's cut point (the
    /// point `(x, y, top)`), in mesh units.
    pub max: f64,
    /// Mean of those distances.
    pub mean: f64,
    /// Deepest cut into the part anywhere: the largest distance inside the part of a
    /// column's cut point (0 when none is inside).
    pub gouge_depth: f64,
    /// Reached columns: over the part, cut to within [`DeviationOptions::reach`] of its top,
    /// and (on a field with [`HeightFieldOptions::pass_width`]) passed over by a feed.
    pub columns: usize,
    /// Columns that would count but that no feed passed over ([`HeightField::passed`] at
    /// the tip of the ball resting on the surface below them), or whose ball's tip lies in
    /// the strip of a stretch the finisher left out ([`HeightField::leave_out`]): what the
    /// finisher left out (where its shank or holder would have met the stock). Not in
    /// `max` and `mean`.
    pub unpassed: usize,
    /// Their area: their count times the square of the column spacing.
    pub unpassed_area: f64,
    /// The largest distance from the part's surface of those columns' cut points.
    pub unpassed_max: f64,
}

/// [`surface_deviation_opt`] with the default options.
pub fn surface_deviation(field: &HeightField, part: &MeshIndex) -> SurfaceDeviation {
    surface_deviation_opt(field, part, &DeviationOptions::default())
}

/// The deviation of `field`'s cut points from `part` (indexed in the part frame, closed):
/// for each column whose cut point is outside the part with the part's surface at most
/// `reach` straight below it, the distance of the cut point from the part's
/// surface (closest point); and the deepest cut point inside the part over all columns.
/// The result is the same whatever the number of threads.
pub fn surface_deviation_opt(
    field: &HeightField,
    part: &MeshIndex,
    o: &DeviationOptions,
) -> SurfaceDeviation {
    surface_deviation_where(field, part, o, &|_: &Point3, _: &Vector3| true)
}

/// [`surface_deviation_opt`] over the columns whose part surface straight below (point and
/// outward normal, in the field's frame) `counts` accepts as well: a setup that finishes
/// only part of what it sees (rest finishing, where earlier setups finished the rest)
/// is measured where it finishes.
///
/// On a [`DeviationOptions::closed_part`] the gouge test passes over cut points with
/// nothing of the part above them, and their distance from the part is found only where
/// they count: the same result as [`surface_deviation_reference`].
pub fn surface_deviation_where(
    field: &HeightField,
    part: &MeshIndex,
    o: &DeviationOptions,
    counts: &(dyn Fn(&Point3, &Vector3) -> bool + Sync),
) -> SurfaceDeviation {
    deviation_rows(field, part, o, counts, true)
}

/// [`surface_deviation_where`] with every cut point's winding number summed (whatever
/// [`DeviationOptions::closed_part`] says): the baseline it is tested and benched against.
#[doc(hidden)]
pub fn surface_deviation_reference(
    field: &HeightField,
    part: &MeshIndex,
    o: &DeviationOptions,
    counts: &(dyn Fn(&Point3, &Vector3) -> bool + Sync),
) -> SurfaceDeviation {
    deviation_rows(field, part, o, counts, false)
}

/// [`surface_deviation_where`] (`fast`) or [`surface_deviation_reference`].
fn deviation_rows(
    field: &HeightField,
    part: &MeshIndex,
    o: &DeviationOptions,
    counts: &(dyn Fn(&Point3, &Vector3) -> bool + Sync),
    fast: bool,
) -> SurfaceDeviation {
    let down = Vector3::new(0.0, 0.0, -1.0);
    let drop = o.ball_radius.and_then(|r| DropCutter::new(part, &Cutter::ball(r, 4.0 * r)).ok());
    let up = Vector3::z();
    let per_row: Vec<Tally> = (0..field.ny)
        .into_par_iter()
        .map(|j| {
            let mut a = Tally::default();
            for i in 0..field.nx {
                let t = field.top[j * field.nx + i];
                if !t.is_finite() {
                    continue;
                }
                let [x, y] = field.column(i, j);
                let p = Point3::new(x, y, t);
                // Of a closed part, a cut point with nothing of it straight above is
                // outside: no gouge, and its distance is wanted only where it counts.
                let outside = fast && o.closed_part && !part.ray_hits_any(&p, &up, f64::INFINITY);
                let mut dist = None;
                if !outside {
                    let d = part.closest_point(&p).distance;
                    if d > o.on_surface && part.contains(&p) {
                        a.gouge = a.gouge.max(d);
                        continue;
                    }
                    dist = Some(d);
                }
                // Outside the part, the first surface straight below is its top there (the
                // ray starts a little above, so that a point on the surface finds it).
                let lift = 2.0 * o.on_surface;
                let Some(hit) = part.cast_ray(&Point3::new(x, y, t + lift), &down, f64::INFINITY) else {
                    continue;
                };
                // The ball resting on the point along its normal is where a ball lowered along
                // the axis over its centre stops: clear of the part, and nothing above it.
                let touches = |r: f64| {
                    let c = hit.point + hit.normal * r;
                    drop.as_ref().is_some_and(|dc| rests_on(dc, &c, r))
                };
                // A ball touches this point with its tip at the centre's height less its radius.
                let r = o.ball_radius.unwrap_or(0.0);
                let above_floor = o.floor.is_none_or(|z| (hit.point + hit.normal * r).z - r >= z);
                if hit.distance - lift <= o.reach
                    && above_floor
                    && o.ball_radius.is_none_or(touches)
                    && counts(&hit.point, &hit.normal)
                {
                    let d = dist.unwrap_or_else(|| part.closest_point(&p).distance);
                    if passed_over(field, &hit.point, &hit.normal, r) {
                        a.max = a.max.max(d);
                        a.sum += d;
                        a.n += 1;
                    } else {
                        a.unpassed_max = a.unpassed_max.max(d);
                        a.unpassed += 1;
                    }
                }
            }
            a
        })
        .collect();
    let t = per_row.into_iter().fold(Tally::default(), |a, r| Tally {
        max: a.max.max(r.max),
        sum: a.sum + r.sum,
        gouge: a.gouge.max(r.gouge),
        n: a.n + r.n,
        unpassed: a.unpassed + r.unpassed,
        unpassed_max: a.unpassed_max.max(r.unpassed_max),
    });
    SurfaceDeviation {
        max: t.max,
        mean: if t.n > 0 { t.sum / t.n as f64 } else { 0.0 },
        gouge_depth: t.gouge,
        columns: t.n,
        unpassed: t.unpassed,
        unpassed_area: t.unpassed as f64 * field.spacing * field.spacing,
        unpassed_max: t.unpassed_max,
    }
}

/// Whether the ball of radius `r` centred at `c` (the drop cutter `dc`'s ball) rests
/// there when lowered along the axis: its drop height over `c` is at most its tip's height
/// (to 0.1 % of the radius). Resting on a surface point along its normal, it touches that
/// point with its tip at the tip's height, so the search starts 0.2 % of the radius below
/// the tip ([`DropCutter::stops_at_most`]: the same answer as comparing
/// [`DropCutter::height`]).
fn rests_on(dc: &DropCutter<'_>, c: &Point3, r: f64) -> bool {
    dc.stops_at_most(c.x, c.y, c.z - r + 1e-3 * r, 3e-3 * r)
}

/// Whether a feed passed over the surface point `q` (outward normal `n`) for a ball of
/// radius `r` (0: the point itself): a feed's tip came within the pass width of where the
/// ball resting on `q` has its tip, no higher than that tip plus the rise of the
/// cutter-location surface (as steep as the part there) over the width and
/// [`PASS_SLACK`] (always, on a field without marks), and that tip does not lie in the
/// strip of a stretch the finisher left out, at a height within the same rise and slack
/// of it ([`HeightField::leave_out`]: the column is the left-out pass's, though the pass
/// beside it came within the pass width).
fn passed_over(field: &HeightField, q: &Point3, n: &Vector3, r: f64) -> bool {
    let c = q + n * r;
    let nz = n.z.abs().max(0.1);
    let rise = field.pass_width.unwrap_or(0.0) * (1.0 - nz * nz).sqrt() / nz;
    let tip = c.z - r;
    field.passed(c.x, c.y, tip + rise + PASS_SLACK)
        && !field.left_out.near(c.x, c.y, tip - rise - PASS_SLACK, tip + rise + PASS_SLACK)
}

/// The finisher's left-out stretches ([`HeightField::leave_out`]), bucketed in XY cells of
/// their width.
#[derive(Debug, Clone, Default)]
struct LeftOut {
    segments: Vec<[Point3; 2]>,
    width: f64,
    cells: std::collections::HashMap<(i64, i64), Vec<usize>>,
}

impl LeftOut {
    fn new(segments: &[[Point3; 2]], width: f64) -> Self {
        let mut cells: std::collections::HashMap<(i64, i64), Vec<usize>> = std::collections::HashMap::new();
        let finite = |s: &[Point3; 2]| s.iter().all(|p| p.coords.iter().all(|v| v.is_finite()));
        if !(width > 0.0 && width.is_finite()) {
            return Self::default();
        }
        let segments: Vec<[Point3; 2]> = segments.iter().filter(|s| finite(s)).copied().collect();
        for (k, [a, b]) in segments.iter().enumerate() {
            let cell = |v: f64| (v / width).floor() as i64;
            let (i0, i1) = (cell(a.x.min(b.x) - width), cell(a.x.max(b.x) + width));
            let (j0, j1) = (cell(a.y.min(b.y) - width), cell(a.y.max(b.y) + width));
            // A stretch longer than a few thousand cells is a bad input: left unmarked.
            if (i1 - i0 + 1).saturating_mul(j1 - j0 + 1) > 4096 {
                continue;
            }
            for i in i0..=i1 {
                for j in j0..=j1 {
                    cells.entry((i, j)).or_default().push(k);
                }
            }
        }
        Self { segments, width, cells }
    }

    /// Whether a stretch lies within the width of `(x, y)` in XY, at a height in
    /// `[z_lo, z_hi]` there.
    fn near(&self, x: f64, y: f64, z_lo: f64, z_hi: f64) -> bool {
        if self.segments.is_empty() {
            return false;
        }
        let key = ((x / self.width).floor() as i64, (y / self.width).floor() as i64);
        let Some(ks) = self.cells.get(&key) else { return false };
        ks.iter().any(|&k| {
            let [a, b] = self.segments[k];
            let (ex, ey) = (b.x - a.x, b.y - a.y);
            let l = ex * ex + ey * ey;
            let u = if l > 0.0 { (((x - a.x) * ex + (y - a.y) * ey) / l).clamp(0.0, 1.0) } else { 0.0 };
            let (px, py, pz) = (a.x + u * ex, a.y + u * ey, a.z + u * (b.z - a.z));
            (px - x).hypot(py - y) <= self.width && pz >= z_lo && pz <= z_hi
        })
    }
}

/// How far above the ball's tip over a surface point (and the cutter-location surface's
/// rise over the pass width) a feed may pass and still count as passing over it: the
/// finisher's pass lift and sampling tolerance, well under any lift over a left-out stretch.
const PASS_SLACK: f64 = 0.05;

/// A row's (then the field's) sums in [`surface_deviation_where`].
#[derive(Default)]
struct Tally {
    max: f64,
    sum: f64,
    gouge: f64,
    n: usize,
    unpassed: usize,
    unpassed_max: f64,
}

/// The height `field` was cut to at `(x, y)`: bilinear between the four nearest columns;
/// where some of them were never cut (beside a wall of the part, whose columns over the
/// part the cutter never crossed), the highest of the others; `+inf` where none was cut,
/// or outside the grid.
fn cut_height(field: &HeightField, x: f64, y: f64) -> f64 {
    let fx = (x - field.min[0]) / field.spacing;
    let fy = (y - field.min[1]) / field.spacing;
    if !(fx >= 0.0 && fy >= 0.0) {
        return f64::INFINITY;
    }
    let (i, j) = (fx.floor() as usize, fy.floor() as usize);
    if i + 1 >= field.nx || j + 1 >= field.ny {
        return f64::INFINITY;
    }
    let (u, v) = (fx - i as f64, fy - j as f64);
    let t = |a: usize, b: usize| field.top[b * field.nx + a];
    let c = [t(i, j), t(i + 1, j), t(i, j + 1), t(i + 1, j + 1)];
    if c.iter().all(|h| h.is_finite()) {
        return (1.0 - v) * ((1.0 - u) * c[0] + u * c[1]) + v * ((1.0 - u) * c[2] + u * c[3]);
    }
    c.into_iter()
        .filter(|h| h.is_finite())
        .fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.max(h))))
        .unwrap_or(f64::INFINITY)
}

/// How far `field`'s cut lies from the part at surface points `points` (each a point and
/// its outward unit normal, in the field's frame; `part` indexed in that frame): the
/// thickness of the material left along the normal, from the point out to where the cut
/// surface (the columns' heights, bilinear between them) passes, to within 0.001. `None`
/// where the point is not reached: more than [`DeviationOptions::reach`] is left, or,
/// with [`DeviationOptions::ball_radius`], no ball of that radius lowered along the axis
/// rests on the point with its tip at or above [`DeviationOptions::floor`], or, on a field
/// with [`HeightFieldOptions::pass_width`], no feed passed over it (as in
/// [`surface_deviation_where`]). Material cut
/// below the point counts as none. The same whatever the number of threads. A part
/// finished in several setups is finished at a point where any one of them finished it:
/// its deviation there is the least of theirs.
pub fn deviation_at(
    field: &HeightField,
    part: &MeshIndex,
    points: &[(Point3, Vector3)],
    o: &DeviationOptions,
) -> Vec<Option<f64>> {
    let drop = o.ball_radius.and_then(|r| DropCutter::new(part, &Cutter::ball(r, 4.0 * r)).ok());
    let step = 0.01;
    points
        .par_iter()
        .with_min_len(256)
        .map(|(q, n)| {
            if let Some(r) = o.ball_radius {
                let c = q + n * r;
                let rests = rests_on(drop.as_ref()?, &c, r);
                if !rests || o.floor.is_some_and(|z| c.z - r < z) {
                    return None;
                }
            } else if o.floor.is_some_and(|z| q.z < z) {
                return None;
            }
            // Not finished here where no pass went over it.
            if !passed_over(field, q, n, o.ball_radius.unwrap_or(0.0)) {
                return None;
            }
            // Material at `q + s n` while it lies below the cut.
            let left = |s: f64| {
                let p = q + n * s;
                p.z < cut_height(field, p.x, p.y) - 1e-9
            };
            if !left(0.0) {
                return Some(0.0);
            }
            let steps = (o.reach / step).ceil() as usize;
            let k = (1..=steps).find(|&k| !left(k as f64 * step))?;
            let (mut lo, mut hi) = ((k - 1) as f64 * step, k as f64 * step);
            while hi - lo > 0.001 {
                let mid = 0.5 * (lo + hi);
                if left(mid) { lo = mid } else { hi = mid }
            }
            Some(hi)
        })
        .collect()
}
