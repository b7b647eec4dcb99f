//! Undercut passes with the library's T-slot cutters (issue #35): after every setup is
//! machined, each setup whose part has an undercut a T-slot cutter reaches from outside the
//! stock, with material left there, is machined again in its own program
//! ([`s2g_toolpath::undercut`]).

use super::MillRun;
use crate::pipeline::api::{MillError, Preset, Stage};
use crate::pipeline::job::{Job, UndercutJob, stock_in_setup};
use crate::pipeline::per_setup::machine_setup;
use crate::policy::Action;
use crate::toolpath::VoxelMaterial;
use crate::toolpath::undercut::{Undercut, UndercutOptions, part_columns, undercut_cuts, undercut_levels};

/// The least material one level of an undercut pass is for, as a fraction of the part's
/// volume: a pass worth a percent of the IoU at least (the T-slot block's wings are 4 %).
const UNDERCUT_WORTH: f64 = 0.01;

impl MillRun {
    /// The options of an undercut pass in this run.
    pub(crate) fn undercut_options(&self) -> UndercutOptions {
        let part = self.target.count() as f64 * self.target.spec().voxel_volume();
        UndercutOptions {
            min_volume: UNDERCUT_WORTH * part,
            clearance: self.clearance,
            rapid_feed: self.rapid,
            ..UndercutOptions::default()
        }
    }

    /// Whether the run may add undercut passes (the shop preset's per-setup layout with a
    /// T-slot cutter in the library): [`program_bound`](Self::program_bound) counts one per
    /// setup then.
    pub(super) fn may_undercut(&self) -> bool {
        self.placements.is_none() && self.opts.preset == Preset::Shop && self.tooling.has_t_slot()
    }

    /// The undercut passes: for each setup in turn (its own job's frame, action and datum),
    /// the widest T-slot cutter of the library that finds a level of undercut with at least
    /// [`UNDERCUT_WORTH`] of the part's volume of material left within its reach
    /// ([`undercut_levels`]) cuts it, in a program of its own after every setup's, planned,
    /// written and simulated as a rest pass of the setup.
    pub(super) fn undercut_passes(&mut self, progress: &mut dyn FnMut(Stage)) -> Result<(), MillError> {
        if !self.may_undercut() {
            return Ok(());
        }
        let tools = self.tooling.t_slot_tools()?;
        let owns: Vec<usize> = (0..self.jobs.len()).filter(|&j| self.jobs[j].rest_of.is_none()).collect();
        let uopts = self.undercut_options();
        for (k, &own) in owns.iter().enumerate() {
            let (setup, note, action) = {
                let j = &self.jobs[own];
                (j.setup, j.note.clone(), j.action)
            };
            let stock = stock_in_setup(&self.stock, &setup);
            for tool in &tools {
                self.check_deadline(|| {
                    format!("undercut pass of setup {} of {}", k + 1, self.setup_count())
                })?;
                let columns = part_columns(&self.part, &setup, &stock, &tool.0, uopts.cell);
                let rest = VoxelMaterial::new(&self.remaining, setup);
                let (levels, _) = undercut_levels(&columns, &tool.0, &stock, &rest, &uopts);
                let pass = Undercut {
                    columns: &columns,
                    setup: &setup,
                    tool: &tool.0,
                    stock: &stock,
                    rest: &rest,
                    levels: &levels,
                };
                if levels.is_empty() || !undercut_cuts(&pass, &uopts) {
                    continue;
                }
                let action = Action { tool_radius: tool.0.radius(), ..action };
                let mut job =
                    Job::new(&setup, &action, *tool, &self.stock, self.rapid, self.clearance, &self.opts)?;
                job.note = Some(match &note {
                    Some(n) => format!("{n}; undercut pass of setup {}", k + 1),
                    None => format!("undercut pass of setup {}", k + 1),
                });
                job.rest_of = Some(k);
                job.undercut =
                    Some(UndercutJob { columns: std::sync::Arc::new(columns), levels, opts: uopts });
                self.jobs.push(job);
                let at = self.jobs.len() - 1;
                let mut times = self.times;
                let result =
                    machine_setup(&self.ctx(), at, &self.remaining, None, &mut times, progress, None);
                self.times = times;
                let (mut program, remaining) = result?;
                program.rest_of = Some(k + 1);
                self.setups.push(program);
                self.remaining = remaining;
                break;
            }
        }
        Ok(())
    }
}
