//! The print rebuilt from its program (seed 004's reconstruction, with tilted beads):
//! the program text is parsed by `s2g-gcode`'s parser with the machine's rotary
//! kinematics (a turning platform's setups or a tilting head's tool axes), each extruding
//! move becomes a bead in the part frame (the segment, the nozzle axis of its block, the
//! thickness that its filament gives at the bead width), and the beads are deposited into
//! a voxel grid and scored against the part.
//!
//! - **Deposit**: a bead is the set of points whose distance to its segment, measured
//!   across the nozzle axis, is at most `w/2`, and which lie between the tip and `t` below
//!   it along the axis (a flat bead under the nozzle, rounded ends).
//! - **Overhang**: bead samples every `w/4` along each bead, at its centre and both edges
//!   of its underside. A sample is supported when an earlier bead's mid-height point lies
//!   below it (`0 < v ≤ ¾ t' + ¼ t` along the axis, `t'` that bead's thickness, ideally
//!   `½ t'`) within `w/2 + t'·tan α` across the axis: the cone of the self-supporting
//!   angle `α` below the sample reaches that bead's body within its thickness; or when
//!   the platform supports it as a flat layer of beads of thickness `t` with its top on the
//!   platform's surface would by the same rule (`platform_supports`: within `½ t` below a vertical bead's
//!   sample, farther below a tilted one's, whose cone meets the platform sooner). The
//!   overhang fraction is the fraction of samples (by bead length) not supported.

use std::collections::HashMap;

use s2g_gcode::{Motion, MotionSink, ParseDialect, ParseOptions, RotaryAxes, RotaryMount, parse_str};
use s2g_geom::{Aabb, GridSpec, Isometry3, Mesh, Point3, Vector3, VoxelGrid, occupancy_iou, voxelize};

use crate::error::{FieldError, Result};

/// One deposited bead: a straight extruding move in the part frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bead {
    /// Start of the nozzle tip.
    pub start: Point3,
    /// End of the nozzle tip.
    pub end: Point3,
    /// Nozzle axis (unit, in the part frame).
    pub axis: Vector3,
    /// Bead thickness under the tip, from the filament pushed.
    pub thickness: f64,
}

/// Collects beads from parsed motions.
struct BeadSink {
    frame: Isometry3,
    /// A tilting head's nozzle axis in the program frame (`+Z` until the head turns).
    head_axis: Vector3,
    tip: Point3,
    width: f64,
    filament_area: f64,
    beads: Vec<Bead>,
}

impl MotionSink for BeadSink {
    type Error = std::convert::Infallible;

    fn motion(&mut self, m: &Motion<'_>) -> std::result::Result<(), Self::Error> {
        match m {
            Motion::Setup { frame, .. } => {
                self.frame = *frame;
                self.head_axis = Vector3::z();
            }
            Motion::ToolAxis { axis, .. } => self.head_axis = *axis,
            Motion::Rapid { to } => self.tip = self.frame * to,
            Motion::Linear { to, extrude, .. } => {
                let end = self.frame * to;
                let len = (end - self.tip).norm();
                if let Some(e) = extrude.filter(|e| *e > 0.0 && len > 1e-9) {
                    let axis = self.frame.rotation * self.head_axis;
                    let thickness = e * self.filament_area / (self.width * len);
                    self.beads.push(Bead { start: self.tip, end, axis, thickness });
                }
                self.tip = end;
            }
            _ => {}
        }
        Ok(())
    }
}

/// Parses `program` (Marlin words with `axes` rotary words turning what `mount` says) and
/// returns its beads, for a bead `width` and a filament of `filament_diameter`.
///
/// Errors: [`FieldError::Program`] when the parser reports an error.
pub fn read_beads(
    program: &str,
    axes: RotaryAxes,
    mount: RotaryMount,
    width: f64,
    filament_diameter: f64,
) -> Result<Vec<Bead>> {
    FieldError::check_positive(&[("width", width), ("filament_diameter", filament_diameter)])?;
    let opts = ParseOptions {
        rotary: Some(axes),
        rotary_mount: mount,
        dialect: ParseDialect::Fdm,
        ..ParseOptions::default()
    };
    let mut sink = BeadSink {
        frame: Isometry3::identity(),
        head_axis: Vector3::z(),
        tip: Point3::origin(),
        width,
        filament_area: std::f64::consts::PI * 0.25 * filament_diameter * filament_diameter,
        beads: Vec::new(),
    };
    let summary = parse_str(program, &opts, &mut sink).map_err(|e| FieldError::Program(e.to_string()))?;
    if let Some(e) = summary.errors.first() {
        return Err(FieldError::Program(format!("the program does not parse back: {e}")));
    }
    Ok(sink.beads)
}

/// How the rebuilt print is scored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoreOptions {
    /// Voxel edge of the deposit and the part. Default `0.5`.
    pub voxel: f64,
    /// Bead width. Default `1.0`.
    pub bead_width: f64,
    /// Self-supporting angle `α`, degrees. Default `45`.
    pub max_overhang_deg: f64,
    /// The platform's height. Default `0`.
    pub platform: f64,
}

impl Default for ScoreOptions {
    fn default() -> Self {
        Self { voxel: 0.5, bead_width: 1.0, max_overhang_deg: 45.0, platform: 0.0 }
    }
}

/// The rebuilt print against the part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrintScore {
    /// Voxel IoU of the deposit and the part.
    pub iou: f64,
    /// Fraction of the bead samples with nothing below them within the self-supporting
    /// angle (module docs).
    pub overhang_fraction: f64,
    /// Beads.
    pub beads: usize,
    /// Their length.
    pub bead_length: f64,
    /// Deposited voxels' volume over the part's voxels' volume.
    pub volume_ratio: f64,
}

fn bead_frame(b: &Bead) -> Option<(Vector3, Vector3, Vector3, f64)> {
    let along = b.end - b.start;
    let len = along.norm();
    let t = along.try_normalize(1e-12)?;
    let d = (b.axis - t * b.axis.dot(&t)).try_normalize(1e-9)?;
    Some((t, d, d.cross(&t), len))
}

/// Deposits the beads into a grid of `spec`.
pub fn deposit(beads: &[Bead], spec: &GridSpec, width: f64) -> VoxelGrid {
    let mut grid = VoxelGrid::new(*spec);
    let half = 0.5 * width;
    for b in beads {
        let Some((t, d, s, len)) = bead_frame(b) else { continue };
        let reach = half.max(b.thickness) + spec.voxel.max();
        let (lo, hi) = (b.start.inf(&b.end), b.start.sup(&b.end));
        let range = |a: usize| spec.center_range(lo[a] - reach, hi[a] + reach, a);
        let (Some(rx), Some(ry), Some(rz)) = (range(0), range(1), range(2)) else { continue };
        for k in rz.0..=rz.1 {
            for j in ry.0..=ry.1 {
                for i in rx.0..=rx.1 {
                    let p = spec.center(i, j, k);
                    let r = p - b.start;
                    let u = r.dot(&t);
                    let excess = u - u.clamp(0.0, len);
                    let lateral = r.dot(&s);
                    let vertical = (r - t * u.clamp(0.0, len)).dot(&d);
                    if excess * excess + lateral * lateral <= half * half
                        && vertical <= 0.0
                        && vertical >= -b.thickness
                    {
                        grid.set(i, j, k, true);
                    }
                }
            }
        }
    }
    grid
}

/// The overhang fraction of the module docs.
pub fn overhang_fraction(beads: &[Bead], width: f64, max_overhang_deg: f64, platform: f64) -> f64 {
    let (total, misses) = overhang_misses(beads, width, max_overhang_deg, platform);
    if total == 0 { 0.0 } else { misses.len() as f64 / total as f64 }
}

/// Whether the platform (`z = platform`) supports the underside sample `p` of a bead of
/// thickness `t` along the axis `d`: by the rule of a supporting bead (module docs) applied
/// to a flat layer of beads of thickness `t` whose top is the platform's surface (their
/// mid-heights on `z = platform - t/2`), some point of that mid-plane lies below `p` along
/// `d` by at most `¾ t + ¼ t = t` and within `w/2 + t·tan α` of `p`'s axis, i.e.
/// `z(p) - platform + t/2 <= t cos ψ + (w/2 + t tan α) sin ψ` with `ψ` the axis's tilt
/// off `+z`. For a vertical axis this is `z(p) <= platform + t/2` (the rule before it); it
/// is never stricter than that while `w/2 + t tan α >= t`.
fn platform_supports(p: &Point3, d: &Vector3, t: f64, width: f64, tan: f64, platform: f64) -> bool {
    let c = d.z.clamp(0.0, 1.0);
    let s = (1.0 - c * c).sqrt();
    p.z - platform + 0.5 * t <= t * c + (0.5 * width + t * tan) * s
}

/// The bead samples [`overhang_fraction`] checks, and those of them with nothing below
/// (where the overhang lies), in bead order.
pub fn overhang_misses(
    beads: &[Bead],
    width: f64,
    max_overhang_deg: f64,
    platform: f64,
) -> (usize, Vec<Point3>) {
    let tan = max_overhang_deg.to_radians().tan();
    let step = 0.25 * width;
    // Mid-height points of every bead, with the bead's index, hashed by cell.
    let cell = (2.0 * width).max(1e-6);
    let key =
        |p: &Point3| [(p.x / cell).floor() as i64, (p.y / cell).floor() as i64, (p.z / cell).floor() as i64];
    let mut mids: HashMap<[i64; 3], Vec<(usize, Point3, f64)>> = HashMap::new();
    let mut samples: Vec<(usize, Point3, Vector3, Vector3, f64)> = Vec::new();
    for (i, b) in beads.iter().enumerate() {
        let Some((t, d, s, len)) = bead_frame(b) else { continue };
        let n = ((len / step).ceil() as usize).max(1);
        for k in 0..n {
            let c = b.start + t * (len * (k as f64 + 0.5) / n as f64);
            let mid = c - d * (0.5 * b.thickness);
            mids.entry(key(&mid)).or_default().push((i, mid, b.thickness));
            samples.push((i, c - d * b.thickness, d, s, b.thickness));
        }
    }
    let (mut total, mut bad) = (0usize, Vec::new());
    for (i, bottom, d, s, th) in samples {
        for e in [-0.5, 0.0, 0.5] {
            let p = bottom + s * (e * width);
            total += 1;
            if platform_supports(&p, &d, th, width, tan, platform) {
                continue;
            }
            let r = (0.5 * width + 3.0 * th * tan.max(1.0)) / cell;
            let (c0, span) = (key(&p), r.ceil() as i64);
            let mut ok = false;
            'search: for dx in -span..=span {
                for dy in -span..=span {
                    for dz in -span..=span {
                        let Some(list) = mids.get(&[c0[0] + dx, c0[1] + dy, c0[2] + dz]) else { continue };
                        for &(j, m, tm) in list {
                            if j >= i {
                                continue;
                            }
                            let rel = p - m;
                            let v = rel.dot(&d);
                            let reach = 0.5 * width + tm * tan;
                            if v > 0.0 && v <= 0.75 * tm + 0.25 * th && (rel - d * v).norm() <= reach {
                                ok = true;
                                break 'search;
                            }
                        }
                    }
                }
            }
            if !ok {
                bad.push(p);
            }
        }
    }
    (total, bad)
}

/// The most voxels along the score's grid.
pub(crate) const MAX_SCORE_VOXELS: usize = 2048;

/// The score's box, `bbox` (the part's and the beads' box) grown by a bead width and a
/// voxel, and the voxels along its longest side; an error beyond [`MAX_SCORE_VOXELS`].
pub(crate) fn score_box(bbox: &Aabb, bead_width: f64, voxel: f64) -> Result<(Aabb, usize)> {
    let bbox = bbox.inflated(bead_width + voxel);
    let n = ((bbox.max - bbox.min).max() / voxel).ceil();
    // NaN (a NaN box) is refused with the rest.
    if n.is_nan() || n > MAX_SCORE_VOXELS as f64 {
        return Err(FieldError::InvalidArgument(format!(
            "{n} voxels of {voxel} along the print (at most {MAX_SCORE_VOXELS})"
        )));
    }
    Ok((bbox, n as usize))
}

/// Scores `beads` against `mesh`: deposit and voxelised part on one grid of cubic voxels
/// over the union of their boxes, IoU, volume ratio and overhang fraction.
///
/// Errors: [`FieldError::InvalidArgument`] for a bad voxel or no bead,
/// [`FieldError::Geometry`] if voxelisation fails.
pub fn score_print(beads: &[Bead], mesh: &Mesh, opts: &ScoreOptions) -> Result<PrintScore> {
    FieldError::check_positive(&[("score.voxel", opts.voxel), ("score.bead_width", opts.bead_width)])?;
    let mut bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
    for b in beads {
        bbox.grow(&b.start);
        bbox.grow(&b.end);
    }
    let (bbox, n) = score_box(&bbox, opts.bead_width, opts.voxel)?;
    let spec = GridSpec::cubic(&bbox, n.max(1)).map_err(FieldError::geom)?;
    let printed = deposit(beads, &spec, opts.bead_width);
    let part = voxelize(mesh, &spec).map_err(FieldError::geom)?;
    let (iou, _) = occupancy_iou(&printed, &part).map_err(FieldError::geom)?;
    let volume_ratio = printed.count() as f64 / (part.count() as f64).max(1.0);
    Ok(PrintScore {
        iou,
        overhang_fraction: overhang_fraction(beads, opts.bead_width, opts.max_overhang_deg, opts.platform),
        beads: beads.len(),
        bead_length: beads.iter().map(|b| (b.end - b.start).norm()).sum(),
        volume_ratio,
    })
}
