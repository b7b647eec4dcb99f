//! `MachineTime` against hand counts of trapezoidal speed profiles.

use nalgebra::{Point3, Vector3};
use s2g_gcode::{ArcDirection, MachineProfile, MachineTime, Motion, MotionSink, Plane, junction_speed};

fn machine(accel: f64) -> MachineProfile {
    MachineProfile { accel: [accel; 3], rapid: [6000.0; 3], max_feed: 6000.0, ..MachineProfile::default() }
}

fn run(m: MachineProfile, moves: &[Motion<'_>]) -> f64 {
    let mut t = MachineTime::new(m);
    for mv in moves {
        t.motion(mv).unwrap();
    }
    t.finish().unwrap();
    t.seconds()
}

fn at(x: f64, y: f64, z: f64) -> Point3<f64> {
    Point3::new(x, y, z)
}

fn lin(x: f64, y: f64, feed: f64) -> Motion<'static> {
    Motion::Linear { to: at(x, y, 0.0), feed, extrude: None }
}

fn close(a: f64, b: f64, what: &str) {
    assert!((a - b).abs() <= 1e-9 * b.abs().max(1.0), "{what}: {a} != {b}");
}

#[test]
fn collinear_moves_are_one_trapezoid() {
    // 20 mm at 600 mm/min = 10 mm/s with 100 mm/s²: 0.1 s up over 0.5 mm, 0.1 s down over
    // 0.5 mm, 19 mm cruising (1.9 s): 2.1 s, whether in one move or four.
    let start = Motion::Rapid { to: at(0.0, 0.0, 0.0) };
    close(run(machine(100.0), &[start.clone(), lin(20.0, 0.0, 600.0)]), 2.1, "one move");
    let split =
        [start, lin(5.0, 0.0, 600.0), lin(10.0, 0.0, 600.0), lin(15.0, 0.0, 600.0), lin(20.0, 0.0, 600.0)];
    close(run(machine(100.0), &split), 2.1, "four moves");
}

#[test]
fn short_moves_never_reach_their_feed() {
    // 1 mm at 6000 mm/min (100 mm/s) with 100 mm/s²: a triangle peaking at sqrt(a l) = 10
    // mm/s after 0.5 mm: 2 * 0.1 s.
    let moves = [Motion::Rapid { to: at(0.0, 0.0, 0.0) }, lin(1.0, 0.0, 6000.0)];
    close(run(machine(100.0), &moves), 0.2, "triangle");
}

#[test]
fn a_square_corner_slows_to_the_junction_speed() {
    // Two 10 mm legs at 10 mm/s meeting at 90 degrees, with a junction speed vj:
    // each leg accelerates or decelerates between 0 and 10 mm/s at one end and between vj
    // and 10 mm/s at the corner.
    let m = machine(100.0);
    let vj = junction_speed(&Vector3::x(), &Vector3::y(), 100.0, m.junction_deviation);
    // sin(45°) = 0.7071: vj² = a δ s / (1 - s) = 100 * 0.01 * 2.414 = 2.414.
    close(vj * vj, 100.0 * 0.01 * (0.5f64.sqrt() / (1.0 - 0.5f64.sqrt())), "vj");
    let leg = |v0: f64, v1: f64| {
        let (v, a, l) = (10.0, 100.0, 10.0);
        let d = (v * v - v0 * v0) / (2.0 * a) + (v * v - v1 * v1) / (2.0 * a);
        (v - v0) / a + (v - v1) / a + (l - d) / v
    };
    let want = leg(0.0, vj) + leg(vj, 0.0);
    let moves = [Motion::Rapid { to: at(0.0, 0.0, 0.0) }, lin(10.0, 0.0, 600.0), lin(10.0, 10.0, 600.0)];
    close(run(m, &moves), want, "square corner");
    // A reversal stops completely.
    let back = [Motion::Rapid { to: at(0.0, 0.0, 0.0) }, lin(10.0, 0.0, 600.0), lin(0.0, 0.0, 600.0)];
    close(run(machine(100.0), &back), 2.0 * leg(0.0, 0.0), "reversal");
}

#[test]
fn rapids_use_the_slowest_axis_and_feeds_are_capped() {
    let m = MachineProfile {
        rapid: [6000.0, 6000.0, 600.0],
        accel: [1e9, 1e9, 1e9],
        max_feed: 1200.0,
        ..MachineProfile::default()
    };
    // 10 mm along Z at 10 mm/s; 10 mm along X at the 20 mm/s feed cap (F 6000 asked).
    let moves = [
        Motion::Rapid { to: at(0.0, 0.0, 0.0) },
        Motion::Rapid { to: at(0.0, 0.0, 10.0) },
        Motion::Linear { to: at(10.0, 0.0, 10.0), feed: 6000.0, extrude: None },
    ];
    let t = run(m, &moves);
    assert!((t - 1.5).abs() < 1e-6, "{t}");
}

#[test]
fn tool_changes_and_dwells_stop_and_add_their_time() {
    let m = machine(100.0);
    let change = m.tool_change_s;
    let moves = [
        Motion::Rapid { to: at(0.0, 0.0, 0.0) },
        lin(10.0, 0.0, 600.0),
        Motion::ToolChange { tool: 2 },
        lin(20.0, 0.0, 600.0),
        Motion::Dwell { seconds: 1.5 },
    ];
    // Each 10 mm leg stops: 1.1 s each.
    close(run(m, &moves), 2.2 + change + 1.5, "stops");
}

#[test]
fn arcs_are_capped_by_centripetal_acceleration() {
    // A full circle of radius 1 at F 6000: sqrt(a r) with a = 100 mm/s² is 10 mm/s, far
    // below the 100 mm/s feed.
    let a = 100.0;
    let v = (a * 1.0f64).sqrt();
    let l = std::f64::consts::TAU;
    let want = l / v + v / a;
    let moves = [
        Motion::Rapid { to: at(1.0, 0.0, 0.0) },
        Motion::Arc {
            to: at(1.0, 0.0, 0.0),
            center: at(0.0, 0.0, 0.0),
            plane: Plane::XY,
            direction: ArcDirection::CounterClockwise,
            turns: 0,
            feed: 6000.0,
            extrude: None,
        },
    ];
    close(run(machine(100.0), &moves), want, "circle");
}

#[test]
fn a_long_program_matches_the_unbounded_plan_and_never_beats_the_feed_time() {
    // A zigzag of 500 legs: the bounded look-ahead gives the same time as a window that
    // holds everything, and no time is below length / feed.
    let mut moves = vec![Motion::Rapid { to: at(0.0, 0.0, 0.0) }];
    for i in 0..500 {
        let y = i as f64 * 0.5;
        let x = if i % 2 == 0 { 30.0 } else { 0.0 };
        moves.push(lin(x, y, 1500.0));
        moves.push(lin(x, y + 0.5, 1500.0));
    }
    let bounded = run(machine(200.0), &moves);
    let unbounded = run(MachineProfile { lookahead: 100_000, ..machine(200.0) }, &moves);
    close(bounded, unbounded, "bounded look-ahead");
    let length = 500.0 * 30.0 + 500.0 * 0.5;
    assert!(bounded > length / 25.0, "{bounded} s for {length} mm at 25 mm/s");
}

#[test]
fn bad_machines_name_the_field() {
    let bad = |m: MachineProfile| m.validate().unwrap_err();
    assert!(bad(MachineProfile { max_feed: 0.0, ..MachineProfile::default() }).contains("max_feed"));
    assert!(
        bad(MachineProfile { accel: [1.0, f64::NAN, 1.0], ..MachineProfile::default() }).contains("accel")
    );
    assert!(
        bad(MachineProfile { spindle_rpm: [5000.0, 100.0], ..MachineProfile::default() }).contains("spindle")
    );
    assert!(bad(MachineProfile { lookahead: 0, ..MachineProfile::default() }).contains("lookahead"));
    assert!(MachineProfile::default().validate().is_ok());
}
