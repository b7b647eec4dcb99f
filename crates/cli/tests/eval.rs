//! `s2g eval`: the paper's tables (issue 5: Table 1 columns per policy, Table 2
//! orientation strategies, Table 3 fixed / chosen policies, Table 4 one clearing strategy
//! removed at a time) as JSON and Markdown, on one small part with tiny settings.
//!
//! Every table row is a full `mill` run (about five seconds each whatever the
//! resolution), the learned policy is run five times for Table 4 and the heuristic once for
//! Table 2: these are the slowest CLI tests, so both outputs are produced by two
//! concurrent processes.

use std::process::{Command, Output};

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn data(rel: &str) -> String {
    format!("{}/../../tests/data/{rel}", env!("CARGO_MANIFEST_DIR"))
}

const MESH: &str = "fdm/models/cube10.stl";

/// The small evaluation every test here runs: a 16^3 grid, 256 surface points, two policies.
const SMALL: [&str; 6] = ["--res", "16", "--points", "256", "--policies", "learned,coarse"];

fn eval(format: &str) -> std::process::Child {
    s2g()
        .args(["eval", &data(MESH)])
        .args(SMALL)
        .arg(format)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

fn done(child: std::process::Child) -> Output {
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "exit {:?}: {}", out.status, String::from_utf8_lossy(&out.stderr));
    out
}

const ROW_KEYS: [&str; 8] = [
    "name",
    "iou",
    "f1",
    "chamfer_x1000",
    "normal_consistency",
    "machining_time_s",
    "unsafe_parts",
    "reward",
];

fn check_row(r: &serde_json::Value) {
    for k in ROW_KEYS {
        assert!(r.get(k).is_some(), "row lacks {k}: {r}");
    }
    let x = |k: &str| r[k].as_f64().unwrap();
    for k in ["iou", "f1", "normal_consistency"] {
        assert!((0.0..=1.0).contains(&x(k)), "{k} out of [0, 1]: {r}");
    }
    // A cube milled from a cube of stock at 16^3: close to exact, and safe.
    assert!(x("iou") > 0.9 && x("f1") > 0.9 && x("normal_consistency") > 0.9, "{r}");
    assert!(x("chamfer_x1000") >= 0.0 && x("chamfer_x1000") < 20.0, "{r}");
    // Nothing to cut: the programs go to their start on the clearance plane and stay there.
    assert!(x("machining_time_s") >= 0.0 && x("machining_time_s").is_finite(), "{r}");
    assert_eq!(r["unsafe_parts"], 0, "{r}");
    // Eq. 13: one R_s per setup (at most 1 each) plus R_f (at most 1) plus 0.1 R_MRR.
    assert!(x("reward") > 1.0 && x("reward").is_finite(), "{r}");
}

/// A Markdown table row as `to_markdown` prints it.
fn md_row(r: &serde_json::Value) -> String {
    let x = |k: &str| r[k].as_f64().unwrap();
    format!(
        "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} | {:.4} | {} |",
        r["name"].as_str().unwrap(),
        x("iou"),
        x("f1"),
        x("chamfer_x1000"),
        x("normal_consistency"),
        x("machining_time_s"),
        x("reward"),
        r["unsafe_parts"]
    )
}

#[test]
fn json_and_markdown_tables() {
    let (json, md) = (eval("--json"), eval("--markdown"));
    let (json, md) = (done(json), done(md));
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    let md = String::from_utf8(md.stdout).unwrap();
    // Progress goes to stderr, one line per run: 2 policies, the heuristic for Table 2, and
    // the learned policy (a row already) without each of 3 strategies and the contour.
    let progress = String::from_utf8_lossy(&json.stderr);
    let announced: Vec<&str> = progress.lines().map(|l| l.rsplit(" with ").next().unwrap_or("")).collect();
    assert_eq!(
        announced,
        [
            "learned",
            "coarse",
            "heuristic",
            "learned without zigzag",
            "learned without periphery",
            "learned without spiral",
            "learned without contour"
        ],
        "{progress}"
    );

    assert_eq!(v["parts"], serde_json::json!(["cube10"]), "{v}");
    // Tables 1 and 3: one row per policy, in the order asked.
    let t1 = v["table1_policies"].as_array().unwrap();
    let names: Vec<&str> = t1.iter().map(|r| r["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["learned", "coarse"], "{v}");
    t1.iter().for_each(check_row);
    // The same rows by name, as `{"policies": {NAME: {...}}}`.
    for r in t1 {
        assert_eq!(&v["policies"][r["name"].as_str().unwrap()], r, "{v}");
    }
    // Table 2: coverage fractions, each at most the upper bound; ours at least the greedy.
    let t2 = &v["table2_orientation"];
    let c = |k: &str| t2[k].as_f64().unwrap_or_else(|| panic!("table 2 lacks {k}: {t2}"));
    let ub = c("upper_bound");
    assert!(ub > 0.0 && ub <= 1.0, "{t2}");
    for k in ["six_axes", "random5", "random6", "plain_greedy", "ours"] {
        assert!((0.0..=ub + 1e-12).contains(&c(k)), "{k}: {t2}");
    }
    assert!(c("ours") + 1e-12 >= c("plain_greedy"), "{t2}");
    // Table 4: the learned policy with nothing removed, then without each strategy and the
    // contour.
    assert_eq!(v["table4_policy"], "learned", "{v}");
    let t4 = v["table4_strategy_ablation"].as_array().unwrap();
    let names: Vec<&str> = t4.iter().map(|r| r["name"].as_str().unwrap()).collect();
    assert_eq!(
        names,
        ["none removed", "without zigzag", "without periphery", "without spiral", "without contour"],
        "{v}"
    );
    t4.iter().for_each(check_row);
    // "none removed" is the learned row of Table 1 (the same runs).
    for k in &ROW_KEYS[1..] {
        assert_eq!(t4[0][k], t1[0][k], "{k}: {v}");
    }

    // The Markdown has the same tables, with the same numbers (the runs are deterministic).
    for h in [
        "### Tables 1 and 3: policies",
        "### Table 2: orientation selection (surface coverage)",
        "### Table 4: clearing strategies removed one at a time from learned",
        "| | IoU | F1 | CD x1000 | NC | T (s) | reward | unsafe |",
        "| 6-axes | Rand(5) | Rand(6) | plain greedy | ours | upper bound |",
    ] {
        assert!(md.contains(h), "markdown lacks {h:?}:\n{md}");
    }
    assert!(md.starts_with("Parts: cube10\n"), "{md}");
    for r in t1.iter().chain(t4) {
        let row = md_row(r);
        assert!(md.lines().any(|l| l == row), "markdown lacks {row:?}:\n{md}");
    }
    let cov = format!(
        "| {:.2}% | {:.2}% | {:.2}% | {:.2}% | {:.2}% | {:.2}% |",
        100.0 * c("six_axes"),
        100.0 * c("random5"),
        100.0 * c("random6"),
        100.0 * c("plain_greedy"),
        100.0 * c("ours"),
        100.0 * ub
    );
    assert!(md.lines().any(|l| l == cov), "markdown lacks {cov:?}:\n{md}");
}

#[test]
fn bad_arguments_fail_fast_with_one_line() {
    let out = s2g()
        .args(["eval", &data(MESH), "--res", "16", "--points", "256", "--policies", "bogus"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.lines().any(|l| l.starts_with("s2g: error:") && l.contains("bogus")), "{err}");
    assert!(out.stdout.is_empty());
    // An unknown policy for Table 4 is refused before anything is milled.
    let out = s2g().args(["eval", &data(MESH)]).args(SMALL).args(["--ablate", "nonesuch"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("s2g: error:") && err.contains("nonesuch") && err.contains("--ablate"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let out = s2g().args(["eval", "--corpus"]).arg(dir.path()).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("no mesh files"), "{err}");
}

/// `--tables policies` runs and prints the policy rows alone; the learned policy gets a
/// fine-tuned row too; a seed group is one row, the mean of its members (milled once when
/// they are rows too), with a confidence interval; malformed groups and unknown tables are
/// one-line errors.
#[test]
fn chosen_tables_fine_tuning_and_seed_groups() {
    let out = s2g()
        .args(["eval", &data(MESH), "--res", "16", "--points", "256", "--tables", "policies"])
        .args([
            "--policies",
            "fine,coarse,learned",
            "--finetune",
            "1",
            "--seed-group",
            "fixed=fine+coarse",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let progress = String::from_utf8_lossy(&out.stderr);
    let announced: Vec<&str> = progress.lines().map(|l| l.rsplit(" with ").next().unwrap_or("")).collect();
    // The group's members were rows already: they are not milled again.
    assert_eq!(announced, ["fine", "coarse", "learned", "learned +ft1"], "{progress}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v.get("table2_orientation").is_none() && v.get("table4_strategy_ablation").is_none(), "{v}");
    let rows = v["table1_policies"].as_array().unwrap();
    let names: Vec<&str> = rows.iter().map(|r| r["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["fine", "coarse", "learned", "learned +ft1", "fixed"], "{v}");
    for r in rows {
        check_row(r);
    }
    // The group is the mean of its members' rows above, with Student's t interval of two
    // values (t = 12.706).
    let (fine, coarse, group) = (&rows[0], &rows[1], &rows[4]);
    for k in ["iou", "machining_time_s", "reward"] {
        let x = |r: &serde_json::Value| r[k].as_f64().unwrap();
        assert!((x(group) - 0.5 * (x(fine) + x(coarse))).abs() <= 1e-9 * x(group).abs().max(1.0), "{k}: {v}");
        let half = 12.706 * (x(fine) - x(coarse)).abs() / 2.0;
        assert!((group["ci95"][k].as_f64().unwrap() - half).abs() <= 1e-6 * half.max(1.0), "{k}: {group}");
    }
    for bad in [["--seed-group", "nameless"], ["--tables", "table9"]] {
        let out = s2g().args(["eval", &data(MESH), "--res", "16"]).args(bad).output().unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(out.stdout.is_empty());
    }
}

/// `s2g eval ARGS` over `parts`, with more arguments and the environment `env`, started.
fn eval_corpus(parts: &std::path::Path, more: &[&str], env: &[(&str, &str)]) -> std::process::Child {
    s2g()
        .arg("eval")
        .arg("--corpus")
        .arg(parts)
        .args(SMALL)
        .args(["--tables", "policies,orientation"])
        .args(more)
        .envs(env.iter().copied())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// Issue 37, beyond one machine: three generated parts evaluated by one process and by
/// two `--shard` processes (on one and on two threads, at the same time) give the same
/// result files, byte for byte, and `--merge` of the shards' folder prints the one
/// process's tables byte for byte; a folder that lacks a part's result, a shard out of
/// range and a shard without `--results` are one-line errors.
#[test]
fn sharded_runs_merge_to_the_single_run_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let (parts, whole, split) =
        (dir.path().join("parts"), dir.path().join("whole"), dir.path().join("split"));
    let out = s2g().args(["gen", "--count", "3", "--seed", "37", "--out"]).arg(&parts).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let results = |d: &std::path::Path| d.to_str().unwrap().to_owned();
    let single = eval_corpus(&parts, &["--results", &results(&whole)], &[]);
    let shards: Vec<_> = [("0/2", "1"), ("1/2", "2")]
        .iter()
        .map(|(k, threads)| {
            eval_corpus(
                &parts,
                &["--shard", k, "--results", &results(&split)],
                &[("RAYON_NUM_THREADS", threads)],
            )
        })
        .collect();
    let single = done(single);
    for shard in shards {
        let out = done(shard);
        assert!(out.stdout.is_empty(), "a shard prints no table: {}", String::from_utf8_lossy(&out.stdout));
    }
    let mut names: Vec<String> = std::fs::read_dir(&split)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names.len(), 3, "{names:?}");
    for name in &names {
        assert!(name.ends_with(".eval.json"), "{name}");
        let (a, b) = (std::fs::read(whole.join(name)).unwrap(), std::fs::read(split.join(name)).unwrap());
        assert!(a == b, "{name} differs between the single run and the shards");
    }
    let merge =
        |d: &std::path::Path, format: &str| s2g().args(["eval", format, "--merge"]).arg(d).output().unwrap();
    let merged = merge(&split, "--markdown");
    assert!(merged.status.success(), "{}", String::from_utf8_lossy(&merged.stderr));
    let table = String::from_utf8(single.stdout).unwrap();
    assert!(table.starts_with("Parts: ") && table.contains("| coarse |"), "{table}");
    assert_eq!(String::from_utf8(merged.stdout).unwrap(), table);
    let (a, b) = (merge(&whole, "--json"), merge(&split, "--json"));
    assert!(a.status.success() && !a.stdout.is_empty() && a.stdout == b.stdout);

    std::fs::remove_file(split.join(&names[1])).unwrap();
    let out = merge(&split, "--markdown");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && out.stdout.is_empty(), "{err}");
    assert!(
        err.lines()
            .any(|l| l.starts_with("s2g: error:") && l.contains("no result for 1 of 3 parts (places 1 ")),
        "{err}"
    );
    for bad in [&["--shard", "2/2", "--results", "x"][..], &["--shard", "0/2"][..]] {
        let out = s2g().args(["eval", &data(MESH)]).args(bad).output().unwrap();
        assert!(!out.status.success() && out.stdout.is_empty(), "{bad:?}");
    }
}
