//! The segments of a `G70`-`G72` lathe profile and their geometry, as LinuxCNC's
//! `interp_g7x.cc` has them: points are complex numbers `Z + iX` (program units), a
//! profile runs towards decreasing Z and X once normalised, and each segment knows how
//! to offset itself, meet its neighbour, and be cut: dived into (going down in X),
//! climbed out of, or crossed at a given X.

use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub, SubAssign};

/// LinuxCNC's `tolerance` of the lathe cycles (program units).
pub(super) const TOL: f64 = 1e-6;

/// A point or vector `Z + iX` (`re` is Z, `im` is X), with `std::complex`'s arithmetic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct C {
    pub(super) re: f64,
    pub(super) im: f64,
}

/// `Z + iX`.
pub(super) const fn c(re: f64, im: f64) -> C {
    C { re, im }
}

/// The imaginary unit.
pub(super) const I: C = c(0.0, 1.0);

impl C {
    pub(super) fn conj(self) -> C {
        c(self.re, -self.im)
    }
    /// `std::abs`: the modulus.
    pub(super) fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    /// `std::norm`: the squared modulus.
    pub(super) fn norm(self) -> f64 {
        self.re * self.re + self.im * self.im
    }
}

impl Add for C {
    type Output = C;
    fn add(self, o: C) -> C {
        c(self.re + o.re, self.im + o.im)
    }
}
impl Sub for C {
    type Output = C;
    fn sub(self, o: C) -> C {
        c(self.re - o.re, self.im - o.im)
    }
}
impl Mul for C {
    type Output = C;
    fn mul(self, o: C) -> C {
        c(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
}
impl Mul<f64> for C {
    type Output = C;
    fn mul(self, k: f64) -> C {
        c(self.re * k, self.im * k)
    }
}
impl Mul<C> for f64 {
    type Output = C;
    fn mul(self, z: C) -> C {
        z * self
    }
}
impl Div<f64> for C {
    type Output = C;
    fn div(self, k: f64) -> C {
        c(self.re / k, self.im / k)
    }
}
impl Div for C {
    type Output = C;
    fn div(self, o: C) -> C {
        let d = o.norm();
        c((self.re * o.re + self.im * o.im) / d, (self.im * o.re - self.re * o.im) / d)
    }
}
impl Neg for C {
    type Output = C;
    fn neg(self) -> C {
        c(-self.re, -self.im)
    }
}
impl AddAssign for C {
    fn add_assign(&mut self, o: C) {
        *self = *self + o;
    }
}
impl SubAssign for C {
    fn sub_assign(&mut self, o: C) {
        *self = *self - o;
    }
}

/// One move of a cycle, in the profile's (possibly flipped) frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Out {
    Rapid(C),
    Feed(C),
    Arc { ccw: bool, center: C, end: C },
}

impl Out {
    /// Whether every coordinate of the move is a finite number.
    pub(super) fn is_finite(&self) -> bool {
        let ok = |p: &C| p.re.is_finite() && p.im.is_finite();
        match self {
            Out::Rapid(p) | Out::Feed(p) => ok(p),
            Out::Arc { center, end, .. } => ok(center) && ok(end),
        }
    }
}

/// Where the moves go: a list, and the geometry's errors.
pub(super) type Moves = Vec<Out>;
/// A geometry error: LinuxCNC's `G7X error: ...` text after the prefix.
pub(super) type GeomResult<T> = Result<T, String>;

/// What a segment is: LinuxCNC's `straight_segment`, `round_segment`, and the corner
/// finishes `chamfer_segment` (`C` word) and `fillet_segment` (`A` word).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    Straight,
    Round,
    Chamfer,
    Fillet,
}

/// Up to two crossings of a segment with a line `X = x` (their Z), in LinuxCNC's order.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Hits {
    v: [f64; 2],
    n: usize,
}

impl Hits {
    fn push(&mut self, z: f64) {
        if self.n < 2 {
            self.v[self.n] = z;
            self.n += 1;
        }
    }
    pub(super) fn is_empty(&self) -> bool {
        self.n == 0
    }
    pub(super) fn front(&self) -> f64 {
        self.v[0]
    }
    pub(super) fn back(&self) -> f64 {
        self.v[self.n.max(1) - 1]
    }
}

/// A profile segment.
#[derive(Debug, Clone, Copy)]
pub(super) struct Seg {
    pub(super) kind: Kind,
    pub(super) s: C,
    pub(super) e: C,
    /// Arcs: the centre and the direction.
    pub(super) c: C,
    pub(super) ccw: bool,
    /// Corner finishes: the chamfer's or fillet's size, until applied.
    pub(super) finish: f64,
}

impl Seg {
    pub(super) fn straight(s: C, e: C) -> Seg {
        Seg { kind: Kind::Straight, s, e, c: c(0.0, 0.0), ccw: false, finish: 0.0 }
    }
    pub(super) fn round(ccw: bool, s: C, center: C, e: C) -> Seg {
        Seg { kind: Kind::Round, s, e, c: center, ccw, finish: 0.0 }
    }
    /// A corner finish of size `d` at corner `at`: a chamfer or a fillet.
    pub(super) fn finish(fillet: bool, d: f64, at: C) -> Seg {
        let kind = if fillet { Kind::Fillet } else { Kind::Chamfer };
        Seg { kind, s: at, e: at, c: at, ccw: false, finish: d }
    }
    pub(super) fn is_round(&self) -> bool {
        matches!(self.kind, Kind::Round | Kind::Fillet)
    }

    pub(super) fn radius(&self) -> f64 {
        if self.is_round() {
            (self.s - self.e).abs().min((self.s - self.c).abs())
        } else {
            (self.s - self.e).abs()
        }
    }

    /// Whether the segment never goes up in Z (and an arc stays on one side of its centre).
    pub(super) fn monotonic(&self) -> bool {
        if !self.is_round() {
            return (self.e - self.s).re <= 1e-3;
        }
        if self.finish != 0.0 {
            return true;
        }
        let entry = (self.s - self.c).im;
        let exit = (self.e - self.c).im;
        let dz = (self.e - self.s).re;
        if self.ccw {
            entry >= -1e-3 && exit >= -1e-3 && dz <= -1e-3
        } else {
            entry <= 1e-3 && exit <= 1e-3 && dz <= -1e-3
        }
    }

    pub(super) fn offset(&mut self, distance: f64) {
        if self.is_round() {
            let r = (self.s - self.c).abs();
            let factor = (r + if self.ccw { distance } else { -distance }) / r;
            self.s = (self.s - self.c) * factor + self.c;
            self.e = (self.e - self.c) * factor + self.c;
        } else {
            let d = I * distance * (self.s - self.e) / (self.s - self.e).abs();
            self.s += d;
            self.e += d;
        }
    }

    pub(super) fn flip_imag(&mut self) {
        self.s = self.s.conj();
        self.e = self.e.conj();
        if self.is_round() {
            self.ccw = !self.ccw;
            self.c = self.c.conj();
        }
    }

    pub(super) fn flip_real(&mut self) {
        self.s = -self.s.conj();
        self.e = -self.e.conj();
        if self.is_round() {
            self.ccw = !self.ccw;
            self.c = -self.c.conj();
        }
    }

    pub(super) fn rotate(&mut self) {
        self.s = -self.s * I;
        self.e = -self.e * I;
        if self.is_round() {
            self.c = -self.c * I;
        }
    }

    pub(super) fn shift(&mut self, d: C) {
        self.s += d;
        self.e += d;
        if self.is_round() {
            self.c += d;
        }
    }

    pub(super) fn draw(&self, out: &mut Moves) {
        if self.is_round() {
            out.push(Out::Arc { ccw: self.ccw, center: self.c, end: self.e });
        } else {
            out.push(Out::Feed(self.e));
        }
    }

    /// An arc's point `p` lies within its sweep.
    fn on_segment(&self, p: C) -> bool {
        let cross = |a: C, b: C| (a.conj() * b).im;
        let (a, b) = (cross(self.s - self.c, p - self.c), cross(self.e - self.c, p - self.c));
        if self.ccw { a >= -TOL && b <= TOL } else { a <= TOL && b >= -TOL }
    }

    /// The Z of the segment's crossings with `X = x`.
    pub(super) fn intersection_z(&self, x: f64) -> Hits {
        let mut is = Hits::default();
        if self.is_round() {
            let r = (self.s - self.c).abs();
            let mut s = -(x - r - self.c.im) * (x + r - self.c.im);
            if s < -TOL {
                return is;
            }
            if s < 0.0 {
                s = 0.0;
            }
            let s = s.sqrt();
            for z in [self.c.re + s, self.c.re - s] {
                if self.on_segment(c(z, x)) {
                    is.push(z);
                }
            }
            return is;
        }
        let (s, e) = (self.s, self.e);
        if s.im.min(e.im) > x + TOL || s.im.max(e.im) < x - TOL {
            return is;
        }
        if (s - e).im.abs() < TOL {
            is.push(s.re);
            is.push(e.re);
        } else {
            is.push((x - s.im) / (e.im - s.im) * (e.re - s.re) + s.re);
        }
        is
    }

    /// Follows the segment up from `loc` (its start); `true` when it does not climb.
    pub(super) fn climb(&self, loc: &mut C, out: &mut Moves) -> GeomResult<bool> {
        if !self.is_round() {
            if self.e.im + TOL < self.s.im {
                return Ok(true);
            }
            if (*loc - self.s).abs() > TOL {
                return Err("How did we get here?".into());
            }
            out.push(Out::Feed(self.e));
            *loc = self.e;
            return Ok(false);
        }
        if !self.ccw {
            if loc.re > self.c.re {
                return Ok(true);
            }
            if (*loc - self.e).abs() > 1e-3 {
                out.push(Out::Arc { ccw: false, center: self.c, end: self.e });
            }
            *loc = self.e;
            return Ok(false);
        }
        if loc.re < self.c.re {
            return Ok(true);
        }
        let ep = self.top();
        if (*loc - ep).abs() > 1e-3 {
            out.push(Out::Arc { ccw: true, center: self.c, end: ep });
        }
        *loc = ep;
        Ok(true)
    }

    /// A counter-clockwise arc's end, or its top when it goes over it.
    fn top(&self) -> C {
        if self.e.re < self.c.re { c(self.c.re, self.c.im + (self.s - self.c).abs()) } else { self.e }
    }

    /// After the roughing passes of `G7x.1`: up along the segment from the level of `loc`.
    pub(super) fn climb_only(&self, loc: &mut C, out: &mut Moves) {
        if !self.is_round() {
            if self.e.im < self.s.im {
                return;
            }
            let is = self.intersection_z(loc.im);
            if is.is_empty() {
                return;
            }
            loc.re = is.front();
            out.push(Out::Feed(*loc));
            out.push(Out::Feed(self.e));
            *loc = self.e;
            return;
        }
        let is = self.intersection_z(loc.im);
        if is.is_empty() {
            return;
        }
        if !self.ccw {
            if is.back() > self.c.re {
                return;
            }
            loc.re = is.back();
            out.push(Out::Feed(*loc));
            if (*loc - self.e).abs() > 1e-3 {
                out.push(Out::Arc { ccw: false, center: self.c, end: self.e });
            }
            *loc = self.e;
            return;
        }
        if is.front() < self.c.re {
            return;
        }
        loc.re = is.front();
        out.push(Out::Feed(*loc));
        let ep = self.top();
        if (*loc - ep).abs() > 1e-3 {
            out.push(Out::Arc { ccw: true, center: self.c, end: ep });
        }
        *loc = ep;
    }

    /// Follows the segment down from `loc` to the level `x` (or its end); `true` when it
    /// does not go down. A straight dive is a rapid when `fast`.
    pub(super) fn dive(&self, loc: &mut C, x: f64, out: &mut Moves, fast: bool) -> GeomResult<bool> {
        if self.is_round() {
            return Ok(self.dive_round(loc, x, out));
        }
        if self.s.im <= self.e.im + TOL {
            return Ok(true);
        }
        let mv = |p: C| if fast { Out::Rapid(p) } else { Out::Feed(p) };
        if x < self.e.im {
            out.push(mv(self.e));
            *loc = self.e;
            return Ok(false);
        }
        let is = self.intersection_z(x);
        if is.is_empty() {
            return Err("x too large in straight dive".into());
        }
        let ep = c(is.front(), x);
        out.push(mv(ep));
        *loc = ep;
        Ok(false)
    }

    fn dive_round(&self, loc: &mut C, x: f64, out: &mut Moves) -> bool {
        if (*loc - self.e).abs() < TOL || (*loc - self.e).re <= TOL {
            *loc = self.e;
            return false;
        }
        let mut is = self.intersection_z(x);
        if is.is_empty() {
            is = self.intersection_z(x - TOL);
        }
        let (ccw, center) = (self.ccw, self.c);
        if ccw {
            if loc.re - TOL > center.re {
                return true;
            }
            let end = if is.is_empty() || is.back() > center.re { self.e } else { c(is.back(), x) };
            out.push(Out::Arc { ccw, center, end });
            *loc = end;
            return false;
        }
        if loc.re <= center.re {
            return true;
        }
        if is.is_empty() {
            out.push(Out::Arc { ccw, center, end: self.e });
            *loc = self.e;
        } else if is.front() >= center.re {
            let end = c(is.front(), x);
            out.push(Out::Arc { ccw, center, end });
            *loc = end;
        }
        false
    }
}

/// Corrects the end of `p` and the start of `n` to where they meet (LinuxCNC
/// `n->intersect_end(p)`).
pub(super) fn intersect(p: &mut Seg, n: &mut Seg) -> GeomResult<()> {
    match (p.is_round(), n.is_round()) {
        (false, false) => {
            let rot = (n.s - n.e).conj() / (n.s - n.e).abs();
            let ps = (p.s - n.e) * rot;
            let pe = (p.e - n.e) * rot;
            if (ps - pe).im == 0.0 {
                return Err("Cannot intersect parallel lines".into());
            }
            let f = ps.im / (ps - pe).im;
            let is = (ps + (pe - ps) * f) / rot + n.e;
            n.s = is;
            p.e = is;
        }
        (true, false) => {
            // An arc followed by a straight.
            if (n.s - p.e).abs() < TOL {
                return Ok(());
            }
            let is = line_circle(n.s, n.e, p.c, p.e, n.s);
            n.s = is;
            p.e = is;
        }
        (false, true) => {
            // A straight followed by an arc.
            if (n.s - p.e).abs() < TOL {
                return Ok(());
            }
            let is = line_circle(p.s, p.e, n.c, n.e, n.s);
            n.s = is;
            p.e = is;
        }
        (true, true) => {
            let a = (n.s - n.c).abs();
            let b = (p.s - p.c).abs();
            let d = (n.c - p.c).abs();
            let cos_b = (d * d + a * a - b * b) / 2.0 / a / d;
            let cos_b2 = (cos_b * cos_b).min(1.0);
            let rot = c(cos_b, (1.0 - cos_b2).sqrt());
            let is = rot * (p.c - n.c) / d * a + n.c;
            p.e = is;
            n.s = is;
        }
    }
    Ok(())
}

/// Where the circle about `center` through `on` crosses the line from `ls` to `le`:
/// the crossing nearest `near` (LinuxCNC's frame: `le` at the origin, the line along
/// the real axis).
fn line_circle(ls: C, le: C, center: C, on: C, near: C) -> C {
    let rot = (ls - le).conj() / (ls - le).abs();
    let pe = (on - le) * rot;
    let pc = (center - le) * rot;
    let b = (pc - pe).norm() - pc.im * pc.im;
    let b = if b < 0.0 { 0.0 } else { b.sqrt() };
    let s1 = c(pc.re + b, 0.0) / rot + le;
    let s2 = c(pc.re - b, 0.0) / rot + le;
    if (near - s1).abs() < (near - s2).abs() { s1 } else { s2 }
}
