//! Canned drilling cycles (`G73`, `G81`, `G82`, `G83`), expanded into moves.

use nalgebra::Point3;

use super::interp::{AXES, Fail, Interp, MAX_CYCLE_MOVES, Mode, PECK_RAPID_DELTA_MM, Res, fmt_code};
use crate::error::GcodeErrorKind;
use crate::motion::{Motion, MotionSink};

/// The words of a cycle block, or where absent the values kept from the cycle's
/// previous block (mm, seconds).
struct CycleWords {
    /// The bottom of the cycle, along the plane's normal axis.
    cc_word: f64,
    /// The R plane.
    r_word: f64,
    /// `G82` dwell.
    p: f64,
    /// `G73`/`G83` peck depth.
    q: f64,
    /// `L`: repeats.
    repeats: u32,
}

impl Interp<'_> {
    /// Runs one block of canned cycle `code` (× 10) as LinuxCNC's `CYCLE_MACRO` does;
    /// `prev` is the motion mode before the block (a new cycle needs all its words).
    pub(super) fn cycle<S: MotionSink>(
        &mut self,
        code: u16,
        prev: Option<Mode>,
        sink: &mut S,
    ) -> Res<(), S::Error> {
        if let Some(l) = [b'a', b'b', b'c'].into_iter().find(|&l| self.block.has(l)) {
            // `rs274`: "Cannot put an a in canned cycle"; lenient: the word is ignored.
            let what = format!("{} word in a canned cycle", l.to_ascii_uppercase() as char);
            self.lenient(self.block.col(l), GcodeErrorKind::ModalConflict(what))?;
        }
        let (ua, ub, uc) = self.plane_axes();
        let s = self.scale();
        let name = format!("G{}", fmt_code(code));
        let entering = prev != Some(Mode::Cycle(code));
        let CycleWords { cc_word, r_word, p, q, repeats } = self.cycle_words(code, entering, uc, &name)?;
        let blk = &self.block;
        let cur = [self.work(0), self.work(1), self.work(2)];
        let mut old_cc = self.cycle_il.unwrap_or(cur[uc]);
        let mut current_cc = cur[uc];
        let (mut aa, mut bb, inc_a, inc_b, r, cc);
        if self.absolute {
            inc_a = 0.0;
            inc_b = 0.0;
            r = r_word;
            cc = cc_word;
            aa = blk.get(AXES[ua]).map_or(cur[ua], |v| v * s);
            bb = blk.get(AXES[ub]).map_or(cur[ub], |v| v * s);
        } else {
            inc_a = blk.get(AXES[ua]).map_or(0.0, |v| v * s);
            inc_b = blk.get(AXES[ub]).map_or(0.0, |v| v * s);
            r = r_word + old_cc;
            cc = r + cc_word;
            aa = cur[ua];
            bb = cur[ub];
        }
        if r < cc {
            return Err(Fail::Line(
                0,
                GcodeErrorKind::CannedCycle("R plane below the bottom of the cycle".into()),
            ));
        }
        // Bound the expansion: hostile input must not turn one line into billions of moves.
        let pecks = if matches!(code, 730 | 830) { ((r - cc) / q).ceil() + 1.0 } else { 1.0 };
        if repeats as f64 * (3.0 * pecks + 4.0) > MAX_CYCLE_MOVES as f64 {
            return Err(Fail::Line(
                0,
                GcodeErrorKind::CannedCycle(format!("expands to more than {MAX_CYCLE_MOVES} moves")),
            ));
        }
        self.need_feed(&name)?;
        self.cycle_il = Some(old_cc);
        let mut pos = cur;
        macro_rules! go {
            ($rapid:expr, $a:expr, $b:expr, $c:expr) => {{
                pos[ua] = $a;
                pos[ub] = $b;
                pos[uc] = $c;
                self.set_work(pos);
                let to = Point3::new(pos[0], pos[1], pos[2]);
                if $rapid {
                    self.emit(sink, &Motion::Rapid { to })?;
                } else {
                    let extrude = if self.e_axis { Some(0.0) } else { None };
                    self.emit(sink, &Motion::Linear { to, feed: self.feed, extrude })?;
                }
            }};
        }
        if old_cc < r {
            go!(true, cur[ua], cur[ub], r);
            old_cc = r;
            current_cc = r;
        }
        let clear = if self.retract_r_plane { r } else { old_cc };
        // LinuxCNC's CYCLE_MACRO: the first positioning happens at the current height,
        // later ones at the clearance height.
        let polar = self.block.polar.filter(|_| (ua, ub) == (0, 1));
        for rep in 0..repeats {
            match polar {
                // LinuxCNC turns a polar point again at each repeat.
                Some((dr, da)) if rep > 0 => {
                    let (r, a) = (aa.hypot(bb) + dr, bb.atan2(aa) + da);
                    (aa, bb) = (r * a.cos(), r * a.sin());
                }
                _ => {
                    aa += inc_a;
                    bb += inc_b;
                }
            }
            if rep == 0 && current_cc > r {
                go!(true, aa, bb, current_cc);
                go!(true, aa, bb, r);
            } else {
                go!(true, aa, bb, clear);
                if clear > r {
                    go!(true, aa, bb, r);
                }
            }
            match code {
                810 => {
                    go!(false, aa, bb, cc);
                    go!(true, aa, bb, clear);
                }
                820 => {
                    go!(false, aa, bb, cc);
                    self.emit(sink, &Motion::Dwell { seconds: p })?;
                    go!(true, aa, bb, clear);
                }
                _ => {
                    let mut depth = r - q;
                    while depth > cc {
                        go!(false, aa, bb, depth);
                        if code == 830 {
                            go!(true, aa, bb, r);
                        }
                        go!(true, aa, bb, depth + PECK_RAPID_DELTA_MM);
                        depth -= q;
                    }
                    go!(false, aa, bb, cc);
                    go!(true, aa, bb, clear);
                }
            }
        }
        pos[ua] = aa;
        pos[ub] = bb;
        pos[uc] = clear;
        self.set_work(pos);
        self.cycle_cc = cc_word;
        self.cycle_r = r_word;
        self.cycle_p = p;
        self.cycle_q = q;
        Ok(())
    }

    /// Reads the cycle words of the block (`uc`: the plane's normal axis; `name`: the
    /// code for messages). `entering`: the cycle starts here, so its words are required.
    fn cycle_words<E>(&self, code: u16, entering: bool, uc: usize, name: &str) -> Res<CycleWords, E> {
        let s = self.scale();
        let blk = &self.block;
        let cc_word = match blk.get(AXES[uc]) {
            Some(z) => z * s,
            None if entering => {
                return Err(Fail::Line(
                    0,
                    GcodeErrorKind::MissingWord {
                        code: name.to_owned(),
                        letter: AXES[uc].to_ascii_uppercase() as char,
                    },
                ));
            }
            None => self.cycle_cc,
        };
        let r_word = match blk.get(b'r') {
            Some(r) => r * s,
            None if entering => {
                return Err(Fail::Line(
                    0,
                    GcodeErrorKind::MissingWord { code: name.to_owned(), letter: 'R' },
                ));
            }
            None => self.cycle_r,
        };
        let p = match (code, blk.get(b'p')) {
            (820, Some(p)) if p >= 0.0 => p,
            (820, Some(_)) => {
                return Err(Fail::Line(blk.col(b'p'), GcodeErrorKind::BadValue("negative dwell".into())));
            }
            (820, None) if entering => {
                return Err(Fail::Line(
                    0,
                    GcodeErrorKind::MissingWord { code: name.to_owned(), letter: 'P' },
                ));
            }
            _ => self.cycle_p,
        };
        let q = match (code, blk.get(b'q')) {
            (730 | 830, Some(q)) => q * s,
            (730 | 830, None) if entering => {
                return Err(Fail::Line(
                    0,
                    GcodeErrorKind::MissingWord { code: name.to_owned(), letter: 'Q' },
                ));
            }
            _ => self.cycle_q,
        };
        if matches!(code, 730 | 830) && q <= 0.0 {
            return Err(Fail::Line(0, GcodeErrorKind::CannedCycle("Q must be positive".into())));
        }
        let repeats = match blk.get(b'l') {
            None => 1,
            Some(l) if l >= 0.0 && l.fract() == 0.0 && l <= 100_000.0 => l as u32,
            Some(l) => return Err(Fail::Line(blk.col(b'l'), GcodeErrorKind::BadValue(format!("L{l}")))),
        };
        Ok(CycleWords { cc_word, r_word, p, q, repeats })
    }
}
