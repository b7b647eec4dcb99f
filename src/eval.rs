//! The paper's evaluation tables on our data (seed 000 Tables 1-4).
//!
//! Table 1: quality and machining time per policy. Table 2: surface coverage of the
//! orientation strategies. Table 3: fixed fine / fixed coarse / random / chosen
//! parameters. Table 4: the chosen policy with one clearing strategy (or the contour pass)
//! removed at a time.

use serde_json::{Value, json};

use crate::geom::Mesh;
use crate::learn::LearnedPolicy;
use crate::pipeline::{MillError, MillOptions, Milled, mill};
use crate::policy::{Action, ActionSpace, FixedPolicy, HeuristicPolicy, Policy, RandomPolicy, StrategyKind};
use crate::voxsim::RewardWeights;

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
}

/// Mean surface coverage of the orientation strategies (Table 2).
#[derive(Debug, Clone, PartialEq, Default)]
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
    /// Table 2.
    pub orientation: CoverageRow,
    /// Table 4: the chosen policy without one clearing strategy each.
    pub ablation: Vec<Row>,
}

/// The policies of Tables 1 and 3, by name: `heuristic`, `random`, `fixed-fine` or `fine` (smallest tool and layer), `fixed-coarse`
/// or `coarse` (largest tool and layer), `fixed:RADIUS,LAYER,STRATEGY` (planning units), or
/// the path of a policy file written by `s2g train`. `None` for anything else.
pub fn policy_by_name(name: &str, space: &ActionSpace, seed: u64) -> Option<Box<dyn Policy>> {
    let fixed = |r: usize, h: usize| -> Box<dyn Policy> {
        Box::new(FixedPolicy(Action {
            tool_radius: space.radii[r],
            layer_height: space.layer_heights[h],
            strategy: StrategyKind::Zigzag,
        }))
    };
    if space.is_empty() {
        return None;
    }
    match name {
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
        path => LearnedPolicy::load(std::path::Path::new(path)).ok().map(|p| Box::new(p) as Box<dyn Policy>),
    }
}

fn mean_row(name: &str, runs: &[Milled]) -> Row {
    let n = runs.len().max(1) as f64;
    let avg = |f: &dyn Fn(&Milled) -> f64| runs.iter().map(f).sum::<f64>() / n;
    Row {
        name: name.to_owned(),
        iou: avg(&|m| m.metrics.iou),
        f1: avg(&|m| m.metrics.f1),
        chamfer_x1000: avg(&|m| m.metrics.chamfer_x1000),
        normal_consistency: avg(&|m| m.metrics.normal_consistency),
        machining_time_s: avg(&|m| m.simulation.machining_time_s),
        unsafe_parts: runs.iter().filter(|m| !m.is_safe()).count(),
        reward: avg(&|m| m.total_reward(&RewardWeights::default())),
    }
}

/// Evaluates `policies` (see [`policy_by_name`]) on `parts`; `on_run(part, row)` is told
/// before each run. Table 4 is computed with the heuristic policy.
pub fn evaluate(
    parts: &[(String, Mesh)],
    policies: &[String],
    opts: &MillOptions,
    on_run: &mut dyn FnMut(&str, &str),
) -> Result<Tables, MillError> {
    let space = opts.action_space();
    let mut tables = Tables { parts: parts.iter().map(|(n, _)| n.clone()).collect(), ..Tables::default() };
    let mut heuristic_runs = Vec::new();
    for name in policies {
        let mut runs = Vec::with_capacity(parts.len());
        for (part, mesh) in parts {
            on_run(part, name);
            let mut policy = policy_by_name(name, &space, opts.seed)
                .ok_or_else(|| MillError::InvalidOption(format!("unknown policy {name:?}")))?;
            runs.push(mill(mesh, policy.as_mut(), opts, &mut |_| {})?);
        }
        tables.policies.push(mean_row(name, &runs));
        if name == "heuristic" {
            heuristic_runs = runs;
        }
    }
    if heuristic_runs.is_empty() {
        for (part, mesh) in parts {
            on_run(part, "heuristic");
            heuristic_runs.push(mill(mesh, &mut HeuristicPolicy::default(), opts, &mut |_| {})?);
        }
    }
    let n = heuristic_runs.len().max(1) as f64;
    let cov = |f: &dyn Fn(&Milled) -> f64| heuristic_runs.iter().map(f).sum::<f64>() / n;
    tables.orientation = CoverageRow {
        six_axes: cov(&|m| m.orientation.baselines.six_axes),
        random5: cov(&|m| m.orientation.baselines.random5),
        random6: cov(&|m| m.orientation.baselines.random6),
        plain_greedy: cov(&|m| m.orientation.baselines.plain_greedy),
        ours: cov(&|m| m.orientation.final_coverage()),
        upper_bound: cov(&|m| m.orientation.upper_bound),
    };
    tables.ablation.push(mean_row("none removed", &heuristic_runs));
    for removed in StrategyKind::ALL {
        let strategies: Vec<StrategyKind> = StrategyKind::ALL.into_iter().filter(|&s| s != removed).collect();
        let o = MillOptions { strategies, ..opts.clone() };
        let mut runs = Vec::with_capacity(parts.len());
        for (part, mesh) in parts {
            on_run(part, &format!("heuristic without {}", removed.name()));
            runs.push(mill(mesh, &mut HeuristicPolicy::default(), &o, &mut |_| {})?);
        }
        tables.ablation.push(mean_row(&format!("without {}", removed.name()), &runs));
    }
    let o = MillOptions { contour: false, ..opts.clone() };
    let mut runs = Vec::with_capacity(parts.len());
    for (part, mesh) in parts {
        on_run(part, "heuristic without contour");
        runs.push(mill(mesh, &mut HeuristicPolicy::default(), &o, &mut |_| {})?);
    }
    tables.ablation.push(mean_row("without contour", &runs));
    Ok(tables)
}

fn row_json(r: &Row) -> Value {
    json!({
        "name": r.name, "iou": r.iou, "f1": r.f1, "chamfer_x1000": r.chamfer_x1000,
        "normal_consistency": r.normal_consistency, "machining_time_s": r.machining_time_s,
        "unsafe_parts": r.unsafe_parts, "reward": r.reward,
    })
}

impl Tables {
    /// The tables as JSON.
    pub fn to_json(&self) -> Value {
        let o = &self.orientation;
        json!({
            "parts": self.parts,
            "policies": self.policies.iter().map(|r| (r.name.clone(), row_json(r))).collect::<serde_json::Map<_, _>>(),
            "table1_policies": self.policies.iter().map(row_json).collect::<Vec<_>>(),
            "table2_orientation": {
                "six_axes": o.six_axes, "random5": o.random5, "random6": o.random6,
                "plain_greedy": o.plain_greedy, "ours": o.ours, "upper_bound": o.upper_bound,
            },
            "table4_strategy_ablation": self.ablation.iter().map(row_json).collect::<Vec<_>>(),
        })
    }

    /// The tables as Markdown, laid out like the paper's.
    pub fn to_markdown(&self) -> String {
        let rows = |rows: &[Row]| -> String {
            rows.iter()
                .map(|r| {
                    format!(
                        "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} | {:.4} | {} |\n",
                        r.name,
                        r.iou,
                        r.f1,
                        r.chamfer_x1000,
                        r.normal_consistency,
                        r.machining_time_s,
                        r.reward,
                        r.unsafe_parts
                    )
                })
                .collect()
        };
        let head =
            "| | IoU | F1 | CD x1000 | NC | T (s) | reward | unsafe |\n|---|---|---|---|---|---|---|---|\n";
        let o = &self.orientation;
        format!(
            "Parts: {}\n\n### Tables 1 and 3: policies\n\n{head}{}\n### Table 2: orientation selection (surface coverage)\n\n\
             | 6-axes | Rand(5) | Rand(6) | plain greedy | ours | upper bound |\n|---|---|---|---|---|---|\n\
             | {:.2}% | {:.2}% | {:.2}% | {:.2}% | {:.2}% | {:.2}% |\n\n### Table 4: clearing strategies removed one at a time\n\n{head}{}",
            self.parts.join(", "),
            rows(&self.policies),
            100.0 * o.six_axes,
            100.0 * o.random5,
            100.0 * o.random6,
            100.0 * o.plain_greedy,
            100.0 * o.ours,
            100.0 * o.upper_bound,
            rows(&self.ablation),
        )
    }
}
