//! Feature programs (seed 001): the three example jobs in `assets/jobs` through the rules, the
//! writers, LinuxCNC `rs274` and the voxel simulator.

use std::path::{Path, PathBuf};

use shape2gcode::gcode::{Dialect, ParseOptions, Stats, parse_str};
use shape2gcode::toolpath::features::FeatureKind;
use shape2gcode::{FeatureProgram, JobSpec, feature_program, load_job, parse_job};

use super::common::rs274_errors;

const JOBS: [&str; 3] = ["seed_pocket", "bracket", "plate"];
const VOXEL: f64 = 0.25;

fn job_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/jobs").join(format!("{name}.toml"))
}

fn program(name: &str) -> (JobSpec, FeatureProgram) {
    let spec = load_job(job_path(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    let p = feature_program(&spec).unwrap_or_else(|e| panic!("{name}: {e}"));
    (spec, p)
}

/// The numbered blocks of a program, without their `N` words.
fn blocks(text: &str) -> Vec<String> {
    let mut expect = 10;
    text.lines()
        .map(|l| {
            let (n, rest) = l.split_once(' ').unwrap_or((l, ""));
            assert_eq!(n, format!("N{expect}"), "block numbers must run N10, N20, ...: {l}");
            expect += 10;
            rest.to_owned()
        })
        .collect()
}

#[test]
fn worked_example_rules_and_structure() {
    let (_, p) = program("seed_pocket");
    let s = &p.plan.summaries[0];
    assert_eq!(s.cuts, 2, "m");
    assert!((s.depth_of_cut - 2.5).abs() < 1e-12, "d = {}", s.depth_of_cut);
    assert_eq!(s.passes, 4, "N");
    assert!((s.stepover - 8.067).abs() < 5e-4, "Q = {}", s.stepover);
    assert!((s.pass_length - 39.2).abs() < 1e-9, "pass length {}", s.pass_length);
    // Roughing keeps R + S from the walls, finishing R: tool centres X17.5..57.5, Y17.5..42.5.
    assert!((s.min[0] - 17.5).abs() < 1e-9 && (s.max[0] - 57.5).abs() < 1e-9, "{:?} {:?}", s.min, s.max);
    assert!((s.min[1] - 17.5).abs() < 1e-9 && (s.max[1] - 42.5).abs() < 1e-9, "{:?} {:?}", s.min, s.max);
    assert!((s.min[2] + 5.0).abs() < 1e-9 && (s.max[2] - 3.0).abs() < 1e-9, "{:?} {:?}", s.min, s.max);

    let text = p.gcode(Dialect::LinuxCnc).expect("writes");
    let b = blocks(&text);
    // The seed's structure, in order.
    let order = [
        "G17 G21 G40",
        "T1 M6",
        "G43 H1",
        "S1200 M3",
        "G0 X17.9 Y17.9 Z3",
        "M8",
        "G1 Z-2.5 F90",
        "X57.1",
        "Y25.9667",
        "X17.9",
        "G0 Z3",
        "G1 Z-5",
        "G0 Z3",
        "M1",
        "T2 M6",
        "G43 H2",
        "S1500 M3",
        "X37.5 Y30",
        "G1 Z-5 F70",
        "Y17.5",
        "X57.5",
        "Y42.5",
        "X17.5",
        "Y17.5",
        "X37.5",
        "G0 Z3",
        "X0 Y0",
        "M9",
        "M5",
        "M30",
    ];
    let mut at = 0;
    for want in order {
        let found = b[at..].iter().position(|l| l.starts_with(want));
        let Some(i) = found else { panic!("block '{want}' missing after block {at} in\n{text}") };
        at += i + 1;
    }
    assert_eq!(at, b.len(), "M30 is the last block");
    // 2 cuts x 4 passes of 39.2 mm along X at feed.
    let passes = b.iter().filter(|l| l.starts_with("X57.1") || l.starts_with("X17.9")).count();
    assert_eq!(passes, 8, "roughing passes");
    assert!(b.iter().filter(|l| l.starts_with('(')).count() >= 10, "comments");
}

#[test]
fn example_programs_pass_rs274_in_every_dialect_it_reads() {
    let dir = tempfile::tempdir().expect("tempdir");
    for name in JOBS {
        let (_, p) = program(name);
        for (dialect, tag) in [(Dialect::LinuxCnc, "linuxcnc"), (Dialect::Grbl, "grbl")] {
            let text = p.gcode(dialect).expect("writes");
            let path = dir.path().join(format!("{name}.{tag}.ngc"));
            std::fs::write(&path, &text).expect("write program");
            let errors = rs274_errors(&path);
            assert!(errors.is_empty(), "{name} ({tag}): rs274 says {errors:?}");
        }
        // Fanuc: same blocks as LinuxCNC but P in ms, and our parser reads it without error.
        let fanuc = p.gcode(Dialect::Fanuc).expect("writes");
        assert!(fanuc.starts_with("%\nO0001\n"), "{name}: Fanuc header");
        let mut stats = Stats::default();
        parse_str(&fanuc, &ParseOptions { stop_at_first_error: true, ..Default::default() }, &mut stats)
            .unwrap_or_else(|e| panic!("{name} (fanuc): {e}"));
    }
}

#[test]
fn example_programs_cut_exactly_the_features() {
    for name in JOBS {
        let (spec, p) = program(name);
        let text = p.gcode(Dialect::LinuxCnc).expect("writes");
        let c = p.voxel_check(&text, VOXEL).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(c.gouge_voxels, 0, "{name}: gouges outside the feature volumes");
        assert_eq!(c.rapid_collision_voxels, 0, "{name}: rapids through material");
        assert_eq!(c.holder_collision_voxels, 0, "{name}: shank collisions");
        let mut expected_volume = 0.0;
        for (f, r) in spec.job.features.iter().zip(&c.features) {
            assert_eq!(r.left_inside, 0, "{name}/{}: material left more than a voxel inside", f.name);
            let floor = r.floor_z.unwrap_or_else(|| panic!("{name}/{}: nothing removed", f.name));
            assert!(
                floor >= -f.depth && floor <= -f.depth + c.voxel,
                "{name}/{}: floor at {floor}, depth {}",
                f.name,
                f.depth
            );
            assert!(r.overcut <= 1e-9, "{name}/{}: overcut {}", f.name, r.overcut);
            expected_volume += match f.kind {
                FeatureKind::Pocket { length, width, corner_radius: rc, .. } => {
                    (length * width - (4.0 - std::f64::consts::PI) * rc * rc) * f.depth
                }
                FeatureKind::Hole { diameter, .. } => {
                    std::f64::consts::PI * 0.25 * diameter * diameter * f.depth
                }
                FeatureKind::Slot { start, end, width, through } => {
                    let len = if through {
                        // Clipped to the block (the examples' through slots run along an axis).
                        if (start[0] - end[0]).abs() < 1e-9 {
                            spec.job.block.width
                        } else {
                            spec.job.block.length
                        }
                    } else {
                        (end[0] - start[0]).hypot(end[1] - start[1])
                    };
                    let caps = if through { 0.0 } else { std::f64::consts::PI * 0.25 * width * width };
                    (len * width + caps) * f.depth
                }
            };
        }
        // Independent check: removed volume = analytic feature volume (disjoint features) to 1 %.
        let removed = c.removed_voxels as f64 * c.voxel.powi(3);
        assert!(
            (removed - expected_volume).abs() <= 0.01 * expected_volume,
            "{name}: removed {removed:.1} mm3, features {expected_volume:.1} mm3"
        );
    }
}

/// grbl has no canned cycles (and no tool numbers): its expanded cycles must cut exactly what
/// LinuxCNC's G81/G82/G83 cut (one tool, so the simulated tool is the same).
#[test]
fn grbl_expansion_cuts_like_canned_cycles() {
    let job = r#"
        [block]
        length = 40.0
        width = 30.0
        height = 10.0
        [[tools]]
        number = 5
        diameter = 6.0
        rpm = 2000
        feed = 100
        [[features]]
        type = "hole"
        name = "g81"
        x = 8.0
        y = 8.0
        diameter = 6.0
        depth = 5.0
        cycle = "drill"
        tool = 5
        [[features]]
        type = "hole"
        name = "g82"
        x = 30.0
        y = 8.0
        diameter = 6.0
        depth = 6.0
        cycle = "dwell"
        tool = 5
        [[features]]
        type = "hole"
        name = "g83"
        x = 20.0
        y = 21.0
        diameter = 6.0
        depth = 9.5
        cycle = "peck"
        peck = 2.0
        tool = 5
    "#;
    let p = feature_program(&parse_job(job, "drills.toml").expect("parses")).expect("plans");
    let lc_text = p.gcode(Dialect::LinuxCnc).expect("writes");
    let gr_text = p.gcode(Dialect::Grbl).expect("writes");
    assert!(lc_text.contains("G98 G83") && !gr_text.contains("G98"), "cycles native vs expanded");
    let lc = p.voxel_check(&lc_text, VOXEL).expect("linuxcnc");
    let gr = p.voxel_check(&gr_text, VOXEL).expect("grbl");
    assert_eq!(lc.removed_voxels, gr.removed_voxels, "grbl's expanded cycles vs G81/G82/G83");
    for c in [&lc, &gr] {
        assert_eq!(c.gouge_voxels + c.rapid_collision_voxels, 0, "drills: gouges or rapid collisions");
        assert!(c.features.iter().all(|f| f.left_inside == 0), "drills: {:?}", c.features);
    }
}

/// The seed's program as printed (Section II.F): its roughing starts with the tool centre on the
/// pocket corner, so it gouges the walls; ours does not (see the module docs).
#[test]
fn seed_program_as_printed_gouges() {
    let seed = "N10 G21 G17 G40\nN20 T01 M06\nN30 S1200 M03\nN40 G90 G00 X12.5 Y12.5\nN50 G43 Z3 H01 M08\n\
N60 G01 Z-2.5 F90\nN70 G91 X38.4\nN80 Y8.067\nN90 X-38.4\nN100 Y8.067\nN110 X38.4\nN120 Y8.067\nN130 X-38.4\n\
N140 G90 G00 Z3\nN150 X12.5 Y12.5\nN160 G01 Z-5\nN170 G91 X38.4\nN180 Y8.067\nN190 X-38.4\nN200 Y8.067\n\
N210 X38.4\nN220 Y8.067\nN230 X-38.4\nN240 G90 G00 Z3\nN250 M01\nN260 T01 M06\nN270 S1500 M03\n\
N280 G00 X37.5 Y30\nN290 G43 Z3 H02 M08\nN300 G01 Z-5 F70\nN310 Y12.5\nN320 X57.5\nN330 Y42.5\nN340 X17.5\n\
N350 Y17.5\nN360 X37.5\nN370 G00 Z3\nN380 X0 Y0 M09\nN390 M05\nN400 M30\n";
    let (_, p) = program("seed_pocket");
    let c = p.voxel_check(seed, VOXEL).expect("seed program simulates");
    eprintln!("seed program as printed: {} gouge voxels at {VOXEL} mm", c.gouge_voxels);
    assert!(c.gouge_voxels > 1000, "the seed's program should gouge: {}", c.gouge_voxels);
    let ours = p.voxel_check(&p.gcode(Dialect::LinuxCnc).expect("writes"), VOXEL).expect("ours");
    assert_eq!(ours.gouge_voxels, 0);
}

fn job_with(edit: impl Fn(&str) -> String) -> Result<FeatureProgram, String> {
    let text = std::fs::read_to_string(job_path("bracket")).expect("read bracket");
    let spec = parse_job(&edit(&text), "edited.toml").map_err(|e| e.to_string())?;
    feature_program(&spec).map_err(|e| e.to_string())
}

#[test]
fn bad_jobs_give_errors_naming_the_feature() {
    let cases: [(&str, &str, &str, &str); 5] = [
        ("x = 92.0\ny = 8.0", "x = 98.0\ny = 8.0", "'hole 2'", "outside the block"),
        ("width = 8.0\ndepth = 4.0", "width = 7.0\ndepth = 4.0", "'adjust slot'", "wider than the slot"),
        ("diameter = 16.0\ndepth = 6.0", "diameter = 16.0\ndepth = 13.0", "'bore'", "beyond the block"),
        ("width = 12.0\ndepth = 3.0", "width = 12.0\ndepth = 3.0\nthrough_typo = 1", "line", "unknown field"),
        ("cycle = \"drill\"", "cycle = \"bore\"", "'hole 1'", "cycle must be"),
    ];
    for (from, to, who, what) in cases {
        let err = job_with(|t| {
            assert!(t.contains(from), "bracket.toml has '{from}'");
            t.replacen(from, to, 1)
        })
        .expect_err(to);
        assert!(err.contains(who) && err.contains(what), "'{to}': {err}");
    }
    // Corner radius below the tool radius.
    let text = std::fs::read_to_string(job_path("seed_pocket")).expect("read");
    let spec =
        parse_job(&text.replace("corner_radius = 5.0", "corner_radius = 4.0"), "x.toml").expect("parses");
    let err = feature_program(&spec).expect_err("corner").to_string();
    assert!(err.contains("'pocket'") && err.contains("corner radius 4"), "{err}");
    // Not TOML at all: the position is named.
    let err = parse_job("[block\nlength = 1", "broken.toml").expect_err("syntax").to_string();
    assert!(err.contains("broken.toml") && err.contains("line 1"), "{err}");
}

/// The same job in inches gives the same program (to rounding) as in millimetres.
#[test]
fn inch_jobs_scale_to_millimetres() {
    let mm = std::fs::read_to_string(job_path("seed_pocket")).expect("read");
    let (_, p_mm) = program("seed_pocket");
    let mut inch = mm.replace("units = \"mm\"", "units = \"inch\"");
    for key in
        ["allowance", "length", "width", "height", "diameter", "feed", "x", "y", "corner_radius", "depth"]
    {
        inch = inch
            .lines()
            .map(|l| match l.split_once(" = ") {
                Some((k, v)) if k == key => match v.parse::<f64>() {
                    Ok(x) => format!("{k} = {}", x / 25.4),
                    Err(_) => l.to_owned(),
                },
                _ => l.to_owned(),
            })
            .collect::<Vec<_>>()
            .join("\n");
    }
    let p_in = feature_program(&parse_job(&inch, "inch.toml").expect("parses")).expect("plans");
    let (a, b) = (&p_mm.plan.summaries[0], &p_in.plan.summaries[0]);
    assert_eq!((a.cuts, a.passes), (b.cuts, b.passes), "inch job rules");
    assert!((a.stepover - b.stepover).abs() < 1e-9 && (a.depth_of_cut - b.depth_of_cut).abs() < 1e-9);
    let (ta, tb) = (p_mm.gcode(Dialect::LinuxCnc).expect("mm"), p_in.gcode(Dialect::LinuxCnc).expect("in"));
    assert_eq!(ta.lines().count(), tb.lines().count(), "same blocks");
}
