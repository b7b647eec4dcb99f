//! `s2g orient`: the JSON report's invariants, the per-setup reconstructions, determinism
//! and errors.

use std::process::{Command, Output};

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn data(rel: &str) -> String {
    format!("{}/../../tests/data/{rel}", env!("CARGO_MANIFEST_DIR"))
}

const MESH: &str = "meshes/openscad/openscad_Old_example002.stl";

fn orient_k(setups: &str, extra: &[&str]) -> Output {
    s2g()
        .args(["orient", &data(MESH), "--max-setups", setups, "--points", "2048", "--json"])
        .args(extra)
        .output()
        .unwrap()
}

fn orient(extra: &[&str]) -> Output {
    orient_k("3", extra)
}

fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "exit {:?}: {}", out.status, String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().unwrap_or_else(|| panic!("not an array: {v}")).iter().map(|x| x.as_f64().unwrap()).collect()
}

/// Drops the wall-clock fields.
fn untimed(mut v: serde_json::Value) -> serde_json::Value {
    let o = v.as_object_mut().unwrap();
    o.remove("seconds");
    o.remove("stage_seconds");
    v
}

#[test]
fn report_invariants_and_reconstructions() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("setups");
    let v = json(&orient(&["--out-dir", out_dir.to_str().unwrap(), "--resolution", "32"]));
    for key in ["directions", "coverage", "baselines", "upper_bound", "seconds"] {
        assert!(v.get(key).is_some(), "report lacks {key}: {v}");
    }
    let dirs = v["directions"].as_array().unwrap();
    let cov = floats(&v["coverage"]);
    assert!((1..=3).contains(&dirs.len()), "{v}");
    assert_eq!(cov.len(), dirs.len(), "{v}");
    for d in dirs {
        let d = floats(d);
        assert_eq!(d.len(), 3);
        let n = d.iter().map(|c| c * c).sum::<f64>().sqrt();
        assert!((n - 1.0).abs() < 1e-9, "direction {d:?} has length {n}");
    }
    let ub = v["upper_bound"].as_f64().unwrap();
    assert!(ub > 0.0 && ub <= 1.0, "{v}");
    assert!(cov[0] > 0.0, "{v}");
    for w in cov.windows(2) {
        assert!(w[0] <= w[1], "coverage decreases: {cov:?}");
    }
    let last = *cov.last().unwrap();
    assert!(last <= ub + 1e-12, "coverage {last} above the upper bound {ub}");
    let b = &v["baselines"];
    for key in ["six_axes", "random5", "random6", "plain_greedy", "swap_search"] {
        let x = b[key].as_f64().unwrap_or_else(|| panic!("baselines lack {key}: {v}"));
        assert!((0.0..=ub + 1e-12).contains(&x), "{key} = {x} outside [0, {ub}]");
    }
    // The search starts from the plain greedy and the refinement keeps the best.
    let (greedy, swap) = (b["plain_greedy"].as_f64().unwrap(), b["swap_search"].as_f64().unwrap());
    assert!(greedy <= swap + 1e-12 && swap <= last + 1e-12, "greedy {greedy}, swap {swap}, final {last}");
    assert!(v["seconds"].as_f64().unwrap() >= 0.0);

    // One closed reconstruction per setup, setup_<i>.stl, each holding the part.
    let meshes = v["meshes"].as_array().unwrap();
    assert_eq!(meshes.len(), dirs.len(), "{v}");
    let mut names: Vec<String> = std::fs::read_dir(&out_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let want: Vec<String> = (0..dirs.len()).map(|i| format!("setup_{i}.stl")).collect();
    assert_eq!(names, want);
    let part = json(&s2g().args(["inspect", "--json", &data(MESH)]).output().unwrap());
    let part_volume = part["volume"].as_f64().unwrap();
    let (lo, hi) = (floats(&part["bbox"]["min"]), floats(&part["bbox"]["max"]));
    for m in meshes {
        let path = m.as_str().unwrap();
        assert!(path.starts_with(out_dir.to_str().unwrap()), "{path}");
        let r = json(&s2g().args(["inspect", "--json", path]).output().unwrap());
        assert_eq!(r["closed"], true, "{path}: {r}");
        // A height closure contains the part (up to a few voxels of 1/32 of the extent)
        // and stays on its grid: the part's bounding box, two voxels of margin, and the
        // rounding of the cubic grid's dimensions.
        let vol = r["volume"].as_f64().unwrap();
        assert!(vol >= 0.95 * part_volume, "{path}: volume {vol} below the part's {part_volume}");
        let h = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max) / 32.0;
        let (rlo, rhi) = (floats(&r["bbox"]["min"]), floats(&r["bbox"]["max"]));
        for a in 0..3 {
            assert!(rlo[a] >= lo[a] - 3.0 * h && rhi[a] <= hi[a] + 3.0 * h, "{path}: bbox {rlo:?}..{rhi:?}");
        }
    }
}

#[test]
fn deterministic_and_plain_greedy_matches_its_baseline() {
    let a = untimed(json(&orient(&[])));
    let b = untimed(json(&orient(&[])));
    assert_eq!(a, b);
    let g = json(&orient(&["--plain-greedy"]));
    let cov = floats(&g["coverage"]);
    let greedy = g["baselines"]["plain_greedy"].as_f64().unwrap();
    assert!((cov.last().unwrap() - greedy).abs() < 1e-12, "{g}");
    assert_eq!(g["baselines"]["swap_search"], g["baselines"]["plain_greedy"], "{g}");
    let one = json(&orient_k("1", &[]));
    assert_eq!(one["directions"].as_array().unwrap().len(), 1, "{one}");
}

#[test]
fn errors_are_one_line() {
    let out = s2g().args(["orient", "/nonexistent/mesh.stl", "--json"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("/nonexistent/mesh.stl"), "{err}");
}
