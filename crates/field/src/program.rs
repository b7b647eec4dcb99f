//! Five-axis milling programs from a layer field (§4.2, §7.4 of seed 002), and their
//! simulation in `s2g-voxsim`.
//!
//! [`mill_program`] turns the pose points of a [`MillingProblem`] into a simultaneous
//! five-axis program for a table-table machine (A/C or B/C rotary words):
//!
//! - **Layers.** Each pose belongs to the layer `round((G_top - G(x)) / h)` of the field `G`
//!   (`h` = [`ProgramOptions::layer_step`] in unit-cube lengths times the median `|∇G|`
//!   over the poses, so layers are about `layer_step` apart); layers are milled from
//!   the top (largest `G`) down, so the tool only meets material on its own layer.
//! - **Tool axis.** The layer normal `∇G/|∇G|` at the pose, taken vertical when it tilts
//!   less than [`ProgramOptions::vertical_snap_deg`] (the rotary C angle is free there and
//!   would otherwise spin); turned toward `+Z` in quarters when the clearance proof fails
//!   along the normal (counted in [`MillProgram::poses_reoriented`]). The rotary angles follow `s2g-gcode`'s conventions
//!   ([`s2g_gcode::rotary_angles`]), C unwrapped to the nearest turn of the previous
//!   block's.
//! - **Toolpaths.** On each layer a nearest-neighbour chain over its poses, or, with a path
//!   field ([`mill_program_with_paths`]), a chain along the iso-curves of `P` (contour-
//!   parallel toolpaths when `P` follows the part's outline); consecutive
//!   poses closer than [`ProgramOptions::link_distance`] are joined by a feed move, others
//!   by a retract along the tool axis, a traverse and a plunge (or via a vertical tool above
//!   the block); when none of the nearest remaining poses can be reached, the tool steps
//!   back along its checked way first. Moves are split so that no
//!   block turns A or C by more than [`ProgramOptions::max_angle_step_deg`].
//! - **Checks.** Every tool position the machine passes through (the blocks sampled as the
//!   simulator interpolates them: rotation slerp, program point lerp) is proved clear of
//!   the part: the distance at axis points spaced `s` apart must exceed `sqrt(r² + s²/4)`
//!   (`r` the largest radius of the tool's cutter),
//!   plus [`ProgramOptions::flute_clearance`] along the flutes, which bounds the whole
//!   cylinder away from the part (the distance is 1-Lipschitz). Poses that fail are left
//!   out, links that fail are replaced by higher retracts or skip their pose; both counted.
//!
//! Programs are written by `s2g-gcode`'s [`GcodeWriter`] with rotary words; each rotary
//! setup block it writes (`G0 A.. C..`) is merged into the move after it, so the rotation
//! and the move are one simultaneous block, which the parser and the simulator treat as a
//! simultaneous axis change.

use s2g_gcode::{
    Dialect, FooterRetract, GcodeWriter, Motion, MotionSink, ParseOptions, RotaryAxes, SpindleDirection,
    WriterOptions, rotary_frame,
};
use s2g_geom::{Aabb, GridSpec, Isometry3, Mesh, Point3, SignedDistance, Vector3, VoxelGrid, voxelize};
use s2g_voxsim::{SimOptions, Simulator, ToolTable};

use crate::error::{FieldError, Result};
use crate::milling::MillingProblem;
use crate::siren::SirenF64;
use crate::tool::Tool;

mod route;

/// How [`mill_program`] builds a program. Lengths in the part's units (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramOptions {
    /// Layer spacing: `G` levels `layer_step × scale × median |∇G|` apart (unit-cube `G`;
    /// planar layers are then `layer_step` apart). Default `3.0` (the cup example's pose
    /// grid).
    pub layer_step: f64,
    /// Largest distance between consecutive poses joined by a feed move. Default `4.5`.
    pub link_distance: f64,
    /// First retract distance along the tool axis for a jump; twice and four times it are
    /// tried next. Default `8.0`.
    pub retract: f64,
    /// Feed rate, mm/min. Default `800`.
    pub feed: f64,
    /// Spindle speed, rpm. Default `12000`.
    pub spindle_rpm: f64,
    /// Extra clearance of the flutes from the part, on top of the cylinder bound: at least
    /// the simulator's sweep tolerance (a quarter voxel). Default `0.3`.
    pub flute_clearance: f64,
    /// Spacing of the axis points of the clearance proof. Default `0.5`.
    pub check_step: f64,
    /// Spacing of the checked tool positions along a move (tip travel, or the travel of
    /// the tool's far end under rotation). Default `0.5`.
    pub move_step: f64,
    /// Largest change of a rotary angle per block, degrees. Default `2.0`.
    pub max_angle_step_deg: f64,
    /// Normals tilting less than this from `+Z` are taken vertical, degrees. Default `2.0`.
    pub vertical_snap_deg: f64,
    /// The machine's rotary axes. Default [`RotaryAxes::AC`].
    pub rotary: RotaryAxes,
    /// Output dialect (one with rotary axes: LinuxCNC or Fanuc). Default
    /// [`Dialect::LinuxCnc`].
    pub dialect: Dialect,
}

impl Default for ProgramOptions {
    fn default() -> Self {
        Self {
            layer_step: 3.0,
            link_distance: 4.5,
            retract: 8.0,
            feed: 800.0,
            spindle_rpm: 12000.0,
            flute_clearance: 0.3,
            check_step: 0.5,
            move_step: 0.5,
            max_angle_step_deg: 2.0,
            vertical_snap_deg: 2.0,
            rotary: RotaryAxes::AC,
            dialect: Dialect::LinuxCnc,
        }
    }
}

impl ProgramOptions {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        FieldError::check_positive(&[
            ("program.layer_step", self.layer_step),
            ("program.link_distance", self.link_distance),
            ("program.retract", self.retract),
            ("program.feed", self.feed),
            ("program.spindle_rpm", self.spindle_rpm),
            ("program.check_step", self.check_step),
            ("program.move_step", self.move_step),
            ("program.max_angle_step_deg", self.max_angle_step_deg),
        ])?;
        FieldError::check_non_negative(&[("program.flute_clearance", self.flute_clearance)])?;
        if !(self.vertical_snap_deg.is_finite() && (0.0..90.0).contains(&self.vertical_snap_deg)) {
            return Err(FieldError::config("program.vertical_snap_deg", "must be in [0, 90)"));
        }
        if !self.dialect.has_rotary_axes() {
            return Err(FieldError::config("program.dialect", "needs rotary axes: LinuxCnc or Fanuc"));
        }
        Ok(())
    }
}

/// What [`mill_program`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct MillProgram {
    /// The G-code text.
    pub text: String,
    /// Layers with at least one pose milled.
    pub layers: usize,
    /// Poses visited.
    pub poses_used: usize,
    /// Poses left out: the clearance proof failed at the pose (e.g. a colliding pose of
    /// planar layers), or no checked route reached it (from where the tool was, or from
    /// the last 64 waypoints back along its way, trying the 6 nearest remaining poses).
    pub poses_skipped: usize,
    /// Of the skipped poses, those where no tool axis passed the clearance proof.
    pub poses_unclear: usize,
    /// Poses milled with the tool axis turned toward `+Z` from the layer normal, because
    /// the normal failed the (stricter than the loss's) clearance proof.
    pub poses_reoriented: usize,
    /// Feed moves between neighbouring poses.
    pub links: usize,
    /// Of the links, those between two poses on the same iso-curve of the path field
    /// ([`mill_program_with_paths`]; `0` without one).
    pub curve_links: usize,
    /// Retract-traverse-plunge jumps.
    pub jumps: usize,
    /// Motion blocks written.
    pub blocks: usize,
}

/// A machine state: tool tip in the part frame, rotary angles (degrees, C unwrapped).
#[derive(Debug, Clone, Copy)]
pub(crate) struct State {
    pub(crate) tip: Point3,
    pub(crate) tilt: f64,
    pub(crate) c: f64,
}

impl State {
    /// The sub-states of a move from `self` to `b`: the tip on the straight line, the angles
    /// linear, no angle changing by more than `max_angle` degrees per piece.
    pub(crate) fn pieces(&self, b: &State, max_angle: f64) -> Vec<State> {
        let a = self;
        let turn = (b.tilt - a.tilt).abs().max((b.c - a.c).abs());
        let n = ((turn / max_angle).ceil() as usize).clamp(1, 100_000);
        (1..=n)
            .map(|k| {
                let t = k as f64 / n as f64;
                State {
                    tip: a.tip + (b.tip - a.tip) * t,
                    tilt: a.tilt + (b.tilt - a.tilt) * t,
                    c: a.c + (b.c - a.c) * t,
                }
            })
            .collect()
    }
}

/// The clearance proof of the module docs.
struct Clearance<'a> {
    part: &'a dyn SignedDistance,
    radius: f64,
    length: f64,
    flute: f64,
    flute_clearance: f64,
    step: f64,
}

impl Clearance<'_> {
    /// Whether the whole tool (a cylinder of `radius` from `tip` along `axis`, `length`
    /// long) is clear of the part, the flutes by `flute_clearance` more.
    fn clear(&self, tip: &Point3, axis: &Vector3) -> bool {
        let base = (self.radius * self.radius + 0.25 * self.step * self.step).sqrt();
        let n = (self.length / self.step).ceil() as usize;
        let mut i = 0;
        while i <= n {
            let a = (i as f64 * self.step).min(self.length);
            let need = if a <= self.flute + 0.5 * self.step { base + self.flute_clearance } else { base };
            let d = self.part.distance(&(tip + axis * a));
            if d.is_nan() || d < need {
                return false;
            }
            // The distance is 1-Lipschitz: the next samples within `d - need - flute
            // clearance` of this one pass too.
            let skip = ((d - need - self.flute_clearance) / self.step).floor().max(0.0) as usize;
            i += 1 + skip;
        }
        true
    }
}

/// The tilt (A or B) and C angles, degrees, that put the tool axis along the unit vector
/// `n`: `s2g-gcode`'s table-table conventions ([`s2g_gcode::rotary_angles`]).
pub(crate) fn tool_axis_angles(axes: RotaryAxes, n: &Vector3) -> (f64, f64) {
    let h = n.x.hypot(n.y);
    let tilt = h.atan2(n.z).to_degrees();
    let c = match axes {
        RotaryAxes::AC => n.x.atan2(-n.y),
        RotaryAxes::BC => n.y.atan2(n.x),
    };
    (tilt, if h < 1e-12 { 0.0 } else { c.to_degrees() })
}

fn frame_of(axes: RotaryAxes, s: &State) -> Isometry3 {
    match axes {
        RotaryAxes::AC => rotary_frame(axes, [s.tilt, 0.0, s.c]),
        RotaryAxes::BC => rotary_frame(axes, [0.0, s.tilt, s.c]),
    }
}

fn axis_of(axes: RotaryAxes, s: &State) -> Vector3 {
    frame_of(axes, s).rotation * Vector3::z()
}

/// Builds the simultaneous five-axis program of the module docs for the layer field `g`
/// over `problem`'s poses, with nearest-neighbour toolpaths on each layer.
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::InvalidArgument`]
/// when no pose passes the clearance proof, [`FieldError::Write`] if the writer fails.
pub fn mill_program(
    g: &SirenF64,
    problem: &MillingProblem<'_>,
    options: &ProgramOptions,
) -> Result<MillProgram> {
    build_program(g, problem, options, None)
}

/// The path field of contour-parallel toolpaths (§3.2, §7.4 of seed 002), for
/// [`mill_program_with_paths`].
#[derive(Debug, Clone, PartialEq)]
pub struct ContourPaths {
    /// `P`, on the same unit-cube coordinates as the layer field (for example from
    /// [`fit_contour_paths`](crate::fit_contour_paths)): its iso-curves on each layer are
    /// the toolpaths.
    pub field: SirenF64,
    /// Spacing of the milled iso-curves, in the part's units: `P` levels `step × scale ×
    /// median |∇P|` apart. Finite and `> 0`.
    pub step: f64,
}

/// [`mill_program`] with contour-parallel toolpaths: on each layer the poses are taken
/// along the iso-curves of the path field `paths.field`, each pose belonging to the
/// iso-curve `round(P(x) / δ)` (`δ` from [`ContourPaths::step`]). From a pose, the nearest
/// remaining pose on the same iso-curve within [`ProgramOptions::link_distance`] comes
/// first (the tool follows the curve), then the nearest remaining pose (the next curve,
/// or a jump). The layers, tool axes, links, jumps and the clearance proof of every pose
/// and move are [`mill_program`]'s; [`MillProgram::curve_links`] counts the feed links
/// along an iso-curve.
///
/// Errors: as [`mill_program`]'s; [`FieldError::InvalidConfig`] for a bad `paths.step`.
pub fn mill_program_with_paths(
    g: &SirenF64,
    problem: &MillingProblem<'_>,
    options: &ProgramOptions,
    paths: &ContourPaths,
) -> Result<MillProgram> {
    FieldError::check_positive(&[("paths.step", paths.step)])?;
    build_program(g, problem, options, Some(paths))
}

fn build_program(
    g: &SirenF64,
    problem: &MillingProblem<'_>,
    options: &ProgramOptions,
    paths: Option<&ContourPaths>,
) -> Result<MillProgram> {
    options.validate()?;
    let tool = problem.tool();
    let clearance = Clearance {
        part: problem.part(),
        radius: tool.envelope_radius(),
        length: tool.length(),
        flute: tool.cutter.flute_length,
        flute_clearance: options.flute_clearance,
        step: options.check_step,
    };
    let (poses, skipped, reoriented) = route::program_poses(g, problem, options, paths, &clearance);
    if poses.is_empty() {
        return Err(FieldError::InvalidArgument("no pose passes the tool clearance check".into()));
    }
    let mut w = Emitter::new(options, options.rotary);
    w.push(Motion::ToolChange { tool: 1 })?;
    w.push(Motion::Spindle { rpm: options.spindle_rpm, direction: SpindleDirection::Clockwise })?;
    let mut out = MillProgram {
        text: String::new(),
        layers: 0,
        poses_used: 0,
        poses_skipped: skipped,
        poses_unclear: skipped,
        poses_reoriented: reoriented,
        links: 0,
        curve_links: 0,
        jumps: 0,
        blocks: 0,
    };
    route::walk_layers(&mut w, &mut out, g, problem, options, &clearance, &poses, paths.is_some())?;
    out.blocks = w.blocks;
    out.text = w.finish()?;
    Ok(out)
}

/// Writes the blocks through [`GcodeWriter`], tracking the rotary state.
struct Emitter {
    writer: GcodeWriter<Vec<u8>>,
    axes: RotaryAxes,
    feed: f64,
    max_angle: f64,
    move_step: f64,
    reach: f64,
    /// The angles of the last written setup.
    angles: Option<(f64, f64)>,
    blocks: usize,
}

impl Emitter {
    fn new(options: &ProgramOptions, axes: RotaryAxes) -> Self {
        // No footer retract: the program leaves along the tool axis itself; a machine-Z move
        // with the part tilted would cross it.
        let opts = WriterOptions {
            rotary: Some(axes),
            comments: false,
            retract: FooterRetract::None,
            ..WriterOptions::default()
        };
        Self {
            writer: GcodeWriter::new(Vec::new(), options.dialect, opts),
            axes,
            feed: options.feed,
            max_angle: options.max_angle_step_deg,
            move_step: options.move_step,
            reach: 0.0,
            angles: None,
            blocks: 0,
        }
    }

    fn push(&mut self, m: Motion<'_>) -> Result<()> {
        self.writer.motion(&m).map_err(FieldError::Write)
    }

    /// A setup block for `s`'s angles, unless they are the last setup's.
    fn setup(&mut self, s: &State) -> Result<()> {
        if self.angles == Some((s.tilt, s.c)) {
            return Ok(());
        }
        self.angles = Some((s.tilt, s.c));
        let rotary = match self.axes {
            RotaryAxes::AC => [Some(s.tilt), None, Some(s.c)],
            RotaryAxes::BC => [None, Some(s.tilt), Some(s.c)],
        };
        self.push(Motion::Setup { frame: frame_of(self.axes, s), rotary })
    }

    fn program_point(&self, s: &State) -> Point3 {
        frame_of(self.axes, s).inverse() * s.tip
    }

    fn rapid(&mut self, s: &State) -> Result<()> {
        let to = self.program_point(s);
        self.reach = self.reach.max(to.coords.norm());
        self.blocks += 1;
        self.push(Motion::Rapid { to })
    }

    /// Whether one block from `a` to `b`, as the simulator interpolates it (rotation slerp,
    /// program point lerp), keeps the tool clear.
    fn check_move(&self, clearance: &Clearance<'_>, a: &State, b: &State) -> bool {
        let (fa, fb) = (frame_of(self.axes, a), frame_of(self.axes, b));
        let (pa, pb) = (fa.inverse() * a.tip, fb.inverse() * b.tip);
        let angle = fa.rotation.angle_to(&fb.rotation);
        let reach = pa.coords.norm().max(pb.coords.norm()) + clearance.length + clearance.radius;
        let travel = (b.tip - a.tip).norm() + angle * reach;
        let n = ((travel / self.move_step).ceil() as usize).clamp(1, 1 << 20);
        (0..=n).all(|k| {
            let t = k as f64 / n as f64;
            let r = fa.rotation.slerp(&fb.rotation, t);
            let tip = r * (pa + (pb - pa) * t);
            clearance.clear(&tip, &(r * Vector3::z()))
        })
    }

    /// Whether the sub-blocks of the move from `a` to `b` keep the tool clear.
    fn check_path(&self, clearance: &Clearance<'_>, a: &State, b: &State) -> bool {
        let mut prev = *a;
        for s in a.pieces(b, self.max_angle) {
            if !self.check_move(clearance, &prev, &s) {
                return false;
            }
            prev = s;
        }
        true
    }

    /// Feed moves from `a` to `b` (checked by the caller), one block per piece.
    fn feed_to(&mut self, a: &State, b: &State, split: bool) -> Result<()> {
        let pieces = if split { a.pieces(b, self.max_angle) } else { vec![*b] };
        for s in pieces {
            self.setup(&s)?;
            let to = self.program_point(&s);
            self.reach = self.reach.max(to.coords.norm());
            self.blocks += 1;
            self.push(Motion::Linear { to, feed: self.feed, extrude: None })?;
        }
        Ok(())
    }

    /// Finishes the writer and merges each rotary setup block into the move after it.
    fn finish(mut self) -> Result<String> {
        self.writer.finish().map_err(FieldError::Write)?;
        let raw = String::from_utf8_lossy(&self.writer.into_inner()).into_owned();
        Ok(merge_rotary_blocks(&raw, self.axes))
    }
}

/// Joins each `G0 A.. C..` (or `G0 B.. C..`) block the writer emits for a setup with the
/// motion block that follows it, so both happen in one simultaneous block. A following
/// block without a motion word inherits the setup block's `G0`. A rotary block followed by
/// another stays alone (a tilting head turning about a tip that does not move: the writer
/// leaves out the move that goes nowhere).
pub(crate) fn merge_rotary_blocks(text: &str, axes: RotaryAxes) -> String {
    let prefix = match axes {
        RotaryAxes::AC => "G0 A",
        RotaryAxes::BC => "G0 B",
    };
    let mut out = String::with_capacity(text.len());
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let is_move =
            |l: &str| l.starts_with("G0 ") || l.starts_with("G1 ") || l.starts_with(['X', 'Y', 'Z']);
        match lines.peek() {
            Some(next) if line.starts_with(prefix) && is_move(next) && !next.starts_with(prefix) => {
                let rotary = &line[3..];
                let next = lines.next().unwrap_or_default();
                let mut merged = if next.starts_with('G') { next.to_string() } else { format!("G0 {next}") };
                match merged.find(" F") {
                    Some(at) => merged.insert_str(at, &format!(" {rotary}")),
                    None => {
                        merged.push(' ');
                        merged.push_str(rotary);
                    }
                }
                out.push_str(&merged);
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// The step of a field `g` (`G`, or a path field `P`) between iso-surfaces `layer_step`
/// apart (part units): `layer_step` in unit-cube lengths times the median `|∇g|` over the
/// poses (the optimisation changes `|∇g|`).
fn gradient_step(g: &SirenF64, problem: &MillingProblem<'_>, layer_step: f64) -> f64 {
    let nz = problem.normalization();
    let mut norms: Vec<f64> = problem
        .poses()
        .iter()
        .map(|x| {
            let u = nz.to_unit(x);
            let (_, d) = g.value_gradient([u.x, u.y, u.z]);
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        })
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    norms.sort_by(f64::total_cmp);
    let median = norms.get(norms.len() / 2).copied().unwrap_or(1.0);
    layer_step * nz.scale * median
}

/// The milling layers as one triangle mesh: the iso-surfaces of `g` at the levels
/// [`mill_program`] mills (about `layer_step` apart, through the highest pose's value),
/// extracted by marching cubes on a lattice of spacing `spacing` over the block, with the
/// triangles whose centroid lies inside the part left out.
///
/// Errors: [`FieldError::InvalidArgument`] for a bad spacing or step (or more than 1000
/// levels), [`FieldError::Geometry`] if marching cubes fails.
pub fn layer_mesh(g: &SirenF64, problem: &MillingProblem<'_>, layer_step: f64, spacing: f64) -> Result<Mesh> {
    let block = problem.block();
    let ext = block.max - block.min;
    if !(spacing.is_finite() && spacing > 0.0 && layer_step.is_finite() && layer_step > 0.0) {
        return Err(FieldError::InvalidArgument(format!("bad spacing {spacing} or layer step {layer_step}")));
    }
    let dims = ext.map(|e| (e / spacing).ceil().max(1.0));
    if dims.iter().any(|&d| d > 512.0) {
        return Err(FieldError::InvalidArgument("layer lattice too fine (> 512 per side)".into()));
    }
    let spec = GridSpec::new(block, [dims.x as usize, dims.y as usize, dims.z as usize])
        .map_err(FieldError::geom)?;
    let nz = problem.normalization();
    let value = |p: &Point3| {
        let u = nz.to_unit(p);
        g.value([u.x, u.y, u.z])
    };
    let values: Vec<f64> = problem.poses().iter().map(value).collect();
    let top = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let bottom = values.iter().copied().fold(f64::INFINITY, f64::min);
    let h = gradient_step(g, problem, layer_step);
    let levels = ((top - bottom) / h).round();
    if !(levels.is_finite() && levels <= 1000.0) {
        return Err(FieldError::InvalidArgument("too many layers (> 1000)".into()));
    }
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for k in 0..=levels as usize {
        let level = top - k as f64 * h;
        let m = s2g_geom::marching_cubes(&spec, level, value).map_err(FieldError::geom)?;
        let base = vertices.len() as u32;
        for t in m.triangles() {
            let v = t.map(|i| m.vertices()[i as usize]);
            let c = Point3::from((v[0].coords + v[1].coords + v[2].coords) / 3.0);
            if problem.part().distance(&c) >= 0.0 {
                triangles.push(t.map(|i| i + base));
            }
        }
        vertices.extend_from_slice(m.vertices());
    }
    Mesh::new(vertices, triangles).map_err(FieldError::geom)
}

/// What [`simulate_program`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct ProgramSimulation {
    /// Removed voxels that belong to the part.
    pub gouge_voxels: u64,
    /// Voxels removed.
    pub removed_voxels: u64,
    /// Stock voxels outside the part (what rough milling may remove).
    pub removable_voxels: u64,
    /// `removed_voxels / removable_voxels`.
    pub removed_fraction: f64,
    /// Stock voxels met by the shank (summed over moves): the tool body touching material
    /// it does not cut.
    pub shank_collision_voxels: u64,
    /// Voxels removed by rapid moves.
    pub rapid_collision_voxels: u64,
    /// Moves simulated.
    pub moves: u64,
    /// Machining time, seconds.
    pub machining_time_s: f64,
}

/// Parses `program` with `options`' rotary axes and simulates it in `s2g-voxsim` on a
/// stock filling `block` (cubic voxels of edge about `voxel`), with the part `mesh`
/// voxelised on the same grid as the target for gouges, cutting with `tool`'s cutter
/// ([`Tool::cutter`]: flutes, shank and holder).
///
/// Errors: [`FieldError::InvalidArgument`] for a bad voxel size or block,
/// [`FieldError::Simulation`] for a program the parser or the simulator rejects.
pub fn simulate_program(
    program: &str,
    mesh: &Mesh,
    block: &Aabb,
    tool: &Tool,
    voxel: f64,
    options: &ProgramOptions,
) -> Result<ProgramSimulation> {
    options.validate()?;
    tool.validate()?;
    let ext = block.max - block.min;
    if !(voxel.is_finite() && voxel > 0.0 && ext.min() > 0.0 && ext.max().is_finite()) {
        return Err(FieldError::InvalidArgument(format!("bad voxel size {voxel} or block")));
    }
    let n = (ext.max() / voxel).ceil();
    if n > 1024.0 {
        return Err(FieldError::InvalidArgument("voxel grid too fine (> 1024 per side)".into()));
    }
    let spec = GridSpec::cubic(block, n as usize).map_err(FieldError::geom)?;
    let stock = VoxelGrid::full(spec);
    let target = voxelize(mesh, &spec).map_err(FieldError::geom)?;
    let removable = stock.count().saturating_sub(target.count());
    let mut sim = Simulator::new(stock, ToolTable::single(tool.cutter), SimOptions::default())
        .and_then(|s| s.with_target(&target))
        .map_err(FieldError::Simulation)?;
    let popts =
        ParseOptions { stop_at_first_error: true, rotary: Some(options.rotary), ..Default::default() };
    s2g_gcode::parse_str(program, &popts, &mut sim).map_err(|e| FieldError::Simulation(e.into()))?;
    let sim = sim.into_simulation().map_err(FieldError::Simulation)?;
    let r = sim.report();
    Ok(ProgramSimulation {
        gouge_voxels: r.gouge_voxels,
        removed_voxels: r.removed_voxels,
        removable_voxels: removable,
        removed_fraction: if removable > 0 { r.removed_voxels as f64 / removable as f64 } else { 0.0 },
        shank_collision_voxels: r.holder_collision_voxels,
        rapid_collision_voxels: r.rapid_collision_voxels,
        moves: r.moves,
        machining_time_s: r.machining_time_s,
    })
}

/// Everything [`mill_mesh`] does, with the defaults of the cup example.
#[derive(Debug, Clone, PartialEq)]
pub struct MillOptions {
    /// The tool (its cutter is the one the program is checked and simulated with), and
    /// its point sampling for the collision loss and the checks. Default
    /// [`Tool::cylinder`]`(2.5, 40.0)` (10 mm of flutes), rings from 3 mm every 2 mm with
    /// 24 points.
    pub tool: Tool,
    /// Spacing of the pose grid. Default `3.0`.
    pub grid: f64,
    /// Poses lie at least `tool.radius() + margin` from the part. Default `0.5`.
    pub margin: f64,
    /// The block (stock) is the part's bounding box grown by this much along X and Y.
    /// Default `6.0`.
    pub stock_side: f64,
    /// ... and by this much on top (the bottom stays flush with the part's). Default `2.0`.
    pub stock_top: f64,
    /// The layer optimisation. Default
    /// [`LayerOptions::default`](crate::LayerOptions::default) with 600 steps, batches of
    /// 192 and the check tool [`MillOptions::tool`].
    pub layers: crate::milling::LayerOptions,
    /// The program. Default [`ProgramOptions::default`].
    pub program: ProgramOptions,
    /// Voxel edge of the simulation. Default `1.0`.
    pub voxel: f64,
    /// Extract the layers as a mesh on a lattice of this spacing ([`layer_mesh`]). Default
    /// `None`.
    pub layers_mesh: Option<f64>,
}

impl Default for MillOptions {
    fn default() -> Self {
        let tool = Tool { axial_step: 2.0, ring_points: 24, ..Tool::default() };
        Self {
            tool,
            grid: 3.0,
            margin: 0.5,
            stock_side: 6.0,
            stock_top: 2.0,
            layers: crate::milling::LayerOptions {
                steps: 600,
                batch_size: 192,
                check_tool: Some(tool),
                ..Default::default()
            },
            program: ProgramOptions::default(),
            voxel: 1.0,
            layers_mesh: None,
        }
    }
}

/// What [`mill_mesh`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct MillReport {
    /// The block milled.
    pub block: Aabb,
    /// Sampled tool poses colliding on the planar layers (before).
    pub collisions_before: crate::milling::CollisionCount,
    /// ... and on the optimised layers (after).
    pub collisions_after: crate::milling::CollisionCount,
    /// The optimisation.
    pub optimisation: crate::milling::LayerReport,
    /// The program from the optimised layers.
    pub program: MillProgram,
    /// Its simulation.
    pub simulation: ProgramSimulation,
    /// The layers as a mesh ([`layer_mesh`]), when [`MillOptions::layers_mesh`] asks.
    pub layers: Option<Mesh>,
    /// The optimised layer field (host copy).
    pub field: SirenF64,
    /// Wall-clock seconds of the whole run (pretraining, checks, program, simulation).
    pub seconds: f64,
}

/// The milling application end to end (§4.2, §7.4 of seed 002): the part `mesh` in a
/// block, planar layers, Eq. 40 with the repair rounds, the five-axis program from the
/// optimised layers ([`mill_program`]) and its simulation ([`simulate_program`]).
///
/// Errors: those of the steps ([`FieldError::EmptyMesh`], [`FieldError::InvalidConfig`],
/// [`FieldError::InvalidArgument`], ...).
pub fn mill_mesh(mesh: &Mesh, options: &MillOptions) -> Result<MillReport> {
    let start = std::time::Instant::now();
    // Refuse bad options before the long optimisation, not after it.
    options.tool.validate()?;
    options.layers.validate()?;
    options.program.validate()?;
    if !(options.voxel.is_finite() && options.voxel > 0.0) {
        return Err(FieldError::InvalidArgument(format!("bad voxel size {}", options.voxel)));
    }
    if let Some(spacing) = options.layers_mesh
        && !(spacing.is_finite() && spacing > 0.0)
    {
        return Err(FieldError::InvalidArgument(format!("bad layer lattice spacing {spacing}")));
    }
    let part = crate::mesh_sdf::MeshSdf::new(mesh)?;
    let bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
    let grow = [options.stock_side, options.stock_top];
    if !grow.iter().all(|v| v.is_finite() && *v >= 0.0) {
        return Err(FieldError::InvalidArgument("stock margins must be finite and >= 0".into()));
    }
    let side = Vector3::new(options.stock_side, options.stock_side, 0.0);
    let block = Aabb::new(bbox.min - side, bbox.max + side + Vector3::new(0.0, 0.0, options.stock_top));
    let problem = MillingProblem::new(&part, block, options.tool, options.grid, options.margin)?;
    let planar = crate::milling::pretrain_planar(&options.layers)?;
    let check_tool = options.layers.check_tool.unwrap_or(options.tool);
    let before = crate::milling::count_collisions(&planar.to_f64()?, &problem, &check_tool)?;
    let (g, report) = crate::milling::optimize_layers(planar, &problem, &options.layers)?;
    let g = g.to_f64()?;
    let after = match report.collisions {
        Some(c) => c,
        None => crate::milling::count_collisions(&g, &problem, &check_tool)?,
    };
    let program = mill_program(&g, &problem, &options.program)?;
    let layers = match options.layers_mesh {
        Some(spacing) => Some(layer_mesh(&g, &problem, options.program.layer_step, spacing)?),
        None => None,
    };
    let simulation =
        simulate_program(&program.text, mesh, &block, &options.tool, options.voxel, &options.program)?;
    Ok(MillReport {
        block,
        collisions_before: before,
        collisions_after: after,
        optimisation: report,
        program,
        simulation,
        layers,
        field: g,
        seconds: start.elapsed().as_secs_f64(),
    })
}
