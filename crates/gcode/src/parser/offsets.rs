//! `G10`: coordinate system offsets (`L2`, `L20`) with LinuxCNC's XY rotation (`R`), tool
//! table and firmware-retract forms.

use super::interp::{AXES, Fail, Interp, Res, rotation_of};
use crate::error::GcodeErrorKind;
use crate::motion::{Motion, MotionSink};

impl Interp<'_> {
    /// `G10`: `L2` sets coordinate system `P`'s offsets (and with `R`, its rotation about
    /// Z in degrees); `L20` sets the offsets so that the current point has the given
    /// coordinates in that system (`R` is an error, as in `rs274`); `L1`, `L10`, `L11`
    /// (tool table) change no motion. Without `L`: firmware retract (FDM, lenient).
    pub(super) fn g10<S: MotionSink>(&mut self, col: usize, sink: &mut S) -> Res<(), S::Error> {
        let Some(l) = self.block.get(b'l') else {
            if self.fdm || (!self.strict && !self.block.has(b'p')) {
                // Firmware retract.
                self.e_axis = true;
                let to = self.work_pos();
                return self
                    .emit(sink, &Motion::Linear { to, feed: self.feed, extrude: Some(-self.retract_len) });
            }
            return Err(Fail::Line(col, GcodeErrorKind::MissingWord { code: "G10".into(), letter: 'L' }));
        };
        match l as i64 {
            2 | 20 => {
                let p = self.block.get(b'p').unwrap_or(-1.0);
                if !(0.0..=9.0).contains(&p) || p.fract() != 0.0 {
                    return Err(Fail::Line(
                        col,
                        GcodeErrorKind::BadValue(format!("G10 coordinate system P{p}")),
                    ));
                }
                let idx = if p == 0.0 { self.coord } else { p as usize };
                if idx == self.coord && self.comp.side.is_some() {
                    return Err(super::comp::comp_refused(
                        col,
                        "cannot change the active coordinate system with cutter radius compensation on",
                    ));
                }
                if l as i64 == 2 {
                    self.g10_l2(idx);
                } else {
                    if self.block.has(b'r') {
                        return Err(Fail::Line(
                            self.block.col(b'r'),
                            GcodeErrorKind::BadValue("R not allowed in G10 L20".into()),
                        ));
                    }
                    self.g10_l20(idx);
                }
                if idx == self.coord {
                    self.load_g5x();
                }
                Ok(())
            }
            1 | 10 | 11 => Ok(()),
            _ => Err(Fail::Line(col, GcodeErrorKind::Unsupported(format!("G10 L{l}")))),
        }
    }

    /// `G10 L2`: the given offsets (mm) and rotation (degrees) of system `idx`.
    fn g10_l2(&mut self, idx: usize) {
        let base = 5201 + 20 * idx;
        let s = self.scale();
        for (i, &axis) in AXES.iter().enumerate() {
            if let Some(v) = self.block.get(axis) {
                self.params.numbered[base + i] = v * s;
            }
        }
        if let Some(r) = self.block.get(b'r') {
            self.params.numbered[base + 9] = r;
        }
    }

    /// `G10 L20`: offsets of system `idx` such that the current machine point has the
    /// given coordinates there, under that system's rotation and the `G92` offset:
    /// `offset = machine - rot(work + g92)` for each given axis.
    fn g10_l20(&mut self, idx: usize) {
        let base = 5201 + 20 * idx;
        let s = self.scale();
        let (c, sn) = rotation_of(self.params.numbered[base + 9]);
        let off = [0, 1, 2].map(|i| self.params.numbered[base + i]);
        // The current point in system `idx`, before its new offsets.
        let (px, py) = (self.mpos[0] - off[0], self.mpos[1] - off[1]);
        let mut w = [
            c * px + sn * py - self.g92[0],
            -sn * px + c * py - self.g92[1],
            self.mpos[2] - off[2] - self.g92[2] - self.tlo,
        ];
        for (i, &axis) in AXES.iter().enumerate() {
            if let Some(v) = self.block.get(axis) {
                w[i] = v * s;
            }
        }
        let (qx, qy) = (w[0] + self.g92[0], w[1] + self.g92[1]);
        let new = [
            self.mpos[0] - (c * qx - sn * qy),
            self.mpos[1] - (sn * qx + c * qy),
            self.mpos[2] - w[2] - self.g92[2] - self.tlo,
        ];
        for (i, &axis) in AXES.iter().enumerate() {
            if self.block.has(axis) {
                self.params.numbered[base + i] = new[i];
            }
        }
    }
}
