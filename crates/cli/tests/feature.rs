//! `s2g feature`: the seed's worked example (seed 001; issue 6: d = 2.5, m = 2, N = 4,
//! Q = 8.067), the program it writes, and bad jobs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn job(name: &str) -> String {
    format!("{}/../../assets/jobs/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn feature(job: &Path, extra: &[&str]) -> Output {
    s2g().arg("feature").arg(job).args(extra).output().unwrap()
}

fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "exit {:?}: {}", out.status, String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn worked_example_rules() {
    let v = json(&feature(Path::new(&job("seed_pocket.toml")), &["--json"]));
    let fs = v["features"].as_array().unwrap();
    assert_eq!(fs.len(), 1, "{v}");
    let f = &fs[0];
    assert_eq!(f["name"], "pocket");
    assert_eq!(f["kind"], "pocket");
    assert_eq!(f["depth_of_cut"], 2.5, "{f}");
    assert_eq!(f["cuts"], 2, "{f}");
    assert_eq!(f["passes"], 4, "{f}");
    // Q = (width - 2 S - 2 r) / (N - 1) = (35 - 0.8 - 10) / 3.
    let q = f["stepover"].as_f64().unwrap();
    assert!((q - 8.067).abs() < 5e-4 && (q - 24.2 / 3.0).abs() < 1e-9, "{f}");
    assert_eq!(f["tool"], 1);
    assert_eq!(f["finish_tool"], 2);
    // The tool centre stays inside the pocket (X12.5..62.5, Y12.5..47.5) less the tool
    // radius, and reaches the floor at Z-5.
    let (lo, hi) = (&f["extents"]["min"], &f["extents"]["max"]);
    let c = |v: &serde_json::Value, i: usize| v[i].as_f64().unwrap();
    assert!(c(lo, 0) >= 12.5 + 5.0 - 1e-9 && c(hi, 0) <= 62.5 - 5.0 + 1e-9, "{f}");
    assert!(c(lo, 1) >= 12.5 + 5.0 - 1e-9 && c(hi, 1) <= 47.5 - 5.0 + 1e-9, "{f}");
    assert!((c(lo, 2) + 5.0).abs() < 1e-9, "{f}");
    assert!(v["motions"].as_u64().unwrap() > 10, "{v}");
}

#[test]
fn writes_a_complete_program() {
    let dir = tempfile::tempdir().unwrap();
    let prog = dir.path().join("prog.ngc");
    let out = feature(Path::new(&job("seed_pocket.toml")), &["-o", prog.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.stdout.is_empty(), "with -o and no --json, nothing on stdout");
    let text = std::fs::read_to_string(&prog).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("N10 "), "{}", lines[0]);
    // Numbered blocks N10, N20, ... in steps of 10.
    for (i, l) in lines.iter().enumerate() {
        assert!(l.starts_with(&format!("N{} ", 10 * (i + 1))), "line {}: {l}", i + 1);
    }
    let words: Vec<&str> = text.split_whitespace().collect();
    for w in ["G21", "M8", "M9", "M5", "M30", "T1", "T2", "S1200", "S1500"] {
        assert!(words.contains(&w), "program lacks {w}");
    }
    assert!(words.contains(&"M6") || words.contains(&"M06"), "no tool change");
    assert!(words.contains(&"M3") || words.contains(&"M03"), "no spindle start");
    assert!(words.iter().any(|w| w.starts_with("G43")), "no tool length offset");
    let at = |w: &str| lines.iter().position(|l| l.split_whitespace().any(|x| x == w)).unwrap();
    assert!(at("T1") < at("T2") && at("T2") < at("M30"), "roughing, finishing, end");
    assert_eq!(lines.last().unwrap().split_whitespace().nth(1), Some("M30"));
    // The written program parses cleanly; stdout without -o is the same program.
    let check = s2g().args(["gcode", "check"]).arg(&prog).output().unwrap();
    assert_eq!(check.status.code(), Some(0), "{}", String::from_utf8_lossy(&check.stdout));
    let stdout = feature(Path::new(&job("seed_pocket.toml")), &[]);
    assert_eq!(String::from_utf8(stdout.stdout).unwrap(), text);
}

/// The worked example with some lines replaced.
fn edited(dir: &Path, name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut src = std::fs::read_to_string(job("seed_pocket.toml")).unwrap();
    for (from, to) in edits {
        assert!(src.contains(from), "{from:?} not in the job");
        src = src.replacen(from, to, 1);
    }
    let path = dir.join(name);
    std::fs::write(&path, src).unwrap();
    path
}

fn one_line_failure(out: &Output, needles: &[&str]) {
    assert!(!out.status.success(), "expected a failure: {}", String::from_utf8_lossy(&out.stdout));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in {err}");
    }
}

#[test]
fn bad_jobs_name_the_feature() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Renamed so the message must name this feature, not a default.
    let far =
        edited(d, "far.toml", &[("name = \"pocket\"", "name = \"far_pocket\""), ("x = 12.5", "x = 40.0")]);
    one_line_failure(&feature(&far, &["--json"]), &["far_pocket", "outside the block"]);
    let deep = edited(d, "deep.toml", &[("depth = 5.0", "depth = 20.0")]);
    one_line_failure(&feature(&deep, &[]), &["'pocket'", "depth"]);
    let sharp = edited(d, "sharp.toml", &[("corner_radius = 5.0", "corner_radius = 2.0")]);
    one_line_failure(&feature(&sharp, &[]), &["'pocket'", "corner radius"]);
    let garbage = d.join("garbage.toml");
    std::fs::write(&garbage, "this is = not [ toml").unwrap();
    one_line_failure(&feature(&garbage, &[]), &["garbage.toml"]);
}
