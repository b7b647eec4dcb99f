//! `s2g train`: a policy file from a corpus, usable by `s2g mill --policy` and
//! `--finetune`, and one-line errors.

use std::process::Command;

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn data(rel: &str) -> String {
    format!("{}/../../tests/data/{rel}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn train_writes_a_policy_that_mill_uses_and_finetunes() {
    let dir = tempfile::tempdir().unwrap();
    let corpus = dir.path().join("corpus");
    std::fs::create_dir(&corpus).unwrap();
    std::fs::copy(data("fdm/models/cube10.stl"), corpus.join("cube10.stl")).unwrap();
    let policy = dir.path().join("p.s2gp");
    let out = s2g()
        .args(["train", "--corpus"])
        .arg(&corpus)
        .args(["--episodes", "3", "--res", "16", "--setups", "1", "--points", "256", "--json", "-o"])
        .arg(&policy)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["episodes"], 3, "{v}");
    assert_eq!(v["parts"], serde_json::json!(["cube10"]), "{v}");
    let returns = v["returns"].as_array().unwrap();
    assert_eq!(returns.len(), 3, "{v}");
    // One setup: R_s + R_f + 0.1 R_MRR, each of the first two at most 1.
    assert!(returns.iter().all(|r| (0.0..3.0).contains(&r.as_f64().unwrap())), "{v}");
    assert!(policy.exists());

    let program = dir.path().join("cube.ngc");
    let out = s2g()
        .args(["mill", &data("fdm/models/cube10.stl"), "--res", "16", "--points", "256", "--setups", "1"])
        .arg("--policy")
        .arg(&policy)
        .args(["--finetune", "1", "--json", "-o"])
        .arg(&program)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["policy"], "learned", "{v}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("fine-tuned for 1 episodes"));
    assert!(program.exists());
}

/// With the exploration schedule fixed by `--epsilon-decay-steps`, a shorter run of the
/// same seed takes exactly the first episodes of a longer one, and replays them from the
/// longer run's outcome file without simulating anything new; the long run replayed writes
/// the same policy file.
#[test]
fn a_shorter_run_with_the_same_schedule_replays_the_first_episodes() {
    let dir = tempfile::tempdir().unwrap();
    let outcomes = dir.path().join("outcomes.jsonl");
    let train = |episodes: &str| {
        let out = s2g()
            .args([
                "train",
                &data("fdm/models/cube10.stl"),
                "--episodes",
                episodes,
                "--epsilon-decay-steps",
                "6",
            ])
            .args(["--res", "16", "--setups", "2", "--points", "256", "--json", "--outcomes"])
            .arg(&outcomes)
            .arg("-o")
            .arg(dir.path().join(format!("p{episodes}.s2gp")))
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["returns"].as_array().unwrap().iter().map(|r| r.as_f64().unwrap()).collect::<Vec<f64>>()
    };
    let lines = || {
        let mut l: Vec<String> =
            std::fs::read_to_string(&outcomes).unwrap().lines().map(str::to_owned).collect();
        l.sort();
        l
    };
    let long = train("6");
    let simulated = lines();
    // Two setups a part: at least the first episode's two steps and the part's start.
    assert!(simulated.len() >= 4, "{simulated:?}");
    let short = train("3");
    assert_eq!(short, long[..3], "the short run left the long run's episodes");
    // Compared whole, bit for bit: the file is read and written again, so this also holds
    // its floats to exact round trips. (Not `assert_eq!`: the lines are long.)
    let after = lines();
    assert!(
        after == simulated,
        "the short run changed the outcome file: {} lines against {}, {} differ",
        after.len(),
        simulated.len(),
        after.iter().zip(&simulated).filter(|(a, b)| a != b).count()
    );
    // The long run again, replayed whole: the same returns and the same policy file, byte
    // for byte.
    let first = std::fs::read(dir.path().join("p6.s2gp")).unwrap();
    assert_eq!(train("6"), long);
    assert!(std::fs::read(dir.path().join("p6.s2gp")).unwrap() == first, "the policy files differ");
}

#[test]
fn train_and_policy_errors_are_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let junk = dir.path().join("junk.s2gp");
    std::fs::write(&junk, "not a policy").unwrap();
    let cases: Vec<Vec<String>> = vec![
        vec!["train".into(), "--corpus".into(), empty.display().to_string(), "-o".into(), "x".into()],
        vec!["mill".into(), data("fdm/models/cube10.stl"), "--policy".into(), junk.display().to_string()],
        vec![
            "mill".into(),
            data("fdm/models/cube10.stl"),
            "--policy".into(),
            "heuristic".into(),
            "--finetune".into(),
            "2".into(),
        ],
    ];
    for args in cases {
        let out = s2g().args(&args).output().unwrap();
        assert!(!out.status.success(), "{args:?} succeeded");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("s2g: error:"), "{args:?}: {err}");
    }
}
