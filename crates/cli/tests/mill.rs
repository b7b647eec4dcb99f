//! `s2g mill`: the files and report it writes, reproducibility, and errors.

use std::process::Command;

fn s2g() -> Command {
    Command::new(env!("CARGO_BIN_EXE_s2g"))
}

fn data(rel: &str) -> String {
    format!("{}/../../tests/data/{rel}", env!("CARGO_MANIFEST_DIR"))
}

/// A small, fast run: the LetterBlock on a coarse grid with two setups.
fn mill_letterblock(dir: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let mut cmd = s2g();
    cmd.args(["mill", &data("meshes/openscad/openscad_Basics_LetterBlock.stl")])
        .args(["--res", "48", "--setups", "2", "--points", "1024"])
        .arg("-o")
        .arg(dir.join("block.ngc"))
        .args(extra);
    cmd.output().unwrap()
}

/// One setup of the 65 mm cube (100 mm in the paper preset) with a fixed `action`,
/// written into `dir`.
fn mill_cube_with(dir: &std::path::Path, action: &str, extra: &[&str]) -> std::process::Output {
    s2g()
        .args(["mill", &data("meshes/openscad/openscad_Basics_text_on_cube.stl")])
        .args(["--policy", action, "--setups", "1"])
        .arg("-o")
        .arg(dir.join("cube.ngc"))
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn writes_programs_report_residual_and_render() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (report, residual, render) = (d.join("r.json"), d.join("res.stl"), d.join("r.png"));
    let out = mill_letterblock(
        d,
        &[
            "--json",
            "--report",
            report.to_str().unwrap(),
            "--residual",
            residual.to_str().unwrap(),
            "--render",
            render.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}: {stderr}", out.status);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "iou",
        "f1",
        "chamfer_x1000",
        "normal_consistency",
        "machining_time_s",
        "gouge_voxels",
        "rapid_collisions",
        "setups",
        "stage_seconds",
        "programs",
        "residual",
        "render",
    ] {
        assert!(v.get(key).is_some(), "report lacks {key}: {v}");
    }
    assert_eq!(v["gouge_voxels"], 0, "{v}");
    assert_eq!(v["rapid_collisions"], 0, "{v}");
    assert!(v["iou"].as_f64().unwrap() > 0.8, "{v}");
    // The default policy is the shipped learned one, and it chose every setup.
    assert_eq!(v["policy"], "learned", "{v}");
    let setups = v["setups"].as_array().unwrap();
    assert_eq!(setups.len(), 2, "{v}");
    // One program per setup, each stating its fixture rotation, each with the lines counted.
    let programs = v["programs"].as_array().unwrap();
    assert_eq!(programs.len(), 2);
    for (p, s) in programs.iter().zip(setups) {
        let text = std::fs::read_to_string(p.as_str().unwrap()).unwrap();
        assert!(text.contains("rotate part so that tool axis"), "{p}: no fixture comment");
        assert_eq!(text.lines().count() as u64, s["program_lines"].as_u64().unwrap(), "{p}");
    }
    // The report file is the printed report; the residual loads; the render is a PNG.
    let file: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(file, v);
    let check = s2g().args(["inspect", "--json"]).arg(&residual).output().unwrap();
    assert!(check.status.success(), "{}", String::from_utf8_lossy(&check.stderr));
    let mesh: serde_json::Value = serde_json::from_slice(&check.stdout).unwrap();
    assert_eq!(mesh["closed"], true, "residual mesh: {mesh}");
    assert!(std::fs::read(&render).unwrap().starts_with(b"\x89PNG\r\n\x1a\n"));
}

#[test]
fn reproducible_runs_give_identical_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let a = mill_letterblock(dir.path(), &["--json", "--reproducible"]);
    let program_a = std::fs::read(dir.path().join("block.1.ngc")).unwrap();
    let b = mill_letterblock(dir.path(), &["--json", "--reproducible"]);
    let program_b = std::fs::read(dir.path().join("block.1.ngc")).unwrap();
    assert!(a.status.success() && b.status.success());
    assert_eq!(a.stdout, b.stdout, "reports differ");
    assert_eq!(program_a, program_b, "programs differ");
}

#[test]
fn bad_input_is_one_line_and_a_failure_exit() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.stl");
    let empty = data("meshes/stl_edge_cases/stl-models/broken/empty.stl");
    // One open triangle: no part to machine (and no warning line besides the error).
    let sheet = data("meshes/stl_edge_cases/stl-models/polytopes/triangle.ascii.stl");
    let cases: [(Vec<String>, &str); 7] = [
        (vec!["mill".into(), missing.display().to_string()], "missing.stl"),
        (vec!["mill".into(), empty.clone()], "empty.stl"),
        (vec!["mill".into(), sheet, "--res".into(), "32".into()], "encloses no voxel"),
        (vec!["mill".into(), "--policy".into(), "fixed:abc".into()], "fixed"),
        (vec!["mill".into(), "--setups".into(), "many".into()], "setups"),
        (vec!["mill".into(), "--layout".into(), "diagonal".into()], "layout"),
        (
            vec!["mill".into(), "--layout".into(), "ac".into(), "--tilt-range".into(), "-30".into()],
            "tilt-range",
        ),
    ];
    for (args, needle) in cases {
        let out = s2g().args(&args).current_dir(dir.path()).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{args:?}: expected one line, got {stderr:?}");
        assert!(lines[0].starts_with("s2g: error:") && lines[0].contains(needle), "{args:?}: {stderr}");
    }
}

/// `--layout ac|bc` writes one 3+2 program at `-o`, with a rotary block per setup; the
/// report still lists every setup (with its angles) and the one program path.
#[test]
fn rotary_layout_writes_one_program_with_rotary_words() {
    let dir = tempfile::tempdir().unwrap();
    for (layout, letter) in [("ac", 'A'), ("bc", 'B')] {
        let out = mill_letterblock(dir.path(), &["--json", "--layout", layout]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{layout}: exit {:?}: {stderr}", out.status);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["layout"], layout, "{v}");
        assert_eq!(v["gouge_voxels"], 0, "{layout}: {v}");
        assert_eq!(v["rapid_collisions"], 0, "{layout}: {v}");
        let programs = v["programs"].as_array().unwrap();
        let expected = dir.path().join("block.ngc");
        assert_eq!(programs.len(), 1, "{layout}: {v}");
        assert_eq!(programs[0].as_str().unwrap(), expected.display().to_string());
        let text = std::fs::read_to_string(&expected).unwrap();
        let setups = v["setups"].as_array().unwrap();
        assert_eq!(setups.len(), 2, "{layout}: {v}");
        let blocks =
            text.lines().filter(|l| l.starts_with(&format!("G0 {letter}")) && l.contains(" C")).count();
        assert_eq!(blocks, setups.len(), "{layout}: one rotary block per setup");
        // The setups' sections add up to the program.
        let lines: u64 = setups.iter().map(|s| s["program_lines"].as_u64().unwrap()).sum();
        assert_eq!(lines, text.lines().count() as u64, "{layout}");
        for s in setups {
            assert_eq!(s["rotary_deg"].as_array().map(Vec::len), Some(3), "{layout}: {s}");
        }
    }
}

/// A setup the machine's tilt axis cannot reach is one error line and exit 1.
#[test]
fn unreachable_setup_is_one_line_and_a_failure_exit() {
    let dir = tempfile::tempdir().unwrap();
    let out = mill_letterblock(dir.path(), &["--layout", "bc", "--tilt-range", "0,0"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one line, got {stderr:?}");
    assert!(lines[0].starts_with("s2g: error:") && lines[0].contains("B range"), "{stderr}");
    assert!(!dir.path().join("block.ngc").exists(), "no program for an unreachable setup");
}

/// An open mesh (the Utah teapot, 64 boundary edges) mills with one warning line that
/// names it and what to expect; a closed one mills without (the error test above finds
/// stderr's only line to be the error).
#[test]
fn an_open_mesh_mills_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let out = s2g()
        .args(["mill", &data("meshes/classic/utah_teapot.stl")])
        .args(["--res", "32", "--setups", "1", "--points", "1024", "--policy", "heuristic"])
        .arg("-o")
        .arg(dir.path().join("teapot.ngc"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(1), "{stderr}");
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(warnings[0].contains("utah_teapot.stl is not closed (64 boundary edges)"), "{stderr}");
}

/// `--time-limit` stops a run that would take far longer (a 0.1 mm end mill on 0.1 mm
/// layers over the cube, 100 mm in the paper preset) with one line naming the stage, exit
/// status 1, and no program or partial file left behind.
#[test]
fn a_time_limit_stops_the_run_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let started = std::time::Instant::now();
    let out = mill_cube_with(dir.path(), "fixed:0.1,0.1,zigzag", &["--time-limit", "3"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "one line: {stderr}");
    // Which stage the limit meets depends on the machine's speed (orientation on a loaded
    // one, planning otherwise); the message names it either way.
    assert!(stderr.contains("time limit of 3 s reached while "), "{stderr}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.is_empty(), "files left behind: {left:?}");
    // It stopped soon after the limit (not a timing assertion on the work itself: without
    // the limit this run writes for hours).
    assert!(started.elapsed().as_secs_f64() < 60.0, "took {:?}", started.elapsed());
}

/// Programs are streamed to their files as they are planned: what `s2g mill` writes is
/// byte for byte what the library keeps in memory for the same run.
#[test]
fn streamed_programs_are_the_library_s_programs() {
    let dir = tempfile::tempdir().unwrap();
    let out = mill_letterblock(dir.path(), &["--policy", "heuristic"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let mesh = shape2gcode::geom::load_mesh(data("meshes/openscad/openscad_Basics_LetterBlock.stl")).unwrap();
    let opts = shape2gcode::MillOptions {
        resolution: 48,
        setups: shape2gcode::SetupCount::Exactly(2),
        orient_points: 1024,
        ..shape2gcode::MillOptions::default()
    };
    let milled =
        shape2gcode::mill(&mesh, &mut shape2gcode::HeuristicPolicy::default(), &opts, &mut |_| {}).unwrap();
    assert_eq!(milled.programs.len(), 2);
    for (i, text) in milled.programs.iter().enumerate() {
        let written = std::fs::read_to_string(dir.path().join(format!("block.{}.ngc", i + 1))).unwrap();
        assert!(written == *text, "program {} differs from the library's", i + 1);
    }
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 2, "only the two programs: {names:?}");
}

/// An action far too fine for its part is refused before planning, in one line that says
/// how much machining it would be, with exit status 1 and nothing written; `--max-hours`
/// raises the limit (the same run then plans, and the time limit stops it).
#[test]
fn an_absurdly_fine_action_is_refused_before_planning() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| mill_cube_with(dir.path(), "fixed:0.05,0.05,zigzag", extra);
    let out = run(&[]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "one line: {stderr}");
    assert!(stderr.contains("would machine for up to") && stderr.contains("limit of 10000 h"), "{stderr}");
    let out = run(&["--max-hours", "100000", "--time-limit", "2"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("time limit of 2 s reached"), "{stderr}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "nothing written");
}

/// The X extent of a program's moves.
fn x_extent(program: &str) -> f64 {
    let xs: Vec<f64> = program
        .lines()
        .filter(|l| l.starts_with('G'))
        .flat_map(|l| l.split_whitespace().filter_map(|w| w.strip_prefix('X')?.parse::<f64>().ok()))
        .collect();
    xs.iter().copied().fold(f64::MIN, f64::max) - xs.iter().copied().fold(f64::MAX, f64::min)
}

/// `--units`, `--scale` and `--size` size the part in the shop preset (the 65 mm cube read
/// as inches and scaled by 0.1 is 65 x 25.4 x 0.1 = 165 mm wide; `--size 20` makes it
/// 20 mm), and the paper preset refuses them in one line.
#[test]
fn units_scale_and_size_set_the_part_s_size_in_the_shop_preset() {
    let dir = tempfile::tempdir().unwrap();
    let action = "fixed:4,8,zigzag";
    let shop = ["--preset", "shop", "--no-finish", "--res", "48", "--rest-roughing", "0"];
    for (extra, side) in
        [(&["--units", "in", "--scale", "0.1"][..], 65.0 * 2.54), (&["--size", "20"][..], 20.0)]
    {
        let args: Vec<&str> = shop.iter().chain(extra).copied().collect();
        let out = mill_cube_with(dir.path(), action, &args);
        assert!(out.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&out.stderr));
        let program = std::fs::read_to_string(dir.path().join("cube.ngc")).unwrap();
        let x = x_extent(&program);
        // The tool centre runs around the part, one radius (4 mm) out and some clearance.
        assert!(x > side && x < side + 30.0, "{extra:?}: X extent {x} for a part {side} mm wide");
    }
    let out = mill_cube_with(dir.path(), action, &["--units", "in"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("shop preset"), "{err}");
}

/// The programs `dir` holds (`block.ngc`, or `block.1.ngc`, ... per setup), joined, and
/// their arc blocks (G2/G3, the helical entries among them).
fn block_programs(dir: &std::path::Path) -> (String, usize) {
    let mut names: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "ngc"))
        .collect();
    names.sort();
    let text: String = names.iter().map(|p| std::fs::read_to_string(p).unwrap()).collect();
    let arcs = text.lines().filter(|l| l.starts_with("G2 ") || l.starts_with("G3 ")).count();
    (text, arcs)
}

/// Issue 35's arcs: the shop preset fits them at 0.005 mm unless `--arc-tolerance 0` says
/// otherwise (more arcs, fewer lines); the paper preset writes straight moves by default,
/// the same bytes as `--arc-tolerance 0`.
#[test]
fn the_shop_preset_fits_arcs_by_default_and_the_paper_preset_does_not() {
    let run = |extra: &[&str]| {
        let dir = tempfile::tempdir().unwrap();
        let out = mill_letterblock(dir.path(), extra);
        assert!(out.status.success(), "{extra:?}: {}", String::from_utf8_lossy(&out.stderr));
        block_programs(dir.path())
    };
    let shop = ["--preset", "shop", "--no-finish"];
    let (fitted, fitted_arcs) = run(&shop);
    let (straight, straight_arcs) = run(&[&shop[..], &["--arc-tolerance", "0"]].concat());
    assert!(
        fitted_arcs > straight_arcs && fitted.lines().count() < straight.lines().count(),
        "shop: {fitted_arcs} arcs in {} lines by default, {straight_arcs} in {} straight",
        fitted.lines().count(),
        straight.lines().count()
    );
    let (paper, _) = run(&[]);
    let (paper_straight, _) = run(&["--arc-tolerance", "0"]);
    assert!(paper == paper_straight, "the paper preset's default programs are not straight");
}
