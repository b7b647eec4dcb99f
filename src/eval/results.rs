//! An evaluation split over processes or machines: which parts a [`Shard`] evaluates, one
//! result file per part ([`write_part_result`]), and the merge of a folder of them into the
//! tables one process would have printed ([`merge_results`]).
//!
//! The tables are means over parts, summed in the parts' order, of per-part scores; a
//! result file keeps each score's exact bits (JSON numbers read back to the same `f64`,
//! non-finite values as strings), so the merged tables are byte for byte those of one
//! [`evaluate`](super::evaluate) of all the parts.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::{CoverageRow, EvalOptions, PartResult, PartScores, RunKey, SeedGroup, TableSet, Tables};
use crate::pipeline::{MillError, MillOptions};

/// One of `count` processes of an evaluation: it evaluates the parts whose place in the
/// sorted part list is `index` modulo `count`. Written and parsed as `K/N` (0-based `K`,
/// as Slurm's `SLURM_ARRAY_TASK_ID` of `--array=0-(N-1)` and Kubernetes'
/// `JOB_COMPLETION_INDEX` count).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: usize,
    /// The number of shards, at least 1.
    pub count: usize,
}

impl Shard {
    /// The whole evaluation in one process.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Whether the part at `part_index` of the sorted part list is this shard's.
    pub fn takes(&self, part_index: usize) -> bool {
        part_index % self.count.max(1) == self.index
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = MillError;

    /// `K/N` with `0 <= K < N`.
    fn from_str(s: &str) -> Result<Self, MillError> {
        let bad = || MillError::InvalidOption(format!("a shard is K/N with 0 <= K < N, got {s:?}"));
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// What every result file of one evaluation shares, and the merge needs: the policies and
/// tables asked for, a fingerprint of the milling options and one of the full part list.
/// Files that differ in it are not merged.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalPlan {
    /// The policies, as [`evaluate`](super::evaluate) takes them.
    pub policies: Vec<String>,
    /// The tables, fine-tuning and seed groups.
    pub eval: EvalOptions,
    /// FNV-1a (64 bits, hex) of the milling options' `Debug` form.
    pub options: String,
    /// The number of parts of the whole evaluation.
    pub count: usize,
    /// FNV-1a (64 bits, hex) of the full sorted part list's names.
    pub parts: String,
}

impl EvalPlan {
    /// The plan of evaluating `policies` on the parts named `parts` (all of them, sorted as
    /// one process would evaluate them) with `eval` and `opts`.
    pub fn new(parts: &[String], policies: &[String], eval: &EvalOptions, opts: &MillOptions) -> Self {
        Self {
            policies: policies.to_vec(),
            eval: eval.clone(),
            options: fnv1a_hex(format!("{opts:?}").as_bytes()),
            count: parts.len(),
            parts: fnv1a_hex(parts.join("\n").as_bytes()),
        }
    }
}

fn fnv1a_hex(bytes: &[u8]) -> String {
    let h = bytes
        .iter()
        .fold(0xcbf2_9ce4_8422_2325_u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3));
    format!("{h:016x}")
}

/// The first field of a result file.
const FORMAT: &str = "s2g eval part result 1";

/// How a result file's name ends: `PART.eval.json`.
pub const RESULT_SUFFIX: &str = ".eval.json";

/// Where [`write_part_result`] writes `part`'s result in `dir`.
pub fn part_result_path(dir: &Path, part: &str) -> PathBuf {
    dir.join(format!("{part}{RESULT_SUFFIX}"))
}

/// Writes `result`, the part at `index` of `plan`'s sorted part list, to
/// [`part_result_path`] in `dir` (created if missing), atomically; returns the path.
pub fn write_part_result(
    dir: &Path,
    result: &PartResult,
    index: usize,
    plan: &EvalPlan,
) -> Result<PathBuf, MillError> {
    if index >= plan.count {
        return Err(MillError::InvalidOption(format!("part index {index} of {} parts", plan.count)));
    }
    let record = FileRecord {
        format: FORMAT.into(),
        part: result.part.clone(),
        index,
        plan: PlanRecord::of(plan),
        runs: result.runs.iter().map(|(k, s)| RunRecord::of(k, s)).collect(),
        orientation: result.orientation.map(CoverageRecord::of),
    };
    let mut text = serde_json::to_string_pretty(&record)
        .map_err(|e| MillError::Encode { what: "a part's evaluation", source: Box::new(e) })?;
    text.push('\n');
    std::fs::create_dir_all(dir).map_err(|source| MillError::Io { path: dir.to_owned(), source })?;
    let path = part_result_path(dir, &result.part);
    crate::geom::write_bytes_atomic(&path, text.as_bytes())?;
    Ok(path)
}

/// Reads every result file (`*.eval.json`) in `dir` and returns the tables of the whole
/// evaluation, with its plan: what one process evaluating all the parts gives, byte for
/// byte. An error when the folder holds no result, files of different evaluations, two
/// results of one part, or lacks a part's result (naming the missing places).
pub fn merge_results(dir: &Path) -> Result<(Tables, EvalPlan), MillError> {
    let io = |source| MillError::Io { path: dir.to_owned(), source };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(io)?
        .map(|e| e.map(|e| e.path()).map_err(io))
        .collect::<Result<Vec<_>, _>>()?;
    files.retain(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.ends_with(RESULT_SUFFIX)));
    files.sort();
    let mut plan: Option<(PlanRecord, PathBuf)> = None;
    let mut slots: Vec<Option<PartResult>> = Vec::new();
    for path in files {
        let bad = |what: String| MillError::BadFile { path: path.clone(), line: None, what, source: None };
        let text =
            std::fs::read_to_string(&path).map_err(|source| MillError::Io { path: path.clone(), source })?;
        let record: FileRecord = serde_json::from_str(&text).map_err(|e| MillError::BadFile {
            path: path.clone(),
            line: Some(e.line()),
            what: "not a part's evaluation result".into(),
            source: Some(Box::new(e)),
        })?;
        if record.format != FORMAT {
            return Err(bad(format!("format {:?}, not {FORMAT:?}", record.format)));
        }
        match &plan {
            None => {
                slots = vec![None; record.plan.count];
                plan = Some((record.plan.clone(), path.clone()));
            }
            Some((p, first)) if *p != record.plan => {
                return Err(bad(format!(
                    "of another evaluation than {} (policies, tables, options or parts differ)",
                    first.display()
                )));
            }
            Some(_) => {}
        }
        let slot = slots
            .get_mut(record.index)
            .ok_or_else(|| bad(format!("part index {} out of range", record.index)))?;
        if let Some(other) = slot {
            return Err(bad(format!("a second result for part {} (also {})", record.index, other.part)));
        }
        *slot = Some(record.result());
    }
    let Some((plan, _)) = plan else {
        return Err(MillError::InvalidOption(format!("{}: no *{RESULT_SUFFIX} result files", dir.display())));
    };
    let missing: Vec<String> =
        slots.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| i.to_string()).collect();
    if !missing.is_empty() {
        return Err(MillError::InvalidOption(format!(
            "{}: no result for {} of {} parts (places {} in the sorted part list): a shard did not finish?",
            dir.display(),
            missing.len(),
            slots.len(),
            missing.join(", ")
        )));
    }
    let results: Vec<PartResult> = slots.into_iter().flatten().collect();
    let plan = plan.plan();
    let tables = super::tables_from_parts(&results, &plan.policies, &plan.eval)?;
    Ok((tables, plan))
}

/// A result file.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileRecord {
    format: String,
    part: String,
    index: usize,
    plan: PlanRecord,
    runs: Vec<RunRecord>,
    orientation: Option<CoverageRecord>,
}

impl FileRecord {
    fn result(self) -> PartResult {
        PartResult {
            part: self.part,
            runs: self.runs.into_iter().map(RunRecord::scores).collect(),
            orientation: self.orientation.map(|c| CoverageRow {
                six_axes: c.six_axes,
                random5: c.random5,
                random6: c.random6,
                plain_greedy: c.plain_greedy,
                ours: c.ours,
                upper_bound: c.upper_bound,
            }),
        }
    }
}

fn heuristic() -> String {
    "heuristic".into()
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanRecord {
    policies: Vec<String>,
    tables: Vec<String>,
    finetune: usize,
    seed_groups: Vec<(String, Vec<String>)>,
    /// Table 4's policy; files written before it was a choice ablated the heuristic.
    #[serde(default = "heuristic")]
    ablated: String,
    options: String,
    count: usize,
    parts: String,
}

impl PlanRecord {
    fn of(p: &EvalPlan) -> Self {
        let t = p.eval.tables;
        let tables = [("policies", t.policies), ("orientation", t.orientation), ("strategies", t.strategies)];
        Self {
            policies: p.policies.clone(),
            tables: tables.iter().filter(|(_, on)| *on).map(|(n, _)| (*n).to_owned()).collect(),
            finetune: p.eval.finetune_episodes,
            seed_groups: p.eval.seed_groups.iter().map(|g| (g.name.clone(), g.members.clone())).collect(),
            ablated: p.eval.ablated.clone(),
            options: p.options.clone(),
            count: p.count,
            parts: p.parts.clone(),
        }
    }

    fn plan(self) -> EvalPlan {
        let on = |name: &str| self.tables.iter().any(|t| t == name);
        let tables = TableSet {
            policies: on("policies"),
            orientation: on("orientation"),
            strategies: on("strategies"),
        };
        EvalPlan {
            eval: EvalOptions {
                tables,
                finetune_episodes: self.finetune,
                seed_groups: self
                    .seed_groups
                    .into_iter()
                    .map(|(name, members)| SeedGroup { name, members })
                    .collect(),
                ablated: self.ablated,
            },
            policies: self.policies,
            options: self.options,
            count: self.count,
            parts: self.parts,
        }
    }
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RunRecord {
    policy: String,
    finetune: usize,
    without: Option<String>,
    #[serde(with = "real")]
    iou: f64,
    #[serde(with = "real")]
    f1: f64,
    #[serde(with = "real")]
    chamfer_x1000: f64,
    #[serde(with = "real")]
    normal_consistency: f64,
    #[serde(with = "real")]
    machining_time_s: f64,
    safe: bool,
    #[serde(with = "real")]
    reward: f64,
}

impl RunRecord {
    fn of(k: &RunKey, s: &PartScores) -> Self {
        Self {
            policy: k.policy.clone(),
            finetune: k.finetune,
            without: k.without.clone(),
            iou: s.iou,
            f1: s.f1,
            chamfer_x1000: s.chamfer_x1000,
            normal_consistency: s.normal_consistency,
            machining_time_s: s.machining_time_s,
            safe: s.safe,
            reward: s.reward,
        }
    }

    fn scores(self) -> (RunKey, PartScores) {
        let key = RunKey { policy: self.policy, finetune: self.finetune, without: self.without };
        let scores = PartScores {
            iou: self.iou,
            f1: self.f1,
            chamfer_x1000: self.chamfer_x1000,
            normal_consistency: self.normal_consistency,
            machining_time_s: self.machining_time_s,
            safe: self.safe,
            reward: self.reward,
        };
        (key, scores)
    }
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CoverageRecord {
    #[serde(with = "real")]
    six_axes: f64,
    #[serde(with = "real")]
    random5: f64,
    #[serde(with = "real")]
    random6: f64,
    #[serde(with = "real")]
    plain_greedy: f64,
    #[serde(with = "real")]
    ours: f64,
    #[serde(with = "real")]
    upper_bound: f64,
}

impl CoverageRecord {
    fn of(c: CoverageRow) -> Self {
        Self {
            six_axes: c.six_axes,
            random5: c.random5,
            random6: c.random6,
            plain_greedy: c.plain_greedy,
            ours: c.ours,
            upper_bound: c.upper_bound,
        }
    }
}

/// An `f64` to its exact bits and back: a JSON number when finite (the workspace's
/// serde_json reads numbers back to the same bits, its `float_roundtrip` feature), else
/// the string `NaN`, `inf` or `-inf`, which JSON has no number for.
mod real {
    use serde::{Deserialize, Deserializer, Serializer, de::Error};

    pub(super) fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() { s.serialize_f64(*v) } else { s.serialize_str(&v.to_string()) }
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Real {
            Number(f64),
            Text(String),
        }
        match Real::deserialize(d)? {
            Real::Number(v) => Ok(v),
            Real::Text(t) => {
                t.parse().ok().filter(|v: &f64| !v.is_finite()).ok_or_else(|| {
                    D::Error::custom(format!("{t:?} is neither a number nor NaN, inf or -inf"))
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `K/N` parses for `0 <= K < N` only, prints back the same, and the shards of `N`
    /// take every place exactly once.
    #[test]
    fn shards_parse_and_partition_the_parts() {
        for (text, ok) in
            [("0/1", true), ("3/4", true), ("4/4", false), ("0/0", false), ("1", false), ("-1/2", false)]
        {
            assert_eq!(text.parse::<Shard>().is_ok(), ok, "{text}");
            if let Ok(s) = text.parse::<Shard>() {
                assert_eq!(s.to_string(), text);
            }
        }
        let shards: Vec<Shard> = (0..4).map(|k| Shard { index: k, count: 4 }).collect();
        for place in 0..17 {
            assert_eq!(shards.iter().filter(|s| s.takes(place)).count(), 1, "place {place}");
        }
        assert!((0..5).all(|p| Shard::ALL.takes(p)));
    }

    /// Scores awkward for JSON (non-finite, 17 significant digits, subnormal) come back
    /// with the same bits, and a folder missing a part's result is refused, naming it.
    #[test]
    fn result_files_round_trip_bits_and_merges_check_completeness() {
        let dir = tempfile::tempdir().unwrap();
        let policies = vec!["coarse".to_string()];
        let eval = EvalOptions {
            tables: TableSet { policies: true, orientation: false, strategies: false },
            ..EvalOptions::default()
        };
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let plan = EvalPlan::new(&names, &policies, &eval, &MillOptions::default());
        let values = [0.1 + 0.2, f64::NAN, f64::INFINITY, 5e-324, 1.0 / 3.0, -0.0, 123456.789];
        let result = |i: usize| PartResult {
            part: names[i].clone(),
            runs: vec![(
                RunKey { policy: "coarse".into(), finetune: 0, without: None },
                PartScores {
                    iou: values[i],
                    f1: values[i + 1],
                    chamfer_x1000: values[i + 2],
                    normal_consistency: values[i + 3],
                    machining_time_s: values[i + 4],
                    safe: i != 1,
                    reward: 1.0 / (i as f64 + 3.0),
                },
            )],
            orientation: None,
        };
        for i in [0, 2] {
            write_part_result(dir.path(), &result(i), i, &plan).unwrap();
        }
        let err = merge_results(dir.path()).unwrap_err().to_string();
        assert!(err.contains("no result for 1 of 3 parts (places 1 in"), "{err}");
        write_part_result(dir.path(), &result(1), 1, &plan).unwrap();
        let (tables, back) = merge_results(dir.path()).unwrap();
        assert_eq!(back, plan);
        let direct =
            super::super::tables_from_parts(&[result(0), result(1), result(2)], &policies, &eval).unwrap();
        assert_eq!(tables.to_markdown(), direct.to_markdown());
        let (a, b) = (&tables.policies[0], &direct.policies[0]);
        for (x, y) in
            [(a.iou, b.iou), (a.f1, b.f1), (a.reward, b.reward), (a.machining_time_s, b.machining_time_s)]
        {
            assert_eq!(x.to_bits(), y.to_bits(), "{a:?} vs {b:?}");
        }
        // Another evaluation's file in the folder is refused.
        let other = EvalPlan::new(&names, &["fine".to_string()], &eval, &MillOptions::default());
        let mut stray = result(1);
        stray.part = "z".into();
        write_part_result(dir.path(), &stray, 1, &other).unwrap();
        assert!(merge_results(dir.path()).is_err());
    }
}
