//! `s2g inspect`: text and JSON reports, the bundled default, and errors.

use std::process::Command;

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn data(rel: &str) -> String {
    format!("{}/../../tests/data/{rel}", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn json_report_of_a_cube() {
    let out = s2g().args(["inspect", "--json", &data("fdm/models/cube10.stl")]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["triangles"], 12);
    assert_eq!(v["closed"], true);
    assert_eq!(v["manifold"], true);
    assert_eq!(v["consistently_oriented"], true);
    assert_eq!(v["bodies"], 1);
    assert!((v["volume"].as_f64().unwrap() - 1000.0).abs() < 1e-9, "{v}");
    assert_eq!(v["bbox"]["min"], serde_json::json!([0.0, 0.0, 0.0]));
    assert_eq!(v["bbox"]["max"], serde_json::json!([10.0, 10.0, 10.0]));
}

#[test]
fn default_is_the_bundled_bunny() {
    let out = s2g().args(["inspect", "--json"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["triangles"], 3674);
    assert_eq!(v["closed"], true);
    let text = s2g().arg("inspect").output().unwrap();
    assert!(text.status.success());
    let text = String::from_utf8(text.stdout).unwrap();
    assert!(
        text.contains("triangles:              3674") && text.contains("closed:                 yes"),
        "{text}"
    );
}

#[test]
fn a_broken_file_is_one_line_on_stderr_and_a_failure() {
    let file = data("meshes/stl_edge_cases/stl-models/broken/fourVertices.ascii.stl");
    let out = s2g().args(["inspect", &file]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("fourVertices.ascii.stl:2: facet has 4 vertices"), "{err}");
    let out = s2g().args(["inspect", "/nonexistent/mesh.stl"]).output().unwrap();
    assert!(!out.status.success());
    // The system's reason appears once: the message does not repeat the cause it chains.
    let cause = std::fs::File::open("/nonexistent/mesh.stl").unwrap_err().to_string();
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_eq!(err.matches(&cause).count(), 1, "{cause:?} in {err}");
}
