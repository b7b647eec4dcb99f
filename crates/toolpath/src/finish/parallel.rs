//! Parallel (raster) finishing: straight passes at an angle over an XY rectangle, the tip
//! height at each point from drop-cutter, sampled adaptively: a segment is split where the
//! drop-cutter height at its midpoint leaves the chord by more than the tolerance, so flat
//! areas stay coarse and curved ones get the points they need.

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use rayon::prelude::*;
use s2g_geom::{DropCutter, Point3};

use super::FinishError;

/// Options of [`parallel_finish_opt`] (lengths in the mesh's units, mm for real parts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParallelFinishOptions {
    /// Direction of the passes in radians from +X, counter-clockwise. Default `0`.
    pub angle: f64,
    /// Distance between neighbouring passes (see `stepover_for_scallop`). Default `0.5`.
    pub stepover: f64,
    /// Spacing of the first, uniform samples along a pass. Default `1.0`.
    pub sample_step: f64,
    /// Largest allowed distance in Z between the drop-cutter height at a segment's midpoint
    /// and the segment's chord; a segment above it is split. Default `0.005`.
    pub tolerance: f64,
    /// Segments no longer than this are not split. Default `0.02`.
    pub min_step: f64,
    /// Every other pass runs backwards (zigzag) rather than all in `angle`'s direction.
    /// Default `true`.
    pub zigzag: bool,
    /// The tip height where the cutter touches nothing: `None` (default) ends the polyline
    /// there and starts a new one where contact resumes; `Some(z)` uses `z`.
    pub floor: Option<f64>,
}

impl Default for ParallelFinishOptions {
    fn default() -> Self {
        Self {
            angle: 0.0,
            stepover: 0.5,
            sample_step: 1.0,
            tolerance: 0.005,
            min_step: 0.02,
            zigzag: true,
            floor: None,
        }
    }
}

/// [`parallel_finish_opt`] with the default options.
pub fn parallel_finish(
    dc: &DropCutter<'_>,
    min: [f64; 2],
    max: [f64; 2],
) -> Result<Vec<Vec<Point3>>, FinishError> {
    parallel_finish_opt(dc, min, max, &ParallelFinishOptions::default())
}

/// One pass: points `origin + t dir` for `t` in `[t0, t1]`.
struct Pass {
    origin: [f64; 2],
    dir: [f64; 2],
    t0: f64,
    t1: f64,
}

impl Pass {
    fn at(&self, t: f64) -> [f64; 2] {
        [self.origin[0] + t * self.dir[0], self.origin[1] + t * self.dir[1]]
    }
}

/// Cutter-location polylines of parallel finishing over the rectangle `[min, max]` (XY):
/// passes `stepover` apart along `angle`, centred on the rectangle, each clipped to it;
/// every point is a tool-tip position whose Z is the drop-cutter height there (or the
/// floor). Passes come in order across the rectangle, each split where the cutter touches
/// nothing (unless `floor` is set). The same input gives the same output, whatever the
/// number of threads. [`FinishError::InvalidOptions`] for a rectangle or option that is
/// not finite, a non-positive length, or more than ten million first samples.
pub fn parallel_finish_opt(
    dc: &DropCutter<'_>,
    min: [f64; 2],
    max: [f64; 2],
    opts: &ParallelFinishOptions,
) -> Result<Vec<Vec<Point3>>, FinishError> {
    check(min, max, opts)?;
    let (sin, cos) = opts.angle.sin_cos();
    let (dir, normal) = ([cos, sin], [-sin, cos]);
    let corners = [[min[0], min[1]], [max[0], min[1]], [max[0], max[1]], [min[0], max[1]]];
    let along = |p: &[f64; 2], v: [f64; 2]| p[0] * v[0] + p[1] * v[1];
    let (olo, ohi) = corners
        .iter()
        .map(|c| along(c, normal))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), o| (a.min(o), b.max(o)));
    let count = ((ohi - olo) / opts.stepover).floor() as usize + 1;
    let first = 0.5 * (olo + ohi) - 0.5 * (count - 1) as f64 * opts.stepover;
    let diag = ((max[0] - min[0]).powi(2) + (max[1] - min[1]).powi(2)).sqrt();
    if count as f64 * (diag / opts.sample_step + 1.0) > 1e7 {
        return Err(FinishError::InvalidOptions("more than ten million first samples".into()));
    }
    let passes: Vec<Vec<Vec<Point3>>> = (0..count)
        .into_par_iter()
        .map(|k| {
            let o = first + k as f64 * opts.stepover;
            let origin = [o * normal[0], o * normal[1]];
            let Some((t0, t1)) = clip(origin, dir, min, max) else { return Vec::new() };
            let pass = Pass { origin, dir, t0, t1 };
            let mut runs = sample(dc, &pass, opts);
            if opts.zigzag && k % 2 == 1 {
                runs.reverse();
                runs.iter_mut().for_each(|r| r.reverse());
            }
            runs
        })
        .collect();
    Ok(passes.into_iter().flatten().collect())
}

fn check(min: [f64; 2], max: [f64; 2], o: &ParallelFinishOptions) -> Result<(), FinishError> {
    let bad = |m: String| Err(FinishError::InvalidOptions(m));
    if !(min.iter().chain(&max).all(|v| v.is_finite()) && min[0] <= max[0] && min[1] <= max[1]) {
        return bad(format!("the rectangle must be finite with min <= max, got {min:?} .. {max:?}"));
    }
    let lengths = [
        ("stepover", o.stepover),
        ("sample_step", o.sample_step),
        ("tolerance", o.tolerance),
        ("min_step", o.min_step),
    ];
    for (name, v) in lengths {
        if !(v.is_finite() && v > 0.0) {
            return bad(format!("{name} must be finite and > 0, got {v}"));
        }
    }
    if !o.angle.is_finite() || o.floor.is_some_and(|z| !z.is_finite()) {
        return bad(format!("angle and floor must be finite, got {} and {:?}", o.angle, o.floor));
    }
    Ok(())
}

/// The parameter range of the line `origin + t dir` inside the rectangle, if any.
fn clip(origin: [f64; 2], dir: [f64; 2], min: [f64; 2], max: [f64; 2]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..2 {
        if dir[a].abs() < 1e-15 {
            if origin[a] < min[a] || origin[a] > max[a] {
                return None;
            }
            continue;
        }
        let (p, q) = ((min[a] - origin[a]) / dir[a], (max[a] - origin[a]) / dir[a]);
        t0 = t0.max(p.min(q));
        t1 = t1.min(p.max(q));
    }
    (t0 <= t1).then_some((t0, t1))
}

/// One pass's polylines: uniform samples, refined, split where there is no contact.
fn sample(dc: &DropCutter<'_>, pass: &Pass, o: &ParallelFinishOptions) -> Vec<Vec<Point3>> {
    let height = |t: f64| {
        let p = pass.at(t);
        dc.height(p[0], p[1]).or(o.floor)
    };
    let n = ((pass.t1 - pass.t0) / o.sample_step).ceil().max(1.0) as usize;
    let ts: Vec<f64> = (0..=n).map(|i| pass.t0 + (pass.t1 - pass.t0) * i as f64 / n as f64).collect();
    let mut points = vec![(ts[0], height(ts[0]))];
    for w in ts.windows(2) {
        let b = (w[1], height(w[1]));
        let a = *points.last().unwrap_or(&b);
        refine(&height, a, b, o, &mut points);
        points.push(b);
    }
    let mut runs = Vec::new();
    let mut run = Vec::new();
    for (t, h) in points {
        match h {
            Some(z) => {
                let p = pass.at(t);
                run.push(Point3::new(p[0], p[1], z));
            }
            None if !run.is_empty() => runs.push(std::mem::take(&mut run)),
            None => {}
        }
    }
    if !run.is_empty() {
        runs.push(run);
    }
    runs
}

/// Pushes the points that `a`-`b` needs between them (not `a` or `b`), in order.
fn refine(
    height: &impl Fn(f64) -> Option<f64>,
    a: (f64, Option<f64>),
    b: (f64, Option<f64>),
    o: &ParallelFinishOptions,
    out: &mut Vec<(f64, Option<f64>)>,
) {
    if !(b.0 - a.0 > o.min_step) {
        return;
    }
    let tm = 0.5 * (a.0 + b.0);
    let m = (tm, height(tm));
    let split = match (a.1, m.1, b.1) {
        (Some(za), Some(zm), Some(zb)) => (zm - 0.5 * (za + zb)).abs() > o.tolerance,
        (None, None, None) => false,
        // Where contact starts or ends, home in on it.
        _ => true,
    };
    if split {
        refine(height, a, m, o, out);
        out.push(m);
        refine(height, m, b, o, out);
    }
}
