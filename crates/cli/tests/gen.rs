//! `s2g gen`: parts and manifest, the same bytes per seed, the shop parts, bad options.

use std::path::Path;
use std::process::Command;

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn read(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap()
}

#[test]
fn parts_and_manifest_are_the_same_bytes_per_seed() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    for dir in [&a, &b] {
        let out = s2g()
            .args(["gen", "--count", "6", "--seed", "42", "--size", "80", "--out"])
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let manifest: serde_json::Value = serde_json::from_slice(&read(a.path(), "manifest.json")).unwrap();
    let parts = manifest["parts"].as_array().unwrap();
    assert_eq!(parts.len(), 6);
    assert_eq!(manifest["seed"], 42);
    for p in parts {
        let file = p["file"].as_str().unwrap();
        assert_eq!(read(a.path(), file), read(b.path(), file), "{file}");
        assert!(p["volume"].as_f64().unwrap() > 0.0);
        assert!(!p["features"].as_array().unwrap().is_empty());
        let mesh = shape2gcode::geom::load_mesh(a.path().join(file)).unwrap();
        let r = shape2gcode::geom::report(&mesh);
        assert!(r.closed && r.manifold && r.consistently_oriented, "{file}");
        let v = p["volume"].as_f64().unwrap();
        // Turned parts are rounded to f32 by STL; the others are stored exactly.
        assert!((r.volume - v).abs() <= 1e-6 * v, "{file}: {} vs {v}", r.volume);
    }
    assert_eq!(read(a.path(), "manifest.json"), read(b.path(), "manifest.json"));
}

#[test]
fn shop_writes_the_five_named_parts() {
    let dir = tempfile::tempdir().unwrap();
    let out = s2g().args(["gen", "--kind", "shop", "--out"]).arg(dir.path()).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for name in ["flanged_bushing", "l_bracket", "pocketed_plate", "stepped_boss", "t_slot_block"] {
        assert!(dir.path().join(format!("{name}.stl")).is_file(), "{name}");
    }
}

#[test]
fn bad_options_are_one_line_and_a_failure() {
    let dir = tempfile::tempdir().unwrap();
    for bad in [
        &["--size", "-5"][..],
        &["--size", "NaN"],
        &["--size", "0"],
        &["--kind", "shop", "--count", "9"],
        &["--kind", "shop", "--size", "50"],
    ] {
        let out = s2g().arg("gen").args(bad).arg("--out").arg(dir.path()).output().unwrap();
        assert!(!out.status.success(), "{bad:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(err.lines().count(), 1, "{bad:?}: {err}");
        assert!(err.starts_with("s2g: error:"), "{bad:?}: {err}");
    }
    let out = s2g().args(["gen", "--kind", "cube", "--out"]).arg(dir.path()).output().unwrap();
    assert!(!out.status.success());
    // Zero parts is a valid request: an empty manifest.
    let out = s2g().args(["gen", "--count", "0", "--out"]).arg(dir.path()).output().unwrap();
    assert!(out.status.success());
    let manifest: serde_json::Value = serde_json::from_slice(&read(dir.path(), "manifest.json")).unwrap();
    assert_eq!(manifest["parts"].as_array().unwrap().len(), 0);
}
