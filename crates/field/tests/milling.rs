//! Milling layers (Eq. 40): the tool sampling, the cup, the losses' behaviour on planar
//! layers, a small cup optimisation that removes every collision, its five-axis program
//! simulated without gouges, and typed errors.

use s2g_field::{
    ContourPaths, FieldError, LayerOptions, MeshSdf, MillOptions, MillingProblem, MillingWeights,
    PathOptions, ProgramOptions, Tool, contour_directions, count_collisions, cup_mesh, fit_contour_paths,
    layer_mesh, mill_mesh, mill_program, mill_program_with_paths, milling_losses, optimize_layers,
    path_stats, pretrain_planar, simulate_program,
};
use s2g_gcode::{Motion, MotionRecorder, ParseOptions, RotaryAxes, parse_str};
use s2g_geom::{Aabb, MeshIndex, Point3, SignedDistance, Sphere};

fn scalar(t: burn::tensor::Tensor<1>) -> f32 {
    t.into_scalar()
}

#[test]
fn tool_points_lie_on_the_sampled_cylinder() {
    let tool = Tool { axial_offset: 1.0, axial_step: 4.0, ring_points: 6, ..Tool::cylinder(2.0, 10.0) };
    let pts = tool.points(0.3);
    // Rings at 1, 5, 9 and 10 (the last clamped to the length), 7 points each.
    assert_eq!(pts.len(), 4 * 7);
    let axial: Vec<f64> = pts.iter().map(|p| p[0]).collect();
    assert!(axial.iter().all(|&a| (1.0..=10.0).contains(&a)));
    assert!((axial.iter().cloned().fold(0.0, f64::max) - 10.0).abs() < 1e-12);
    let on_ring = pts.iter().filter(|p| ((p[1] * p[1] + p[2] * p[2]).sqrt() - 2.0).abs() < 1e-12).count();
    let on_axis = pts.iter().filter(|p| p[1] == 0.0 && p[2] == 0.0).count();
    assert_eq!((on_ring, on_axis), (24, 4));
    assert_eq!(MillingWeights::default().collision_at(0, 10), 8000.0);
    assert_eq!(MillingWeights::default().collision_at(9, 10), 40000.0);
}

#[test]
fn cup_is_closed_with_the_expected_volume_and_an_overhang() {
    let cup = cup_mesh(30.0, 50.0, 24.0, 20.0, 8.0, 5.0, 256).unwrap();
    let pi = std::f64::consts::PI;
    let volume = pi * (30f64.powi(2) * 50.0 - 24f64.powi(2) * 37.0 - 20f64.powi(2) * 5.0);
    let rel = (cup.signed_volume() - volume).abs() / volume;
    // 256 facets lose (1 - sin(2π/256)/(2π/256)) ≈ 1e-4 of the area of each circle.
    assert!(rel < 1e-3, "volume {} vs {volume}", cup.signed_volume());
    let sdf = MeshSdf::new(&cup).unwrap();
    assert!(sdf.distance(&Point3::new(27.0, 0.0, 20.0)) < 0.0, "wall is solid");
    assert!(sdf.distance(&Point3::new(22.0, 0.0, 47.0)) < 0.0, "lip is solid");
    assert!(sdf.distance(&Point3::new(22.0, 0.0, 40.0)) > 0.0, "cavity under the lip is empty");
    assert!(sdf.distance(&Point3::new(0.0, 0.0, 47.0)) > 0.0, "opening is empty");
    // The closest-point gradient agrees with the index's distance.
    let p = Point3::new(10.0, 5.0, 30.0);
    let g = sdf.gradient(&p);
    let h = 1e-4;
    let fd = (sdf.distance(&(p + g * h)) - sdf.distance(&(p - g * h))) / (2.0 * h);
    assert!((fd - 1.0).abs() < 1e-6, "directional derivative along the gradient {fd}");
    assert!(
        (MeshIndex::new(&cup).unwrap().signed_distance(&p) - sdf.distance(&p)).abs() < 1e-12,
        "MeshSdf is MeshIndex's distance"
    );
    assert!(matches!(cup_mesh(30.0, 50.0, 20.0, 24.0, 8.0, 5.0, 64), Err(FieldError::InvalidArgument(_))));
    assert!(matches!(
        cup_mesh(f64::NAN, 50.0, 24.0, 20.0, 8.0, 5.0, 64),
        Err(FieldError::InvalidArgument(_))
    ));
}

/// The counts of a program, without its text.
struct ContourSummary<'a>(&'a s2g_field::MillProgram);

impl std::fmt::Debug for ContourSummary<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = self.0;
        write!(
            f,
            "layers {} used {} skipped {} links {} (on curve {}) jumps {} blocks {}",
            p.layers, p.poses_used, p.poses_skipped, p.links, p.curve_links, p.jumps, p.blocks
        )
    }
}

fn small_cup() -> (s2g_geom::Mesh, Aabb) {
    let cup = cup_mesh(30.0, 50.0, 24.0, 20.0, 8.0, 5.0, 48).unwrap();
    let block = Aabb::new(Point3::new(-36.0, -36.0, 0.0), Point3::new(36.0, 36.0, 52.0));
    (cup, block)
}

/// On planar layers above a sphere the tool along +Z is clear: zero collision losses; a
/// pose under the sphere has its tool through it: positive part-collision loss.
#[test]
fn losses_vanish_where_planar_layers_are_clear() {
    let sphere = Sphere { center: Point3::new(0.0, 0.0, 0.0), radius: 10.0 };
    let block = Aabb::new(Point3::new(-20.0, -20.0, -20.0), Point3::new(20.0, 20.0, 20.0));
    let tool = Tool { axial_offset: 2.0, axial_step: 3.0, ring_points: 8, ..Tool::cylinder(2.0, 15.0) };
    let poses = vec![Point3::new(0.0, 0.0, 13.0), Point3::new(15.0, 0.0, -5.0), Point3::new(0.0, 0.0, -15.0)];
    let problem = MillingProblem::with_poses(&sphere, block, tool, poses).unwrap();
    let options = LayerOptions { pretrain_steps: 300, ..LayerOptions::default() };
    let g = pretrain_planar(&options).unwrap();
    let clear = milling_losses(&g, &problem, &[0, 1], 0.0, &options.constants).unwrap();
    assert_eq!(scalar(clear.part_collision), 0.0);
    assert_eq!(scalar(clear.layer_collision), 0.0);
    assert_eq!(scalar(clear.zero_gradient), 0.0, "the planar field has |∇G| ≈ 1");
    let spacing = scalar(clear.spacing);
    assert!(spacing < 1e-2, "planar layers are evenly spaced: {spacing}");
    assert_eq!(scalar(clear.curvature), 0.0, "planar layers are flat");
    let hit = milling_losses(&g, &problem, &[2], 0.0, &options.constants).unwrap();
    assert!(scalar(hit.part_collision) > 0.0);
    let count = count_collisions(&g.to_f64().unwrap(), &problem, &tool).unwrap();
    assert_eq!((count.poses, count.part, count.layer), (3, 1, 0));
    // Typed errors, no panics.
    assert!(matches!(
        milling_losses(&g, &problem, &[], 0.0, &options.constants),
        Err(FieldError::InvalidArgument(_))
    ));
    assert!(matches!(
        milling_losses(&g, &problem, &[7], 0.0, &options.constants),
        Err(FieldError::InvalidArgument(_))
    ));
    let bad = MillingProblem::with_poses(&sphere, block, tool, vec![Point3::new(f64::NAN, 0.0, 0.0)]);
    assert!(matches!(bad, Err(FieldError::NonFinite { .. })));
    let bad_tool = Tool::cylinder(-1.0, 15.0);
    assert!(matches!(
        MillingProblem::with_poses(&sphere, block, bad_tool, vec![]),
        Err(FieldError::InvalidConfig { .. })
    ));
    assert!(matches!(
        MillingProblem::new(&sphere, block, tool, 0.0, 0.0),
        Err(FieldError::InvalidArgument(_))
    ));
    let no_steps = LayerOptions { batch_size: 0, ..LayerOptions::default() };
    assert!(matches!(pretrain_planar(&no_steps), Err(FieldError::InvalidConfig { .. })));
}

/// The small cup: planar layers leave poses under the lip whose tool hits it; Eq. 40 with
/// the repair rounds removes every colliding pose under the check's own sampling, and the
/// five-axis program of the optimised layers simulates without gouges.
#[test]
fn optimised_cup_layers_have_no_colliding_poses_and_mill_without_gouges() {
    let (cup, block) = small_cup();
    let part = MeshSdf::new(&cup).unwrap();
    let tool = Tool { axial_step: 4.0, ring_points: 12, ..Tool::default() };
    let problem = MillingProblem::new(&part, block, tool, 6.0, 0.5).unwrap();
    let options = LayerOptions {
        pretrain_steps: 300,
        steps: 40,
        batch_size: 128,
        repair_rounds: 10,
        repair_steps: 20,
        check_tool: Some(tool),
        ..LayerOptions::default()
    };
    let planar = pretrain_planar(&options).unwrap();
    let planar_f64 = planar.to_f64().unwrap();
    let before = count_collisions(&planar_f64, &problem, &tool).unwrap();
    assert!(before.part > 0, "planar layers should leave colliding poses under the lip: {before:?}");
    assert_eq!(before.layer, 0, "planar layers never cut into unmilled layers: {before:?}");
    let (g, report) = optimize_layers(planar, &problem, &options).unwrap();
    assert!(report.repair_rounds >= 1 && report.repair_rounds <= 10, "{report:?}");
    assert_eq!(report.steps, 40 + 20 * report.repair_rounds);
    let g = g.to_f64().unwrap();
    let after = count_collisions(&g, &problem, &tool).unwrap();
    assert_eq!((after.part, after.layer), (0, 0), "optimised layers still collide: {after:?} ({report:?})");
    assert_eq!(report.collisions, Some(after));

    // Five-axis programs: the planar one leaves the colliding poses out, the optimised
    // one tilts the tool; neither gouges the part.
    let popts = ProgramOptions { layer_step: 6.0, link_distance: 9.0, ..ProgramOptions::default() };
    let planar_program = mill_program(&planar_f64, &problem, &popts).unwrap();
    assert!(planar_program.poses_skipped >= before.part, "{planar_program:?}");
    let program = mill_program(&g, &problem, &popts).unwrap();
    assert!(
        program.poses_used > planar_program.poses_used,
        "{} vs {}",
        program.poses_used,
        planar_program.poses_used
    );
    let mut rec = MotionRecorder::default();
    let parse = ParseOptions { rotary: Some(RotaryAxes::AC), ..ParseOptions::default() };
    let summary = parse_str(&program.text, &parse, &mut rec).unwrap();
    assert!(summary.errors.is_empty(), "{:?}", summary.errors);
    // Rotary words share the block of the move they go with (simultaneous motion), and
    // some blocks tilt the tool by more than 10 degrees.
    let mut simultaneous = 0;
    let mut tilted = 0;
    for w in rec.motions.windows(2) {
        if let ((l0, Motion::Setup { rotary, .. }), (l1, next)) = (&w[0], &w[1]) {
            assert_eq!(l0, l1, "a setup on its own line: {next:?}");
            simultaneous += 1;
            tilted += (rotary[0].unwrap_or(0.0).abs() > 10.0) as usize;
        }
    }
    assert!(simultaneous > 0 && tilted > 0, "{simultaneous} simultaneous blocks, {tilted} tilted");
    let layers = layer_mesh(&g, &problem, 6.0, 3.0).unwrap();
    assert!(!layers.triangles().is_empty(), "no layer surfaces");
    for (name, text) in [("planar", &planar_program.text), ("optimised", &program.text)] {
        let sim = simulate_program(text, &cup, &block, &tool, 2.0, &popts).unwrap();
        assert_eq!(sim.gouge_voxels, 0, "{name}: {sim:?}");
        assert!(sim.removed_fraction > 0.3 && sim.removed_fraction <= 1.0, "{name}: {sim:?}");
    }

    // Contour-parallel toolpaths from a path field along the cup's outline (§7.4): the
    // same clearance proof of every pose and move, no gouges, and most feed links along
    // an iso-curve of P.
    let path_options = PathOptions { steps: 300, ..PathOptions::default() };
    let (paths, path_report) = fit_contour_paths(&g, &problem, &path_options).unwrap();
    let paths = ContourPaths { field: paths.to_f64().unwrap(), step: 6.0 };
    let (points, dirs) = contour_directions(&g, &problem);
    let stats = path_stats(&g, &paths.field, &points, &dirs, s2g_field::Backend::default()).unwrap();
    let contour = mill_program_with_paths(&g, &problem, &popts, &paths).unwrap();
    let sim = simulate_program(&contour.text, &cup, &block, &tool, 2.0, &popts).unwrap();
    println!(
        "paths {path_report:?}\n{stats:?}\ncontour {contour:?}\nnearest {program:?}\n{sim:?}",
        contour = ContourSummary(&contour),
        program = ContourSummary(&program)
    );
    assert!(stats.mean_angle_deg < 15.0, "{stats:?}");
    assert_eq!(sim.gouge_voxels, 0, "contour: {sim:?}");
    assert!(sim.removed_fraction > 0.3, "contour: {sim:?}");
    assert!(
        contour.poses_used + 10 >= program.poses_used,
        "{} vs {}",
        contour.poses_used,
        program.poses_used
    );
    assert!(
        2 * contour.curve_links > contour.links,
        "{} of {} links along a curve",
        contour.curve_links,
        contour.links
    );
    assert_eq!(program.curve_links, 0);
    assert!(matches!(
        mill_program_with_paths(&g, &problem, &popts, &ContourPaths { step: 0.0, ..paths.clone() }),
        Err(FieldError::InvalidConfig { .. })
    ));

    // Typed errors, no panics.
    let bad = ProgramOptions { feed: f64::NAN, ..popts.clone() };
    assert!(matches!(mill_program(&g, &problem, &bad), Err(FieldError::InvalidConfig { .. })));
    assert!(matches!(
        simulate_program(&program.text, &cup, &block, &tool, 0.0, &popts),
        Err(FieldError::InvalidArgument(_))
    ));
    assert!(matches!(
        simulate_program("G1 X1 Y2 Z3 F100\nG2 X10 Y0 I0 J0\n", &cup, &block, &tool, 2.0, &popts),
        Err(FieldError::Simulation(_))
    ));
    assert!(matches!(layer_mesh(&g, &problem, 6.0, 0.0), Err(FieldError::InvalidArgument(_))));
    let empty = s2g_geom::Mesh::new(vec![], vec![]).unwrap();
    assert!(matches!(mill_mesh(&empty, &MillOptions::default()), Err(FieldError::EmptyMesh)));
    let bad_repair = LayerOptions { repair_decay: 0.0, ..options.clone() };
    assert!(matches!(pretrain_planar(&bad_repair), Err(FieldError::InvalidConfig { .. })));
}
