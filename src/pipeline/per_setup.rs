//! The per-setup layout: each setup planned, written, parsed back and simulated as its own
//! 3-axis program; the sink that feeds the simulator and records the path.

use std::cell::RefCell;
use std::collections::BTreeSet;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::api::{MillError, SetupFinish, SetupProgram, Stage, StageSeconds};
use super::finish_scope::{FinishScope, prismatic_normal, sculpted_contact};
use super::job::Job;
use super::pipe::{ChunkWriter, chunk_channel};
use super::rest_finish::Unfinished;
use crate::gcode::{
    Dialect, GcodeWriter, MachineProfile, MachineTime, Motion, MotionSink, ParseOptions, SinkThread, Tee,
    ToolChange, WriterOptions, parse_reader,
};
use crate::geom::{Mesh, MeshIndex, Point3, Setup, VoxelGrid};
use crate::toolpath::finish::{
    FinishOptions, FinishPaths, FinishSummary, KeepPoint, LeftOut, finish_paths, finish_setup_paths,
    part_in_setup_frame,
};
use crate::toolpath::undercut::{Undercut, plan_undercut};
use crate::toolpath::{PlanProgress, PlanSummary, VoxelMaterial, plan_setup_watched};
use crate::trace::PathTrace;
use crate::voxsim::{
    DeviationOptions, HeightField, HeightFieldOptions, Simulator, ToolTable, deviation_at,
    surface_deviation_opt, surface_deviation_where,
};

/// What both layouts share.
pub(super) struct Ctx<'a> {
    pub(super) part: &'a Mesh,
    /// The part's voxels on the simulation grid.
    pub(super) target: &'a VoxelGrid,
    pub(super) jobs: &'a [Job],
    pub(super) sim: &'a RefCell<Simulator>,
    /// Number of setups of the run (`jobs` may hold only those chosen so far).
    pub(super) setups: usize,
    pub(super) dialect: Dialect,
    pub(super) wopts: &'a WriterOptions,
    /// Keep the per-setup programs' text ([`MillRun::keep_programs`]).
    pub(super) keep_programs: bool,
    /// Where the per-setup programs are written ([`MillRun::stream_programs`]).
    pub(super) outputs: Option<&'a ProgramOutputs>,
    /// When the run must have finished, and its limit in seconds.
    pub(super) deadline: Option<(Instant, f64)>,
    /// The machine that times each program, where the run has one (a library's).
    pub(super) machine: Option<&'a MachineProfile>,
    /// Column spacing of the finished surface's height field.
    pub(super) surface_spacing: f64,
    /// What the finished surface is measured against ([`FinishingPart`]).
    pub(super) finishing_part: &'a FinishingPart,
}

/// What a finishing run measures its finished surface against: the part's surface samples
/// (point, outward normal; part frame) at which the deviation is measured
/// ([`PartDeviation`](super::api::PartDeviation)), and whether the part is closed and
/// consistently wound ([`DeviationOptions::closed_part`]); no samples and not closed where
/// the run does not finish.
#[derive(Clone)]
pub(super) struct FinishingPart {
    pub(super) samples: Vec<(Point3, crate::geom::Vector3)>,
    pub(super) closed: bool,
}

impl FinishingPart {
    pub(super) fn new(part: &Mesh, opts: &super::api::MillOptions) -> Result<Self, MillError> {
        if opts.finish.is_none() {
            return Ok(Self { samples: Vec::new(), closed: false });
        }
        let s = crate::geom::sample_surface(part, super::api::PartDeviation::SAMPLES, opts.seed ^ 0xde71)?;
        let r = crate::geom::report(part);
        Ok(Self {
            samples: s.points.into_iter().zip(s.normals).collect(),
            closed: r.closed && r.consistently_oriented,
        })
    }
}

/// Opens the writer of each per-setup program ([`MillRun::stream_programs`]).
pub(super) type ProgramOutputs =
    Arc<dyn Fn(usize) -> std::io::Result<Box<dyn std::io::Write + Send>> + Send + Sync>;

impl Ctx<'_> {
    /// The material still to cut: the simulated stock less the part. The part is never
    /// cut, so counting it as material would make later setups trace the finished walls
    /// again in air (rest machining skips what is gone, not what must stay).
    pub(super) fn excess(&self) -> Result<VoxelGrid, MillError> {
        let mut g = self.sim.borrow_mut().residual_grid();
        g.andnot(self.target).map_err(|e| MillError::Simulation(e.into()))?;
        Ok(g)
    }
}

pub(super) fn sim_error(e: crate::voxsim::SimError) -> MillError {
    MillError::Simulation(e)
}

/// Setup `i` as its own 3-axis program: plans it against `remaining`, writes it, parses the
/// text back into the simulator. Returns the setup's program and the material left after it.
///
/// With `finish_if`, a finished setup's finishing is tentative: once its roughing is
/// simulated, `finish_if` is asked (the simulator holds the roughing's outcome then) and
/// the program goes on with the finishing where it says yes, else ends after the roughing,
/// as it would have without the finishing. Either way the program is planned, written and
/// simulated once.
pub(super) fn machine_setup(
    ctx: &Ctx<'_>,
    i: usize,
    remaining: &VoxelGrid,
    trace: Option<&mut PathTrace>,
    times: &mut StageSeconds,
    progress: &mut dyn FnMut(Stage),
    finish_if: Option<FinishIf<'_>>,
) -> Result<(SetupProgram, VoxelGrid), MillError> {
    let job = &ctx.jobs[i];
    let setups = ctx.setups;
    progress(Stage::GcodeTranslation { setup: i + 1, setups });
    let t = Instant::now();
    // The simulator's counts so far (flushed after the previous setup) are earlier programs'.
    let (gouges_before, rapids_before, holders_before) = sim_counts(ctx);
    let mut tee = simulating(ctx.sim, trace);
    tee.first.clock = ctx.machine.map(|m| MachineTime::new(m.clone()));
    let finishing = prepare_finishing(ctx, job, i, &mut tee.first)?;
    // A 3-axis program per setup: the fixture rotation is in its header comment,
    // so the simulator is told the frame here.
    tee.motion(&Motion::Setup { frame: job.setup.frame, rotary: [None; 3] }).map_err(sim_error)?;
    // Without a tool changer (grbl) the program pauses (`M0`) for the operator to fit the
    // tool it names in a comment: the simulator is told that tool here, as it is told the
    // fixture's frame, or it would cut with the one before.
    if ctx.dialect.spec().tool_change == ToolChange::Pause {
        tee.motion(&Motion::ToolChange { tool: job.tool.number }).map_err(sim_error)?;
    }
    // The planner writes the program on its own thread while this one parses it back
    // and simulates it, chunk by chunk: planning and simulation overlap, and the text is
    // held whole only when it is kept.
    let (part, dialect, mut wopts, keep) = (ctx.part, ctx.dialect, ctx.wopts.clone(), ctx.keep_programs);
    // A shop's programs (those that select a work offset) are numbered per setup, so that
    // a Fanuc control holds them side by side (O0001, O0002, ...).
    if wopts.work_offset.is_some() {
        wopts.program_number = u32::try_from(i + 1).unwrap_or(u32::MAX).min(9999);
    }
    let copy = ctx.outputs.map(|open| open(i)).transpose();
    let copy = copy.map_err(|e| MillError::program(i + 1, "opening the program's output", e))?;
    // A finished setup's roughing cuts all that remains, the finisher's skin too: the
    // link's rapids rest on the levels above having cut it (ARCHITECTURE.md, finishing).
    let watch = PlanProgress::default();
    let mut tee = Tee::new(tee.first.watching(&mut *progress, &watch, i + 1, setups), tee.second);
    // The answer to `finish_if`, from the reader's checkpoint to the planner.
    let (verdict_tx, verdict) = match finish_if {
        Some(f) => {
            let (tx, rx) = std::sync::mpsc::channel();
            (Some((f, tx)), Some(rx))
        }
        None => (None, None),
    };
    // Set once the finishing planned beside the roughing is not wanted.
    let (stop_early, certain) = (AtomicBool::new(false), verdict.is_none());
    let (planned, parsed, waited) = std::thread::scope(|scope| {
        let (mut out, mut reader) = chunk_channel(keep);
        out.copy = copy;
        reader.deadline = ctx.deadline.map(|(at, _)| at);
        reader.checkpoint = verdict_tx.map(|(finish_if, tx)| {
            Box::new(move || {
                // A planner gone (it failed) needs no answer.
                let _ = tx.send(finish_if());
            }) as Box<dyn FnMut() + '_>
        });
        let (watch, finishing) = (&watch, &finishing);
        let early = plan_beside(scope, job, finishing, i, certain, &stop_early);
        let planner = scope.spawn(move || {
            let writer = GcodeWriter::new(out, dialect, wopts);
            let fin = (finishing.as_ref(), early);
            write_program(part, job, remaining, fin, writer, watch, verdict, i)
        });
        let parsed = parse_reader(&mut reader, &ParseOptions::default(), &mut tee);
        // A planner still waiting at a checkpoint (the program ended before it) is told no.
        reader.checkpoint = None;
        if parsed.is_ok() {
            // The parser stops at the program end; the writer may still send what follows.
            while reader.rx.recv().is_ok() {}
        }
        let waited = reader.waited;
        // Hanging up stops a planner whose program is no longer read, and cancelling
        // stops one that is still planning a batch of layers.
        drop(reader);
        watch.cancel();
        let planned = planner.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        stop_early.store(true, Ordering::Relaxed);
        (planned, parsed, waited)
    });
    let mut clock = tee.first.clock.take();
    let (surface, split_s) = (tee.first.surface.take(), tee.first.split_s);
    if let (Some((at, limit_s)), Err(_)) = (ctx.deadline, &parsed)
        && Instant::now() >= at
    {
        return Err(MillError::TimeLimit {
            stage: format!("planning and simulating setup {} of {setups}", i + 1),
            limit_s,
        });
    }
    let ((plan, finished), text, planning) = match planned {
        Ok(done) => done,
        // A parser that stopped hung up on the planner: its error is the cause.
        Err(e) => {
            return Err(match parsed {
                Err(p) => MillError::program(i + 1, "re-reading the program", p),
                Ok(_) => e,
            });
        }
    };
    let text =
        String::from_utf8(text).map_err(|e| MillError::program(i + 1, "reading the program's text", e))?;
    // Planning ran beside the simulation: each stage counts the time its side was busy.
    times.gcode_translation += planning.as_secs_f64();
    progress(Stage::Simulation { setup: i + 1, setups });
    let summary = parsed.map_err(|e| MillError::program(i + 1, "re-reading the program", e))?;
    if let Some(err) = summary.errors.first() {
        return Err(MillError::program(i + 1, "re-reading the program", err.clone()));
    }
    let surface = surface.map(SinkThread::join).transpose();
    let surface = surface.map_err(|e| MillError::program(i + 1, "re-reading the program", e))?;
    // Flushes the simulator, so its report is complete for this setup.
    let remaining = ctx.excess()?;
    let sim = ctx.sim.borrow();
    let report = sim.report();
    let gouge_voxels = report.gouge_voxels - gouges_before;
    // The simulator keeps one set of lines over all programs; this setup's are the new
    // ones (a line number that already collided in an earlier program is not repeated).
    let rapid_collision_lines = new_lines(&report.rapid_collision_lines, &rapids_before);
    let holder_collision_lines = new_lines(&report.holder_collisions, &holders_before);
    times.simulation += t.elapsed().saturating_sub(waited).as_secs_f64();
    let machine_time_s = clock.as_mut().map(|c| {
        let Ok(()) = c.finish();
        c.seconds()
    });
    let fin = (finished, surface, finishing);
    let finish = finish_result(job, fin, split_s, machine_time_s, &plan, ctx, times);
    let program = SetupProgram {
        setup: job.setup,
        action: job.action,
        tool: job.tool,
        machine_time_s,
        plan,
        text,
        rotary_deg: None,
        lines: summary.lines,
        gouge_voxels,
        rapid_collision_lines,
        holder_collision_lines,
        preservation: 1.0,
        finish,
        rest_of: None,
    };
    Ok((program, remaining))
}

/// What [`machine_setup`]'s planner thread does: plans setup `i`'s `job` against
/// `remaining` into `writer` (its roughing, then its finishing where `verdict` says so,
/// [`finish_follows`]); returns the plans, the text kept and the time spent planning.
#[allow(clippy::too_many_arguments)]
fn write_program(
    part: &Mesh,
    job: &Job,
    remaining: &VoxelGrid,
    (finishing, early): (Option<&Finishing>, Option<EarlyFinish<'_>>),
    mut writer: GcodeWriter<ChunkWriter>,
    watch: &PlanProgress,
    verdict: Option<std::sync::mpsc::Receiver<bool>>,
    i: usize,
) -> Result<Planned, MillError> {
    let t = Instant::now();
    let rest = VoxelMaterial::new(remaining, job.setup);
    if let Some(note) = &job.note {
        writer
            .motion(&Motion::Comment(note.as_str().into()))
            .map_err(|e| MillError::program(i + 1, "writing the program", e))?;
    }
    let plan = match &job.undercut {
        // An undercut pass: the T-slot cutter's contours at its levels.
        Some(u) => {
            let Some(stock) = job.popts.stock else {
                return Err(MillError::InvalidOption("an undercut pass needs its stock box".into()));
            };
            let (setup, tool, levels) = (&job.setup, &job.tool, &u.levels);
            let pass = Undercut { columns: &u.columns, setup, tool, stock: &stock, rest: &rest, levels };
            plan_undercut(&pass, &u.opts, &mut writer)
        }
        None => plan_setup_watched(part, &job.setup, &job.tool, &job.popts, Some(&rest), &mut writer, watch),
    }
    .map_err(|source| MillError::Plan { setup: i + 1, source })?;
    // The finishing follows the roughing in the same program.
    let finished = match finish_follows(&mut writer, verdict, i)? {
        true => {
            // Waiting for the passes planned beside the roughing counts as planning.
            let planned = match early {
                Some((h, _)) => h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))?,
                None => plan_finishing(job, finishing, i, None)?,
            };
            emit_finishing(job, finishing, planned, &mut writer, i)?
        }
        // Passes planned for a finishing that does not follow are stopped and dropped.
        false => {
            if let Some((_, stop)) = early {
                stop.store(true, Ordering::Relaxed);
            }
            None
        }
    };
    writer.finish().map_err(|e| MillError::program(i + 1, "writing the program", e))?;
    let (text, blocked) =
        writer.into_inner().finish().map_err(|e| MillError::program(i + 1, "writing the program", e))?;
    Ok(((plan, finished), text, t.elapsed().saturating_sub(blocked)))
}

/// The thread planning setup `i`'s finishing passes from the setup's start beside its
/// roughing ([`plan_finishing_aside`]), where it has them and they are `certain` to
/// follow, stopped by `stop`. Only a finishing sure to follow: one a verdict may call off (a rest
/// pass then carries it, planned anew) would cost its planning for nothing, and planned
/// beside the roughing most of it is done before the verdict (1.5-2 s of CPU on the turned
/// shaft). `machine_setup` sets `stop` once its planner is done, and joins the height
/// field's thread ([`SinkThread::join`]) once the program is parsed.
fn plan_beside<'scope>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    job: &'scope Job,
    finishing: &'scope Option<Finishing>,
    i: usize,
    certain: bool,
    stop: &'scope AtomicBool,
) -> Option<EarlyFinish<'scope>> {
    let fin = finishing.as_ref().filter(|_| certain)?;
    Some((scope.spawn(move || plan_finishing_aside(job, Some(fin), i, stop)), stop))
}

/// With the flag that stops it.
type EarlyFinish<'scope> =
    (std::thread::ScopedJoinHandle<'scope, Result<Option<FinishPaths>, MillError>>, &'scope AtomicBool);

/// A setup's plans (roughing, finishing), its text where kept, and the planning time.
type Planned = ((PlanSummary, Option<(FinishSummary, LeftOut)>), Vec<u8>, std::time::Duration);

/// What [`machine_setup`] asks, once a setup's roughing is simulated, whether its
/// finishing follows.
pub(super) type FinishIf<'a> = &'a mut dyn FnMut() -> bool;

/// Whether the finishing follows the roughing `writer` has written: without a `verdict`
/// to wait for it does; with one, the roughing is passed on whole with a checkpoint after
/// it, and the answer the reader sends from there, once it has simulated the roughing,
/// says (a reader gone says no).
fn finish_follows(
    writer: &mut GcodeWriter<ChunkWriter>,
    verdict: Option<std::sync::mpsc::Receiver<bool>>,
    i: usize,
) -> Result<bool, MillError> {
    let Some(verdict) = verdict else { return Ok(true) };
    writer.flush_blocks().map_err(|e| MillError::program(i + 1, "writing the program", e))?;
    let out = writer.get_mut();
    out.checkpoint().map_err(|e| MillError::program(i + 1, "writing the program", e))?;
    // Waiting for the reader is not planning.
    let t = Instant::now();
    let yes = verdict.recv().unwrap_or(false);
    out.blocked += t.elapsed();
    Ok(yes)
}

/// The lines of `now` not in `before`.
fn new_lines(now: &[u64], before: &BTreeSet<u64>) -> Vec<u64> {
    now.iter().copied().filter(|l| !before.contains(l)).collect()
}

/// The simulator's gouge count, rapid-collision and holder-collision lines so far.
fn sim_counts(ctx: &Ctx<'_>) -> (u64, BTreeSet<u64>, BTreeSet<u64>) {
    let sim = ctx.sim.borrow();
    let r = sim.report();
    (
        r.gouge_voxels,
        r.rapid_collision_lines.iter().copied().collect(),
        r.holder_collisions.iter().copied().collect(),
    )
}

/// The part in the program's frame, for the finisher's drop-cutter and the finished
/// surface's height field (which the watcher feeds the finishing moves, after the
/// finishing tool change), and the finisher's options; `None` for a setup roughed only.
fn prepare_finishing(
    ctx: &Ctx<'_>,
    job: &Job,
    i: usize,
    watcher: &mut Watcher<'_>,
) -> Result<Option<Finishing>, MillError> {
    Ok(match &job.finish {
        Some(f) => {
            let mesh = part_in_setup_frame(ctx.part, &job.setup);
            let b = mesh.bbox().ok_or(crate::geom::GeomError::EmptyMesh)?;
            let index = MeshIndex::new(&mesh)?;
            let (lo, hi) = (b.min, b.max);
            let m = f.tool.radius() + ctx.surface_spacing;
            let tools = ToolTable::single(f.tool.cutter).with(f.tool.number, f.tool.cutter);
            // A feed passed over a column when its tip came within three quarters of the
            // raster's stepover of it: every column between two neighbouring passes is
            // nearer one of them than half a stepover (and the grid's half diagonal), a
            // column on a pass left out is a stepover from both. Steep-and-shallow's passes
            // lie nearer (its waterline levels at most 0.71 stepovers apart on the walls of
            // 45 degrees and more it gives them, its parallel passes 0.57); waterline alone
            // spaces its levels wider on gentler slopes, so its columns are not marked
            // (every one within reach counts).
            let stepover =
                crate::toolpath::finish::stepover_for_scallop(&f.tool.cutter, f.choice.scallop, 0.0)
                    .map_err(|source| MillError::Plan {
                        setup: i + 1,
                        source: crate::toolpath::ToolpathError::Finish(source),
                    })?;
            let hopts = HeightFieldOptions {
                spacing: ctx.surface_spacing,
                pass_width: (f.choice.strategy != crate::policy::FinishStrategyKind::Waterline)
                    .then_some(0.75 * stepover),
                ..HeightFieldOptions::default()
            };
            let mut field = HeightField::new_opt([lo.x - m, lo.y - m], [hi.x + m, hi.y + m], tools, &hopts)
                .map_err(sim_error)?;
            // Swept on a thread of its own, beside the simulator, every move there: handing
            // each long finishing move to rayon from the parser's thread cost a context
            // switch or two per move.
            field.set_parallel_columns(usize::MAX);
            watcher.surface = Some(SinkThread::spawn(field, SURFACE_BATCH, SURFACE_BATCHES));
            let rest = Unfinished::new(ctx.part, ctx.jobs, i)?;
            Some(Finishing { opts: job.finish_options(f, [lo.z, hi.z]), index, rest, stepover })
        }
        None => None,
    })
}

/// Motions per batch handed to the height field's thread, and batches waiting at most.
const SURFACE_BATCH: usize = 1024;
const SURFACE_BATCHES: usize = 8;

/// A setup's finishing, prepared ([`prepare_finishing`]).
pub(super) struct Finishing {
    opts: FinishOptions,
    /// The part in the setup's frame.
    index: MeshIndex,
    /// What earlier setups finished, left out here.
    rest: Option<Unfinished>,
    /// The raster's stepover for the choice's scallop on flat ground, the height field's
    /// marks are sized by.
    stepover: f64,
}

/// The passes of setup `i`'s (0-based) finishing, planned ([`finish_paths`]); `None` for
/// a setup roughed only.
fn plan_finishing(
    job: &Job,
    finishing: Option<&Finishing>,
    i: usize,
    cancel: Option<&AtomicBool>,
) -> Result<Option<FinishPaths>, MillError> {
    let (Some(f), Some(fin)) = (&job.finish, finishing) else {
        return Ok(None);
    };
    let strategy = f.choice.strategy.strategy();
    // Not where an earlier setup finished, and, where the roughing cut to size, only where
    // the ball touches a sculpted face.
    let sculpted = f.scope == FinishScope::Sculpted;
    let (radius, index, rest) = (f.tool.radius(), &fin.index, fin.rest.as_ref());
    let both = |tip: &Point3| {
        (!sculpted || sculpted_contact(index, tip, radius)) && rest.is_none_or(|r| r.keep(tip))
    };
    let keep = (sculpted || rest.is_some()).then_some(&both as &dyn KeepPoint);
    finish_paths(&fin.index, &f.tool, &*strategy, &fin.opts, keep, cancel)
        .map(Some)
        .map_err(|source| MillError::Plan { setup: i + 1, source: source.widen() })
}

/// [`plan_finishing`] on a rayon pool of its own, as many threads as the global one: run
/// beside the roughing's planner and simulator (which use the global pool), its work and
/// theirs share the cores by the system's scheduling instead of queueing behind each
/// other's jobs. On the global pool where no pool can be built. Stops early once `cancel`
/// is set (the finishing does not follow the roughing: a rest pass carries it).
fn plan_finishing_aside(
    job: &Job,
    finishing: Option<&Finishing>,
    i: usize,
    cancel: &AtomicBool,
) -> Result<Option<FinishPaths>, MillError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(rayon::current_num_threads())
        .thread_name(|k| format!("s2g-finish-{k}"))
        .build();
    match pool {
        Ok(pool) => pool.install(|| plan_finishing(job, finishing, i, Some(cancel))),
        Err(_) => plan_finishing(job, finishing, i, Some(cancel)),
    }
}

/// The finishing of setup `i` (0-based) into `writer`, after its roughing: the passes
/// `planned` ahead ([`plan_finishing_aside`], on its thread, while the roughing was written
/// and simulated), written ([`finish_setup_paths`]): the motions `finish_setup_left_out`
/// writes.
fn emit_finishing<W: std::io::Write>(
    job: &Job,
    finishing: Option<&Finishing>,
    planned: Option<FinishPaths>,
    writer: &mut GcodeWriter<W>,
    i: usize,
) -> Result<Option<(FinishSummary, LeftOut)>, MillError> {
    let (Some(f), Some(fin), Some(planned)) = (&job.finish, finishing, planned) else {
        return Ok(None);
    };
    let name = f.choice.strategy.strategy();
    finish_setup_paths(&fin.index, &job.setup, &f.tool, name.name(), &fin.opts, planned, writer)
        .map(Some)
        .map_err(|source| MillError::Plan { setup: i + 1, source })
}

/// A finished setup's report: its times split at the finishing tool change (the machine's,
/// else the planners' estimates) and the deviation of the surface its finishing cut.
fn finish_result(
    job: &Job,
    (finished, surface, finishing): (
        Option<(FinishSummary, LeftOut)>,
        Option<HeightField>,
        Option<Finishing>,
    ),
    split_s: Option<f64>,
    machine_time_s: Option<f64>,
    plan: &PlanSummary,
    ctx: &Ctx<'_>,
    times: &mut StageSeconds,
) -> Option<SetupFinish> {
    let (samples, closed_part) = (&ctx.finishing_part.samples, ctx.finishing_part.closed);
    match (&job.finish, finished, surface, finishing) {
        (
            Some(f),
            Some((summary, left_out)),
            Some(mut field),
            Some(Finishing { opts: fopts, index, rest, stepover }),
        ) => {
            let t = Instant::now();
            // The pass points the shank and holder check left out stand for a strip half
            // a stepover wide each side: the surface there is not reached, though the pass
            // beside it came within the field's pass width.
            field.leave_out(&left_out.stretches, 0.5 * stepover);
            // Over the surface the finishing tool can touch (a concave corner tighter than
            // it is not a region it reaches) and not below the finisher's floor (what its
            // tool reaches).
            let dopts = DeviationOptions {
                ball_radius: Some(f.tool.radius()),
                floor: fopts.floor,
                closed_part,
                ..DeviationOptions::default()
            };
            // Where this setup finishes: not where an earlier one did, and only on the
            // sculpted faces where the roughing cut to size.
            let sculpted = f.scope == FinishScope::Sculpted;
            let deviation = match (&rest, sculpted) {
                (None, false) => surface_deviation_opt(&field, &index, &dopts),
                _ => surface_deviation_where(&field, &index, &dopts, &|q, n| {
                    (!sculpted || !prismatic_normal(n)) && rest.as_ref().is_none_or(|r| r.keeps_contact(q, n))
                }),
            };
            // The run's surface samples in this setup's frame.
            let inv = job.setup.frame.inverse();
            let pts: Vec<(Point3, crate::geom::Vector3)> =
                samples.iter().map(|(p, n)| (inv * p, inv * n)).collect();
            let reached: Vec<f32> = deviation_at(&field, &index, &pts, &dopts)
                .into_iter()
                .map(|d| d.map_or(f32::NAN, |d| d as f32))
                .collect();
            times.surface += t.elapsed().as_secs_f64();
            let (roughing_time_s, finishing_time_s) = match machine_time_s {
                Some(total) => {
                    let split = split_s.unwrap_or(total);
                    (split, total - split)
                }
                None => (plan.estimated_time_s, summary.time_s),
            };
            Some(SetupFinish {
                choice: f.choice,
                tool: f.tool,
                summary,
                roughing_time_s,
                finishing_time_s,
                deviation,
                reached,
            })
        }
        _ => None,
    }
}

/// The run's simulator as a sink (in a `RefCell`: the run reads its report between setups).
pub(super) struct SimSink<'a>(pub(super) &'a RefCell<Simulator>);

impl MotionSink for SimSink<'_> {
    type Error = crate::voxsim::SimError;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        self.0.borrow_mut().motion(m)
    }
    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.0.borrow_mut().source_line(line)
    }
    fn finish(&mut self) -> Result<(), Self::Error> {
        self.0.borrow_mut().finish()
    }
}

/// What the simulator is fed through: the motions go to a [`Watcher`] first, then to the
/// simulator.
pub(super) type Simulating<'a> = Tee<Watcher<'a>, SimSink<'a>>;

/// The motions fed to the simulator, `trace` recording the first setup's path.
pub(super) fn simulating<'a>(
    sim: &'a RefCell<Simulator>,
    trace: Option<&'a mut PathTrace>,
) -> Simulating<'a> {
    Tee::new(
        Watcher {
            trace,
            frame: Setup::top(),
            setups: 0,
            last: None,
            watch: None,
            clock: None,
            tool_changes: 0,
            split_s: None,
            surface: None,
        },
        SimSink(sim),
    )
}

/// Watches the motions on their way to the simulator: records the first setup's path in
/// part units (the render's trace) and reports [`Stage::Layers`] progress.
pub(super) struct Watcher<'a> {
    pub(super) trace: Option<&'a mut PathTrace>,
    /// The current frame and how many setups have begun.
    pub(super) frame: Setup,
    pub(super) setups: usize,
    /// The last point, in the part frame and the program's (setup) frame.
    pub(super) last: Option<(Point3, Point3)>,
    /// Where to report [`Stage::Layers`] ([`Watcher::watching`]).
    pub(super) watch: Option<Watch<'a>>,
    /// Times the program on a machine, where the run has one.
    pub(super) clock: Option<MachineTime>,
    /// Tool changes seen: the second is the finishing tool's.
    pub(super) tool_changes: usize,
    /// The clock's seconds at the finishing tool change (0 without a clock).
    pub(super) split_s: Option<f64>,
    /// The height field the finishing moves cut, where the setup is finished, fed on its
    /// own thread.
    pub(super) surface: Option<SinkThread<HeightField>>,
}

/// What a [`Watcher`] reports progress with.
pub(super) struct Watch<'a> {
    pub(super) progress: &'a mut dyn FnMut(Stage),
    pub(super) planner: &'a PlanProgress,
    pub(super) setup: usize,
    pub(super) setups: usize,
    pub(super) moves: u64,
}

impl<'a> Watcher<'a> {
    /// Reports [`Stage::Layers`] of setup `setup` (1-based) of `setups` to `progress`
    /// every few thousand moves, with the levels `planner` has emitted.
    pub(super) fn watching<'b>(
        self,
        progress: &'b mut dyn FnMut(Stage),
        planner: &'b PlanProgress,
        setup: usize,
        setups: usize,
    ) -> Watcher<'b>
    where
        'a: 'b,
    {
        Watcher {
            trace: self.trace,
            frame: self.frame,
            setups: self.setups,
            last: self.last,
            watch: Some(Watch { progress, planner, setup, setups, moves: 0 }),
            clock: self.clock,
            tool_changes: self.tool_changes,
            split_s: self.split_s,
            surface: self.surface,
        }
    }
}

impl MotionSink for Watcher<'_> {
    type Error = crate::voxsim::SimError;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        if let Motion::Setup { frame, .. } = m {
            self.frame = Setup { frame: *frame };
            self.setups += 1;
            self.last = None;
        } else if let (Some(trace), Some(at), 1) = (self.trace.as_deref_mut(), m.end_point(), self.setups) {
            let to = self.frame.to_part(&at);
            if let Some((from, was)) = self.last {
                // Program coordinates of one level are written alike.
                trace.push(from, to, !matches!(m, Motion::Rapid { .. }), [was.z, at.z], 1e-9);
            }
            self.last = Some((to, at));
        }
        if let Motion::ToolChange { .. } = m {
            self.tool_changes += 1;
            if self.tool_changes == 2 {
                self.split_s = Some(self.clock.as_ref().map_or(0.0, MachineTime::seconds));
            }
        }
        if self.tool_changes >= 2
            && let Some(field) = &mut self.surface
            && !matches!(m, Motion::Setup { .. })
        {
            let Ok(()) = field.motion(m);
        }
        if let Some(clock) = &mut self.clock {
            let Ok(()) = clock.motion(m);
        }
        if let Some(w) = &mut self.watch {
            w.moves += 1;
            if w.moves % (1 << 14) == 0 {
                let (done, levels) = w.planner.levels();
                (w.progress)(Stage::Layers {
                    setup: w.setup,
                    setups: w.setups,
                    done,
                    levels,
                    moves: w.moves,
                });
            }
        }
        Ok(())
    }
}
