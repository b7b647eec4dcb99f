//! Rest roughing ([`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing)): a
//! setup machined again, right after its roughing and before its finishing, with smaller
//! flat end mills over the simulated in-process stock.

use super::MillRun;
use crate::geom::{Point3, Setup};
use crate::pipeline::api::{MillError, Preset, SetupProgram, Stage};
use crate::pipeline::job::{FinishJob, Job, stock_in_setup};
use crate::pipeline::per_setup::machine_setup;
use crate::policy::Action;
use crate::toolpath::Tool;
use crate::toolpath::library::Cutting;
use rayon::prelude::*;

impl MillRun {
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

    /// The material left (mm³) that a rest pass of setup `k` (0-based) with `tool` may
    /// reach: voxels of the simulated stock less the part that lie farther from the part
    /// than the finishing allowance and a voxel (the allowance is the finisher's), within
    /// the tool's reach below the stock's top ([`rest_reach`](Self::rest_reach)), and seen
    /// along the setup's tool axis (the ray from the voxel's centre towards the spindle
    /// leaves the grid without meeting the part's voxels). Whether the tool fits where that
    /// material lies is the planner's to find: this bounds what the pass can remove.
    fn reachable_left(&self, k: usize, tool: &RestTool) -> f64 {
        let Some(job) = self.jobs.iter().rev().find(|j| j.rest_of == Some(k)) else { return 0.0 };
        let setup = job.setup;
        let top = stock_in_setup(&self.stock, &setup).max.z;
        let floor = top - self.rest_reach(&setup, &tool.0);
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
        let left: Vec<[usize; 3]> = self.remaining.iter_set().collect();
        let count = left
            .into_par_iter()
            .filter(|&[i, j, k]| {
                let p = spec.center(i, j, k);
                setup.to_setup(&p).z >= floor
                    && !target.any_in_range(
                        [i.saturating_sub(near), j.saturating_sub(near), k.saturating_sub(near)],
                        [i + near, j + near, k + near],
                    )
                    && seen(p)
            })
            .count();
        count as f64 * spec.voxel_volume()
    }

    /// Rest roughing of setup `k` (0-based), just roughed by its own job, from `first`
    /// ([`first_rest_tool`](Self::first_rest_tool)) down the library: each pass machines
    /// the setup again, in its own program with the setup's fixture, action and datum, over
    /// the material the earlier programs left (the simulated stock less the part; the
    /// planner skips what is gone). A further, smaller tool follows while the passes stay
    /// within [`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing) and at least
    /// [`MillOptions::rest_continue_mm3`](crate::MillOptions::rest_continue_mm3) of the
    /// material left lies within its reach ([`reachable_left`](Self::reachable_left)).
    /// The setup's `finish` follows the last pass in its program: a pass after which a smaller
    /// tool may follow is cut without it, and where none follows, the simulation is wound
    /// back and the pass cut again with it. Called by
    /// [`machine_finished`](MillRun::machine_finished).
    pub(super) fn rest_rough(
        &mut self,
        k: usize,
        first: RestTool,
        mut finish: Option<FinishJob>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<(), MillError> {
        let (mut tool, mut n) = (first, 1);
        loop {
            let next = match n < self.opts.rest_roughing {
                true => self.smaller_tool(k, tool.0.radius())?,
                false => None,
            };
            let tentative = next.is_some() && finish.is_some();
            let snapshot = tentative
                .then(|| (self.sim.borrow().clone(), self.remaining.clone(), self.times, self.jobs.len()));
            let mut program =
                self.rest_pass(k, &tool, if next.is_some() { None } else { finish.take() }, progress)?;
            let go_on = match &next {
                Some(t) => self.reachable_left(k, t) >= self.opts.rest_continue_mm3,
                None => false,
            };
            if let (false, Some((sim, remaining, times, jobs))) = (go_on, snapshot) {
                *self.sim.get_mut() = sim;
                (self.remaining, self.times) = (remaining, times);
                self.jobs.truncate(jobs);
                program = self.rest_pass(k, &tool, finish.take(), progress)?;
            }
            self.setups.push(program);
            match next.filter(|_| go_on) {
                Some(t) => (tool, n) = (t, n + 1),
                None => return Ok(()),
            }
        }
    }

    /// One rest pass of setup `k` with `tool`, then `finish` in its program: planned,
    /// written and simulated; the material left is updated.
    fn rest_pass(
        &mut self,
        k: usize,
        tool: &RestTool,
        finish: Option<FinishJob>,
        progress: &mut dyn FnMut(Stage),
    ) -> Result<SetupProgram, MillError> {
        let own = self.jobs.iter().rposition(|j| j.rest_of.is_none()).unwrap_or(0);
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
        cutter.cutter.stickout = self.rest_reach(&setup, &cutter);
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
