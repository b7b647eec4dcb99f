//! The 3+2 rotary layout: one program for every setup, each placed by rotary words.

use std::io::{BufRead, Read};
use std::time::Instant;

use super::api::{MillError, SetupProgram, Stage, StageSeconds};
use super::per_setup::{Ctx, simulating};
use super::pipe::read_from_buffer;
use crate::gcode::{
    GcodeWriter, Motion, MotionSink, ParseOptions, RotaryAxes, Transformed, WriteError, WriterOptions,
    parse_reader, rotary_angles, rotary_frame,
};
use crate::geom::{Isometry3, Point3, Rotation3, Setup, Vector3};
use crate::toolpath::{PlanSummary, VoxelMaterial, plan_setup_rest};
use crate::trace::PathTrace;

/// How a setup is put under the spindle of a table-table machine.
#[derive(Debug, Clone, Copy)]
pub(super) struct Placement {
    /// The kinematic frame of `angles` (program to part).
    pub(super) frame: Isometry3,
    /// `[A, B, C]` in degrees, rounded to the program's decimals.
    pub(super) angles: [f64; 3],
    /// Planning-frame coordinates to program coordinates: a turn about Z (and the planning
    /// frame's translation), so that XY arcs stay XY arcs.
    pub(super) to_program: Isometry3,
}

impl Placement {
    /// The placement of `setup` (0-based `index`) under `axes` with the tilt axis limited
    /// to `range` degrees, or [`MillError::Unreachable`].
    pub(super) fn new(
        axes: RotaryAxes,
        setup: &Setup,
        range: [f64; 2],
        decimals: usize,
        index: usize,
    ) -> Result<Self, MillError> {
        let (li, letter) = match axes {
            RotaryAxes::AC => (0, 'A'),
            RotaryAxes::BC => (1, 'B'),
        };
        let solved = rotary_angles(axes, &setup.frame);
        let (tilt, c) = (solved[li], solved[2]);
        let q = 10f64.powi(decimals as i32);
        let round = |v: f64| (v * q).round() / q;
        // C in (-180, 180] after rounding.
        let wrap = |v: f64| {
            let v = round(v);
            if v > 180.0 {
                v - 360.0
            } else if v <= -180.0 {
                v + 360.0
            } else {
                v
            }
        };
        // The same tool axis with the tilt's sign flipped: Rz(C + 180) Rx(-θ) = Rz(C) Rx(θ) Rz(180).
        let [lo, hi] = range;
        let (tilt, c) = [(round(tilt), wrap(c)), (round(-tilt), wrap(c + 180.0))]
            .into_iter()
            .find(|(t, _)| (lo..=hi).contains(t))
            .ok_or_else(|| {
                let t = setup.tool_axis();
                MillError::Unreachable {
                    setup: index + 1,
                    tool_axis: [t.x, t.y, t.z],
                    letter,
                    tilt_deg: tilt,
                    range_deg: range,
                }
            })?;
        let mut angles = [0.0; 3];
        angles[li] = tilt;
        angles[2] = c;
        let frame = rotary_frame(axes, angles);
        // frame * program = setup.frame * planned; up to the rounding of the angles the
        // difference is a turn about Z: keep exactly that, from where it sends +X.
        let d = frame.inverse() * setup.frame;
        let x = d.rotation * Vector3::x();
        let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), x.y.atan2(x.x));
        Ok(Self { frame, angles, to_program: Isometry3::from_parts(d.translation, turn) })
    }
}

/// One section of the rotary program, as written.
pub(super) struct Section {
    /// Its first line in the program (1-based).
    pub(super) first_line: u64,
    /// Its bytes in the program.
    pub(super) bytes: std::ops::Range<usize>,
    /// Target voxels removed before the parser reached it.
    pub(super) gouges_before: u64,
    pub(super) plan: PlanSummary,
}

/// The one 3+2 program, written setup by setup *while the parser reads it*: when the
/// parser has read every line so far (so the simulator has seen every move before them),
/// the next setup is planned against the material the simulator left and its section is
/// appended. So the program is parsed in one pass, with the modal state a controller
/// would carry, and every setup is still planned against the simulated rest material.
pub(super) struct RotarySource<'a, 'p> {
    pub(super) ctx: &'a Ctx<'a>,
    pub(super) axes: RotaryAxes,
    pub(super) placements: &'a [Placement],
    pub(super) turn_z: f64,
    pub(super) progress: &'p mut dyn FnMut(Stage),
    pub(super) text: String,
    pub(super) pos: usize,
    pub(super) lines: u64,
    pub(super) sections: Vec<Section>,
    /// The last programmed point, in program coordinates.
    pub(super) last: Option<Point3>,
    pub(super) error: Option<MillError>,
    pub(super) plan_seconds: f64,
}

impl RotarySource<'_, '_> {
    pub(super) fn write_next(&mut self) -> Result<(), MillError> {
        let i = self.sections.len();
        let (job, place) = (&self.ctx.jobs[i], &self.placements[i]);
        let remaining = self.ctx.excess()?;
        let gouges_before = self.ctx.sim.borrow().report().gouge_voxels;
        (self.progress)(Stage::GcodeTranslation { setup: i + 1, setups: self.ctx.jobs.len() });
        let t = Instant::now();
        let program_err = |what: &str, e: WriteError| MillError::program(i + 1, what, e);
        // A writer per section, so that its text is complete when the parser needs it; the
        // first writes the header, the last the footer, and every axis word and feed is
        // stated again after a rotation anyway.
        let wopts = WriterOptions {
            rotary: Some(self.axes),
            header: i == 0,
            footer: i + 1 == self.ctx.jobs.len(),
            ..self.ctx.wopts.clone()
        };
        let mut writer = GcodeWriter::new(Vec::new(), self.ctx.dialect, wopts);
        // Safe retract before the rotation: straight up from where the tool is (above the
        // origin before the first), high enough for the stock to turn under it.
        let from = self.last.unwrap_or_else(Point3::origin);
        let up = Point3::new(from.x, from.y, self.turn_z);
        writer.motion(&Motion::Rapid { to: up }).map_err(|e| program_err("writing the program", e))?;
        let rest = VoxelMaterial::new(&remaining, job.setup);
        let a = place.angles;
        let mut sink = Transformed::new(&mut writer, place.to_program)
            .with_setup(place.frame, [Some(a[0]), Some(a[1]), Some(a[2])]);
        let plan = plan_setup_rest(self.ctx.part, &job.setup, &job.tool, &job.popts, Some(&rest), &mut sink)
            .map_err(|source| MillError::Plan { setup: i + 1, source })?;
        self.last = Some(sink.last_point().unwrap_or(up));
        writer.finish().map_err(|e| program_err("writing the program", e))?;
        let mut text = String::from_utf8(writer.into_inner())
            .map_err(|e| MillError::program(i + 1, "reading the program's text", e))?;
        if i > 0 {
            // Each section's writer counts its setup as the first.
            text = text.replacen("SETUP 1: ", &format!("SETUP {}: ", i + 1), 1);
        }
        let start = self.text.len();
        self.text.push_str(&text);
        self.sections.push(Section {
            first_line: self.lines + 1,
            bytes: start..self.text.len(),
            gouges_before,
            plan,
        });
        self.lines += text.lines().count() as u64;
        self.plan_seconds += t.elapsed().as_secs_f64();
        (self.progress)(Stage::Simulation { setup: i + 1, setups: self.ctx.jobs.len() });
        Ok(())
    }
}

impl Read for RotarySource<'_, '_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        read_from_buffer(self, buf)
    }
}

impl BufRead for RotarySource<'_, '_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        if self.pos == self.text.len()
            && self.sections.len() < self.ctx.jobs.len()
            && self.error.is_none()
            && let Err(e) = self.write_next()
        {
            let message = e.to_string();
            self.error = Some(e);
            return Err(std::io::Error::other(message));
        }
        Ok(&self.text.as_bytes()[self.pos..])
    }

    fn consume(&mut self, n: usize) {
        self.pos = (self.pos + n).min(self.text.len());
    }
}

/// One 3+2 program for all setups, parsed back in one pass with the rotary kinematics.
pub(super) fn mill_rotary(
    ctx: &Ctx<'_>,
    axes: RotaryAxes,
    placements: &[Placement],
    turn_z: f64,
    trace: &mut PathTrace,
    times: &mut StageSeconds,
    progress: &mut dyn FnMut(Stage),
) -> Result<Vec<SetupProgram>, MillError> {
    let t = Instant::now();
    let mut source = RotarySource {
        ctx,
        axes,
        placements,
        turn_z,
        progress,
        text: String::new(),
        pos: 0,
        lines: 0,
        sections: Vec::new(),
        last: None,
        error: None,
        plan_seconds: 0.0,
    };
    let popts = ParseOptions { rotary: Some(axes), ..ParseOptions::default() };
    let mut tee = simulating(ctx.sim, Some(trace));
    let parsed = parse_reader(&mut source, &popts, &mut tee);
    let section_of = |sections: &[Section], line: u64| sections.iter().rposition(|s| s.first_line <= line);
    let summary = match parsed {
        Ok(summary) => summary,
        Err(e) => {
            let setup = source.sections.len().max(1);
            return Err(source
                .error
                .take()
                .unwrap_or_else(|| MillError::program(setup, "re-reading the program", e)));
        }
    };
    if let Some(err) = summary.errors.first() {
        let setup = section_of(&source.sections, err.line).map_or(1, |s| s + 1);
        return Err(MillError::program(setup, "re-reading the program", err.clone()));
    }
    if source.sections.len() < ctx.jobs.len() {
        return Err(MillError::Program {
            setup: source.sections.len() + 1,
            what: "re-reading the program: it ended before this setup".into(),
            source: None,
        });
    }
    // The parser finished the simulator, so its report is complete.
    let sim = ctx.sim.borrow();
    let report = sim.report();
    let mut setups = Vec::with_capacity(ctx.jobs.len());
    for (i, (sec, job)) in source.sections.iter().zip(ctx.jobs).enumerate() {
        let next = source.sections.get(i + 1);
        let gouges_after = next.map_or(report.gouge_voxels, |n| n.gouges_before);
        let lines = sec.first_line..next.map_or(u64::MAX, |n| n.first_line);
        setups.push(SetupProgram {
            setup: Setup { frame: placements[i].frame },
            action: job.action,
            tool: job.tool,
            // The one program runs through setups without stopping: it is timed whole.
            machine_time_s: None,
            plan: sec.plan.clone(),
            text: source.text[sec.bytes.clone()].to_owned(),
            rotary_deg: Some(placements[i].angles),
            lines: next.map_or(source.lines + 1, |n| n.first_line) - sec.first_line,
            gouge_voxels: gouges_after - sec.gouges_before,
            rapid_collision_lines: report
                .rapid_collision_lines
                .iter()
                .copied()
                .filter(|l| lines.contains(l))
                .collect(),
            holder_collision_lines: report
                .holder_collisions
                .iter()
                .copied()
                .filter(|l| lines.contains(l))
                .collect(),
            preservation: 1.0,
            rest_of: None,
            finish: None,
        });
    }
    times.gcode_translation += source.plan_seconds;
    times.simulation += (t.elapsed().as_secs_f64() - source.plan_seconds).max(0.0);
    Ok(setups)
}
