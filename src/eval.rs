//! The paper's evaluation tables on our data (seed 000 Tables 1-4).
//!
//! Table 1: quality and machining time per policy. Table 2: surface coverage of the
//! orientation strategies. Table 3: fixed fine / fixed coarse / random / chosen
//! parameters. Table 4: the chosen policy with one clearing strategy (or the contour pass)
//! removed at a time. Table 5 (reward ablations) is the policy table of policies trained
//! with other reward weights (`s2g train --reward-weights`). Learned policies can also be
//! evaluated fine-tuned on each part (Appendix A.7), and policies trained with different
//! seeds as one row with a 95 % confidence interval (Appendix A.8).
//!
//! Each part is evaluated on its own ([`evaluate_part`]) and the tables are means over the
//! parts' results ([`tables_from_parts`]), so an evaluation splits over processes and
//! machines: a [`Shard`] takes every N-th part, [`write_part_result`] writes one result file
//! per part, and [`merge_results`] gives the tables of one process, byte for byte.

mod results;

use serde_json::{Value, json};

use crate::geom::Mesh;
#[cfg(feature = "learn")]
use crate::learn::{LearnedPolicy, TrainOptions};
use crate::pipeline::{MillError, MillOptions, MillRun, Milled};
use crate::policy::{Action, ActionSpace, FixedPolicy, HeuristicPolicy, Policy, RandomPolicy, StrategyKind};
use crate::voxsim::RewardWeights;

pub use results::{EvalPlan, RESULT_SUFFIX, Shard, merge_results, part_result_path, write_part_result};

/// The mean metrics of one row over the evaluated parts.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Row {
    /// What the row evaluates.
    pub name: String,
    /// Mean IoU.
    pub iou: f64,
    /// Mean F1.
    pub f1: f64,
    /// Mean Chamfer distance x1000.
    pub chamfer_x1000: f64,
    /// Mean normal consistency.
    pub normal_consistency: f64,
    /// Mean machining time, seconds.
    pub machining_time_s: f64,
    /// Parts whose programs gouged or rapided through material.
    pub unsafe_parts: usize,
    /// Mean total reward (Eq. 13, the paper's weights; see [`Milled::total_reward`]).
    pub reward: f64,
    /// For a [seed group](SeedGroup): half-widths of the 95 % confidence intervals of the
    /// mean over its members (Student's t, one value per member: its mean over the parts).
    pub ci95: Option<Ci95>,
}

/// Half-widths of 95 % confidence intervals of a row's means.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Ci95 {
    /// Of the IoU.
    pub iou: f64,
    /// Of the normal consistency.
    pub normal_consistency: f64,
    /// Of the machining time, seconds.
    pub machining_time_s: f64,
    /// Of the total reward.
    pub reward: f64,
}

/// Policies that differ only in their training seed, reported as one row: the mean of
/// their rows, with confidence intervals (seed 000 Appendix A.8).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SeedGroup {
    /// The row's name.
    pub name: String,
    /// The policies (names as [`policy_by_name`] takes them, usually policy files).
    pub members: Vec<String>,
}

/// What [`evaluate`] computes besides the policy rows.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalOptions {
    /// Which tables.
    pub tables: TableSet,
    /// When positive, every learned policy (`learned` or a policy file) also gets a row
    /// `NAME +ftN`: the policy fine-tuned on each part for this many episodes before
    /// milling it (seed 000 Appendix A.7: five), the episodes milled as the evaluation
    /// mills. Default 0.
    pub finetune_episodes: usize,
    /// Rows of policies trained with different seeds (Appendix A.8).
    pub seed_groups: Vec<SeedGroup>,
    /// The policy Table 4 takes the clearing strategies (and the contour pass) away from,
    /// one at a time, by name as [`policy_by_name`] takes it. The paper ablates its learned
    /// policy, which then chooses the best of the actions that are left; the default is
    /// `learned` (the shipped policy), or `heuristic` in a build without the `learn`
    /// feature, which has none.
    pub ablated: String,
}

impl Default for EvalOptions {
    /// Every table, no fine-tuning, no seed groups, Table 4 of the shipped policy.
    fn default() -> Self {
        Self {
            tables: TableSet::default(),
            finetune_episodes: 0,
            seed_groups: Vec::new(),
            ablated: default_ablated().to_owned(),
        }
    }
}

/// The policy Table 4 ablates unless told otherwise ([`EvalOptions::ablated`]).
pub fn default_ablated() -> &'static str {
    if cfg!(feature = "learn") { "learned" } else { "heuristic" }
}

/// Mean surface coverage of the orientation strategies (Table 2).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CoverageRow {
    /// Six principal axes.
    pub six_axes: f64,
    /// Five random directions (mean over seeds).
    pub random5: f64,
    /// Six random directions (mean over seeds).
    pub random6: f64,
    /// The paper's plain greedy.
    pub plain_greedy: f64,
    /// Ours (multi-start swap search and refinement).
    pub ours: f64,
    /// Points visible from any candidate.
    pub upper_bound: f64,
}

/// All four tables.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Tables {
    /// Names of the evaluated parts.
    pub parts: Vec<String>,
    /// Table 1 (and 3): one row per policy.
    pub policies: Vec<Row>,
    /// Table 2, when computed.
    pub orientation: Option<CoverageRow>,
    /// Table 4: the chosen policy without one clearing strategy each.
    pub ablation: Vec<Row>,
    /// The policy of Table 4 ([`EvalOptions::ablated`]), when it was computed.
    pub ablated: Option<String>,
}

/// Which tables [`evaluate`] computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableSet {
    /// Tables 1 and 3: one row per policy.
    pub policies: bool,
    /// Table 2: orientation strategies (from heuristic runs, made if no policy is `heuristic`).
    pub orientation: bool,
    /// Table 4: [`EvalOptions::ablated`] without one clearing strategy (or the contour)
    /// each.
    pub strategies: bool,
}

impl Default for TableSet {
    /// All of them.
    fn default() -> Self {
        Self { policies: true, orientation: true, strategies: true }
    }
}

/// The policies of Tables 1 and 3, by name: `learned` (the policy shipped in the crate,
/// `LearnedPolicy::bundled`; with the `learn` feature), `heuristic`, `random`, `fixed-fine` or `fine` (smallest tool and layer), `fixed-coarse`
/// or `coarse` (largest tool and layer), `fixed:RADIUS,LAYER,STRATEGY` (planning units), or
/// the path of a policy file written by `s2g train`. `None` for anything else.
pub fn policy_by_name(name: &str, space: &ActionSpace, seed: u64) -> Option<Box<dyn Policy>> {
    let fixed = |r: usize, h: usize| -> Box<dyn Policy> {
        Box::new(FixedPolicy(Action {
            tool_radius: space.radii[r],
            layer_height: space.layer_heights[h],
            strategy: StrategyKind::ZIGZAG,
        }))
    };
    if space.is_empty() {
        return None;
    }
    match name {
        "learned" => learned_by_name(name),
        "heuristic" => Some(Box::new(HeuristicPolicy::default())),
        "random" => Some(Box::new(RandomPolicy::new(seed))),
        "fine" | "fixed-fine" => Some(fixed(0, 0)),
        "coarse" | "fixed-coarse" => Some(fixed(space.radii.len() - 1, space.layer_heights.len() - 1)),
        s if s.starts_with("fixed:") => {
            let parts: Vec<&str> = s["fixed:".len()..].split(',').collect();
            let [r, h, st] = parts[..] else { return None };
            Some(Box::new(FixedPolicy(Action {
                tool_radius: r.trim().parse().ok().filter(|v: &f64| v.is_finite() && *v > 0.0)?,
                layer_height: h.trim().parse().ok().filter(|v: &f64| v.is_finite() && *v > 0.0)?,
                strategy: StrategyKind::from_name(st.trim())?,
            })))
        }
        path => learned_by_name(path),
    }
}

/// The shipped learned policy (`learned`) or the policy file at `name`; `None` when it
/// cannot be read, or always without the `learn` feature.
fn learned_by_name(name: &str) -> Option<Box<dyn Policy>> {
    #[cfg(feature = "learn")]
    {
        LearnedPolicy::named(name).ok().map(|p| Box::new(p) as Box<dyn Policy>)
    }
    #[cfg(not(feature = "learn"))]
    {
        let _ = name;
        None
    }
}

/// The learned policy `name` fine-tuned on `mesh` for `episodes` episodes (Appendix A.7);
/// an error without the `learn` feature.
fn finetuned(
    name: &str,
    part: &str,
    mesh: &Mesh,
    episodes: usize,
    opts: &MillOptions,
) -> Result<Box<dyn Policy>, MillError> {
    #[cfg(feature = "learn")]
    {
        let mut learned = LearnedPolicy::named(name)?;
        let train = TrainOptions { seed: opts.seed, mill: opts.clone(), ..TrainOptions::default() };
        learned.finetune(mesh, part, episodes, &train, &mut |_| {})?;
        Ok(Box::new(learned))
    }
    #[cfg(not(feature = "learn"))]
    {
        let _ = (part, mesh, episodes, opts);
        Err(MillError::InvalidOption(format!("fine-tuning {name} needs shape2gcode's `learn` feature")))
    }
}

fn mean_row(name: &str, runs: &[PartScores]) -> Row {
    let n = runs.len().max(1) as f64;
    let avg = |f: &dyn Fn(&PartScores) -> f64| runs.iter().map(f).sum::<f64>() / n;
    Row {
        name: name.to_owned(),
        iou: avg(&|m| m.iou),
        f1: avg(&|m| m.f1),
        chamfer_x1000: avg(&|m| m.chamfer_x1000),
        normal_consistency: avg(&|m| m.normal_consistency),
        machining_time_s: avg(&|m| m.machining_time_s),
        unsafe_parts: runs.iter().filter(|m| !m.safe).count(),
        reward: avg(&|m| m.reward),
        ci95: None,
    }
}

/// The two-sided 95 % quantile of Student's t with `dof` degrees of freedom.
fn t95(dof: usize) -> f64 {
    const T: [f64; 10] = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228];
    match dof {
        0 => f64::NAN,
        d if d <= T.len() => T[d - 1],
        d if d <= 30 => 2.228 - (2.228 - 2.042) * (d - 10) as f64 / 20.0,
        _ => 1.960,
    }
}

/// The mean of `rows` (one per seed) named `name`, with 95 % confidence intervals of the
/// mean (none for a single row).
fn group_row(name: &str, rows: &[Row]) -> Row {
    let n = rows.len().max(1) as f64;
    let mean = |f: &dyn Fn(&Row) -> f64| rows.iter().map(f).sum::<f64>() / n;
    let half = |f: &dyn Fn(&Row) -> f64| {
        let m = mean(f);
        let var = rows.iter().map(|r| (f(r) - m).powi(2)).sum::<f64>() / (n - 1.0);
        t95(rows.len() - 1) * (var / n).sqrt()
    };
    Row {
        name: name.to_owned(),
        iou: mean(&|r| r.iou),
        f1: mean(&|r| r.f1),
        chamfer_x1000: mean(&|r| r.chamfer_x1000),
        normal_consistency: mean(&|r| r.normal_consistency),
        machining_time_s: mean(&|r| r.machining_time_s),
        unsafe_parts: rows.iter().map(|r| r.unsafe_parts).max().unwrap_or(0),
        reward: mean(&|r| r.reward),
        ci95: (rows.len() > 1).then(|| Ci95 {
            iou: half(&|r| r.iou),
            normal_consistency: half(&|r| r.normal_consistency),
            machining_time_s: half(&|r| r.machining_time_s),
            reward: half(&|r| r.reward),
        }),
    }
}

/// Whether `name` is a learned policy: `learned` or a policy file.
fn is_learned(name: &str) -> bool {
    name == "learned" || std::path::Path::new(name).is_file()
}

/// What one run of one part scored: the [`Row`] columns before the mean over parts.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PartScores {
    /// IoU.
    pub iou: f64,
    /// F1.
    pub f1: f64,
    /// Chamfer distance x1000.
    pub chamfer_x1000: f64,
    /// Normal consistency.
    pub normal_consistency: f64,
    /// Machining time, seconds.
    pub machining_time_s: f64,
    /// No gouge and no rapid through material.
    pub safe: bool,
    /// Total reward (Eq. 13, the paper's weights).
    pub reward: f64,
}

impl PartScores {
    fn of(m: &Milled) -> Self {
        Self {
            iou: m.metrics.iou,
            f1: m.metrics.f1,
            chamfer_x1000: m.metrics.chamfer_x1000,
            normal_consistency: m.metrics.normal_consistency,
            machining_time_s: m.simulation.machining_time_s,
            safe: m.is_safe(),
            reward: m.total_reward(&RewardWeights::default()),
        }
    }
}

/// Which run of a part a [`PartScores`] is: a policy (fine-tuned for `finetune` episodes
/// when positive), or, for Table 4, the policy `without` one clearing strategy (by its
/// name) or the `contour` pass.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RunKey {
    /// The policy, as [`policy_by_name`] takes it.
    pub policy: String,
    /// Fine-tuning episodes; 0 for none.
    pub finetune: usize,
    /// Table 4: the strategy (or `contour`) removed; `None` for a policy row.
    pub without: Option<String>,
}

impl RunKey {
    fn policy(name: &str, finetune: usize) -> Self {
        Self { policy: name.to_owned(), finetune, without: None }
    }

    fn ablation(policy: &str, removed: &str) -> Self {
        Self { policy: policy.to_owned(), finetune: 0, without: Some(removed.to_owned()) }
    }

    /// How progress reports and table rows name the run.
    pub fn label(&self) -> String {
        match (&self.without, self.finetune) {
            (Some(removed), _) => format!("{} without {removed}", self.policy),
            (None, 0) => self.policy.clone(),
            (None, f) => format!("{} +ft{f}", self.policy),
        }
    }
}

/// Everything the tables need of one part ([`evaluate_part`]): the scores of each run, and
/// the orientation strategies' coverage from the heuristic run when there was one. The
/// tables are means of these over the parts ([`tables_from_parts`]), so parts can be
/// evaluated apart (in other processes, on other machines) and merged.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PartResult {
    /// The part's name.
    pub part: String,
    /// The runs, in the order they were milled.
    pub runs: Vec<(RunKey, PartScores)>,
    /// Table 2's coverages of this part (its heuristic run's), when it was milled with
    /// the heuristic.
    pub orientation: Option<CoverageRow>,
}

impl PartResult {
    fn scores(&self, key: &RunKey) -> Option<&PartScores> {
        self.runs.iter().find(|(k, _)| k == key).map(|(_, s)| s)
    }
}

/// The runs [`evaluate`] makes of every part for `policies` and `eval`, each once, in the
/// order they are made.
fn run_keys(policies: &[String], eval: &EvalOptions) -> Vec<RunKey> {
    let which = eval.tables;
    let mut keys: Vec<RunKey> = Vec::new();
    let mut add = |k: RunKey| {
        if !keys.contains(&k) {
            keys.push(k);
        }
    };
    let members = eval.seed_groups.iter().flat_map(|g| g.members.iter());
    for name in policies.iter().chain(members).filter(|_| which.policies) {
        add(RunKey::policy(name, 0));
        if eval.finetune_episodes > 0 && is_learned(name) {
            add(RunKey::policy(name, eval.finetune_episodes));
        }
    }
    if which.orientation || which.strategies {
        add(RunKey::policy("heuristic", 0));
    }
    if which.strategies {
        add(RunKey::policy(&eval.ablated, 0));
        for removed in StrategyKind::all() {
            add(RunKey::ablation(&eval.ablated, removed.name()));
        }
        add(RunKey::ablation(&eval.ablated, "contour"));
    }
    keys
}

/// Evaluates `policies` (see [`policy_by_name`]) on `parts`, for what `eval` asks;
/// `on_run(part, row)` is told before each run. Table 4 is computed with
/// [`EvalOptions::ablated`]. The same as [`evaluate_part`] on each part and [`tables_from_parts`] on the
/// results.
pub fn evaluate(
    parts: &[(String, Mesh)],
    policies: &[String],
    eval: &EvalOptions,
    opts: &MillOptions,
    on_run: &mut dyn FnMut(&str, &str),
) -> Result<Tables, MillError> {
    let results = parts
        .iter()
        .map(|(part, mesh)| evaluate_part(part, mesh, policies, eval, opts, on_run))
        .collect::<Result<Vec<_>, _>>()?;
    tables_from_parts(&results, policies, eval)
}

/// Mills one part for every run the tables of [`evaluate`] need; `on_run(part, row)` is
/// told before each run. A part's result depends on the part, the policies, `eval` and
/// `opts` alone, never on the other parts evaluated.
pub fn evaluate_part(
    part: &str,
    mesh: &Mesh,
    policies: &[String],
    eval: &EvalOptions,
    opts: &MillOptions,
    on_run: &mut dyn FnMut(&str, &str),
) -> Result<PartResult, MillError> {
    let space = opts.action_space();
    let mut result = PartResult { part: part.to_owned(), ..PartResult::default() };
    for key in run_keys(policies, eval) {
        on_run(part, &key.label());
        let by_name = |space: &ActionSpace| {
            policy_by_name(&key.policy, space, opts.seed)
                .ok_or_else(|| MillError::InvalidOption(format!("unknown policy {:?}", key.policy)))
        };
        let milled = match (&key.without, key.finetune) {
            (Some(removed), _) => {
                let o = match StrategyKind::from_name(removed) {
                    Some(removed) => MillOptions {
                        strategies: StrategyKind::all().into_iter().filter(|&s| s != removed).collect(),
                        ..opts.clone()
                    },
                    None => MillOptions { contour: false, ..opts.clone() },
                };
                scored(mesh, by_name(&o.action_space())?.as_mut(), &o)?
            }
            (None, 0) => scored(mesh, by_name(&space)?.as_mut(), opts)?,
            (None, f) => scored(mesh, finetuned(&key.policy, part, mesh, f, opts)?.as_mut(), opts)?,
        };
        if key == RunKey::policy("heuristic", 0) {
            let m = &milled;
            result.orientation = Some(CoverageRow {
                six_axes: m.orientation.baselines.six_axes,
                random5: m.orientation.baselines.random5,
                random6: m.orientation.baselines.random6,
                plain_greedy: m.orientation.baselines.plain_greedy,
                ours: m.orientation.final_coverage(),
                upper_bound: m.orientation.upper_bound,
            });
        }
        result.runs.push((key, PartScores::of(&milled)));
    }
    Ok(result)
}

/// The tables of [`evaluate`] from the parts' results ([`evaluate_part`] with the same
/// `policies` and `eval`), in the order given: byte for byte what one [`evaluate`] of the
/// same parts prints. An error names a part that lacks a run the tables need.
pub fn tables_from_parts(
    results: &[PartResult],
    policies: &[String],
    eval: &EvalOptions,
) -> Result<Tables, MillError> {
    let which = eval.tables;
    let runs = |key: &RunKey| -> Result<Vec<PartScores>, MillError> {
        results
            .iter()
            .map(|r| {
                r.scores(key).copied().ok_or_else(|| {
                    MillError::InvalidOption(format!("part {} has no run of {}", r.part, key.label()))
                })
            })
            .collect()
    };
    let row = |key: &RunKey| Ok::<_, MillError>(mean_row(&key.label(), &runs(key)?));
    let mut tables = Tables { parts: results.iter().map(|r| r.part.clone()).collect(), ..Tables::default() };
    let tuned = |name: &str| eval.finetune_episodes > 0 && is_learned(name);
    for name in policies.iter().filter(|_| which.policies) {
        tables.policies.push(row(&RunKey::policy(name, 0))?);
        if tuned(name) {
            tables.policies.push(row(&RunKey::policy(name, eval.finetune_episodes))?);
        }
    }
    for group in eval.seed_groups.iter().filter(|_| which.policies) {
        let mut rows = Vec::with_capacity(group.members.len());
        let mut tuned_rows = Vec::new();
        for member in &group.members {
            rows.push(row(&RunKey::policy(member, 0))?);
            if tuned(member) {
                tuned_rows.push(row(&RunKey::policy(member, eval.finetune_episodes))?);
            }
        }
        tables.policies.push(group_row(&group.name, &rows));
        if !tuned_rows.is_empty() {
            tables
                .policies
                .push(group_row(&format!("{} +ft{}", group.name, eval.finetune_episodes), &tuned_rows));
        }
    }
    // Table 2 comes with Table 4 too, as it always has.
    if which.orientation || which.strategies {
        let coverage = results
            .iter()
            .map(|r| {
                r.orientation.ok_or_else(|| {
                    MillError::InvalidOption(format!("part {} has no orientation coverage", r.part))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let n = coverage.len().max(1) as f64;
        let cov = |f: &dyn Fn(&CoverageRow) -> f64| coverage.iter().map(f).sum::<f64>() / n;
        tables.orientation = Some(CoverageRow {
            six_axes: cov(&|c| c.six_axes),
            random5: cov(&|c| c.random5),
            random6: cov(&|c| c.random6),
            plain_greedy: cov(&|c| c.plain_greedy),
            ours: cov(&|c| c.ours),
            upper_bound: cov(&|c| c.upper_bound),
        });
    }
    if which.strategies {
        tables.ablation.push(mean_row("none removed", &runs(&RunKey::policy(&eval.ablated, 0))?));
        let removed = StrategyKind::all().into_iter().map(|s| s.name().to_owned());
        for removed in removed.chain(["contour".to_owned()]) {
            let key = RunKey::ablation(&eval.ablated, &removed);
            tables.ablation.push(mean_row(&format!("without {removed}"), &runs(&key)?));
        }
        tables.ablated = Some(eval.ablated.clone());
    }
    Ok(tables)
}

/// What [`mill`](crate::mill) gives, without keeping the programs: the tables need only
/// the scores, and the finest actions write gigabytes.
fn scored(mesh: &Mesh, policy: &mut dyn Policy, opts: &MillOptions) -> Result<Milled, MillError> {
    let mut run = MillRun::new(mesh, opts, &mut |_| {})?;
    run.keep_programs(false);
    run.complete(policy, &mut |_| {})
}

fn row_json(r: &Row) -> Value {
    let mut v = json!({
        "name": r.name, "iou": r.iou, "f1": r.f1, "chamfer_x1000": r.chamfer_x1000,
        "normal_consistency": r.normal_consistency, "machining_time_s": r.machining_time_s,
        "unsafe_parts": r.unsafe_parts, "reward": r.reward,
    });
    if let Some(c) = &r.ci95 {
        v["ci95"] = json!({
            "iou": c.iou, "normal_consistency": c.normal_consistency,
            "machining_time_s": c.machining_time_s, "reward": c.reward,
        });
    }
    v
}

impl Tables {
    /// The tables as JSON; a table not computed is left out.
    pub fn to_json(&self) -> Value {
        let mut v = json!({
            "parts": self.parts,
            "policies": self.policies.iter().map(|r| (r.name.clone(), row_json(r))).collect::<serde_json::Map<_, _>>(),
            "table1_policies": self.policies.iter().map(row_json).collect::<Vec<_>>(),
        });
        if let Some(o) = &self.orientation {
            v["table2_orientation"] = json!({
                "six_axes": o.six_axes, "random5": o.random5, "random6": o.random6,
                "plain_greedy": o.plain_greedy, "ours": o.ours, "upper_bound": o.upper_bound,
            });
        }
        if !self.ablation.is_empty() {
            v["table4_strategy_ablation"] = self.ablation.iter().map(row_json).collect::<Vec<_>>().into();
            v["table4_policy"] = self.ablated.clone().into();
        }
        v
    }

    /// The tables as Markdown, laid out like the paper's.
    pub fn to_markdown(&self) -> String {
        let rows = |rows: &[Row]| -> String {
            rows.iter()
                .map(|r| {
                    let pm = |v: f64, h: Option<f64>, d: usize| match h {
                        Some(h) => format!("{v:.d$} ± {h:.d$}"),
                        None => format!("{v:.d$}"),
                    };
                    let c = r.ci95.as_ref();
                    format!(
                        "| {} | {} | {:.3} | {:.3} | {} | {} | {} | {} |\n",
                        r.name,
                        pm(r.iou, c.map(|c| c.iou), 3),
                        r.f1,
                        r.chamfer_x1000,
                        pm(r.normal_consistency, c.map(|c| c.normal_consistency), 3),
                        pm(r.machining_time_s, c.map(|c| c.machining_time_s), 1),
                        pm(r.reward, c.map(|c| c.reward), 4),
                        r.unsafe_parts
                    )
                })
                .collect()
        };
        let head =
            "| | IoU | F1 | CD x1000 | NC | T (s) | reward | unsafe |\n|---|---|---|---|---|---|---|---|\n";
        let mut out = format!("Parts: {}\n", self.parts.join(", "));
        if !self.policies.is_empty() {
            out += &format!("\n### Tables 1 and 3: policies\n\n{head}{}", rows(&self.policies));
        }
        if let Some(o) = &self.orientation {
            out += &format!(
                "\n### Table 2: orientation selection (surface coverage)\n\n\
                 | 6-axes | Rand(5) | Rand(6) | plain greedy | ours | upper bound |\n|---|---|---|---|---|---|\n\
                 | {:.2}% | {:.2}% | {:.2}% | {:.2}% | {:.2}% | {:.2}% |\n",
                100.0 * o.six_axes,
                100.0 * o.random5,
                100.0 * o.random6,
                100.0 * o.plain_greedy,
                100.0 * o.ours,
                100.0 * o.upper_bound,
            );
        }
        if !self.ablation.is_empty() {
            out += &format!(
                "\n### Table 4: clearing strategies removed one at a time from {}\n\n{head}{}",
                self.ablated.as_deref().unwrap_or("?"),
                rows(&self.ablation)
            );
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(iou: f64, reward: f64) -> Row {
        Row { name: "x".into(), iou, reward, machining_time_s: 10.0 * reward, ..Row::default() }
    }

    /// Three seeds: the mean and Student's t interval with two degrees of freedom
    /// (t = 4.303), checked by hand; one seed has no interval.
    #[test]
    fn seed_groups_are_means_with_student_t_intervals() {
        let g = group_row("learned", &[row(0.80, 3.0), row(0.84, 3.3), row(0.82, 3.6)]);
        assert!((g.iou - 0.82).abs() < 1e-12 && (g.reward - 3.3).abs() < 1e-12, "{g:?}");
        let c = g.ci95.expect("three seeds have an interval");
        // sd(iou) = 0.02, sd(reward) = 0.3, n = 3.
        assert!((c.iou - 4.303 * 0.02 / 3f64.sqrt()).abs() < 1e-9, "{c:?}");
        assert!((c.reward - 4.303 * 0.3 / 3f64.sqrt()).abs() < 1e-9, "{c:?}");
        assert!((c.machining_time_s - 10.0 * c.reward).abs() < 1e-9, "{c:?}");
        assert!(group_row("one", &[row(0.8, 3.0)]).ci95.is_none());
        assert_eq!(t95(1), 12.706);
        assert_eq!(t95(1000), 1.960);
        assert!(t95(20) < t95(10) && t95(20) > t95(1000));
    }
}
