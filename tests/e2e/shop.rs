//! The shop preset with a tool library: each setup's tool, spindle speed, feeds and coolant
//! come from the library's cutting data, the programs change tools with length offsets and
//! run in `rs274` with the library's tool table, and the report's times are the machine's.

use shape2gcode::gcode::{Coolant, Dialect, MachineTime, Motion, MotionSink, ParseOptions, parse_str};
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
    // A reach's slack that is no length.
    for slack in [f64::NAN, -0.1, f64::INFINITY] {
        let opts = MillOptions { tool_aware_reach: true, reach_slack: Some(slack), ..shop("aluminium-6061") };
        match run(&opts) {
            Err(MillError::InvalidOption(m)) => assert!(m.contains("slack"), "{m}"),
            other => panic!("{slack}: {:?}", other.map(|m| m.metrics)),
        }
    }
}

/// What a program does before its first feed move, in order: tool changes, spindle starts
/// and coolant, parsed back from its text.
#[derive(Default)]
struct Start {
    events: Vec<String>,
    feeding: bool,
}

impl MotionSink for Start {
    type Error = std::convert::Infallible;

    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        match m {
            _ if self.feeding => {}
            Motion::Linear { .. } | Motion::Arc { .. } => self.feeding = true,
            Motion::ToolChange { tool } => self.events.push(format!("T{tool}")),
            Motion::Spindle { rpm, .. } if *rpm > 0.0 => self.events.push(format!("S{}", rpm.round())),
            Motion::Coolant(Coolant::Flood) => self.events.push("M8".into()),
            _ => {}
        }
        Ok(())
    }
}

/// The shop preset writes for grbl and Fanuc programs their controllers accept: a safe
/// start block with G54, the tool (Fanuc: `T n M6` and `G43 H n` with an integer register;
/// grbl, which has no tool changer: `M0` naming the tool), the tool's spindle speed and
/// the material's coolant before the first cut, the program end, and for Fanuc the `%`
/// delimiters and one program number per setup. Parsed back, each program changes to its
/// tool, starts the spindle at the tool's speed and floods before it feeds.
#[test]
fn grbl_and_fanuc_shop_programs_have_a_controller_s_blocks() {
    for dialect in [Dialect::Grbl, Dialect::Fanuc] {
        let milled = mill_example001(&MillOptions { dialect, ..shop("aluminium-6061") });
        assert!(!milled.setups.is_empty());
        for (i, s) in milled.setups.iter().enumerate() {
            let name = format!("{dialect} setup {}", i + 1);
            let t = &s.tool;
            let lines: Vec<&str> = s.text.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
            let first_move = lines.iter().position(|l| l.starts_with("G0")).expect("a move");
            let start = &lines[..first_move];
            let has = |want: &str| start.contains(&want);
            assert!(has("G17 G21 G40 G49 G80 G90 G94") && has("G54"), "{name}: safe start {start:?}");
            let rpm = format!("S{} M3", t.spindle_rpm.round());
            assert!(has(&rpm) && has("M8"), "{name}: no {rpm:?} or M8 in {start:?}");
            assert!(lines.contains(&"M30"), "{name}: no program end");
            match dialect {
                Dialect::Fanuc => {
                    assert_eq!(lines.first(), Some(&"%"), "{name}");
                    assert_eq!(lines.get(1).copied(), Some(format!("O{:04}", i + 1).as_str()), "{name}");
                    assert_eq!(lines.last(), Some(&"%"), "{name}");
                    let (change, offset) = (format!("T{} M6", t.number), format!("G43 H{}", t.number));
                    assert!(has(&change) && has(&offset), "{name}: no {change:?} / {offset:?} in {start:?}");
                }
                _ => {
                    assert!(
                        !s.text.contains("M6") && !s.text.contains("G43"),
                        "{name}: grbl has no M6 or G43 H"
                    );
                    let pause = format!("M0 (tool change T{})", t.number);
                    assert!(has(&pause), "{name}: no {pause:?} in {start:?}");
                    assert!(!s.text.contains('%') && !lines.iter().any(|l| l.starts_with('O')), "{name}");
                }
            }
            let mut seen = Start::default();
            let summary = parse_str(&s.text, &ParseOptions::default(), &mut seen).unwrap();
            assert!(summary.errors.is_empty(), "{name}: {:?}", summary.errors);
            let mut want = vec![format!("S{}", t.spindle_rpm.round()), "M8".to_string()];
            if dialect == Dialect::Fanuc {
                want.insert(0, format!("T{}", t.number));
            }
            assert_eq!(seen.events, want, "{name}: before the first cut");
        }
    }
}

/// Tools too short for the stock: every flat end mill of the library sticks out 12 mm from
/// its chuck (flutes and necks of at most 12 mm) on a part 43 mm tall. No setup may bring the chuck
/// into the stock: each setup cuts only as deep as its tool reaches below the stock's top
/// (the highest in-process stock point under the holder), so the simulator, which sweeps
/// shank and holder too, finds no holder collision and the run is safe, at the price of
/// the material out of reach.
#[test]
fn short_tools_never_bring_their_holder_into_the_stock() {
    let mut short: ToolLibrary = default_tool_library().clone();
    for t in &mut short.tools {
        t.cutter.stickout = 12.0;
        t.cutter.flute_length = t.cutter.flute_length.min(12.0);
        // A long-reach end mill's neck ends at the chuck at the latest.
        if let Some(n) = &mut t.cutter.neck {
            n.reach = n.reach.min(12.0);
        }
        assert!(t.cutter.holder.is_some(), "T{} has a holder", t.number);
    }
    let opts = MillOptions { tools: Some(short), ..shop("aluminium-6061") };
    let milled = mill_example001(&opts);
    let full = mill_example001(&shop("aluminium-6061"));
    assert!(
        milled.simulation.holder_collisions.is_empty(),
        "holder collisions at {:?}",
        milled.simulation.holder_collisions
    );
    assert!(milled.is_safe(), "gouges {}", milled.simulation.gouge_voxels);
    for s in &milled.setups {
        assert!(s.tool.cutter.stickout <= 12.0, "T{} sticks out {}", s.tool.number, s.tool.cutter.stickout);
    }
    // The test means something only if the short tools leave material the long ones cut.
    assert!(
        milled.simulation.removed_voxels < full.simulation.removed_voxels,
        "short tools removed {} voxels, long ones {}",
        milled.simulation.removed_voxels,
        full.simulation.removed_voxels
    );
}
