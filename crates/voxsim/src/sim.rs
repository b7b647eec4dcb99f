//! [`Simulator`]: the [`MotionSink`] that carves (or deposits) along the motions it receives.

use std::collections::BTreeSet;
use std::sync::atomic::Ordering;

use nalgebra::{Translation3, UnitQuaternion};
use s2g_gcode::{ArcDirection, Motion, MotionSink, Plane};
use s2g_geom::{Isometry3, Point3, Vector3, VoxelGrid};

use crate::dexel::Dexel;
use crate::engine::{
    FLAG_HOLDER, FLAG_RAPID, Op, Scratch, Stats, Store, Sweep, Tolerance, ToolPrims, run_batch,
};
use crate::error::{Result, SimError};
use crate::paper::Paper;
use crate::sweep::Seg;
use crate::tool::{BeadProfile, Cutter, ToolTable};

/// Which algorithm removes material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Carver {
    /// Exact swept volume on the voxel grid, any fixed tool axis (the default).
    Exact,
    /// Dexel columns for setups whose tool axis is a grid axis (+ or -), merged into the
    /// voxel stock when the setup ends; other setups fall back to [`Carver::Exact`].
    Dexel,
    /// The paper's Monte-Carlo Algorithm A1, as printed (baseline for comparison only;
    /// rapids do not cut, no holder checks).
    PaperMonteCarlo {
        /// Samples per mm of path (`1 / sweep_step`).
        samples_per_unit: f64,
        /// RNG seed.
        seed: u64,
    },
}

/// Simulation options.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOptions {
    /// Carving algorithm. Default [`Carver::Exact`].
    pub carver: Carver,
    /// Rapid traverse rate in mm/min, for the machining time. Default 5000.
    pub rapid_rate_mm_per_min: f64,
    /// Tool tip position (program frame) before the first move; `None` (default): unknown,
    /// the first move is a positioning move that only places the tool at its end point.
    pub start: Option<Point3>,
    /// Arcs are split into chords whose sagitta is below this fraction of the smallest
    /// voxel edge. Default 0.25.
    pub arc_tolerance: f64,
    /// Whether to check the shank and holder against the stock. Default true.
    pub check_holder: bool,
    /// Moves queued before a carving pass of the exact carver. Default 4096.
    pub batch_moves: usize,
    /// Below this many (brick, move) pairs a pass runs on one thread. Default 256.
    pub parallel_threshold: usize,
    /// Upper bound on the sub-steps of a move that changes the setup frame. Default 4096.
    pub max_substeps: usize,
    /// Voxel centres within this fraction of the smallest voxel edge outside the swept
    /// volume count as inside, so that ties (round program coordinates on voxel-centre
    /// planes) resolve the same way in every carver despite rounding. Default 1e-9.
    pub tie_tolerance: f64,
    /// A rapid move, shank or holder collides with stock only where it reaches deeper
    /// than this fraction of the smallest voxel edge past a voxel's centre; a shallower
    /// contact grazes the voxel: a rapid still removes it, but neither is reported. Program
    /// coordinates are rounded (s2g writes four decimals) and offset curves are chords of
    /// arcs, so one wall traced on two levels differs by a micrometre or so, and a rapid
    /// descending along it meets the voxels the upper pass left by that much. Default
    /// 0.01 (3.9 µm for 256 voxels on 100 mm).
    pub collision_tolerance: f64,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            carver: Carver::Exact,
            rapid_rate_mm_per_min: 5000.0,
            start: None,
            arc_tolerance: 0.25,
            check_holder: true,
            batch_moves: 4096,
            parallel_threshold: 256,
            max_substeps: 4096,
            tie_tolerance: 1e-9,
            collision_tolerance: 0.01,
        }
    }
}

impl SimOptions {
    fn validate(&self) -> Result<()> {
        let bad = |m: &str| Err(SimError::InvalidOption(m.to_string()));
        if !(self.rapid_rate_mm_per_min.is_finite() && self.rapid_rate_mm_per_min > 0.0) {
            return bad("rapid rate must be finite and > 0");
        }
        if !(self.tie_tolerance.is_finite() && (0.0..0.5).contains(&self.tie_tolerance)) {
            return bad("tie tolerance must be in [0, 0.5)");
        }
        if !(self.collision_tolerance.is_finite() && (0.0..0.5).contains(&self.collision_tolerance)) {
            return bad("collision tolerance must be in [0, 0.5)");
        }
        if !(self.arc_tolerance.is_finite() && self.arc_tolerance > 0.0) {
            return bad("arc tolerance must be finite and > 0");
        }
        if self.batch_moves == 0 || self.batch_moves > 1 << 24 || self.max_substeps == 0 {
            return bad("batch_moves must be in 1..=2^24 and max_substeps > 0");
        }
        if let Some(p) = self.start
            && !p.iter().all(|c| c.is_finite())
        {
            return bad("start position must be finite");
        }
        if let Carver::PaperMonteCarlo { samples_per_unit, .. } = self.carver
            && !(samples_per_unit.is_finite() && samples_per_unit > 0.0)
        {
            return bad("samples_per_unit must be finite and > 0");
        }
        Ok(())
    }
}

/// What a simulation found. Everything here is deterministic; wall time is the caller's.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SimReport {
    /// Voxels removed from the stock.
    pub removed_voxels: u64,
    /// `removed_voxels * voxel volume`.
    pub removed_volume_mm3: f64,
    /// Voxels added (additive mode).
    pub deposited_voxels: u64,
    /// `deposited_voxels * voxel volume`.
    pub deposited_volume_mm3: f64,
    /// Removed voxels that belong to the target part.
    pub gouge_voxels: u64,
    /// Source line of the first move (in program order) that removed a target voxel.
    pub first_gouge_line: Option<u64>,
    /// Distinct source lines (ascending) of rapid moves that removed material past
    /// [`SimOptions::collision_tolerance`].
    pub rapid_collision_lines: Vec<u64>,
    /// Voxels removed by rapid moves past the collision tolerance (grazed ones are removed
    /// but not counted here).
    pub rapid_collision_voxels: u64,
    /// Distinct source lines (ascending) where the shank or holder met stock past the
    /// collision tolerance.
    pub holder_collisions: Vec<u64>,
    /// Stock voxels met by the shank or holder (summed over moves).
    pub holder_collision_voxels: u64,
    /// Feed length / feed rate + rapid length / rapid rate + dwells, in seconds.
    pub machining_time_s: f64,
    /// Length of feed moves (arcs by arc length) in mm.
    pub feed_length_mm: f64,
    /// Length of rapid moves in mm.
    pub rapid_length_mm: f64,
    /// Feed moves without a usable feed rate (not counted in the time).
    pub feedless_moves: u64,
    /// Removed volume per minute of machining time (0 when the time is 0).
    pub mrr_mm3_per_min: f64,
    /// Number of moves (rapid, linear, arc).
    pub moves: u64,
}

/// Weights of the paper's total reward (Eq. 13); defaults are the paper's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RewardWeights {
    /// Weight of the preservation term. Default 1.
    pub lambda_s: f64,
    /// Weight of the final IoU. Default 1.
    pub lambda_f: f64,
    /// Weight of the removal rate. Default 0.1.
    pub lambda_mrr: f64,
}

impl Default for RewardWeights {
    fn default() -> Self {
        Self { lambda_s: 1.0, lambda_f: 1.0, lambda_mrr: 0.1 }
    }
}

/// The paper's reward terms (Shape2Gcode §3.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rewards {
    /// Eq. 10: fraction of target voxels still present (1 for an empty target).
    pub preservation: f64,
    /// Eq. 11: IoU of residual stock and target (1 when both are empty).
    pub final_iou: f64,
    /// Eq. 12: removed voxels per second of machining time (0 for zero time).
    pub mrr: f64,
    /// Eq. 13 with the whole program as one step: `ls R_s + lf R_f + lmrr R_MRR`.
    pub total: f64,
}

/// The result of a finished simulation.
#[derive(Debug, Clone)]
pub struct Simulation {
    report: SimReport,
    residual: VoxelGrid,
}

impl Simulation {
    /// The report.
    pub fn report(&self) -> &SimReport {
        &self.report
    }

    /// The residual stock (part frame).
    pub fn residual(&self) -> &VoxelGrid {
        &self.residual
    }

    /// Splits into report and residual stock.
    pub fn into_parts(self) -> (SimReport, VoxelGrid) {
        (self.report, self.residual)
    }

    /// The paper's rewards of the residual against `target` (same grid).
    pub fn rewards(&self, target: &VoxelGrid, weights: &RewardWeights) -> Result<Rewards> {
        rewards(&self.residual, target, &self.report, weights)
    }
}

/// The paper's rewards (Eqs. 10-13) for a residual stock, a target on the same grid and a report.
pub fn rewards(
    residual: &VoxelGrid,
    target: &VoxelGrid,
    report: &SimReport,
    w: &RewardWeights,
) -> Result<Rewards> {
    if residual.spec() != target.spec() {
        return Err(SimError::GridMismatch);
    }
    let inter = residual.count_and(target)? as f64;
    let t = target.count() as f64;
    let s = residual.count() as f64;
    let preservation = if t > 0.0 { inter / t } else { 1.0 };
    let union = s + t - inter;
    let final_iou = if union > 0.0 { inter / union } else { 1.0 };
    let mrr = if report.machining_time_s > 0.0 {
        report.removed_voxels as f64 / report.machining_time_s
    } else {
        0.0
    };
    let total = w.lambda_s * preservation + w.lambda_f * final_iou + w.lambda_mrr * mrr;
    Ok(Rewards { preservation, final_iou, mrr, total })
}

/// How a move moves.
#[derive(Debug, Clone, Copy)]
enum Path {
    Line,
    Arc { center: Point3, plane: Plane, sweep: f64, r0: f64, r1: f64, a0: f64, h0: f64, h1: f64 },
}

/// The material simulator (see the crate docs for the model).
#[derive(Debug, Clone)]
pub struct Simulator {
    opts: SimOptions,
    store: Store,
    target: Option<Store>,
    tools: ToolTable,
    tool: Cutter,
    prims: ToolPrims,
    bead: Option<ToolPrims>,
    frame: Isometry3,
    pending_setup: Option<(Isometry3, u64)>,
    pos: Option<Point3>,
    line: u64,
    seq: u64,
    queue: Vec<Sweep>,
    scratch: Scratch,
    dexel: Option<Dexel>,
    paper: Option<Paper>,
    stats: Stats,
    rapid_lines: BTreeSet<u64>,
    holder_lines: BTreeSet<u64>,
    report: SimReport,
}

impl Simulator {
    /// A subtractive simulator carving `stock` (part frame) with `tools`.
    pub fn new(stock: VoxelGrid, tools: ToolTable, opts: SimOptions) -> Result<Self> {
        tools.validate()?;
        opts.validate()?;
        let tool = tools.default;
        let paper = match opts.carver {
            Carver::PaperMonteCarlo { samples_per_unit, seed } => Some(Paper::new(samples_per_unit, seed)),
            _ => None,
        };
        Ok(Self {
            store: Store::from_grid(&stock),
            target: None,
            prims: ToolPrims::cutter(&tool),
            tool,
            tools,
            bead: None,
            frame: Isometry3::identity(),
            pending_setup: None,
            pos: opts.start,
            line: 0,
            seq: 0,
            queue: Vec::new(),
            scratch: Scratch::default(),
            dexel: None,
            paper,
            stats: Stats::default(),
            rapid_lines: BTreeSet::new(),
            holder_lines: BTreeSet::new(),
            report: SimReport::default(),
            opts,
        })
    }

    /// An additive simulator (the `Depositor` mode): extrusion moves (linear or arc with
    /// `extrude > 0`) deposit a bead of `profile` below the nozzle tip into `grid`;
    /// other moves only move. Uses the exact engine whatever `opts.carver` says.
    pub fn depositor(grid: VoxelGrid, profile: BeadProfile, opts: SimOptions) -> Result<Self> {
        profile.validate()?;
        let mut opts = opts;
        opts.carver = Carver::Exact;
        opts.check_holder = false;
        let w = match profile {
            BeadProfile::Rectangle { width, .. } | BeadProfile::Stadium { width, .. } => width,
            BeadProfile::Circle { diameter } => diameter,
        };
        let mut s = Self::new(grid, ToolTable::single(Cutter::flat(0.5 * w, w)), opts)?;
        s.bead = Some(ToolPrims::bead(&profile));
        Ok(s)
    }

    /// Adds (or replaces) tool `number` of the tool table, for the tool changes still to
    /// come. Errors on an invalid cutter.
    pub fn add_tool(&mut self, number: u32, cutter: Cutter) -> Result<()> {
        cutter.validate().map_err(|e| crate::tool::tool_error(Some(number), e))?;
        self.tools.tools.insert(number, cutter);
        Ok(())
    }

    /// Adds a target part on the same grid, for gouge detection and the rewards.
    pub fn with_target(mut self, target: &VoxelGrid) -> Result<Self> {
        if target.spec() != &self.store.spec {
            return Err(SimError::GridMismatch);
        }
        self.target = Some(Store::from_grid(target));
        Ok(self)
    }

    /// The report so far; complete after [`MotionSink::finish`].
    pub fn report(&self) -> &SimReport {
        &self.report
    }

    /// Finishes (flushing queued moves) and returns report and residual stock.
    pub fn into_simulation(mut self) -> Result<Simulation> {
        self.flush_all();
        Ok(Simulation { report: self.report.clone(), residual: self.store.to_grid() })
    }

    /// A copy of the current residual stock (flushes queued moves first).
    pub fn residual_grid(&mut self) -> VoxelGrid {
        self.flush_all();
        self.store.to_grid()
    }

    fn invalid(&self, message: impl Into<String>) -> SimError {
        SimError::InvalidMotion { line: self.line, message: message.into() }
    }

    /// The carvers' tolerances in part units.
    fn tolerance(&self) -> Tolerance {
        let voxel = self.store.spec.voxel.min();
        Tolerance { tie: self.opts.tie_tolerance * voxel, graze: self.opts.collision_tolerance * voxel }
    }

    fn flush_queue(&mut self) {
        if self.queue.is_empty() {
            return;
        }
        let tol = self.tolerance();
        let st = run_batch(
            &mut self.store,
            self.target.as_ref(),
            &self.queue,
            self.opts.check_holder,
            self.opts.parallel_threshold,
            tol,
            &mut self.scratch,
        );
        for (sw, f) in self.queue.iter().zip(&self.scratch.flags) {
            let f = f.load(Ordering::Relaxed);
            if f & FLAG_RAPID != 0 {
                self.rapid_lines.insert(sw.line);
            }
            if f & FLAG_HOLDER != 0 {
                self.holder_lines.insert(sw.line);
            }
        }
        self.queue.clear();
        self.absorb(st);
    }

    fn merge_dexel(&mut self) {
        if let Some(mut d) = self.dexel.take() {
            d.merge_into(&mut self.store);
        }
    }

    fn flush_all(&mut self) {
        self.flush_queue();
        self.merge_dexel();
        self.update_report();
    }

    fn absorb(&mut self, st: Stats) {
        self.stats = self.stats.add(st);
        self.update_report();
    }

    fn update_report(&mut self) {
        let v = self.store.spec.voxel_volume();
        let r = &mut self.report;
        r.removed_voxels = self.stats.removed;
        r.removed_volume_mm3 = self.stats.removed as f64 * v;
        r.deposited_voxels = self.stats.deposited;
        r.deposited_volume_mm3 = self.stats.deposited as f64 * v;
        r.gouge_voxels = self.stats.gouge;
        r.first_gouge_line = self.stats.first_gouge.map(|(_, l)| l);
        r.rapid_collision_voxels = self.stats.rapid_voxels;
        r.rapid_collision_lines = self.rapid_lines.iter().copied().collect();
        r.holder_collision_voxels = self.stats.holder_voxels;
        r.holder_collisions = self.holder_lines.iter().copied().collect();
        r.mrr_mm3_per_min =
            if r.machining_time_s > 0.0 { r.removed_volume_mm3 / (r.machining_time_s / 60.0) } else { 0.0 };
    }

    /// Routes one fixed-axis segment (part frame) to the active carver.
    fn sweep(&mut self, p0: Point3, p1: Point3, axis: Vector3, rapid: bool, op: Op) {
        let prims = if op == Op::Deposit { self.bead.unwrap_or(self.prims) } else { self.prims };
        let sw = Sweep { seg: Seg::new(p0, p1, axis), prims, op, rapid, seq: self.seq, line: self.line };
        match self.opts.carver {
            Carver::PaperMonteCarlo { .. } => {
                if rapid || op != Op::Cut {
                    return;
                }
                if let Some(paper) = self.paper.as_mut() {
                    let st = paper.segment(
                        &mut self.store,
                        self.target.as_ref(),
                        p0,
                        p1,
                        axis,
                        self.tool.radius,
                        (self.seq, self.line),
                    );
                    self.absorb(st);
                }
            }
            Carver::Dexel if op == Op::Cut => {
                let ax = (0..3).find(|&i| axis[i].abs() > 1.0 - 1e-12);
                match ax {
                    Some(ax) => {
                        let sign = axis[ax].signum();
                        if self.dexel.as_ref().is_some_and(|d| d.ax != ax || d.sign != sign) {
                            self.merge_dexel();
                        }
                        self.flush_queue();
                        let tol = self.tolerance();
                        let dex = self.dexel.get_or_insert_with(|| Dexel::new(&self.store, ax, sign));
                        let st = dex.apply(
                            &self.store,
                            self.target.as_ref(),
                            &sw,
                            self.opts.check_holder,
                            self.opts.parallel_threshold,
                            tol,
                        );
                        if st.rapid_voxels > 0 {
                            self.rapid_lines.insert(sw.line);
                        }
                        if st.holder_voxels > 0 {
                            self.holder_lines.insert(sw.line);
                        }
                        self.absorb(st);
                    }
                    None => {
                        self.merge_dexel();
                        self.queue_sweep(sw);
                    }
                }
            }
            _ => {
                self.merge_dexel();
                self.queue_sweep(sw);
            }
        }
    }

    fn queue_sweep(&mut self, sw: Sweep) {
        self.queue.push(sw);
        if self.queue.len() >= self.opts.batch_moves {
            self.flush_queue();
        }
    }

    /// Handles a rapid, linear or arc move.
    fn do_move(
        &mut self,
        to: Point3,
        path: Option<Path>,
        feed: Option<f64>,
        extrude: Option<f64>,
    ) -> Result<()> {
        if !to.iter().all(|c| c.is_finite()) {
            return Err(self.invalid(format!("non-finite end point {to:?}")));
        }
        self.report.moves += 1;
        self.seq += 1;
        let rapid = feed.is_none();
        let pending = self.pending_setup.take();
        // A setup change reported on the same (known) source line as this move happened
        // during it: interpolate. Otherwise the setup was indexed and the position is unknown.
        let interp = pending.filter(|&(_, l)| l != 0 && l == self.line && self.pos.is_some());
        if pending.is_some() && interp.is_none() {
            self.pos = None;
        }
        let known = self.pos.is_some();
        let from = self.pos.unwrap_or(to);
        self.pos = Some(to);
        let path = path.unwrap_or(Path::Line);
        // Length and time.
        let len = match path {
            Path::Line => (to - from).norm(),
            Path::Arc { sweep, r0, r1, h0, h1, .. } => {
                let planar = sweep.abs() * 0.5 * (r0 + r1);
                (planar * planar + (h1 - h0) * (h1 - h0)).sqrt()
            }
        };
        if !len.is_finite() {
            return Err(self.invalid("non-finite move length"));
        }
        match feed {
            None => {
                self.report.rapid_length_mm += len;
                self.report.machining_time_s += len / self.opts.rapid_rate_mm_per_min * 60.0;
            }
            Some(f) => {
                self.report.feed_length_mm += len;
                if f.is_finite() && f > 0.0 {
                    self.report.machining_time_s += len / f * 60.0;
                } else {
                    self.report.feedless_moves += 1;
                }
            }
        }
        let op = if self.bead.is_some() {
            if rapid || extrude.is_none_or(|e| e.is_nan() || e <= 0.0) || !known {
                return Ok(());
            }
            Op::Deposit
        } else {
            Op::Cut
        };
        if known && len == 0.0 && interp.is_none() {
            return Ok(());
        }
        // Pieces: chords of arcs, and sub-steps of a frame change.
        let h = self.store.spec.voxel.min();
        let tol = self.opts.arc_tolerance * h;
        let mut pieces = 1usize;
        if let Path::Arc { sweep, r0, r1, .. } = path {
            let r = r0.max(r1);
            if r > tol {
                let step = 2.0 * (1.0 - tol / r).clamp(-1.0, 1.0).acos();
                pieces = ((sweep.abs() / step.max(1e-9)).ceil() as usize).max(1);
            }
        }
        let (f0, f1) = match interp {
            Some((prev, _)) => (prev, self.frame),
            None => (self.frame, self.frame),
        };
        if interp.is_some() {
            let angle = f0.rotation.angle_to(&f1.rotation);
            let reach = from.coords.norm().max(to.coords.norm()) + self.tool.stickout + self.tool.radius;
            let dtheta = (2.0 * tol / reach).min((8.0 * tol / reach).sqrt()).max(1e-9);
            let n = (angle / dtheta).ceil() as usize;
            pieces = pieces.max(n.clamp(1, self.opts.max_substeps));
        }
        let pieces = pieces.min(1 << 22);
        let point = |s: f64| -> Point3 {
            match path {
                Path::Line => from + (to - from) * s,
                Path::Arc { center, plane, sweep, r0, r1, a0, h0, h1 } => {
                    let (u, v, n) = plane_axes(plane);
                    let ang = a0 + sweep * s;
                    let r = r0 + (r1 - r0) * s;
                    let mut p = center;
                    p[u] = center[u] + r * ang.cos();
                    p[v] = center[v] + r * ang.sin();
                    p[n] = h0 + (h1 - h0) * s;
                    if s >= 1.0 { to } else { p }
                }
            }
        };
        let frame_at = |s: f64| -> Isometry3 {
            if interp.is_none() {
                return f0;
            }
            let rot: UnitQuaternion<f64> = f0.rotation.slerp(&f1.rotation, s);
            let tr = f0.translation.vector.lerp(&f1.translation.vector, s);
            Isometry3::from_parts(Translation3::from(tr), rot)
        };
        let mut s_prev = 0.0;
        let mut fr_prev = frame_at(0.0);
        let mut p_prev = fr_prev * point(0.0);
        for i in 1..=pieces {
            let s = i as f64 / pieces as f64;
            let fr = frame_at(s);
            let p = fr * point(s);
            let axis = frame_at(0.5 * (s + s_prev)).rotation * Vector3::z();
            self.sweep(p_prev, p, axis, rapid, op);
            s_prev = s;
            fr_prev = fr;
            p_prev = p;
        }
        let _ = fr_prev;
        Ok(())
    }
}

/// `(u, v, normal)` coordinate indices of an arc plane (u x v = normal).
fn plane_axes(plane: Plane) -> (usize, usize, usize) {
    match plane {
        Plane::XY => (0, 1, 2),
        Plane::ZX => (2, 0, 1),
        Plane::YZ => (1, 2, 0),
    }
}

impl MotionSink for Simulator {
    type Error = SimError;

    fn motion(&mut self, motion: &Motion<'_>) -> Result<()> {
        match motion {
            Motion::Rapid { to } => self.do_move(*to, None, None, None),
            Motion::Linear { to, feed, extrude } => self.do_move(*to, None, Some(*feed), *extrude),
            Motion::Arc { to, center, plane, direction, turns, feed, extrude } => {
                if !center.iter().all(|c| c.is_finite()) || !to.iter().all(|c| c.is_finite()) {
                    return Err(self.invalid("non-finite arc"));
                }
                let from = self.pos.unwrap_or(*to);
                let (u, v, n) = plane_axes(*plane);
                let (du0, dv0) = (from[u] - center[u], from[v] - center[v]);
                let (du1, dv1) = (to[u] - center[u], to[v] - center[v]);
                let r0 = du0.hypot(dv0);
                let r1 = du1.hypot(dv1);
                if r0 == 0.0 || r1 == 0.0 || self.pos.is_none() {
                    // Degenerate arc (or unknown start): a straight move (documented fallback).
                    return self.do_move(*to, None, Some(*feed), *extrude);
                }
                let a0 = dv0.atan2(du0);
                let a1 = dv1.atan2(du1);
                let tau = std::f64::consts::TAU;
                let extra = *turns as f64 * tau;
                let sweep = match direction {
                    ArcDirection::CounterClockwise => {
                        let mut s = (a1 - a0).rem_euclid(tau);
                        if s <= 1e-12 {
                            s += tau;
                        }
                        s + extra
                    }
                    ArcDirection::Clockwise => {
                        let mut s = (a0 - a1).rem_euclid(tau);
                        if s <= 1e-12 {
                            s += tau;
                        }
                        -(s + extra)
                    }
                };
                let path =
                    Path::Arc { center: *center, plane: *plane, sweep, r0, r1, a0, h0: from[n], h1: to[n] };
                self.do_move(*to, Some(path), Some(*feed), *extrude)
            }
            Motion::ToolChange { tool } => {
                self.tool = *self.tools.get(*tool);
                self.prims = ToolPrims::cutter(&self.tool);
                Ok(())
            }
            Motion::Dwell { seconds } => {
                if seconds.is_finite() && *seconds > 0.0 {
                    self.report.machining_time_s += seconds;
                }
                Ok(())
            }
            Motion::Setup { frame, .. } => {
                let ok = frame.translation.vector.iter().all(|c| c.is_finite())
                    && frame.rotation.coords.iter().all(|c| c.is_finite());
                if !ok {
                    return Err(self.invalid("non-finite setup frame"));
                }
                self.pending_setup = Some((self.frame, self.line));
                self.frame = *frame;
                Ok(())
            }
            Motion::ToolAxis { axis, .. } => {
                if (axis - Vector3::z()).norm() > 1e-9 {
                    return Err(self.invalid(format!(
                        "a tilting head's tool axis {axis} is off +Z: the simulator turns the part (setups), not the tool"
                    )));
                }
                Ok(())
            }
            Motion::End => {
                self.flush_all();
                Ok(())
            }
            _ => Ok(()),
        }
    }

    fn source_line(&mut self, line: u64) -> Result<()> {
        self.line = line;
        Ok(())
    }

    fn finish(&mut self) -> Result<()> {
        self.flush_all();
        Ok(())
    }
}

impl Simulation {
    /// The residual stock as a closed triangle mesh (geom's voxel marching cubes).
    pub fn residual_mesh(&self) -> Result<s2g_geom::Mesh> {
        Ok(s2g_geom::marching_cubes_voxels(&self.residual)?)
    }
}

fn parse_error(e: s2g_gcode::ParseError<SimError>) -> SimError {
    e.into()
}

/// Parses `program` (G-code text, stopping at the first G-code error) and simulates it on
/// `stock` with `tools`.
pub fn simulate_str(
    program: &str,
    stock: VoxelGrid,
    tools: ToolTable,
    opts: &SimOptions,
) -> Result<Simulation> {
    let mut sim = Simulator::new(stock, tools, opts.clone())?;
    let popts = s2g_gcode::ParseOptions { stop_at_first_error: true, ..Default::default() };
    s2g_gcode::parse_str(program, &popts, &mut sim).map_err(parse_error)?;
    sim.into_simulation()
}

/// [`simulate_str`] for a file (streamed; errors name the file).
pub fn simulate_file(
    path: impl AsRef<std::path::Path>,
    stock: VoxelGrid,
    tools: ToolTable,
    opts: &SimOptions,
) -> Result<Simulation> {
    let mut sim = Simulator::new(stock, tools, opts.clone())?;
    let popts = s2g_gcode::ParseOptions { stop_at_first_error: true, ..Default::default() };
    s2g_gcode::parse_file(path, &popts, &mut sim).map_err(parse_error)?;
    sim.into_simulation()
}
