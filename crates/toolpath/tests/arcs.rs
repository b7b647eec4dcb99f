//! Arc fitting in the planner (`PlanOptions::arc_tolerance`) and in finishing.

mod common;

use s2g_gcode::{ArcDirection, Motion, MotionRecorder, MotionSink, Plane};
use s2g_geom::{Aabb, Point3, Setup};
use s2g_toolpath::{PlanOptions, Tool, plan_setup, strategies};

use common::{HeightField, sphere};

/// A move: start, end and, for an XY arc, its centre and direction.
type Move = (Point3, Point3, Option<(Point3, ArcDirection)>);

/// The moves of a recorded program at level `z`, after the first that reaches it: each as
/// (start, end, `Some((centre, direction))` for an XY arc).
fn moves_at(rec: &MotionRecorder, z: f64) -> Vec<Move> {
    let mut out = Vec::new();
    let mut pos: Option<Point3> = None;
    for (_, m) in &rec.motions {
        let Some(to) = m.end_point() else { continue };
        if let Some(from) = pos
            && (from.z - z).abs() < 1e-9
            && (to.z - z).abs() < 1e-9
        {
            match *m {
                Motion::Arc { center, plane: Plane::XY, direction, turns: 0, .. } => {
                    out.push((from, to, Some((center, direction))))
                }
                Motion::Linear { .. } => out.push((from, to, None)),
                _ => {}
            }
        }
        pos = Some(to);
    }
    out
}

/// A 20 mm square boss milled with a 3 mm tool and arcs at 0.01 mm: its contour turns
/// each corner on an arc about the corner itself, clockwise (climb: the part on the
/// right), whose radius is the planned distance from the wall (the tool radius and the
/// tolerance, which the walls keep) to within the contour's own thinning. The arc spans
/// most of the corner (but where the loop starts and ends, inside one corner's join): the
/// planner's polygon has its join vertices on the circle and its chords inside it, so a
/// piece on the part's side meets the chain in the middle of a chord, and one short piece
/// on each side links it to the straight offsets. The loop that took 38 straight moves
/// takes 18.
#[test]
fn a_square_contour_turns_each_corner_on_one_arc_about_it() {
    let part = HeightField::new(1, 1, 20.0, |_, _| 5.0).mesh();
    let stock = Aabb::new(Point3::new(-10.0, -10.0, 0.0), Point3::new(30.0, 30.0, 5.0));
    let (r, tol) = (3.0, 0.01);
    let plan = |arc_tolerance| {
        let opts = PlanOptions {
            layer_height: 5.0,
            stock: Some(stock),
            strategy: strategies().get("periphery").expect("periphery"),
            arc_tolerance,
            ..Default::default()
        };
        let mut rec = MotionRecorder::default();
        plan_setup(&part, &Setup::top(), &Tool::flat(r), &opts, &mut rec).expect("plan");
        moves_at(&rec, 0.0)
    };
    let fitted = plan(Some(tol));
    let straight = plan(None);
    let mut whole = 0;
    for (x, y) in [(0.0, 0.0), (0.0, 20.0), (20.0, 20.0), (20.0, 0.0)] {
        let corner = Point3::new(x, y, 0.0);
        let arcs: Vec<_> = fitted
            .iter()
            .filter_map(|&(a, b, arc)| {
                arc.filter(|(c, _)| (c - corner).norm() < 1e-3).map(|(c, d)| (a, b, c, d))
            })
            .collect();
        assert!(!arcs.is_empty(), "no arc about the corner ({x}, {y}): {fitted:?}");
        let mut turn = 0.0;
        for (a, b, c, d) in arcs {
            assert_eq!(d, ArcDirection::Clockwise);
            // Radii about the arc's own centre (within a micrometre of the corner).
            let (ra, rb) = ((a - c).norm(), (b - c).norm());
            assert!(ra >= r + tol && ra <= r + tol + 0.005 * r + 1e-3, "radius {ra}");
            assert!((ra - rb).abs() < 1e-6);
            turn += (a - c).angle(&(b - c));
        }
        whole += usize::from(turn > 65f64.to_radians());
    }
    // The loop starts and ends at a vertex of one corner's join, which its arc cannot span.
    assert!(whole >= 3, "{whole} corners turned on an arc about them");
    // The contour loop: everything at the level within the tool radius and a margin of the
    // square (the periphery rings lie a step-over inside the free region, farther out).
    let on_contour = |m: &&Move| {
        let d = |p: &Point3| (p.x.clamp(0.0, 20.0) - p.x).hypot(p.y.clamp(0.0, 20.0) - p.y);
        d(&m.0) < r + 0.1 && d(&m.1) < r + 0.1
    };
    let (n_fit, n_straight) =
        (fitted.iter().filter(on_contour).count(), straight.iter().filter(on_contour).count());
    assert!(n_straight >= 30 && n_fit <= 20, "contour: {n_fit} moves fitted, {n_straight} straight");
}

/// Parallel finishing over a faceted sphere with arcs at 0.005 mm: the passes (along X)
/// become G18 arcs and lines, far fewer moves than the straight passes with their steps
/// up and over the chords that would cut in; sampled densely, the arcs come no nearer the
/// part than the straight moves (both are checked with the drop-cutter at the same
/// samples) and lie within the tolerance (and the sampling's chord tolerance) above the
/// cutter-location surface, measured across it;
/// the simulated surface is gouged no deeper and left no coarser than without arcs.
#[test]
fn finishing_passes_become_arcs_above_the_surface() {
    use s2g_geom::{Cutter, DropCutter, MeshIndex};
    use s2g_toolpath::finish::{FinishOptions, Parallel, finish_setup_opt};
    use s2g_voxsim::{HeightField, HeightFieldOptions, ToolTable, surface_deviation};
    let mesh = sphere(15.0, 96, 48);
    let index = MeshIndex::new(&mesh).expect("index");
    let tool = Tool::ball(2.0);
    let cutter = Cutter::ball(2.0, 30.0);
    let dc = DropCutter::new(&index, &cutter).expect("drop-cutter");
    let tol = 0.005;
    let finish = |arc_tolerance| {
        let opts = FinishOptions { scallop: 0.05, floor: Some(0.0), arc_tolerance, ..Default::default() };
        let mut rec = MotionRecorder::default();
        finish_setup_opt(&index, &Setup::top(), &tool, &Parallel::default(), &opts, &mut rec)
            .expect("finish");
        rec
    };
    let (straight, fitted) = (finish(None), finish(Some(tol)));
    let moves = |rec: &MotionRecorder| rec.motions.iter().filter(|(_, m)| m.end_point().is_some()).count();
    let (n0, n1) = (moves(&straight), moves(&fitted));
    // Every feed, sampled 0.005 apart: how deep the part reaches above it, and for arcs
    // how far above the surface they pass, measured across it.
    let sweep = |rec: &MotionRecorder| {
        let (mut deepest, mut highest, mut arcs) = (0.0f64, 0.0f64, 0);
        let mut pos: Option<Point3> = None;
        for (_, m) in &rec.motions {
            let piece = match (m, pos) {
                (&Motion::Linear { to, .. }, Some(a)) => Some((None, a, to)),
                (&Motion::Arc { to, center, plane: Plane::ZX, direction, turns, .. }, Some(a)) => {
                    let spec =
                        s2g_gcode::ArcSpec { start: a, end: to, center, plane: Plane::ZX, direction, turns };
                    Some((Some(spec), a, to))
                }
                _ => None,
            };
            if let Some((spec, a, b)) = piece {
                arcs += usize::from(spec.is_some());
                let len = spec.map_or((b - a).norm(), |s| s.length());
                let n = (len / 0.005).ceil().max(1.0) as usize;
                for k in 0..=n {
                    let t = k as f64 / n as f64;
                    let p = spec.map_or(a + (b - a) * t, |s| s.point_at(t));
                    let Some(h) = dc.height(p.x, p.y) else { continue };
                    deepest = deepest.max(h - p.z);
                    if spec.is_some() {
                        let h = |x: f64| dc.height(x, p.y).unwrap_or(h);
                        let slope = (h(p.x + 0.01) - h(p.x - 0.01)) / 0.02;
                        highest = highest.max((p.z - h(p.x)) / slope.hypot(1.0));
                    }
                }
            }
            if let Some(p) = m.end_point() {
                pos = Some(p);
            }
        }
        (deepest, highest, arcs)
    };
    let (deep0, _, _) = sweep(&straight);
    let (deep1, high1, arcs) = sweep(&fitted);
    assert!(arcs > 100, "{arcs} arcs");
    assert!((n1 as f64) < 0.6 * n0 as f64, "{n1} moves with arcs, {n0} without");
    // Both are checked at samples 0.05 apart to 1e-4: between them the part may reach a
    // little higher, as much along arcs as along chords.
    assert!(deep1 <= deep0.max(1e-3), "the part reaches {deep1} above an arc, {deep0} above a chord");
    assert!(high1 <= tol + 0.003, "an arc passes {high1} above the surface");
    let deviation = |rec: &MotionRecorder| {
        // Arcs replayed as chords within 1e-5 (the default 1e-3, inside the arc, would
        // cut that much into the part where an arc hugs it).
        let fo = HeightFieldOptions { arc_tolerance: 1e-5, ..HeightFieldOptions::default() };
        let mut field = HeightField::new_opt([-12.0, -12.0], [12.0, 12.0], ToolTable::single(cutter), &fo)
            .expect("field");
        for (_, m) in &rec.motions {
            field.motion(m).expect("replays");
        }
        surface_deviation(&field, &index)
    };
    let (d0, d1) = (deviation(&straight), deviation(&fitted));
    assert!(
        d1.gouge_depth <= d0.gouge_depth + 1e-4,
        "gouge {} with arcs, {} without",
        d1.gouge_depth,
        d0.gouge_depth
    );
    assert!(d1.max <= d0.max + tol, "{d1:?} against {d0:?}");
}
