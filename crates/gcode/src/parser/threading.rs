//! `G76`: LinuxCNC's lathe threading cycle, expanded into its passes (traverses and
//! spindle-synchronised feeds in the XZ plane), move for move as `rs274` makes them.

use nalgebra::Point3;

use super::interp::{Fail, Interp, Res};
use crate::error::GcodeErrorKind;
use crate::motion::{Motion, MotionSink, Plane};

/// Most passes one `G76` may make.
const MAX_PASSES: usize = 100_000;

/// The geometry of one `G76` block (mm, radians), along X (depth) and Z (the drive line).
struct Thread {
    /// Start X: the drive line.
    safe_x: f64,
    y: f64,
    start_z: f64,
    /// Z at the end of the drive line, shifted by the full depth's compound offset.
    target_z: f64,
    /// +1 for inside threads (`I` > 0, boring), -1 for outside ones.
    dir: f64,
    /// The thread's full depth from the drive line: `|I| + |K|`.
    full: f64,
    /// `|I|`: the drive line to the thread peaks.
    peak: f64,
    /// `|K|`: the thread's depth.
    k: f64,
    tan_q: f64,
    /// `E`, signed along Z as the cut goes.
    taper: f64,
    entry_taper: bool,
    exit_taper: bool,
    feed: f64,
}

impl Interp<'_> {
    /// `G76 P Z I J K [R Q H E L]`: threading passes from the current point (the drive
    /// line's start) to `Z`; the first at depth `|I| + J`, the n-th at `|I| + J n^(1/R)`,
    /// then `H` + 1 passes at the full depth `|I| + |K|`, each shifted along Z by the
    /// compound angle `Q`, with tapers of length `E` at the ends `L` names; then a
    /// traverse to the drive line's end.
    pub(super) fn g76<S: MotionSink>(&mut self, col: usize, sink: &mut S) -> Res<(), S::Error> {
        if self.plane != Plane::ZX {
            return Err(Fail::Line(
                col,
                GcodeErrorKind::ModalConflict("G76 only in the XZ plane (G18)".into()),
            ));
        }
        let s = self.scale();
        for l in [b'p', b'i', b'j', b'k'] {
            if !self.block.has(l) {
                let letter = l.to_ascii_uppercase() as char;
                return Err(Fail::Line(col, GcodeErrorKind::MissingWord { code: "G76".into(), letter }));
            }
        }
        let get = |l: u8| self.block.get(l).unwrap_or(0.0);
        let (pitch, i, j, k) = (get(b'p') * s, get(b'i') * s, get(b'j').abs() * s, get(b'k').abs() * s);
        if pitch <= 0.0 || j <= 0.0 || !(pitch.is_finite() && i.is_finite() && j.is_finite() && k.is_finite())
        {
            return Err(Fail::Line(col, GcodeErrorKind::BadValue("G76 needs P > 0 and J > 0".into())));
        }
        let degression = self.block.get(b'r').filter(|r| *r >= 1.0).unwrap_or(1.0);
        let spring = self.block.get(b'h').map_or(0.0, |h| h.max(0.0)) as usize;
        let start = [self.work(0), self.work(1), self.work(2)];
        let end_z = self.target(false)[2];
        let q = self.block.get(b'q').filter(|q| *q != -1.0).unwrap_or(0.0).to_radians();
        let sign = if end_z > start[2] { -1.0 } else { 1.0 };
        let tan_q = (sign * q).tan();
        let taper = sign * self.block.get(b'e').map_or(0.0, |e| e.max(0.0) * s);
        let flags = self.block.get(b'l').map_or(0, |l| l.max(0.0) as u32);
        let t = Thread {
            safe_x: start[0],
            y: start[1],
            start_z: start[2],
            target_z: end_z + k * tan_q,
            dir: if i > 0.0 { 1.0 } else { -1.0 },
            full: i.abs() + k,
            peak: i.abs(),
            k,
            tan_q,
            taper,
            entry_taper: flags & 1 != 0,
            exit_taper: flags & 2 != 0,
            feed: pitch * self.rpm,
        };
        let mut depth = t.peak + j;
        let mut pass = 1usize;
        while depth < t.full && pass < MAX_PASSES {
            self.thread_pass(&t, depth, sink)?;
            pass += 1;
            depth = t.peak + j * (pass as f64).powf(1.0 / degression);
        }
        for _ in 0..=spring.min(MAX_PASSES) {
            self.thread_pass(&t, t.full, sink)?;
        }
        let end = [t.safe_x, t.y, end_z];
        self.set_work(end);
        self.emit(sink, &Motion::Rapid { to: Point3::new(end[0], end[1], end[2]) })
    }

    /// One pass at `depth` from the drive line: to the start of the cut outside the
    /// thread, in, along (with the tapers), and back out.
    fn thread_pass<S: MotionSink>(&mut self, t: &Thread, depth: f64, sink: &mut S) -> Res<(), S::Error> {
        let zoff = (depth - t.peak) * t.tan_q;
        let out_x = t.safe_x + t.dir * (depth - t.full);
        let in_x = t.safe_x + t.dir * depth;
        let z0 = t.start_z - zoff;
        let p = |x: f64, z: f64| Point3::new(x, t.y, z);
        let rapid = |to: Point3<f64>| Motion::Rapid { to };
        let feed = |to: Point3<f64>| Motion::Linear { to, feed: t.feed, extrude: None };
        self.emit(sink, &rapid(p(out_x, z0)))?;
        if t.taper != 0.0 && t.entry_taper {
            self.emit(sink, &feed(p(in_x - t.dir * t.k, z0)))?;
            self.emit(sink, &feed(p(in_x, z0 - t.taper)))?;
        } else {
            self.emit(sink, &rapid(p(in_x, z0)))?;
        }
        let z1 = t.target_z - zoff;
        if t.taper != 0.0 && t.exit_taper {
            self.emit(sink, &feed(p(in_x, z1 + t.taper)))?;
            self.emit(sink, &feed(p(in_x - t.dir * t.k, z1)))?;
        } else {
            self.emit(sink, &feed(p(in_x, z1)))?;
        }
        self.emit(sink, &rapid(p(out_x, z1)))?;
        self.set_work([out_x, t.y, z1]);
        Ok(())
    }
}
