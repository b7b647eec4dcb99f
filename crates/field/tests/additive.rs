//! Printing layers (Eq. 37): the overhang measure on analytic cases, the support-free and
//! base losses on prescribed gradients, the bent arm's 60° overhang under planar layers, a
//! tiny optimisation that reduces it, and typed errors.

use burn::tensor::{Tensor, TensorData};
use s2g_field::{
    Backend, FieldError, MeshSdf, PrintConstants, PrintOptions, PrintProblem, PrintSamples, Tool, base_loss,
    bent_arm_mesh, first_layers_loss, optimize_print_layers, overhang_angle, overhang_stats,
    pretrain_planar_print, print_collisions, print_losses, support_free_loss,
};
use s2g_geom::{Aabb, BoxShape, Point3, Sphere, Vector3};

fn scalar(t: Tensor<1>) -> f32 {
    t.into_scalar()
}

fn rows(v: &[[f64; 3]]) -> Tensor<2> {
    let data: Vec<f32> = v.iter().flat_map(|r| r.map(|c| c as f32)).collect();
    Tensor::<2>::from_data(TensorData::new(data, [v.len(), 3]), &Backend::default().device())
}

/// The underside of an arm leaning 60° from the vertical, its axis, and the arm's side.
fn lean(deg: f64) -> (Vector3, Vector3) {
    let g = deg.to_radians();
    (Vector3::new(g.cos(), 0.0, -g.sin()), Vector3::new(g.sin(), 0.0, g.cos()))
}

#[test]
fn overhang_angle_is_the_lean_past_the_wall() {
    let z = Vector3::z();
    let (under, axis) = lean(60.0);
    assert!((overhang_angle(&under, &z) - 60.0).abs() < 1e-9);
    assert!((overhang_angle(&(under * 3.0), &(z * 0.2)) - 60.0).abs() < 1e-9, "scale-free");
    assert!(overhang_angle(&under, &axis).abs() < 1e-9, "printing along the arm: a wall");
    assert_eq!(overhang_angle(&Vector3::x(), &z), 0.0, "vertical wall");
    assert_eq!(overhang_angle(&z, &z), 0.0, "top face");
    assert!((overhang_angle(&-z, &z) - 90.0).abs() < 1e-9, "ceiling");
    let (thirty, _) = lean(30.0);
    assert!((overhang_angle(&thirty, &z) - 30.0).abs() < 1e-9);
    assert_eq!(overhang_angle(&under, &Vector3::zeros()), 90.0, "no build direction");
}

#[test]
fn support_free_and_base_losses_vanish_only_when_aligned() {
    let (under, axis) = lean(60.0);
    let (thirty, _) = lean(30.0);
    let normals = rows(&[under.into(), [1.0, 0.0, 0.0], thirty.into(), [0.0, 0.0, 1.0]]);
    let eff = PrintConstants::default().effective_overhang_deg();
    assert_eq!(eff, 43.0);
    // Planar layers: only the 60° underside is beyond 43°.
    let planar = support_free_loss(rows(&[[0.0, 0.0, 2.0]; 4]), normals.clone(), eff, 25.0);
    let expected = 25.0 * (60f64.to_radians().sin() - 43f64.to_radians().sin()) / 4.0;
    assert!((scalar(planar) as f64 - expected).abs() < 1e-5, "{expected}");
    // Layers turning with the arm: the underside becomes a wall, the 30° face is 0° (it
    // lies on the other side of the tilted direction), the top stays up.
    let turned = support_free_loss(rows(&[(axis * 5.0).into(); 4]), normals.clone(), eff, 25.0);
    assert_eq!(scalar(turned), 0.0);
    // A direction pointing down makes the top face a ceiling.
    let down = support_free_loss(rows(&[[0.0, 0.0, -1.0]; 4]), normals, eff, 25.0);
    assert!(scalar(down) > 0.0);

    let on_platform = base_loss(rows(&[[0.0, 0.0, 3.0]; 2]), [0.0, 0.0, 1.0], 2.5);
    assert!(scalar(on_platform).abs() < 1e-6);
    let tilted = base_loss(rows(&[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), [0.0, 0.0, 1.0], 2.5);
    assert!((scalar(tilted) - 1.25).abs() < 1e-6);
}

#[test]
fn first_layers_loss_counts_only_layers_steeper_than_allowed() {
    let (s30, c30) = 30f64.to_radians().sin_cos();
    let (s60, c60) = 60f64.to_radians().sin_cos();
    let grads = rows(&[[2.0 * s30, 0.0, 2.0 * c30], [0.0, s60, c60], [0.0, 0.0, -1.0]]);
    let limit = 45f64.to_radians().cos();
    let loss = scalar(first_layers_loss(grads, &[limit; 3], 2.5)) as f64;
    // 30° is within 45°; 60° and a layer upside down are not.
    let expected = 2.5 * ((limit - c60) + (limit + 1.0)) / 3.0;
    assert!((loss - expected).abs() < 1e-5, "{loss} vs {expected}");
    assert_eq!(scalar(first_layers_loss(rows(&[[0.0, 0.0, 1.0]]), &[1.0], 2.5)), 0.0);
}

/// Layers leaning 40° off the platform (an asymmetric pretraining) pay the first layers'
/// loss over a block standing on the platform only where it is held flat; planar ones
/// pay nothing.
#[test]
fn leaning_first_layers_pay_near_the_platform() {
    let block = BoxShape { min: Point3::new(-5.0, -5.0, 0.0), max: Point3::new(5.0, 5.0, 10.0) };
    let bounds = Aabb::new(block.min, block.max);
    let base: Vec<Point3> = (0..5)
        .flat_map(|i| (0..5).map(move |j| Point3::new(2.0 * i as f64 - 4.0, 2.0 * j as f64 - 4.0, 0.0)))
        .collect();
    let samples = PrintSamples {
        poses: vec![Point3::new(0.0, 0.0, 5.0)],
        surface: vec![Point3::new(5.0, 0.0, 5.0)],
        normals: vec![Vector3::x()],
        base,
    };
    let problem = PrintProblem::with_samples(&block, nozzle(), bounds, 0.0, samples).unwrap();
    let base_term = |lean: f64, first_layers: f64| {
        let options =
            PrintOptions { pretrain_steps: 200, pretrain_lean_deg: lean, ..PrintOptions::default() };
        let g = pretrain_planar_print(&options).unwrap();
        let (_, grad) = g.to_f64().unwrap().value_gradient([0.0, 0.0, 0.0]);
        let tilt = Vector3::new(grad[0], grad[1], grad[2]).angle(&Vector3::z()).to_degrees();
        assert!((tilt - lean).abs() < 3.0, "pretrained tilt {tilt} for {lean}");
        let constants = PrintConstants { first_layers, ..PrintConstants::default() };
        scalar(print_losses(&g, &problem, &[0], &[0], 0.0, &constants).unwrap().base) as f64
    };
    let (flat, free) = (base_term(40.0, 3.0), base_term(40.0, 0.0));
    // Eq. 31 alone: 2.5 (1 - cos 40°); held flat, points up to 1.5 high allow less than 40°.
    assert!((free - 2.5 * (1.0 - 40f64.to_radians().cos())).abs() < 0.05, "{free}");
    assert!(flat > free + 0.05, "{flat} vs {free}");
    assert!(base_term(0.0, 3.0) < 0.01);
    let bad = PrintOptions { pretrain_lean_deg: 90.0, ..PrintOptions::default() };
    assert!(matches!(pretrain_planar_print(&bad), Err(FieldError::InvalidConfig { .. })));
}

fn arm() -> s2g_geom::Mesh {
    bent_arm_mesh(6.0, 12.0, 16.0, 60.0, 24.0, 24, 8).unwrap()
}

fn nozzle() -> Tool {
    Tool { axial_offset: 1.0, axial_step: 4.0, ring_points: 8, ..Tool::cylinder(2.5, 20.0) }
}

fn small_options() -> PrintOptions {
    PrintOptions { pretrain_steps: 200, batch_size: 64, surface_batch: 128, ..PrintOptions::default() }
}

/// The arm is closed with the expected volume, its faces (off the base) overhang by at
/// most exactly 60° under `+Z`, and planar layers measure that on the surface samples,
/// with no nozzle collision.
#[test]
fn planar_layers_overhang_the_bent_arm_by_sixty_degrees() {
    let mesh = arm();
    let pi = std::f64::consts::PI;
    let (k, r) = (24.0, 6.0);
    let section = 0.5 * k * r * r * (2.0 * pi / k).sin();
    let volume = section * (12.0 + 16.0 * 60f64.to_radians() + 24.0);
    let rel = (mesh.signed_volume() - volume).abs() / volume;
    assert!(rel < 5e-3, "volume {} vs {volume}", mesh.signed_volume());
    let worst = (0..mesh.triangles().len())
        .filter_map(|t| mesh.face_normal(t))
        .filter(|n| n.z > -0.999)
        .map(|n| overhang_angle(&n, &Vector3::z()))
        .fold(0.0, f64::max);
    assert!((worst - 60.0).abs() < 1e-9, "largest facet overhang {worst}");

    let part = MeshSdf::new(&mesh).unwrap();
    let problem = PrintProblem::from_mesh(&part, &mesh, nozzle(), 4.0, 800, 1).unwrap();
    assert!(!problem.base().is_empty() && problem.poses().len() > 20, "{problem:?}");
    assert!(problem.base().iter().all(|p| p.z.abs() < 1e-9));
    let options = small_options();
    let g = pretrain_planar_print(&options).unwrap();
    let host = g.to_f64().unwrap();
    let stats = overhang_stats(&host, &problem, 45.0).unwrap();
    assert!((stats.max_deg - 60.0).abs() < 1.0, "{stats:?}");
    assert!(stats.fraction_over > 0.03 && stats.fraction_over < 0.5, "{stats:?}");
    let (hits, bad) = print_collisions(&host, &problem, &nozzle()).unwrap();
    assert_eq!((hits.part, hits.platform, bad.len()), (0, 0, 0), "planar layers never hit printed material");
    let all: Vec<usize> = (0..problem.poses().len()).collect();
    let surface: Vec<usize> = (0..problem.surface().len()).collect();
    let losses = print_losses(&g, &problem, &all, &surface, 0.0, &options.constants).unwrap();
    assert!(scalar(losses.support_free) > 0.0);
    assert!(scalar(losses.base) < 1e-3, "the planar bottom layer lies on the platform");
    assert_eq!(scalar(losses.collision), 0.0);
    assert_eq!(scalar(losses.platform), 0.0);
    assert!(losses.colliding_poses.is_empty());
}

/// A few Adam steps on Eq. 37 tilt the layers under the arm: the largest overhang drops
/// below 45° and no sample is left beyond it, without nozzle collisions.
#[test]
fn a_tiny_optimisation_reduces_the_overhang() {
    let mesh = arm();
    let part = MeshSdf::new(&mesh).unwrap();
    let problem = PrintProblem::from_mesh(&part, &mesh, nozzle(), 4.0, 800, 1).unwrap();
    let options = PrintOptions { steps: 40, ..small_options() };
    let g = pretrain_planar_print(&options).unwrap();
    let before = overhang_stats(&g.to_f64().unwrap(), &problem, 45.0).unwrap();
    let (g, report) = optimize_print_layers(g, &problem, &options).unwrap();
    assert_eq!(report.steps, 40);
    let host = g.to_f64().unwrap();
    let after = overhang_stats(&host, &problem, 45.0).unwrap();
    // Planar: 60° and about 9 % of the samples beyond 45°; after 40 steps: none.
    assert!(before.max_deg > 59.0 && before.over > 0, "{before:?}");
    assert!(after.max_deg < 45.0, "{before:?} -> {after:?}");
    assert_eq!(after.over, 0, "{before:?} -> {after:?}");
    let (hits, _) = print_collisions(&host, &problem, &nozzle()).unwrap();
    assert_eq!((hits.part, hits.platform), (0, 0), "{hits:?}");
}

/// The platform term: a platform above the poses puts every nozzle point below it.
#[test]
fn nozzle_below_the_platform_is_a_collision() {
    let sphere = Sphere { center: Point3::new(0.0, 0.0, 10.0), radius: 8.0 };
    let bounds = Aabb::new(Point3::new(-8.0, -8.0, 2.0), Point3::new(8.0, 8.0, 18.0));
    let samples = PrintSamples {
        poses: vec![Point3::new(0.0, 0.0, 10.0), Point3::new(2.0, 0.0, 8.0)],
        surface: vec![Point3::new(8.0, 0.0, 10.0)],
        normals: vec![Vector3::x()],
        base: vec![],
    };
    let options = small_options();
    let g = pretrain_planar_print(&options).unwrap();
    let host = g.to_f64().unwrap();
    let clear = PrintProblem::with_samples(&sphere, nozzle(), bounds, 2.0, samples.clone()).unwrap();
    let l = print_losses(&g, &clear, &[0, 1], &[0], 0.0, &options.constants).unwrap();
    assert_eq!((scalar(l.platform), scalar(l.collision), scalar(l.support_free)), (0.0, 0.0, 0.0));
    assert_eq!(print_collisions(&host, &clear, &nozzle()).unwrap().0.platform, 0);
    let buried = PrintProblem::with_samples(&sphere, nozzle(), bounds, 100.0, samples.clone()).unwrap();
    let l = print_losses(&g, &buried, &[0, 1], &[0], 0.0, &options.constants).unwrap();
    assert!(scalar(l.platform) > 0.0);
    assert_eq!(l.colliding_poses, vec![0, 1]);
    assert_eq!(print_collisions(&host, &buried, &nozzle()).unwrap().0.platform, 2);

    // Typed errors, no panics.
    let bad = |s: PrintSamples| PrintProblem::with_samples(&sphere, nozzle(), bounds, 2.0, s);
    let nan = PrintSamples { poses: vec![Point3::new(f64::NAN, 0.0, 0.0)], ..samples.clone() };
    assert!(matches!(bad(nan), Err(FieldError::NonFinite { what: "pose point", .. })));
    let zero = PrintSamples { normals: vec![Vector3::zeros()], ..samples.clone() };
    assert!(matches!(bad(zero), Err(FieldError::InvalidArgument(_))));
    let short = PrintSamples { normals: vec![], ..samples.clone() };
    assert!(matches!(bad(short), Err(FieldError::InvalidArgument(_))));
    let none = PrintSamples { poses: vec![], ..samples.clone() };
    assert!(matches!(bad(none), Err(FieldError::InvalidArgument(_))));
    assert!(matches!(
        PrintProblem::with_samples(&sphere, nozzle(), bounds, f64::INFINITY, samples.clone()),
        Err(FieldError::NonFinite { .. })
    ));
    let thin = Tool { ring_points: 2, ..nozzle() };
    assert!(matches!(
        PrintProblem::with_samples(&sphere, thin, bounds, 2.0, samples),
        Err(FieldError::InvalidConfig { .. })
    ));
    assert!(matches!(
        print_losses(&g, &clear, &[], &[0], 0.0, &options.constants),
        Err(FieldError::InvalidArgument(_))
    ));
    assert!(matches!(
        print_losses(&g, &clear, &[0], &[3], 0.0, &options.constants),
        Err(FieldError::InvalidArgument(_))
    ));
    let steep = PrintConstants { max_overhang_deg: 95.0, ..PrintConstants::default() };
    assert!(matches!(
        print_losses(&g, &clear, &[0], &[0], 0.0, &steep),
        Err(FieldError::InvalidConfig { .. })
    ));
    let wide = PrintConstants { overhang_margin_deg: 50.0, ..PrintConstants::default() };
    assert!(matches!(
        optimize_print_layers(g.clone(), &clear, &PrintOptions { constants: wide, ..options.clone() }),
        Err(FieldError::InvalidConfig { .. })
    ));
    assert!(matches!(
        pretrain_planar_print(&PrintOptions { surface_batch: 0, ..options.clone() }),
        Err(FieldError::InvalidConfig { .. })
    ));
    assert!(matches!(overhang_stats(&host, &clear, 91.0), Err(FieldError::InvalidArgument(_))));
    assert!(matches!(bent_arm_mesh(6.0, 12.0, 5.0, 60.0, 24.0, 24, 8), Err(FieldError::InvalidArgument(_))));
    assert!(matches!(
        bent_arm_mesh(6.0, 12.0, 16.0, f64::NAN, 24.0, 24, 8),
        Err(FieldError::InvalidArgument(_))
    ));
    let empty = s2g_geom::Mesh::new(vec![], vec![]).unwrap();
    assert!(matches!(
        PrintProblem::from_mesh(&sphere, &empty, nozzle(), 2.0, 100, 0),
        Err(FieldError::EmptyMesh)
    ));
    let mesh = arm();
    assert!(matches!(
        PrintProblem::from_mesh(&sphere, &mesh, nozzle(), 0.0, 100, 0),
        Err(FieldError::InvalidArgument(_))
    ));
}
