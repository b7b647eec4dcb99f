//! The dexel (ray-rep) carver for setups whose tool axis is a grid axis (+ or -).
//!
//! Each column of voxels parallel to the tool axis holds a sorted list of material
//! intervals (voxel index ranges), so undercuts left by other setups survive. The swept
//! cutter is convex, so its intersection with a column's centre line is one interval,
//! computed in closed form per column (see [`crate::sweep::Prim::column`]); the voxels whose
//! centres fall in it are subtracted. The same voxel-centre rule as the exact carver is
//! used, so the two agree up to floating-point ties on the boundary. Columns are read
//! from the voxel stock lazily, when a move first touches them, and written back (only
//! their changed range) when the setup ends.

use rayon::prelude::*;
use s2g_geom::Point3;

use crate::engine::{Op, Stats, Store, Sweep, Tolerance};
use crate::sweep::Prim;

/// One column's state.
#[derive(Debug, Clone, Default)]
struct Col {
    active: bool,
    /// Changed index range `[lo, hi)`.
    dirty: (u32, u32),
    runs: Vec<[u32; 2]>,
    target: Vec<[u32; 2]>,
}

/// Dexel field along grid axis `ax`, tool axis sign `sign`.
#[derive(Debug, Clone)]
pub(crate) struct Dexel {
    pub ax: usize,
    pub sign: f64,
    uax: usize,
    vax: usize,
    nu: usize,
    nv: usize,
    cols: Vec<Col>,
}

impl Dexel {
    pub fn new(store: &Store, ax: usize, sign: f64) -> Self {
        let (uax, vax) = match ax {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let d = store.spec.dims;
        let (nu, nv) = (d[uax], d[vax]);
        Self { ax, sign, uax, vax, nu, nv, cols: vec![Col::default(); nu * nv] }
    }

    /// Applies one sweep; returns its statistics (removed, gouge, holder hits).
    pub fn apply(
        &mut self,
        store: &Store,
        target: Option<&Store>,
        sw: &Sweep,
        check_guard: bool,
        parallel_threshold: usize,
        tol: Tolerance,
    ) -> Stats {
        let eps = tol.tie;
        debug_assert!(sw.op == Op::Cut);
        let guard = check_guard && sw.prims.nguard > 0;
        let (lo, hi) = sw.aabb(guard);
        let spec = store.spec;
        let (Some((u0, u1)), Some((v0, v1))) = (
            spec.center_range(lo[self.uax], hi[self.uax], self.uax),
            spec.center_range(lo[self.vax], hi[self.vax], self.vax),
        ) else {
            return Stats::default();
        };
        let nu = self.nu;
        let (ax, uax, vax, sign) = (self.ax, self.uax, self.vax, self.sign);
        let nk = spec.dims[ax];
        let this = Geometry { ax, uax, vax, sign, eps };
        let row = |(v, cols): (usize, &mut [Col])| -> Stats {
            let mut st = Stats::default();
            for (u, col) in cols.iter_mut().enumerate().take(u1 + 1).skip(u0) {
                let mut base = Point3::origin();
                base[uax] = spec.origin[uax] + (u as f64 + 0.5) * spec.voxel[uax];
                base[vax] = spec.origin[vax] + (v as f64 + 0.5) * spec.voxel[vax];
                base[ax] = spec.origin[ax];
                let range = |prims: &[Prim]| this.range(&spec, sw, prims, &base);
                let cut = range(&sw.prims.cut[..sw.prims.ncut]);
                if !col.active {
                    // Initialise lazily, and only when the column is reached at all.
                    let any_guard =
                        guard && sw.prims.guard[..sw.prims.nguard].iter().any(|p| range(&[*p]).is_some());
                    if cut.is_none() && !any_guard {
                        continue;
                    }
                    col.active = true;
                    col.dirty = (u32::MAX, 0);
                    col.runs = runs_of(nk, |k| store.get_idx(this.idx(u, v, k)));
                    if let Some(t) = target {
                        col.target = runs_of(nk, |k| t.get_idx(this.idx(u, v, k)));
                    }
                }
                // The centre of the column's voxel `k`.
                let at = |k: u32| {
                    let mut q = base;
                    q[ax] = spec.origin[ax] + (k as f64 + 0.5) * spec.voxel[ax];
                    q
                };
                if let Some((a, b)) = cut {
                    if sw.rapid {
                        // Only voxels deeper inside the tool than the graze tolerance collide.
                        st.rapid_voxels += deep_in(&col.runs, a, b, |k| sw.cut_contains(&at(k), -tol.graze));
                    }
                    let mut gouge = 0u64;
                    let target_runs = &col.target;
                    let removed = subtract(&mut col.runs, a, b, |x, y| gouge += overlap(target_runs, x, y));
                    if removed > 0 {
                        col.dirty = (col.dirty.0.min(a), col.dirty.1.max(b));
                        st.removed += removed;
                        if gouge > 0 {
                            st.gouge += gouge;
                            st.first_gouge = Some((sw.seq, sw.line));
                        }
                    }
                }
                if guard {
                    for p in &sw.prims.guard[..sw.prims.nguard] {
                        if let Some((a, b)) = range(&[*p]) {
                            st.holder_voxels +=
                                deep_in(&col.runs, a, b, |k| p.contains(&sw.seg, &at(k), -tol.graze));
                        }
                    }
                }
            }
            st
        };
        let slab = &mut self.cols[v0 * nu..(v1 + 1) * nu];
        let n = (u1 - u0 + 1) * (v1 - v0 + 1);
        if n < parallel_threshold * 64 {
            slab.chunks_mut(nu).enumerate().map(|(i, c)| row((v0 + i, c))).fold(Stats::default(), Stats::add)
        } else {
            slab.par_chunks_mut(nu)
                .enumerate()
                .map(|(i, c)| row((v0 + i, c)))
                .reduce(Stats::default, Stats::add)
        }
    }

    /// Writes every changed column back into the voxel stock and forgets them.
    pub fn merge_into(&mut self, store: &mut Store) {
        for v in 0..self.nv {
            for u in 0..self.nu {
                let col = &mut self.cols[u + self.nu * v];
                if !col.active {
                    continue;
                }
                let (lo, hi) = col.dirty;
                let mut r = 0;
                for k in lo..hi {
                    while r < col.runs.len() && col.runs[r][1] <= k {
                        r += 1;
                    }
                    let inside = r < col.runs.len() && col.runs[r][0] <= k;
                    let mut i = [0; 3];
                    i[self.uax] = u;
                    i[self.vax] = v;
                    i[self.ax] = k as usize;
                    store.set(i[0], i[1], i[2], inside);
                }
                *col = Col::default();
            }
        }
    }
}

/// Axis bookkeeping shared by the row workers.
#[derive(Clone, Copy)]
struct Geometry {
    ax: usize,
    uax: usize,
    vax: usize,
    sign: f64,
    eps: f64,
}

impl Geometry {
    fn idx(&self, u: usize, v: usize, k: usize) -> [usize; 3] {
        let mut i = [0; 3];
        i[self.uax] = u;
        i[self.vax] = v;
        i[self.ax] = k;
        i
    }

    /// Voxel index range `[a, b)` along the column covered by the union of `prims`.
    fn range(
        &self,
        spec: &s2g_geom::GridSpec,
        sw: &Sweep,
        prims: &[Prim],
        base: &Point3,
    ) -> Option<(u32, u32)> {
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        for p in prims {
            if let Some((s0, s1)) = p.column(&sw.seg, base) {
                lo = lo.min(s0);
                hi = hi.max(s1);
            }
        }
        if lo > hi {
            return None;
        }
        let (lo, hi) = (lo - self.eps, hi + self.eps);
        let (x0, x1) = (base[self.ax] + self.sign * lo, base[self.ax] + self.sign * hi);
        let (k0, k1) = spec.center_range(x0.min(x1), x0.max(x1), self.ax)?;
        Some((k0 as u32, k1 as u32 + 1))
    }
}

impl Store {
    #[inline]
    fn get_idx(&self, i: [usize; 3]) -> bool {
        self.get(i[0], i[1], i[2])
    }
}

/// Run-length encoding of the set indices of a column.
fn runs_of(n: usize, get: impl Fn(usize) -> bool) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    let mut start = None;
    for k in 0..n {
        match (get(k), start) {
            (true, None) => start = Some(k),
            (false, Some(s)) => {
                out.push([s as u32, k as u32]);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push([s as u32, n as u32]);
    }
    out
}

/// How many voxels of `runs` in `[a, b)` pass `deep` (only the overlap is tested).
fn deep_in(runs: &[[u32; 2]], a: u32, b: u32, deep: impl Fn(u32) -> bool) -> u64 {
    runs.iter().flat_map(|&[x, y]| x.max(a)..y.min(b)).filter(|&k| deep(k)).count() as u64
}

/// Number of indices of `[a, b)` covered by `runs`.
fn overlap(runs: &[[u32; 2]], a: u32, b: u32) -> u64 {
    runs.iter().map(|&[x, y]| (y.min(b) as i64 - x.max(a) as i64).max(0) as u64).sum()
}

/// Removes `[lo, hi)` from `runs`; calls `removed(x, y)` for every removed piece; returns the count.
fn subtract(runs: &mut Vec<[u32; 2]>, lo: u32, hi: u32, mut removed: impl FnMut(u32, u32)) -> u64 {
    let mut n = 0u64;
    let mut i = 0;
    while i < runs.len() {
        let [a, b] = runs[i];
        if b <= lo {
            i += 1;
            continue;
        }
        if a >= hi {
            break;
        }
        let (x, y) = (a.max(lo), b.min(hi));
        n += (y - x) as u64;
        removed(x, y);
        match (a < lo, b > hi) {
            (true, true) => {
                runs[i] = [a, lo];
                runs.insert(i + 1, [hi, b]);
                break;
            }
            (true, false) => {
                runs[i] = [a, lo];
                i += 1;
            }
            (false, true) => {
                runs[i] = [hi, b];
                break;
            }
            (false, false) => {
                runs.remove(i);
            }
        }
    }
    n
}
