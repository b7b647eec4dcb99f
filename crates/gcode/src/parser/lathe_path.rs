//! A `G70`-`G72` profile as a whole (LinuxCNC's `g7x` class): normalised so that it runs
//! towards decreasing Z and X (flips and a quarter turn, undone on the way out), its
//! corner finishes applied, offset by a distance, and cut: `G70` follows it, `G71`/`G72`
//! rough the stock between it and the cycle's start in passes, pockets included.

use super::lathe_geom::{C, GeomResult, Moves, Out, Seg, TOL, c, intersect};

/// Most moves one cycle may make (a profile that the roughing never finishes).
const MAX_MOVES: usize = 1_000_000;
/// The error of a cycle that would not end (LinuxCNC's loops for ever).
const NEVER_ENDS: &str = "the roughing passes never end";
/// The error of a cycle of more than [`MAX_MOVES`] moves.
const TOO_MANY: &str = "more than 1000000 moves";
/// Most work (segments offset, summed over the steps) of the offsets of one cycle: each
/// step is at most half the shortest segment.
const MAX_OFFSET_WORK: usize = 5_000_000;

/// The profile: its first segment runs from the cycle's start point to the profile's.
#[derive(Debug, Clone)]
pub(super) struct Path {
    pub(super) segs: Vec<Seg>,
    delta: f64,
    escape: C,
    /// Bit 0: Z flipped, bit 1: X flipped, bit 2: turned a quarter.
    flip: u8,
    pocket_starts: Vec<C>,
}

/// The roughing words of `G71`/`G72`.
pub(super) struct Rough {
    /// 0: pockets too; 1 (`.1`): no pockets; 2 (`.2`): only the pockets.
    pub(super) cycle: u8,
    pub(super) x: f64,
    pub(super) z: f64,
    /// `U`, `W`: the profile's displacement.
    pub(super) u: f64,
    pub(super) w: f64,
    /// `D`: stock left on the profile; `I`: depth of cut; `R`: retract.
    pub(super) d: f64,
    pub(super) i: f64,
    pub(super) r: f64,
}

impl Path {
    pub(super) fn new(segs: Vec<Seg>) -> Path {
        Path { segs, delta: 0.5, escape: c(0.3, 0.3), flip: 0, pocket_starts: Vec::new() }
    }

    /// A copy, as LinuxCNC's copy constructor makes it (no pocket starts).
    fn copy(&self) -> Path {
        Path { pocket_starts: Vec::new(), ..self.clone() }
    }

    fn front(&self) -> &Seg {
        &self.segs[0]
    }
    fn back(&self) -> &Seg {
        &self.segs[self.segs.len() - 1]
    }

    /// Turns the profile a quarter.
    fn rotate(&mut self) {
        self.segs.iter_mut().for_each(Seg::rotate);
        self.flip ^= 4;
    }

    /// Flips the profile so that Z and X decrease from its start to its end.
    fn swap(&mut self) {
        let d = self.front().e - self.back().e;
        if d.im > 0.0 {
            self.segs.iter_mut().for_each(Seg::flip_imag);
            self.flip ^= 2;
        }
        if d.re < 0.0 {
            self.segs.iter_mut().for_each(Seg::flip_real);
            self.flip ^= 1;
        }
    }

    /// A move of the normalised frame back in the program's.
    pub(super) fn unflip(&self, m: Out) -> Out {
        let f = |p: C| match self.flip {
            0 => p,
            1 => -p.conj(),
            2 => p.conj(),
            3 => -p,
            4 => super::lathe_geom::I * p,
            5 => (super::lathe_geom::I * p).conj(),
            6 => -(super::lathe_geom::I * p).conj(),
            _ => -(super::lathe_geom::I * p),
        };
        let mirrored = matches!(self.flip, 1 | 2 | 5 | 6);
        match m {
            Out::Rapid(p) => Out::Rapid(f(p)),
            Out::Feed(p) => Out::Feed(f(p)),
            Out::Arc { ccw, center, end } => {
                Out::Arc { ccw: ccw != mirrored, center: f(center), end: f(end) }
            }
        }
    }

    fn monotonic(&mut self) -> GeomResult<()> {
        let f = self.segs[0];
        if (f.e - f.s).re > 0.0 {
            self.segs[0].s.re = f.e.re;
        }
        if self.segs.iter().all(Seg::monotonic) { Ok(()) } else { Err("Not monotonic".into()) }
    }

    /// Applies the chamfers and fillets to their corners.
    fn do_finish(&mut self) -> GeomResult<()> {
        let n = self.segs.len();
        for h in 1..n.saturating_sub(1) {
            if self.segs[h].finish != 0.0
                && matches!(
                    self.segs[h].kind,
                    super::lathe_geom::Kind::Chamfer | super::lathe_geom::Kind::Fillet
                )
            {
                self.corner_finish(h)?;
            }
        }
        self.segs.retain(|s| s.radius() >= 1e-3);
        if self.segs.is_empty() {
            return Err("Not monotonic".into());
        }
        Ok(())
    }

    /// The chamfer or fillet `h` between its neighbours (LinuxCNC `corner_finish`).
    fn corner_finish(&mut self, h: usize) -> GeomResult<()> {
        let (prev, next) = (self.segs[h - 1], self.segs[h + 1]);
        let mut finish = self.segs[h].finish;
        let offset = |finish: f64| {
            let (mut p, mut n) = (prev, next);
            p.offset(finish);
            n.offset(finish);
            (p, n)
        };
        let (mut p, mut n) = offset(finish);
        if (p.e - n.s).re > 1e-2 {
            finish = -finish;
            (p, n) = offset(finish);
        }
        if (p.e - n.s).re > 1e-2 {
            return Err(format!("Corner finish failed at ({},{})", prev.e.re, prev.e.im));
        }
        intersect(&mut p, &mut n)?;
        let center = (p.e + n.s) / 2.0;
        p.offset(-finish);
        n.offset(-finish);
        let seg = &mut self.segs[h];
        seg.s = p.e;
        seg.e = n.s;
        if seg.kind == super::lathe_geom::Kind::Fillet {
            seg.c = center;
            seg.ccw = (seg.s - center).im > 0.0 || (seg.e - center).im > 0.0;
            seg.finish = 0.0;
        } else {
            seg.finish = finish;
        }
        self.segs[h - 1].e = p.e;
        self.segs[h + 1].s = n.s;
        Ok(())
    }

    /// Offsets the profile (all but its first segment, the approach) by `distance`
    /// towards the stock, in steps of at most half the shortest segment.
    fn add_distance(&mut self, distance: f64, work: &mut usize) -> GeomResult<()> {
        if self.segs.len() < 2 || !distance.is_finite() {
            return Err("the profile cannot be offset".into());
        }
        let v1 = self.front().e - self.front().s;
        let v2 = self.back().s - self.front().s;
        let distance = if (v1 / v2).im < 0.0 { -distance } else { distance };
        let mut first = self.segs.remove(0);
        let mut current = 0.0;
        while current != distance {
            *work += self.segs.len() + 1;
            if *work > MAX_OFFSET_WORK || self.segs.is_empty() {
                return Err("the profile cannot be offset".into());
            }
            let mut step = self.segs.iter().map(|s| s.radius() / 2.0).fold(1e9, f64::min);
            step = step.min((distance - current).abs());
            if !(step > 0.0 && step.is_finite()) {
                return Err("the profile cannot be offset".into());
            }
            if distance < 0.0 {
                step = -step;
            }
            self.offset_step(step, distance);
            self.settle_corners()?;
            current += step;
        }
        for k in 0..self.segs.len().saturating_sub(1) {
            let mid = (self.segs[k].e + self.segs[k + 1].s) / 2.0;
            self.segs[k].e = mid;
            self.segs[k + 1].s = mid;
        }
        let Some(s) = self.segs.first() else { return Err("the profile cannot be offset".into()) };
        first.e = s.s;
        self.segs.insert(0, first);
        Ok(())
    }

    /// One offset step: every segment moved by `step`, the vanished ones dropped, arcs
    /// (turning as `distance`'s sign says) inserted where neighbours parted.
    fn offset_step(&mut self, step: f64, distance: f64) {
        let mut k = 0;
        while k < self.segs.len() {
            self.segs[k].offset(step);
            if self.segs[k].radius() < 1e-3 {
                self.segs.remove(k);
            } else {
                k += 1;
            }
        }
        let mut k = 0;
        while k + 1 < self.segs.len() {
            let (p, n) = (self.segs[k], self.segs[k + 1]);
            if (p.e - n.s).re > 1e-2 {
                let (mut s, mut e) = (p, n);
                s.offset(-step);
                e.offset(-step);
                let center = (s.e + e.s) / 2.0;
                self.segs.insert(k + 1, Seg::round(distance > 0.0, p.e, center, n.s));
                k += 1;
            }
            k += 1;
        }
    }

    /// Drops what the step turned back and meets each segment with the next.
    fn settle_corners(&mut self) -> GeomResult<()> {
        let mut k = 0;
        while k + 1 < self.segs.len() {
            if !self.segs[k].monotonic() {
                if k > 0 && self.segs[k].radius() >= self.segs[k - 1].radius() {
                    self.segs.remove(k - 1);
                } else {
                    self.segs.remove(k);
                }
                k = 0;
                if self.segs.len() < 2 {
                    break;
                }
            }
            if self.segs[k].radius() < 1e-3 {
                self.segs.remove(k);
                k = 1;
                continue;
            }
            let (a, b) = self.segs.split_at_mut(k + 1);
            intersect(&mut a[k], &mut b[0])?;
            k += 1;
        }
        Ok(())
    }

    /// `G70`: `p` passes along the profile, at distances from `d` down to `e`, each from
    /// a rapid to the start point (`x`, `z`) and one to the offset profile's start.
    pub(super) fn g70(mut self, x: f64, z: f64, d: f64, e: f64, p: f64, out: &mut Moves) -> GeomResult<()> {
        self.segs[0].s = c(z, x);
        let mut probe = self.copy();
        probe.segs.remove(0);
        if probe.segs.is_empty() {
            return Err("Not monotonic".into());
        }
        probe.swap();
        if !probe.segs.iter().all(Seg::monotonic) {
            probe.rotate();
            probe.swap();
        }
        probe.monotonic()?;
        if probe.flip & 4 != 0 {
            self.rotate();
        }
        self.swap();
        self.do_finish()?;
        self.monotonic()?;
        let mut raw = Moves::new();
        let passes = p as i64;
        let mut r = Ok(());
        let mut work = 0;
        if passes > (MAX_MOVES / 2) as i64 {
            return Err(TOO_MANY.into());
        }
        for pass in (1..=passes).rev() {
            let distance = (pass - 1) as f64 * (d - e) / p + e;
            let mut path = self.copy();
            r = path.add_distance(distance, &mut work);
            if r.is_ok() && raw.len() > MAX_MOVES {
                r = Err(TOO_MANY.into());
            }
            if r.is_err() {
                break;
            }
            raw.push(Out::Rapid(path.front().s));
            raw.push(Out::Rapid(path.front().e));
            for s in &path.segs[1..] {
                s.draw(&mut raw);
            }
        }
        if r.as_ref().is_err_and(|e| e == TOO_MANY) {
            // None of its moves: the cycle is refused whole.
            raw.clear();
        }
        out.extend(raw.into_iter().map(|m| self.unflip(m)));
        r
    }

    /// `G71` (`rotate` false) and `G72` (true): roughing passes.
    pub(super) fn rough(mut self, w: &Rough, rotate: bool, out: &mut Moves) -> GeomResult<()> {
        self.segs[0].s = c(w.z, w.x);
        if rotate {
            self.rotate();
        }
        self.swap();
        self.do_finish()?;
        self.monotonic()?;
        self.add_distance(w.d, &mut 0)?;
        let shift = c(w.w, w.u);
        self.segs.iter_mut().for_each(|s| s.shift(shift));
        self.delta = w.i.max(2.0 * TOL);
        self.escape = c(w.r, w.r);
        let mut raw = Moves::new();
        let start = self.front().s;
        raw.push(Out::Rapid(start));
        if self.back().e.im < start.im {
            let from = self.back().e;
            self.segs.push(Seg::straight(from, c(from.re, start.im)));
        }
        self.pocket_starts.push(start);
        let r = self.pocket(w.cycle, start, &mut raw);
        if r.as_ref().is_err_and(|e| e == NEVER_ENDS || e == TOO_MANY) {
            // None of its moves: the cycle is refused whole.
            raw.clear();
        }
        out.extend(raw.into_iter().map(|m| self.unflip(m)));
        r
    }

    /// LinuxCNC `pocket`: passes at X levels `delta` apart, from segment `p` on.
    fn pocket(&mut self, mut cycle: u8, mut loc: C, out: &mut Moves) -> GeomResult<()> {
        let mut p = 0;
        let mut rounds = 0usize;
        'pocket: loop {
            let mut x = self.pocket_starts[self.pocket_starts.len() - 1].im;
            if cycle == 2 {
                while p < self.segs.len() {
                    if self.segs[p].dive(&mut loc, -1e9, out, p == 0)? {
                        break;
                    }
                    p += 1;
                }
                cycle = 3;
            }
            let mut last = None;
            while p < self.segs.len() {
                if last == Some((p, loc, x)) {
                    // As the round before: LinuxCNC would loop here for ever.
                    return Err(NEVER_ENDS.into());
                }
                last = Some((p, loc, x));
                rounds += 1;
                if out.len() > MAX_MOVES {
                    return Err(TOO_MANY.into());
                }
                if rounds > 10 * MAX_MOVES {
                    return Err(NEVER_ENDS.into());
                }
                x = self.level_below(x, loc.im)?;
                if self.segs[p].dive(&mut loc, x, out, p == 0)? {
                    if cycle == 1 {
                        for s in &self.segs[p..] {
                            s.climb_only(&mut loc, out);
                        }
                        return Ok(());
                    }
                    while p < self.segs.len() {
                        if self.segs[p].climb(&mut loc, out)? {
                            if cycle == 3 {
                                let top = self.pocket_starts[self.pocket_starts.len() - 1];
                                if loc.im > top.im && self.pocket_starts.len() > 1 {
                                    self.pocket_starts.pop();
                                }
                                if self.pocket_starts.len() == 1 {
                                    self.pocket_starts.push(loc);
                                }
                            }
                            continue 'pocket;
                        }
                        p += 1;
                    }
                    return Ok(());
                }
                if (loc.im - x).abs() > TOL {
                    p += 1;
                    continue;
                }
                if let Some(next) = self.cut_level(p, &mut loc, &mut x, out) {
                    p = next;
                }
            }
            return Ok(());
        }
    }

    /// The first level `delta` apart below `x` that is not above `at` (LinuxCNC steps
    /// down to it; so do we, within a bound).
    fn level_below(&self, mut x: f64, at: f64) -> GeomResult<f64> {
        let mut n = 0;
        while x - TOL > at {
            x -= self.delta;
            n += 1;
            if n > MAX_MOVES {
                return Err(NEVER_ENDS.into());
            }
        }
        Ok(x)
    }

    /// One roughing pass at the level of `loc` from the diving segment `p`: a feed to
    /// where the level meets the profile again, the retract, back, and down to `loc`.
    /// Returns the new diving segment when the level starts on another one.
    fn cut_level(&self, p: usize, loc: &mut C, x: &mut f64, out: &mut Moves) -> Option<usize> {
        for ip in p..self.segs.len() {
            let is = self.segs[ip].intersection_z(loc.im);
            if is.is_empty() {
                continue;
            }
            let dest_z = if ip != p { is.front() } else { is.back() };
            let distance = (dest_z - loc.re).abs();
            if dest_z - TOL > loc.re {
                continue;
            }
            if distance < TOL {
                if p == ip {
                    continue;
                } else if (*loc - self.segs[ip].s).abs() < TOL {
                    return Some(ip);
                }
                *x -= self.delta;
                return None;
            }
            let mut dest = c(dest_z, loc.im);
            out.push(Out::Feed(dest));
            let scale = (distance / 2.0 / self.escape.re).min(1.0);
            dest += self.escape * scale;
            out.push(Out::Rapid(dest));
            out.push(Out::Rapid(*loc - (self.escape * scale).conj()));
            out.push(if p == 0 { Out::Rapid(*loc) } else { Out::Feed(*loc) });
            *x -= self.delta;
            return None;
        }
        None
    }
}
