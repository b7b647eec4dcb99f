use std::path::Path;

use s2g_gcode::{Coolant, MachineProfile};
use s2g_geom::CutterShape;

use super::*;

const DEFAULT: &str = include_str!("../../../../assets/tools/default.toml");

fn default_library() -> ToolLibrary {
    ToolLibrary::from_toml(DEFAULT, Path::new("default.toml")).expect("the shipped library parses")
}

fn close(a: f64, b: f64, what: &str) {
    assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "{what}: {a} != {b}");
}

#[test]
fn the_default_library_has_what_the_issue_asks_for() {
    let lib = default_library();
    let diameters = |f: fn(&CutterShape) -> bool| -> Vec<f64> {
        lib.tools.iter().filter(|t| f(&t.cutter.shape)).map(|t| t.cutter.diameter()).collect()
    };
    let mut flats = diameters(|s| matches!(s, CutterShape::Flat(_)));
    flats.sort_by(f64::total_cmp);
    let balls = diameters(|s| matches!(s, CutterShape::Ball(_)));
    let bulls = diameters(|s| matches!(s, CutterShape::BullNose(_)));
    assert_eq!((flats.first(), flats.last()), (Some(&1.0), Some(&12.0)), "{flats:?}");
    assert_eq!((balls.first(), balls.last()), (Some(&1.0), Some(&10.0)), "{balls:?}");
    assert!(bulls.len() >= 2, "{bulls:?}");
    // Long-reach end mills of 1, 2, 3 and 2 mm: necks under the flutes, reaching past them
    // and, with the shank wider than the flutes, as far as the tool reaches; the second
    // 2 mm one (at most 0.7 of the 4 mm end mill, the rest tool's step) 25 mm, past every
    // other end mill of at most 0.7 of 4 or 5 mm (a 4 mm slot 22 mm deep, example007's).
    let long: Vec<_> = lib
        .tools
        .iter()
        .filter(|t| !t.cutter.is_t_slot())
        .filter_map(|t| t.cutter.neck.map(|n| (t, n)))
        .collect();
    assert_eq!(long.iter().map(|(t, _)| t.cutter.diameter()).collect::<Vec<_>>(), [1.0, 2.0, 3.0, 2.0]);
    let deep = |w: f64| {
        lib.tools
            .iter()
            .filter(|t| {
                t.cutter.radius <= 0.7 * w / 2.0 + 1e-9 && matches!(t.cutter.shape, CutterShape::Flat(_))
            })
            .map(|t| t.cutter.reach())
            .fold(0.0, f64::max)
    };
    assert!(deep(4.0) >= 25.0 && deep(5.0) >= 25.0, "{} {}", deep(4.0), deep(5.0));
    for (t, n) in &long {
        t.cutter.validate().expect("a valid long-reach cutter");
        assert!(n.radius < t.cutter.radius && n.reach >= 3.0 * t.cutter.flute_length, "T{}: {n:?}", t.number);
        assert_eq!(t.cutter.reach(), n.reach, "T{}", t.number);
    }
    // T-slot cutters for 12 and 7 mm slots (DIN 851): discs wider than their necks, the
    // necks reaching past the discs, cut no faster than a flat end mill of the disc's
    // diameter would, no deeper axially than the disc is thick.
    let slots: Vec<_> = lib.tools.iter().filter(|t| t.cutter.is_t_slot()).collect();
    assert_eq!(slots.iter().map(|t| t.cutter.diameter()).collect::<Vec<_>>(), [21.0, 12.5]);
    let alu = lib.material("aluminium-6061").expect("aluminium");
    let twelve = lib.tools.iter().find(|t| t.cutter.diameter() == 12.0).expect("12 mm flat");
    for t in &slots {
        t.cutter.validate().expect("a valid T-slot cutter");
        let n = t.cutter.neck.expect("a neck");
        assert!(n.radius < t.cutter.radius && n.reach > t.cutter.flute_length, "T{}: {n:?}", t.number);
        let c = t.cutting(alu, &MachineProfile::default()).expect("cutting");
        assert!(c.max_axial_depth <= t.cutter.flute_length + 1e-9, "T{}: {c:?}", t.number);
        let flat = twelve.cutting(alu, &MachineProfile::default()).expect("cutting");
        assert!(c.feed / t.flutes as f64 <= flat.feed / twelve.flutes as f64, "T{}", t.number);
    }
    for m in ["aluminium-6061", "mild-steel", "pom", "wax"] {
        let material = lib.material(m).expect(m);
        for t in &lib.tools {
            assert!(t.cutting.contains_key(m), "T{} has no data for {m}", t.number);
            let c = t.cutting(material, &MachineProfile::default()).expect("cutting");
            assert!(
                c.feed > 0.0 && c.spindle_rpm > 0.0 && c.max_axial_depth > 0.0,
                "T{} {m}: {c:?}",
                t.number
            );
            assert!(t.cutter.holder.is_some() && t.cutter.stickout >= t.cutter.flute_length);
        }
    }
    assert_eq!(lib.material("aluminium-6061").unwrap().coolant, Coolant::Flood);
    assert_eq!(lib.material("wax").unwrap().coolant, Coolant::Off);
    assert_eq!(lib.machine, Some(MachineProfile::default()));
}

#[test]
fn feeds_and_speeds_follow_the_chart_formulas() {
    let lib = default_library();
    let alu = lib.material("aluminium-6061").unwrap();
    let machine = MachineProfile::default();
    // 6 mm, 3 flutes, vc 250 m/min, fz 0.036 mm: n = 250000 / (6 pi) = 13,263 rpm,
    // vf = 0.036 * 3 * n = 1,432.4 mm/min.
    let t6 = lib.tools.iter().find(|t| t.name.starts_with("6 mm flat")).unwrap();
    let c = t6.cutting(alu, &machine).unwrap();
    let n = (250_000.0 / (6.0 * std::f64::consts::PI)).round();
    close(c.spindle_rpm, n, "rpm");
    close(c.feed, 0.036 * 3.0 * n, "feed");
    close(c.plunge_feed, 0.3 * c.feed, "plunge");
    close(c.max_axial_depth, 6.0, "ap");
    close(c.max_radial_depth, 3.0, "ae");
    // 1 mm: 79,577 rpm asked, the spindle's 24,000 given; the feed follows the rpm given.
    let t1 = lib.tool(1).unwrap();
    let c = t1.cutting(alu, &machine).unwrap();
    close(c.spindle_rpm, 24_000.0, "capped rpm");
    close(c.feed, 0.006 * 3.0 * 24_000.0, "feed at the capped rpm");
    // A slow machine caps the feed.
    let slow = MachineProfile { max_feed: 500.0, ..MachineProfile::default() };
    close(t6.cutting(alu, &slow).unwrap().feed, 500.0, "capped feed");
    // The planner's tool carries all of it.
    let tool = t6.tool(alu, &machine).unwrap();
    assert_eq!((tool.number, tool.coolant), (t6.number, Coolant::Flood));
    assert_eq!(tool.cutter, t6.cutter);
    assert!(tool.validate().is_ok());
}

#[test]
fn toml_round_trips() {
    let lib = default_library();
    let text = lib.to_toml();
    let back = ToolLibrary::from_toml(&text, Path::new("written.toml")).expect("reads back");
    assert_eq!(back, lib);
}

#[test]
fn linuxcnc_tables_round_trip_and_read_linuxcnc_s_own() {
    let lib = default_library();
    let table = lib.to_linuxcnc_table();
    assert_eq!(table.lines().count(), lib.tools.len());
    let back = ToolLibrary::from_linuxcnc_table(&table, Path::new("tool.tbl")).expect("reads back");
    for (a, b) in lib.tools.iter().zip(&back.tools) {
        assert_eq!((a.number, &a.name), (b.number, &b.name));
        close(a.cutter.diameter(), b.cutter.diameter(), "diameter");
        assert_eq!(
            matches!(a.cutter.shape, CutterShape::Ball(_)),
            matches!(b.cutter.shape, CutterShape::Ball(_)),
            "{}",
            a.name
        );
    }
    // LinuxCNC's sample configuration's table, a probe without D included.
    let sample = "T1 P1 D0.125000 Z+0.511000 ;1/8 end mill\nT2 P2 D0.062500 Z+0.100000 ;1/16 end mill\n\
                  T3 P3 D0.201000 Z+1.273000 ;#7 tap drill\nT99999 P123     Z+0.100000 ;big tool number\n";
    let lib = ToolLibrary::from_linuxcnc_table(sample, Path::new("tool.tbl")).unwrap();
    assert_eq!(lib.tools.iter().map(|t| t.number).collect::<Vec<_>>(), [1, 2, 3]);
    assert_eq!(lib.tools[0].name, "1/8 end mill");
    // The material's fallback gives imported tools their data.
    let alu = default_library().material("aluminium-6061").unwrap().clone();
    let c = lib.tools[0].cutting_data(&alu).unwrap();
    close(c.chip_load, 0.006 * 0.125, "fallback chip load");
    let no_fallback = Material { fallback: None, ..alu };
    assert!(matches!(lib.tools[0].cutting_data(&no_fallback), Err(LibraryError::NoCuttingData { .. })));
}

#[test]
fn bad_files_say_where() {
    let check = |text: &str, want: &str, line: usize| match ToolLibrary::from_toml(text, Path::new("t.toml"))
    {
        Err(LibraryError::Parse { line: l, message, .. }) => {
            assert_eq!(l, line, "{message}");
            assert!(message.contains(want), "{message}");
        }
        other => panic!("{text:?}: {other:?}"),
    };
    check("[[tool]]\nnumber = 1\nname = \"x\"\nshape = \"cone\"\n", "cone", 4);
    check("[[tool]]\nnumber = -3\n", "-3", 2);
    check("[[material]]\nname = \"a\"\ncolant = \"flood\"\n", "colant", 3);
    let bull = "[[tool]]\nnumber = 4\nname = \"b\"\nshape = \"bull\"\ndiameter = 6.0\ncorner_radius = 4.0\n\
                flutes = 2\nflute_length = 18.0\nstickout = 30.0\nshank_diameter = 6.0\n";
    match ToolLibrary::from_toml(bull, Path::new("t.toml")) {
        Err(LibraryError::Invalid { message, .. }) => {
            assert!(message.contains("T4") && message.contains("corner"))
        }
        other => panic!("{other:?}"),
    }
    let twice = format!("{bull}\n{bull}").replace("corner_radius = 4.0", "corner_radius = 1.0");
    match ToolLibrary::from_toml(&twice, Path::new("t.toml")) {
        Err(LibraryError::Invalid { message, .. }) => assert!(message.contains("twice"), "{message}"),
        other => panic!("{other:?}"),
    }
    match ToolLibrary::from_linuxcnc_table("T1 P1 D6\nT2 P2 Dx ;bad\n", Path::new("t.tbl")) {
        Err(LibraryError::Parse { line: 2, column: 7, .. }) => {}
        other => panic!("{other:?}"),
    }
    let lib = default_library();
    assert!(matches!(lib.material("titanium"), Err(LibraryError::UnknownMaterial { .. })));
}

#[test]
fn freecad_bits_read_as_their_shapes() {
    let bit = |shape: &str, extra: &str| {
        format!(
            "{{\"version\": 2, \"name\": \"bit\", \"shape\": \"{shape}\", \"attribute\": {{}},\n\
             \"parameter\": {{\"CuttingEdgeHeight\": \"30.000 mm\", \"Diameter\": \"6.000 mm\",\n\
             \"Length\": \"50.000 mm\", \"ShankDiameter\": \"0.25 in\"{extra}}}}}"
        )
    };
    let end = read_fctb(&bit("endmill.fcstd", ""), Path::new("e.fctb")).unwrap();
    assert!(matches!(end.cutter.shape, CutterShape::Flat(_)));
    close(end.cutter.radius, 3.0, "radius");
    close(end.cutter.flute_length, 30.0, "flutes");
    close(end.cutter.stickout, 50.0, "stick-out");
    close(end.cutter.shank_radius, 0.5 * 6.35, "inch shank");
    assert_eq!(end.flutes, 2);
    let ball = read_fctb(&bit("ballend.fcstd", ", \"Flutes\": \"4\""), Path::new("b.fctb")).unwrap();
    assert!(matches!(ball.cutter.shape, CutterShape::Ball(_)));
    assert_eq!(ball.flutes, 4);
    let bull = read_fctb(&bit("bullnose.fcstd", ", \"FlatRadius\": \"2 mm\""), Path::new("n.fctb")).unwrap();
    close(bull.cutter.corner_radius(), 1.0, "corner radius");
    match read_fctb(&bit("chamfer.fcstd", ""), Path::new("c.fctb")) {
        Err(LibraryError::Parse { message, line: 1, .. }) => {
            assert!(message.contains("chamfer"), "{message}")
        }
        other => panic!("{other:?}"),
    }
    match read_fctb(&bit("endmill.fcstd", "").replace("6.000 mm", "6 furlongs"), Path::new("c.fctb")) {
        Err(LibraryError::Parse { message, line: 2, .. }) => {
            assert!(message.contains("furlongs"), "{message}")
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(read_fctb("{", Path::new("x.fctb")), Err(LibraryError::Parse { .. })));
}
