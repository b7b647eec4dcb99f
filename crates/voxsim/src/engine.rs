//! The voxel stock and the exact brick-parallel carving engine.
//!
//! Moves are queued as [`Sweep`]s and processed in batches: every sweep is binned to the
//! 8x8x8 bricks its (inflated) swept volume can touch, the `(brick, sweep)` pairs are
//! sorted, and bricks are processed in parallel, each applying its sweeps in program order.
//! So a long move is spread over many threads, and a finishing program of millions of tiny
//! moves is processed many moves per pass. Per brick and sweep the brick is first classified
//! with the inflated/deflated tests at its centre (outside: skipped at binning; inside:
//! cleared with word operations) and only partial bricks test the centres of their
//! remaining voxels. The per-brick loop allocates nothing.

use std::sync::atomic::{AtomicU8, Ordering};

use rayon::prelude::*;
use s2g_geom::{BRICK, Brick, GridSpec, Point3, VoxelGrid};

use crate::sweep::{Prim, Seg};
use crate::tool::{BeadProfile, Cutter, CutterShape};

/// Flag bit: a rapid move removed material.
pub(crate) const FLAG_RAPID: u8 = 1;
/// Flag bit: the shank or holder met stock.
pub(crate) const FLAG_HOLDER: u8 = 2;

/// What a sweep does to the voxels it covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Op {
    Cut,
    Deposit,
}

/// The cutting and guard (shank, holder) primitives of a cutter.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ToolPrims {
    pub cut: [Prim; 2],
    pub ncut: usize,
    pub guard: [Prim; 2],
    pub nguard: usize,
}

impl ToolPrims {
    pub fn cutter(c: &Cutter) -> Self {
        let (r, lf) = (c.radius, c.flute_length);
        let flat = Prim::Cyl { h0: 0.0, h1: lf, r };
        let ball = [Prim::Capsule { c: r, r }, Prim::Cyl { h0: r, h1: lf, r }];
        let (cut, ncut) = match c.shape {
            CutterShape::Flat => ([flat, flat], 1),
            CutterShape::Ball => (ball, 2),
            CutterShape::BullNose { corner_radius: rc } if rc <= 0.0 => ([flat, flat], 1),
            CutterShape::BullNose { corner_radius: rc } if rc >= r => (ball, 2),
            CutterShape::BullNose { corner_radius: rc } => {
                ([Prim::RDisc { c: rc, rp: r - rc, rc }, Prim::Cyl { h0: rc, h1: lf, r }], 2)
            }
        };
        let mut guard = [flat, flat];
        let mut nguard = 0;
        if c.stickout > lf {
            guard[nguard] = Prim::Cyl { h0: lf, h1: c.stickout, r: c.shank_radius };
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
        Self { cut: [p, p], ncut: 1, guard: [p, p], nguard: 0 }
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

    /// Axis-aligned bounds of the swept cutting part (and the guard, when asked).
    pub fn aabb(&self, guard: bool) -> (Point3, Point3) {
        let s = &self.seg;
        let mut lo = Point3::from([f64::INFINITY; 3]);
        let mut hi = Point3::from([f64::NEG_INFINITY; 3]);
        let n = if guard { self.prims.nguard } else { 0 };
        for p in self.prims.cut[..self.prims.ncut].iter().chain(&self.prims.guard[..n]) {
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
}

impl Store {
    pub fn from_grid(g: &VoxelGrid) -> Self {
        let bdims = g.brick_dims();
        let mut s = Self { spec: *g.spec(), bdims, bricks: vec![[0; BRICK]; bdims.iter().product()] };
        for (base, b) in g.bricks() {
            let i = s.brick_index(base[0] / BRICK, base[1] / BRICK, base[2] / BRICK);
            s.bricks[i] = *b;
        }
        s
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

/// Reusable buffers of the engine.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    pairs: Vec<u64>,
    groups: Vec<(usize, usize, usize)>,
    pub flags: Vec<AtomicU8>,
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
    eps: f64,
    scratch: &mut Scratch,
) -> Stats {
    let Scratch { pairs, groups, flags } = scratch;
    pairs.clear();
    groups.clear();
    flags.clear();
    flags.extend((0..sweeps.len()).map(|_| AtomicU8::new(0)));
    let st: &Store = store;
    for (si, sw) in sweeps.iter().enumerate() {
        let guard = check_guard && sw.op == Op::Cut && sw.prims.nguard > 0;
        let (lo, hi) = sw.aabb(guard);
        let Some(r) = brick_range(&st.spec, &lo, &hi) else { continue };
        let n = (r[0].1 - r[0].0 + 1) * (r[1].1 - r[1].0 + 1) * (r[2].1 - r[2].0 + 1);
        let bin = |bx: usize, by: usize, bz: usize| -> Option<u64> {
            let b = st.brick_index(bx, by, bz);
            if sw.op == Op::Cut && st.bricks[b].iter().all(|&w| w == 0) {
                return None;
            }
            let (c, d) = st.brick_ball([bx * BRICK, by * BRICK, bz * BRICK]);
            (sw.cut_contains(&c, d + eps) || (guard && sw.guard_contains(&c, d + eps)))
                .then_some(((b as u64) << 24) | si as u64)
        };
        if n >= 4096 {
            let rows: Vec<(usize, usize)> =
                (r[2].0..=r[2].1).flat_map(|bz| (r[1].0..=r[1].1).map(move |by| (by, bz))).collect();
            pairs.par_extend(
                rows.into_par_iter()
                    .flat_map_iter(|(by, bz)| (r[0].0..=r[0].1).filter_map(move |bx| bin(bx, by, bz))),
            );
        } else {
            for bz in r[2].0..=r[2].1 {
                for by in r[1].0..=r[1].1 {
                    pairs.extend((r[0].0..=r[0].1).filter_map(|bx| bin(bx, by, bz)));
                }
            }
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
    let view = Store { spec, bdims, bricks: Vec::new() };
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
    let flags: &[AtomicU8] = flags;
    let work = |(brick, &(b, s, e)): (&mut Brick, &(usize, usize, usize))| {
        let base = [
            (b % bdims[0]) * BRICK,
            ((b / bdims[0]) % bdims[1]) * BRICK,
            (b / (bdims[0] * bdims[1])) * BRICK,
        ];
        let tgt = target.map(|t| &t.bricks[b]);
        process_brick(&view, brick, base, tgt, sweeps, &pairs[s..e], check_guard, eps, flags)
    };
    if pairs.len() < parallel_threshold {
        refs.into_iter().zip(groups.iter()).map(work).fold(Stats::default(), Stats::add)
    } else {
        refs.into_par_iter().zip(groups.par_iter()).map(work).reduce(Stats::default, Stats::add)
    }
}

#[inline]
fn popcount(b: &Brick) -> u64 {
    b.iter().map(|w| w.count_ones() as u64).sum()
}

/// Voxel centres of the brick at `base` whose bit is set in `bits` and that satisfy
/// `inside(q, 0)`, for a **convex** region. Each 8-voxel row along x is first culled at its
/// middle with `inside(mid, +half)`; a row whose two end centres are inside is inside
/// whole (convexity), so only rows crossing the boundary test their voxels one by one.
#[inline]
fn select(view: &Store, base: [usize; 3], bits: &Brick, inside: impl Fn(&Point3, f64) -> bool) -> Brick {
    let s = &view.spec;
    let half = 3.5 * s.voxel.x;
    let x0 = s.origin.x + (base[0] as f64 + 0.5) * s.voxel.x;
    let mut out = [0u64; BRICK];
    for (z, &word) in bits.iter().enumerate() {
        if word == 0 {
            continue;
        }
        let qz = s.origin.z + ((base[2] + z) as f64 + 0.5) * s.voxel.z;
        for y in 0..BRICK {
            let row = (word >> (BRICK * y)) & 0xff;
            if row == 0 {
                continue;
            }
            let qy = s.origin.y + ((base[1] + y) as f64 + 0.5) * s.voxel.y;
            if !inside(&Point3::new(x0 + half, qy, qz), half) {
                continue;
            }
            let first = row.trailing_zeros() as usize;
            let last = 63 - row.leading_zeros() as usize;
            let at = |x: usize| Point3::new(x0 + x as f64 * s.voxel.x, qy, qz);
            let hit = if inside(&at(first), 0.0) && inside(&at(last), 0.0) {
                row
            } else {
                let mut hit = 0u64;
                let mut w = row;
                while w != 0 {
                    let x = w.trailing_zeros() as usize;
                    w &= w - 1;
                    if inside(&at(x), 0.0) {
                        hit |= 1 << x;
                    }
                }
                hit
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
    pairs: &[u64],
    check_guard: bool,
    eps: f64,
    flags: &[AtomicU8],
) -> Stats {
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
                    select(view, base, &grid, |q, d| sw.cut_contains(q, d + eps))
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
                    select(view, base, brick, |q, d| sw.cut_contains(q, d + eps))
                };
                let n = popcount(&cut);
                if n > 0 {
                    st.removed += n;
                    for z in 0..BRICK {
                        brick[z] &= !cut[z];
                    }
                    if sw.rapid {
                        st.rapid_voxels += n;
                        flags[si].fetch_or(FLAG_RAPID, Ordering::Relaxed);
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
                if check_guard && sw.prims.nguard > 0 && sw.guard_contains(&c, d + eps) {
                    let hits = if sw.guard_contains(&c, eps - d) {
                        popcount(brick)
                    } else {
                        // Shank and holder together are not convex: select per primitive.
                        let mut m = [0u64; BRICK];
                        for g in &sw.prims.guard[..sw.prims.nguard] {
                            let part = select(view, base, brick, |q, d| g.contains(&sw.seg, q, d + eps));
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
