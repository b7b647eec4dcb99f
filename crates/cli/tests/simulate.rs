//! `s2g simulate`: removed volume against a closed form, time, residual mesh, gouges,
//! rapid and holder collisions, and errors.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

/// Stock of every run here: 40 x 20 x 10 mm.
const STOCK: &str = "box:0,0,0,40,20,10";

/// A straight slot with a flat tool: plunge at X8 Y10 to Z6 (line 3), feed to X30 (line 4),
/// rapid out (line 5). 4 mm deep, 22 mm long.
const SLOT: &str = "G21 G90\nG0 X8 Y10 Z15\nG1 Z6 F600\nG1 X30\nG0 Z15\nM30\n";

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// An ASCII STL of the box [lo, hi], outward normals.
fn box_stl(dir: &Path, name: &str, lo: [f64; 3], hi: [f64; 3]) -> PathBuf {
    let v = |i: usize| {
        [
            if i & 1 == 0 { lo[0] } else { hi[0] },
            if i & 2 == 0 { lo[1] } else { hi[1] },
            if i & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    // Two counter-clockwise (seen from outside) triangles per face.
    let faces = [
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
    ];
    let mut s = String::from("solid box\n");
    for f in faces {
        for tri in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            s.push_str(" facet normal 0 0 0\n  outer loop\n");
            for i in tri {
                let p = v(i);
                s.push_str(&format!("   vertex {} {} {}\n", p[0], p[1], p[2]));
            }
            s.push_str("  endloop\n endfacet\n");
        }
    }
    s.push_str("endsolid box\n");
    write(dir, name, &s)
}

fn simulate(program: &Path, extra: &[&str]) -> Output {
    s2g().arg("simulate").arg(program).args(["--stock", STOCK]).args(extra).output().unwrap()
}

fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "exit {:?}: {}", out.status, String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn f(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} missing or not a number: {v}"))
}

#[test]
fn slot_volume_time_and_residual() {
    let dir = tempfile::tempdir().unwrap();
    let prog = write(dir.path(), "slot.ngc", SLOT);
    let residual = dir.path().join("residual.stl");
    let out =
        simulate(&prog, &["--tool", "flat:3", "--res", "80", "--json", "-o", residual.to_str().unwrap()]);
    let v = json(&out);
    for key in [
        "removed_volume_mm3",
        "removed_voxels",
        "gouge_voxels",
        "rapid_collisions",
        "holder_collisions",
        "machining_time_s",
        "seconds",
    ] {
        assert!(v.get(key).is_some(), "report lacks {key}: {v}");
    }
    assert_eq!(v["dims"], serde_json::json!([80, 40, 20]), "{v}");
    let h = f(&v, "voxel_mm");
    assert!((h - 0.5).abs() < 1e-12, "{v}");
    // Stadium prism: r = 3, L = 22, depth 4 (the plunge lies inside it).
    let (r, l, d) = (3.0, 22.0, 4.0);
    let base = 2.0 * r * l + PI * r * r;
    let want = base * d;
    let area = 2.0 * base + (2.0 * l + 2.0 * PI * r) * d;
    let got = f(&v, "removed_volume_mm3");
    assert!((got - want).abs() <= area * h / 2.0, "removed {got} mm3, closed form {want}");
    let voxels = v["removed_voxels"].as_u64().unwrap();
    assert!((got - voxels as f64 * h * h * h).abs() < 1e-9, "{v}");
    assert_eq!(v["gouge_voxels"], 0);
    assert_eq!(v["rapid_collisions"], serde_json::json!([]));
    assert_eq!(v["holder_collisions"], serde_json::json!([]));
    // Feed 9 + 22 mm at 600 mm/min; rapid 9 mm at the default 5000 mm/min (the first
    // rapid only positions the tool: its start is unknown).
    assert!((f(&v, "feed_length_mm") - 31.0).abs() < 1e-9, "{v}");
    assert!((f(&v, "rapid_length_mm") - 9.0).abs() < 1e-9, "{v}");
    let t = 31.0 / 600.0 * 60.0 + 9.0 / 5000.0 * 60.0;
    let time = f(&v, "machining_time_s");
    assert!((time - t).abs() <= 1e-6 * t, "machining time {time} s, want {t}");
    assert!(f(&v, "seconds") >= 0.0);

    // The residual stock is a closed mesh holding the stock minus what was removed.
    let check = s2g().args(["inspect", "--json"]).arg(&residual).output().unwrap();
    let mesh = json(&check);
    assert_eq!(mesh["closed"], true, "{mesh}");
    assert_eq!(mesh["manifold"], true, "{mesh}");
    assert_eq!(mesh["bodies"], 1, "{mesh}");
    let vol = f(&mesh, "volume");
    let left = 8000.0 - got;
    assert!((vol - left).abs() <= area * h / 2.0, "residual mesh volume {vol}, stock left {left}");
}

#[test]
fn dexel_carver_agrees_on_a_three_axis_slot() {
    let dir = tempfile::tempdir().unwrap();
    let prog = write(dir.path(), "slot.ngc", SLOT);
    let exact = json(&simulate(&prog, &["--tool", "flat:3", "--res", "40", "--json"]));
    let dexel = json(&simulate(&prog, &["--tool", "flat:3", "--res", "40", "--json", "--carver", "dexel"]));
    assert!(exact["removed_voxels"].as_u64().unwrap() > 0);
    assert_eq!(exact["removed_voxels"], dexel["removed_voxels"]);
}

#[test]
fn a_target_the_slot_cuts_into_is_gouged_at_the_plunge() {
    let dir = tempfile::tempdir().unwrap();
    let prog = write(dir.path(), "slot.ngc", SLOT);
    // Target up to z = 7: the slot's lowest millimetre (of four) is in it.
    let deep = box_stl(dir.path(), "deep.stl", [0., 0., 0.], [40., 20., 7.]);
    let v = json(&simulate(
        &prog,
        &["--tool", "flat:3", "--res", "80", "--json", "--target", deep.to_str().unwrap()],
    ));
    let gouge = v["gouge_voxels"].as_u64().unwrap();
    assert!(gouge > 0, "{v}");
    assert_eq!(4 * gouge, v["removed_voxels"].as_u64().unwrap(), "{v}");
    assert_eq!(v["first_gouge_line"], 3, "{v}");
    let p = f(&v["rewards"], "preservation");
    assert!(p < 1.0 && p > 0.9, "{v}");
    // Target up to z = 5: untouched.
    let low = box_stl(dir.path(), "low.stl", [0., 0., 0.], [40., 20., 5.]);
    let v = json(&simulate(
        &prog,
        &["--tool", "flat:3", "--res", "80", "--json", "--target", low.to_str().unwrap()],
    ));
    assert_eq!(v["gouge_voxels"], 0, "{v}");
    assert_eq!(v["first_gouge_line"], serde_json::Value::Null, "{v}");
    assert_eq!(f(&v["rewards"], "preservation"), 1.0, "{v}");
    let iou = f(&v["rewards"], "final_iou");
    assert!(iou > 0.0 && iou < 1.0, "{v}");
}

#[test]
fn a_rapid_through_stock_and_a_short_flute_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    // Line 3 rapids 5 mm down into the stock.
    let prog = write(dir.path(), "rapid.ngc", "G21 G90\nG0 X8 Y10 Z15\nG0 Z5\nG0 Z15\nM30\n");
    let v = json(&simulate(&prog, &["--tool", "flat:3", "--res", "40", "--json"]));
    assert_eq!(v["rapid_collisions"], serde_json::json!([3]), "{v}");
    assert!(v["rapid_collision_voxels"].as_u64().unwrap() > 0, "{v}");
    // A 2 mm flute on a 4 mm deep slot: the shank meets stock on the slot move (line 4),
    // not on the plunge, whose flutes swept the whole column first. The flutes leave the
    // top 2 mm standing, so the retract (line 5) rapids through it.
    let slot = write(dir.path(), "slot.ngc", SLOT);
    let full = json(&simulate(&slot, &["--tool", "flat:3", "--res", "40", "--json"]));
    let v = json(&simulate(&slot, &["--tool", "flat:3:2", "--res", "40", "--json"]));
    assert_eq!(v["holder_collisions"], serde_json::json!([4]), "{v}");
    assert!(v["holder_collision_voxels"].as_u64().unwrap() > 0, "{v}");
    assert_eq!(v["rapid_collisions"], serde_json::json!([5]), "{v}");
    assert!(v["removed_voxels"].as_u64() < full["removed_voxels"].as_u64(), "{v}\n{full}");
    let v = json(&simulate(&slot, &["--tool", "flat:3:2", "--res", "40", "--json", "--no-holder-check"]));
    assert_eq!(v["holder_collisions"], serde_json::json!([]), "{v}");
}

fn one_line_failure(out: &Output, needle: &str) {
    assert!(!out.status.success(), "expected a failure: {}", String::from_utf8_lossy(&out.stdout));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(needle), "{needle:?} not in {err}");
}

#[test]
fn malformed_programs_and_bad_options_fail_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let bad = write(dir.path(), "bad.ngc", "G21 G90\nG0 X8 Y10 Z15\nG1 X30 Q\n");
    one_line_failure(&simulate(&bad, &["--tool", "flat:3", "--res", "40", "--json"]), "bad.ngc:3:");
    let slot = write(dir.path(), "slot.ngc", SLOT);
    for tool in ["flat:abc", "cone:1", "flat:-1", "flat", "bull:2"] {
        one_line_failure(&simulate(&slot, &["--tool", tool, "--res", "40"]), &format!("--tool {tool}"));
    }
    let out =
        s2g().arg("simulate").arg(&slot).args(["--stock", "box:0,0,0,40", "--res", "40"]).output().unwrap();
    one_line_failure(&out, "six numbers");
    // A file that cannot be opened: its name and the system's reason, once.
    let missing = dir.path().join("missing.ngc");
    let cause = std::fs::File::open(&missing).unwrap_err().to_string();
    let out = simulate(&missing, &["--res", "40"]);
    one_line_failure(&out, "missing.ngc");
    assert_eq!(String::from_utf8_lossy(&out.stderr).matches(&cause).count(), 1, "{cause}");
}
