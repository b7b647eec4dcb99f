//! Exact membership in the volume swept by a cutter moving along a segment with a fixed axis.
//!
//! Every cutter is a union of *primitives* placed relative to the tip `P(t) = p0 + t d`,
//! `t in [0, 1]`, with unit tool axis `a`:
//! - [`Prim::Cyl`]: disc of radius `r` between heights `h0..h1` (flat end, shank, holder);
//! - [`Prim::Capsule`]: ball of radius `r` centred at height `c` (ball end);
//! - [`Prim::RDisc`]: every point within `rc` of the disc of radius `rp` at height `c`
//!   (the rounded puck whose lower half is a bull nose's end);
//! - [`Prim::Slab`]: rectangular bead section (additive mode).
//!
//! For a point `q`, membership is an existence question over `t`. For the cylinder the
//! axial condition is a linear interval in `t` and the radial one a quadratic interval: the
//! point is inside iff they intersect inside `[0, 1]` (closed form). The capsule is the
//! point-to-segment distance. For the rounded disc, `t -> dist(q - P(t), disc)^2` is convex
//! (distance to a convex set composed with an affine map), so its minimum over `[0, 1]` is
//! found by bisection on the sign of its derivative, to machine precision.
//!
//! Every test takes an offset `delta`: positive inflates the primitive (a superset of its
//! Minkowski sum with a ball of radius `delta`), negative deflates it (a subset whose
//! `delta`-neighbourhood lies inside). Brick culling uses both to classify whole 8x8x8
//! bricks as outside / inside without visiting their voxels.

use s2g_geom::{Point3, Vector3};

/// Bisection steps for the convex one-dimensional minimisations.
const BISECT_STEPS: usize = 60;

/// A segment swept with a fixed axis (part frame).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Seg {
    pub p0: Point3,
    pub d: Vector3,
    pub a: Vector3,
    /// `d . a`.
    pub da: f64,
    /// `d` perpendicular to `a`.
    pub dp: Vector3,
    /// `|dp|^2`.
    pub aa: f64,
    /// `|d|^2`.
    pub dd: f64,
    /// `|d|`, as `dd.sqrt()` (computed once per segment, not per column).
    pub len: f64,
}

impl Seg {
    pub fn new(p0: Point3, p1: Point3, a: Vector3) -> Self {
        let d = p1 - p0;
        let da = d.dot(&a);
        let dp = d - a * da;
        let dd = d.norm_squared();
        Self { p0, d, a, da, dp, aa: dp.norm_squared(), dd, len: dd.sqrt() }
    }

    /// `(w . a, w_perp)` for `w = q - p0`.
    #[inline]
    fn split(&self, q: &Point3) -> (f64, Vector3) {
        let w = q - self.p0;
        let wa = w.dot(&self.a);
        (wa, w - self.a * wa)
    }

    /// The `t` interval (clipped to `[0, 1]`) where `|w_perp - t dp| <= r`.
    #[inline]
    fn radial(&self, wp: &Vector3, r: f64) -> Option<(f64, f64)> {
        if r < 0.0 {
            return None;
        }
        let c = wp.norm_squared();
        // Below a picometre of sideways motion the distance is constant in t.
        if self.aa < 1e-24 {
            return (c <= r * r).then_some((0.0, 1.0));
        }
        let b = wp.dot(&self.dp);
        let disc = b * b - self.aa * (c - r * r);
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        let lo = ((b - s) / self.aa).max(0.0);
        let hi = ((b + s) / self.aa).min(1.0);
        (lo <= hi).then_some((lo, hi))
    }
}

/// One convex piece of a swept tool or bead (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Prim {
    Cyl { h0: f64, h1: f64, r: f64 },
    Capsule { c: f64, r: f64 },
    RDisc { c: f64, rp: f64, rc: f64 },
    Slab { h0: f64, h1: f64, hw: f64 },
}

impl Prim {
    /// Bounding cylinder `(h_lo, h_hi, radius)` about the axis.
    pub fn bound(&self) -> (f64, f64, f64) {
        match *self {
            Prim::Cyl { h0, h1, r } => (h0, h1, r),
            Prim::Capsule { c, r } => (c - r, c + r, r),
            Prim::RDisc { c, rp, rc } => (c - rc, c + rc, rp + rc),
            Prim::Slab { h0, h1, hw } => (h0, h1, hw),
        }
    }

    /// Whether `q` lies in the sweep of the primitive offset by `delta`.
    #[inline]
    pub fn contains(&self, s: &Seg, q: &Point3, delta: f64) -> bool {
        match *self {
            Prim::Cyl { h0, h1, r } => cyl(s, q, h0 - delta, h1 + delta, r + delta),
            Prim::Capsule { c, r } => {
                let r = r + delta;
                if r < 0.0 {
                    return false;
                }
                let w = q - (s.p0 + s.a * c);
                let t = if s.dd > 0.0 { (w.dot(&s.d) / s.dd).clamp(0.0, 1.0) } else { 0.0 };
                (w - s.d * t).norm_squared() <= r * r
            }
            Prim::RDisc { c, rp, rc } => rdisc(s, q, c, rp, rc + delta),
            Prim::Slab { h0, h1, hw } => slab(s, q, h0, h1, hw, delta),
        }
    }

    /// The interval of `s` such that `base + s a` lies in the sweep (lines parallel to the
    /// tool axis; used by the dexel carver). Exact for every primitive but the rounded disc,
    /// whose convex envelope is minimised to machine precision.
    pub fn column(&self, sg: &Seg, base: &Point3) -> Option<(f64, f64)> {
        let (wa, wp) = sg.split(base);
        match *self {
            Prim::Cyl { h0, h1, r } | Prim::Slab { h0, h1, hw: r } => {
                let (t0, t1) = sg.radial(&wp, r)?;
                let (m0, m1) = (t0 * sg.da, t1 * sg.da);
                Some((h0 - wa + m0.min(m1), h1 - wa + m0.max(m1)))
            }
            Prim::Capsule { c, r } => {
                let (t0, t1) = sg.radial(&wp, r)?;
                let cc = wp.norm_squared();
                let b = wp.dot(&sg.dp);
                let half = |t: f64| (r * r - (cc - 2.0 * t * b + t * t * sg.aa)).max(0.0).sqrt();
                let centre = |t: f64| c - wa + t * sg.da;
                if sg.aa < 1e-24 {
                    let h = half(t0);
                    let (m0, m1) = (centre(t0), centre(t1));
                    return Some((m0.min(m1) - h, m0.max(m1) + h));
                }
                // Closed-form extremes of centre(t) -/+ half(t): with rho^2 = aa (t - tm)^2 + m
                // and K = r^2 - m, the stationary points are tm -/+ da sqrt(K / aa) / |d|.
                let tm = b / sg.aa;
                let k = (r * r - (cc - b * b / sg.aa)).max(0.0);
                let off = sg.da * (k / sg.aa).sqrt() / sg.len;
                let tlo = (tm - off).clamp(t0, t1);
                let thi = (tm + off).clamp(t0, t1);
                Some((centre(tlo) - half(tlo), centre(thi) + half(thi)))
            }
            Prim::RDisc { c, rp, rc } => {
                let (t0, t1) = sg.radial(&wp, rp + rc)?;
                let cc = wp.norm_squared();
                let b = wp.dot(&sg.dp);
                let half = |t: f64| {
                    let rho = (cc - 2.0 * t * b + t * t * sg.aa).max(0.0).sqrt();
                    let y = (rho - rp).max(0.0);
                    (rc * rc - y * y).max(0.0).sqrt()
                };
                let lo = |t: f64| c - wa + t * sg.da - half(t);
                let hi = |t: f64| -(c - wa + t * sg.da + half(t));
                let a = golden_min(lo, t0, t1);
                let z = golden_min(hi, t0, t1);
                Some((lo(a), -hi(z)))
            }
        }
    }

    /// The lower end of [`Prim::column`]'s interval, by the same expressions (so the same
    /// bits), without computing its upper end: what a height field keeps.
    #[inline]
    pub fn column_low(&self, sg: &Seg, base: &Point3) -> Option<f64> {
        let (wa, wp) = sg.split(base);
        match *self {
            Prim::Cyl { h0, r, .. } | Prim::Slab { h0, hw: r, .. } => {
                let (t0, t1) = sg.radial(&wp, r)?;
                let (m0, m1) = (t0 * sg.da, t1 * sg.da);
                Some(h0 - wa + m0.min(m1))
            }
            Prim::Capsule { c, r } => {
                let (t0, t1) = sg.radial(&wp, r)?;
                let cc = wp.norm_squared();
                let b = wp.dot(&sg.dp);
                let half = |t: f64| (r * r - (cc - 2.0 * t * b + t * t * sg.aa)).max(0.0).sqrt();
                let centre = |t: f64| c - wa + t * sg.da;
                if sg.aa < 1e-24 {
                    let h = half(t0);
                    let (m0, m1) = (centre(t0), centre(t1));
                    return Some(m0.min(m1) - h);
                }
                let tm = b / sg.aa;
                let k = (r * r - (cc - b * b / sg.aa)).max(0.0);
                let off = sg.da * (k / sg.aa).sqrt() / sg.len;
                let tlo = (tm - off).clamp(t0, t1);
                Some(centre(tlo) - half(tlo))
            }
            Prim::RDisc { c, rp, rc } => {
                let (t0, t1) = sg.radial(&wp, rp + rc)?;
                let cc = wp.norm_squared();
                let b = wp.dot(&sg.dp);
                let half = |t: f64| {
                    let rho = (cc - 2.0 * t * b + t * t * sg.aa).max(0.0).sqrt();
                    let y = (rho - rp).max(0.0);
                    (rc * rc - y * y).max(0.0).sqrt()
                };
                let lo = |t: f64| c - wa + t * sg.da - half(t);
                Some(lo(golden_min(lo, t0, t1)))
            }
        }
    }
}

/// Minimiser of a convex function on `[a, b]` by golden-section search.
fn golden_min(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    const G: f64 = 0.618_033_988_749_894_8;
    let mut x1 = b - G * (b - a);
    let mut x2 = a + G * (b - a);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..BISECT_STEPS + 20 {
        if b - a < 1e-13 {
            break;
        }
        if f1 <= f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - G * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + G * (b - a);
            f2 = f(x2);
        }
    }
    // The ends matter for monotone functions.
    let m = 0.5 * (a + b);
    [a, m, b].into_iter().fold(m, |best, t| if f(t) < f(best) { t } else { best })
}

/// Swept cylinder: exists `t` with `lo <= (q - P(t)) . a <= hi` and radial distance `<= r`.
#[inline]
fn cyl(s: &Seg, q: &Point3, lo: f64, hi: f64, r: f64) -> bool {
    if r < 0.0 || lo > hi {
        return false;
    }
    let (wa, wp) = s.split(q);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    if s.da == 0.0 {
        if wa < lo || wa > hi {
            return false;
        }
    } else {
        // h(t) = wa - t da in [lo, hi].
        let x = (wa - hi) / s.da;
        let y = (wa - lo) / s.da;
        t0 = t0.max(x.min(y));
        t1 = t1.min(x.max(y));
        if t0 > t1 {
            return false;
        }
    }
    match s.radial(&wp, r) {
        Some((a, b)) => a.max(t0) <= b.min(t1),
        None => false,
    }
}

/// Swept rounded disc: `min_t dist(q - P(t), disc)^2 <= rc^2` (convex in `t`).
fn rdisc(s: &Seg, q: &Point3, c: f64, rp: f64, rc: f64) -> bool {
    if rc < 0.0 {
        return false;
    }
    let (wa, wp) = s.split(q);
    let r2 = rc * rc;
    let cc = wp.norm_squared();
    let b = wp.dot(&s.dp);
    // phi(t) and phi'(t) with rho^2 = cc - 2 t b + t^2 aa, h = wa - t da.
    let eval = |t: f64| {
        let rho = (cc - 2.0 * t * b + t * t * s.aa).max(0.0).sqrt();
        let y = (rho - rp).max(0.0);
        let h = wa - t * s.da - c;
        let drho = if rho > 0.0 { (t * s.aa - b) / rho } else { 0.0 };
        (y * y + h * h, 2.0 * y * drho - 2.0 * h * s.da)
    };
    let (f0, g0) = eval(0.0);
    if f0 <= r2 {
        return true;
    }
    let (f1, g1) = eval(1.0);
    if f1 <= r2 {
        return true;
    }
    if g0 >= 0.0 || g1 <= 0.0 {
        return false;
    }
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..BISECT_STEPS {
        let m = 0.5 * (lo + hi);
        let (f, g) = eval(m);
        if f <= r2 {
            return true;
        }
        if g > 0.0 {
            hi = m;
        } else {
            lo = m;
        }
        if hi - lo < 1e-15 {
            break;
        }
    }
    eval(0.5 * (lo + hi)).0 <= r2
}

/// Swept rectangle bead: flat ends, lateral half width `hw` (horizontal in the plane
/// perpendicular to `a`), heights `[lo, hi]` below/above the tip. Degenerates to the
/// swept cylinder when the move has no sideways component.
fn slab(s: &Seg, q: &Point3, h0: f64, h1: f64, hw: f64, delta: f64) -> bool {
    if s.aa < 1e-24 {
        return cyl(s, q, h0 - delta, h1 + delta, hw + delta);
    }
    let len = s.aa.sqrt();
    // A ball of radius delta moved along the path changes t by delta / len, hence the
    // height by delta |da| / len: widen the height band by that too.
    let dh = delta * (1.0 + s.da.abs() / len);
    let (lo, hi, w) = (h0 - dh, h1 + dh, hw + delta);
    if w < 0.0 || lo > hi {
        return false;
    }
    let (wa, wp) = s.split(q);
    let along = wp.dot(&s.dp) / len;
    if along < -delta || along > len + delta {
        return false;
    }
    let lateral2 = wp.norm_squared() - along * along;
    if lateral2 > w * w {
        return false;
    }
    let t = (along / len).clamp(0.0, 1.0);
    let h = wa - t * s.da;
    h >= lo && h <= hi
}
