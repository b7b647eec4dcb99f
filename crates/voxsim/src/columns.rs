//! The per-column and per-block tests of the height field's tiled sweep
//! ([`crate::HeightField`]), with fewer square roots than their baselines (kept here for
//! the bench and the tests) and the same answers bit for bit.

/// The two per-column tests of a move's tiled sweep, on the column's squared distance
/// `rho2` from the move's path (`rho = rho2.sqrt()`): whether a feed marks it
/// (`rho <= w`) and whether it lies no higher than the cutter's tip profile can cut it
/// (`t <= zmin + floor(rho)`). With `fast`, each is first decided on `rho2` where a margin
/// far wider than the rounding of either side (1e-9 relative) separates them, without a
/// square root; only columns inside the margin take the exact expressions. So every
/// decision is the exact one, bit for bit.
#[derive(Clone, Copy)]
pub(crate) struct ColumnTests {
    radius: f64,
    rc: f64,
    zmin: f64,
    w: f64,
    /// `w^2` less and more the margin.
    w2: [f64; 2],
    /// `radius^2` and more the margin: beyond it, a ball's floor is `rc` bit for bit.
    rim2: f64,
    /// A ball end (`radius - rc == 0`): the floor is `rc - sqrt(rc^2 - rho^2)`, decided
    /// on `rho2` alone.
    ball: bool,
    fast: bool,
}

impl ColumnTests {
    const MARGIN: f64 = 1e-9;

    pub(crate) fn new((radius, rc): (f64, f64), zmin: f64, w: f64, fast: bool) -> Self {
        let w2 = [w * w * (1.0 - Self::MARGIN), w * w * (1.0 + Self::MARGIN)];
        let rim2 = radius * radius * (1.0 + Self::MARGIN);
        Self { radius, rc, zmin, w, w2, rim2, ball: radius - rc == 0.0, fast }
    }

    /// How high above the tip the cutter's profile lies at `rho` from its axis.
    #[inline]
    pub(crate) fn floor(&self, rho: f64) -> f64 {
        let (radius, rc) = (self.radius, self.rc);
        let d = rho.min(radius) - (radius - rc);
        if d <= 0.0 { 0.0 } else { rc - (rc * rc - d * d).max(0.0).sqrt() }
    }

    /// `rho2.sqrt() <= w`.
    #[inline]
    pub(crate) fn marks(&self, rho2: f64) -> bool {
        if self.w < 0.0 {
            return false;
        }
        if !self.fast {
            return rho2.sqrt() <= self.w;
        }
        if rho2 <= self.w2[0] {
            return true;
        }
        if rho2 >= self.w2[1] {
            return false;
        }
        self.marks_exact(rho2)
    }

    /// [`ColumnTests::marks`] by the square root: out of line, so that the compiler does
    /// not compute the root ahead of the tests that make it needless.
    #[cold]
    #[inline(never)]
    fn marks_exact(&self, rho2: f64) -> bool {
        rho2.sqrt() <= self.w
    }

    /// `t <= zmin + floor(rho2.sqrt())`.
    #[inline]
    pub(crate) fn above(&self, t: f64, rho2: f64) -> bool {
        if !(self.fast && self.ball) {
            return t <= self.zmin + self.floor(rho2.sqrt());
        }
        match self.ball_above(t, rho2) {
            Some(v) => v,
            None => self.above_exact(t, rho2),
        }
    }

    /// [`ColumnTests::above`] by the square roots, out of line as
    /// [`ColumnTests::marks_exact`] is.
    #[cold]
    #[inline(never)]
    fn above_exact(&self, t: f64, rho2: f64) -> bool {
        t <= self.zmin + self.floor(rho2.sqrt())
    }

    /// [`ColumnTests::above`] for a ball end where the margin decides it: with
    /// `q = zmin + rc - t`, the test is `sqrt(rc^2 - rho^2) <= q` (the root's argument at
    /// least 0), compared squared. Beyond the radius (by the margin: the root of `rho2` is
    /// then above it) the floor is `rc - sqrt(0)`, `rc` itself: the test is `t <= zmin +
    /// rc` as the exact expressions compute it, also where `q` is near 0 (the rim of an
    /// earlier move of the pass at the same height).
    #[inline]
    fn ball_above(&self, t: f64, rho2: f64) -> Option<bool> {
        let rc = self.rc;
        if rho2 >= self.rim2 {
            return Some(t <= self.zmin + rc);
        }
        let q = self.zmin + rc - t;
        let m = Self::MARGIN * (1.0 + self.zmin.abs() + rc + t.abs());
        if q < -m {
            return Some(false);
        }
        // Near 0 (or NaN, for a column still at +inf), the exact expressions decide.
        if q.is_nan() || q <= m {
            return None;
        }
        let (s, e) = ((rc * rc - rho2).max(0.0), Self::MARGIN * (1.0 + rc * rc));
        if s + e < (q - m) * (q - m) {
            Some(true)
        } else if s - e > (q + m) * (q + m) {
            Some(false)
        } else {
            None
        }
    }
}

/// Whether the segment `p q` meets the rectangle `[lo, hi]`: the segment clipped to it
/// (Liang-Barsky) keeps a piece.
fn segment_meets_rect(lo: [f64; 2], hi: [f64; 2], p: [f64; 2], q: [f64; 2]) -> bool {
    let d = [q[0] - p[0], q[1] - p[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        if d[k] == 0.0 {
            if p[k] < lo[k] || p[k] > hi[k] {
                return false;
            }
        } else {
            let (a, b) = ((lo[k] - p[k]) / d[k], (hi[k] - p[k]) / d[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
    }
    t0 <= t1
}

/// The distance from the rectangle `[lo, hi]` to the segment `p q` in the plane (0 where
/// they meet): the least of the six squared distances ([`apart_squared`]), then one square
/// root; the root is monotone, so it is the least of their roots, bit for bit.
pub(crate) fn rect_segment_distance(lo: [f64; 2], hi: [f64; 2], p: [f64; 2], q: [f64; 2]) -> f64 {
    if segment_meets_rect(lo, hi, p, q) {
        return 0.0;
    }
    apart_squared(lo, hi, p, q).into_iter().fold(f64::INFINITY, f64::min).sqrt()
}

/// [`rect_segment_distance`] as the least of six square roots: its baseline (the same
/// bits).
pub(crate) fn rect_segment_distance_roots(lo: [f64; 2], hi: [f64; 2], p: [f64; 2], q: [f64; 2]) -> f64 {
    if segment_meets_rect(lo, hi, p, q) {
        return 0.0;
    }
    apart_squared(lo, hi, p, q).into_iter().map(f64::sqrt).fold(f64::INFINITY, f64::min)
}

/// The distance between the rectangle `[lo, hi]` and the box `[x0, x1] x [y0, y1]` (0 where
/// they meet), less `2e-9` (at least 0): a lower bound of the rectangle's distance from any
/// segment in the box less the `1e-9` margin of the tiled sweep's `near`, by a
/// margin far wider than the rounding of either.
#[inline]
pub(crate) fn box_gap(lo: [f64; 2], hi: [f64; 2], [x0, x1, y0, y1]: [f64; 4]) -> f64 {
    let gx = (lo[0] - x1).max(x0 - hi[0]).max(0.0);
    let gy = (lo[1] - y1).max(y0 - hi[1]).max(0.0);
    ((gx * gx + gy * gy).sqrt() - 2e-9).max(0.0)
}

/// Where the segment `p q` and the rectangle `[lo, hi]` are apart, the nearest pair has an
/// end of the segment or a corner of the rectangle: the squared distances from the four
/// corners to the segment and from its two ends to the rectangle.
fn apart_squared(lo: [f64; 2], hi: [f64; 2], p: [f64; 2], q: [f64; 2]) -> [f64; 6] {
    let d = [q[0] - p[0], q[1] - p[1]];
    let to_rect = |x: [f64; 2]| {
        let dx = (lo[0] - x[0]).max(x[0] - hi[0]).max(0.0);
        let dy = (lo[1] - x[1]).max(x[1] - hi[1]).max(0.0);
        dx * dx + dy * dy
    };
    let dd = d[0] * d[0] + d[1] * d[1];
    let to_seg = |x: [f64; 2]| {
        let u =
            if dd > 0.0 { (((x[0] - p[0]) * d[0] + (x[1] - p[1]) * d[1]) / dd).clamp(0.0, 1.0) } else { 0.0 };
        let (ex, ey) = (x[0] - p[0] - d[0] * u, x[1] - p[1] - d[1] * u);
        ex * ex + ey * ey
    };
    [to_seg(lo), to_seg([hi[0], lo[1]]), to_seg(hi), to_seg([lo[0], hi[1]]), to_rect(p), to_rect(q)]
}

#[cfg(test)]
mod tests {
    use super::{ColumnTests, box_gap, rect_segment_distance, rect_segment_distance_roots};
    use s2g_geom::SplitMix64;

    /// `x` moved by `k` units in the last place.
    fn ulps(x: f64, k: i64) -> f64 {
        if x == 0.0 {
            return x;
        }
        f64::from_bits((x.to_bits() as i64 + k) as u64)
    }

    /// Both tests, with and without the margin, agree on columns at and a few ulps about
    /// their boundaries (`rho = w`, `t = zmin + floor(rho)`) and on random ones, for ball,
    /// bull-nose and flat profiles.
    #[test]
    fn the_fast_tests_decide_as_the_exact_ones() {
        let mut g = SplitMix64::new(7, 36);
        let (mut marked, mut above, mut cases) = (0, 0, 0);
        for _ in 0..20_000 {
            let radius = g.uniform(0.1, 8.0);
            let rc = match g.below(3) {
                0 => radius,
                1 => g.uniform(0.0, radius),
                _ => 0.0,
            };
            let zmin = g.uniform(-60.0, 60.0);
            let w = if g.below(4) == 0 { -1.0 } else { g.uniform(0.0, 2.0) };
            let (fast, exact) = (
                ColumnTests::new((radius, rc), zmin, w, true),
                ColumnTests::new((radius, rc), zmin, w, false),
            );
            let rho = match g.below(4) {
                0 => w.abs(),
                1 => radius,
                // About the rim beyond which a ball's floor is taken as `rc`.
                2 => radius * (1.0 + 0.5 * ColumnTests::MARGIN),
                _ => g.uniform(0.0, 1.2 * radius),
            };
            for k in -3..=3 {
                let rho2 = ulps(rho * rho, k);
                let on = zmin + exact.floor(rho2.sqrt());
                let ts = [
                    on,
                    ulps(on, -2),
                    ulps(on, -1),
                    ulps(on, 1),
                    ulps(on, 2),
                    zmin + g.uniform(0.0, 1.2 * rc),
                ];
                assert_eq!(fast.marks(rho2), exact.marks(rho2), "marks at rho2 {rho2}, w {w}");
                marked += usize::from(exact.marks(rho2));
                for t in ts {
                    assert_eq!(
                        fast.above(t, rho2),
                        exact.above(t, rho2),
                        "t {t}, rho2 {rho2}, {radius} {rc} {zmin}"
                    );
                    above += usize::from(exact.above(t, rho2));
                    cases += 1;
                }
            }
        }
        // Both outcomes of each test were met many times.
        assert!(marked > 10_000 && marked < 130_000, "{marked}");
        assert!(above > cases / 10 && above < cases * 9 / 10, "{above} of {cases}");
    }

    /// The one-root distance between a rectangle and a segment equals the six-root one,
    /// bit for bit, apart and meeting, on random and axis-aligned segments.
    #[test]
    fn the_rect_segment_distance_is_its_baseline() {
        let mut g = SplitMix64::new(11, 36);
        let mut apart = 0;
        for k in 0..50_000 {
            let lo = [g.uniform(-5.0, 5.0), g.uniform(-5.0, 5.0)];
            let hi = [lo[0] + g.uniform(0.0, 2.0), lo[1] + g.uniform(0.0, 2.0)];
            let p = [g.uniform(-9.0, 9.0), g.uniform(-9.0, 9.0)];
            let q = match k % 3 {
                0 => [p[0], g.uniform(-9.0, 9.0)],
                1 => [g.uniform(-9.0, 9.0), p[1]],
                _ => [g.uniform(-9.0, 9.0), g.uniform(-9.0, 9.0)],
            };
            let (d, e) = (rect_segment_distance(lo, hi, p, q), rect_segment_distance_roots(lo, hi, p, q));
            assert_eq!(d.to_bits(), e.to_bits(), "{lo:?} {hi:?} {p:?} {q:?}");
            apart += usize::from(d > 0.0);
        }
        assert!(apart > 10_000 && apart < 49_000, "{apart}");
    }

    /// The box gap is at most the block's distance from the path less its margin (what
    /// the tiled sweep's `near` is), for segments inside their box, far from and touching
    /// the rectangle, short and long, with blocks near the coordinates of a 100 mm part;
    /// and close to it where the segment is short (the gap decides those blocks).
    #[test]
    fn the_box_gap_is_at_most_the_blocks_distance() {
        let mut g = SplitMix64::new(13, 36);
        let (mut close, mut apart) = (0, 0);
        for k in 0..100_000 {
            let lo = [g.uniform(-120.0, 120.0), g.uniform(-120.0, 120.0)];
            let hi = [lo[0] + g.uniform(0.0, 1.0), lo[1] + g.uniform(0.0, 1.0)];
            let len = if k % 2 == 0 { g.uniform(0.0, 0.5) } else { g.uniform(0.0, 30.0) };
            let p = [lo[0] + g.uniform(-8.0, 8.0), lo[1] + g.uniform(-8.0, 8.0)];
            let q = match k % 5 {
                0 => p,
                1 => [p[0], p[1] + len],
                2 => [p[0] - len, p[1]],
                _ => {
                    let a = g.uniform(0.0, std::f64::consts::TAU);
                    [p[0] + len * a.cos(), p[1] + len * a.sin()]
                }
            };
            let path = [p[0].min(q[0]), p[0].max(q[0]), p[1].min(q[1]), p[1].max(q[1])];
            let (gap, d) = (box_gap(lo, hi, path), rect_segment_distance(lo, hi, p, q));
            let near = (d - 1e-9).max(0.0);
            assert!(gap <= near, "{lo:?} {hi:?} {p:?} {q:?}: {gap} > {near}");
            apart += usize::from(near > 0.0);
            close += usize::from(len < 0.5 && near > 0.0 && gap > near - 0.5);
        }
        assert!(apart > 50_000, "{apart}");
        assert!(close > 20_000, "{close}");
    }
}
