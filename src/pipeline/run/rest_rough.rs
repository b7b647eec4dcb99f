//! Rest roughing ([`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing)): a
//! setup machined again, right after its own program's roughing and before its finishing,
//! with smaller flat end mills over the simulated in-process stock, where material they
//! are for is left.

use super::MillRun;
use crate::geom::{DropCutter, MeshIndex, Point3, Setup};
use crate::pipeline::api::{MillError, Preset, SetupProgram, Stage};
use crate::pipeline::job::{FinishJob, Job, stock_in_setup};
use crate::pipeline::per_setup::machine_setup;
use crate::policy::Action;
use crate::toolpath::Tool;
use crate::toolpath::finish::part_in_setup_frame;
use crate::toolpath::library::Cutting;
use crate::trace::PathTrace;
use rayon::prelude::*;

impl MillRun {
    /// Machines the last job, setup `i`'s own (0-based): planned, written and simulated;
    /// the material left is updated. The first setup's toolpath is traced when asked.
    pub(super) fn machine_own(&mut self, i: usize, progress: &mut dyn FnMut(Stage)) -> Result<(), MillError> {
        let n = self.jobs.len() - 1;
        let mut trace = std::mem::take(&mut self.trace);
        if i == 0 {
            trace = PathTrace::default();
        }
        let mut times = self.times;
        let result = machine_setup(
            &self.ctx(),
            n,
            &self.remaining,
            (i == 0 && self.keep_trace).then_some(&mut trace),
            &mut times,
            progress,
        );
        (self.trace, self.times) = (trace, times);
        let (program, remaining) = result?;
        self.setups.push(program);
        self.remaining = remaining;
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
        self.setup_count() * (1 + rest)
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
        let depth = stock_in_setup(&self.stock, &self.orientation.setups[k]).extent().z;
        Ok(self.tooling.rest_tool(radius, depth)?.filter(|t| t.0.radius() < radius))
    }

    /// How deep below the setup's stock top a rest pass with `tool` may cut (its planning
    /// stick-out): its flutes' length at least; with a shank no wider than its flutes (which
    /// then follows them down through what they cut), as deep as keeps its holder, at the
    /// library's stick-out above the tip, a millimetre and a voxel diagonal above the highest
    /// material left in the setup (stock or part), and no deeper than its stick-out below
    /// the stock's top. (With the flutes' length only, a 4 mm tool stopped 12 mm into the
    /// turned shaft's 28 mm cross hole from either side.)
    fn rest_reach(&self, setup: &Setup, tool: &Tool) -> f64 {
        let c = &tool.cutter;
        if c.shank_radius > c.radius || !c.stickout.is_finite() {
            return c.flute_length;
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
        (c.stickout + (top - high) - margin).clamp(c.flute_length, c.stickout)
    }

    /// The least material (mm³) a rest pass is for: [`MillOptions::rest_continue`](crate::MillOptions::rest_continue)
    /// of the part's volume on the simulation grid.
    pub(super) fn rest_volume(&self) -> f64 {
        self.opts.rest_continue * self.target.count() as f64 * self.target.spec().voxel_volume()
    }

    /// The material left (mm³) that a rest pass with `tool` after one with `wider` in the
    /// setup last roughed is for: [`rest_left`](Self::rest_left) from the stock's top down
    /// to the tool's reach ([`rest_reach`](Self::rest_reach)), with the setup's `finisher`.
    pub(super) fn reachable_left(&self, tool: &Tool, wider: &Tool, finisher: Option<&Tool>) -> f64 {
        let Some(own) = self.own_job() else { return 0.0 };
        let top = stock_in_setup(&self.stock, &own.setup).max.z;
        self.rest_left([tool, wider], [top - self.rest_reach(&own.setup, tool), f64::INFINITY], finisher)
    }

    /// The material left (mm³) in the setup last roughed, between heights `[lo, hi]` of its
    /// frame, that a rest pass with `tool` after one with `wider` is for (classic rest
    /// machining): voxels of the simulated stock less the part, farther from the part than
    /// the finishing allowance and a voxel, seen along the setup's tool axis (the ray from
    /// the voxel's centre towards the spindle leaves the grid without meeting the part's
    /// voxels), that `tool` takes and `wider` does not, and that, where the setup is
    /// finished with `finisher`, its ball does not take either. A tool takes a voxel when,
    /// lowered over the part (drop-cutter) at some place whose cutter covers the voxel (its
    /// own and twelve around it), its tip stops at most a voxel above the voxel's centre,
    /// and the voxel lies within its reach below the stock's top. What the wider tool takes
    /// but left is the roughing's terraces between layers, which a pass at the same layers
    /// leaves as they are; what the finisher takes it takes (on the bunny at 100 mm, rest
    /// passes over that material cost an hour of machining for no IoU: 13,930 s against
    /// 10,167 s). Whether the rest tool gets
    /// there is the planner's to find: this bounds what the pass can remove.
    fn rest_left(&self, [tool, wider]: [&Tool; 2], [lo, hi]: [f64; 2], finisher: Option<&Tool>) -> f64 {
        let Some(own) = self.own_job() else { return 0.0 };
        let setup = own.setup;
        let spec = *self.remaining.spec();
        let h = spec.voxel.min();
        let o = &self.opts;
        let allowance = o.finish.map_or(0.0, |_| o.finish_allowance[0].max(o.finish_allowance[1]));
        let near = (allowance / h).ceil() as usize + 1;
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
        let Ok(index) = MeshIndex::new(&part_in_setup_frame(&self.part, &setup)) else { return 0.0 };
        let cutter = |t: &Tool| {
            DropCutter::new(&index, &t.cutter).ok().map(|dc| (dc, t.radius(), top - t.envelope().length))
        };
        let (Some(rest), Some(wide)) = (cutter(tool), cutter(wider)) else { return 0.0 };
        let ball = finisher.and_then(cutter);
        let takes = |(dc, r, floor): &(DropCutter<'_>, f64, f64), q: &Point3, around: bool| {
            let step = std::f64::consts::PI / 6.0;
            q.z >= *floor
                && (0..if around { 13 } else { 1 }).any(|n| {
                    let (a, d) = match n {
                        0 => (0.0, 0.0),
                        1..=6 => (2.0 * step * n as f64, 0.5 * r),
                        _ => (2.0 * step * n as f64 + step, 0.95 * r),
                    };
                    dc.height(q.x + d * a.cos(), q.y + d * a.sin()).is_none_or(|tip| q.z >= tip - h)
                })
        };
        let left: Vec<[usize; 3]> = self.remaining.iter_set().collect();
        let count = left
            .into_par_iter()
            .filter(|&[i, j, k]| {
                let p = spec.center(i, j, k);
                let q = setup.to_setup(&p);
                (lo..=hi).contains(&q.z)
                    && !target.any_in_range(
                        [i.saturating_sub(near), j.saturating_sub(near), k.saturating_sub(near)],
                        [i + near, j + near, k + near],
                    )
                    && seen(p)
                    // The ball's tip over the voxel: a lower bound of what it takes.
                    && !ball.as_ref().is_some_and(|b| takes(b, &q, false))
                    && takes(&rest, &q, true)
                    && !takes(&wide, &q, true)
            })
            .count();
        count as f64 * spec.voxel_volume()
    }

    /// The rest tool of setup `k` (0-based) after a pass with `wider`: down the library
    /// from `candidate` ([`smaller_tool`](Self::smaller_tool) after each), the first one
    /// that at least [`rest_volume`](Self::rest_volume) of the material left is for
    /// ([`reachable_left`](Self::reachable_left), with the setup's `finisher`), of at most
    /// [`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing) tools considered in
    /// the setup (`tried` counts them). A tool too wide for what is left is passed over
    /// for a smaller one: a 5 mm end mill cuts nothing of a 4.5 mm slot, a 3 mm one does.
    pub(super) fn worth_a_pass(
        &self,
        k: usize,
        wider: &Tool,
        mut candidate: Option<RestTool>,
        tried: &mut usize,
        finisher: Option<&Tool>,
    ) -> Result<Option<RestTool>, MillError> {
        while let Some(t) = candidate {
            if *tried >= self.opts.rest_roughing {
                break;
            }
            *tried += 1;
            if self.reachable_left(&t.0, wider, finisher) >= self.rest_volume() {
                return Ok(Some(t));
            }
            candidate = self.smaller_tool(k, t.0.radius())?;
        }
        Ok(None)
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
        first: RestTool,
        mut tried: usize,
        mut finish: Option<FinishJob>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<(), MillError> {
        let mut tool = first;
        let finisher = finish.as_ref().map(|f| f.tool);
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
                &tool,
                if smaller.is_some() { None } else { finish.take() },
                finisher,
                progress,
            )?;
            let next = self.worth_a_pass(k, &tool.0, smaller, &mut tried, finisher.as_ref())?;
            if let (None, Some((sim, remaining, jobs))) = (&next, snapshot) {
                (*self.sim.get_mut(), self.remaining) = (sim, remaining);
                self.jobs.truncate(jobs);
                program = self.rest_pass(k, &tool, finish.take(), finisher, progress)?;
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
        let action = Action { tool_radius: tool.0.radius(), ..action };
        self.check_deadline(|| format!("rest roughing setup {} of {}", k + 1, self.setup_count()))?;
        // A rest pass reaches only as deep as keeps its holder above all stock
        // ([`rest_reach`](Self::rest_reach)).
        let (mut cutter, cutting) = *tool;
        let (stickout, flutes) = (cutter.cutter.stickout, cutter.cutter.flute_length);
        // Deeper than its flutes only where material the pass is for lies there: the
        // roughing's terraces alone cost the bunny 19 minutes of 8 mm passes for no IoU.
        let reach = self.rest_reach(&setup, &cutter);
        let top = stock_in_setup(&self.stock, &setup).max.z;
        let wider = self.jobs[own].tool;
        let deep_left = || self.rest_left([&cutter, &wider], [top - reach, top - flutes], finisher.as_ref());
        cutter.cutter.stickout = match reach > flutes && deep_left() >= self.rest_volume() {
            true => reach,
            false => flutes,
        };
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
        job.finish = finish;
        self.jobs.push(job);
        let at = self.jobs.len() - 1;
        // Deeper than its flutes, the pass is checked in the simulator: where its shank or
        // holder met stock, the simulation is wound back and the pass cut again as deep as
        // its flutes are long.
        let deep = self.jobs[at].tool.cutter.stickout > flutes;
        let before = deep.then(|| self.sim.borrow().clone());
        let mut times = self.times;
        let result = machine_setup(&self.ctx(), at, &self.remaining, None, &mut times, progress);
        let result = match (result, before) {
            (Ok((program, _)), Some(before)) if !program.holder_collision_lines.is_empty() => {
                *self.sim.get_mut() = before;
                self.jobs[at].tool.cutter.stickout = flutes;
                machine_setup(&self.ctx(), at, &self.remaining, None, &mut times, progress)
            }
            (result, _) => result,
        };
        self.times = times;
        let (mut program, remaining) = result?;
        program.rest_of = Some(k + 1);
        // The program ran with the library's tool: only its plan was cut short.
        program.tool.cutter.stickout = stickout;
        self.remaining = remaining;
        Ok(program)
    }
}

/// A rest-roughing tool and its cutting data.
pub(super) type RestTool = (Tool, Option<Cutting>);
