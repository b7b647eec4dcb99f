//! Set cover over a [`VisibilityMatrix`]: the paper's greedy (Eq. 3) and a multi-start
//! swap local search that improves on it.
//!
//! Everything here is deterministic: ties go to the lowest direction index, and the
//! random starts come from a seeded generator.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;

use s2g_geom::Real;

use crate::visibility::{VisibilityMatrix, popcount};

/// `|a | b|` without allocating.
#[inline]
fn count_or(a: &[u64], b: &[u64]) -> usize {
    a.iter().zip(b).map(|(x, y)| (x | y).count_ones() as usize).sum()
}

/// `|a & b|` without allocating.
#[inline]
fn count_and(a: &[u64], b: &[u64]) -> usize {
    a.iter().zip(b).map(|(x, y)| (x & y).count_ones() as usize).sum()
}

/// The candidate maximising `score`, ties to the first in `candidates` order; `None`
/// when there is no candidate.
fn argmax(candidates: &[usize], score: impl Fn(usize) -> usize + Sync) -> Option<(usize, usize)> {
    candidates
        .par_iter()
        .enumerate()
        .map(|(pos, &c)| (score(c), pos, c))
        .reduce_with(|a, b| if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) { b } else { a })
        .map(|(s, _, c)| (c, s))
}

/// The paper's greedy set cover (Eq. 3): repeatedly adds the candidate that sees the
/// most not-yet-covered samples, until the covered fraction reaches `target` or
/// `max_picks` directions are chosen (or no candidate adds anything). Returns the
/// picks in order.
pub fn greedy(m: &VisibilityMatrix, candidates: &[usize], max_picks: usize, target: f64) -> Vec<usize> {
    let mut covered = vec![0u64; m.words()];
    let mut picks = Vec::new();
    let need = (target * m.points() as f64).ceil().max(0.0) as usize;
    while picks.len() < max_picks && popcount(&covered) < need.min(m.points()) {
        let Some((best, gain)) = argmax(candidates, |c| {
            m.row(c).iter().zip(&covered).map(|(r, u)| (r & !u).count_ones() as usize).sum()
        }) else {
            break;
        };
        if gain == 0 {
            break;
        }
        picks.push(best);
        for (u, r) in covered.iter_mut().zip(m.row(best)) {
            *u |= r;
        }
    }
    picks
}

/// Reorders `set` greedily: first the direction that covers most, then each next the
/// one adding most. Returns the order and the coverage fraction after each pick.
pub fn greedy_order(m: &VisibilityMatrix, set: &[usize]) -> (Vec<usize>, Vec<f64>) {
    let mut rest: Vec<usize> = set.to_vec();
    let mut covered = vec![0u64; m.words()];
    let mut order = Vec::with_capacity(set.len());
    let mut curve = Vec::with_capacity(set.len());
    while !rest.is_empty() {
        let (pos, _) = rest
            .iter()
            .enumerate()
            .map(|(pos, &c)| (pos, count_or(&covered, m.row(c))))
            .fold((0, 0), |best, x| if x.1 > best.1 { x } else { best });
        let d = rest.remove(pos);
        for (u, r) in covered.iter_mut().zip(m.row(d)) {
            *u |= r;
        }
        order.push(d);
        curve.push(m.fraction(popcount(&covered)));
    }
    (order, curve)
}

/// The best `k`-subset of `pool` by exhaustive search (for small pools such as the six
/// axes); ties to the lexicographically first subset.
pub fn best_subset(m: &VisibilityMatrix, pool: &[usize], k: usize) -> Vec<usize> {
    let k = k.min(pool.len());
    let mut best: (usize, Vec<usize>) = (0, pool[..k].to_vec());
    let mut idx: Vec<usize> = (0..k).collect();
    loop {
        let set: Vec<usize> = idx.iter().map(|&i| pool[i]).collect();
        let c = m.covered(&set);
        if c > best.0 {
            best = (c, set);
        }
        // Next combination in lexicographic order.
        let mut i = k;
        loop {
            if i == 0 {
                return best.1;
            }
            i -= 1;
            if idx[i] < pool.len() - k + i {
                break;
            }
        }
        idx[i] += 1;
        for j in i + 1..k {
            idx[j] = idx[j - 1] + 1;
        }
    }
}

/// Best-improvement swap search: repeatedly replaces one direction of `set` by the
/// candidate that most increases the number of covered samples, until no swap
/// improves (or `max_sweeps` sweeps). Returns the improved set and its covered count.
pub fn swap_search(
    m: &VisibilityMatrix,
    set: &[usize],
    candidates: &[usize],
    max_sweeps: usize,
) -> (Vec<usize>, usize) {
    let mut set = set.to_vec();
    let mut current = m.covered(&set);
    let mut others = vec![0u64; m.words()];
    for _ in 0..max_sweeps {
        let mut best: Option<(usize, usize, usize)> = None; // (count, position, candidate)
        for pos in 0..set.len() {
            others.iter_mut().for_each(|w| *w = 0);
            for (q, &d) in set.iter().enumerate() {
                if q != pos {
                    for (u, r) in others.iter_mut().zip(m.row(d)) {
                        *u |= r;
                    }
                }
            }
            let Some((c, count)) =
                argmax(candidates, |c| if set.contains(&c) { 0 } else { count_or(&others, m.row(c)) })
            else {
                continue;
            };
            if count > current && best.is_none_or(|b| count > b.0) {
                best = Some((count, pos, c));
            }
        }
        match best {
            Some((count, pos, c)) => {
                set[pos] = c;
                current = count;
            }
            None => break,
        }
    }
    (set, current)
}

/// Options of [`multi_start_search`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchOptions {
    /// Number of seeded random starts besides greedy and the best axes. Default `4`.
    pub random_starts: usize,
    /// Perturbation rounds after the starts (iterated local search): replace
    /// `1 + round % 2` directions of the best set at random, re-run the swap search,
    /// keep the result if it covers more. Default `24`.
    pub kicks: usize,
    /// Cap on swap sweeps per local search. Default `64`.
    pub max_sweeps: usize,
    /// Seed of the random starts and kicks. Default `0`.
    pub seed: u64,
}

impl Default for SearchOptions {
    fn default() -> Self {
        Self { random_starts: 4, kicks: 24, max_sweeps: 64, seed: 0 }
    }
}

/// Multi-start swap search for the `k` directions that cover the most samples.
/// Starts: `greedy_start` (normally the plain greedy picks, padded greedily to `k`),
/// the best `k` of `axes`, and seeded random `k`-subsets of `candidates`; each is
/// improved by [`swap_search`], then iterated local search perturbs the best. Returns
/// the best set found and its covered count; never worse than any start.
pub fn multi_start_search(
    m: &VisibilityMatrix,
    candidates: &[usize],
    axes: &[usize],
    greedy_start: &[usize],
    k: usize,
    opts: &SearchOptions,
) -> (Vec<usize>, usize) {
    let k = k.min(candidates.len());
    if k == 0 {
        return (Vec::new(), 0);
    }
    let mut rng = StdRng::seed_from_u64(opts.seed ^ 0x05ee_d0f5_ea5c);
    let mut starts: Vec<Vec<usize>> = Vec::new();
    let mut g = greedy_start.to_vec();
    g.truncate(k);
    pad_greedily(m, candidates, &mut g, k);
    starts.push(g);
    if !axes.is_empty() {
        let mut a = best_subset(m, axes, k);
        pad_greedily(m, candidates, &mut a, k);
        starts.push(a);
    }
    for _ in 0..opts.random_starts {
        starts.push(random_subset(&mut rng, candidates, k));
    }
    let mut best: (Vec<usize>, usize) = (Vec::new(), 0);
    for s in starts {
        let r = swap_search(m, &s, candidates, opts.max_sweeps);
        if best.0.is_empty() || r.1 > best.1 {
            best = r;
        }
    }
    for round in 0..opts.kicks {
        let mut s = best.0.clone();
        for _ in 0..(1 + round % 2).min(k) {
            let pos = rng.random_range(0..k);
            let c = candidates[rng.random_range(0..candidates.len())];
            if !s.contains(&c) {
                s[pos] = c;
            }
        }
        let r = swap_search(m, &s, candidates, opts.max_sweeps);
        if r.1 > best.1 {
            best = r;
        }
    }
    best
}

/// Adds greedy picks to `set` until it has `k` distinct directions (or no candidate is left).
fn pad_greedily(m: &VisibilityMatrix, candidates: &[usize], set: &mut Vec<usize>, k: usize) {
    while set.len() < k {
        let covered = m.union(set);
        let Some((c, _)) = argmax(candidates, |c| {
            if set.contains(&c) { 0 } else { 1 + popcount(m.row(c)) - count_and(&covered, m.row(c)) }
        }) else {
            return;
        };
        if set.contains(&c) {
            return;
        }
        set.push(c);
    }
}

/// `k` distinct candidates drawn uniformly.
fn random_subset(rng: &mut StdRng, candidates: &[usize], k: usize) -> Vec<usize> {
    let mut pool = candidates.to_vec();
    for i in 0..k.min(pool.len()) {
        let j = rng.random_range(i..pool.len());
        pool.swap(i, j);
    }
    pool.truncate(k);
    pool
}

/// Each tilted direction of `chosen` gives way to a principal axis (`axes`, rows of `m`)
/// that keeps the set's coverage at `target` or above: the opposite of an axis of the set
/// where one does (a flip), else the one covering most (the lower index of equals). Sets
/// short of the target stay as they are. Orientation selection does this with a
/// tool-aware reach (issue 35): a box stock's faces are the shop's datums, and a tilted
/// setup that wins a few narrow samples over an axis (gearwheel_40t's tooth-gap roots,
/// which the reach's ray tests pass from an axis in their plane) does not cut more than
/// the flip whose rest passes cut the gaps through.
pub(crate) fn prefer_axes(m: &VisibilityMatrix, chosen: &mut [usize], axes: &[usize], target: Real) {
    if m.coverage(chosen) < target {
        return;
    }
    let dirs = m.directions();
    for pos in 0..chosen.len() {
        if axes.contains(&chosen[pos]) {
            continue;
        }
        let mut best: Option<(usize, (bool, usize))> = None;
        for &a in axes.iter().filter(|a| !chosen.contains(a)) {
            let mut trial = chosen.to_vec();
            trial[pos] = a;
            let flip = chosen.iter().any(|&c| axes.contains(&c) && dirs[c].dot(&dirs[a]) < -0.999);
            // The union counted once: `covered` and, from it, `coverage(&trial)`.
            let covered = m.covered(&trial);
            let key = (flip, covered);
            if m.fraction(covered) >= target && best.is_none_or(|(_, k)| key > k) {
                best = Some((a, key));
            }
        }
        if let Some((a, _)) = best {
            chosen[pos] = a;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use s2g_geom::{UnitVector3, Vector3};

    /// A matrix from explicit sets of visible sample indices.
    fn matrix(points: usize, rows: &[&[usize]]) -> VisibilityMatrix {
        let rows = rows
            .iter()
            .enumerate()
            .map(|(d, r)| {
                let mut bits = vec![0u64; points.div_ceil(64)];
                for &i in *r {
                    bits[i / 64] |= 1 << (i % 64);
                }
                (UnitVector3::new_normalize(Vector3::new(1.0, d as f64, 0.5)), bits)
            })
            .collect();
        VisibilityMatrix::from_rows(points, rows).unwrap()
    }

    #[test]
    fn greedy_is_suboptimal_on_the_classic_trap_and_swap_fixes_it() {
        // Samples 0..12. Two halves {0..6}, {6..12} cover everything; greedy first takes
        // the big row {0..4, 6..10} (8 samples) and then needs two more.
        let a: Vec<usize> = (0..6).collect();
        let b: Vec<usize> = (6..12).collect();
        let big: Vec<usize> = (0..4).chain(6..10).collect();
        let m = matrix(12, &[&a, &b, &big, &[4, 5], &[10, 11]]);
        let all: Vec<usize> = (0..5).collect();
        let g = greedy(&m, &all, 2, 1.0);
        assert_eq!(g[0], 2, "greedy starts with the largest row");
        assert!(m.covered(&g) < 12, "greedy with 2 picks covers {} of 12", m.covered(&g));
        let (s, c) = swap_search(&m, &g, &all, 10);
        assert_eq!(c, 12, "swap search from {g:?} reaches {s:?}");
        let (s2, c2) = multi_start_search(&m, &all, &[0, 1], &g, 2, &SearchOptions::default());
        assert_eq!((c2, m.covered(&s2)), (12, 12));
    }

    #[test]
    fn greedy_stops_at_target_and_reports_a_monotone_curve() {
        let m = matrix(100, &[&(0..50).collect::<Vec<_>>(), &(40..95).collect::<Vec<_>>(), &[99], &[98]]);
        let all: Vec<usize> = (0..4).collect();
        assert_eq!(greedy(&m, &all, 10, 0.95), vec![1, 0]);
        assert_eq!(greedy(&m, &all, 10, 1.0).len(), 4, "reaches 97 % then 98, 99 picks");
        assert_eq!(greedy(&m, &all, 1, 1.0), vec![1]);
        let (order, curve) = greedy_order(&m, &[2, 0, 1]);
        assert_eq!(order, vec![1, 0, 2]);
        assert_eq!(curve, vec![0.55, 0.95, 0.96]);
    }

    #[test]
    fn best_subset_is_exhaustive() {
        let m = matrix(10, &[&[0, 1, 2], &[3, 4], &[0, 1], &[5, 6, 7, 8], &[2, 9]]);
        assert_eq!(m.covered(&best_subset(&m, &[0, 1, 2, 3, 4], 2)), 7);
        assert_eq!(m.covered(&best_subset(&m, &[0, 1, 2, 3, 4], 4)), 10);
        assert_eq!(best_subset(&m, &[1, 2], 5).len(), 2);
    }

    #[test]
    fn a_tilted_setup_gives_way_to_a_flip_or_else_the_axis_covering_most_that_meets_the_target() {
        let axes = crate::directions::principal_axes();
        // Ten samples: +Z sees 0..6, the tilted direction (row 6) and +X the rest, -Z all
        // of the rest but sample 9.
        let sees = |list: &[usize]| {
            let mut bits = vec![0u64; 1];
            list.iter().for_each(|&i| bits[0] |= 1 << i);
            bits
        };
        let mut rows: Vec<(UnitVector3, Vec<u64>)> = axes
            .iter()
            .enumerate()
            .map(|(a, d)| match a {
                0 => (*d, sees(&[0, 1, 2, 3, 4, 5])),
                1 => (*d, sees(&[6, 7, 8])),
                2 => (*d, sees(&[6, 7, 8, 9])),
                _ => (*d, sees(&[])),
            })
            .collect();
        rows.push((UnitVector3::new_normalize(Vector3::new(-0.8, 0.0, -0.6)), sees(&[6, 7, 8, 9])));
        let m = VisibilityMatrix::from_rows(10, rows).unwrap();
        let all: Vec<usize> = (0..6).collect();
        let pick = |target: f64| {
            let mut chosen = vec![0, 6];
            prefer_axes(&m, &mut chosen, &all, target);
            chosen
        };
        assert_eq!(pick(0.9), [0, 1], "the flip meets the target");
        assert_eq!(pick(0.95), [0, 2], "the flip does not: the axis that does");
        // Where no axis offered meets the target the tilt stays; a set short of it stays.
        let mut short = vec![0, 6];
        prefer_axes(&m, &mut short, &[0, 1], 0.95);
        assert_eq!(short, [0, 6], "-Z alone is offered and misses sample 9");
        let mut alone = vec![6];
        prefer_axes(&m, &mut alone, &all, 0.5);
        assert_eq!(alone, [6], "under the target");
    }
}
