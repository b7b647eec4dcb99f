//! Writer tests: arc fitting, LinuxCNC output checked by the reference interpreter
//! `rs274`, and proptest round trips through our own parser.

use std::borrow::Cow;
use std::f64::consts::{PI, TAU};
use std::path::Path;
use std::process::Command;

use nalgebra::{Isometry3, Point3, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use s2g_gcode::{
    ArcDirection, ArcFitOptions, ArcFitter, ArcSpec, Coolant, Dialect, GcodeWriter, Motion, MotionRecorder,
    MotionSink, Plane, SpindleDirection, WriterOptions, linearize_arc, plane_axes, write_program,
};

// ---------------------------------------------------------------------------
// Random programs.

/// One generated step; turned into motions by [`build`], which tracks the position
/// so that arcs start on their circle.
#[derive(Debug, Clone)]
enum Op {
    Rapid([f64; 3]),
    Linear([f64; 3], f64),
    /// plane, ccw, radius, angle of the centre seen from the start, sweep (0 = full circle), helix dz, turns, feed
    Arc(u8, bool, f64, f64, f64, f64, u32, f64),
    Tool(u32),
    Spindle(f64, u8),
    Coolant(u8),
    Dwell(f64),
    Comment(String),
}

fn coord() -> impl Strategy<Value = f64> {
    -100.0..100.0f64
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        3 => [coord(), coord(), coord()].prop_map(Op::Rapid),
        4 => ([coord(), coord(), coord()], 10.0..5000.0f64).prop_map(|(p, f)| Op::Linear(p, f)),
        4 => (
            0u8..3,
            any::<bool>(),
            0.5..50.0f64,
            0.0..TAU,
            prop_oneof![Just(0.0), 0.2..(TAU - 0.2)],
            prop_oneof![Just(0.0), -5.0..5.0f64],
            prop_oneof![4 => Just(0u32), 1 => 1u32..3],
            10.0..3000.0f64,
        )
            .prop_map(|(pl, ccw, r, phi, sweep, dz, turns, f)| Op::Arc(pl, ccw, r, phi, sweep, dz, turns, f)),
        1 => (1u32..20).prop_map(Op::Tool),
        1 => (100u32..20000, 0u8..3).prop_map(|(s, d)| Op::Spindle(s as f64, d)),
        1 => (0u8..3).prop_map(Op::Coolant),
        1 => (0u32..10_000).prop_map(|ms| Op::Dwell(ms as f64 / 1000.0)),
        1 => "[a-zA-Z0-9][a-zA-Z0-9 ]{0,20}[a-zA-Z0-9]".prop_map(Op::Comment),
    ]
}

/// Motions of `ops`, starting with a rapid so that every arc has a start.
fn build(ops: &[Op]) -> Vec<Motion<'static>> {
    let mut p = Point3::new(1.0, 2.0, 3.0);
    let mut out = vec![Motion::Rapid { to: p }];
    for op in ops {
        match op.clone() {
            Op::Rapid(q) => {
                p = q.into();
                out.push(Motion::Rapid { to: p });
            }
            Op::Linear(q, feed) => {
                p = q.into();
                out.push(Motion::Linear { to: p, feed, extrude: None });
            }
            Op::Arc(pl, ccw, r, phi, sweep, dz, turns, feed) => {
                let plane = [Plane::XY, Plane::ZX, Plane::YZ][pl as usize];
                let (u, v, w) = plane_axes(plane);
                let mut center = p;
                center[u] += r * phi.cos();
                center[v] += r * phi.sin();
                let a0 = (p[v] - center[v]).atan2(p[u] - center[u]);
                let a1 = if ccw { a0 + sweep } else { a0 - sweep };
                let mut to = p;
                if sweep != 0.0 {
                    to[u] = center[u] + r * a1.cos();
                    to[v] = center[v] + r * a1.sin();
                }
                to[w] += dz;
                let direction = if ccw { ArcDirection::CounterClockwise } else { ArcDirection::Clockwise };
                out.push(Motion::Arc { to, center, plane, direction, turns, feed, extrude: None });
                p = to;
            }
            Op::Tool(t) => out.push(Motion::ToolChange { tool: t }),
            Op::Spindle(rpm, d) => out.push(Motion::Spindle {
                rpm,
                direction: [
                    SpindleDirection::Clockwise,
                    SpindleDirection::CounterClockwise,
                    SpindleDirection::Off,
                ][d as usize],
            }),
            Op::Coolant(c) => {
                out.push(Motion::Coolant([Coolant::Mist, Coolant::Flood, Coolant::Off][c as usize]))
            }
            Op::Dwell(s) => out.push(Motion::Dwell { seconds: s }),
            Op::Comment(c) => out.push(Motion::Comment(Cow::Owned(c))),
        }
    }
    out
}

fn program() -> impl Strategy<Value = Vec<Motion<'static>>> {
    prop::collection::vec(op(), 1..40).prop_map(|ops| build(&ops))
}

fn seeded(cases: u32) -> TestRunner {
    let cfg = Config { cases, failure_persistence: None, ..Config::default() };
    TestRunner::new_with_rng(cfg, TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]))
}

// ---------------------------------------------------------------------------
// Arc fitting.

/// Smallest distance from `q` to the path of `motions` started at `start`
/// (arcs densely linearised).
fn path_points(start: Point3<f64>, motions: &[(u64, Motion<'static>)]) -> Vec<Point3<f64>> {
    let mut pts = vec![start];
    let mut p = start;
    for (_, m) in motions {
        if m.end_point().is_none() {
            continue;
        }
        linearize_arc(&p, m, 1e-5, |q| pts.push(q)).expect("valid arc");
        p = m.end_point().unwrap_or(p);
    }
    pts
}

fn dist_to_polyline(q: &Point3<f64>, pts: &[Point3<f64>]) -> f64 {
    pts.windows(2)
        .map(|w| {
            let d = w[1] - w[0];
            let l2 = d.norm_squared();
            let t = if l2 > 0.0 { ((q - w[0]).dot(&d) / l2).clamp(0.0, 1.0) } else { 0.0 };
            (q - (w[0] + d * t)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Feeds `pts` (first = start) through an [`ArcFitter`]; checks the deviation bound
/// at every input point and segment midpoint, and the exact end; returns
/// (compression ratio, arcs written).
fn fit_and_check(name: &str, pts: &[Point3<f64>], extrude: Option<f64>, opts: ArcFitOptions) -> (f64, usize) {
    let mut fitter = ArcFitter::new(MotionRecorder::default(), opts);
    fitter.motion(&Motion::Rapid { to: pts[0] }).expect("infallible");
    for p in &pts[1..] {
        fitter.motion(&Motion::Linear { to: *p, feed: 600.0, extrude }).expect("infallible");
    }
    fitter.finish().expect("infallible");
    let ratio = fitter.compression_ratio();
    let rec = fitter.into_inner();
    let out = &rec.motions[1..];
    let path = path_points(pts[0], out);
    let last = out.last().and_then(|m| m.1.end_point());
    assert_eq!(last, pts.last().copied(), "{name}: end point must be exact");
    let tol = opts.tolerance * 1.000001 + 1e-5;
    for (i, w) in pts.windows(2).enumerate() {
        for q in [w[1], nalgebra::center(&w[0], &w[1])] {
            let d = dist_to_polyline(&q, &path);
            assert!(
                d <= tol,
                "{name}: input point/midpoint {i} ({q}) is {d} from the fitted path (tol {tol})"
            );
        }
    }
    if let Some(e) = extrude {
        let total: f64 = out
            .iter()
            .filter_map(|(_, m)| match m {
                Motion::Linear { extrude, .. } | Motion::Arc { extrude, .. } => *extrude,
                _ => None,
            })
            .sum();
        let want = e * (pts.len() - 1) as f64;
        assert!((total - want).abs() < 1e-9 * want.max(1.0), "{name}: extrusion {total} != {want}");
    }
    let arcs = out.iter().filter(|m| matches!(m.1, Motion::Arc { .. })).count();
    (ratio, arcs)
}

fn circle_points(plane: Plane, c: [f64; 3], r: f64, a0: f64, sweep: f64, n: usize) -> Vec<Point3<f64>> {
    let (u, v, _) = plane_axes(plane);
    (0..=n)
        .map(|i| {
            let a = a0 + sweep * i as f64 / n as f64;
            let mut p = Point3::from(c);
            p[u] += r * a.cos();
            p[v] += r * a.sin();
            p
        })
        .collect()
}

#[test]
fn arc_fitter_recovers_circles() {
    let opts = ArcFitOptions::default();
    for (k, plane) in [Plane::XY, Plane::ZX, Plane::YZ].into_iter().enumerate() {
        for (sweep, n) in [(PI / 2.0, 30), (-1.5 * PI, 120), (TAU * 0.999, 200), (3.0 * PI, 300)] {
            let r = 5.0 + 7.0 * k as f64;
            let pts = circle_points(plane, [3.0, -2.0, 1.5], r, 0.3, sweep, n);
            let name = format!("circle plane {plane:?} r {r} sweep {sweep} n {n}");
            let (ratio, arcs) = fit_and_check(&name, &pts, None, opts);
            assert!(arcs >= 1, "{name}: no arc fitted");
            // Each arc stays below a full turn, so at most ceil(turns) + 1 arcs.
            let max_arcs = (sweep.abs() / TAU).ceil() as usize + 1;
            assert!(arcs <= max_arcs, "{name}: {arcs} arcs");
            let expect = (n + 1) as f64 / (max_arcs + 1) as f64;
            assert!(ratio >= expect, "{name}: ratio {ratio} < {expect}");
        }
    }
}

/// `xy_only` fits the XY plane's circles and leaves the other planes' as lines.
#[test]
fn arc_fitter_xy_only_leaves_vertical_circles_as_lines() {
    let opts = ArcFitOptions { xy_only: true, ..ArcFitOptions::default() };
    for (plane, want) in [(Plane::XY, true), (Plane::ZX, false), (Plane::YZ, false)] {
        let pts = circle_points(plane, [3.0, -2.0, 1.5], 5.0, 0.3, PI / 2.0, 30);
        let (_, arcs) = fit_and_check(&format!("{plane:?}"), &pts, None, opts);
        assert_eq!(arcs > 0, want, "{plane:?}: {arcs} arcs");
    }
}

#[test]
fn arc_fitter_keeps_proportional_extrusion() {
    let pts = circle_points(Plane::XY, [100.0, 100.0, 0.2], 8.0, 0.0, PI, 60);
    let (ratio, arcs) = fit_and_check("extruding half circle", &pts, Some(0.05), ArcFitOptions::default());
    assert_eq!(arcs, 1, "one arc expected");
    assert!(ratio > 20.0, "ratio {ratio}");
}

/// A circle whose odd vertices lie 0.6 tolerance outside and inside it in turn (the even
/// ones on it), as thinned offset rings come: the circle through the first, middle (odd)
/// and last vertices deviates by 1.2 tolerances, the best centre on the ends' bisector by
/// 0.6, so the run is one arc.
#[test]
fn arc_fitter_finds_the_circle_of_vertices_off_it() {
    let opts = ArcFitOptions { tolerance: 0.005, xy_only: true, ..ArcFitOptions::default() };
    for (r, n) in [(6.0, 42), (25.0, 102), (2.0, 26)] {
        let mut pts = circle_points(Plane::XY, [1.0, -3.0, 4.0], r, 0.2, 0.5 * PI, n);
        for (i, p) in pts.iter_mut().enumerate() {
            let off = match i % 4 {
                1 => 0.6,
                3 => -0.6,
                _ => 0.0,
            };
            let k = 1.0 + off * opts.tolerance / r;
            let (dx, dy) = (p.x - 1.0, p.y + 3.0);
            (p.x, p.y) = (1.0 + k * dx, -3.0 + k * dy);
        }
        let name = format!("perturbed circle r {r} n {n}");
        let (ratio, arcs) = fit_and_check(&name, &pts, None, opts);
        assert_eq!(arcs, 1, "{name}: {arcs} arcs");
        assert!(ratio >= (n + 1) as f64 / 2.0, "{name}: ratio {ratio}");
    }
}

#[test]
fn arc_fitter_no_false_arcs_on_zigzag() {
    let pts: Vec<_> =
        (0..100).map(|i| Point3::new(i as f64, if i % 2 == 0 { 0.0 } else { 1.0 }, 0.0)).collect();
    let (ratio, arcs) = fit_and_check("zigzag", &pts, None, ArcFitOptions::default());
    assert_eq!(arcs, 0, "zigzag must not become arcs");
    assert!((ratio - 1.0).abs() < 1e-12, "ratio {ratio}");
    // A square: corners are not arcs either.
    let sq = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0], [0.0, 0.0], [10.0, 0.0]];
    let pts: Vec<_> = sq.iter().map(|p| Point3::new(p[0], p[1], 1.0)).collect();
    assert_eq!(fit_and_check("square", &pts, None, ArcFitOptions::default()).1, 0);
}

#[test]
fn arc_fitter_deviation_bound_on_noisy_paths() {
    let mut runner = seeded(64);
    let strat = (
        prop::collection::vec((-0.2..0.2f64, -0.2..0.2f64), 3..80),
        0.0..0.05f64,
        1.0..40.0f64,
        any::<bool>(),
    );
    runner
        .run(&strat, |(noise, amp, r, circle)| {
            let n = noise.len();
            let pts: Vec<_> = noise
                .iter()
                .enumerate()
                .map(|(i, (a, b))| {
                    let t = i as f64 / n as f64;
                    let (x, y) =
                        if circle { (r * (2.0 * t).cos(), r * (2.0 * t).sin()) } else { (t * r, 0.0) };
                    Point3::new(x + a * amp * 100.0, y + b * amp * 100.0, 2.0)
                })
                .collect();
            let name = format!("noisy path n {n} amp {amp} r {r} circle {circle}");
            fit_and_check(&name, &pts, None, ArcFitOptions::default());
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
}

/// A shop program's safe start selects its work offset after the header, and the tool
/// length offset names its register as an integer in every dialect that has one (Fanuc
/// writes whole numbers with a point elsewhere: `X1.`, but `H9.` is no register).
#[test]
fn work_offset_and_length_offset_register() {
    let program = [
        Motion::ToolChange { tool: 9 },
        Motion::Rapid { to: Point3::new(1.0, 2.0, 5.0) },
        Motion::Linear { to: Point3::new(1.0, 2.0, -1.0), feed: 300.0, extrude: None },
    ];
    for dialect in [Dialect::LinuxCnc, Dialect::Fanuc, Dialect::Grbl] {
        let opts = WriterOptions { tool_length_offset: true, work_offset: Some(1), ..Default::default() };
        let mut w = GcodeWriter::new(Vec::new(), dialect, opts);
        for m in &program {
            w.motion(m).expect("writes");
        }
        w.finish().expect("writes");
        let text = String::from_utf8(w.into_inner()).expect("utf-8");
        let lines: Vec<&str> = text.lines().collect();
        let header = lines.iter().position(|l| l.starts_with("G17 G21")).expect("safe start");
        assert_eq!(lines.get(header + 1), Some(&"G54"), "{dialect}: {text}");
        let g43 = lines.iter().find(|l| l.starts_with("G43")).copied();
        let want = (dialect != Dialect::Grbl).then_some("G43 H9");
        assert_eq!(g43, want, "{dialect}: {text}");
        assert!(text.contains(if dialect == Dialect::Fanuc { "X1. Y2." } else { "X1 Y2" }), "{dialect}");
    }
    // G59 is the last; a seventh is refused, as is a work offset for a printer.
    for (dialect, k) in [(Dialect::LinuxCnc, 7), (Dialect::Marlin, 1)] {
        let opts = WriterOptions { work_offset: Some(k), ..Default::default() };
        let mut w = GcodeWriter::new(Vec::new(), dialect, opts);
        assert!(w.motion(&program[1]).is_err(), "{dialect} G{}", 53 + k);
    }
}

#[test]
fn writer_reports_compression_ratio() {
    let pts = circle_points(Plane::XY, [0.0, 0.0, 0.0], 20.0, 0.0, PI, 90);
    let mut ms = vec![Motion::Rapid { to: pts[0] }];
    ms.extend(pts[1..].iter().map(|p| Motion::Linear { to: *p, feed: 500.0, extrude: None }));
    let opts = WriterOptions { arc_fit: Some(ArcFitOptions::default()), ..Default::default() };
    let mut w = GcodeWriter::new(Vec::new(), Dialect::LinuxCnc, opts);
    for m in &ms {
        w.motion(m).expect("writes");
    }
    w.finish().expect("writes");
    assert!(w.compression_ratio() > 20.0, "ratio {}", w.compression_ratio());
    let text = String::from_utf8(w.into_inner()).expect("utf8");
    assert_eq!(text.lines().filter(|l| l.starts_with("G3")).count(), 1, "{text}");
    // The fitted program runs in the reference interpreter and ends where the polyline does.
    let dir = tempfile::tempdir().expect("temp dir");
    let moves = run_rs274(dir.path(), "fitted", &text);
    let last = &moves[moves.len() - 2];
    assert!(close_pt(&last.to, &pts[pts.len() - 1], 1e-4), "fitted end {}", last.to);
    assert!(moves.iter().any(|m| m.kind == "arc"), "no ARC_FEED in {text}");
}

// ---------------------------------------------------------------------------
// The reference interpreter.

fn rs274() -> String {
    let found = Command::new("sh").arg("-c").arg("command -v rs274").output();
    match found {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).trim().to_owned(),
        _ => panic!(
            "rs274 (LinuxCNC's standalone interpreter, Debian package linuxcnc-uspace) is not on PATH; \
             install it to run the LinuxCNC writer checks"
        ),
    }
}

/// A move as rs274 reports it: kind, end point (work frame), and for arcs the centre and rotation.
#[derive(Debug, Clone)]
struct CanonMove {
    kind: &'static str,
    to: Point3<f64>,
    arc: Option<(Point3<f64>, i64)>,
}

fn numbers(line: &str) -> Vec<f64> {
    let (Some(a), Some(b)) = (line.find('('), line.rfind(')')) else { return Vec::new() };
    line[a + 1..b].split([',', ' ']).filter_map(|s| s.trim().parse().ok()).collect()
}

/// Runs rs274 on `text`; panics with the program and rs274's message on any error.
fn run_rs274(dir: &Path, name: &str, text: &str) -> Vec<CanonMove> {
    let exe = rs274();
    let file = dir.join(format!("{name}.ngc"));
    std::fs::write(&file, text).expect("write program");
    let table = dir.join("tools.tbl");
    let tools: String = (0..=20).map(|t| format!("T{t} P{t} Z0 D0\n")).collect();
    std::fs::write(&table, tools).expect("write tool table");
    // rs274 reads and rewrites `rs274ngc.var` in its working directory: give each
    // run its own. Concurrent starts sometimes die with SIGBUS (shared memory set-up
    // in LinuxCNC's libraries), so runs are serialised and a run killed by a signal
    // (no exit code; a rejected program exits with code 1) is retried.
    static RS274: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = RS274.lock().unwrap_or_else(|e| e.into_inner());
    let run = || {
        Command::new(&exe)
            .current_dir(dir)
            .arg("-g")
            .arg("-t")
            .arg(&table)
            .arg(&file)
            .output()
            .expect("run rs274")
    };
    let mut out = run();
    for _ in 0..3 {
        if out.status.code().is_some() {
            break;
        }
        out = run();
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "rs274 rejected {name} ({}):\n{}\n{}\n--- program ---\n{text}",
        out.status,
        stdout.lines().rev().take(4).collect::<Vec<_>>().join("\n"),
        stderr
    );
    let mut plane = Plane::XY;
    let mut moves = Vec::new();
    for line in stdout.lines() {
        if line.contains("SELECT_PLANE(") {
            plane = if line.contains("CANON_PLANE_XZ") {
                Plane::ZX
            } else if line.contains("CANON_PLANE_YZ") {
                Plane::YZ
            } else {
                Plane::XY
            };
        }
        let n = numbers(line);
        if line.contains("STRAIGHT_TRAVERSE(") || line.contains("STRAIGHT_FEED(") {
            let kind = if line.contains("TRAVERSE") { "rapid" } else { "feed" };
            moves.push(CanonMove { kind, to: Point3::new(n[0], n[1], n[2]), arc: None });
        } else if line.contains("ARC_FEED(") {
            // ARC_FEED(first_end, second_end, first_axis, second_axis, rotation, axis_end, a, b, c)
            // with (first, second, axis) = (X, Y, Z), (Z, X, Y), (Y, Z, X) for XY, XZ, YZ.
            let (u, v, w) = plane_axes(plane);
            let mut to = Point3::origin();
            let mut c = Point3::origin();
            to[u] = n[0];
            to[v] = n[1];
            to[w] = n[5];
            c[u] = n[2];
            c[v] = n[3];
            moves.push(CanonMove { kind: "arc", to, arc: Some((c, n[4] as i64)) });
        }
    }
    moves
}

/// The moves `motions` should produce, as rs274 would report them.
fn expected_moves(motions: &[Motion<'_>]) -> Vec<CanonMove> {
    let mut out = Vec::new();
    for m in motions {
        match m {
            Motion::Rapid { to } => out.push(CanonMove { kind: "rapid", to: *to, arc: None }),
            Motion::Linear { to, .. } => out.push(CanonMove { kind: "feed", to: *to, arc: None }),
            Motion::Arc { to, center, direction, turns, .. } => {
                let rot = (*turns as i64 + 1) * if *direction == ArcDirection::Clockwise { -1 } else { 1 };
                out.push(CanonMove { kind: "arc", to: *to, arc: Some((*center, rot)) })
            }
            _ => {}
        }
    }
    out
}

fn check_against_rs274(dir: &Path, name: &str, motions: &[Motion<'_>], opts: WriterOptions) {
    let tol = 0.5 * 10f64.powi(-(opts.decimals as i32)) * 3.0 + 1e-4;
    let text = write_program(Dialect::LinuxCnc, opts, motions).expect("writes");
    let got = run_rs274(dir, name, &text);
    let want = expected_moves(motions);
    // The footer adds one retract (G53 G0 Z0).
    assert_eq!(
        got.len(),
        want.len() + 1,
        "{name}: move count\n{text}\n{:#?}",
        motions.iter().filter(|m| m.end_point().is_some()).collect::<Vec<_>>()
    );
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g.kind, w.kind, "{name}: move {i} kind\n{text}");
        let d = (g.to - w.to).abs().max();
        assert!(d <= tol, "{name}: move {i} ends at {} instead of {} (d {d})\n{text}", g.to, w.to);
        if let (Some((gc, gr)), Some((wc, wr))) = (g.arc, w.arc) {
            assert_eq!(gr, wr, "{name}: move {i} rotation");
            let (u, v, _) = match &motions.iter().filter(|m| m.end_point().is_some()).nth(i) {
                Some(Motion::Arc { plane, .. }) => plane_axes(*plane),
                _ => (0, 1, 2),
            };
            let dc = (gc[u] - wc[u]).abs().max((gc[v] - wc[v]).abs());
            assert!(dc <= tol * 2.0, "{name}: move {i} centre {gc} instead of {wc}\n{text}");
        }
    }
}

#[test]
fn linuxcnc_output_runs_in_rs274() {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut runner = seeded(30);
    let case = std::cell::Cell::new(0u32);
    runner
        .run(&program(), |motions| {
            case.set(case.get() + 1);
            let case = case.get();
            let opts = match case % 3 {
                0 => WriterOptions::default(),
                1 => WriterOptions { line_numbers: true, modal: false, ..Default::default() },
                _ => WriterOptions { decimals: 3, comments: false, ..Default::default() },
            };
            check_against_rs274(dir.path(), &format!("case{case}"), &motions, opts);
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn every_dialect_writes_an_example() {
    let dir = tempfile::tempdir().expect("temp dir");
    let frame = Isometry3::rotation(Vector3::y() * (PI / 2.0));
    let example = vec![
        Motion::Comment(Cow::Borrowed("example (with parens)")),
        Motion::Setup { frame: Isometry3::identity(), rotary: [None; 3] },
        Motion::ToolChange { tool: 3 },
        Motion::Spindle { rpm: 12000.0, direction: SpindleDirection::Clockwise },
        Motion::Coolant(Coolant::Flood),
        Motion::Rapid { to: Point3::new(0.0, 0.0, 5.0) },
        Motion::Linear { to: Point3::new(0.0, 0.0, -1.0), feed: 200.0, extrude: None },
        Motion::Arc {
            to: Point3::new(0.0, 0.0, -1.0),
            center: Point3::new(5.0, 0.0, -1.0),
            plane: Plane::XY,
            direction: ArcDirection::Clockwise,
            turns: 0,
            feed: 800.0,
            extrude: None,
        },
        Motion::Dwell { seconds: 0.5 },
        Motion::Setup { frame, rotary: [None; 3] },
        Motion::Rapid { to: Point3::new(1.0, 2.0, 5.0) },
        Motion::Linear { to: Point3::new(1.0, 2.0, -0.5), feed: 150.0, extrude: None },
    ];
    for d in [Dialect::LinuxCnc, Dialect::Grbl, Dialect::Fanuc, Dialect::Marlin] {
        let text = write_program(d, WriterOptions::default(), &example).expect("writes");
        let path = dir.path().join(format!("example_{d:?}.nc"));
        std::fs::write(&path, &text).expect("write");
        assert!(
            text.contains("SETUP 2: rotate part so that tool axis = +1.000000 +0.000000 +0.000000"),
            "{d:?}\n{text}"
        );
        assert!(!text.contains("-0 ") && !text.contains("e-") && !text.contains("NaN"), "{d:?}\n{text}");
        match d {
            Dialect::Fanuc => assert!(text.starts_with("%\nO0001\n") && text.ends_with("M30\n%\n"), "{text}"),
            Dialect::Grbl => assert!(text.contains("M0 (tool change T3)") && !text.contains("M6"), "{text}"),
            Dialect::Marlin => {
                assert!(text.contains(";example (with parens)") && text.contains("M82"), "{text}")
            }
            Dialect::LinuxCnc => {
                assert!(text.contains("(example [with parens])") && text.contains("T3 M6"), "{text}");
            }
        }
    }
    let opts = WriterOptions::default();
    check_against_rs274(dir.path(), "example", &example, opts);
}

#[test]
fn linearised_arcs_stay_on_the_circle() {
    // grbl cannot write extra turns: its output must still trace the helix.
    let start = Point3::new(10.0, 0.0, 0.0);
    let arc = Motion::Arc {
        to: Point3::new(0.0, 10.0, -3.0),
        center: Point3::origin(),
        plane: Plane::XY,
        direction: ArcDirection::CounterClockwise,
        turns: 2,
        feed: 100.0,
        extrude: None,
    };
    let opts = WriterOptions { header: false, footer: false, ..Default::default() };
    let text =
        write_program(Dialect::Grbl, opts, &[Motion::Rapid { to: start }, arc.clone()]).expect("writes");
    let spec = ArcSpec::from_motion(start, &arc).expect("arc");
    let mut n = 0;
    for line in text.lines().skip(1) {
        let (mut x, mut y) = (None, None);
        for w in line.split(' ') {
            let v = w[1..].parse::<f64>().ok();
            match w.as_bytes()[0] {
                b'X' => x = v,
                b'Y' => y = v,
                _ => {}
            }
        }
        if let (Some(x), Some(y)) = (x, y) {
            let r = x.hypot(y);
            assert!((r - 10.0).abs() < 1e-3, "{line}: radius {r}");
            n += 1;
        }
    }
    let want = spec.segments(0.002).expect("segments");
    assert!(n + 10 >= want, "{n} points for {want} chords");
}

// ---------------------------------------------------------------------------
// Round trips through our parser.

use s2g_gcode::{ExtrusionMode, Marker, ParseOptions, parse_str};

/// Parses `text`; asserts no errors; returns the motions (header comment removed).
fn parse_back(name: &str, text: &str) -> Vec<Motion<'static>> {
    let mut rec = MotionRecorder::default();
    let summary = parse_str(text, &ParseOptions::default(), &mut rec).expect("infallible sink");
    assert!(summary.errors.is_empty(), "{name}: parse errors {:?}\n{text}", summary.errors);
    rec.motions
        .into_iter()
        .map(|(_, m)| m)
        .filter(|m| !matches!(m, Motion::Comment(c) if c.starts_with("generated by s2g-gcode")))
        .collect()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn close_pt(a: &Point3<f64>, b: &Point3<f64>, tol: f64) -> bool {
    (a - b).abs().max() <= tol
}

/// What `m` should read back as, written by `dialect` with `opts`; `None` when
/// the writer leaves it out.
fn expected(dialect: Dialect, opts: &WriterOptions, m: &Motion<'static>) -> Option<Motion<'static>> {
    match m {
        Motion::Comment(_) | Motion::Marker(_) if !opts.comments => None,
        Motion::ToolChange { tool } if dialect == Dialect::Grbl => {
            opts.comments.then(|| Motion::Comment(Cow::Owned(format!("tool change T{tool}"))))
        }
        _ => Some(m.clone()),
    }
}

/// Compares parsed motions with the input; arcs a dialect linearises are matched
/// against the run of linear moves that replaced them (each on the helix).
fn compare(
    name: &str,
    dialect: Dialect,
    opts: &WriterOptions,
    input: &[Motion<'static>],
    got: &[Motion<'static>],
    text: &str,
) {
    let tol = 1.01 * 10f64.powi(-(opts.decimals as i32));
    let etol = 2.01 * 10f64.powi(-(opts.e_decimals as i32));
    let ctx = |i: usize, what: &str| format!("{name}: {what} at parsed motion {i}\n{text}");
    let mut j = 0;
    let mut pos = Point3::origin();
    for m in input {
        let Some(want) = expected(dialect, opts, m) else { continue };
        if let Motion::Arc { to, turns, plane, extrude, .. } = &want {
            let linearised = match dialect {
                Dialect::LinuxCnc => false,
                Dialect::Grbl | Dialect::Fanuc => *turns > 0,
                Dialect::Marlin => *turns > 0 || *plane != Plane::XY,
            };
            if linearised {
                let spec = ArcSpec::from_motion(pos, &want).expect("arc");
                let r = spec.radius();
                let (u, v, _) = plane_axes(*plane);
                let mut e_sum = 0.0;
                let n = spec.segments(opts.arc_tolerance).expect("segments");
                for k in 0..n {
                    let Some(Motion::Linear { to: p, extrude: e, .. }) = got.get(j) else {
                        panic!("{}", ctx(j, "linearised arc ended early"));
                    };
                    e_sum += e.unwrap_or(0.0);
                    let rr = (p[u] - spec.center[u]).hypot(p[v] - spec.center[v]);
                    assert!(
                        (rr - r).abs() <= 3.0 * tol,
                        "{}",
                        ctx(j, &format!("chord point off the circle by {}", rr - r))
                    );
                    j += 1;
                    if k + 1 == n {
                        assert!(close_pt(p, to, tol), "{}", ctx(j, "linearised arc end"));
                    }
                }
                if let Some(e) = extrude {
                    assert!(close(e_sum, *e, etol * 10.0), "{}", ctx(j, "linearised extrusion"));
                }
                pos = *to;
                continue;
            }
        }
        let Some(g) = got.get(j) else { panic!("{}", ctx(j, &format!("missing {want:?}"))) };
        let ok = match (&want, g) {
            (Motion::Rapid { to: a }, Motion::Rapid { to: b }) => close_pt(a, b, tol),
            (
                Motion::Linear { to: a, feed: fa, extrude: ea },
                Motion::Linear { to: b, feed: fb, extrude: eb },
            ) => {
                close_pt(a, b, tol)
                    && close(*fa, *fb, tol)
                    && close(ea.unwrap_or(0.0), eb.unwrap_or(0.0), etol)
            }
            (
                Motion::Arc { to: a, center: ca, plane: pa, direction: da, turns: ta, feed: fa, extrude: ea },
                Motion::Arc { to: b, center: cb, plane: pb, direction: db, turns: tb, feed: fb, extrude: eb },
            ) => {
                let (u, v, _) = plane_axes(*pa);
                close_pt(a, b, tol)
                    && close(ca[u], cb[u], 2.0 * tol)
                    && close(ca[v], cb[v], 2.0 * tol)
                    && pa == pb
                    && da == db
                    && ta == tb
                    && close(*fa, *fb, tol)
                    && close(ea.unwrap_or(0.0), eb.unwrap_or(0.0), etol)
            }
            (Motion::Spindle { rpm: ra, direction: da }, Motion::Spindle { rpm: rb, direction: db }) => {
                da == db && (*da == SpindleDirection::Off || close(*ra, *rb, tol))
            }
            (Motion::Dwell { seconds: a }, Motion::Dwell { seconds: b }) => close(*a, *b, 1e-3),
            (
                Motion::Marker(Marker::Layer { index: ia, z: za }),
                Motion::Marker(Marker::Layer { index: ib, z: zb }),
            ) => ia == ib && close(za.unwrap_or(-1.0), zb.unwrap_or(-1.0), tol),
            (a, b) => a == b,
        };
        assert!(ok, "{}", ctx(j, &format!("expected {want:?}, got {g:?}")));
        if let Some(p) = want.end_point() {
            pos = p;
        }
        j += 1;
    }
    // What follows is the footer: no further cutting moves.
    for (k, g) in got[j..].iter().enumerate() {
        assert!(
            !matches!(g, Motion::Linear { .. } | Motion::Arc { .. }),
            "{}",
            ctx(j + k, &format!("unexpected footer motion {g:?}"))
        );
    }
}

fn round_trip(name: &str, dialect: Dialect, opts: WriterOptions, motions: &[Motion<'static>]) {
    let text = write_program(dialect, opts.clone(), motions).expect("writes");
    let got = parse_back(name, &text);
    compare(name, dialect, &opts, motions, &got, &text);
}

fn cnc_options(case: u32) -> WriterOptions {
    match case % 4 {
        0 => WriterOptions::default(),
        1 => WriterOptions { line_numbers: true, ..Default::default() },
        2 => WriterOptions { modal: false, decimals: 3, ..Default::default() },
        _ => WriterOptions {
            line_numbers: true,
            modal: false,
            comments: false,
            decimals: 5,
            ..Default::default()
        },
    }
}

#[test]
fn cnc_dialects_round_trip() {
    for dialect in [Dialect::LinuxCnc, Dialect::Grbl, Dialect::Fanuc] {
        let case = std::cell::Cell::new(0u32);
        seeded(64)
            .run(&program(), |motions| {
                case.set(case.get() + 1);
                let name = format!("{dialect:?} case {}", case.get());
                round_trip(&name, dialect, cnc_options(case.get()), &motions);
                Ok(())
            })
            .unwrap_or_else(|e| panic!("{e}"));
    }
}

/// FDM programs: travels, extruding lines and XY arcs, retractions, markers, dwells.
fn fdm_program() -> impl Strategy<Value = Vec<Motion<'static>>> {
    #[derive(Debug, Clone)]
    enum F {
        Travel([f64; 2]),
        Print([f64; 2], f64),
        Arc(bool, f64, f64, f64, f64),
        Retract(f64),
        Layer(Option<u16>),
        Kind(u8),
        Dwell(u32),
        Comment(String),
    }
    let f = prop_oneof![
        2 => [0.0..200.0f64, 0.0..200.0f64].prop_map(F::Travel),
        5 => ([0.0..200.0f64, 0.0..200.0f64], 0.001..3.0f64).prop_map(|(p, e)| F::Print(p, e)),
        2 => (any::<bool>(), 1.0..30.0f64, 0.0..TAU, 0.3..6.0f64, 0.01..2.0f64)
            .prop_map(|(ccw, r, phi, sw, e)| F::Arc(ccw, r, phi, sw, e)),
        1 => (0.1..5.0f64).prop_map(F::Retract),
        1 => prop::option::of(0u16..500).prop_map(F::Layer),
        1 => (0u8..3).prop_map(F::Kind),
        1 => (0u32..3000).prop_map(F::Dwell),
        1 => "[a-zA-Z][a-zA-Z0-9 ]{0,12}[a-zA-Z0-9]".prop_map(F::Comment),
    ];
    prop::collection::vec(f, 1..40).prop_map(|fs| {
        let mut z = 0.2;
        let mut p = Point3::new(100.0, 100.0, z);
        let mut out = vec![Motion::Rapid { to: p }];
        for f in fs {
            match f {
                F::Travel(q) => {
                    p = Point3::new(q[0], q[1], z);
                    out.push(Motion::Rapid { to: p });
                }
                F::Print(q, e) => {
                    p = Point3::new(q[0], q[1], z);
                    out.push(Motion::Linear { to: p, feed: 1800.0, extrude: Some(e) });
                }
                F::Arc(ccw, r, phi, sweep, e) => {
                    let c = Point3::new(p.x + r * phi.cos(), p.y + r * phi.sin(), z);
                    let a0 = (p.y - c.y).atan2(p.x - c.x);
                    let a1 = if ccw { a0 + sweep } else { a0 - sweep };
                    let to = Point3::new(c.x + r * a1.cos(), c.y + r * a1.sin(), z);
                    let direction =
                        if ccw { ArcDirection::CounterClockwise } else { ArcDirection::Clockwise };
                    out.push(Motion::Arc {
                        to,
                        center: c,
                        plane: Plane::XY,
                        direction,
                        turns: 0,
                        feed: 1200.0,
                        extrude: Some(e),
                    });
                    p = to;
                }
                F::Retract(e) => out.push(Motion::Linear { to: p, feed: 2400.0, extrude: Some(-e) }),
                F::Layer(i) => {
                    z += 0.2;
                    let marker = match i {
                        Some(i) => Marker::Layer { index: Some(i as i64), z: None },
                        None => Marker::Layer { index: None, z: Some(z) },
                    };
                    out.push(Motion::Marker(marker));
                    p.z = z;
                    out.push(Motion::Rapid { to: p });
                }
                F::Kind(k) => out.push(Motion::Marker(Marker::Type(Cow::Borrowed(
                    ["WALL-OUTER", "FILL", "Skirt/Brim"][k as usize],
                )))),
                F::Dwell(ms) => out.push(Motion::Dwell { seconds: ms as f64 / 1000.0 }),
                F::Comment(c) => out.push(Motion::Comment(Cow::Owned(c))),
            }
        }
        out
    })
}

#[test]
fn marlin_round_trips() {
    let case = std::cell::Cell::new(0u32);
    seeded(96)
        .run(&fdm_program(), |motions| {
            case.set(case.get() + 1);
            let c = case.get();
            let opts = WriterOptions {
                extrusion: if c.is_multiple_of(2) {
                    ExtrusionMode::Absolute
                } else {
                    ExtrusionMode::Relative
                },
                line_numbers: c.is_multiple_of(3),
                modal: !c.is_multiple_of(5),
                ..Default::default()
            };
            round_trip(&format!("Marlin case {c}"), Dialect::Marlin, opts, &motions);
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn setups_read_back_as_comments() {
    let frame = Isometry3::rotation(Vector3::x() * (PI / 2.0));
    let ms = vec![
        Motion::Rapid { to: Point3::new(0.0, 0.0, 10.0) },
        Motion::Setup { frame, rotary: [None; 3] },
        Motion::Rapid { to: Point3::new(0.0, 0.0, 10.0) },
    ];
    for rotary in [None, Some(s2g_gcode::RotaryAxes::AC), Some(s2g_gcode::RotaryAxes::BC)] {
        let opts = WriterOptions { rotary, ..Default::default() };
        let text = write_program(Dialect::LinuxCnc, opts, &ms).expect("writes");
        let got = parse_back("setup", &text);
        let comment = got.iter().find_map(|m| match m {
            Motion::Comment(c) if c.starts_with("SETUP 1:") => Some(c.clone()),
            _ => None,
        });
        assert_eq!(
            comment.as_deref(),
            Some(
                "SETUP 1: rotate part so that tool axis = +0.000000 -1.000000 +0.000000; frame quaternion w x y z = \
                 +0.707107 +0.707107 +0.000000 +0.000000; translation = +0.000000 +0.000000 +0.000000"
            ),
            "{text}"
        );
        // After a setup every axis is stated again, so the rapid is not dropped.
        // The rotary line is a (zero-length) rapid for both interpreters.
        let rapids = 3 + rotary.is_some() as usize;
        assert_eq!(
            got.iter().filter(|m| matches!(m, Motion::Rapid { .. })).count(),
            rapids,
            "{rotary:?}\n{text}"
        );
        match rotary {
            Some(s2g_gcode::RotaryAxes::AC) => assert!(text.contains("G0 A90 C0\n"), "{text}"),
            Some(s2g_gcode::RotaryAxes::BC) => assert!(text.contains("G0 B90 C-90\n"), "{text}"),
            _ => {}
        }
        let dir = tempfile::tempdir().expect("dir");
        let moves = run_rs274(dir.path(), "setup", &text);
        assert_eq!(moves.len(), rapids, "{text}");
    }
}

/// One fixed program per dialect: the Fanuc program number and `G4 X` dwell, setup
/// comments (with the `M0` pause) and every motion kind read back with no error.
#[test]
fn every_dialect_round_trips_dwells_and_setups() {
    let frame = Isometry3::rotation(Vector3::x() * (PI / 2.0));
    let ms: Vec<Motion<'static>> = vec![
        Motion::Rapid { to: Point3::new(0.0, 0.0, 10.0) },
        Motion::Spindle { rpm: 12000.0, direction: SpindleDirection::Clockwise },
        Motion::Coolant(Coolant::Flood),
        Motion::Linear { to: Point3::new(5.0, 0.0, -1.0), feed: 300.0, extrude: None },
        Motion::Dwell { seconds: 1.25 },
        Motion::Arc {
            to: Point3::new(0.0, 5.0, -1.0),
            center: Point3::new(0.0, 0.0, -1.0),
            plane: Plane::XY,
            direction: ArcDirection::CounterClockwise,
            turns: 0,
            feed: 300.0,
            extrude: None,
        },
        Motion::Setup { frame: Isometry3::identity(), rotary: [None; 3] },
        Motion::Rapid { to: Point3::new(0.0, 0.0, 10.0) },
        Motion::Setup { frame, rotary: [None; 3] },
        Motion::Rapid { to: Point3::new(1.0, 2.0, 10.0) },
        Motion::Linear { to: Point3::new(1.0, 2.0, -0.5), feed: 150.0, extrude: None },
        Motion::Dwell { seconds: 0.5 },
        Motion::Comment(Cow::Borrowed("done")),
    ];
    for dialect in [Dialect::LinuxCnc, Dialect::Grbl, Dialect::Fanuc, Dialect::Marlin] {
        for line_numbers in [false, true] {
            let name = format!("{dialect:?} line numbers {line_numbers}");
            let opts = WriterOptions { line_numbers, ..Default::default() };
            let text = write_program(dialect, opts.clone(), &ms).expect("writes");
            if dialect == Dialect::Fanuc {
                assert!(text.starts_with("%\nO0001\n") && text.contains("G4 X1.25"), "{text}");
            }
            let mut rec = MotionRecorder::default();
            let summary = parse_str(&text, &ParseOptions::default(), &mut rec).expect("infallible sink");
            assert!(summary.errors.is_empty(), "{name}: {:?}\n{text}", summary.errors);
            assert_eq!(summary.program_number, (dialect == Dialect::Fanuc).then_some(1), "{name}");
            let got: Vec<Motion<'static>> = rec.motions.into_iter().map(|(_, m)| m).collect();
            let setups: Vec<&str> = got
                .iter()
                .filter_map(|m| match m {
                    Motion::Comment(c) if c.starts_with("SETUP ") => Some(c.as_ref()),
                    _ => None,
                })
                .collect();
            assert_eq!(setups.len(), 2, "{name}: {setups:?}\n{text}");
            assert!(
                setups[1].starts_with("SETUP 2: rotate part so that tool axis = +0.000000 -1.000000"),
                "{name}"
            );
            // Without setups and the header comment, the rest must read back as written.
            let input: Vec<Motion<'static>> =
                ms.iter().filter(|m| !matches!(m, Motion::Setup { .. })).cloned().collect();
            let got: Vec<Motion<'static>> = got
                .into_iter()
                .filter(|m| {
                    !matches!(m, Motion::Comment(c) if c.starts_with("SETUP ") || c.starts_with("generated by"))
                })
                .collect();
            let dwells: Vec<f64> = got
                .iter()
                .filter_map(|m| match m {
                    Motion::Dwell { seconds } => Some(*seconds),
                    _ => None,
                })
                .collect();
            assert_eq!(dwells, [1.25, 0.5], "{name}\n{text}");
            compare(&name, dialect, &opts, &input, &got, &text);
        }
    }
}

// ---------------------------------------------------------------------------
// 3+2 rotary setups: writer and parser share `rotary_frame` / `rotary_angles`.

use s2g_gcode::{
    RotaryAxes, RotaryMount, axis_angles, rotary_angles, rotary_axis, rotary_frame, rotary_twist,
};

/// A random rotation (normalised 4-vector, rejection of short ones) and translation.
fn frame_strategy() -> impl Strategy<Value = Isometry3<f64>> {
    (
        [-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64],
        [-50.0..50.0f64, -50.0..50.0f64, -50.0..50.0f64],
    )
        .prop_filter("non-degenerate quaternion", |(q, _)| q.iter().map(|c| c * c).sum::<f64>() > 0.01)
        .prop_map(|(q, t)| {
            let q =
                nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
            Isometry3::from_parts(nalgebra::Translation3::new(t[0], t[1], t[2]), q)
        })
}

fn tool_axis(f: &Isometry3<f64>) -> Vector3<f64> {
    f.rotation * Vector3::z()
}

#[test]
fn rotary_angles_invert_rotary_frame() {
    // Plus the edge cases: vertical up and down, horizontal along each axis.
    let edges: Vec<Isometry3<f64>> = [
        Vector3::zeros(),
        Vector3::x() * PI,
        Vector3::y() * PI,
        Vector3::x() * (PI / 2.0),
        Vector3::y() * (-PI / 2.0),
        Vector3::x() * 1e-9,
    ]
    .into_iter()
    .map(Isometry3::rotation)
    .collect();
    let check = |f: &Isometry3<f64>| {
        for axes in [RotaryAxes::AC, RotaryAxes::BC] {
            let ang = rotary_angles(axes, f);
            let k = rotary_frame(axes, ang);
            let d = (tool_axis(&k) - tool_axis(f)).norm();
            assert!(d < 1e-9, "{axes:?} {f:?}: angles {ang:?} give tool axis off by {d}");
            assert_eq!(k.translation.vector, Vector3::zeros());
            // The kinematic frame has no twist; the frame is the kinematic one turned by the twist.
            assert!(rotary_twist(axes, &k).abs() < 1e-7, "{axes:?} {ang:?}: {}", rotary_twist(axes, &k));
            let phi = rotary_twist(axes, f).to_radians();
            let rebuilt = k.rotation * nalgebra::UnitQuaternion::from_axis_angle(&Vector3::z_axis(), phi);
            assert!(rebuilt.angle_to(&f.rotation) < 1e-9, "{axes:?} {f:?}: twist {phi}");
            // The angles of the kinematic frame are the angles themselves.
            let again = rotary_angles(axes, &k);
            for i in 0..3 {
                let diff = (again[i] - ang[i] + 540.0).rem_euclid(360.0) - 180.0;
                assert!(diff.abs() < 1e-6, "{axes:?} {ang:?} -> {again:?}");
            }
        }
    };
    edges.iter().for_each(check);
    seeded(500)
        .run(&frame_strategy(), |f| {
            check(&f);
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
}

/// Writes two setups with rotary words and parses them back under the same kinematics.
fn rotary_round_trip(axes: RotaryAxes, f1: Isometry3<f64>, f2: Isometry3<f64>, decimals: usize) -> String {
    let ms = vec![
        Motion::Rapid { to: Point3::new(0.0, 0.0, 20.0) },
        Motion::Setup { frame: f1, rotary: [None; 3] },
        Motion::Rapid { to: Point3::new(1.0, 2.0, 20.0) },
        Motion::Linear { to: Point3::new(1.0, 2.0, -1.0), feed: 200.0, extrude: None },
        Motion::Setup { frame: f2, rotary: [None; 3] },
        Motion::Rapid { to: Point3::new(-3.0, 4.0, 15.0) },
        Motion::Linear { to: Point3::new(-3.0, 5.0, -2.0), feed: 250.0, extrude: None },
    ];
    let opts = WriterOptions { rotary: Some(axes), decimals, ..Default::default() };
    let text = write_program(Dialect::LinuxCnc, opts, &ms).expect("writes");
    let mut rec = MotionRecorder::default();
    let po = ParseOptions { rotary: Some(axes), ..ParseOptions::default() };
    let summary = parse_str(&text, &po, &mut rec).expect("infallible sink");
    assert!(summary.errors.is_empty(), "{axes:?}: {:?}\n{text}", summary.errors);
    let got: Vec<Motion<'static>> = rec.motions.into_iter().map(|(_, m)| m).collect();
    let setups: Vec<(Isometry3<f64>, [Option<f64>; 3])> = got
        .iter()
        .filter_map(|m| match m {
            Motion::Setup { frame, rotary } => Some((*frame, *rotary)),
            _ => None,
        })
        .collect();
    assert_eq!(setups.len(), 2, "{axes:?}\n{text}");
    for ((got, rotary), want) in setups.iter().zip([f1, f2]) {
        let d = (tool_axis(got) - tool_axis(&want)).norm();
        assert!(d < 1e-9, "{axes:?}: tool axis off by {d}: {got:?} vs {want:?}\n{text}");
        let kin = rotary_frame(axes, rotary_angles(axes, &want));
        let a = got.rotation.angle_to(&kin.rotation);
        assert!(a < 1e-9, "{axes:?}: rotation differs from the kinematic one by {a} rad\n{text}");
        let used = match axes {
            RotaryAxes::AC => [true, false, true],
            RotaryAxes::BC => [false, true, true],
        };
        assert_eq!(rotary.map(|r| r.is_some()), used, "{axes:?}: {rotary:?}");
    }
    // The rotary lines move nothing else: the moves read back are the input moves, in order.
    let ends: Vec<Point3<f64>> = got.iter().filter_map(Motion::end_point).collect();
    let want = [[0.0, 0.0, 20.0], [1.0, 2.0, 20.0], [1.0, 2.0, -1.0], [-3.0, 4.0, 15.0], [-3.0, 5.0, -2.0]];
    for (k, w) in want.iter().enumerate() {
        assert!(close_pt(&ends[k], &Point3::from(*w), 1e-9), "{axes:?}: move {k}: {:?}\n{text}", ends[k]);
    }
    let setup_at = got.iter().position(|m| matches!(m, Motion::Setup { .. })).expect("setup");
    let first_after = got[setup_at..].iter().find_map(Motion::end_point).expect("move after the setup");
    assert!(
        close_pt(&first_after, &Point3::new(1.0, 2.0, 20.0), 1e-9),
        "setup comes before the move\n{text}"
    );
    text
}

#[test]
fn rotary_setups_read_back_as_kinematic_frames() {
    // Random frames: ten decimals make the written angles exact to 1e-10 degrees.
    let pair = (frame_strategy(), frame_strategy());
    for axes in [RotaryAxes::AC, RotaryAxes::BC] {
        seeded(48)
            .run(&pair, |(f1, f2)| {
                rotary_round_trip(axes, f1, f2, 10);
                Ok(())
            })
            .unwrap_or_else(|e| panic!("{e}"));
        // Kinematic frames of whole-degree angles round-trip exactly at the default 4 decimals.
        let f1 = rotary_frame(axes, [35.0, 35.0, -120.0]);
        let f2 = rotary_frame(axes, [90.0, 90.0, 45.0]);
        let text = rotary_round_trip(axes, f1, f2, 4);
        let word = if axes == RotaryAxes::AC { "G0 A35 C-120" } else { "G0 B35 C-120" };
        assert!(text.contains(word), "{text}");
    }
    // Incremental rotary words add up; G20 does not scale degrees.
    let mut rec = MotionRecorder::default();
    let po = ParseOptions { rotary: Some(RotaryAxes::AC), ..ParseOptions::default() };
    parse_str("G20 G0 A30 C10\nG91 G0 A15 C-20 X1\n", &po, &mut rec).expect("parse");
    let rot: Vec<[Option<f64>; 3]> = rec
        .motions
        .iter()
        .filter_map(|(_, m)| match m {
            Motion::Setup { rotary, .. } => Some(*rotary),
            _ => None,
        })
        .collect();
    assert_eq!(rot, [[Some(30.0), None, Some(10.0)], [Some(45.0), None, Some(-10.0)]]);
    assert_eq!(rec.motions.iter().filter(|(_, m)| m.end_point().is_some()).count(), 1);
}

/// A tilting head with tool-centre-point control: the writer puts a tool axis into rotary
/// words without moving the tip, and the parser reads the same text back as tool axes
/// with the points unchanged; read as a turning table instead, the points are turned.
#[test]
fn head_tool_axes_read_back_with_the_tip_in_the_part_frame() {
    for axes in [RotaryAxes::AC, RotaryAxes::BC] {
        let tilted = rotary_axis(axes, [30.0, 30.0, 60.0]);
        let sideways = rotary_axis(axes, [90.0, 90.0, -45.0]);
        let points = [[5.0, -2.0, 10.0], [6.0, -1.0, 9.5], [6.0, 3.0, 9.0]];
        let ms = vec![
            Motion::Rapid { to: Point3::from(points[0]) },
            Motion::ToolAxis { axis: tilted, rotary: [None; 3] },
            Motion::Linear { to: Point3::from(points[1]), feed: 600.0, extrude: Some(0.05) },
            Motion::ToolAxis { axis: sideways, rotary: [None; 3] },
            Motion::Linear { to: Point3::from(points[2]), feed: 600.0, extrude: Some(0.05) },
        ];
        let opts = WriterOptions { rotary: Some(axes), decimals: 10, ..Default::default() };
        let text = write_program(Dialect::Marlin, opts, &ms).expect("writes");
        let read = |mount| {
            let mut rec = MotionRecorder::default();
            let po = ParseOptions { rotary: Some(axes), rotary_mount: mount, ..ParseOptions::default() };
            let summary = parse_str(&text, &po, &mut rec).expect("infallible sink");
            assert!(summary.errors.is_empty(), "{axes:?}: {:?}\n{text}", summary.errors);
            rec.motions.into_iter().map(|(_, m)| m).collect::<Vec<_>>()
        };
        let head = read(RotaryMount::Head);
        let got_axes: Vec<Vector3<f64>> = head
            .iter()
            .filter_map(|m| match m {
                Motion::ToolAxis { axis, .. } => Some(*axis),
                _ => None,
            })
            .collect();
        assert_eq!(got_axes.len(), 2, "{axes:?}\n{text}");
        for (got, want) in got_axes.iter().zip([tilted, sideways]) {
            assert!((got - want).norm() < 1e-9, "{axes:?}: axis {got} against {want}\n{text}");
        }
        assert!(!head.iter().any(|m| matches!(m, Motion::Setup { .. })), "{axes:?}: a head turns no table");
        let ends: Vec<Point3<f64>> = head.iter().filter_map(Motion::end_point).collect();
        // The three moves, then the footer's lift.
        assert_eq!(ends.len(), 4, "{axes:?}\n{text}");
        for (e, w) in ends.iter().zip(points) {
            assert!(close_pt(e, &Point3::from(w), 1e-9), "{axes:?}: tip {e} against {w:?}\n{text}");
        }
        // The angles written are the axis's.
        let [a, b, c] = axis_angles(axes, &sideways);
        assert!((rotary_axis(axes, [a, b, c]) - sideways).norm() < 1e-12);
        // The same text on a turning table: setups, and the part-frame tip moves with them.
        let table = read(RotaryMount::Table);
        let mut frame = Isometry3::identity();
        let mut tips = Vec::new();
        for m in &table {
            match m {
                Motion::Setup { frame: f, .. } => frame = *f,
                m => tips.extend(m.end_point().map(|p| frame * p)),
            }
        }
        assert!(close_pt(&tips[0], &Point3::from(points[0]), 1e-9));
        assert!(!close_pt(&tips[2], &Point3::from(points[2]), 1e-3), "{axes:?}: {:?}", tips[2]);
    }
    // Without rotary words, a tool axis is a comment, and the tip's words stay modal.
    let ms = [
        Motion::Linear { to: Point3::new(1.0, 2.0, 3.0), feed: 100.0, extrude: None },
        Motion::ToolAxis { axis: Vector3::x(), rotary: [None; 3] },
        Motion::Linear { to: Point3::new(1.0, 2.0, 4.0), feed: 100.0, extrude: None },
    ];
    let text = write_program(Dialect::LinuxCnc, WriterOptions::default(), &ms).expect("writes");
    assert!(text.contains("(TOOL AXIS = +1.000000 +0.000000 +0.000000)"), "{text}");
    assert!(text.lines().any(|l| l.trim() == "Z4"), "{text}");
}

/// Any tool axis (random unit vectors, the lower half included) written by the writer at
/// ten decimals reads back as the same axis on a head, and the tip between two turns as
/// the same point: [`axis_angles`] and [`rotary_axis`] invert each other through the text.
#[test]
fn any_head_axis_round_trips() {
    for axes in [RotaryAxes::AC, RotaryAxes::BC] {
        seeded(64)
            .run(&(frame_strategy(), frame_strategy()), |(f1, f2)| {
                let (a1, a2) = (f1.rotation * Vector3::z(), f2.rotation * Vector3::z());
                let (p1, p2) = (Point3::from(f1.translation.vector), Point3::from(f2.translation.vector));
                let ms = [
                    Motion::ToolAxis { axis: a1, rotary: [None; 3] },
                    Motion::Linear { to: p1, feed: 300.0, extrude: None },
                    Motion::ToolAxis { axis: a2, rotary: [None; 3] },
                    Motion::Linear { to: p2, feed: 300.0, extrude: None },
                ];
                let opts = WriterOptions { rotary: Some(axes), decimals: 10, ..Default::default() };
                let text = write_program(Dialect::LinuxCnc, opts, &ms).expect("writes");
                let mut rec = MotionRecorder::default();
                let po = ParseOptions {
                    rotary: Some(axes),
                    rotary_mount: RotaryMount::Head,
                    ..ParseOptions::default()
                };
                let summary = parse_str(&text, &po, &mut rec).expect("infallible sink");
                prop_assert!(summary.errors.is_empty(), "{:?}\n{}", summary.errors, text);
                let got: Vec<Vector3<f64>> = rec
                    .motions
                    .iter()
                    .filter_map(|(_, m)| match m {
                        Motion::ToolAxis { axis, .. } => Some(*axis),
                        _ => None,
                    })
                    .collect();
                prop_assert_eq!(got.len(), 2);
                prop_assert!(
                    (got[0] - a1).norm() < 1e-8 && (got[1] - a2).norm() < 1e-8,
                    "{:?}\n{}",
                    got,
                    text
                );
                let ends: Vec<Point3<f64>> = rec.motions.iter().filter_map(|(_, m)| m.end_point()).collect();
                prop_assert!(close_pt(&ends[0], &p1, 1e-8) && close_pt(&ends[1], &p2, 1e-8), "{:?}", ends);
                Ok(())
            })
            .unwrap_or_else(|e| panic!("{axes:?}: {e}"));
    }
}

// ---------------------------------------------------------------------------
// Drill cycles and tool changes through the writer (and back through the parser).

mod cycles_and_tools {
    use nalgebra::Point3;
    use s2g_gcode::{
        CycleKind, Dialect, DrillCycle, Motion, MotionRecorder, ParseOptions, WriterOptions, parse_str,
        write_program,
    };

    fn moves(ms: &[(u64, Motion<'static>)]) -> Vec<Motion<'static>> {
        ms.iter()
            .map(|(_, m)| m.clone())
            .filter(|m| matches!(m, Motion::Rapid { .. } | Motion::Linear { .. } | Motion::Dwell { .. }))
            .collect()
    }

    /// LinuxCNC text of each cycle, read back by the parser (its own cycle expansion), moves
    /// like `DrillCycle::expand`; grbl gets the expansion itself.
    #[test]
    fn written_cycles_parse_back_as_their_expansion() {
        for kind in [CycleKind::Drill, CycleKind::Dwell { seconds: 0.75 }, CycleKind::Peck { peck: 1.5 }] {
            let start = Point3::new(0.0, 0.0, 5.0);
            let cycle =
                DrillCycle { kind, x: 10.0, y: 4.0, clearance: 5.0, r_plane: 1.0, bottom: -4.0, feed: 100.0 };
            let program =
                [Motion::Rapid { to: start }, Motion::Cycle(cycle), Motion::Stop { optional: true }];
            let mut expected = vec![Motion::Rapid { to: start }];
            cycle.expand(Some(start), |m| expected.push(m));
            // Dedupe zero-length rapids the parser would not produce.
            expected.dedup_by(
                |b, a| matches!((a, b), (Motion::Rapid { to: p }, Motion::Rapid { to: q }) if p == q),
            );
            for dialect in [Dialect::LinuxCnc, Dialect::Grbl] {
                let opts = WriterOptions { line_numbers: true, footer: false, ..Default::default() };
                let text = write_program(dialect, opts, &program).expect("writes");
                assert_eq!(text.contains("G98"), dialect == Dialect::LinuxCnc, "{dialect:?}: {text}");
                assert!(text.contains("M1\n"), "{dialect:?}: optional stop in {text}");
                if dialect == Dialect::LinuxCnc {
                    assert!(text.contains("G80"), "cycle cancelled before the end: {text}");
                }
                let mut rec = MotionRecorder::default();
                parse_str(&text, &ParseOptions { stop_at_first_error: true, ..Default::default() }, &mut rec)
                    .expect("parses");
                let got = moves(&rec.motions);
                let mut got = got;
                got.dedup_by(
                    |b, a| matches!((a, b), (Motion::Rapid { to: p }, Motion::Rapid { to: q }) if p == q),
                );
                assert_eq!(
                    got.len(),
                    expected.len(),
                    "{kind:?} {dialect:?}: {got:?} vs {expected:?}\n{text}"
                );
                for (g, e) in got.iter().zip(&expected) {
                    let close = match (g, e) {
                        (Motion::Rapid { to: a }, Motion::Rapid { to: b })
                        | (Motion::Linear { to: a, .. }, Motion::Linear { to: b, .. }) => {
                            (a - b).norm() < 1e-3
                        }
                        (Motion::Dwell { seconds: a }, Motion::Dwell { seconds: b }) => (a - b).abs() < 1e-6,
                        _ => false,
                    };
                    assert!(close, "{kind:?} {dialect:?}: {g:?} vs {e:?}\n{text}");
                }
            }
        }
    }

    #[test]
    fn tool_length_offset_follows_tool_changes() {
        let program = [Motion::ToolChange { tool: 3 }, Motion::Rapid { to: Point3::new(1.0, 2.0, 3.0) }];
        let opts =
            WriterOptions { tool_length_offset: true, header: false, footer: false, ..Default::default() };
        let text = write_program(Dialect::LinuxCnc, opts.clone(), &program).expect("writes");
        assert_eq!(text, "T3 M6\nG43 H3\nG0 X1 Y2 Z3\n");
        let text = write_program(Dialect::Grbl, opts, &program).expect("writes");
        assert!(!text.contains("G43"), "grbl has no G43 H: {text}");
    }
}

/// An arc whose radius is above the written decimals' quantum but under LinuxCNC's radius
/// tolerance (0.00005 inch) is written as a line, which our parser (and `rs274`) reads; a
/// rest-roughing pass of a 3 mm end mill planned one on OpenSCAD's example001 and the
/// program failed to parse ("degenerate arc: zero radius").
#[test]
fn arcs_under_linuxcnc_s_radius_tolerance_are_written_as_lines() {
    for r in [0.0002, 0.0006, 0.0012, 0.002] {
        let start = Point3::new(1.0, 2.0, -1.0);
        let center = Point3::new(1.0 + r, 2.0, -1.0);
        let to = Point3::new(1.0 + r, 2.0 + r, -1.0);
        let motions = [
            Motion::Rapid { to: start },
            Motion::Arc {
                to,
                center,
                plane: Plane::XY,
                direction: ArcDirection::CounterClockwise,
                turns: 0,
                feed: 600.0,
                extrude: None,
            },
        ];
        let text = write_program(Dialect::LinuxCnc, WriterOptions::default(), &motions).unwrap();
        let back = parse_back(&format!("radius {r}"), &text);
        let arcs = back.iter().filter(|m| matches!(m, Motion::Arc { .. })).count();
        assert_eq!(arcs, usize::from(r >= 0.0013), "radius {r}: {text}");
    }
}
