//! The voxel stock and the exact brick-parallel carving engine.
//!
//! Moves are queued as [`Sweep`]s and processed in batches: every sweep is binned (sweeps
//! in parallel) to the 8x8x8 bricks its (inflated) swept volume can touch, leaving out the
//! bricks a one-bit-per-brick occupancy map marks empty, the `(brick, sweep)` pairs are
//! sorted, and bricks are processed in parallel, each applying its sweeps in program order.
//! So a long move is spread over many threads, and a finishing program of millions of tiny
//! moves is processed many moves per pass. Per brick and sweep the brick is first classified
//! with the inflated/deflated tests at its centre (outside: skipped at binning; inside:
//! cleared with word operations) and only partial bricks test the centres of their
//! remaining voxels. The per-brick loop allocates nothing.

use std::sync::atomic::{AtomicU8, Ordering};

use rayon::prelude::*;
use s2g_geom::{BRICK, Brick, GridSpec, Point3, Vector3, VoxelGrid};

use crate::sweep::{Prim, Seg};
use crate::tool::{BeadProfile, Cutter};
use s2g_geom::{Solid, Solids};

/// Flag bit: a rapid move removed material.
pub(crate) const FLAG_RAPID: u8 = 1;
/// Flag bit: the shank or holder met stock.
pub(crate) const FLAG_HOLDER: u8 = 2;

/// The carvers' tolerances, in part units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Tolerance {
    /// Voxel centres this close outside a swept volume count as inside it, so that ties
    /// resolve the same way in every carver ([`SimOptions::tie_tolerance`](crate::SimOptions)).
    pub tie: f64,
    /// A rapid move, shank or holder collides with a stock voxel only if the voxel's centre
    /// lies deeper than this inside it; shallower, it grazes the voxel (a rapid still
    /// removes it) ([`SimOptions::collision_tolerance`](crate::SimOptions)).
    pub graze: f64,
}

/// What a sweep does to the voxels it covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Op {
    Cut,
    Deposit,
}

/// The cutting and guard (shank, holder) primitives of a cutter.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ToolPrims {
    pub cut: [Prim; Solids::CAPACITY],
    pub ncut: usize,
    pub guard: [Prim; 3],
    pub nguard: usize,
}

impl ToolPrims {
    pub fn cutter(c: &Cutter) -> Self {
        let lf = c.flute_length;
        let flat = Prim::Cyl { h0: 0.0, h1: lf, r: c.radius };
        // The flutes are the solids the cutter's end shape names, swept exactly.
        let solids = c.cutting_solids();
        let mut cut = [flat; Solids::CAPACITY];
        for (p, s) in cut.iter_mut().zip(solids.as_slice()) {
            *p = match *s {
                Solid::Cylinder { h0, h1, r } => Prim::Cyl { h0, h1, r },
                Solid::Ball { c, r } => Prim::Capsule { c, r },
                Solid::Torus { c, rp, rc } => Prim::RDisc { c, rp, rc },
            };
        }
        let ncut = solids.as_slice().len();
        let mut guard = [flat; 3];
        let mut nguard = 0;
        // A long-reach end mill's neck: not cutting, from the flutes' top to its reach.
        if let Some(n) = c.neck {
            guard[nguard] = Prim::Cyl { h0: lf, h1: c.shank_start(), r: n.radius };
            nguard += 1;
        }
        if c.stickout > c.shank_start() {
            guard[nguard] = Prim::Cyl { h0: c.shank_start(), h1: c.stickout, r: c.shank_radius };
            nguard += 1;
        }
        if let Some(h) = c.holder {
            guard[nguard] = Prim::Cyl { h0: c.stickout, h1: c.stickout + h.length, r: h.radius };
            nguard += 1;
        }
        Self { cut, ncut, guard, nguard }
    }

    pub fn bead(b: &BeadProfile) -> Self {
        let p = match *b {
            BeadProfile::Rectangle { width, height } => Prim::Slab { h0: -height, h1: 0.0, hw: 0.5 * width },
            BeadProfile::Stadium { width, height } => Prim::Cyl { h0: -height, h1: 0.0, r: 0.5 * width },
            BeadProfile::Circle { diameter } => Prim::Capsule { c: -0.5 * diameter, r: 0.5 * diameter },
        };
        Self { cut: [p; Solids::CAPACITY], ncut: 1, guard: [p; 3], nguard: 0 }
    }
}

/// One queued move: a fixed-axis segment sweep of one tool or bead.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sweep {
    pub seg: Seg,
    pub prims: ToolPrims,
    pub op: Op,
    pub rapid: bool,
    /// Global move sequence number (program order).
    pub seq: u64,
    /// Source line.
    pub line: u64,
}

impl Sweep {
    #[inline]
    pub fn cut_contains(&self, q: &Point3, delta: f64) -> bool {
        self.prims.cut[..self.prims.ncut].iter().any(|p| p.contains(&self.seg, q, delta))
    }

    #[inline]
    pub fn guard_contains(&self, q: &Point3, delta: f64) -> bool {
        self.prims.guard[..self.prims.nguard].iter().any(|p| p.contains(&self.seg, q, delta))
    }

    /// The cutting primitives, then the guard's when asked.
    fn parts(&self, guard: bool) -> impl Iterator<Item = &Prim> {
        let n = if guard { self.prims.nguard } else { 0 };
        self.prims.cut[..self.prims.ncut].iter().chain(&self.prims.guard[..n])
    }

    /// Axis-aligned bounds of the swept cutting part (and the guard, when asked).
    pub fn aabb(&self, guard: bool) -> (Point3, Point3) {
        let s = &self.seg;
        let mut lo = Point3::from([f64::INFINITY; 3]);
        let mut hi = Point3::from([f64::NEG_INFINITY; 3]);
        for p in self.parts(guard) {
            let (h0, h1, r) = p.bound();
            for i in 0..3 {
                let ai = s.a[i];
                let rad = r * (1.0 - ai * ai).max(0.0).sqrt();
                let ends = [s.p0[i], s.p0[i] + s.d[i]];
                for e in ends {
                    for h in [h0, h1] {
                        lo[i] = lo[i].min(e + h * ai - rad);
                        hi[i] = hi[i].max(e + h * ai + rad);
                    }
                }
            }
        }
        (lo, hi)
    }

    /// One cylinder about the axis `(h_lo, h_hi, radius)` bounding every cutting primitive
    /// (and the guard's, when asked).
    fn bound(&self, guard: bool) -> (f64, f64, f64) {
        let (mut h_lo, mut h_hi, mut r) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
        for p in self.parts(guard) {
            let (l, h, rr) = p.bound();
            h_lo = h_lo.min(l);
            h_hi = h_hi.max(h);
            r = r.max(rr);
        }
        (h_lo, h_hi, r)
    }

    /// Bounds on the two axes other than `k` of the points of the sweep (its cutting part,
    /// and the guard when asked) whose coordinate `k` lies in `[z0, z1]`; `None` when there
    /// are none. Each point is `p0 + t d + h a + rho` with `t` in `[0, 1]`, `h` in the
    /// primitives' height range and `rho` perpendicular to `a` no longer than their radius:
    /// the slab cuts the `(t, h)` rectangle to a polygon, and coordinates are linear in
    /// `(t, h)`, so their extremes are at its vertices. For a long tilted tool this is far
    /// tighter than the whole sweep's box.
    pub fn slab_bounds(&self, k: usize, z0: f64, z1: f64, guard: bool) -> Option<[(f64, f64); 2]> {
        let s = &self.seg;
        let (h_lo, h_hi, r) = self.bound(guard);
        let rad = |i: usize| r * (1.0 - s.a[i] * s.a[i]).max(0.0).sqrt();
        let (lo, hi) = (z0 - rad(k) - s.p0[k], z1 + rad(k) - s.p0[k]);
        let f = |(t, h): (f64, f64)| t * s.d[k] + h * s.a[k];
        let mut poly = [(0.0, 0.0); 8];
        poly[..4].copy_from_slice(&[(0.0, h_lo), (1.0, h_lo), (1.0, h_hi), (0.0, h_hi)]);
        let mut len = 4;
        len = clip(&mut poly, len, |p| f(p) - lo);
        len = clip(&mut poly, len, |p| hi - f(p));
        if len == 0 {
            return None;
        }
        let mut out = [(0.0, 0.0); 2];
        for (o, i) in out.iter_mut().zip([(k + 1) % 3, (k + 2) % 3]) {
            let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
            for &(t, h) in &poly[..len] {
                let x = s.p0[i] + t * s.d[i] + h * s.a[i];
                a = a.min(x);
                b = b.max(x);
            }
            *o = (a - rad(i), b + rad(i));
        }
        Some(out)
    }
}

/// Clips the convex polygon `poly[..len]` to `g >= 0` (Sutherland-Hodgman; `g` linear);
/// returns the new length (at most one more vertex).
fn clip(poly: &mut [(f64, f64); 8], len: usize, g: impl Fn((f64, f64)) -> f64) -> usize {
    let mut out = [(0.0, 0.0); 8];
    let mut m = 0;
    for i in 0..len {
        let (p, q) = (poly[i], poly[(i + 1) % len]);
        let (gp, gq) = (g(p), g(q));
        if gp >= 0.0 {
            out[m] = p;
            m += 1;
        }
        if (gp >= 0.0) != (gq >= 0.0) && m < out.len() {
            let u = gp / (gp - gq);
            out[m] = (p.0 + u * (q.0 - p.0), p.1 + u * (q.1 - p.1));
            m += 1;
        }
    }
    *poly = out;
    m
}

/// A box around the cutting part of a sweep, in the frame `(u, v, a)` of the move: `a` the
/// tool axis, `u` the sideways direction of motion, `v = a x u`. Exact row selection only
/// tests the voxels whose centres fall in it, which for a thin tool on a long axis is a
/// small part of each 8-voxel row.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SweepBox {
    o: Point3,
    axes: [Vector3; 3],
    lo: [f64; 3],
    hi: [f64; 3],
    /// `1 / (voxel_x * axes[j].x)`: voxel steps along a row per unit of box coordinate
    /// (infinite when the row runs parallel to that face pair).
    inv_step: [f64; 3],
}

impl SweepBox {
    /// The box of `sw`'s cutting primitives grown by `pad`, for rows of voxels `voxel_x`
    /// apart along x.
    pub fn new(sw: &Sweep, pad: f64, voxel_x: f64) -> Self {
        let s = &sw.seg;
        let a = s.a;
        let len = s.aa.sqrt();
        let u = if len > 1e-12 {
            s.dp / len
        } else {
            // No sideways motion: any direction perpendicular to the axis.
            let t = if a.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
            (t - a * t.dot(&a)).normalize()
        };
        let v = a.cross(&u);
        let (h_lo, h_hi, r) = sw.bound(false);
        let along = if len > 1e-12 { len } else { 0.0 };
        let lo = [-r - pad, -r - pad, h_lo + s.da.min(0.0) - pad];
        let hi = [along + r + pad, r + pad, h_hi + s.da.max(0.0) + pad];
        let axes = [u, v, a];
        let inv_step = axes.map(|e| 1.0 / (voxel_x * e.x));
        Self { o: s.p0, axes, lo, hi, inv_step }
    }

    /// Whether no face normal of this box separates it from the axis-aligned box
    /// `[c - h, c + h]`. False means the two are disjoint, so a block of voxel centres it
    /// misses has none in the box (true may still be a miss along a grid or edge axis).
    #[inline]
    pub fn meets(&self, c: &Point3, h: &Vector3) -> bool {
        let w = c - self.o;
        (0..3).all(|j| {
            let e = &self.axes[j];
            let m = w.dot(e);
            let r = h.x * e.x.abs() + h.y * e.y.abs() + h.z * e.z.abs();
            m + r >= self.lo[j] && m - r <= self.hi[j]
        })
    }

    /// Grid axis `i`'s share of a point's box coordinates: `(v - o_i) axes[j]_i` for
    /// `j = 0..3`, where `v` is the point's coordinate `i`. The shares of a point's three
    /// coordinates sum to its `(q - o) . axes[j]`.
    #[inline]
    pub fn part(&self, i: usize, v: f64) -> [f64; 3] {
        let d = v - self.o[i];
        [d * self.axes[0][i], d * self.axes[1][i], d * self.axes[2][i]]
    }

    /// Bit mask of the eight voxels `q0 + k (voxel_x, 0, 0)`, `k = 0..8`, whose centres
    /// lie in the box, given `c[j] = (q0 - o) . axes[j]` (summed from [`part`](Self::part)s).
    #[inline]
    pub fn row_mask(&self, c: [f64; 3]) -> u64 {
        let (mut klo, mut khi) = (0.0f64, (BRICK - 1) as f64);
        for (j, c) in c.into_iter().enumerate() {
            let inv = self.inv_step[j];
            if inv.is_finite() {
                let (a, b) = ((self.lo[j] - c) * inv, (self.hi[j] - c) * inv);
                let (a, b) = if a < b { (a, b) } else { (b, a) };
                // Plain comparisons (no NaN can occur): `f64::max` costs more here.
                if a > klo {
                    klo = a;
                }
                if b < khi {
                    khi = b;
                }
            } else if c < self.lo[j] || c > self.hi[j] {
                return 0;
            }
        }
        if klo > khi {
            return 0;
        }
        // 0 <= klo <= khi <= 7 here: truncation is floor, and ceil adds one for a fraction
        // (libm's calls were a few per cent of a simulation).
        let (a, b) = (klo as u32 + u32::from(klo as u32 as f64 != klo), khi as u32);
        if a > b {
            return 0;
        }
        (u64::MAX >> (63 - (b - a))) << a
    }
}

/// Totals of one batch (or of a whole run).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Stats {
    pub removed: u64,
    pub rapid_voxels: u64,
    pub gouge: u64,
    /// `(seq, line)` of the earliest move that removed a target voxel.
    pub first_gouge: Option<(u64, u64)>,
    pub holder_voxels: u64,
    pub deposited: u64,
}

impl Stats {
    pub fn add(mut self, o: Stats) -> Stats {
        self.removed += o.removed;
        self.rapid_voxels += o.rapid_voxels;
        self.gouge += o.gouge;
        self.holder_voxels += o.holder_voxels;
        self.deposited += o.deposited;
        self.first_gouge = match (self.first_gouge, o.first_gouge) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        self
    }
}

/// Bit-packed voxels in the same brick layout as [`VoxelGrid`], with random brick access.
#[derive(Debug, Clone)]
pub(crate) struct Store {
    pub spec: GridSpec,
    pub bdims: [usize; 3],
    pub bricks: Vec<Brick>,
    /// One bit per brick, by brick index: clear means the brick is empty (set may still be
    /// empty, until the next pass that touches the brick). Binning reads these 4 KiB
    /// (at 256^3) instead of the bricks' 2 MiB: most bricks a long flute sweeps through
    /// are already empty.
    occ: Vec<u64>,
}

impl Store {
    pub fn from_grid(g: &VoxelGrid) -> Self {
        let bdims = g.brick_dims();
        let n = bdims.iter().product();
        let mut s =
            Self { spec: *g.spec(), bdims, bricks: vec![[0; BRICK]; n], occ: vec![0; n.div_ceil(64)] };
        for (base, b) in g.bricks() {
            let i = s.brick_index(base[0] / BRICK, base[1] / BRICK, base[2] / BRICK);
            s.bricks[i] = *b;
            s.note(i);
        }
        s
    }

    /// Whether brick `b` may hold voxels (false: it is empty).
    #[inline]
    pub fn may_hold(&self, b: usize) -> bool {
        self.occ[b / 64] >> (b % 64) & 1 != 0
    }

    /// Records whether brick `b` holds voxels now.
    #[inline]
    fn note(&mut self, b: usize) {
        let m = 1u64 << (b % 64);
        if self.bricks[b].iter().any(|&w| w != 0) {
            self.occ[b / 64] |= m;
        } else {
            self.occ[b / 64] &= !m;
        }
    }

    pub fn to_grid(&self) -> VoxelGrid {
        let mut g = VoxelGrid::new(self.spec);
        g.par_bricks_mut().for_each(|(base, b)| {
            *b = self.bricks[self.brick_index(base[0] / BRICK, base[1] / BRICK, base[2] / BRICK)];
        });
        g
    }

    #[inline]
    pub fn brick_index(&self, bx: usize, by: usize, bz: usize) -> usize {
        bx + self.bdims[0] * (by + self.bdims[1] * bz)
    }

    #[inline]
    pub fn get(&self, i: usize, j: usize, k: usize) -> bool {
        let b = self.brick_index(i / BRICK, j / BRICK, k / BRICK);
        self.bricks[b][k % BRICK] >> ((i % BRICK) + BRICK * (j % BRICK)) & 1 != 0
    }

    #[inline]
    pub fn set(&mut self, i: usize, j: usize, k: usize, v: bool) {
        let b = self.brick_index(i / BRICK, j / BRICK, k / BRICK);
        let m = 1u64 << ((i % BRICK) + BRICK * (j % BRICK));
        if v {
            self.bricks[b][k % BRICK] |= m;
            self.occ[b / 64] |= 1 << (b % 64);
        } else {
            self.bricks[b][k % BRICK] &= !m;
        }
    }

    /// Voxel counts of brick `base` that lie inside the grid, per axis.
    #[inline]
    fn extent(&self, base: [usize; 3]) -> [usize; 3] {
        let d = self.spec.dims;
        [(d[0] - base[0]).min(BRICK), (d[1] - base[1]).min(BRICK), (d[2] - base[2]).min(BRICK)]
    }

    /// Centre of the block of voxel centres of the brick at `base`, and its half diagonal.
    #[inline]
    fn brick_ball(&self, base: [usize; 3]) -> (Point3, f64) {
        let s = &self.spec;
        let c = Point3::new(
            s.origin.x + (base[0] as f64 + 4.0) * s.voxel.x,
            s.origin.y + (base[1] as f64 + 4.0) * s.voxel.y,
            s.origin.z + (base[2] as f64 + 4.0) * s.voxel.z,
        );
        (c, 3.5 * s.voxel.norm())
    }
}

/// Reusable buffers of the engine (a clone starts with empty ones).
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    pairs: Vec<u64>,
    boxes: Vec<SweepBox>,
    /// Candidate brick runs of one sweep: `(layer, row, first, last)`.
    rows: Vec<(usize, usize, usize, usize)>,
    groups: Vec<(usize, usize, usize)>,
    pub flags: Vec<AtomicU8>,
}

impl Clone for Scratch {
    fn clone(&self) -> Self {
        Self::default()
    }
}

/// Brick range `[lo, hi]` (inclusive) along each axis touched by `[lo, hi]` in space.
fn brick_range(spec: &GridSpec, lo: &Point3, hi: &Point3) -> Option<[(usize, usize); 3]> {
    let mut out = [(0, 0); 3];
    for a in 0..3 {
        let (i0, i1) = spec.center_range(lo[a], hi[a], a)?;
        out[a] = (i0 / BRICK, i1 / BRICK);
    }
    Some(out)
}

/// Applies a batch of sweeps to `store` (see the module docs). `flags[i]` receives
/// [`FLAG_RAPID`] / [`FLAG_HOLDER`] for sweep `i`.
pub(crate) fn run_batch(
    store: &mut Store,
    target: Option<&Store>,
    sweeps: &[Sweep],
    check_guard: bool,
    parallel_threshold: usize,
    tol: Tolerance,
    scratch: &mut Scratch,
) -> Stats {
    let eps = tol.tie;
    let Scratch { pairs, boxes, rows, groups, flags } = scratch;
    pairs.clear();
    boxes.clear();
    // Padding of the sweep boxes: the engine's tolerance plus rounding of the box frame.
    let pad =
        eps + 1e-9 * store.spec.voxel.norm() * (store.spec.dims.iter().max().copied().unwrap_or(1) as f64);
    boxes.extend(sweeps.iter().map(|sw| SweepBox::new(sw, pad, store.spec.voxel.x)));
    groups.clear();
    flags.clear();
    flags.extend((0..sweeps.len()).map(|_| AtomicU8::new(0)));
    let st: &Store = store;
    let bin = |si: usize, rows: &mut Vec<_>, out: &mut Vec<u64>| {
        bin_sweep(st, si, &sweeps[si], &boxes[si], check_guard, eps, rows, out);
    };
    if sweeps.len() >= PARALLEL_BINNING {
        // Sweeps are binned independently (the pairs are sorted next), so a batch spreads
        // over the threads: on two cores the planner leaves one idle at times.
        let parts: Vec<Vec<u64>> = (0..sweeps.len())
            .into_par_iter()
            .with_min_len(PARALLEL_BINNING / 4)
            .fold(
                || (Vec::new(), Vec::new()),
                |(mut out, mut rows), si| {
                    bin(si, &mut rows, &mut out);
                    (out, rows)
                },
            )
            .map(|(out, _)| out)
            .collect();
        pairs.extend(parts.into_iter().flatten());
    } else {
        for si in 0..sweeps.len() {
            bin(si, rows, pairs);
        }
    }
    if pairs.is_empty() {
        return Stats::default();
    }
    if pairs.len() > 1 << 14 {
        pairs.par_sort_unstable();
    } else {
        pairs.sort_unstable();
    }
    let mut start = 0;
    for i in 1..=pairs.len() {
        if i == pairs.len() || pairs[i] >> 24 != pairs[start] >> 24 {
            groups.push(((pairs[start] >> 24) as usize, start, i));
            start = i;
        }
    }
    // Disjoint mutable references to the bricks of the groups, in index order.
    let mut refs: Vec<&mut Brick> = Vec::with_capacity(groups.len());
    let bdims = store.bdims;
    let spec = store.spec;
    let view = Store { spec, bdims, bricks: Vec::new(), occ: Vec::new() };
    let mut rest: &mut [Brick] = &mut store.bricks;
    let mut offset = 0;
    for &(b, _, _) in groups.iter() {
        let (_, tail) = std::mem::take(&mut rest).split_at_mut(b - offset);
        let (one, tail) = tail.split_at_mut(1);
        refs.push(&mut one[0]);
        rest = tail;
        offset = b + 1;
    }
    let pairs: &[u64] = pairs;
    let boxes: &[SweepBox] = boxes;
    let flags: &[AtomicU8] = flags;
    let work = |(brick, &(b, s, e)): (&mut Brick, &(usize, usize, usize))| {
        let base = [
            (b % bdims[0]) * BRICK,
            ((b / bdims[0]) % bdims[1]) * BRICK,
            (b / (bdims[0] * bdims[1])) * BRICK,
        ];
        let tgt = target.map(|t| &t.bricks[b]);
        process_brick(&view, brick, base, tgt, sweeps, boxes, &pairs[s..e], check_guard, tol, flags)
    };
    let stats = if pairs.len() < parallel_threshold {
        refs.into_iter().zip(groups.iter()).map(work).fold(Stats::default(), Stats::add)
    } else {
        refs.into_par_iter().zip(groups.par_iter()).map(work).reduce(Stats::default, Stats::add)
    };
    for &(b, _, _) in groups.iter() {
        store.note(b);
    }
    stats
}

/// Sweeps per batch from which binning runs on the thread pool.
const PARALLEL_BINNING: usize = 64;

/// Appends to `out` the `(brick << 24 | si)` pairs of sweep `si`: the bricks that may hold
/// material (every candidate brick for a deposit) and that its cutting part's box and
/// inflated volume, or its guard's, reach. `rows` is scratch.
#[allow(clippy::too_many_arguments)] // One sweep's whole context, as `process_brick`'s.
fn bin_sweep(
    st: &Store,
    si: usize,
    sw: &Sweep,
    bx: &SweepBox,
    check_guard: bool,
    eps: f64,
    rows: &mut Vec<(usize, usize, usize, usize)>,
    out: &mut Vec<u64>,
) {
    let spec = st.spec;
    // Half extent of a brick's block of voxel centres.
    let half = spec.voxel * (0.5 * (BRICK - 1) as f64);
    let guard = check_guard && sw.op == Op::Cut && sw.prims.nguard > 0;
    let (lo, hi) = sw.aabb(guard);
    let Some(r) = brick_range(&spec, &lo, &hi) else { return };
    let bin = |b: [usize; 3]| -> Option<u64> {
        let bi = st.brick_index(b[0], b[1], b[2]);
        if sw.op == Op::Cut && !st.may_hold(bi) {
            return None;
        }
        let (c, d) = st.brick_ball([b[0] * BRICK, b[1] * BRICK, b[2] * BRICK]);
        // The cutting part reaches the brick only if its box meets the brick's voxel
        // centres (a much tighter test than the brick's ball for a thin tool).
        let cuts = bx.meets(&c, &half) && sw.cut_contains(&c, d + eps);
        (cuts || (guard && sw.guard_contains(&c, d + eps))).then_some(((bi as u64) << 24) | si as u64)
    };
    // Layers of bricks across the grid axis closest to the tool axis; in each, only the
    // bricks within the slab bounds of the sweep are candidates.
    let k = sw.seg.a.iamax();
    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
    rows.clear();
    for bk in r[k].0..=r[k].1 {
        let first = bk * BRICK;
        let last = (first + BRICK - 1).min(spec.dims[k] - 1);
        let centre = |v: usize| spec.origin[k] + (v as f64 + 0.5) * spec.voxel[k];
        let Some([ri, rj]) = sw.slab_bounds(k, centre(first) - eps, centre(last) + eps, guard) else {
            continue;
        };
        let (Some(ci), Some(cj)) =
            (spec.center_range(ri.0 - eps, ri.1 + eps, i), spec.center_range(rj.0 - eps, rj.1 + eps, j))
        else {
            continue;
        };
        let (i0, i1) = ((ci.0 / BRICK).max(r[i].0), (ci.1 / BRICK).min(r[i].1));
        for bj in (cj.0 / BRICK).max(r[j].0)..=(cj.1 / BRICK).min(r[j].1) {
            if i0 <= i1 {
                rows.push((bk, bj, i0, i1));
            }
        }
    }
    let brick = move |bk: usize, bj: usize, bi: usize| {
        let mut b = [0; 3];
        (b[k], b[j], b[i]) = (bk, bj, bi);
        b
    };
    let n: usize = rows.iter().map(|&(_, _, i0, i1)| i1 - i0 + 1).sum();
    if n >= 4096 {
        out.par_extend(
            rows.par_iter()
                .flat_map_iter(|&(bk, bj, i0, i1)| (i0..=i1).filter_map(move |bi| bin(brick(bk, bj, bi)))),
        );
    } else {
        for &(bk, bj, i0, i1) in rows.iter() {
            out.extend((i0..=i1).filter_map(|bi| bin(brick(bk, bj, bi))));
        }
    }
}

#[inline]
fn popcount(b: &Brick) -> u64 {
    b.iter().map(|w| w.count_ones() as u64).sum()
}

/// Voxel centres of the brick at `base` whose bit is set in `bits` and that satisfy
/// `inside(q, 0)`, for a **convex** region. Each 8-voxel row along x is first cut down to
/// the voxels inside `bounds` (a box around the region), or without one culled at its
/// middle with `inside(mid, +half)`. The inside centres of a row form one run (convexity):
/// a row whose two end centres are inside is inside whole, one with a single end inside
/// finds the run's other end by bisection, and only a row with both ends outside tests the
/// voxels between them one by one.
#[inline]
fn select(
    view: &Store,
    base: [usize; 3],
    bits: &Brick,
    bounds: Option<&SweepBox>,
    inside: impl Fn(&Point3, f64) -> bool,
) -> Brick {
    let s = &view.spec;
    let half = 3.5 * s.voxel.x;
    let x0 = s.origin.x + (base[0] as f64 + 0.5) * s.voxel.x;
    let qy = |y: usize| s.origin.y + ((base[1] + y) as f64 + 0.5) * s.voxel.y;
    // The box coordinates of the rows' first voxels, by parts: a row then costs two
    // additions per box axis rather than a dot product. (Rounding differs from the dot
    // product's by far less than the box's padding, and the box only narrows the voxels
    // that `inside` decides.)
    let (px, py) = match bounds {
        Some(b) => (b.part(0, x0), std::array::from_fn(|y| b.part(1, qy(y)))),
        None => ([0.0; 3], [[0.0; 3]; BRICK]),
    };
    let mut out = [0u64; BRICK];
    for (z, &word) in bits.iter().enumerate() {
        if word == 0 {
            continue;
        }
        let qz = s.origin.z + ((base[2] + z) as f64 + 0.5) * s.voxel.z;
        let pz = bounds.map_or([0.0; 3], |b| b.part(2, qz));
        for (y, py) in py.iter().enumerate() {
            let row = (word >> (BRICK * y)) & 0xff;
            if row == 0 {
                continue;
            }
            let qy = qy(y);
            let row = match bounds {
                Some(b) => row & b.row_mask(std::array::from_fn(|j| px[j] + py[j] + pz[j])),
                None if inside(&Point3::new(x0 + half, qy, qz), half) => row,
                None => 0,
            };
            if row == 0 {
                continue;
            }
            let first = row.trailing_zeros() as usize;
            let last = 63 - row.leading_zeros() as usize;
            let at = |x: usize| Point3::new(x0 + x as f64 * s.voxel.x, qy, qz);
            // The inside centres of the row form one run (convexity).
            let head = inside(&at(first), 0.0);
            let tail = if first == last { head } else { inside(&at(last), 0.0) };
            // With one end inside, the run's other end: the inside voxel next to the outside
            // one, by bisection between the inside end `a` and the outside end `b`.
            let run_end = |mut a: usize, mut b: usize| {
                while a.abs_diff(b) > 1 {
                    let m = (a + b) / 2;
                    if inside(&at(m), 0.0) { a = m } else { b = m }
                }
                a
            };
            let hit = match (head, tail) {
                (true, true) => row,
                (true, false) => row & (u64::MAX >> (63 - run_end(first, last))),
                (false, true) => row & (u64::MAX << run_end(last, first)),
                // Both ends outside: the run, if any, lies between them.
                (false, false) => {
                    let mut hit = 0u64;
                    let mut w = row & !(1 << first) & !(1 << last);
                    while w != 0 {
                        let x = w.trailing_zeros() as usize;
                        w &= w - 1;
                        if inside(&at(x), 0.0) {
                            hit |= 1 << x;
                        }
                    }
                    hit
                }
            };
            out[z] |= hit << (BRICK * y);
        }
    }
    out
}

/// Whether the eight extreme voxel centres of the brick's in-grid part satisfy `inside`:
/// for a convex region, the whole brick is then inside.
#[inline]
fn corners_inside(view: &Store, base: [usize; 3], inside: impl Fn(&Point3) -> bool) -> bool {
    let s = &view.spec;
    let e = view.extent(base);
    let c = |a: usize, i: usize| s.origin[a] + ((base[a] + i) as f64 + 0.5) * s.voxel[a];
    let xs = [c(0, 0), c(0, e[0] - 1)];
    let ys = [c(1, 0), c(1, e[1] - 1)];
    let zs = [c(2, 0), c(2, e[2] - 1)];
    zs.iter().all(|&z| ys.iter().all(|&y| xs.iter().all(|&x| inside(&Point3::new(x, y, z)))))
}

/// In-grid bit mask of the brick at `base`.
fn in_grid_mask(view: &Store, base: [usize; 3]) -> Brick {
    let [nx, ny, nz] = view.extent(base);
    let row = if nx == BRICK { 0xff } else { (1u64 << nx) - 1 };
    let mut slice = 0u64;
    for y in 0..ny {
        slice |= row << (BRICK * y);
    }
    let mut out = [0; BRICK];
    for w in out.iter_mut().take(nz) {
        *w = slice;
    }
    out
}

#[allow(clippy::too_many_arguments)] // One brick's whole context; a struct would only rename it.
fn process_brick(
    view: &Store,
    brick: &mut Brick,
    base: [usize; 3],
    target: Option<&Brick>,
    sweeps: &[Sweep],
    boxes: &[SweepBox],
    pairs: &[u64],
    check_guard: bool,
    tol: Tolerance,
    flags: &[AtomicU8],
) -> Stats {
    let (eps, graze) = (tol.tie, tol.graze);
    let mut st = Stats::default();
    let (c, d) = view.brick_ball(base);
    for &p in pairs {
        let si = (p & 0xff_ffff) as usize;
        let sw = &sweeps[si];
        match sw.op {
            Op::Deposit => {
                let grid = in_grid_mask(view, base);
                let mask = if sw.cut_contains(&c, eps - d)
                    || corners_inside(view, base, |q| sw.cut_contains(q, eps))
                {
                    grid
                } else {
                    select(view, base, &grid, Some(&boxes[si]), |q, d| sw.cut_contains(q, d + eps))
                };
                for z in 0..BRICK {
                    st.deposited += (mask[z] & !brick[z]).count_ones() as u64;
                    brick[z] |= mask[z];
                }
            }
            Op::Cut => {
                if brick.iter().all(|&w| w == 0) {
                    break;
                }
                let cut = if sw.cut_contains(&c, eps - d) {
                    *brick
                } else if !sw.cut_contains(&c, d + eps) {
                    [0; BRICK]
                } else if corners_inside(view, base, |q| sw.cut_contains(q, eps)) {
                    *brick
                } else {
                    select(view, base, brick, Some(&boxes[si]), |q, d| sw.cut_contains(q, d + eps))
                };
                let n = popcount(&cut);
                if n > 0 {
                    st.removed += n;
                    for z in 0..BRICK {
                        brick[z] &= !cut[z];
                    }
                    if sw.rapid {
                        // Only voxels deeper inside the tool than the graze tolerance collide.
                        let deep = if sw.cut_contains(&c, -graze - d) {
                            n
                        } else {
                            popcount(&select(view, base, &cut, Some(&boxes[si]), |q, d| {
                                sw.cut_contains(q, d - graze)
                            }))
                        };
                        if deep > 0 {
                            st.rapid_voxels += deep;
                            flags[si].fetch_or(FLAG_RAPID, Ordering::Relaxed);
                        }
                    }
                    if let Some(t) = target {
                        let g: u64 = (0..BRICK).map(|z| (cut[z] & t[z]).count_ones() as u64).sum();
                        if g > 0 {
                            st.gouge += g;
                            if st.first_gouge.is_none_or(|(s, _)| sw.seq < s) {
                                st.first_gouge = Some((sw.seq, sw.line));
                            }
                        }
                    }
                }
                if check_guard && sw.prims.nguard > 0 && sw.guard_contains(&c, d - graze) {
                    let hits = if sw.guard_contains(&c, -graze - d) {
                        popcount(brick)
                    } else {
                        // Shank and holder together are not convex: select per primitive.
                        let mut m = [0u64; BRICK];
                        for g in &sw.prims.guard[..sw.prims.nguard] {
                            let part =
                                select(view, base, brick, None, |q, d| g.contains(&sw.seg, q, d - graze));
                            for z in 0..BRICK {
                                m[z] |= part[z];
                            }
                        }
                        popcount(&m)
                    };
                    if hits > 0 {
                        st.holder_voxels += hits;
                        flags[si].fetch_or(FLAG_HOLDER, Ordering::Relaxed);
                    }
                }
            }
        }
    }
    st
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng, rngs::StdRng};
    use s2g_geom::Aabb;

    fn unit(rng: &mut StdRng) -> Vector3 {
        loop {
            let v = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if (0.1..1.0).contains(&v.norm()) {
                return v.normalize();
            }
        }
    }

    /// The tests' 40-voxel grid over a 20 x 16 x 12 box, and their tie tolerance.
    fn test_grid() -> (GridSpec, f64) {
        let bbox = Aabb::new(Point3::new(-10.0, -8.0, -6.0), Point3::new(10.0, 8.0, 6.0));
        let spec = GridSpec::cubic(&bbox, 40).unwrap();
        (spec, 1e-6 * spec.voxel.min())
    }

    /// Every voxel's index and centre, x fastest.
    fn centres(spec: &GridSpec) -> impl Iterator<Item = ([usize; 3], Point3)> + '_ {
        let [nx, ny, nz] = spec.dims;
        (0..nz).flat_map(move |k| {
            (0..ny).flat_map(move |j| (0..nx).map(move |i| ([i, j, k], spec.center(i, j, k))))
        })
    }

    /// The culled engine (slab-bounded binning, boxed row selection) removes exactly the
    /// voxels whose centres a per-voxel test puts in the sweep, for tilted, axis-aligned,
    /// sideways and plunging moves of every cutter shape, with and without a guard; rapids
    /// and guards collide with exactly the voxels deeper inside than the graze tolerance.
    #[test]
    fn culling_matches_a_per_voxel_brute_force() {
        let mut rng = StdRng::seed_from_u64(11);
        let (spec, eps) = test_grid();
        let tol = Tolerance { tie: eps, graze: 0.2 * spec.voxel.min() };
        let mut grazed = 0;
        let cutters = [
            Cutter::flat(0.6, 30.0),
            Cutter::ball(1.7, 5.0),
            Cutter::bull(2.5, 0.8, 4.0),
            Cutter { stickout: 6.0, shank_radius: 1.0, ..Cutter::flat(0.9, 2.0) },
        ];
        let mut scratch = Scratch::default();
        let mut checked = 0;
        for case in 0..48 {
            let c = &cutters[case % cutters.len()];
            let a = match case % 4 {
                0 => Vector3::z(),
                1 => -Vector3::x(),
                _ => unit(&mut rng),
            };
            let p0 = Point3::new(
                rng.random_range(-9.0..9.0),
                rng.random_range(-7.0..7.0),
                rng.random_range(-5.0..5.0),
            );
            let d = match case % 3 {
                0 => unit(&mut rng) * rng.random_range(0.0..12.0),
                1 => a * rng.random_range(-4.0..4.0),
                _ => {
                    let u = unit(&mut rng);
                    (u - a * u.dot(&a)) * rng.random_range(0.0..12.0)
                }
            };
            let sw = Sweep {
                seg: Seg::new(p0, p0 + d, a),
                prims: ToolPrims::cutter(c),
                op: Op::Cut,
                rapid: case % 2 == 1,
                seq: 0,
                line: 0,
            };
            let mut store = Store::from_grid(&VoxelGrid::full(spec));
            let st = run_batch(&mut store, None, &[sw], true, 1 << 30, tol, &mut scratch);
            let (mut want, mut deep, mut holder) = (0u64, 0u64, 0u64);
            for ([i, j, k], q) in centres(&spec) {
                let cut = sw.cut_contains(&q, eps);
                want += u64::from(cut);
                deep += u64::from(cut && sw.cut_contains(&q, -tol.graze));
                holder += u64::from(!cut && sw.guard_contains(&q, -tol.graze));
                assert_eq!(store.get(i, j, k), !cut, "case {case}: voxel ({i}, {j}, {k})");
            }
            assert_eq!(st.removed, want, "case {case}");
            assert_eq!(st.rapid_voxels, if sw.rapid { deep } else { 0 }, "case {case}: rapid");
            assert_eq!(st.holder_voxels, holder, "case {case}: guard");
            checked += usize::from(want > 0);
            grazed += want - deep;
        }
        assert!(checked >= 40, "most sweeps cut something: {checked}");
        assert!(grazed > 100, "the tolerance leaves out the voxels the tools only graze: {grazed}");
    }

    /// Over many batches on one store, bricks emptied by earlier batches are skipped by the
    /// occupancy bits, and a deposit refills them: the result is still exactly the per-voxel
    /// union (cuts) and the bits say "empty" only for empty bricks.
    #[test]
    fn occupancy_culling_across_batches_is_exact() {
        let mut rng = StdRng::seed_from_u64(5);
        let (spec, eps) = test_grid();
        let mut store = Store::from_grid(&VoxelGrid::full(spec));
        let mut want = vec![true; spec.dims.iter().product()];
        let mut scratch = Scratch::default();
        let bead = ToolPrims::bead(&BeadProfile::Stadium { width: 3.0, height: 2.0 });
        for batch in 0..30 {
            let deposit = batch % 7 == 6;
            let a = if batch % 2 == 0 { Vector3::z() } else { unit(&mut rng) };
            let p0 = Point3::new(
                rng.random_range(-9.0..9.0),
                rng.random_range(-7.0..7.0),
                rng.random_range(-5.0..5.0),
            );
            let d = unit(&mut rng) * rng.random_range(2.0..14.0);
            let sw = Sweep {
                seg: Seg::new(p0, p0 + d, a),
                prims: if deposit { bead } else { ToolPrims::cutter(&Cutter::flat(2.5, 30.0)) },
                op: if deposit { Op::Deposit } else { Op::Cut },
                rapid: false,
                seq: batch,
                line: batch,
            };
            run_batch(
                &mut store,
                None,
                &[sw],
                true,
                1 << 30,
                Tolerance { tie: eps, graze: eps },
                &mut scratch,
            );
            let mut n = 0;
            for ([i, j, k], q) in centres(&spec) {
                let v = &mut want[i + spec.dims[0] * (j + spec.dims[1] * k)];
                if sw.cut_contains(&q, eps) {
                    *v = deposit;
                }
                assert_eq!(store.get(i, j, k), *v, "batch {batch}: voxel ({i}, {j}, {k})");
                n += usize::from(*v);
            }
            assert!(n > 0, "batch {batch}: material is left");
            for (b, brick) in store.bricks.iter().enumerate() {
                if brick.iter().any(|&w| w != 0) {
                    assert!(store.may_hold(b), "batch {batch}: brick {b} holds voxels but is marked empty");
                }
            }
        }
        let empty = (0..store.bricks.len()).filter(|&b| !store.may_hold(b)).count();
        assert!(empty > 10, "the cuts emptied bricks that later batches skip: {empty}");
    }
}
