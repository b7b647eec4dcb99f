//! Acceptance tests of the toolpath planner on analytic parts and bundled meshes.

mod common;

use common::{
    Above, HeightField, MeshAbove, Truth, check_program, cylinder, inside_stock, moves, samples, uncovered,
};
use s2g_gcode::MotionRecorder;
use s2g_geom::{Aabb, Isometry3, Mesh, MeshIndex, Point3, Rotation3, Setup, Similarity3, Vector3};
use std::sync::Arc;

use s2g_toolpath::{
    ClearingContext, ClearingStrategy, Periphery, PlanOptions, PlanSummary, Point2, SetupSlices, Spiral,
    Tool, ToolpathError, Zigzag, plan_layers, plan_setup, plan_setup_rest, slice_setup, strategies,
};

/// The strategies every property is checked with.
fn all_strategies() -> [Arc<dyn ClearingStrategy>; 4] {
    [
        Arc::new(Zigzag { angle_deg: 0.0 }),
        Arc::new(Zigzag { angle_deg: 30.0 }),
        Arc::new(Periphery),
        Arc::new(Spiral),
    ]
}

/// The analytic parts: (name, height field).
fn analytic_parts() -> Vec<(&'static str, HeightField)> {
    vec![
        ("box", HeightField::new(4, 3, 0.25, |_, _| 0.4)),
        ("stepped block", HeightField::new(8, 6, 0.125, |i, _| if i < 4 { 0.5 } else { 0.25 })),
        (
            "box with pocket",
            HeightField::new(
                8,
                8,
                0.125,
                |i, j| if (2..6).contains(&i) && (2..6).contains(&j) { 0.2 } else { 0.5 },
            ),
        ),
        (
            "stepped block with pocket",
            HeightField::new(10, 8, 0.1, |i, j| {
                if (1..4).contains(&i) && (2..6).contains(&j) {
                    0.15
                } else if i >= 6 {
                    0.3
                } else {
                    0.5
                }
            }),
        ),
    ]
}

fn opts_for(strategy: Arc<dyn ClearingStrategy>, h: f64) -> PlanOptions {
    PlanOptions { layer_height: h, strategy, stock_margin: 0.1, ..Default::default() }
}

/// Checks one analytic part with one strategy: distance to the exact closure, stock bounds,
/// coverage and rapids.
fn check_heightfield(name: &str, hf: &HeightField, strategy: &Arc<dyn ClearingStrategy>) {
    let part = hf.mesh();
    let tool = Tool::flat(0.04);
    let r = tool.radius();
    let opts = opts_for(strategy.clone(), 0.1);
    let (slices, layers) = plan_layers::<()>(&part, &Setup::top(), &tool, &opts, None).expect("plans");
    let stock = slices.stock;
    // Floors land exactly on the flat levels.
    for f in hf.h.iter() {
        assert!(
            slices.levels.iter().any(|z| (z - f).abs() < 1e-12) || *f >= stock.max.z - 1e-9,
            "{name}: no layer at floor {f}: {:?}",
            slices.levels
        );
    }
    assert!(
        (slices.levels.last().copied().unwrap_or(f64::NAN) - 0.0).abs() < 1e-12,
        "{name}: last level {:?}",
        slices.levels
    );
    let lo = Point2::new(stock.min.x, stock.min.y);
    let hi = Point2::new(stock.max.x, stock.max.y);
    for (plan, keep) in layers.iter().zip(&slices.keepouts) {
        let ki = keep.index();
        for path in plan.contour.iter().chain(&plan.clearing) {
            for p in samples(path, 0.25 * r) {
                // Independent: exact horizontal distance to the material above the level.
                let d = hf.distance_above(&p, plan.z, 1e-7);
                assert!(
                    d >= r - 1e-7,
                    "{name}/{}: layer {} z {}: point {p:?} is {d} from the part (< r = {r})",
                    strategy.name(),
                    plan.index,
                    plan.z
                );
                // The planner's own exact keep-out agrees.
                let dk = common::sd(&ki, &p);
                assert!(dk >= r - 1e-7, "{name}/{}: keep-out distance {dk} at {p:?}", strategy.name());
                let q = Point3::new(p.x, p.y, plan.z);
                assert!(inside_stock(&q, &stock, r, stock.max.z), "{name}: {q:?} outside stock + r");
            }
        }
        let miss = uncovered(plan, keep, lo, hi, r, 0.3 * r);
        assert!(
            miss.is_empty(),
            "{name}/{}: layer {} z {}: {} uncovered material points, e.g. {:?}",
            strategy.name(),
            plan.index,
            plan.z,
            miss.len(),
            &miss[..miss.len().min(5)]
        );
    }
    // The program: cutting inside the stock allowance (x, y and z) and clear of the part,
    // rapids only above the stock or straight down onto levels already cleared.
    let mut rec = MotionRecorder::default();
    let summary = plan_setup(&part, &Setup::top(), &tool, &opts, &mut rec).expect("plan");
    assert_eq!(summary.layers, slices.levels.len());
    let clear_z = stock.max.z + opts.clearance_height;
    let what = format!("{name}/{}", strategy.name());
    let counts = check_program(&what, &rec, &stock, r, clear_z, hf, None, 0.25 * r);
    assert!(counts.cutting_points > 0 && counts.rapids_below_top > 0, "{what}: {counts:?}");
}

#[test]
fn analytic_parts_keep_clear_stay_in_stock_and_leave_no_islands() {
    for (name, hf) in analytic_parts() {
        for s in all_strategies() {
            check_heightfield(name, &hf, &s);
        }
    }
}

#[test]
fn cylinder_contour_keeps_the_radius_and_covers() {
    let part = cylinder(0.5, 0.5, 0.3, 0.4, 48);
    let tool = Tool::flat(0.03);
    let r = tool.radius();
    for s in all_strategies() {
        let opts = opts_for(s.clone(), 0.1);
        let (slices, layers) = plan_layers::<()>(&part, &Setup::top(), &tool, &opts, None).expect("plans");
        let lo = Point2::new(slices.stock.min.x, slices.stock.min.y);
        let hi = Point2::new(slices.stock.max.x, slices.stock.max.y);
        for (plan, keep) in layers.iter().zip(&slices.keepouts) {
            let ki = keep.index();
            for path in plan.contour.iter().chain(&plan.clearing) {
                for p in samples(path, 0.25 * r) {
                    // The prism is inside the circle: distance to the circle is a lower bound.
                    // Nothing is above the top level (the tip may rest on the top face).
                    let d = if plan.z < 0.4 - 1e-9 {
                        ((p - Point2::new(0.5, 0.5)).norm() - 0.3).max(0.0)
                    } else {
                        f64::INFINITY
                    };
                    let dk = common::sd(&ki, &p);
                    assert!(
                        dk >= r - 1e-7 && d >= r - 1e-7 - 0.3 * (1.0 - (std::f64::consts::PI / 48.0).cos()),
                        "cylinder/{}: {p:?} d {d} dk {dk}",
                        s.name()
                    );
                }
            }
            let miss = uncovered(plan, keep, lo, hi, r, 0.3 * r);
            assert!(
                miss.is_empty(),
                "cylinder/{}: {} uncovered, e.g. {:?}",
                s.name(),
                miss.len(),
                miss.first()
            );
        }
    }
}

fn bunny() -> Mesh {
    let m = s2g_geom::load_mesh(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/meshes/classic/stanford_bunny.stl"
    ))
    .expect("bundled bunny");
    s2g_geom::normalize_unit_cube(&m).expect("normalise").0
}

fn openscad(name: &str) -> Mesh {
    let p = format!("{}/../../tests/data/meshes/openscad/{name}", env!("CARGO_MANIFEST_DIR"));
    let m = s2g_geom::load_mesh(&p).unwrap_or_else(|e| panic!("{p}: {e}"));
    s2g_geom::normalize_unit_cube(&m).expect("normalise").0
}

/// Every property on a bundled mesh, against oracles independent of the planner's regions
/// (`truth` is the part as it really is; `part` is what the planner is given):
/// - every contour and clearing point, on every layer, sampled every r/2 along the paths,
///   is at least r from the part's material above the level (geom's BVH closest point to
///   the part's triangles clipped above the level, [`MeshAbove`]); the planner's own
///   keep-out agrees with the oracle there;
/// - the emitted program's cutting moves (sampled every r) pass the same oracle, and the
///   part's signed distance clears the tool axis ([`Truth::check_tip`], every 4r);
/// - cutting stays inside the stock allowance in x, y and z; rapids stay above the stock or
///   go straight down onto cleared levels, clear of the part ([`check_program`]);
/// - no reachable material point of a layer is missed by the paths ([`uncovered`]).
fn check_mesh(
    name: &str,
    part: &Mesh,
    truth: &Mesh,
    setup: &Setup,
    strategy: &Arc<dyn ClearingStrategy>,
) -> (SetupSlices, PlanSummary) {
    let tool = Tool::flat(0.02);
    let r = tool.radius();
    let opts = PlanOptions {
        layer_height: 1.0 / 16.0,
        stock_margin: 0.05,
        strategy: strategy.clone(),
        ..Default::default()
    };
    let name = format!("{name}/{strategy:?}");
    let (slices, layers) = plan_layers::<()>(part, setup, &tool, &opts, None).expect("plans");
    assert!(layers.len() >= 8, "{name}: {} layers", layers.len());
    let above = MeshAbove::new(truth, setup, &slices.levels, opts.level_tolerance);
    let index = MeshIndex::new(truth).expect("index");
    let truth = Truth { sdf: &index, setup: *setup, every: 4 };
    let stock = slices.stock;
    let clear_z = stock.max.z + opts.clearance_height;
    let lo = Point2::new(stock.min.x, stock.min.y);
    let hi = Point2::new(stock.max.x, stock.max.y);
    let mut points = 0;
    for (plan, keep) in layers.iter().zip(&slices.keepouts) {
        let ki = keep.index();
        let what = format!("{name}: layer {} z {}", plan.index, plan.z);
        for path in plan.contour.iter().chain(&plan.clearing) {
            for p in samples(path, 0.5 * r) {
                points += 1;
                let d = above.above(&p, plan.z);
                assert!(d >= r - 1e-7, "{what}: point {p:?} is {d} from the part above (< r = {r})");
                let dk = common::sd(&ki, &p);
                assert!(dk >= r - 1e-7, "{what}: point {p:?} keep-out distance {dk}");
                assert!(
                    dk == d || (dk - d).abs() <= 1e-6 * (1.0 + d),
                    "{what}: keep-out distance {dk} but part distance {d}"
                );
                let q = Point3::new(p.x, p.y, plan.z);
                assert!(inside_stock(&q, &stock, r, clear_z), "{what}: {q:?} outside the stock allowance");
            }
        }
        let miss = uncovered(plan, keep, lo, hi, r, 0.5 * r);
        assert!(
            miss.is_empty(),
            "{what}: {} uncovered material points, e.g. {:?}",
            miss.len(),
            &miss[..miss.len().min(5)]
        );
    }
    assert!(points > 1000, "{name}: only {points} path points");
    let mut rec = MotionRecorder::default();
    let summary = plan_setup(part, setup, &tool, &opts, &mut rec).expect("plan");
    assert_eq!(summary.layers, slices.levels.len());
    // The emitted program: the same paths plus links and entries, sampled every r of
    // travel; the signed distance every 4th sample (it dominates the test's time).
    let counts = check_program(&name, &rec, &stock, r, clear_z, &above, Some(&truth), r);
    assert!(counts.cutting_points > 0 && counts.rapids_below_top > 0, "{name}: {counts:?}");
    (slices, summary)
}

#[test]
fn bundled_meshes_keep_the_tool_radius() {
    let bunny = bunny();
    let ex1 = openscad("openscad_Old_example001.stl");
    for s in all_strategies() {
        check_mesh("bunny", &bunny, &bunny, &Setup::top(), &s);
        check_mesh("example001 from +X", &ex1, &ex1, &Setup::six_axes()[2], &s);
    }
}

/// The full property checks re-run on moved and reversed copies of a bundled part.
#[test]
fn rotated_and_reversed_parts_pass_every_property() {
    let part = openscad("openscad_Old_example002.stl");
    let top = Setup::top();
    for s in [Arc::new(Zigzag::default()) as Arc<dyn ClearingStrategy>, Arc::new(Spiral)] {
        let (base, b) = check_mesh("example002", &part, &part, &top, &s);
        // Turned 37 degrees about the setup's Z axis: a different plan (passes meet the
        // walls at new angles), the same cross-section areas.
        let spin = Isometry3::rotation(Vector3::z() * 37f64.to_radians());
        let spun = part.transformed(&Similarity3::from_isometry(spin, 1.0));
        let (turned, _) = check_mesh("example002 turned 37 deg about Z", &spun, &spun, &top, &s);
        assert_eq!(base.levels.len(), turned.levels.len());
        for (l, (a, c)) in base.keepouts.iter().zip(&turned.keepouts).enumerate() {
            let rel = (a.area() - c.area()).abs() / a.area().max(1e-12);
            assert!(rel <= 1e-6, "turned: layer {l} keep-out area {} vs {}", a.area(), c.area());
        }
        // Moved rigidly (a general rotation and a shift) with the setup moved with it: the
        // setup-frame geometry, and so the program, is the same.
        let iso = Isometry3::from_parts(
            nalgebra::Translation3::new(0.2, -0.1, 0.05),
            Rotation3::from_euler_angles(0.3, -0.7, 1.1),
        );
        let moved = part.transformed(&Similarity3::from_isometry(iso, 1.0));
        let setup = Setup { frame: iso * top.frame };
        let (_, m) = check_mesh("example002 moved with its setup", &moved, &moved, &setup, &s);
        assert!(
            (m.cutting_length - b.cutting_length).abs() <= 1e-6 * b.cutting_length,
            "moved {m:?} vs {b:?}"
        );
        // Every triangle's orientation reversed: the same part, the same program.
        let (_, f) = check_mesh("example002 reversed", &part.flipped(), &part, &top, &s);
        assert!(
            (f.cutting_length - b.cutting_length).abs() <= 1e-9 * b.cutting_length,
            "reversed {f:?} vs {b:?}"
        );
        assert_eq!(
            (f.retracts, f.helix_entries, f.ramp_entries),
            (b.retracts, b.helix_entries, b.ramp_entries)
        );
    }
}

#[test]
fn flipped_and_rotated_parts_give_the_same_keepouts() {
    let part = openscad("openscad_Old_example002.stl");
    let tool = Tool::flat(0.02);
    let opts = PlanOptions { layer_height: 1.0 / 16.0, ..Default::default() };
    let base = slice_setup::<()>(&part, &Setup::top(), &tool, &opts).expect("slices");
    let flipped = slice_setup::<()>(&part.flipped(), &Setup::top(), &tool, &opts).expect("slices");
    assert_eq!(base.levels, flipped.levels);
    for (l, (a, b)) in base.keepouts.iter().zip(&flipped.keepouts).enumerate() {
        assert!((a.area() - b.area()).abs() <= 1e-9, "flipped: layer {l} area {} vs {}", a.area(), b.area());
    }
    // Rotate the part by R and the setup with it: the setup-frame geometry is unchanged.
    let rot = Rotation3::from_euler_angles(0.3, -0.7, 1.1);
    let iso = Isometry3::from_parts(nalgebra::Translation3::new(0.2, -0.1, 0.05), rot);
    let moved = part.transformed(&s2g_geom::Similarity3::from_isometry(iso, 1.0));
    let setup = Setup { frame: iso * Setup::top().frame };
    let rotated = slice_setup::<()>(&moved, &setup, &tool, &opts).expect("slices");
    assert_eq!(base.levels.len(), rotated.levels.len());
    for (l, (a, b)) in base.keepouts.iter().zip(&rotated.keepouts).enumerate() {
        let rel = (a.area() - b.area()).abs() / a.area().max(1e-12);
        assert!(rel <= 1e-6, "rotated: layer {l} area {} vs {}", a.area(), b.area());
    }
    // And the planned programs agree in length.
    let mut r1 = MotionRecorder::default();
    let mut r2 = MotionRecorder::default();
    let s1 = plan_setup(&part, &Setup::top(), &tool, &opts, &mut r1).expect("plan");
    let s2 = plan_setup(&part.flipped(), &Setup::top(), &tool, &opts, &mut r2).expect("plan");
    assert!((s1.cutting_length - s2.cutting_length).abs() <= 1e-6 * s1.cutting_length, "{s1:?} vs {s2:?}");
    let _ = Vector3::z();
}

#[test]
fn impossible_inputs_are_typed_errors() {
    let part = HeightField::new(2, 2, 0.5, |_, _| 0.3).mesh();
    let top = Setup::top();
    let mut rec = MotionRecorder::default();
    let bad_tools = [
        Tool::flat(0.0),
        Tool::flat(f64::NAN),
        Tool { feed: 0.0, ..Tool::flat(0.1) },
        Tool::bull(0.1, 0.2),
        Tool { cutter: s2g_geom::Cutter { flute_length: -1.0, ..Tool::flat(0.1).cutter }, ..Tool::flat(0.1) },
    ];
    for t in bad_tools {
        let e = plan_setup(&part, &top, &t, &PlanOptions::default(), &mut rec);
        assert!(matches!(e, Err(ToolpathError::InvalidTool(_))), "{t:?}: {e:?}");
    }
    let bad_opts = [
        PlanOptions { layer_height: 0.0, ..Default::default() },
        PlanOptions { stepover: 1.5, ..Default::default() },
        PlanOptions { stepover: f64::NAN, ..Default::default() },
        PlanOptions { strategy: Arc::new(Zigzag { angle_deg: f64::INFINITY }), ..Default::default() },
        PlanOptions { arc_step: -1.0, ..Default::default() },
    ];
    for o in bad_opts {
        let e = plan_setup(&part, &top, &Tool::flat(0.1), &o, &mut rec);
        assert!(matches!(e, Err(ToolpathError::InvalidOptions(_))), "{o:?}: {e:?}");
    }
    let e = plan_setup(&Mesh::default(), &top, &Tool::flat(0.1), &PlanOptions::default(), &mut rec);
    assert!(matches!(e, Err(ToolpathError::EmptyMesh)), "{e:?}");
    let stock = Aabb::new(Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 1.0));
    let e = plan_setup(
        &part,
        &top,
        &Tool::flat(0.1),
        &PlanOptions { stock: Some(stock), ..Default::default() },
        &mut rec,
    );
    assert!(matches!(e, Err(ToolpathError::InvalidStock(_))), "{e:?}");
    // A tool far larger than the part is fine: nothing but air around it.
    let s = plan_setup(
        &part,
        &top,
        &Tool::flat(5.0),
        &PlanOptions { layer_height: 0.1, ..Default::default() },
        &mut rec,
    )
    .expect("huge tool plans");
    assert!(s.layers > 0);
}

#[test]
fn rest_machining_skips_material_already_removed() {
    let hf =
        HeightField::new(
            8,
            8,
            0.125,
            |i, j| if (2..6).contains(&i) && (2..6).contains(&j) { 0.2 } else { 0.5 },
        );
    let part = hf.mesh();
    let tool = Tool::flat(0.04);
    let opts = PlanOptions { measure_air_cut: true, ..opts_for(Arc::new(Zigzag::default()), 0.1) };
    let mut full = MotionRecorder::default();
    let s_full = plan_setup(&part, &Setup::top(), &tool, &opts, &mut full).expect("plan");
    // An earlier setup removed everything above z = 0.35 and everything outside the part's
    // footprint: only the pocket remains to be cut.
    let rest = |min: &Point3, max: &Point3| {
        let pocket = min.x < 0.75 && max.x > 0.25 && min.y < 0.75 && max.y > 0.25;
        min.z < 0.35 && pocket && max.z > 0.2
    };
    let mut part_rec = MotionRecorder::default();
    let s_rest =
        plan_setup_rest(&part, &Setup::top(), &tool, &opts, Some(&rest), &mut part_rec).expect("plan");
    assert!(
        s_rest.cutting_length < 0.5 * s_full.cutting_length,
        "rest {} vs full {}",
        s_rest.cutting_length,
        s_full.cutting_length
    );
    assert!(s_rest.skipped_layers >= 1, "{s_rest:?}");
    let air = s_rest.air_cut_fraction.expect("air fraction with rest info");
    assert!((0.0..=1.0).contains(&air), "{air}");
    // No cutting above 0.35 except straight entries.
    for (rapid, a, b) in moves(&part_rec) {
        if !rapid && a.z == b.z {
            assert!(b.z < 0.35 + 1e-9, "cut at {b:?} where nothing remains");
        }
    }
}

#[test]
fn the_registry_names_the_built_in_strategies_in_order() {
    let registry = strategies();
    assert_eq!(registry.names().collect::<Vec<_>>(), ["zigzag", "periphery", "spiral"]);
    assert_eq!(registry.len(), 3);
    for name in ["zigzag", "periphery", "spiral"] {
        assert_eq!(registry.get(name).expect(name).name(), name);
        assert_eq!(registry.get(&name.to_uppercase()).expect(name).name(), name, "case-insensitive");
    }
    // The registry's zigzag runs along X, as the default options' does.
    assert_eq!(format!("{:?}", registry.get("zigzag").unwrap()), "Zigzag { angle_deg: 0.0 }");
    assert_eq!(format!("{:?}", PlanOptions::default().strategy), "Zigzag { angle_deg: 0.0 }");
}

#[test]
fn an_unknown_strategy_name_is_an_error_that_lists_the_known_ones() {
    let e = strategies().get("trochoidal").unwrap_err();
    assert_eq!(e.name, "trochoidal");
    assert_eq!(e.known, ["zigzag", "periphery", "spiral"]);
    assert_eq!(e.to_string(), "unknown clearing strategy \"trochoidal\" (known: zigzag, periphery, spiral)");
    assert!(strategies().get("").is_err());
    assert!(s2g_toolpath::StrategyRegistry::new().get("zigzag").is_err());
}

#[test]
fn registering_appends_a_new_name_and_replaces_a_known_one_in_place() {
    let mut registry = strategies().clone();
    /// Runs the region's loops (enough to register and look up).
    #[derive(Debug)]
    struct Loops(&'static str);
    impl ClearingStrategy for Loops {
        fn name(&self) -> &str {
            self.0
        }
        fn clear(&self, region: &s2g_toolpath::Region2, _: &ClearingContext) -> Vec<s2g_toolpath::Polyline2> {
            region.loops()
        }
    }
    assert!(registry.register(Arc::new(Loops("loops"))).is_none());
    assert_eq!(registry.names().collect::<Vec<_>>(), ["zigzag", "periphery", "spiral", "loops"]);
    let old = registry.register(Arc::new(Loops("Periphery"))).expect("replaced");
    assert_eq!(old.name(), "periphery");
    assert_eq!(registry.names().collect::<Vec<_>>(), ["zigzag", "Periphery", "spiral", "loops"]);
    assert_eq!(format!("{:?}", registry.get("periphery").unwrap()), "Loops(\"Periphery\")");
    // The built-in registry is untouched.
    assert_eq!(strategies().names().collect::<Vec<_>>(), ["zigzag", "periphery", "spiral"]);
}

/// A strategy from outside the crate receives the options' arc step, milling direction and
/// step-over, and the tool's radius, and its paths are what the layers clear.
#[test]
fn a_plugged_in_strategy_gets_the_planner_s_context() {
    use std::sync::Mutex;
    #[derive(Debug, Default)]
    struct Spy(Mutex<Vec<ClearingContext>>);
    impl ClearingStrategy for Spy {
        fn name(&self) -> &str {
            "spy"
        }
        fn clear(&self, _: &s2g_toolpath::Region2, ctx: &ClearingContext) -> Vec<s2g_toolpath::Polyline2> {
            self.0.lock().unwrap().push(*ctx);
            vec![s2g_toolpath::Polyline2::open(vec![
                ctx.start,
                ctx.start + s2g_toolpath::Vector2::new(1e-3, 0.0),
            ])]
        }
    }
    let part = HeightField::new(4, 3, 0.25, |_, _| 0.4).mesh();
    let spy = Arc::new(Spy::default());
    let tool = Tool::flat(0.04);
    let opts = PlanOptions {
        layer_height: 0.1,
        stepover: 0.4,
        arc_step: 0.05,
        climb: false,
        strategy: spy.clone(),
        stock_margin: 0.1,
        ..Default::default()
    };
    let (_, layers) = plan_layers::<()>(&part, &Setup::top(), &tool, &opts, None).expect("plans");
    let seen = spy.0.lock().unwrap().clone();
    assert_eq!(seen.len(), layers.len());
    for ctx in &seen {
        assert_eq!((ctx.tool_radius, ctx.arc_step, ctx.climb), (0.04, 0.05, false));
        assert!((ctx.stepover - 0.4 * 0.08).abs() < 1e-15, "{ctx:?}");
    }
    assert!(layers.iter().all(|l| l.clearing.len() == 1), "the strategy's paths are the clearing");
    let mut rec = MotionRecorder::default();
    plan_setup(&part, &Setup::top(), &tool, &opts, &mut rec).expect("plan");
    let header = rec.motions.iter().find_map(|(_, m)| match m {
        s2g_gcode::Motion::Comment(c) => Some(c.to_string()),
        _ => None,
    });
    assert_eq!(header.as_deref(), Some("s2g-toolpath: tool 1 radius 0.04 strategy spy"));
}

/// A closed tube: prisms over regular `n`-gons of radii `outer` and `inner` about (cx, cy),
/// z in [0, h], the inner one a through bore.
fn tube(cx: f64, cy: f64, outer: f64, inner: f64, h: f64, n: usize) -> Mesh {
    let p = |rad: f64, k: usize, z: f64| {
        let a = std::f64::consts::TAU * (k % n) as f64 / n as f64;
        Point3::new(cx + rad * a.cos(), cy + rad * a.sin(), z)
    };
    let mut soup = Vec::new();
    for k in 0..n {
        let o0 = |z: f64| p(outer, k, z);
        let o1 = |z: f64| p(outer, k + 1, z);
        let i0 = |z: f64| p(inner, k, z);
        let i1 = |z: f64| p(inner, k + 1, z);
        // Top and bottom rings, the outer wall facing out, the bore's wall facing in.
        soup.extend([[i0(h), o0(h), o1(h)], [i0(h), o1(h), i1(h)]]);
        soup.extend([[i0(0.0), o1(0.0), o0(0.0)], [i0(0.0), i1(0.0), o1(0.0)]]);
        soup.extend([[o0(0.0), o1(0.0), o1(h)], [o0(0.0), o1(h), o0(h)]]);
        soup.extend([[i0(0.0), i1(h), i1(0.0)], [i0(0.0), i0(h), i1(h)]]);
    }
    Mesh::from_soup(&soup).expect("finite")
}

/// A bore is cut to size: the contour inside a through bore (a 256-gon, whose offset the
/// keep-out's thinning folds into chords) runs at the tool radius from its wall, at most
/// 0.5 % of the radius more, at every level below the top. The keep-out's growth and the
/// chords of its thinning both leave material on a concave wall; with the growth at 0.5 %
/// of the radius (and its chords as much again) the bore was cut 0.6-1.2 % small.
#[test]
fn a_bore_is_contoured_to_size() {
    let (c, inner, n) = (Point2::new(0.5, 0.5), 0.25, 256);
    let part = tube(c.x, c.y, 0.45, inner, 0.4, n);
    let tool = Tool::flat(0.06);
    let r = tool.radius();
    let opts = opts_for(Arc::new(Zigzag { angle_deg: 0.0 }), 0.1);
    let (_, layers) = plan_layers::<()>(&part, &Setup::top(), &tool, &opts, None).expect("plans");
    let wall = |k: usize| {
        let a = std::f64::consts::TAU * (k % n) as f64 / n as f64;
        c + inner * s2g_toolpath::Vector2::new(a.cos(), a.sin())
    };
    let mut levels = 0;
    for plan in layers.iter().filter(|l| l.z < 0.4 - 1e-9) {
        let bore: Vec<Point2> = plan
            .contour
            .iter()
            .flat_map(|path| samples(path, 0.1 * r))
            .filter(|p| (p - c).norm() < inner)
            .collect();
        assert!(!bore.is_empty(), "level {}: no contour in the bore", plan.z);
        levels += 1;
        for p in bore {
            let d = (0..n)
                .map(|k| s2g_toolpath::point_segment_distance(&p, &wall(k), &wall(k + 1)))
                .fold(f64::INFINITY, f64::min);
            assert!(
                d >= r - 1e-7 && d <= 1.005 * r,
                "level {}: {p:?} is {d} from the bore's wall, r = {r}",
                plan.z
            );
        }
    }
    assert!(levels >= 3, "{levels} levels in the bore");
}
