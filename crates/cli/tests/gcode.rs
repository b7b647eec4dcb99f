//! `s2g gcode check|stats|motions`: exit codes and `file:line:col: message` lines, counts,
//! extents and lengths of a program written here, and the motions as JSON lines.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn data(rel: &str) -> String {
    format!("{}/../../tests/data/{rel}", env!("CARGO_MANIFEST_DIR"))
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

fn gcode(sub: &str, file: &Path, extra: &[&str]) -> Output {
    s2g().args(["gcode", sub]).arg(file).args(extra).output().unwrap()
}

/// Two rapids, three straight feeds and two half circles (one cw, one ccw) of radius 5.
const PROGRAM: &str = "\
G21 G90 G17
G0 X0 Y0 Z5
G1 Z-1 F100
G1 X10 F200
G2 X20 Y0 I5 J0
G1 Y-3
G3 X20 Y-13 J-5
G0 Z5
M30
";

/// Checks that every line of `text` reads `FILE:LINE:COL: message` and returns (line, col).
fn positions(text: &str, file: &str) -> Vec<(u64, u64)> {
    text.lines()
        .map(|l| {
            let rest =
                l.strip_prefix(file).and_then(|r| r.strip_prefix(':')).unwrap_or_else(|| panic!("{l:?}"));
            let mut it = rest.splitn(3, ':');
            let line: u64 = it.next().unwrap().parse().unwrap_or_else(|_| panic!("no line number: {l:?}"));
            let col: u64 = it.next().unwrap().parse().unwrap_or_else(|_| panic!("no column: {l:?}"));
            let msg = it.next().unwrap_or_else(|| panic!("no message: {l:?}"));
            assert!(msg.starts_with(' ') && msg.trim().len() > 3, "{l:?}");
            assert!(line >= 1 && col >= 1, "{l:?}");
            (line, col)
        })
        .collect()
}

#[test]
fn check_good_and_bad_files() {
    for good in ["cnc/programs/one-inch-circle_g20_N.nc", "cnc/programs/arc-zx-plane_g18.nc"] {
        let out = gcode("check", Path::new(&data(good)), &[]);
        assert_eq!(out.status.code(), Some(0), "{good}: {}", String::from_utf8_lossy(&out.stdout));
        assert!(out.stdout.is_empty(), "{good}: {}", String::from_utf8_lossy(&out.stdout));
    }
    let bad = data("cnc/odd/gcodeLexer_samples_comments.ngc");
    let out = gcode("check", Path::new(&bad), &[]);
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8(out.stdout).unwrap();
    let pos = positions(&text, &bad);
    assert!(pos.len() >= 3, "{text}");
    assert!(pos.contains(&(8, 2)) && text.contains("unclosed comment"), "{text}");
    for w in pos.windows(2) {
        assert!(w[0].0 <= w[1].0, "errors out of line order: {text}");
    }
    let bad = data("cnc/odd/cncjs_special-fields_checksums.gcode");
    let out = gcode("check", Path::new(&bad), &[]);
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(positions(&text, &bad), vec![(8, 16)], "{text}");
    assert!(text.contains("checksum mismatch"), "{text}");

    // A file written here: the missing number after Y (column 7 of line 2).
    let dir = tempfile::tempdir().unwrap();
    let mine = write(dir.path(), "b.ngc", "G21\nG1 X1 Y\nG1 X2 F100\n");
    let out = gcode("check", &mine, &[]);
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(positions(&text, mine.to_str().unwrap()), vec![(2, 7)], "{text}");
    // A file that cannot be read is an error, not a clean check.
    let out = gcode("check", &dir.path().join("missing.ngc"), &[]);
    assert!(!out.status.success());
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
}

#[test]
fn stats_of_a_written_program() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "p.ngc", PROGRAM);
    let out = gcode("stats", &file, &["--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["lines"], 9, "{v}");
    assert_eq!(v["errors"], 0, "{v}");
    assert_eq!(v["rapids"], 2, "{v}");
    assert_eq!(v["linears"], 3, "{v}");
    assert_eq!(v["arcs"], 2, "{v}");
    assert_eq!(v["tool_changes"], 0, "{v}");
    // End points (and the start at the origin); arcs' bulges are not in the box.
    assert_eq!(v["bbox_mm"]["min"], serde_json::json!([0.0, -13.0, -1.0]), "{v}");
    assert_eq!(v["bbox_mm"]["max"], serde_json::json!([20.0, 0.0, 5.0]), "{v}");
    let num = |k: &str| v[k].as_f64().unwrap_or_else(|| panic!("{k}: {v}"));
    let feed = 6.0 + 10.0 + 5.0 * PI + 3.0 + 5.0 * PI;
    assert!((num("feed_length_mm") - feed).abs() < 1e-9, "{v}");
    assert!((num("rapid_length_mm") - 11.0).abs() < 1e-9, "{v}");
    let t = 6.0 / 100.0 * 60.0 + (feed - 6.0) / 200.0 * 60.0 + 11.0 / 5000.0 * 60.0;
    assert!((num("estimated_time_s") - t).abs() < 1e-9 * t, "{v}");
    // A slower rapid rate changes only the rapid part.
    let out = gcode("stats", &file, &["--json", "--rapid", "1000"]);
    let w: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let t2 = t - 11.0 / 5000.0 * 60.0 + 11.0 / 1000.0 * 60.0;
    assert!((w["estimated_time_s"].as_f64().unwrap() - t2).abs() < 1e-9 * t2, "{w}");
    let out = gcode("stats", &file, &["--rapid", "0"]);
    assert!(!out.status.success());
}

fn motions(file: &Path) -> Vec<serde_json::Value> {
    let out = gcode("motions", file, &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8(out.stdout).unwrap();
    text.lines().map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l:?}: {e}"))).collect()
}

#[test]
fn motions_are_json_lines() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "p.ngc", PROGRAM);
    let ms = motions(&file);
    let moves: Vec<&serde_json::Value> =
        ms.iter().filter(|m| matches!(m["kind"].as_str(), Some("rapid" | "feed" | "arc"))).collect();
    let got: Vec<(u64, &str, Vec<f64>)> = moves
        .iter()
        .map(|m| {
            let to = m["to"].as_array().unwrap().iter().map(|c| c.as_f64().unwrap()).collect();
            (m["line"].as_u64().unwrap(), m["kind"].as_str().unwrap(), to)
        })
        .collect();
    let want: Vec<(u64, &str, Vec<f64>)> = vec![
        (2, "rapid", vec![0., 0., 5.]),
        (3, "feed", vec![0., 0., -1.]),
        (4, "feed", vec![10., 0., -1.]),
        (5, "arc", vec![20., 0., -1.]),
        (6, "feed", vec![20., -3., -1.]),
        (7, "arc", vec![20., -13., -1.]),
        (8, "rapid", vec![20., -13., 5.]),
    ];
    assert_eq!(got, want);
    assert_eq!(moves[1]["feed"], 100.0);
    assert_eq!(moves[2]["feed"], 200.0);
    let (cw, ccw) = (moves[3], moves[5]);
    assert_eq!(cw["center"], serde_json::json!([15.0, 0.0, -1.0]), "{cw}");
    assert_eq!(cw["direction"], "cw");
    assert_eq!(cw["plane"], "xy");
    assert_eq!(ccw["center"], serde_json::json!([20.0, -8.0, -1.0]), "{ccw}");
    assert_eq!(ccw["direction"], "ccw");
    assert_eq!(ccw["feed"], 200.0, "modal feed");
    assert_eq!(ms.last().unwrap()["kind"], "end");
    assert_eq!(ms.last().unwrap()["line"], 9);

    // Inches come out in millimetres; G91 moves are made absolute.
    let inch = write(dir.path(), "inch.ngc", "G20 G90\nG0 X1 Y2 Z0.5\nG1 X2 F10\nG91 G1 X1\n");
    let ms = motions(&inch);
    let close = |m: &serde_json::Value, want: [f64; 3]| {
        let to: Vec<f64> = m["to"].as_array().unwrap().iter().map(|c| c.as_f64().unwrap()).collect();
        assert!(to.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-9), "{m} vs {want:?}");
    };
    close(&ms[0], [25.4, 50.8, 12.7]);
    close(&ms[1], [50.8, 50.8, 12.7]);
    close(&ms[2], [76.2, 50.8, 12.7]);
    assert!((ms[1]["feed"].as_f64().unwrap() - 254.0).abs() < 1e-9, "{}", ms[1]);

    // Errors go to stderr as file:line:col and fail the command.
    let bad = write(dir.path(), "b.ngc", "G21\nG1 X1 Y\n");
    let out = gcode("motions", &bad, &[]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(positions(&err, bad.to_str().unwrap()), vec![(2, 7)], "{err}");
}
