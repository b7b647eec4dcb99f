//! An evaluation split into shards, each writing one result file per part, merges into the
//! tables of one process byte for byte (issue 37, "Beyond one machine"). `s2g eval
//! --shard` and `--merge` run the same steps in separate processes (crates/cli/tests/eval.rs,
//! and scripts/slurm/test_local_cluster.sh on a one-node Slurm cluster).

use s2g_gen::{GenOptions, generate};
use shape2gcode::geom::Mesh;
use shape2gcode::{
    EvalOptions, EvalPlan, MillOptions, Shard, TableSet, evaluate, evaluate_part, merge_results,
    tables_from_parts, write_part_result,
};

/// Four generated parts at 16^3, two policies (the heuristic gives Table 2 as well): the
/// tables of one `evaluate` and the merge of two shards' result files, written in the
/// opposite order, are the same bytes as Markdown and as JSON; one shard's own tables are
/// not (the merge really combines the shards).
#[test]
fn sharded_evaluation_merges_to_the_single_process_tables_byte_for_byte() {
    let parts: Vec<(String, Mesh)> = (0..4)
        .map(|i| {
            let p = generate(37, i, &GenOptions::default()).unwrap_or_else(|e| panic!("part {i}: {e}"));
            (p.name, p.mesh)
        })
        .collect();
    let names: Vec<String> = parts.iter().map(|(n, _)| n.clone()).collect();
    let opts =
        MillOptions { orient_points: 256, resolution: 16, metric_samples: 1000, ..MillOptions::default() };
    let policies = vec!["heuristic".to_string(), "coarse".to_string()];
    let eval = EvalOptions {
        tables: TableSet { policies: true, orientation: true, strategies: false },
        ..EvalOptions::default()
    };
    let single = evaluate(&parts, &policies, &eval, &opts, &mut |_, _| {}).unwrap();
    assert_eq!(single.parts, names);
    let plan = EvalPlan::new(&names, &policies, &eval, &opts);
    let dir = tempfile::tempdir().unwrap();
    let mut shard0 = Vec::new();
    for shard in [Shard { index: 1, count: 2 }, Shard { index: 0, count: 2 }] {
        for (i, (name, mesh)) in parts.iter().enumerate().filter(|(i, _)| shard.takes(*i)) {
            let result = evaluate_part(name, mesh, &policies, &eval, &opts, &mut |_, _| {}).unwrap();
            write_part_result(dir.path(), &result, i, &plan).unwrap();
            if shard.index == 0 {
                shard0.push(result);
            }
        }
    }
    let (merged, back) = merge_results(dir.path()).unwrap();
    assert_eq!(back, plan);
    assert_eq!(merged.to_markdown(), single.to_markdown());
    let json = |t: &shape2gcode::Tables| serde_json::to_string_pretty(&t.to_json()).unwrap();
    assert_eq!(json(&merged), json(&single));
    for r in &merged.policies {
        assert!(r.iou > 0.0 && r.iou <= 1.0 && r.reward.is_finite(), "{r:?}");
    }
    let alone = tables_from_parts(&shard0, &policies, &eval).unwrap();
    assert_eq!(alone.parts.len(), 2);
    assert_ne!(alone.to_markdown(), single.to_markdown(), "one shard's tables are the whole's");
}
