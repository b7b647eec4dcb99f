//! Properties of the motions beyond G0-G3 and drilling (rotated coordinate systems,
//! splines, spindle-synchronised moves, probing, inverse time, threading), checked
//! against their definitions rather than against `rs274` (tests/rs274.rs does that).

use nalgebra::Point3;
use s2g_gcode::{
    GcodeErrorKind, Motion, MotionRecorder, ParseDialect, ParseOptions, ParseSummary, parse_str,
};

fn run(text: &str, opts: &ParseOptions) -> (ParseSummary, Vec<Motion<'static>>) {
    let mut rec = MotionRecorder::default();
    let s = parse_str(text, opts, &mut rec).expect("parse");
    (s, rec.motions.into_iter().map(|m| m.1).filter(|m| m.end_point().is_some()).collect())
}

fn clean(text: &str) -> Vec<Motion<'static>> {
    let strict = ParseOptions { dialect: ParseDialect::Cnc, ..ParseOptions::default() };
    let (s, m) = run(text, &strict);
    assert!(s.errors.is_empty(), "{text:?}: {:?}", s.errors);
    m
}

fn end(m: &Motion<'_>) -> Point3<f64> {
    m.end_point().expect("a move")
}

fn first_error(text: &str) -> (u64, u32, GcodeErrorKind) {
    let strict = ParseOptions { dialect: ParseDialect::Cnc, ..ParseOptions::default() };
    let (s, _) = run(text, &strict);
    let e = s.errors.first().unwrap_or_else(|| panic!("{text:?}: expected an error"));
    (e.line, e.column, e.kind.clone())
}

/// Under a rotated system, program coordinates are unchanged and `G53` reaches the
/// machine point: the work point of machine (mx, my) is the rotation back of
/// (mx, my) less the offset, for every angle.
#[test]
fn rotation_maps_machine_points_back() {
    for deg in [0.0f64, 15.0, 30.0, 90.0, -135.0, 400.0] {
        let text = format!("G21 F100\nG10 L2 P1 X3 Y-2 R{deg}\nG0 X1 Y1\nG53 G0 X10 Y5\nG1 X2\nM2\n");
        let m = clean(&text);
        assert_eq!(m.len(), 3, "{text}");
        assert!((end(&m[0]) - Point3::new(1.0, 1.0, 0.0)).norm() < 1e-12, "{text}: {:?}", m[0]);
        let (c, s) = (deg.to_radians().cos(), deg.to_radians().sin());
        let (px, py) = (10.0 - 3.0, 5.0 + 2.0);
        let want = Point3::new(c * px + s * py, -s * px + c * py, 0.0);
        assert!((end(&m[1]) - want).norm() < 1e-9, "{text}: {:?} want {want:?}", m[1]);
        // A later move in program coordinates keeps the other axis from the G53 point.
        assert!((end(&m[2]) - Point3::new(2.0, want.y, 0.0)).norm() < 1e-9, "{text}: {:?}", m[2]);
    }
    // `G10 L20` with R is refused, with the R word's column.
    assert_eq!(first_error("G21\nG10 L20 P1 X1 R30\n").0, 2);
}

/// A `G5.1` spline becomes straight feeds from its start to its end, each within the
/// tolerance of the quadratic Bézier curve; halving the tolerance adds segments.
#[test]
fn quadratic_splines_stay_within_tolerance() {
    let text = "G21 G17 F100\nG0 X0 Y0\nG5.1 X10 Y0 I5 J5\nM2\n";
    let mut counts = Vec::new();
    for tol in [0.1, 0.01, 0.001] {
        let opts = ParseOptions { spline_tolerance_mm: tol, ..ParseOptions::default() };
        let (s, m) = run(text, &opts);
        assert!(s.errors.is_empty(), "{:?}", s.errors);
        let pts: Vec<Point3<f64>> = m[1..].iter().map(end).collect();
        assert!((pts[pts.len() - 1] - Point3::new(10.0, 0.0, 0.0)).norm() < 1e-12);
        // The curve: B(u) = (10u, 10u(1-u)); its point nearest each chord's midpoint.
        let mut prev = Point3::new(0.0, 0.0, 0.0);
        for p in &pts {
            let mid = Point3::from((prev.coords + p.coords) / 2.0);
            let u = mid.x / 10.0;
            let dist = (mid.y - 10.0 * u * (1.0 - u)).abs();
            assert!(dist <= tol * 1.01, "tolerance {tol}: chord mid {mid:?} is {dist} off");
            prev = *p;
        }
        counts.push(pts.len());
    }
    assert!(counts.windows(2).all(|w| w[1] > w[0]), "{counts:?}");
    // No control point: an error on the G5.1 line.
    assert_eq!(first_error("G21 F100\nG5.1 X1 Y1\n").0, 2);
    // Outside the XY plane: an error.
    assert_eq!(first_error("G21 F100 G18\nG5.1 X1 Y1 I1 J0\n").0, 2);
}

/// `G33.1` taps in and comes back out along the same line: the position is unchanged;
/// `G33` ends at its target; both need K.
#[test]
fn spindle_synchronised_moves() {
    let m = clean("G21 S600 M3\nG0 X1 Y2 Z3\nG33.1 Z-4 K1.25\nG0 X5\nM2\n");
    let pts: Vec<Point3<f64>> = m.iter().map(end).collect();
    assert_eq!(pts[1], Point3::new(1.0, 2.0, -4.0));
    assert_eq!(pts[2], Point3::new(1.0, 2.0, 3.0));
    assert_eq!(pts[3], Point3::new(5.0, 2.0, 3.0));
    // The feed follows the spindle: K mm per revolution at 600 rpm.
    assert!(matches!(m[1], Motion::Linear { feed, .. } if (feed - 750.0).abs() < 1e-9), "{:?}", m[1]);
    let (line, col, kind) = first_error("G21 S600 M3\nG0 Z3\nG33 Z-4\n");
    assert_eq!((line, col), (3, 1));
    assert!(matches!(kind, GcodeErrorKind::MissingWord { letter: 'K', .. }), "{kind:?}");
}

/// A probe move reaches its target, sets `#5061`-`#5063`, and leaves the position
/// 0.254 mm back towards its start; a probe toward the point it is at is an error.
#[test]
fn probing_backs_off_and_sets_parameters() {
    let m = clean("G21 F50\nG0 X1 Y1 Z10\nG38.2 Z-2\nG0 X[#5061 + 1] Y[#5062] Z[#5063]\nG1 X3\nM2\n");
    let pts: Vec<Point3<f64>> = m.iter().map(end).collect();
    assert_eq!(pts[1], Point3::new(1.0, 1.0, -2.0));
    assert_eq!(pts[2], Point3::new(2.0, 1.0, -2.0));
    let m = clean("G21 F50\nG0 Z10\nG38.3 Z0\nG1 X1\nM2\n");
    assert!((end(&m[2]) - Point3::new(1.0, 0.0, 0.254)).norm() < 1e-12, "{:?}", m[2]);
    assert_eq!(first_error("G21 F50\nG0 Z1\nG38.2 Z1\n").0, 3);
}

/// Under `G93` each feed move takes 1/F minutes: feed = F × length; a feed move without
/// F is an error, and `G94` returns to the modal feed rate.
#[test]
fn inverse_time_feeds() {
    let m = clean("G21 F100\nG0 X0 Y0\nG93 G1 X30 Y40 F2\nG3 X-30 Y40 R50 F4\nG94 G1 X0 F70\nM2\n");
    let feed = |m: &Motion<'_>| match m {
        Motion::Linear { feed, .. } | Motion::Arc { feed, .. } => *feed,
        _ => f64::NAN,
    };
    assert!((feed(&m[1]) - 100.0).abs() < 1e-9, "{:?}", m[1]);
    // The arc from angle atan2(40, 30) to atan2(40, -30) on a radius of 50.
    let sweep = 40f64.atan2(-30.0) - 40f64.atan2(30.0);
    assert!((feed(&m[2]) - 4.0 * 50.0 * sweep).abs() < 1e-9, "{:?}", m[2]);
    assert!((feed(&m[3]) - 70.0).abs() < 1e-12, "{:?}", m[3]);
    let (line, _, kind) = first_error("G21 F100\nG93 G1 X1 F1\nG1 X2\n");
    assert_eq!(line, 3);
    assert!(matches!(kind, GcodeErrorKind::ZeroFeed(_)), "{kind:?}");
}

/// `G76` with constant depth (R1): passes at |I| + J n until the full depth, then H + 1
/// at it; every cut runs to the end Z and the cycle ends on the drive line at Z.
#[test]
fn threading_passes() {
    let m = clean("G21 G18 S300 M3\nG0 X20 Z5\nG76 P2 Z-30 I-1 J0.25 K1.2 H2\nM2\n");
    // Depths 1.25, 1.5, 1.75, 2.0 (< 2.2), then 2.2 three times: 7 passes of 4 moves.
    assert_eq!(m.len(), 1 + 7 * 4 + 1, "{m:?}");
    let cuts: Vec<Point3<f64>> = m[1..m.len() - 1].chunks(4).map(|p| end(&p[1])).collect();
    let want = [1.25, 1.5, 1.75, 2.0, 2.2, 2.2, 2.2];
    for (c, d) in cuts.iter().zip(want) {
        assert!((c.x - (20.0 - d)).abs() < 1e-12 && c.z == 5.0, "{c:?} for depth {d}");
    }
    for p in m[1..m.len() - 1].chunks(4) {
        assert!((end(&p[2]).z + 30.0).abs() < 1e-12, "{:?}", p[2]);
        assert!(matches!(p[2], Motion::Linear { feed, .. } if (feed - 600.0).abs() < 1e-9));
    }
    assert_eq!(end(&m[m.len() - 1]), Point3::new(20.0, 0.0, -30.0));
    // Only in the XZ plane, and J is needed.
    assert_eq!(first_error("G21 G17 S300 M3\nG76 P2 Z-30 I-1 J0.25 K1.2\n").0, 2);
    assert_eq!(first_error("G21 G18 S300 M3\nG76 P2 Z-30 I-1 K1.2\n").0, 2);
}

/// Odd values never panic and never give non-finite points.
#[test]
fn odd_values_stay_finite() {
    let programs = [
        "G21 F1\nG10 L2 P1 R[1e300]\nG0 X1 Y1\nG53 G0 X1\n",
        "G21 F1\nG5.1 X1e10 Y0 I1e-300 J1e300\n",
        "G21 F1 G18 S1 M3\nG76 P1e-9 Z-1e9 I-1 J1e-9 K1 R1\n",
        "G21 F1 G18 S1 M3\nG76 P1 Z-1 I-1 J1 K1 R1e308 Q89.9999 E1e300 L3 H1e12\n",
        "G21 F1\nG93 G2 X1 Y0 R1 F1e308\n",
        "G21 F1\nG43.1 Z1e308\nG0 X1\nG10 L20 P1 Z0\n",
    ];
    for p in programs {
        for dialect in [ParseDialect::Cnc, ParseDialect::Auto] {
            let opts = ParseOptions { dialect, ..ParseOptions::default() };
            let (_, m) = run(p, &opts);
            for x in &m {
                let e = end(x);
                assert!(e.iter().all(|v| v.is_finite()) || m.is_empty(), "{p:?}: {x:?}");
            }
        }
    }
}
