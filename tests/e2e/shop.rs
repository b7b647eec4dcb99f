//! The shop preset with a tool library: each setup's tool, spindle speed, feeds and coolant
//! come from the library's cutting data, the programs change tools with length offsets and
//! run in `rs274` with the library's tool table, and the report's times are the machine's.

use shape2gcode::gcode::{Coolant, MachineTime, MotionSink, ParseOptions, parse_str};
use shape2gcode::geom::load_mesh;
use shape2gcode::toolpath::library::ToolLibrary;
use shape2gcode::{HeuristicPolicy, MillError, MillOptions, Milled, Preset, default_tool_library, mill};

use super::common::{data, rs274_errors_with_table};

fn shop(material: &str) -> MillOptions {
    MillOptions {
        preset: Preset::Shop,
        resolution: 64,
        orient_points: 2048,
        metric_samples: 2000,
        material: material.into(),
        ..MillOptions::default()
    }
}

fn mill_example001(opts: &MillOptions) -> Milled {
    let mesh = load_mesh(data("meshes/openscad/openscad_Old_example001.stl")).unwrap();
    mill(&mesh, &mut HeuristicPolicy::default(), opts, &mut |_| {}).unwrap()
}

/// The machine time of a program's text, timed anew from the parsed text.
fn machine_time_of(text: &str) -> f64 {
    let machine = default_tool_library().machine.clone().unwrap();
    let mut clock = MachineTime::new(machine);
    parse_str(text, &ParseOptions::default(), &mut clock).unwrap();
    let Ok(()) = clock.finish();
    clock.seconds()
}

#[test]
fn setups_cut_with_the_library_s_tools_at_their_cutting_data() {
    let lib = default_tool_library();
    let machine = lib.machine.clone().unwrap();
    let alu = lib.material("aluminium-6061").unwrap();
    let milled = mill_example001(&shop("aluminium-6061"));
    assert!(!milled.setups.is_empty());
    let dir = tempfile::tempdir().unwrap();
    let table = lib.to_linuxcnc_table();
    let mut feed_time = 0.0;
    for (i, s) in milled.setups.iter().enumerate() {
        let t = &s.tool;
        // The library's flat end mill of the action's radius, at its data.
        let want = lib.tools.iter().find(|l| l.number == t.number).expect("a library tool");
        assert_eq!(want.cutter, t.cutter, "setup {}", i + 1);
        assert_eq!(t.cutter.radius, s.action.tool_radius);
        let c = want.cutting(alu, &machine).unwrap();
        assert_eq!((t.spindle_rpm, t.feed, t.plunge_feed), (c.spindle_rpm, c.feed, c.plunge_feed));
        assert_eq!(t.coolant, Coolant::Flood);
        // The program changes to it, sets its length offset, speed and coolant.
        let text = &s.text;
        for word in [format!("T{} M6", t.number), format!("G43 H{}", t.number), "M8".into(), "M9".into()] {
            assert!(text.contains(&word), "setup {}: no {word:?}", i + 1);
        }
        let rpm = format!("S{}", t.spindle_rpm.round());
        assert!(text.contains(&rpm), "setup {}: no {rpm}", i + 1);
        // LinuxCNC runs it with the library's tool table.
        let path = dir.path().join(format!("setup{i}.ngc"));
        std::fs::write(&path, text).unwrap();
        let errors = rs274_errors_with_table(&path, &table);
        assert!(errors.is_empty(), "setup {}: rs274: {errors:?}", i + 1);
        // The report's time is the machine's, and the machine is never faster than
        // length / feed.
        let timed = s.machine_time_s.expect("a shop setup is timed on the machine");
        assert!((timed - machine_time_of(text)).abs() <= 1e-9 * timed, "setup {}: {timed}", i + 1);
        feed_time += timed;
    }
    assert!(
        feed_time >= milled.simulation.machining_time_s,
        "{feed_time} < {}",
        milled.simulation.machining_time_s
    );
    let report = milled.report_json(false);
    assert_eq!(report["machining_time_s"].as_f64().unwrap(), (feed_time * 1000.0).round() / 1000.0);
    assert!(report["setups"][0]["tool"]["number"].as_u64().is_some());
}

#[test]
fn the_material_sets_speeds_and_coolant() {
    let wax = mill_example001(&shop("wax"));
    let alu = mill_example001(&shop("aluminium-6061"));
    for s in &wax.setups {
        assert_eq!(s.tool.coolant, Coolant::Off);
        assert!(!s.text.contains("M8") && !s.text.contains("M7"), "wax needs no coolant");
    }
    // Same tools, other cutting data: the 12 mm end mill turns at 150 against 250 m/min.
    let rpm = |m: &Milled| m.setups.iter().map(|s| (s.tool.number, s.tool.spindle_rpm)).collect::<Vec<_>>();
    for ((tw, w), (ta, a)) in rpm(&wax).into_iter().zip(rpm(&alu)) {
        if tw == ta && a < 24_000.0 {
            assert!(w < a, "T{tw}: {w} rpm in wax, {a} in aluminium");
        }
    }
}

#[test]
fn what_the_library_cannot_do_is_refused_before_cutting() {
    let mesh = load_mesh(data("meshes/openscad/openscad_Old_example001.stl")).unwrap();
    let run = |opts: &MillOptions| mill(&mesh, &mut HeuristicPolicy::default(), opts, &mut |_| {});
    match run(&shop("titanium")) {
        Err(MillError::InvalidOption(m)) => assert!(m.contains("titanium") && m.contains("wax"), "{m}"),
        other => panic!("{:?}", other.map(|m| m.metrics)),
    }
    let paper = MillOptions { tools: Some(default_tool_library().clone()), ..MillOptions::default() };
    match run(&paper) {
        Err(MillError::InvalidOption(m)) => assert!(m.contains("shop preset"), "{m}"),
        other => panic!("{:?}", other.map(|m| m.metrics)),
    }
    // A library of ball end mills only has nothing to rough with.
    let mut balls: ToolLibrary = default_tool_library().clone();
    balls.tools.retain(|t| t.cutter.corner_radius() == t.cutter.radius);
    match run(&MillOptions { tools: Some(balls), ..shop("aluminium-6061") }) {
        Err(MillError::InvalidOption(m)) => assert!(m.contains("flat end mill"), "{m}"),
        other => panic!("{:?}", other.map(|m| m.metrics)),
    }
}
