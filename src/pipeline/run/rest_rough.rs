//! Rest roughing ([`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing)): each setup machined again with smaller
//! flat end mills over the simulated in-process stock, once every setup has its program.

use super::MillRun;
use crate::pipeline::api::{MillError, Preset, Stage};
use crate::pipeline::job::{Job, stock_in_setup};
use crate::pipeline::per_setup::machine_setup;
use crate::policy::Action;

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

    /// Rest roughing ([`MillOptions::rest_roughing`](crate::MillOptions::rest_roughing)), once every setup is machined: each
    /// setup again, in its own program with its fixture, its action and its datum, with
    /// a smaller flat end mill of the library (`Tooling::rest_tool`), over
    /// the material the earlier programs left (the simulated stock less the part; the
    /// planner skips what is gone), as deep below the stock's top as its flutes are long.
    /// Nothing in the paper
    /// preset or the rotary layout. Called by [`finish`](MillRun::finish), once every setup
    /// has its action.
    pub(super) fn rest_rough(&mut self, progress: &mut dyn FnMut(Stage)) -> Result<(), MillError> {
        if self.placements.is_some() || self.opts.preset != Preset::Shop || self.opts.rest_roughing == 0 {
            return Ok(());
        }
        let primary = self.setup_count();
        // Each setup's last job: its own, then its latest rest pass's.
        let mut last: Vec<usize> = (0..primary).collect();
        for _ in 0..self.opts.rest_roughing {
            for (k, last) in last.iter_mut().enumerate() {
                let before = &self.jobs[*last];
                let depth = stock_in_setup(&self.stock, &self.orientation.setups[k]).extent().z;
                let Some(tool) = self.tooling.rest_tool(before.tool.radius(), depth)? else { continue };
                if tool.0.radius() >= before.tool.radius() {
                    continue;
                }
                let (setup, note) = (before.setup, before.note.clone());
                let action = Action { tool_radius: tool.0.radius(), ..before.action };
                self.check_deadline(|| format!("rest roughing setup {} of {primary}", k + 1))?;
                // A rest pass reaches only as deep below the stock's top as its flutes are
                // long, so its shank and holder stay above all stock. (A setup's own roughing
                // cuts every level from the top down, and a shank no wider than the flutes
                // follows them through what they cut; a rest pass skips the levels where
                // nothing is left for it and may leave stock above its cut that the shank
                // would meet: OpenSCAD's example001 at 128^3 had 4 holder collisions so.)
                let (mut tool, cutting) = tool;
                let stickout = tool.cutter.stickout;
                tool.cutter.stickout = tool.cutter.flute_length;
                let mut job = Job::new(
                    &setup,
                    &action,
                    (tool, cutting),
                    &self.stock,
                    self.rapid,
                    self.clearance,
                    &self.opts,
                )?;
                job.note = Some(match note {
                    Some(n) => format!("{n}; rest roughing of setup {}", k + 1),
                    None => format!("rest roughing of setup {}", k + 1),
                });
                self.jobs.push(job);
                *last = self.jobs.len() - 1;
                let mut times = self.times;
                let result = machine_setup(&self.ctx(), *last, &self.remaining, None, &mut times, progress);
                self.times = times;
                let (mut program, remaining) = result?;
                program.rest_of = Some(k + 1);
                // The program ran with the library's tool: only its plan was cut short.
                program.tool.cutter.stickout = stickout;
                self.setups.push(program);
                self.remaining = remaining;
            }
        }
        Ok(())
    }
}
