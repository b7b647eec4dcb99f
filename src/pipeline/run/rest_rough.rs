//! Rest roughing ([`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing)): a
//! setup machined again, right after its own program's roughing and before its finishing,
//! with smaller flat end mills over the simulated in-process stock, where material they
//! are for is left.

use super::MillRun;
use crate::geom::{DropCutter, MeshIndex, Point3, Setup, VoxelGrid};
use crate::pipeline::api::{MillError, Preset, SetupProgram, Stage};
use crate::pipeline::job::{FinishJob, Job, stock_in_setup};
use crate::pipeline::per_setup::machine_setup;
use crate::policy::Action;
use crate::toolpath::Tool;
use crate::toolpath::finish::part_in_setup_frame;
use crate::toolpath::library::Cutting;
use crate::trace::PathTrace;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU8, Ordering};

impl MillRun {
    /// Machines the last job, setup `i`'s own (0-based): planned, written and simulated;
    /// the material left is updated. The first setup's toolpath is traced when asked. With
    /// `finish_if`, the job's finishing follows its roughing where `finish_if`, asked of
    /// the run once the roughing is simulated, says yes ([`machine_setup`]).
    ///
    /// A program with fitted arcs whose shank or holder met stock is wound back and written
    /// again with straight moves (the same plan, [`PlanOptions::fit_arcs`] false): under an
    /// overhang's shadow each level's contour is the same curve, each fitted on its own to
    /// within the arc tolerance on the part's side, so a lower level's shank, following its
    /// flutes' path, can stand up to the tolerance inside what a level above left
    /// (example004's oblique 12 mm roughing at 256^3 with the tool-aware reach).
    ///
    /// [`PlanOptions::fit_arcs`]: crate::toolpath::PlanOptions::fit_arcs
    pub(super) fn machine_own(
        &mut self,
        i: usize,
        mut finish_if: Option<&mut dyn FnMut(&Self) -> bool>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<(), MillError> {
        let n = self.jobs.len() - 1;
        let popts = &self.jobs[n].popts;
        let cutter = &self.jobs[n].tool.cutter;
        let guarded = cutter.stickout.is_finite() || cutter.holder.is_some();
        let before = (popts.fit_arcs && popts.arc_tolerance.is_some() && guarded)
            .then(|| (self.sim.borrow().clone(), self.trace.clone()));
        let first = self.machine_own_once(i, finish_if.as_deref_mut(), progress)?;
        let (program, remaining) = match before {
            Some((sim, trace)) if !first.0.holder_collision_lines.is_empty() => {
                (*self.sim.get_mut(), self.trace) = (sim, trace);
                self.jobs[n].popts.fit_arcs = false;
                self.machine_own_once(i, finish_if, progress)?
            }
            _ => first,
        };
        self.setups.push(program);
        self.remaining = remaining;
        Ok(())
    }

    /// [`Self::machine_own`]'s program and the material left after it, written once.
    fn machine_own_once<'f>(
        &mut self,
        i: usize,
        finish_if: Option<&mut (dyn FnMut(&Self) -> bool + 'f)>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<(SetupProgram, VoxelGrid), MillError> {
        let n = self.jobs.len() - 1;
        let mut trace = std::mem::take(&mut self.trace);
        if i == 0 {
            trace = PathTrace::default();
        }
        let mut times = self.times;
        let run = &*self;
        let mut ask = finish_if.map(|f| move || f(run));
        let result = machine_setup(
            &run.ctx(),
            n,
            &run.remaining,
            (i == 0 && run.keep_trace).then_some(&mut trace),
            &mut times,
            progress,
            ask.as_mut().map(|a| a as &mut dyn FnMut() -> bool),
        );
        (self.trace, self.times) = (trace, times);
        result
    }

    /// Machines setup `i`'s own job, the last, then its rest passes where the rest rule
    /// finds one worth it from its first rest tool `rest` ([`rest_verdict`](Self::rest_verdict)).
    /// Where the job is finished (`finishes`; `finisher` is the tool a rest pass leaves
    /// material for, none where the ball takes only sculpted faces) and has a rest tool, whether a pass
    /// follows is known once its roughing is simulated: the program goes on with its
    /// finishing where none does, and ends after the roughing where one does (the passes
    /// then carry the finishing).
    pub(super) fn machine_own_then_rest(
        &mut self,
        i: usize,
        rest: Option<RestTool>,
        finishes: bool,
        finisher: Option<Tool>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<(), MillError> {
        let verdict = if rest.is_some() && finishes {
            let mut verdict = None;
            let mut finish_if = |run: &Self| {
                let left = run.ctx().excess();
                let v = left.and_then(|left| run.rest_verdict(&left, i, rest, finisher.as_ref()));
                let finish_here = matches!(v, Ok((None, ..)));
                verdict = Some(v);
                finish_here
            };
            self.machine_own(i, Some(&mut finish_if), progress)?;
            verdict
        } else {
            self.machine_own(i, None, progress)?;
            None
        };
        let verdict = match verdict {
            Some(v) => v?,
            None => self.rest_verdict(&self.remaining, i, rest, finisher.as_ref())?,
        };
        if let (Some(first), tried, scope) = verdict {
            // The rest passes carry the setup's finishing, which its own program left out.
            let finish = self.jobs.last_mut().and_then(|j| j.finish.take());
            return self.rest_rough(i, &scope, first, tried, finish, progress);
        }
        Ok(())
    }

    /// The most programs the run writes: one per setup, and in the shop preset's per-setup
    /// layout one per setup and rest-roughing pass ([`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing)), of
    /// which [`Milled::programs`](crate::Milled::programs) holds those written (a setup gets no rest pass where the
    /// library has no smaller flat end mill).
    pub fn program_bound(&self) -> usize {
        let rest = if self.placements.is_none() && self.opts.preset == Preset::Shop {
            self.opts.rest_roughing
        } else {
            0
        };
        // An undercut pass per setup where the library has a T-slot cutter.
        self.setup_count() * (1 + rest + usize::from(self.may_undercut()))
    }

    /// The index of the last setup's own job: rest passes follow their setup's own job at
    /// once (`machine_finished`), so the setup they machine again is its.
    fn own_job_index(&self) -> Option<usize> {
        self.jobs.iter().rposition(|j| j.rest_of.is_none())
    }

    /// The last setup's own job ([`own_job_index`](Self::own_job_index)).
    fn own_job(&self) -> Option<&Job> {
        self.own_job_index().map(|i| &self.jobs[i])
    }

    /// How many setups have their action (the jobs less the rest-roughing ones).
    pub(super) fn chosen(&self) -> usize {
        self.jobs.iter().filter(|j| j.rest_of.is_none()).count()
    }

    /// The first rest-roughing tool of setup `k` (0-based) roughed by `job`
    /// ([`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing)): a flat end mill
    /// of the library smaller than its own (`Tooling::rest_tool`). None in the paper preset,
    /// the rotary layout, with no rest passes, or where the library has none smaller.
    pub(super) fn first_rest_tool(&self, k: usize, job: &Job) -> Result<Option<RestTool>, MillError> {
        if self.placements.is_some() || self.opts.preset != Preset::Shop || self.opts.rest_roughing == 0 {
            return Ok(None);
        }
        self.smaller_tool(k, job.tool.radius())
    }

    /// The rest tool after one of `radius` in setup `k` (`Tooling::rest_tool`), if smaller.
    fn smaller_tool(&self, k: usize, radius: f64) -> Result<Option<RestTool>, MillError> {
        Ok(self.tooling.rest_tool(radius, self.stock_depth(k))?.filter(|t| t.0.radius() < radius))
    }

    /// How deep the stock is along setup `k`'s (0-based) axis: the depth the rest tool rule
    /// ranks reach over.
    fn stock_depth(&self, k: usize) -> f64 {
        stock_in_setup(&self.stock, &self.orientation.setups[k]).extent().z
    }

    /// How deep below the setup's stock top a rest pass with `tool` may cut (its planning
    /// stick-out): its flutes' length (a long-reach end mill's neck's reach) at least; with
    /// a shank no wider than its flutes (which then follows them down through what they
    /// cut), as deep as keeps its holder, at the
    /// library's stick-out above the tip, a millimetre and a voxel diagonal above the highest
    /// material left in the setup (stock or part), and no deeper than its stick-out below
    /// the stock's top. (With the flutes' length only, a 4 mm tool stopped 12 mm into the
    /// turned shaft's 28 mm cross hole from either side.)
    fn rest_reach(&self, setup: &Setup, tool: &Tool) -> f64 {
        let c = &tool.cutter;
        if c.shank_radius > c.radius || !c.stickout.is_finite() {
            // As deep as the flutes, or a long-reach end mill's neck, are long.
            return c.shank_start();
        }
        let top = stock_in_setup(&self.stock, setup).max.z;
        let grid = self.sim.borrow_mut().residual_grid();
        let spec = *grid.spec();
        let high = grid
            .iter_set()
            .map(|[i, j, k]| setup.to_setup(&spec.center(i, j, k)).z)
            .fold(f64::NEG_INFINITY, f64::max);
        if !high.is_finite() {
            return c.flute_length;
        }
        let margin = 1.0 + spec.voxel.norm();
        (c.stickout + (top - high) - margin).clamp(c.shank_start(), c.stickout)
    }

    /// The least material (mm³) a rest pass is for: [`MillOptions::rest_continue`](crate::MillOptions::rest_continue)
    /// of the part's volume on the simulation grid.
    pub(super) fn rest_volume(&self) -> f64 {
        self.opts.rest_continue * self.target.count() as f64 * self.target.spec().voxel_volume()
    }

    /// The [`RestScope`] of the setup last roughed, built once for every tool the rest rule
    /// considers there; none indexed where no rest tool is `wanted` or the part is empty in
    /// its frame (no rest pass is then worth it).
    pub(super) fn rest_scope(&self, wanted: bool) -> RestScope {
        let none = RestScope { index: None, bottom: f64::INFINITY, cache: Default::default() };
        let Some(own) = self.own_job().filter(|_| wanted) else { return none };
        let part = part_in_setup_frame(&self.part, &own.setup);
        let bottom = part.bbox().map_or(f64::INFINITY, |b| b.min.z);
        RestScope { index: MeshIndex::new(&part).ok(), bottom, cache: Default::default() }
    }

    /// The material left (mm³) that a rest pass with `tool` after one with `wider` in the
    /// setup last roughed is for: [`rest_left`](Self::rest_left) of `remaining` from the
    /// stock's top down to the tool's reach ([`rest_reach`](Self::rest_reach)), with the
    /// setup's `finisher`.
    pub(super) fn reachable_left(
        &self,
        remaining: &VoxelGrid,
        scope: &RestScope,
        tool: &Tool,
        wider: &Tool,
        finisher: Option<&Tool>,
    ) -> f64 {
        let Some(own) = self.own_job() else { return 0.0 };
        let top = stock_in_setup(&self.stock, &own.setup).max.z;
        self.rest_left(
            remaining,
            scope,
            [tool, wider],
            [top - self.rest_reach(&own.setup, tool), f64::INFINITY],
            finisher,
        )
    }

    /// The material left (mm³) in the setup last roughed, between heights `[lo, hi]` of its
    /// frame, that a rest pass with `tool` after one with `wider` is for (classic rest
    /// machining): voxels of `remaining` (the simulated stock less the part), seen along the setup's tool
    /// axis (the ray from the voxel's centre towards the spindle leaves the grid without
    /// meeting the part's voxels), no lower than the part's lowest point in the setup (where
    /// its layers stop), farther from the part than the finishing allowance and a quarter
    /// voxel, that `tool` takes and `wider` does not, and that, where the setup is finished
    /// with `finisher`, its end does not take either.
    ///
    /// A tool takes a voxel when, lowered over the part (drop-cutter) at some place whose
    /// cutter covers the voxel, it cuts at most a voxel above the voxel's centre there (its
    /// tip, raised by its end's rounding at the voxel's distance from its axis), and the
    /// voxel lies within its reach below the stock's top. The rest tool is lowered at 19
    /// places (over the voxel, six at half its radius, twelve at 0.95, so that in a square
    /// corner one lies on the bisector); the wider one at 61 out to 0.98 of its radius, so
    /// that beside a straight wall it takes what a smaller tool takes (at 13 places, six at
    /// 0.95, a tool covers a voxel no nearer the wall than 0.18 of its radius, at the 61
    /// places 0.03). The finisher is lowered at 13 places (six at 0.95) and takes
    /// what it cuts to within half a voxel: a 6 mm ball rests 0.27 mm into a 2.5 mm groove.
    /// What the wider tool takes but left is the roughing's terraces between layers, which
    /// a pass at the same layers leaves as they are; what the finisher takes it takes (on
    /// the bunny at 100 mm, rest passes over that material cost an hour of machining for no
    /// IoU: 13,930 s against 10,167 s). The voxels beside the part count: in a groove a few
    /// voxels wide they are most of it (the turned shaft's 2.5 mm grooves, 4 voxels wide at
    /// 128: for the 2 mm tool 148 voxels a setup, 36 mm³, and 6 with the voxels beside the
    /// part left out as before; with `--rest-continue 0` the passes removed 30 mm³ a setup
    /// there, in 0.5 mm cells of the independent scorer). Whether the rest tool gets there
    /// is the planner's to find: this bounds what the pass can remove.
    fn rest_left(
        &self,
        remaining: &VoxelGrid,
        scope: &RestScope,
        [tool, wider]: [&Tool; 2],
        [lo, hi]: [f64; 2],
        finisher: Option<&Tool>,
    ) -> f64 {
        let Some(own) = self.own_job() else { return 0.0 };
        let Some(index) = scope.index.as_ref() else { return 0.0 };
        let setup = own.setup;
        let spec = *remaining.spec();
        let h = spec.voxel.min();
        // The setup's own roughing's allowance (none where it cut to size).
        let allowance = own.popts.finishing_allowance.max(own.popts.axial_allowance);
        let axis = setup.tool_axis().into_inner();
        let target = &self.target;
        let seen = |p: Point3| {
            let mut t = 0.5 * h;
            loop {
                let Some([i, j, k]) = spec.index_of(&(p + axis * t)) else { return true };
                if target.get(i, j, k) {
                    return false;
                }
                t += 0.5 * h;
            }
        };
        let top = stock_in_setup(&self.stock, &setup).max.z;
        let cutter = |t: &Tool| {
            let corner = t.cutter.shape.end().corner_radius(t.radius());
            DropCutter::new(index, &t.cutter)
                .ok()
                .map(|dc| (dc, t.radius(), corner, top - t.envelope().length))
        };
        let (Some(rest), Some(wide)) = (cutter(tool), cutter(wider)) else { return 0.0 };
        let ball = finisher.and_then(cutter);
        // Where a tool is lowered to take a voxel, in its radii: over it, and around it at
        // half and 0.95 of its radius (six and six places); the wider tool at 24 and 36
        // places out to 0.98.
        let ring = |n: usize, f: f64, turn: f64| {
            (0..n).map(move |m| {
                let a = std::f64::consts::TAU * (m as f64 + turn) / n as f64;
                [f * a.cos(), f * a.sin()]
            })
        };
        let coarse: Vec<[f64; 2]> =
            std::iter::once([0.0, 0.0]).chain(ring(6, 0.5, 0.0)).chain(ring(6, 0.95, 0.5)).collect();
        // The rest tool also at twelve places at 0.95, every 30 degrees from 15: in a
        // square corner the wider tool's fillet lies along the bisector, where the six
        // places (30 degrees off it) put the rest tool into a wall; it found no voxel of
        // the 6 mm end mill's fillets in example002's square holes for the 4 mm one.
        let corners: Vec<[f64; 2]> =
            std::iter::once([0.0, 0.0]).chain(ring(6, 0.5, 0.0)).chain(ring(12, 0.95, 0.5)).collect();
        let fine: Vec<[f64; 2]> =
            std::iter::once([0.0, 0.0]).chain(ring(24, 0.5, 0.0)).chain(ring(36, 0.98, 0.5)).collect();
        // Whether the tool, lowered at one of `places` (in radii) around the voxel at `q`,
        // cuts to at most `above` over its centre there: its tip, raised by its end's
        // rounding at the voxel's distance from its axis (a ball's sphere).
        type Lowered<'a> = (DropCutter<'a>, f64, f64, f64);
        let takes = |(dc, r, corner, floor): &Lowered<'_>, q: &Point3, places: &[[f64; 2]], above: f64| {
            q.z >= *floor
                && places.iter().any(|[x, y]| {
                    let off = (r * x.hypot(*y) - (r - corner)).max(0.0);
                    let lift = corner - (corner * corner - off * off).max(0.0).sqrt();
                    // Nothing above the level there: the tip stops at most at it (or nothing
                    // stops it), found without the whole drop where the part is higher.
                    dc.height_above(q.x + r * x, q.y + r * y, q.z - lift + above).is_none()
                })
        };
        // Farther from the part than the allowance and a quarter voxel: what the rest tool
        // cuts to size.
        let clear = allowance + 0.25 * h;
        // What does not depend on the rest tool is worked out once for the material left,
        // the wider tool and the finisher (the rule asks for several rest tools in turn),
        // each voxel when first in a tool's range: the same tests, in the same order.
        let mut cache = scope.cache.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let key = (*wider, finisher.copied());
        if !cache.as_ref().is_some_and(|c| c.holds(remaining, &key)) {
            *cache = Some(RestCache::new(remaining, key));
        }
        let Some(cache) = cache.as_ref() else { return 0.0 };
        let count: usize = cache
            .bricks
            .par_iter()
            .map(|&(b, corner, offset)| {
                let mut n = 0;
                for (ordinal, [di, dj, dk]) in brick_voxels(&cache.remaining_bricks[b]).enumerate() {
                    let [i, j, k] = [corner[0] + di, corner[1] + dj, corner[2] + dk];
                    let p = spec.center(i, j, k);
                    let q = setup.to_setup(&p);
                    if !((lo..=hi).contains(&q.z) && q.z >= scope.bottom) {
                        continue;
                    }
                    let state = &cache.state[offset + ordinal];
                    let mut known = state.load(Ordering::Relaxed);
                    if known == RestCache::UNKNOWN {
                        let kept = seen(p)
                            && index.closest_point(&q).distance > clear
                            && !ball.as_ref().is_some_and(|b| takes(b, &q, &coarse, 0.5 * h));
                        known = if kept { RestCache::KEPT } else { RestCache::OUT };
                        state.store(known, Ordering::Relaxed);
                    }
                    if known == RestCache::OUT || !takes(&rest, &q, &corners, h) {
                        continue;
                    }
                    if known == RestCache::KEPT {
                        let wide_takes = takes(&wide, &q, &fine, h);
                        known = if wide_takes { RestCache::WIDE_TAKES } else { RestCache::WIDE_LEAVES };
                        state.store(known, Ordering::Relaxed);
                    }
                    n += usize::from(known == RestCache::WIDE_LEAVES);
                }
                n
            })
            .sum();
        count as f64 * spec.voxel_volume()
    }

    /// The rest tool of setup `k` (0-based) after a pass with `wider`: down the library
    /// from `candidate` ([`smaller_tool`](Self::smaller_tool) after each), the first one
    /// that at least [`rest_volume`](Self::rest_volume) of the material left (`remaining`)
    /// is for ([`reachable_left`](Self::reachable_left), with the setup's `finisher`), of at most
    /// [`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing) tools considered in
    /// the setup (`tried` counts them). A tool too wide for what is left is passed over
    /// for a smaller one: a 5 mm end mill cuts nothing of a 4.5 mm slot, a 3 mm one does.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn worth_a_pass(
        &self,
        remaining: &VoxelGrid,
        k: usize,
        scope: &RestScope,
        wider: &Tool,
        mut candidate: Option<RestTool>,
        tried: &mut usize,
        finisher: Option<&Tool>,
    ) -> Result<Option<RestTool>, MillError> {
        let mut bound = wider.radius();
        while let Some(t) = candidate {
            if *tried >= self.opts.rest_roughing {
                break;
            }
            *tried += 1;
            let left = self.reachable_left(remaining, scope, &t.0, wider, finisher);
            if left >= self.rest_volume() {
                return Ok(Some(
                    self.stiffer_if_as_good(remaining, k, scope, [wider, &t.0], bound, left, finisher)?
                        .unwrap_or(t),
                ));
            }
            bound = t.0.radius();
            candidate = self.smaller_tool(k, bound)?;
        }
        Ok(None)
    }

    /// Where the rest tool `long` (after one of `bound` radius), a long-reach end mill, is
    /// for `left` of the material left after `wider`, the stiffer tool the rest rule would
    /// take in its place (`Tooling::stiffer_rest_tool`: wider, or as wide on a shorter neck,
    /// reaching less deep) if that one is for as much less at most
    /// [`rest_volume`](Self::rest_volume): the extra reach buys nothing there, and the
    /// stiffer tool cuts faster (or the wider one leaves less).
    #[allow(clippy::too_many_arguments)]
    fn stiffer_if_as_good(
        &self,
        remaining: &VoxelGrid,
        k: usize,
        scope: &RestScope,
        [wider, long]: [&Tool; 2],
        bound: f64,
        left: f64,
        finisher: Option<&Tool>,
    ) -> Result<Option<RestTool>, MillError> {
        let Some(stiff) = self.tooling.stiffer_rest_tool(bound, self.stock_depth(k), long)? else {
            return Ok(None);
        };
        let theirs = self.reachable_left(remaining, scope, &stiff.0, wider, finisher);
        let worth = self.rest_volume();
        Ok((theirs >= worth && theirs + worth > left).then_some(stiff))
    }

    /// The rest rule's verdict on setup `k` (0-based), just roughed by its own job, the
    /// last, leaving `remaining` ([`worth_a_pass`](Self::worth_a_pass) from its first rest
    /// tool `rest`): the first rest tool worth a pass, if any, the tools considered, and
    /// the setup's [`RestScope`] for the passes.
    pub(super) fn rest_verdict(
        &self,
        remaining: &VoxelGrid,
        k: usize,
        rest: Option<RestTool>,
        finisher: Option<&Tool>,
    ) -> Result<RestVerdict, MillError> {
        let Some(own) = self.jobs.last().map(|j| j.tool) else {
            return Ok((None, 0, self.rest_scope(false)));
        };
        let scope = self.rest_scope(rest.is_some());
        let mut tried = 0;
        let first = self.worth_a_pass(remaining, k, &scope, &own, rest, &mut tried, finisher)?;
        Ok((first, tried, scope))
    }

    /// Rest roughing of setup `k` (0-based), just roughed by its own job, from `first`
    /// ([`worth_a_pass`](Self::worth_a_pass), `tried` tools considered so far) down the
    /// library: each pass machines the setup again, in its own program with the setup's
    /// fixture, action and datum, over the material the earlier programs left (the
    /// simulated stock less the part; the planner skips what is gone). A further, smaller
    /// tool follows where [`worth_a_pass`](Self::worth_a_pass) finds one. The setup's
    /// `finish` follows the last pass in its program: a pass after which a smaller tool
    /// may follow is cut without it, and where none follows, the simulation is wound back
    /// and the pass cut again with it. Called by
    /// [`machine_finished`](MillRun::machine_finished).
    pub(super) fn rest_rough(
        &mut self,
        k: usize,
        scope: &RestScope,
        first: RestTool,
        mut tried: usize,
        mut finish: Option<FinishJob>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<(), MillError> {
        let mut tool = first;
        let finisher = finish.as_ref().and_then(FinishJob::takes_rest);
        loop {
            let smaller = match tried < self.opts.rest_roughing {
                true => self.smaller_tool(k, tool.0.radius())?,
                false => None,
            };
            let tentative = smaller.is_some() && finish.is_some();
            let snapshot =
                tentative.then(|| (self.sim.borrow().clone(), self.remaining.clone(), self.jobs.len()));
            let mut program = self.rest_pass(
                k,
                scope,
                &tool,
                if smaller.is_some() { None } else { finish.take() },
                finisher,
                progress,
            )?;
            let next = self.worth_a_pass(
                &self.remaining,
                k,
                scope,
                &tool.0,
                smaller,
                &mut tried,
                finisher.as_ref(),
            )?;
            if let (None, Some((sim, remaining, jobs))) = (&next, snapshot) {
                (*self.sim.get_mut(), self.remaining) = (sim, remaining);
                self.jobs.truncate(jobs);
                program = self.rest_pass(k, scope, &tool, finish.take(), finisher, progress)?;
            }
            self.setups.push(program);
            match next {
                Some(t) => tool = t,
                None => return Ok(()),
            }
        }
    }

    /// One rest pass of setup `k` with `tool`, then `finish` in its program: planned,
    /// written and simulated; the material left is updated. `finisher` is the tool that
    /// finishes the setup, in this program or a later one.
    fn rest_pass(
        &mut self,
        k: usize,
        scope: &RestScope,
        tool: &RestTool,
        finish: Option<FinishJob>,
        finisher: Option<Tool>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<SetupProgram, MillError> {
        let own = self.own_job_index().unwrap_or(0);
        let (setup, note, action) = {
            let j = &self.jobs[own];
            (j.setup, j.note.clone(), j.action)
        };
        // Levels no farther apart than the rest tool's radius: at the own levels the
        // material in a groove the wider tool could not enter stays as terraces between
        // them (the turned shaft's 2.5 mm grooves, seen from the side, are troughs 2 mm
        // deep that a 2 mm end mill at 2 mm levels cut a fifth of).
        let action = Action {
            tool_radius: tool.0.radius(),
            layer_height: action.layer_height.min(tool.0.radius()),
            ..action
        };
        self.check_deadline(|| format!("rest roughing setup {} of {}", k + 1, self.setup_count()))?;
        // A rest pass reaches only as deep as keeps its holder above all stock
        // ([`rest_reach`](Self::rest_reach)).
        let (mut cutter, cutting) = *tool;
        let (library, flutes) = (cutter.cutter, cutter.cutter.flute_length);
        // Deeper than its flutes only where material the pass is for lies there: the
        // roughing's terraces alone cost the bunny 19 minutes of 8 mm passes for no IoU.
        let reach = self.rest_reach(&setup, &cutter);
        let top = stock_in_setup(&self.stock, &setup).max.z;
        let wider = self.jobs[own].tool;
        let deep_left = || {
            self.rest_left(
                &self.remaining,
                scope,
                [&cutter, &wider],
                [top - reach, top - flutes],
                finisher.as_ref(),
            )
        };
        let planned = match reach > flutes && deep_left() >= self.rest_volume() {
            true => reach,
            false => flutes,
        };
        cut_short(&mut cutter.cutter, planned);
        let mut job = Job::new(
            &setup,
            &action,
            (cutter, cutting),
            &self.stock,
            self.rapid,
            self.clearance,
            &self.opts,
        )?;
        job.note = Some(match &note {
            Some(n) => format!("{n}; rest roughing of setup {}", k + 1),
            None => format!("rest roughing of setup {}", k + 1),
        });
        job.rest_of = Some(k);
        // As the setup's own roughing: with the allowance, or cut to size.
        let own_popts = &self.jobs[own].popts;
        (job.popts.finishing_allowance, job.popts.axial_allowance) =
            (own_popts.finishing_allowance, own_popts.axial_allowance);
        // A last level at the floor the rest tool reaches in each region its regular
        // levels stop above (a V groove's flanks as far apart as the tool is wide).
        job.popts.floor_levels = true;
        job.finish = finish;
        self.jobs.push(job);
        let at = self.jobs.len() - 1;
        // Deeper than its flutes, the pass is checked in the simulator: where its shank or
        // holder met stock, the simulation is wound back and the pass cut again as deep as
        // its flutes are long.
        let deep = self.jobs[at].tool.cutter.stickout > flutes;
        let before = deep.then(|| self.sim.borrow().clone());
        let mut times = self.times;
        let result = machine_setup(&self.ctx(), at, &self.remaining, None, &mut times, progress, None);
        let result = match (result, before) {
            (Ok((program, _)), Some(before)) if !program.holder_collision_lines.is_empty() => {
                *self.sim.get_mut() = before;
                cut_short(&mut self.jobs[at].tool.cutter, flutes);
                machine_setup(&self.ctx(), at, &self.remaining, None, &mut times, progress, None)
            }
            (result, _) => result,
        };
        self.times = times;
        let (mut program, remaining) = result?;
        program.rest_of = Some(k + 1);
        // The program ran with the library's tool: only its plan was cut short.
        program.tool.cutter = library;
        self.remaining = remaining;
        Ok(program)
    }
}

/// Cuts a rest pass's planning cutter short: its stick-out at `to` above the tip, and a
/// long-reach end mill's neck no longer (none where `to` is the flutes' length), so that
/// it plans no deeper ([`Cutter::reach`](crate::geom::Cutter::reach)) and stays valid.
fn cut_short(c: &mut crate::geom::Cutter, to: f64) {
    c.stickout = to;
    c.neck =
        c.neck.filter(|_| to > c.flute_length).map(|n| crate::geom::Neck { reach: n.reach.min(to), ..n });
}

/// A rest-roughing tool and its cutting data.
pub(super) type RestTool = (Tool, Option<Cutting>);

/// The rest rule's verdict on a setup just roughed ([`MillRun::rest_verdict`]).
pub(super) type RestVerdict = (Option<RestTool>, usize, RestScope);

/// What the rest rule ([`MillRun::rest_left`]) asks of one setup's part and does not change
/// between its passes, built once per setup ([`MillRun::rest_scope`]) and shared by every
/// tool it considers and every deep-reach check: the part in the setup's frame, indexed for
/// drop-cutters, and its lowest point there (below it the setup's layers do not go).
pub(super) struct RestScope {
    index: Option<MeshIndex>,
    bottom: f64,
    /// What the rule found of the voxels last weighed ([`RestCache`]).
    cache: std::sync::Mutex<Option<RestCache>>,
}

/// What [`MillRun::rest_left`] found of each voxel of the material left that does not
/// depend on the rest tool, for one wider tool and finisher: whether it is seen along the
/// axis, clear of the part and not the finisher's, and where the rest tool takes it, whether
/// the wider tool does. Each voxel's state is set by the one thread that weighs it, so the
/// count is the same whatever the number of threads.
struct RestCache {
    key: (Tool, Option<Tool>),
    /// The material left: its grid and bricks, and per brick with a voxel set, its index,
    /// its lower corner's voxel and the offset of its first voxel's state in `state`.
    spec: crate::geom::GridSpec,
    remaining_bricks: Vec<crate::geom::Brick>,
    bricks: Vec<(usize, [usize; 3], usize)>,
    state: Vec<AtomicU8>,
}

impl RestCache {
    const UNKNOWN: u8 = 0;
    const OUT: u8 = 1;
    const KEPT: u8 = 2;
    const WIDE_TAKES: u8 = 3;
    const WIDE_LEAVES: u8 = 4;

    fn new(remaining: &VoxelGrid, key: (Tool, Option<Tool>)) -> Self {
        let mut bricks = Vec::new();
        let mut remaining_bricks = Vec::with_capacity(remaining.brick_dims().iter().product());
        let mut total = 0;
        for (b, (corner, brick)) in remaining.bricks().enumerate() {
            remaining_bricks.push(*brick);
            let n: usize = brick.iter().map(|w| w.count_ones() as usize).sum();
            if n > 0 {
                bricks.push((b, corner, total));
                total += n;
            }
        }
        let state = (0..total).map(|_| AtomicU8::new(Self::UNKNOWN)).collect();
        Self { key, spec: *remaining.spec(), remaining_bricks, bricks, state }
    }

    /// Whether this is what was found of `remaining` for `key`.
    fn holds(&self, remaining: &VoxelGrid, key: &(Tool, Option<Tool>)) -> bool {
        self.key == *key
            && self.spec == *remaining.spec()
            && remaining.bricks().len() == self.remaining_bricks.len()
            && remaining.bricks().zip(&self.remaining_bricks).all(|((_, a), b)| a == b)
    }
}

/// The set voxels of a brick, as offsets from its lower corner, in a fixed order.
fn brick_voxels(brick: &crate::geom::Brick) -> impl Iterator<Item = [usize; 3]> + '_ {
    use crate::geom::BRICK;
    brick.iter().enumerate().flat_map(|(z, &word)| {
        (0..BRICK * BRICK)
            .filter(move |bit| word >> bit & 1 == 1)
            .map(move |bit| [bit % BRICK, bit / BRICK, z])
    })
}
