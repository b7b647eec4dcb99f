//! Parser tests: the sample programs, the odd files, and one table of cases per feature.

use std::path::{Path, PathBuf};

use nalgebra::Point3;
use s2g_gcode::{
    ArcDirection, GcodeErrorKind, Marker, Motion, MotionRecorder, ParseDialect, ParseError, ParseOptions,
    ParseSummary, Plane, RotaryAxes, Stats, parse_file, parse_reader, parse_str,
};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data").join(rel)
}

fn files(rel: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(data(rel))
        .unwrap_or_else(|e| panic!("{rel}: {e}"))
        .map(|e| e.expect("dir entry").path())
        .collect();
    v.sort();
    assert!(!v.is_empty(), "no files in {rel}");
    v
}

fn run(text: &str, opts: &ParseOptions) -> (ParseSummary, Vec<(u64, Motion<'static>)>) {
    let mut rec = MotionRecorder::default();
    let s = parse_str(text, opts, &mut rec).expect("parse");
    (s, rec.motions)
}

fn moves(text: &str) -> Vec<Motion<'static>> {
    let (s, m) = run(text, &ParseOptions::default());
    assert!(s.errors.is_empty(), "{text:?}: unexpected errors {:?}", s.errors);
    m.into_iter().map(|x| x.1).filter(|m| m.end_point().is_some()).collect()
}

fn close(a: Point3<f64>, b: [f64; 3], what: &str) {
    let d = (a - Point3::from(b)).norm();
    assert!(d < 1e-9, "{what}: got {a:?}, want {b:?}");
}

fn ends(text: &str) -> Vec<[f64; 3]> {
    moves(text).iter().map(|m| m.end_point().expect("move").coords.into()).collect()
}

fn check_ends(text: &str, want: &[[f64; 3]]) {
    let got = ends(text);
    assert_eq!(got.len(), want.len(), "{text:?}: move count, got {got:?}");
    for (g, w) in got.iter().zip(want) {
        close(Point3::from(*g), *w, text);
    }
}

fn first_error(text: &str, opts: &ParseOptions) -> (u64, u32, GcodeErrorKind) {
    let (s, _) = run(text, opts);
    let e = s.errors.first().unwrap_or_else(|| panic!("{text:?}: expected an error"));
    (e.line, e.column, e.kind.clone())
}

fn strict() -> ParseOptions {
    ParseOptions { dialect: ParseDialect::Cnc, ..ParseOptions::default() }
}

#[test]
fn sample_programs_parse_without_errors() {
    for dir in ["cnc/programs", "fdm/gcode"] {
        for f in files(dir) {
            let mut stats = Stats::default();
            let s = parse_file(&f, &ParseOptions::default(), &mut stats).expect("parse");
            if f.ends_with("arc-r_modal.nc") {
                // `X0Y20` in G2/G3 mode without I, J, K or R: an error, as in `rs274`.
                let lines: Vec<u64> = s.errors.iter().map(|e| e.line).collect();
                assert_eq!(lines, [3, 7], "{:?}", s.errors);
                assert!(s.errors.iter().all(|e| e.kind == GcodeErrorKind::ArcMissingCenter));
                continue;
            }
            assert!(s.errors.is_empty(), "{}: {:?}", f.display(), s.errors);
            assert!(stats.moves() > 0, "{}: no moves", f.display());
            assert!(s.lines > 0);
        }
    }
}

#[test]
fn fdm_programs_have_layers_and_extrusion() {
    for f in files("fdm/gcode") {
        let mut stats = Stats::default();
        let s = parse_file(&f, &ParseOptions::default(), &mut stats).expect("parse");
        assert!(s.errors.is_empty());
        // The slicer runs are in 0.2 mm layers: a 10 mm cube has 50, the 4 mm dogbone 20.
        let name = f.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let height = if name.contains("cube10") {
            Some(10.0)
        } else if name.contains("dogbone") {
            Some(4.0)
        } else {
            None
        };
        assert!(stats.layers > 0, "{}: no layers", f.display());
        assert!(stats.extruded_mm > 100.0, "{}: extruded {}", f.display(), stats.extruded_mm);
        let (lo, hi) = stats.bbox.expect("bbox");
        if let Some(h) = height {
            assert_eq!(stats.layers, (h / 0.2f64).round() as u64, "{}: layers", f.display());
            assert!(hi.z >= h - 1e-6 && lo.z >= -1e-6, "{}: z range {lo:?} {hi:?}", f.display());
        }
    }
}

#[test]
fn reader_and_str_agree_on_every_sample() {
    for dir in ["cnc/programs", "fdm/gcode", "cnc/odd"] {
        for f in files(dir) {
            let bytes = std::fs::read(&f).expect("read");
            let text = String::from_utf8_lossy(&bytes);
            let mut a = MotionRecorder::default();
            let sa = parse_str(&text, &ParseOptions::default(), &mut a).expect("str");
            // A tiny buffer forces lines to span reads.
            let mut b = MotionRecorder::default();
            let r = std::io::BufReader::with_capacity(7, bytes.as_slice());
            let sb = parse_reader(r, &ParseOptions::default(), &mut b).expect("reader");
            assert_eq!(a.motions, b.motions, "{}", f.display());
            assert_eq!(sa.errors, sb.errors, "{}", f.display());
            assert_eq!(sa.lines, sb.lines, "{}", f.display());
        }
    }
}

#[test]
fn odd_files_give_the_right_errors() {
    let o = ParseOptions { stop_at_program_end: false, ..ParseOptions::default() };
    let check = |name: &str| {
        let mut rec = MotionRecorder::default();
        parse_file(data(&format!("cnc/odd/{name}")), &o, &mut rec).expect("parse")
    };
    // Checksums: only line 8 is wrong; the error names the path, line and column.
    let s = check("cncjs_special-fields_checksums.gcode");
    assert_eq!(s.errors.len(), 1, "{:?}", s.errors);
    let e = &s.errors[0];
    assert_eq!((e.line, e.column), (8, 16));
    assert!(matches!(e.kind, GcodeErrorKind::BadChecksum { stated: 30, .. }), "{e}");
    let shown = e.to_string();
    assert!(shown.contains("cncjs_special-fields_checksums.gcode:8:16: checksum"), "{shown}");
    // Not G-code.
    let s = check("cncjs_messed-up.gcode");
    assert_eq!(s.errors.len(), 1);
    assert!(matches!(s.errors[0].kind, GcodeErrorKind::NotGcode(_)), "{}", s.errors[0]);
    assert_eq!((s.errors[0].line, s.errors[0].column), (1, 1));
    // Spaces: three identical moves, no error.
    let s = check("cncjs_spaces.gcode");
    assert!(s.errors.is_empty());
    let m = ends(&std::fs::read_to_string(data("cnc/odd/cncjs_spaces.gcode")).expect("read"));
    assert_eq!(m, vec![[-5.0, 0.0, 0.0]; 3]);
    // Lexer samples: the unclosed comment on line 8, column 2; O-words unsupported.
    let s = check("gcodeLexer_samples_comments.ngc");
    let unclosed: Vec<_> = s.errors.iter().filter(|e| e.kind == GcodeErrorKind::UnclosedComment).collect();
    assert_eq!(unclosed.len(), 1, "{:?}", s.errors);
    assert_eq!((unclosed[0].line, unclosed[0].column), (8, 2));
    assert!(s.errors.iter().any(|e| e.line == 46 && matches!(e.kind, GcodeErrorKind::NotGcode(_))));
    // O-word control flow runs from line 128 on: its call of a subroutine the file does
    // not define is an error that ends the program, as in `rs274`.
    let last = s.errors.last().expect("errors");
    assert_eq!(last.line, 128, "{:?}", s.errors);
    assert!(matches!(&last.kind, GcodeErrorKind::ControlFlow(m) if m.contains("undefined subroutine o100")));
    // Without that line, the conditions reading parameters never set are errors at the
    // parameter and end the program there.
    let text = std::fs::read_to_string(data("cnc/odd/gcodeLexer_samples_comments.ngc")).expect("read");
    let without: String =
        text.lines().filter(|l| !l.starts_with("o100 call")).map(|l| format!("{l}\n")).collect();
    let mut rec = MotionRecorder::default();
    let s = parse_str(&without, &o, &mut rec).expect("parse");
    let last = s.errors.last().expect("errors");
    assert_eq!((last.line, last.column), (144, 11), "{:?}", s.errors);
    assert!(matches!(&last.kind, GcodeErrorKind::UndefinedParameter(n) if n == "scale"), "{last}");
}

#[test]
fn o_words_and_program_numbers() {
    // Fanuc program numbers: a label, in Auto; an error under strict LinuxCNC.
    let (s, m) = run("%\nO1234\nG0 X1\n%\n", &ParseOptions::default());
    assert!(s.errors.is_empty() && s.warnings.is_empty(), "{:?} {:?}", s.errors, s.warnings);
    assert_eq!(s.program_number, Some(1234));
    assert_eq!(m.len(), 1, "{m:?}");
    let (s, m) = run("O0001 (part one)\nG0 X1\n", &ParseOptions::default());
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    assert_eq!(s.program_number, Some(1));
    assert_eq!(m[0].1, Motion::Comment("part one".into()));
    let (l, c, k) = first_error("O1234\n", &strict());
    assert!((l, c) == (1, 1) && matches!(k, GcodeErrorKind::Unsupported(_)), "{k:?}");
    // An O word after other words, or with other words, is not a program number.
    for text in ["G0 X1 O12", "O12 G0 X1", "O", "o<x", "o[1 call"] {
        let (s, m) = run(text, &ParseOptions::default());
        assert_eq!(s.errors.len(), 1, "{text:?}: {:?}", s.errors);
        assert!(m.is_empty(), "{text:?}: {m:?}");
    }
    // Control flow runs (the unit tests of each construct are in `o_word_control_flow`);
    // misplaced or unmatched O-words are errors on their lines.
    type Case = (&'static str, usize, &'static [[f64; 3]]);
    let cases: &[Case] = &[
        ("o100 sub\nG0 X5\no100 endsub\nG0 X1", 0, &[[1.0, 0.0, 0.0]]),
        ("O0100 SUB\nG0 X5\n  o 100 EndSub\nG0 X1", 0, &[[1.0, 0.0, 0.0]]),
        (
            "o<s> sub\no1 if [1]\nG0 X5\no1 endif\no<s> endsub\no<s> call\nG0 X1",
            0,
            &[[5.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
        ),
        ("o100 if [1]\nG0 X5\no100 else\nG0 X6\no100 endif\nG0 X1", 0, &[[5.0, 0.0, 0.0], [1.0, 0.0, 0.0]]),
        ("o<a> do\nG0 X5\no<a> while [0]\nG0 X2", 0, &[[5.0, 0.0, 0.0], [2.0, 0.0, 0.0]]),
        (
            "o7 repeat [3]\nG0 X5\nN20 o7 endrepeat\nG0 X3",
            0,
            &[[5.0, 0.0, 0.0], [5.0, 0.0, 0.0], [5.0, 0.0, 0.0], [3.0, 0.0, 0.0]],
        ),
        // A control-flow error ends the program, as in `rs274`.
        ("o100 call [1]\nG0 X1", 1, &[]),
        ("G0 X2\no1 if\nG0 X1\no1 endif", 1, &[[2.0, 0.0, 0.0]]),
        // An unmatched O-word: the program does not run.
        ("o100 endsub\nG0 X1", 1, &[]),
        ("G0 X1\no9 while [1]\nG0 X5", 1, &[[1.0, 0.0, 0.0]]),
        ("o9 if [1]\no8 endif\no9 endif", 1, &[]),
        ("G0 X1 o9 if [1]", 1, &[]),
    ];
    for (text, errors, want) in cases {
        let (s, m) = run(text, &ParseOptions::default());
        assert_eq!(s.errors.len(), *errors, "{text:?}: {:?}", s.errors);
        assert!(s.warnings.is_empty(), "{text:?}: {:?}", s.warnings);
        let lines: Vec<&str> = text.lines().collect();
        assert!(
            s.errors.iter().all(|e| lines[e.line as usize - 1].to_lowercase().contains('o')),
            "{text:?}: errors on O-word lines only: {:?}",
            s.errors
        );
        let got: Vec<[f64; 3]> = m.iter().filter_map(|x| x.1.end_point()).map(|p| p.coords.into()).collect();
        assert_eq!(got.len(), want.len(), "{text:?}: {got:?}");
        for (g, w) in got.iter().zip(want.iter()) {
            close(Point3::from(*g), *w, text);
        }
    }
}

#[test]
fn fanuc_dwell_in_x() {
    let (s, m) = run("G1 X1 F100\nG4 X2.5\nG4 P1 X3\n", &ParseOptions::default());
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    assert_eq!(s.warnings.len(), 1, "warned once: {:?}", s.warnings);
    let m: Vec<_> = m.into_iter().map(|x| x.1).collect();
    // `G4 X2.5`: a dwell, no move. `G4 P1 X3`: LinuxCNC's reading, dwell then the G1 move.
    assert_eq!(m[1], Motion::Dwell { seconds: 2.5 });
    assert_eq!(m[2], Motion::Dwell { seconds: 1.0 });
    assert_eq!(m.len(), 4, "{m:?}");
    close(m[3].end_point().expect("move"), [3.0, 0.0, 0.0], "G4 P1 X3");
    // Inch mode does not scale seconds.
    let (_, m) = run("G20\nG4 X2\n", &ParseOptions::default());
    assert_eq!(m[0].1, Motion::Dwell { seconds: 2.0 });
    let (_, _, k) = first_error("G4 X2", &strict());
    assert!(matches!(k, GcodeErrorKind::MissingWord { letter: 'P', .. }), "{k:?}");
}

#[test]
fn stop_at_first_error_returns_it() {
    let o = ParseOptions { stop_at_first_error: true, ..ParseOptions::default() };
    let mut rec = MotionRecorder::default();
    match parse_str("G0 X1\nG0 X(oops\nG0 X3\n", &o, &mut rec) {
        Err(ParseError::Gcode(e)) => {
            assert_eq!(e.line, 2);
            assert_eq!(e.to_string(), "<input>:2:5: unclosed comment: '(' without ')' on the same line");
        }
        other => panic!("expected a G-code error, got {other:?}"),
    }
    assert_eq!(rec.motions.len(), 1);
    // Collecting mode continues past the bad line.
    let (s, m) = run("G0 X1\nG0 X(oops\nG0 X3\n", &ParseOptions::default());
    assert_eq!(s.errors.len(), 1);
    assert_eq!(m.len(), 2);
}

#[test]
fn sink_error_stops_parsing() {
    struct Fussy(u32);
    impl s2g_gcode::MotionSink for Fussy {
        type Error = String;
        fn motion(&mut self, _: &Motion<'_>) -> Result<(), String> {
            self.0 += 1;
            if self.0 == 2 { Err("full".into()) } else { Ok(()) }
        }
    }
    let mut s = Fussy(0);
    let r = parse_str("G0 X1\nG0 X2\nG0 X3\n", &ParseOptions::default(), &mut s);
    assert!(matches!(r, Err(ParseError::Sink(ref m)) if m == "full"), "{r:?}");
    assert_eq!(s.0, 2);
}

#[test]
fn lexing_cases() {
    // (program, expected end points)
    let cases: &[(&str, &[[f64; 3]])] = &[
        ("G0X1Y2Z3", &[[1.0, 2.0, 3.0]]),
        ("g0 x1 y2", &[[1.0, 2.0, 0.0]]),
        ("G 0 X - 5 Y 1 2 . 5", &[[-5.0, 12.5, 0.0]]),
        ("G0 X1. Y.5 Z-.25", &[[1.0, 0.5, -0.25]]),
        ("G0 X+3", &[[3.0, 0.0, 0.0]]),
        ("N10 G0 X1 (comment) Y2 ; tail", &[[1.0, 2.0, 0.0]]),
        ("G0 X1\r\nG0 X2\rG0 X3\n", &[[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]]),
        ("%\nG0 X1\n%\nG0 X9\n", &[[1.0, 0.0, 0.0]]),
        ("/G0 X4\nG0 X5", &[[4.0, 0.0, 0.0], [5.0, 0.0, 0.0]]),
        ("G0 X1\nM2\nG0 X7", &[[1.0, 0.0, 0.0]]),
        ("G0 X0.1234567890123456789", &[[0.123_456_789_012_345_68, 0.0, 0.0]]),
    ];
    for (text, want) in cases {
        check_ends(text, want);
    }
    // A correct RepRap checksum.
    let body = "N3 G0 X2";
    let sum = body.bytes().fold(0u8, |a, b| a ^ b);
    check_ends(&format!("{body}*{sum}"), &[[2.0, 0.0, 0.0]]);
    // Block delete when enabled.
    let o = ParseOptions { block_delete: true, ..ParseOptions::default() };
    let (_, m) = run("/G0 X4\nG0 X5", &o);
    assert_eq!(m.len(), 1);
    // Comments are reported without delimiters.
    let (_, m) = run("G0 X1 ( hello ) ; world", &ParseOptions::default());
    assert_eq!(m[0].1, Motion::Comment("hello".into()));
    assert_eq!(m[1].1, Motion::Comment("world".into()));
    assert_eq!(m[2].0, 1);
}

#[test]
fn lexing_errors() {
    let o = ParseOptions::default();
    type Case = (&'static str, u64, u32, fn(&GcodeErrorKind) -> bool);
    let cases: &[Case] = &[
        ("G0 X1 X2", 1, 7, |k| matches!(k, GcodeErrorKind::RepeatedWord('X'))),
        ("G0 G1 X1", 1, 4, |k| matches!(k, GcodeErrorKind::ModalConflict(_))),
        ("G0 X1 @", 1, 7, |k| matches!(k, GcodeErrorKind::NotGcode(_))),
        ("G0 X.", 1, 5, |k| matches!(k, GcodeErrorKind::BadNumber(_))),
        ("G1.55 X1", 1, 1, |k| matches!(k, GcodeErrorKind::UnknownCode(_))),
        ("o100 if [1]", 1, 1, |k| matches!(k, GcodeErrorKind::ControlFlow(_))),
        ("N1 G0 X1*99", 1, 9, |k| matches!(k, GcodeErrorKind::BadChecksum { stated: 99, .. })),
        ("\nG0 X[1/0]", 2, 7, |k| matches!(k, GcodeErrorKind::Expression(_))),
        ("G0 X#<nope>", 1, 5, |k| matches!(k, GcodeErrorKind::UndefinedParameter(n) if n == "nope")),
        ("G0 X[1+2", 1, 9, |k| matches!(k, GcodeErrorKind::Expression(_))),
        ("X1", 1, 1, |k| matches!(k, GcodeErrorKind::AxisWordsWithoutMotion)),
    ];
    for (text, line, col, pred) in cases {
        let (l, c, k) = first_error(text, &strict());
        assert_eq!((l, c), (*line, *col), "{text:?}: {k:?}");
        assert!(pred(&k), "{text:?}: {k:?}");
        if text.starts_with('X') {
            continue;
        }
        let (l, c, k) = first_error(text, &o);
        assert_eq!((l, c), (*line, *col), "{text:?}: {k:?}");
        assert!(pred(&k), "{text:?}: {k:?}");
    }
}

#[test]
fn modal_cases() {
    let cases: &[(&str, &[[f64; 3]])] = &[
        // G91 incremental.
        ("G91 G0 X1 Y1\nX1\nG90 X0", &[[1.0, 1.0, 0.0], [2.0, 1.0, 0.0], [0.0, 1.0, 0.0]]),
        // G20: everything in mm.
        ("G20 G0 X1 Y-0.5", &[[25.4, -12.7, 0.0]]),
        ("G20 G91 G0 X1\nG21 X1", &[[25.4, 0.0, 0.0], [26.4, 0.0, 0.0]]),
        // G92: the current point becomes the given coordinates.
        ("G0 X10\nG92 X0\nG0 X5\nG92.1\nG0 X0", &[[10.0, 0.0, 0.0], [5.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
        // G10 L2 + G55, then back to G54; G53 machine coordinates.
        (
            "G10 L2 P2 X100 Y50\nG55 G0 X1 Y1\nG53 G0 X0 Y0\nG54 G0 X1",
            &[[1.0, 1.0, 0.0], [-100.0, -50.0, 0.0], [1.0, 0.0, 0.0]],
        ),
        // G10 L20: the current point becomes X0 in G54.
        ("G0 X7\nG10 L20 P1 X0\nG0 Y1", &[[7.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
        // G28 to the stored home (#5161..), G28 with an intermediate point.
        (
            "G0 X5 Y5\nG28.1\nG0 X0 Y0\nG28",
            &[[5.0, 5.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 5.0, 0.0]],
        ),
        // Explicit G0/G1 without axes still produce a (zero-length) move, as rs274 does.
        ("G0 X1\nG0\nF100\nG1", &[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]),
    ];
    for (text, want) in cases {
        check_ends(text, want);
    }
}

#[test]
fn state_motions() {
    let (s, m) = run("T3 M6\nS1200 M3\nM8\nG4 P1.5\nM5 M9\nM30", &ParseOptions::default());
    assert!(s.errors.is_empty());
    let m: Vec<_> = m.into_iter().map(|x| x.1).collect();
    use s2g_gcode::{Coolant, SpindleDirection};
    assert_eq!(
        m,
        vec![
            Motion::ToolChange { tool: 3 },
            Motion::Spindle { rpm: 1200.0, direction: SpindleDirection::Clockwise },
            Motion::Coolant(Coolant::Flood),
            Motion::Dwell { seconds: 1.5 },
            Motion::Spindle { rpm: 1200.0, direction: SpindleDirection::Off },
            Motion::Coolant(Coolant::Off),
            Motion::End,
        ]
    );
    assert_eq!(s.program_end, Some(6));
}

fn arc_of(text: &str) -> (Point3<f64>, Point3<f64>, Plane, ArcDirection, u32) {
    let m = moves(text);
    match m.last() {
        Some(Motion::Arc { to, center, plane, direction, turns, .. }) => {
            (*to, *center, *plane, *direction, *turns)
        }
        other => panic!("{text:?}: expected an arc, got {other:?}"),
    }
}

#[test]
fn arc_cases() {
    use ArcDirection::{Clockwise as Cw, CounterClockwise as Ccw};
    // (program, end, centre, plane, direction, extra turns)
    type Case = (&'static str, [f64; 3], [f64; 3], Plane, ArcDirection, u32);
    let cases: &[Case] = &[
        ("G0 X10 Y0\nG3 X0 Y10 I-10 J0 F100", [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], Plane::XY, Ccw, 0),
        ("G0 X10 Y0\nG2 X0 Y-10 I-10 F100", [0.0, -10.0, 0.0], [0.0, 0.0, 0.0], Plane::XY, Cw, 0),
        // R form: minor arc with R>0, major arc with R<0.
        ("G0 X10\nG3 X0 Y10 R10 F100", [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], Plane::XY, Ccw, 0),
        ("G0 X10\nG3 X0 Y10 R-10 F100", [0.0, 10.0, 0.0], [10.0, 10.0, 0.0], Plane::XY, Ccw, 0),
        ("G0 X10\nG2 X0 Y10 R10 F100", [0.0, 10.0, 0.0], [10.0, 10.0, 0.0], Plane::XY, Cw, 0),
        // Full circle, helix with extra turns.
        ("G0 X10\nG2 X10 Y0 I-10 F100", [10.0, 0.0, 0.0], [0.0, 0.0, 0.0], Plane::XY, Cw, 0),
        ("G0 X10\nG3 X10 Y0 Z-3 I-10 P3 F100", [10.0, 0.0, -3.0], [0.0, 0.0, 0.0], Plane::XY, Ccw, 2),
        // Planes.
        ("G18 G0 X0 Z20\nG2 X20 Z0 I0 K-20 F200", [20.0, 0.0, 0.0], [0.0, 0.0, 0.0], Plane::ZX, Cw, 0),
        ("G19 G0 Y5\nG3 Y0 Z5 J-5 F200", [0.0, 0.0, 5.0], [0.0, 0.0, 0.0], Plane::YZ, Ccw, 0),
        // G90.1 absolute centre, G91 incremental end, G20.
        ("G90.1 G0 X10\nG3 X0 Y10 I0 J0 F100", [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], Plane::XY, Ccw, 0),
        ("G91 G0 X10\nG3 X-10 Y10 I-10 F100", [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], Plane::XY, Ccw, 0),
        ("G20 G0 X1\nG3 X0 Y1 I-1 F4", [0.0, 25.4, 0.0], [0.0, 0.0, 0.0], Plane::XY, Ccw, 0),
    ];
    for (text, to, center, plane, dir, turns) in cases {
        let (t, c, p, d, n) = arc_of(text);
        close(t, *to, text);
        close(c, *center, text);
        assert_eq!((p, d, n), (*plane, *dir, *turns), "{text:?}");
    }
}

#[test]
fn arc_errors_like_linuxcnc() {
    let o = ParseOptions::default();
    // End point 0.5 mm off the circle of radius 10: beyond LinuxCNC's tolerance.
    let (l, _, k) = first_error("G0 X10\nG3 X0 Y10.5 I-10 F100", &o);
    assert_eq!(l, 2);
    assert!(matches!(k, GcodeErrorKind::ArcRadiusMismatch { .. }), "{k:?}");
    // 0.005 mm off: accepted (relative error 0.05 % and absolute below 0.028 mm).
    assert_eq!(ends("G0 X10\nG3 X0 Y10.005 I-10 F100").len(), 2);
    // R too small to reach the end point.
    let (_, _, k) = first_error("G0 X0\nG2 X10 R4 F100", &strict());
    assert!(matches!(k, GcodeErrorKind::ArcRadiusTooSmall { .. }), "{k:?}");
    // R arc ending at its start.
    let (_, _, k) = first_error("G0 X1\nG2 X1 R4 F100", &strict());
    // Lenient fallbacks: a half circle, and no move.
    let (s, m) = run("G0 X0\nG2 X10 R4 F100\nG2 X10 R4", &o);
    assert!(s.errors.is_empty() && s.warnings.len() == 2, "{:?}", s.warnings);
    assert_eq!(m.len(), 2);
    assert!(matches!(k, GcodeErrorKind::ArcDegenerate(_)), "{k:?}");
    // Strict LinuxCNC: no centre and no feed are errors; lenient: warnings.
    let (_, _, k) = first_error("G0 X1\nG2 X3 Y1 F10", &strict());
    assert_eq!(k, GcodeErrorKind::ArcMissingCenter);
    let (_, _, k) = first_error("G1 X3", &strict());
    assert!(matches!(k, GcodeErrorKind::ZeroFeed(_)), "{k:?}");
    // No centre is an error in Auto too (as in `rs274`), at the first axis word; a
    // warning and a straight move once the program is an FDM one.
    let (s, m) = run("G1 X3\nG2 X3 Y1", &o);
    assert_eq!(s.errors.len(), 1, "{:?}", s.errors);
    assert_eq!(
        (s.errors[0].line, s.errors[0].column, &s.errors[0].kind),
        (2, 1, &GcodeErrorKind::ArcMissingCenter)
    );
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert_eq!(m.len(), 1);
    let (s, m) = run("M83\nG1 X3 E1 F100\nG2 X3 Y1", &o);
    assert!(s.errors.is_empty() && s.warnings.len() == 1, "{:?} {:?}", s.errors, s.warnings);
    assert_eq!(m.len(), 2);
    // Exponent notation: an E word glued to a number is an error before any printer
    // evidence (rs274 rejects the E word), at the E; an E word after one is extrusion.
    for opts in [o.clone(), strict()] {
        let (l, c, k) = first_error("G21 F100\nG1 X1e999\n", &opts);
        assert_eq!((l, c), (2, 6), "{k:?}");
        assert!(matches!(k, GcodeErrorKind::NotGcode(m) if m.starts_with("E word")));
    }
    let (s, m) = run("M82\nG1 X1E5 F100\n", &o);
    assert!(s.errors.is_empty() && m.len() == 1, "{:?}", s.errors);
}

#[test]
fn canned_cycles_match_hand_expansion() {
    // Hand-expanded from LinuxCNC's convert_cycle_xy rules (and checked against rs274 in rs274.rs).
    let r = |x: f64, y: f64, z: f64| ('r', [x, y, z]);
    let f = |x: f64, y: f64, z: f64| ('f', [x, y, z]);
    type Case<'a> = (&'a str, Vec<(char, [f64; 3])>);
    let cases: Vec<Case<'_>> = vec![
        // G81, default G99 (retract to R), then a modal repeat at X3.
        (
            "G0 Z5\nG81 X1 Y1 Z-2 R1 F100\nX3",
            vec![
                r(0., 0., 5.),
                r(1., 1., 5.),
                r(1., 1., 1.),
                f(1., 1., -2.),
                r(1., 1., 1.),
                r(3., 1., 1.),
                f(3., 1., -2.),
                r(3., 1., 1.),
            ],
        ),
        // G98: retract to the initial level.
        (
            "G0 Z5\nG98 G81 X1 Y1 Z-2 R1 F100",
            vec![r(0., 0., 5.), r(1., 1., 5.), r(1., 1., 1.), f(1., 1., -2.), r(1., 1., 5.)],
        ),
        // G91 with L3: R and Z relative to the initial level, XY steps repeated.
        (
            "G0 Z5\nG91 G81 X1 Z-2 R-3 L2 F100",
            vec![
                r(0., 0., 5.),
                r(1., 0., 5.),
                r(1., 0., 2.),
                f(1., 0., 0.),
                r(1., 0., 2.),
                r(2., 0., 2.),
                f(2., 0., 0.),
                r(2., 0., 2.),
            ],
        ),
        // G83 peck with full retract to R, rapid back to 0.254 mm above the last depth.
        (
            "G0 Z5\nG83 X5 Y5 Z-1.5 R2 Q1.2 F100",
            vec![
                r(0., 0., 5.),
                r(5., 5., 5.),
                r(5., 5., 2.),
                f(5., 5., 0.8),
                r(5., 5., 2.),
                r(5., 5., 1.054),
                f(5., 5., -0.4),
                r(5., 5., 2.),
                r(5., 5., -0.146),
                f(5., 5., -1.5),
                r(5., 5., 2.),
            ],
        ),
        // G73 chip breaking.
        (
            "G0 Z5\nG73 X6 Z-1 R1 Q0.7 F100",
            vec![
                r(0., 0., 5.),
                r(6., 0., 5.),
                r(6., 0., 1.),
                f(6., 0., 0.3),
                r(6., 0., 0.554),
                f(6., 0., -0.4),
                r(6., 0., -0.146),
                f(6., 0., -1.),
                r(6., 0., 1.),
            ],
        ),
    ];
    for (text, want) in cases {
        let got = moves(text);
        let got: Vec<(char, [f64; 3])> = got
            .iter()
            .map(|m| match m {
                Motion::Rapid { to } => ('r', to.coords.into()),
                Motion::Linear { to, .. } => ('f', to.coords.into()),
                other => panic!("{text:?}: unexpected {other:?}"),
            })
            .collect();
        assert_eq!(got.len(), want.len(), "{text:?}: {got:?}");
        for (g, w) in got.iter().zip(&want) {
            assert_eq!(g.0, w.0, "{text:?}: {got:?}");
            close(Point3::from(g.1), w.1, text);
        }
    }
    // G82 dwells at the bottom.
    let (_, m) = run("G0 Z5\nG82 X1 Z-1 R1 P0.5 F100", &ParseOptions::default());
    assert!(m.iter().any(|x| x.1 == Motion::Dwell { seconds: 0.5 }));
    // Missing R on entry, R below Z, non-positive Q.
    let o = ParseOptions::default();
    assert!(matches!(first_error("G81 X1 Z-1 F1", &o).2, GcodeErrorKind::MissingWord { letter: 'R', .. }));
    assert!(matches!(first_error("G81 X1 Z1 R0 F1", &o).2, GcodeErrorKind::CannedCycle(_)));
    assert!(matches!(first_error("G83 X1 Z-1 R1 Q0 F1", &o).2, GcodeErrorKind::CannedCycle(_)));
}

#[test]
fn expressions_and_parameters() {
    let cases: &[(&str, f64)] = &[
        ("G0 X[1+2*3]", 7.0),
        ("G0 X[2**3**2]", 64.0),
        ("G0 X[[1+2]*3]", 9.0),
        ("G0 X[7 MOD 3]", 1.0),
        ("G0 X[-7 MOD 3]", 2.0),
        ("G0 X[1 EQ 1]", 1.0),
        ("G0 X[2 GT 3 OR 1 LT 2]", 1.0),
        ("G0 X[1 AND 0]", 0.0),
        ("G0 X[1 XOR 1]", 0.0),
        ("G0 X[3 GE 3] ", 1.0),
        ("G0 XSIN[90]", 1.0),
        ("G0 X[COS[180]]", -1.0),
        ("G0 XATAN[1]/[1]", 45.0),
        ("G0 X[ABS[-2.5]]", 2.5),
        ("G0 X[SQRT[16]+EXP[0]+LN[1]]", 5.0),
        ("G0 X[ROUND[2.5]+FIX[-1.5]+FUP[1.2]]", 3.0),
        ("G0 X[ACOS[0]+ASIN[1]]", 180.0),
        ("G0 X[TAN[45]]", 1.0),
        ("#1=5\nG0 X#1", 5.0),
        ("#<Depth> = 2.5\nG0 X#<depth>", 2.5),
        ("#<_global>=4\nG0 X[#<_global>*2]", 8.0),
        ("#2=3\n#3=2\nG0 X##3", 3.0),
        ("#<a>=1\nG0 X[EXISTS[#<a>]+EXISTS[#<b>]]", 1.0),
        // Assignments take effect after the line's reads (LinuxCNC).
        ("#3=15\n#3=6 G0 X#3", 15.0),
        ("#3=15\n#3=6\nG0 X#3", 6.0),
        ("G0 X-[1+1]", -2.0),
    ];
    for (text, x) in cases {
        let m = moves(text);
        let got = m.last().and_then(Motion::end_point).expect("move").x;
        assert!((got - x).abs() < 1e-9, "{text:?}: got {got}, want {x}");
    }
}

#[test]
fn fdm_features() {
    let o = ParseOptions::default();
    // Absolute E, G92 E0 reset, relative E with M83, retraction, G10/G11.
    let text =
        "M82\nG92 E0\nG1 X1 E1 F600\nG1 X2 E3\nG92 E0\nG1 X3 E0.5\nG1 E-0.8\nM83\nG1 X4 E0.2\nG10\nG11\n";
    let (s, m) = run(text, &o);
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    let ex: Vec<f64> = m
        .iter()
        .filter_map(|x| match &x.1 {
            Motion::Linear { extrude, .. } => *extrude,
            _ => None,
        })
        .collect();
    let want = [1.0, 2.0, 0.5, -1.3, 0.2, -1.0, 1.0];
    assert_eq!(ex.len(), want.len(), "{ex:?}");
    for (a, b) in ex.iter().zip(want) {
        assert!((a - b).abs() < 1e-12, "{ex:?}");
    }
    // G4 P in milliseconds once FDM codes appeared; G28 homes.
    let (_, m) = run("M83\nG4 P500\nG0 X5 Y5\nG28 X", &o);
    assert!(m.iter().any(|x| x.1 == Motion::Dwell { seconds: 0.5 }));
    close(m.last().and_then(|x| x.1.end_point()).expect("home"), [0.0, 5.0, 0.0], "G28 X");
    // Slicer markers.
    let text = ";LAYER:3\n;LAYER_CHANGE\n;Z:0.4\n;HEIGHT:0.2\n;TYPE:Perimeter\nG1 Z0.6 F100 ; move to next layer (7)\n";
    let (_, m) = run(text, &o);
    let marks: Vec<Motion<'_>> = m.into_iter().map(|x| x.1).collect();
    assert_eq!(marks[0], Motion::Marker(Marker::Layer { index: Some(3), z: None }));
    assert_eq!(marks[1], Motion::Marker(Marker::Layer { index: None, z: Some(0.4) }));
    assert_eq!(marks[2], Motion::Comment("HEIGHT:0.2".into()));
    assert_eq!(marks[3], Motion::Marker(Marker::Type("Perimeter".into())));
    assert_eq!(marks[4], Motion::Marker(Marker::Layer { index: Some(7), z: Some(0.6) }));
}

#[test]
fn hostile_inputs_do_not_panic() {
    let o = ParseOptions::default();
    let inputs = [
        "G0 X[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[1]",
        "G0 X99999999999999999999999999999999999999999999",
        "G0 X1e400",
        "#5602=1",
        "#0=1",
        "G0 X#-1",
        "G3 X1 P99999999999999 I1 F1",
        "G81 X1 Z-1 R1 L999999999 F1",
        "G83 X1 Z-100000000 R1 Q0.000000001 F1",
        "G2 I0 J0 X0 F1",
        "\u{0}\u{1}\u{ff}",
        "T-1 M6",
        "S-5",
        "G0 X1 *",
        "G10 L2 P99 X1",
        "M61 Q-1",
        "G0 XATAN[1]",
        "/",
        "  /  ",
        "G0 X[1 ** 0.5 ** -1]",
        "G0 X[-8 ** 0.5]",
    ];
    for t in inputs {
        let mut st = Stats::default();
        let r = parse_str(t, &o, &mut st);
        assert!(r.is_ok(), "{t:?}");
    }
    // Found by the fuzzer: a modal peck cycle with huge L and R expanded to 552 million
    // moves. The expansion is now capped and reported.
    let t = "G0 Z1\nG83 X1 Z-1 R1 Q0.11 F1\nX2 L90000 R810\nX3";
    let (s, m) = run(t, &o);
    assert_eq!(s.errors.len(), 1, "{:?}", s.errors);
    assert_eq!(s.errors[0].line, 3);
    assert!(matches!(s.errors[0].kind, GcodeErrorKind::CannedCycle(_)));
    assert!(m.len() < 200, "{} motions", m.len());
}

/// End points of a program's moves, with their lines, through [`parse_str`], the reader
/// and the two-stage path (which must agree).
fn flow_moves(text: &str, opts: &ParseOptions) -> (ParseSummary, Vec<(u64, [f64; 3])>) {
    let (s, m) = run(text, opts);
    let got: Vec<(u64, [f64; 3])> =
        m.iter().filter_map(|(l, x)| x.end_point().map(|p| (*l, p.coords.into()))).collect();
    let mut b = MotionRecorder::default();
    let r = std::io::BufReader::with_capacity(5, text.as_bytes());
    let sb = parse_reader(r, opts, &mut b).expect("reader");
    assert_eq!(m, b.motions, "{text:?}: reader");
    assert_eq!((&s.errors, s.lines), (&sb.errors, sb.lines), "{text:?}: reader");
    for chunk in [1, 7, 64] {
        let mut c = MotionRecorder::default();
        let sc = s2g_gcode::parse_str_two_stage(text, opts, &mut c, chunk).expect("two stages");
        assert_eq!(m, c.motions, "{text:?}: two stages, chunks of {chunk}");
        assert_eq!((&s.errors, s.lines), (&sc.errors, sc.lines), "{text:?}: two stages");
    }
    (s, got)
}

#[test]
fn o_word_control_flow() {
    let o = ParseOptions::default();
    let xs = |v: &[(u64, [f64; 3])]| v.iter().map(|(_, p)| p[0]).collect::<Vec<_>>();
    // A while loop that runs three times gives three moves, on the loop's line.
    let (s, m) = flow_moves("G0 X9\n#1=0\no1 while [#1 LT 3]\nG0 X#1\n#1=[#1+1]\no1 endwhile\nG0 X7\n", &o);
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    assert_eq!(xs(&m), [9.0, 0.0, 1.0, 2.0, 7.0]);
    assert_eq!(m.iter().map(|x| x.0).collect::<Vec<_>>(), [1, 4, 4, 4, 7]);
    assert_eq!(s.lines, 7);
    // Nested subroutines with positional parameters, local to each call; return values.
    let text = "o<inner> sub\nG0 X[#1 + #2]\no<inner> return [#1 * 10]\no<inner> endsub\n\
                o<outer> sub\n#<loc> = 3\no<inner> call [#1] [#<loc>]\nG0 Y#<_value>\nG0 Z#1\no<outer> endsub\n\
                #1 = 100\no<outer> call [2]\nG0 X#1\n";
    let (s, m) = flow_moves(text, &o);
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    let want = [[5.0, 0.0, 0.0], [5.0, 20.0, 0.0], [5.0, 20.0, 2.0], [100.0, 20.0, 2.0]];
    assert_eq!(m.iter().map(|x| x.1).collect::<Vec<_>>(), want);
    // A local named parameter of a sub is gone after it; a global one stays.
    let (s, _) = flow_moves("o1 sub\n#<l> = 1\n#<_g> = 2\no1 endsub\no1 call\nG0 X#<_g>\nG0 X#<l>\n", &o);
    assert_eq!(s.errors.len(), 1, "{:?}", s.errors);
    assert!(matches!(&s.errors[0].kind, GcodeErrorKind::UndefinedParameter(n) if n == "l"), "{:?}", s.errors);
    assert_eq!(s.errors[0].line, 7);
    // if / elseif / else picks the right branch.
    for (v, want) in [(1.0, 10.0), (2.0, 20.0), (3.0, 30.0)] {
        let text = format!(
            "#<v> = {v}\no5 if [#<v> EQ 1]\nG0 X10\no5 elseif [#<v> EQ 2]\nG0 X20\no5 else\nG0 X30\no5 endif\nG0 Y1\n"
        );
        let (s, m) = flow_moves(&text, &o);
        assert!(s.errors.is_empty(), "{:?}", s.errors);
        assert_eq!(xs(&m), [want, want], "{text}");
    }
    // repeat, break and continue (X3 skipped, stop after X5), do-while.
    let text = "#1 = 0\no2 repeat [10]\n#1 = [#1 + 1]\no3 if [#1 EQ 3]\no2 continue\no3 endif\n\
                o4 if [#1 GT 5]\no2 break\no4 endif\nG0 X#1\no2 endrepeat\n\
                o6 do\nG0 Y#1\n#1 = [#1 - 2]\no6 while [#1 GT 0]\n";
    let (s, m) = flow_moves(text, &o);
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    assert_eq!(xs(&m), [1.0, 2.0, 4.0, 5.0, 5.0, 5.0, 5.0]);
    assert_eq!(m[4..].iter().map(|x| x.1[1]).collect::<Vec<_>>(), [6.0, 4.0, 2.0]);
    // repeat [0] runs nothing; a while loop's continue re-tests the condition.
    let (_, m) = flow_moves(
        "o1 repeat [0]\nG0 X1\no1 endrepeat\n#1=0\no2 while [#1 LT 2]\n#1=[#1+1]\no2 continue\nG0 X9\no2 endwhile\nG0 Y1\n",
        &o,
    );
    assert_eq!(m.iter().map(|x| x.1).collect::<Vec<_>>(), [[0.0, 1.0, 0.0]]);
    // A loop that never ends stops at the step limit, with a typed error at the line.
    let lim = ParseOptions { max_steps: 1000, ..ParseOptions::default() };
    let (s, m) = flow_moves("G0 X1\no9 while [1]\nG0 X2\no9 endwhile\nG0 X3\n", &lim);
    assert_eq!(s.errors.len(), 1, "{:?}", s.errors);
    assert_eq!(s.errors[0].kind, GcodeErrorKind::StepLimit(1000));
    assert!((2..=4).contains(&s.errors[0].line), "{:?}", s.errors);
    assert!(m.len() > 100 && m.len() < 1000 && m.iter().all(|x| x.1[0] != 3.0));
    // Unbounded recursion stops at the call depth limit.
    let (s, _) = flow_moves("o1 sub\no1 call\no1 endsub\no1 call\n", &o);
    assert!(
        matches!(&s.errors[0].kind, GcodeErrorKind::ControlFlow(m) if m.contains("nested")),
        "{:?}",
        s.errors
    );
    // Calling an undefined subroutine: an error at the O (line and column).
    let (l, c, k) = first_error("G0 X1\n  o<nope> call [1]\n", &o);
    assert_eq!((l, c), (2, 3));
    assert!(matches!(k, GcodeErrorKind::ControlFlow(m) if m.contains("o<nope>")));
    // Polar words, alone and in a G91 bolt circle, read the same by every driver.
    let (s, m) = flow_moves("G21 F100\nG0 @2 ^90\nG91 G81 R1 Z-1 ^90 L4\n", &o);
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    let holes: Vec<[f64; 2]> =
        m.iter().filter(|x| x.0 == 3 && x.1[2] == 0.0).map(|x| [x.1[0], x.1[1]]).collect();
    let want = [[-2.0, 0.0], [0.0, -2.0], [2.0, 0.0], [0.0, 2.0]];
    assert_eq!(holes.len(), 4, "{m:?}");
    for (h, w) in holes.iter().zip(want) {
        assert!((h[0] - w[0]).abs() < 1e-9 && (h[1] - w[1]).abs() < 1e-9, "{holes:?}");
    }
    // The read-only position parameters follow the moves of a loop.
    let (s, m) = flow_moves("G21\no1 while [#5420 LT 3]\nG91 G0 X[#<_x> + 1]\no1 endwhile\n", &o);
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    assert_eq!(xs(&m), [1.0, 3.0]);
    // Strict mode runs the same.
    let (s, m) = flow_moves("o1 repeat [2]\nG0 X1\no1 endrepeat\n", &strict());
    assert!(s.errors.is_empty() && m.len() == 2, "{:?}", s.errors);
}

#[test]
fn o_word_subroutines_from_the_search_path() {
    let dir = tempfile::tempdir().expect("tempdir");
    let sub = "(square)\no<sq> sub\no<half> call [#1]\nG0 X[#1 * #1] Y#<_value>\no<sq> endsub\n";
    std::fs::write(dir.path().join("sq.ngc"), sub).expect("write");
    std::fs::write(dir.path().join("half.ngc"), "o<half> sub\no<half> return [#1 / 2]\no<half> endsub\n")
        .expect("write");
    let text = "G21\no<sq> call [3]\nG0 Z1\nM2\n";
    // Without a search path: an error at the call, the program ends there.
    let (s, m) = run(text, &ParseOptions::default());
    assert_eq!((s.errors.len(), s.errors[0].line, m.len()), (1, 2, 0), "{:?}", s.errors);
    // With one: both files are found (the second called from the first).
    let o = ParseOptions {
        subroutine_path: vec![dir.path().join("nope"), dir.path().into()],
        ..ParseOptions::default()
    };
    let (s, m) = flow_moves(text, &o);
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    assert_eq!(m.iter().map(|x| x.1).collect::<Vec<_>>(), [[9.0, 1.5, 0.0], [9.0, 1.5, 1.0]]);
    assert_eq!(s.lines, 4);
}

#[test]
fn lathe_cycles() {
    // A roughing cycle whose passes never end (`rs274` loops for ever on it): refused with
    // an error, at the line that ends its profile as `rs274` reports the cycle's errors,
    // none of its passes made; the program goes on.
    let endless = "G18 G21 F100\nG0 X9.797 Z2.344\nO100 SUB\nG0 X1.219 Z1.006\nG1 X5.031 Z1.006\n\
                   G1 X6.600 Z0.103\nG1 X7.600 Z0.103\nO100 ENDSUB\nG71 Q100 X8.797 Z1.344 D0.480 I1.104 R0.464\n\
                   G0 X10.797\nM2\n";
    let (s, m) = run(endless, &ParseOptions::default());
    let e = s.errors.first().expect("an error");
    assert_eq!(e.line, 8, "{e}");
    assert!(matches!(&e.kind, GcodeErrorKind::CannedCycle(w) if w.contains("never end")), "{e}");
    let lines: Vec<u64> =
        m.iter().filter(|(_, m)| matches!(m, Motion::Rapid { .. })).map(|(l, _)| *l).collect();
    // The rapid before, the cycle's rapid to its start, the rapid after.
    assert_eq!(lines, [2, 9, 10]);

    // A finishing pass: its moves are the cycle line's, and it ends at the profile's end.
    let g70 = "G18 G21 F100\nG0 X20 Z5\nO100 SUB\nG0 X2 Z2\nG1 Z0\nG1 X8 Z-10\nG1 X12\nO100 ENDSUB\n\
               G70 Q100 X15 Z4\nM2\n";
    let (s, m) = run(g70, &strict());
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    let cycle: Vec<&Motion<'_>> = m.iter().filter(|(l, _)| *l == 9).map(|(_, m)| m).collect();
    assert_eq!(cycle.len(), 6, "{cycle:?}");
    match cycle.last() {
        Some(Motion::Linear { to, .. }) => close(*to, [12.0, 0.0, -10.0], "last G70 feed"),
        other => panic!("{other:?}"),
    }

    // Without Q: strict LinuxCNC wants it; lenient reads old Fanuc G70 (inch).
    let (_, _, kind) = first_error("G18 G21\nG70 X1 Z1\nM2\n", &strict());
    assert!(matches!(kind, GcodeErrorKind::MissingWord { letter: 'Q', .. }), "{kind:?}");
    let (s, m) = run("G70\nG0 X1\nM2\n", &ParseOptions::default());
    assert!(s.errors.is_empty(), "{:?}", s.errors);
    match m.iter().find(|(_, m)| matches!(m, Motion::Rapid { .. })) {
        Some((_, Motion::Rapid { to })) => close(*to, [25.4, 0.0, 0.0], "G70 as inch"),
        other => panic!("{other:?}"),
    }
}

/// Inputs the fuzzer found in the lathe cycles (fuzz/seeds/parse/lathe_fuzz_regression*.ngc:
/// control bytes, profiles with an arc whose centre cannot be, cycles calling missing
/// profiles), read with the fuzz target's options: early versions sent moves to
/// non-finite points. Every line is read and every end point is finite, in both modes.
#[test]
fn lathe_cycle_fuzz_inputs_move_to_finite_points() {
    let inputs: [&[u8]; 2] = [
        include_bytes!("../../../fuzz/seeds/parse/lathe_fuzz_regression.ngc"),
        include_bytes!("../../../fuzz/seeds/parse/lathe_fuzz_regression2.ngc"),
    ];
    for (k, bytes) in inputs.into_iter().enumerate() {
        let text = String::from_utf8_lossy(bytes);
        let lines = text.split_terminator('\n').count() as u64;
        for dialect in [ParseDialect::Auto, ParseDialect::Cnc] {
            let opts = ParseOptions {
                dialect,
                rotary: Some(RotaryAxes::BC),
                stop_at_program_end: false,
                max_steps: 500,
                tool_diameters: (1..10).map(|t| (t, t as f64 * 0.5)).collect(),
                ..ParseOptions::default()
            };
            let (s, m) = run(&text, &opts);
            assert_eq!(s.lines, lines, "input {k}, {dialect:?}");
            for (line, motion) in &m {
                let finite = motion.end_point().is_none_or(|p| p.iter().all(|v| v.is_finite()));
                assert!(finite, "input {k}, {dialect:?}: line {line}: {motion:?}");
            }
        }
    }
}
