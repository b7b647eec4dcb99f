//! Milling layers (Eq. 40): the tool sampling, the cup, the losses' behaviour on planar
//! layers, a small cup optimisation that removes collisions, and typed errors.

use s2g_field::{
    FieldError, LayerOptions, MeshSdf, MillingProblem, MillingWeights, Tool, count_collisions, cup_mesh,
    milling_losses, optimize_layers, pretrain_planar,
};
use s2g_geom::{Aabb, MeshIndex, Point3, SignedDistance, Sphere};

fn scalar(t: burn::tensor::Tensor<1>) -> f32 {
    t.into_scalar()
}

#[test]
fn tool_points_lie_on_the_sampled_cylinder() {
    let tool = Tool { radius: 2.0, length: 10.0, axial_offset: 1.0, axial_step: 4.0, ring_points: 6 };
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
    let tool = Tool { radius: 2.0, length: 15.0, axial_offset: 2.0, axial_step: 3.0, ring_points: 8 };
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
    let bad_tool = Tool { radius: -1.0, ..tool };
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

/// The small cup: planar layers leave poses under the lip whose tool hits it; a short
/// optimisation of Eq. 40 lowers their number.
#[test]
fn optimised_cup_layers_collide_less_than_planar_layers() {
    let (cup, block) = small_cup();
    let part = MeshSdf::new(&cup).unwrap();
    let train = Tool { axial_step: 8.0, ring_points: 6, ..Tool::default() };
    let check = Tool { axial_step: 4.0, ring_points: 12, ..Tool::default() };
    let problem = MillingProblem::new(&part, block, train, 6.0, 0.5).unwrap();
    let options = LayerOptions { pretrain_steps: 300, steps: 40, batch_size: 128, ..LayerOptions::default() };
    let planar = pretrain_planar(&options).unwrap();
    let before = count_collisions(&planar.to_f64().unwrap(), &problem, &check).unwrap();
    assert!(before.part > 0, "planar layers should leave colliding poses under the lip: {before:?}");
    assert_eq!(before.layer, 0, "planar layers never cut into unmilled layers: {before:?}");
    let (g, report) = optimize_layers(planar, &problem, &options).unwrap();
    assert_eq!(report.steps, 40);
    let after = count_collisions(&g.to_f64().unwrap(), &problem, &check).unwrap();
    assert!(after.part < before.part, "before {before:?}, after {after:?}");
}
