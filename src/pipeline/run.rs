//! [`MillRun`]: the run one setup at a time, from the mesh to the scored result.

use std::cell::RefCell;
use std::sync::Arc;
use std::time::Instant;

use super::api::{
    MillError, MillOptions, Milled, PartDeviation, Preset, ProgramLayout, SetupCount, SetupProgram, Stage,
    StageSeconds,
};
use super::job::{FinishJob, Job, feeds, setup_features, stock_in_setup};
use super::per_setup::{Ctx, FinishingPart, ProgramOutputs, sim_error};
use super::rotary::{Placement, mill_rotary};
use super::setup_choice::{Reaches, SetupChoice, choose_setups};
use super::stock::{StockBody, datum_comment, datum_setup};
use super::tooling::{Tooling, planned_tool};
use crate::gcode::{FooterRetract, WriterOptions};
use crate::geom::{
    Aabb, Mesh, MeshIndex, MetricOptions, Normalization, Point3, TAUBIN_LAMBDA, TAUBIN_MU, Vector3,
    VoxelGrid, compare, marching_cubes_voxels, sample_surface, taubin_smooth, unit_cube_normalization,
    voxelize,
};
use crate::orient::{OrientOptions, OrientationResult};
use crate::policy::{Action, ActionSpace, FinishChoice, Policy, SetupContext, SetupFeatures};
use crate::toolpath::Tool;
use crate::toolpath::library::Cutting;
use crate::trace::PathTrace;
use crate::voxsim::{RewardWeights, Rewards, SimOptions, SimReport, Simulator};

mod grid;
mod rest_rough;
mod undercut;

/// A milling run one setup at a time: what [`mill`](super::mill) does, opened up so that a caller (the
/// learning environment, an interactive tool) picks each setup's [`Action`] after seeing
/// what the earlier setups left.
///
/// [`MillRun::new`] normalises the part, selects the orientations and prepares the
/// simulator; then, while [`next_setup`](Self::next_setup) is `Some`, read
/// [`features`](Self::features) and [`machine`](Self::machine) an action; then
/// [`finish`](Self::finish) scores the result. In the per-setup layout `machine` plans,
/// writes, parses back and simulates the setup at once, so [`rewards`](Self::rewards) is
/// up to date after each setup. The rotary layout's one program is parsed in one pass, so
/// its setups are cut in `finish`, and until then `rewards` and the features' removal
/// fraction describe the uncut stock.
///
/// A run is `Clone`: a copy continues independently from the same state (the learning
/// environment keeps copies at the action prefixes it has simulated).
#[derive(Clone)]
pub struct MillRun {
    opts: MillOptions,
    /// The input mesh in the unit cube, for scoring.
    unit_part: Mesh,
    unit: Normalization,
    /// The part in planning units.
    part: Mesh,
    space: ActionSpace,
    /// The radius of each tool the simulator knows, tool `i + 1` at `i`: the action
    /// space's radii, then those of actions outside it, in the order first used.
    tool_radii: Vec<f64>,
    /// The stock's box (the planners' stock) and its body (the simulator's).
    stock: Aabb,
    body: StockBody,
    to_input: Normalization,
    orientation: OrientationResult,
    /// The two candidate setup sets' comparison, where a finishing run made one.
    setup_choice: Option<SetupChoice>,
    placements: Option<Vec<Placement>>,
    /// The geometric features of each setup (the removal fraction is filled in later).
    features: Vec<SetupFeatures>,
    target: VoxelGrid,
    sim: RefCell<Simulator>,
    jobs: Vec<Job>,
    setups: Vec<SetupProgram>,
    /// The material still to cut after the setups machined so far.
    remaining: VoxelGrid,
    trace: PathTrace,
    times: StageSeconds,
    wopts: WriterOptions,
    /// Whether the per-setup programs' text and trace are kept (see
    /// [`keep_programs`](Self::keep_programs)).
    keep_programs: bool,
    /// Whether the first setup's toolpath is kept for rendering ([`Self::keep_trace`]).
    keep_trace: bool,
    /// Where each per-setup program is written as it is made ([`Self::stream_programs`]).
    outputs: Option<ProgramOutputs>,
    /// When the run must have finished, and its limit ([`Self::time_limit`]).
    deadline: Option<(Instant, f64)>,
    /// The cutters: the paper's planned ones, or a library's.
    tooling: Tooling,
    diag: f64,
    feed: f64,
    rapid: f64,
    clearance: f64,
    /// What the finished surface is measured against ([`PartDeviation`]'s surface samples,
    /// and whether the part is closed); empty where the run does not finish.
    finishing_part: FinishingPart,
}

impl MillRun {
    /// Loads `mesh` into a run: checks the options, normalises the part, selects the
    /// setups (stage [`Stage::Orientation`]), computes every setup's features (stage
    /// [`Stage::ActionSelection`]) and prepares the simulation grid and the part's voxels.
    pub fn new(mesh: &Mesh, opts: &MillOptions, progress: &mut dyn FnMut(Stage)) -> Result<Self, MillError> {
        check_options(mesh, opts)?;
        let mut times = StageSeconds::default();
        let decimals = 4;

        let (unit, part, preset_stock, to_input) = part_and_stock(mesh, opts)?;
        let part_box = part.bbox().ok_or(crate::geom::GeomError::EmptyMesh)?;
        let body = StockBody::new(&opts.stock, &part_box, preset_stock)?;
        let stock = body.bbox();
        let space = opts.action_space();
        if space.strategies.is_empty() {
            return Err(MillError::InvalidOption("no clearing strategy left to choose from".into()));
        }

        // Orientation selection.
        progress(Stage::Orientation);
        let t = Instant::now();
        let mut oopts = OrientOptions {
            points: opts.orient_points,
            candidates: opts.orient_candidates,
            seed: opts.seed,
            // A wall overhanging by less than half a voxel over the stock hides nothing the
            // grid can show.
            min_cos: if opts.flank_walls { -0.5 / opts.resolution as f64 } else { 0.0 },
            ..OrientOptions::default()
        };
        if let SetupCount::Exactly(n) = opts.setups {
            oopts.max_setups = n.max(1);
            oopts.coverage_target = 1.0;
        }
        // A shop's tools reach only so deep below the stock's top: setups are chosen for
        // what their tools reach (with finishing, maybe the ball's: `choose_setups`).
        let tooling = Tooling::new(opts, stock.extent().norm(), feeds(None).0)?;
        // What does not depend on the setups (the part's voxels on the simulation grid, its
        // index and the samples the features read) is computed beside the orientation
        // search, whose serial steps leave a core idle.
        let spec = grid::simulation_grid(&stock, &part, &part_box, opts)?;
        // A tool that comes within the roughing's allowance of a surface reaches it, or
        // within half a voxel where the grid shows no less (or within the slack asked for).
        let slack = opts.reach_slack.unwrap_or(MillOptions::REACH_SLACK_MM.max(0.5 * spec.voxel.max()));
        let reaches = Reaches::of_tooling(&part, &tooling, stock, slack, opts);
        let (orientation, (target, index, samples, beside)) = rayon::join(
            || choose_setups(&part, &body, &oopts, reaches, opts.stock_removal),
            || {
                let t = Instant::now();
                let target = voxelize(&part, &spec);
                let voxelized = t.elapsed();
                let index = MeshIndex::new(&part);
                let samples = sample_surface(&part, 4096, opts.seed ^ 0x5eed);
                (target, index, samples, [voxelized, t.elapsed() - voxelized])
            },
        );
        let (orientation, setup_choice) = orientation?;
        let (target, index, samples) = (target?, index?, samples?);
        // Every setup would cut the whole stock away, and the scores have no part to compare.
        if target.count() == 0 {
            return Err(MillError::NoVolume { resolution: opts.resolution });
        }
        // The rotary layout fails here, before any planning, on a setup its machine cannot reach.
        let placements = match opts.layout {
            ProgramLayout::PerSetup => None,
            ProgramLayout::Rotary(axes) => Some(
                orientation
                    .setups
                    .iter()
                    .enumerate()
                    .map(|(i, s)| Placement::new(axes, s, opts.rotary_tilt_range_deg, decimals, i))
                    .collect::<Result<Vec<_>, _>>()?,
            ),
        };
        times.orientation = t.elapsed().as_secs_f64();

        // What the policy will look at.
        progress(Stage::ActionSelection);
        let t = Instant::now();
        let diag = stock.extent().norm();
        let voxel = stock.extent().max() / opts.resolution as f64;
        let features = orientation
            .setups
            .iter()
            .map(|setup| setup_features(&index, &samples, setup, &space, diag, &stock, voxel))
            .collect();
        times.action_selection = (t.elapsed() + beside[1]).as_secs_f64();

        let (feed, rapid) = feeds(tooling.machine());
        let t = Instant::now();
        let tools = tooling.tool_table(&space.radii)?;
        let mut sim_opts =
            SimOptions { carver: opts.carver, rapid_rate_mm_per_min: rapid, ..SimOptions::default() };
        if opts.arc_tolerance.is_some() {
            // Arcs along the walls: the simulator's chords (a quarter of a voxel deep by
            // default, always inside the arc) would cut into the part where an arc runs
            // around it, so they follow the arc within 1/64 of a voxel.
            sim_opts.arc_tolerance = 1.0 / 1024.0;
        }
        let mut sim = Simulator::new(body.voxels(spec), tools, sim_opts)
            .map_err(sim_error)?
            .with_target(&target)
            .map_err(sim_error)?;
        let mut remaining = sim.residual_grid();
        remaining.andnot(&target).map_err(|e| MillError::Simulation(e.into()))?;
        times.simulation += (t.elapsed() + beside[0]).as_secs_f64();

        let finishing_part = FinishingPart::new(&part, opts)?;
        Ok(Self {
            opts: opts.clone(),
            unit_part: mesh.transformed(&unit.as_similarity()),
            unit,
            part,
            tool_radii: space.radii.clone(),
            space,
            stock,
            body,
            to_input,
            orientation,
            setup_choice,
            placements,
            features,
            target,
            sim: RefCell::new(sim),
            jobs: Vec::new(),
            setups: Vec::new(),
            remaining,
            trace: PathTrace::default(),
            times,
            // Every program ends with the planner's retract to the clearance plane. No
            // `G53 G0 Z0` after it: the program sets no work offset, so a reader (the
            // simulator, `rs274`) takes machine Z0 for work Z0, and where the last pass ends
            // over the part that is a rapid plunge into it.
            wopts: WriterOptions {
                decimals,
                retract: FooterRetract::None,
                // A shop's programs set each tool's length offset after its change, and
                // select G54, the work coordinate system their datum is stated in.
                tool_length_offset: tooling.machine().is_some(),
                work_offset: tooling.machine().map(|_| 1),
                ..WriterOptions::default()
            },
            keep_programs: true,
            keep_trace: true,
            outputs: None,
            deadline: None,
            tooling,
            diag,
            feed,
            rapid,
            // Appendix A.1: start 0.1 (of the normalised part) above the top.
            clearance: 0.1 * stock.extent().max(),
            finishing_part,
        })
    }

    /// What both layouts' machining reads.
    fn ctx(&self) -> Ctx<'_> {
        Ctx {
            part: &self.part,
            target: &self.target,
            jobs: &self.jobs,
            sim: &self.sim,
            setups: self.orientation.setups.len(),
            dialect: self.opts.dialect,
            wopts: &self.wopts,
            keep_programs: self.keep_programs,
            outputs: self.outputs.as_ref(),
            deadline: self.deadline,
            machine: self.tooling.machine(),
            surface_spacing: self.opts.surface_spacing,
            finishing_part: &self.finishing_part,
        }
    }

    /// Stops the run with [`MillError::TimeLimit`] once `limit` has passed since `started`:
    /// before each setup, within a setup's planning and simulation (the planner stops
    /// before its next layer), and before scoring.
    pub fn time_limit(&mut self, started: Instant, limit: std::time::Duration) {
        self.deadline = Some((started + limit, limit.as_secs_f64()));
    }

    fn check_deadline(&self, stage: impl FnOnce() -> String) -> Result<(), MillError> {
        match self.deadline {
            Some((at, limit_s)) if Instant::now() >= at => {
                Err(MillError::TimeLimit { stage: stage(), limit_s })
            }
            _ => Ok(()),
        }
    }

    /// Whether the per-setup programs are kept (the default): their text in
    /// [`SetupProgram::text`] and [`Milled::programs`], the first setup's toolpath in
    /// [`Milled::trace`] for the rendering. A caller that only wants the simulated outcome
    /// (the learning environment) turns it off: each program is then streamed from the
    /// planner to the parser and simulator and never held whole, which matters for the
    /// finest actions (a 0.1 mm tool clearing rings on 1/512 layers writes over a gigabyte
    /// and tens of millions of moves for one setup). The rotary layout always keeps its
    /// program.
    pub fn keep_programs(&mut self, keep: bool) {
        self.keep_programs = keep;
        self.keep_trace = keep;
    }

    /// Whether the first setup's toolpath is kept in [`Milled::trace`] for the rendering
    /// (default: as [`keep_programs`](Self::keep_programs)). The trace keeps one level in
    /// two, four, ... as needed to stay within [`PathTrace::CAPACITY`] segments.
    pub fn keep_trace(&mut self, keep: bool) {
        self.keep_trace = keep;
    }

    /// Writes each per-setup program into `open(setup)` (setup counted from 0) as it is
    /// planned, instead of keeping its text ([`keep_programs`](Self::keep_programs) is
    /// turned off): memory then stays bounded by the simulation grid whatever the
    /// program's size. A writer that fails stops the run with [`MillError::Program`]; the
    /// caller decides what becomes of what was written (the CLI writes to temporary files
    /// and renames them only when the whole run succeeds). The rotary layout's one
    /// program is always kept whole, as before.
    pub fn stream_programs(
        &mut self,
        open: impl Fn(usize) -> std::io::Result<Box<dyn std::io::Write + Send>> + Send + Sync + 'static,
    ) {
        let keep_trace = self.keep_trace;
        self.keep_programs(false);
        self.keep_trace = keep_trace;
        self.outputs = Some(Arc::new(open));
    }

    /// The volume of the material the simulator holds now, in cubic planning units
    /// (mm³): before the first setup, the stock the run starts from ([`MillOptions::stock`]
    /// on the simulation grid).
    pub fn stock_volume(&self) -> f64 {
        let g = self.sim.borrow_mut().residual_grid();
        g.count() as f64 * g.spec().voxel_volume()
    }

    /// The action space, in planning units.
    pub fn space(&self) -> &ActionSpace {
        &self.space
    }

    /// Orientation selection's result: the setups in machining order.
    pub fn orientation(&self) -> &OrientationResult {
        &self.orientation
    }

    /// Where a finishing run planned setups both for the roughing's reach and for the
    /// ball's, what each set leaves unreached and which it took; `None` where it planned
    /// one set (no finishing, a mostly prismatic part, a ball reaching as deep, or both
    /// reaches giving the same setups).
    pub fn setup_choice(&self) -> Option<SetupChoice> {
        self.setup_choice
    }

    /// Number of setups.
    pub fn setup_count(&self) -> usize {
        self.orientation.setups.len()
    }

    /// The 0-based setup [`machine`](Self::machine) cuts next; `None` once every setup has
    /// its action.
    pub fn next_setup(&self) -> Option<usize> {
        let i = self.chosen();
        (i < self.setup_count()).then_some(i)
    }

    /// The features of the next setup (those of the last one once all are machined), with
    /// the removal fraction of the material left now.
    pub fn features(&self) -> SetupFeatures {
        let i = self.chosen().min(self.features.len().saturating_sub(1));
        let mut f = self.features.get(i).cloned().unwrap_or_default();
        let stock = self.target.spec().len() as f64;
        f.removal_fraction = if stock > 0.0 { self.remaining.count() as f64 / stock } else { 0.0 };
        f
    }

    /// The policy's view of the next setup, given its `features`.
    pub fn context<'a>(&'a self, features: &'a SetupFeatures) -> SetupContext<'a> {
        SetupContext {
            index: self.chosen(),
            setups: self.setup_count(),
            space: &self.space,
            features,
            // A setup not finished whole is roughed as without finishing (same layers).
            finishing: self.opts.finish.filter(|_| {
                super::finish_scope::finished_whole(&self.part, self.orientation.setups.get(self.chosen()))
            }),
        }
    }

    /// The paper's rewards (Eq. 10-12 and the one-step total of Eq. 13, default weights)
    /// of the stock as simulated so far against the part.
    pub fn rewards(&self, weights: &RewardWeights) -> Result<Rewards, MillError> {
        let residual = self.sim.borrow_mut().residual_grid();
        let report = self.sim.borrow().report().clone();
        crate::voxsim::rewards(&residual, &self.target, &report, weights).map_err(sim_error)
    }

    /// The simulator's report so far (complete for the setups machined in the per-setup
    /// layout).
    pub fn report(&self) -> SimReport {
        self.sim.borrow().report().clone()
    }

    /// The simulated stock so far (per-setup layout: after the setups machined), on the
    /// simulation grid: what two runs' programs cut can be compared voxel for voxel.
    pub fn residual_grid(&self) -> VoxelGrid {
        self.sim.borrow_mut().residual_grid()
    }

    /// The setups machined so far (per-setup layout; empty for the rotary layout until
    /// [`finish`](Self::finish)).
    pub fn machined(&self) -> &[SetupProgram] {
        &self.setups
    }

    /// The tool of `radius` and its cutting data (a library tool's). In the paper preset a
    /// radius outside the action space (a fixed action's) gets a tool of its own, added to
    /// the simulator's table, so that the simulation cuts with the radius the planner
    /// planned for; a library has the tools it has.
    fn tool_for(&mut self, radius: f64, depth: f64) -> Result<(Tool, Option<Cutting>), MillError> {
        if let Tooling::Planned { .. } = self.tooling {
            let number = match self.tool_radii.iter().position(|&r| r == radius) {
                Some(i) => i as u32 + 1,
                None => {
                    let number = self.tool_radii.len() as u32 + 1;
                    let cutter = planned_tool(radius, number, self.diag, self.feed).cutter;
                    self.sim.get_mut().add_tool(number, cutter).map_err(sim_error)?;
                    self.tool_radii.push(radius);
                    number
                }
            };
            return self.tooling.tool(radius, number, depth);
        }
        self.tooling.tool(radius, 0, depth)
    }

    /// Cuts the next setup with `action`: plans it against the material left, writes its
    /// program, parses the text back and simulates it (per-setup layout), or records the
    /// action for [`finish`](Self::finish) (rotary layout). Errors when every setup already
    /// has its action.
    pub fn machine(&mut self, action: Action, progress: &mut dyn FnMut(Stage)) -> Result<(), MillError> {
        self.machine_finished(action, self.opts.finish, progress)
    }

    /// [`machine`](Self::machine), finishing the setup after its roughing with `finish`
    /// (a policy's choice) where the run finishes ([`MillOptions::finish`]; ignored where
    /// it does not). In the shop preset's per-setup layout the setup's rest-roughing
    /// programs ([`MillOptions::rest_roughing`]) follow its roughing at once, and the
    /// finishing follows the last of them: rough, rest-rough, finish, then the next setup.
    pub fn machine_finished(
        &mut self,
        action: Action,
        finish: Option<FinishChoice>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<(), MillError> {
        let finish = finish.filter(|_| self.opts.finish.is_some());
        let Some(i) = self.next_setup() else {
            return Err(MillError::InvalidOption(format!("all {} setups are machined", self.setup_count())));
        };
        self.check_deadline(|| format!("starting setup {} of {}", i + 1, self.setup_count()))?;
        // The stock's depth along the setup's axis: how far its tool may have to reach.
        let depth = stock_in_setup(&self.stock, &self.orientation.setups[i]).extent().z;
        let tool = self.tool_for(action.tool_radius, depth)?;
        // The action records the tool actually used (a library may give a longer one).
        let action = Action { tool_radius: tool.0.radius(), ..action };
        let o = &self.opts;
        let (setup, note) = match o.datum {
            Some(d) => {
                let (setup, at) = datum_setup(&self.orientation.setups[i], &self.stock, d);
                (setup, Some(datum_comment(d, &at, &self.body)))
            }
            None => (self.orientation.setups[i], None),
        };
        let mut job = Job::new(&setup, &action, tool, &self.stock, self.rapid, self.clearance, o)?;
        job.note = note;
        if let Some(choice) = finish {
            check_finish_choice(&choice)?;
            let tool = self.tooling.finishing_tool(&job.tool, depth, choice.tool)?;
            if let Tooling::Planned { .. } = self.tooling {
                self.sim.get_mut().add_tool(tool.number, tool.cutter).map_err(sim_error)?;
            }
            let scope = super::finish_scope::FinishScope::All;
            job.finish = Some(FinishJob { choice, tool, roughed_radius: job.tool.radius(), scope });
            super::finish_scope::scope_finishing(&mut job, &self.part);
        }
        let (length_mm, hours) = job.estimate();
        if hours.is_nan() || hours > o.max_estimated_hours {
            return Err(MillError::ActionTooLarge {
                setup: i + 1,
                tool_radius: action.tool_radius,
                layer_height: action.layer_height,
                length_mm,
                hours,
                limit_hours: o.max_estimated_hours,
            });
        }
        // A shop roughs, rest-roughs, then finishes each setup: the finishing moves to the last rest pass.
        let rest = self.first_rest_tool(i, &job)?;
        // Whether the setup is finished, and the finisher a rest pass leaves material for
        // (none where the ball takes only sculpted faces: rest passes are planned as without finishing).
        let (finishes, finisher) =
            (job.finish.is_some(), job.finish.as_ref().and_then(FinishJob::takes_rest));
        self.jobs.push(job);
        if self.placements.is_some() {
            return Ok(());
        }
        self.machine_own_then_rest(i, rest, finishes, finisher, progress)
    }

    /// Machines every setup still without an action with `policy`'s choice, then
    /// [`finish`](Self::finish)es: the rest of what [`mill`](super::mill) does.
    pub fn complete(
        mut self,
        policy: &mut dyn Policy,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<Milled, MillError> {
        while self.next_setup().is_some() {
            let t = Instant::now();
            let features = self.features();
            let ctx = self.context(&features);
            let action = policy.choose(&ctx);
            let finish = self.opts.finish.map(|d| policy.finish(&ctx, d));
            self.times.action_selection += t.elapsed().as_secs_f64();
            self.machine_finished(action, finish, progress)?;
        }
        self.finish(&policy.name(), progress)
    }

    /// Finishes the run: the rotary layout's program is written and simulated now, then
    /// the residual stock is meshed and scored (stage [`Stage::Scoring`]). `policy` names
    /// the policy in the result. Errors when a setup has no action yet.
    pub fn finish(mut self, policy: &str, progress: &mut dyn FnMut(Stage)) -> Result<Milled, MillError> {
        if let Some(i) = self.next_setup() {
            return Err(MillError::InvalidOption(format!(
                "setup {} of {} has no action yet",
                i + 1,
                self.setup_count()
            )));
        }
        // The undercuts a T-slot cutter reaches from the side, after every setup.
        self.undercut_passes(progress)?;
        let opts = &self.opts;
        if let (ProgramLayout::Rotary(axes), Some(placements)) = (opts.layout, &self.placements) {
            // Above this height (program +Z, rotary centre at the origin) the tool clears
            // every point of the stock in every orientation of the table.
            let turn_z =
                self.stock.corners().iter().map(|c| c.coords.norm()).fold(0.0, f64::max) + self.clearance;
            let (mut trace, mut times) = (std::mem::take(&mut self.trace), self.times);
            let setups = mill_rotary(&self.ctx(), axes, placements, turn_z, &mut trace, &mut times, progress);
            (self.trace, self.times) = (trace, times);
            self.setups = setups?;
        }
        let part_voxels = self.target.count() as f64;
        let mut gouged = 0;
        for s in &mut self.setups {
            gouged += s.gouge_voxels;
            s.preservation = if part_voxels > 0.0 { 1.0 - gouged as f64 / part_voxels } else { 1.0 };
        }
        let t = Instant::now();
        self.check_deadline(|| "scoring the residual stock".into())?;
        let simulated = self.sim.into_inner().into_simulation().map_err(sim_error)?;
        let rewards = simulated.rewards(&self.target, &RewardWeights::default()).map_err(sim_error)?;
        let simulation = simulated.report().clone();
        let programs: Vec<String> = match opts.layout {
            ProgramLayout::PerSetup => self.setups.iter().map(|s| s.text.clone()).collect(),
            ProgramLayout::Rotary(_) => vec![self.setups.iter().map(|s| s.text.as_str()).collect()],
        };
        self.times.simulation += t.elapsed().as_secs_f64();

        // Score in the unit cube.
        progress(Stage::Scoring);
        let t = Instant::now();
        let mut residual_plan = marching_cubes_voxels(simulated.residual())?;
        if opts.residual_smoothing > 0 {
            residual_plan = taubin_smooth(&residual_plan, opts.residual_smoothing, TAUBIN_LAMBDA, TAUBIN_MU)?;
        }
        let to_input = self.to_input;
        let residual = residual_plan.transformed(&to_input.inverse_similarity());
        let mut mopts =
            MetricOptions { samples: opts.metric_samples, seed: opts.seed, ..MetricOptions::default() };
        if grid::face_grid(opts) {
            let to_unit = self.unit.as_similarity() * to_input.inverse_similarity();
            grid::scorer_on_grid(&mut mopts, simulated.residual().spec(), &to_unit);
        }
        let metrics = compare(&residual.transformed(&self.unit.as_similarity()), &self.unit_part, &mopts)?;
        self.times.scoring = t.elapsed().as_secs_f64();

        let stock = Aabb::new(to_input.from_unit(&self.stock.min), to_input.from_unit(&self.stock.max));
        let trace_axis = self.orientation.setups.first().map_or(Vector3::z(), |s| s.tool_axis().into_inner());
        let back = to_input.inverse_similarity();
        let mut trace = self.trace;
        trace.segments.iter_mut().for_each(|(a, b, _)| {
            *a = back * *a;
            *b = back * *b;
        });
        let surface_deviation = PartDeviation::combine(
            self.setups.iter().filter_map(|s| s.finish.as_ref()).map(|f| f.reached.as_slice()),
        );
        Ok(Milled {
            surface_deviation,
            preset: opts.preset,
            stock_option: opts.stock,
            datum: opts.datum,
            policy: policy.to_owned(),
            programs,
            setups: self.setups,
            orientation: self.orientation,
            simulation,
            rewards,
            metrics,
            residual,
            stock,
            trace,
            trace_axis,
            stage_seconds: self.times,
        })
    }
}

/// Refuses options no run can use, before any work.
fn check_options(mesh: &Mesh, opts: &MillOptions) -> Result<(), MillError> {
    if !MillOptions::RESOLUTIONS.contains(&opts.resolution) {
        return Err(MillError::InvalidOption(format!(
            "resolution must be {:?}, got {}",
            MillOptions::RESOLUTIONS,
            opts.resolution
        )));
    }
    if mesh.is_empty() {
        return Err(crate::geom::GeomError::EmptyMesh.into());
    }
    if let Some(s) = opts.reach_slack
        && !(s.is_finite() && s >= 0.0)
    {
        return Err(MillError::InvalidOption(format!("the reach's slack must be finite and >= 0, got {s}")));
    }
    let d = opts.roughing_depth_diameters;
    if !(d.is_finite() && d >= 0.0) {
        return Err(MillError::InvalidOption(format!(
            "roughing depth must be finite and >= 0 diameters, got {d}"
        )));
    }
    if let ProgramLayout::Rotary(_) = opts.layout {
        if let Err(e) = opts.dialect.require_rotary_axes() {
            return Err(MillError::InvalidOption(format!("the rotary layout needs rotary axes: {e}")));
        }
        let [lo, hi] = opts.rotary_tilt_range_deg;
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(MillError::InvalidOption(format!(
                "rotary tilt range must be finite with min <= max, got [{lo}, {hi}]"
            )));
        }
    }
    if opts.datum.is_some() && opts.layout != ProgramLayout::PerSetup {
        return Err(MillError::InvalidOption(
            "a datum is for per-setup programs; the rotary layout's origin is its rotary centre".into(),
        ));
    }
    if !(opts.rest_continue.is_finite() && opts.rest_continue >= 0.0) {
        return Err(MillError::InvalidOption(format!(
            "the rest-roughing fraction of the part's volume must be finite and >= 0, got {}",
            opts.rest_continue
        )));
    }
    if let Some(t) = opts.arc_tolerance
        && !(t.is_finite() && t > 0.0)
    {
        return Err(MillError::InvalidOption(format!("arc tolerance must be finite and > 0, got {t}")));
    }
    if let Some(f) = &opts.finish {
        check_finish_options(opts, f)?;
    }
    Ok(())
}

/// Finishing runs per setup after a tool change, so it needs the per-setup layout and a
/// tool changer; its allowance, spacing and choice must make sense.
fn check_finish_options(opts: &MillOptions, f: &FinishChoice) -> Result<(), MillError> {
    let bad = |m: String| Err(MillError::InvalidOption(m));
    if opts.layout != ProgramLayout::PerSetup {
        return bad("finishing is for per-setup programs (the rotary layout roughs only)".into());
    }
    if opts.dialect.spec().tool_change == crate::gcode::ToolChange::Pause {
        return bad(format!(
            "finishing changes tools in the program: the {} dialect has no tool changer",
            opts.dialect
        ));
    }
    if !opts.finish_allowance.iter().all(|a| a.is_finite() && *a >= 0.0) {
        return bad(format!(
            "the finishing allowance must be finite and >= 0, got {:?}",
            opts.finish_allowance
        ));
    }
    if !(opts.surface_spacing.is_finite() && opts.surface_spacing > 0.0) {
        return bad(format!("the surface spacing must be finite and > 0, got {}", opts.surface_spacing));
    }
    check_finish_choice(f)
}

fn check_finish_choice(f: &FinishChoice) -> Result<(), MillError> {
    if !(f.scallop.is_finite() && f.scallop > 0.0) {
        return Err(MillError::InvalidOption(format!(
            "the scallop height must be finite and > 0, got {}",
            f.scallop
        )));
    }
    Ok(())
}

/// The part in planning units, its stock, and the maps from the input mesh: into the unit
/// cube (for scoring) and from planning units back to the input's.
fn part_and_stock(
    mesh: &Mesh,
    opts: &MillOptions,
) -> Result<(Normalization, Mesh, Aabb, Normalization), MillError> {
    // Units: the paper plans in the unit cube; the shop in part units. `to_input`
    // maps planning units back to the input mesh's units.
    let unit: Normalization = unit_cube_normalization(mesh)?;
    let (part, stock, to_input) = match opts.preset {
        Preset::Paper => {
            let k = opts.paper_scale_mm;
            if !(k.is_finite() && k > 0.0) {
                return Err(MillError::InvalidOption(format!("paper_scale_mm must be positive, got {k}")));
            }
            let s = opts.paper_space_scale;
            if !(s.is_finite() && s > 0.0) {
                return Err(MillError::InvalidOption(format!("paper_space_scale must be positive, got {s}")));
            }
            let norm = Normalization { scale: unit.scale * k, translation: unit.translation * k };
            let part = mesh.transformed(&norm.as_similarity());
            let half = 0.5 * k;
            let stock = Aabb::new(Point3::new(-half, -half, -half), Point3::new(half, half, half));
            (part, stock, norm)
        }
        Preset::Shop => {
            let k = opts.input_scale;
            if !(k.is_finite() && k > 0.0) {
                return Err(MillError::InvalidOption(format!("input_scale must be positive, got {k}")));
            }
            // Millimetres from here on; a scale of 1 leaves the mesh as it is.
            let (part, norm) = if k == 1.0 {
                (mesh.clone(), Normalization::identity())
            } else {
                let norm = Normalization { scale: k, translation: Vector3::zeros() };
                (mesh.transformed(&norm.as_similarity()), norm)
            };
            let bbox = part.bbox().ok_or(crate::geom::GeomError::EmptyMesh)?;
            let margin = opts.stock_margin.max(0.0) * bbox.extent().max();
            (part, bbox.inflated(margin), norm)
        }
    };
    Ok((unit, part, stock, to_input))
}
