//! `s2g reconstruct`: solid and tubes from FDM G-code, JSON report, 3MF output, truncated
//! input, errors.

use std::process::Command;

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn data(rel: &str) -> String {
    format!("{}/../../tests/data/{rel}", env!("CARGO_MANIFEST_DIR"))
}

const CUBE: &str = "fdm/gcode/prusa_cube10_infill20_rectilinear.gcode";

#[test]
fn solid_and_tubes_with_json_reports() {
    let dir = tempfile::tempdir().unwrap();
    for (mode, profile, out) in [("--solid", "slot", "solid.stl"), ("--tubes", "circle", "tubes.ply")] {
        let path = dir.path().join(out);
        let o = s2g()
            .args(["reconstruct", &data(CUBE), mode, "--profile", profile, "--json", "-o"])
            .arg(&path)
            .output()
            .unwrap();
        assert!(o.status.success(), "{mode}: {}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["watertight"], true, "{mode}: {v}");
        assert_eq!(v["layers"], 50, "{mode}");
        let err = v["volume_error"].as_f64().unwrap();
        assert!(err.abs() < 0.03, "{mode}: volume error {err}");
        assert!(std::fs::metadata(&path).unwrap().len() > 1000, "{mode}: {} written", path.display());
    }
    // Fixed sizes and the layer render.
    let png = dir.path().join("layer.png");
    let o = s2g()
        .args(["reconstruct", &data(CUBE), "--tubes", "--profile", "rect", "--width", "0.45"])
        .args(["--layer-height", "0.2", "--layer", "3", "--layer-png"])
        .arg(&png)
        .arg("-o")
        .arg(dir.path().join("t.obj"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
}

#[test]
fn solid_as_3mf_loads_back_watertight_with_the_reported_volume() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("solid.3mf");
    let o = s2g().args(["reconstruct", &data(CUBE), "--solid", "--json", "-o"]).arg(&path).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let mesh = shape2gcode::geom::load_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mesh.triangles().len() as u64, v["triangles"].as_u64().unwrap());
    let rep = shape2gcode::geom::report(&mesh);
    assert!(rep.closed && rep.manifold && rep.consistently_oriented, "{rep:?}");
    assert_eq!(v["watertight"], true);
    let volume = v["solid_volume_mm3"].as_f64().unwrap();
    assert!((rep.volume - volume).abs() <= 1e-6 * volume, "{} vs {volume}", rep.volume);
    let extruded = v["extruded_volume_mm3"].as_f64().unwrap();
    assert!((rep.volume / extruded - 1.0).abs() < 0.03, "{} vs extruded {extruded}", rep.volume);
    // The same program gives the same bytes.
    let again = dir.path().join("again.3mf");
    let o = s2g().args(["reconstruct", &data(CUBE), "--solid", "-o"]).arg(&again).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read(&path).unwrap() == std::fs::read(&again).unwrap(), "3MF output is deterministic");
}

#[test]
fn truncated_program_warns_and_bad_arguments_fail() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data(CUBE)).unwrap();
    let cut = dir.path().join("cut.gcode");
    let mut end = text.len() / 2;
    while text.as_bytes()[end] == b'\n' || text.as_bytes()[end - 1] == b'\n' {
        end += 1;
    }
    std::fs::write(&cut, &text[..end]).unwrap();
    let line = text[..end].lines().count();
    let o = s2g().arg("reconstruct").arg(&cut).arg("-o").arg(dir.path().join("c.stl")).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains(&format!("line {line}:")), "warning names line {line}: {stderr}");
    for bad in [
        vec![
            "reconstruct".to_string(),
            data(CUBE),
            "-o".into(),
            dir.path().join("x.3ds").display().to_string(),
        ],
        vec!["reconstruct".into(), data(CUBE), "--width=-2".into(), "-o".into(), "x.stl".into()],
        vec!["reconstruct".into(), "/nonexistent.gcode".into(), "-o".into(), "x.stl".into()],
    ] {
        let o = s2g().args(&bad).current_dir(dir.path()).output().unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{bad:?} should fail");
        assert!(e.starts_with("s2g: error:") && e.trim_end().lines().count() == 1, "{bad:?}: {e}");
    }
}
