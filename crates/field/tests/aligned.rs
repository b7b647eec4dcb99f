//! Direction-aligned layers (DAC, Eq. 38) and layer-toolpath co-optimisation (TGC,
//! Eq. 39) on a coarse bent arm: Table 1's weights, the alignment measure and the arm's
//! axis field on analytic cases, short optimisations that must align the layers and the
//! toolpaths, reproducibility, and typed errors.

use burn::tensor::Tensor;
use s2g_field::{
    AlignProblem, Backend, DacOptions, DacWeights, FieldError, MeshSdf, PrintConstants, PrintProblem,
    SirenConfig, TgcConstants, TgcOptions, TgcWeights, Tool, alignment_stats, bent_arm_axis, bent_arm_mesh,
    dac_losses, init_tgc_fields, layer_alignment, optimize_dac_layers, optimize_tgc, path_stats,
    pretrain_planar_dac, print_collisions, tgc_losses,
};
use s2g_geom::{Mesh, Point3, Vector3};

const COLUMN: f64 = 12.0;
const BEND_RADIUS: f64 = 16.0;
const BEND_DEG: f64 = 60.0;

fn scalar(t: Tensor<1>) -> f32 {
    t.into_scalar()
}

fn arm() -> Mesh {
    bent_arm_mesh(6.0, COLUMN, BEND_RADIUS, BEND_DEG, 24.0, 16, 6).unwrap()
}

fn nozzle() -> Tool {
    Tool { axial_offset: 1.0, axial_step: 4.0, ring_points: 8, ..Tool::cylinder(2.5, 20.0) }
}

fn axis(p: &Point3) -> Vector3 {
    bent_arm_axis(p, COLUMN, BEND_RADIUS, BEND_DEG)
}

/// A coarse problem: poses on a 4 mm grid in the arm, the arm's axis at each.
fn problem<'a>(part: &'a MeshSdf, mesh: &Mesh) -> AlignProblem<'a> {
    let print = PrintProblem::from_mesh(part, mesh, nozzle(), 4.0, 200, 1).unwrap();
    AlignProblem::from_field(print, axis).unwrap()
}

fn small_net(seed: u64, omega: f64) -> SirenConfig {
    SirenConfig { sine_layers: 2, width: 32, first_omega: omega, hidden_omega: 30.0, seed }
}

fn small_dac(steps: usize) -> DacOptions {
    DacOptions {
        network: small_net(0, 5.0),
        pretrain_steps: 150,
        steps,
        batch_size: 64,
        learning_rate: 2e-3,
        ..DacOptions::default()
    }
}

fn small_tgc(steps: usize) -> TgcOptions {
    TgcOptions {
        layer_network: small_net(0, 5.0),
        path_network: small_net(1, 8.0),
        pretrain_steps: 150,
        steps,
        batch_size: 64,
        learning_rate: 2e-3,
        ..TgcOptions::default()
    }
}

#[test]
fn weights_default_to_table_1() {
    let w = DacWeights::default();
    assert_eq!((w.spacing, w.curvature), (2.0, 0.2), "Table 1, DAC row");
    assert_eq!((w.collision_start, w.collision_end), (8000.0, 40000.0));
    assert_eq!(w.collision_at(0, 11), 8000.0);
    assert_eq!(w.collision_at(5, 11), 24000.0);
    assert_eq!(w.collision_at(10, 11), 40000.0);
    let t = TgcWeights::default();
    assert_eq!((t.spacing, t.curvature, t.path_spacing), (2.0, 0.2, 2.0), "Table 1, TGC row");
    assert_eq!((t.path_curvature_start, t.path_curvature_end), (0.001, 1.0));
    assert_eq!(t.path_curvature_at(0, 3), 0.001);
    assert!((t.path_curvature_at(1, 3) - 0.5005).abs() < 1e-12);
    assert_eq!(t.path_curvature_at(2, 3), 1.0);
    assert_eq!(DacOptions::default().weights, w);
    assert_eq!(TgcOptions::default().weights, t);
}

#[test]
fn the_axis_field_and_the_alignment_angle() {
    let z = Vector3::z();
    // Column, bend (30° about the bend's centre), arm (beyond 60°).
    let column = axis(&Point3::new(1.0, 2.0, 5.0));
    assert!((column - z).norm() < 1e-12);
    let t = 30f64.to_radians();
    let bend = axis(&Point3::new(BEND_RADIUS * (1.0 - t.cos()), 0.0, COLUMN + BEND_RADIUS * t.sin()));
    assert!((bend - Vector3::new(t.sin(), 0.0, t.cos())).norm() < 1e-12, "{bend:?}");
    let arm_dir = axis(&Point3::new(40.0, 0.0, 40.0));
    let g = 60f64.to_radians();
    assert!((arm_dir - Vector3::new(g.sin(), 0.0, g.cos())).norm() < 1e-12);
    // Planar layers (normal +z): the direction leaves them by 90° - t.
    assert!((layer_alignment(&z, &column).unwrap() - 90.0).abs() < 1e-9);
    assert!((layer_alignment(&(z * 3.0), &bend).unwrap() - 60.0).abs() < 1e-9);
    assert!((layer_alignment(&z, &arm_dir).unwrap() - 30.0).abs() < 1e-9);
    // Layers y = const contain the whole axis.
    assert!(layer_alignment(&Vector3::y(), &arm_dir).unwrap().abs() < 1e-9);
    // No panic on bad input: a NaN point or bend angle reads as the column's +z.
    assert_eq!(bent_arm_axis(&Point3::new(f64::NAN, 0.0, 30.0), COLUMN, BEND_RADIUS, BEND_DEG), z);
    assert_eq!(bent_arm_axis(&Point3::new(40.0, 0.0, 40.0), COLUMN, BEND_RADIUS, f64::NAN), z);
    assert_eq!(bent_arm_axis(&Point3::new(40.0, 0.0, 40.0), COLUMN, BEND_RADIUS, -10.0), z);
    assert_eq!(layer_alignment(&z, &Vector3::zeros()), None);
    assert_eq!(layer_alignment(&Vector3::zeros(), &z), Some(90.0));
}

/// Planar layers on the arm: misaligned by more than 45° on average, no nozzle collision,
/// Eq. 21 equals `mean d_z²` (`∇G = ẑ`) and the collision terms are zero.
#[test]
fn planar_layers_cut_across_the_arm() {
    let mesh = arm();
    let part = MeshSdf::new(&mesh).unwrap();
    let problem = problem(&part, &mesh);
    let options = small_dac(1);
    let g = pretrain_planar_dac(&options).unwrap();
    let host = g.to_f64().unwrap();
    let stats = alignment_stats(&host, &problem);
    assert_eq!(stats.samples, problem.print().poses().len());
    assert!(stats.mean_deg > 45.0 && stats.max_deg > 85.0, "{stats:?}");
    let (hits, _) = print_collisions(&host, problem.print(), &nozzle()).unwrap();
    assert_eq!((hits.part, hits.platform), (0, 0));
    let all: Vec<usize> = (0..problem.print().poses().len()).collect();
    let losses = dac_losses(&g, &problem, &all, 0.0, &options.constants).unwrap();
    let want = problem.directions().iter().map(|d| d.z * d.z).sum::<f64>() / all.len() as f64;
    let got = scalar(losses.alignment) as f64;
    assert!((got - want).abs() < 0.02 * want, "Eq. 21 {got} vs mean d_z² {want}");
    assert_eq!(scalar(losses.collision), 0.0);
    assert_eq!(scalar(losses.platform), 0.0);
    assert!(losses.colliding_poses.is_empty());
}

/// A dense sampling of the nozzle, for the checks.
fn check_nozzle() -> Tool {
    Tool { axial_step: 1.5, ring_points: 24, ..nozzle() }
}

/// A short DAC optimisation turns the layers towards the arm's axis: the mean angle drops
/// by at least 30° (planar: about 54°), the alignment loss by half, the layer spacing loss
/// stays small, and no nozzle pose hits printed material or the platform.
#[test]
fn dac_aligns_the_layers_with_the_axis() {
    let mesh = arm();
    let part = MeshSdf::new(&mesh).unwrap();
    let problem = problem(&part, &mesh);
    let options = small_dac(150);
    let g = pretrain_planar_dac(&options).unwrap();
    let before = alignment_stats(&g.to_f64().unwrap(), &problem);
    let (g, report) = optimize_dac_layers(g, &problem, &options).unwrap();
    let host = g.to_f64().unwrap();
    let after = alignment_stats(&host, &problem);
    assert_eq!(report.steps, 150);
    assert!(after.mean_deg < before.mean_deg - 30.0, "{before:?} -> {after:?}");
    assert!(after.fraction_within_10 > 0.5, "{after:?}");
    assert!(report.final_losses[0] < 0.5 * report.initial_losses[0], "{report:?}");
    assert!(report.final_losses[3] < 0.2, "layer spacing loss {}", report.final_losses[3]);
    assert!(report.final_losses[4] < 0.05, "zero-gradient loss {}", report.final_losses[4]);
    let (hits, _) = print_collisions(&host, problem.print(), &check_nozzle()).unwrap();
    assert_eq!((hits.part, hits.platform), (0, 0), "{hits:?}");
}

/// The ablation of Fig. 16(d1, d2): without the collision terms the layers in the column
/// turn upright and the horizontal nozzle dips below the platform at the bottom poses;
/// with them (Table 1's weights) it does not, at the price of some alignment there.
#[test]
fn the_collision_term_keeps_the_nozzle_off_the_platform() {
    let mesh = arm();
    let part = MeshSdf::new(&mesh).unwrap();
    let problem = problem(&part, &mesh);
    let run = |weights: DacWeights| {
        let options = DacOptions { weights, ..small_dac(150) };
        let (g, _) = optimize_dac_layers(pretrain_planar_dac(&options).unwrap(), &problem, &options).unwrap();
        let host = g.to_f64().unwrap();
        (
            alignment_stats(&host, &problem),
            print_collisions(&host, problem.print(), &check_nozzle()).unwrap().0,
        )
    };
    let (free, free_hits) =
        run(DacWeights { collision_start: 0.0, collision_end: 0.0, ..DacWeights::default() });
    let (safe, safe_hits) = run(DacWeights::default());
    assert!(free_hits.platform > 0, "{free:?} {free_hits:?}");
    assert_eq!(safe_hits.platform + safe_hits.part, 0, "{safe:?} {safe_hits:?}");
    assert!(free.mean_deg < safe.mean_deg, "{free:?} vs {safe:?}");
}

/// A short TGC co-optimisation from planar layers and a random path field: the toolpath
/// tangents turn towards the prescribed directions and the layers towards containing them.
#[test]
fn tgc_aligns_the_toolpaths_with_the_axis() {
    let mesh = arm();
    let part = MeshSdf::new(&mesh).unwrap();
    let problem = problem(&part, &mesh);
    let (points, directions) = problem.unit_samples();
    let options = small_tgc(150);
    let fields = init_tgc_fields(&options).unwrap();
    let (g0, p0) = (fields.layer.to_f64().unwrap(), fields.path.to_f64().unwrap());
    let layers_before = alignment_stats(&g0, &problem);
    let paths_before = path_stats(&g0, &p0, &points, &directions, Backend::default()).unwrap();
    let (fields, report) = optimize_tgc(fields, &problem, &options).unwrap();
    let (g1, p1) = (fields.layer.to_f64().unwrap(), fields.path.to_f64().unwrap());
    let layers_after = alignment_stats(&g1, &problem);
    let paths_after = path_stats(&g1, &p1, &points, &directions, Backend::default()).unwrap();
    assert_eq!(report.steps, 150);
    // Random P: about 75° off; planar G: about 54° (measured once).
    assert!(paths_before.mean_angle_deg > 45.0, "{paths_before:?}");
    assert!(paths_after.mean_angle_deg < 10.0, "{paths_before:?} -> {paths_after:?}");
    assert!(layers_after.mean_deg < 10.0, "{layers_before:?} -> {layers_after:?}");
    // Evenly spaced paths, `|∇_s P|` near its target 1.
    assert!(paths_after.spacing_cv < 0.1, "{paths_after:?}");
    assert!((paths_after.spacing_mean - 1.0).abs() < 0.2, "{paths_after:?}");
    assert!(report.final_losses[6] < 0.5 * report.initial_losses[6], "{report:?}");
}

/// The same options give bit-identical fields and reports.
#[test]
fn same_seed_same_result() {
    let mesh = arm();
    let part = MeshSdf::new(&mesh).unwrap();
    let problem = problem(&part, &mesh);
    let points = [[0.1, -0.05, 0.2], [-0.2, 0.0, -0.3], [0.0, 0.1, 0.0]];
    let dac = || {
        let options = DacOptions { pretrain_steps: 20, ..small_dac(15) };
        let (g, report) =
            optimize_dac_layers(pretrain_planar_dac(&options).unwrap(), &problem, &options).unwrap();
        let host = g.to_f64().unwrap();
        (points.map(|p| host.value_gradient(p)), report.final_losses)
    };
    let tgc = || {
        let options = TgcOptions { pretrain_steps: 20, ..small_tgc(15) };
        let (f, report) = optimize_tgc(init_tgc_fields(&options).unwrap(), &problem, &options).unwrap();
        let (g, p) = (f.layer.to_f64().unwrap(), f.path.to_f64().unwrap());
        (points.map(|x| (g.value(x), p.value(x))), report.final_losses)
    };
    let (a, b) = (dac(), dac());
    assert_eq!(a, b);
    let (c, d) = (tgc(), tgc());
    assert_eq!(c, d);
    // A different batch seed gives a different field.
    let options = DacOptions { pretrain_steps: 20, seed: 7, ..small_dac(15) };
    let (g, _) = optimize_dac_layers(pretrain_planar_dac(&options).unwrap(), &problem, &options).unwrap();
    let host = g.to_f64().unwrap();
    assert_ne!(points.map(|p| host.value_gradient(p)), a.0);
}

#[test]
fn bad_input_gives_typed_errors() {
    let mesh = arm();
    let part = MeshSdf::new(&mesh).unwrap();
    let problem = problem(&part, &mesh);
    let bad_config = |r: Result<(), FieldError>, field: &str| match r {
        Err(FieldError::InvalidConfig { field: f, .. }) => assert_eq!(f, field),
        other => panic!("{field}: {other:?}"),
    };
    let dac = |o: DacOptions| o.validate();
    bad_config(dac(DacOptions { learning_rate: f64::NAN, ..DacOptions::default() }), "learning_rate");
    bad_config(dac(DacOptions { learning_rate: 0.0, ..DacOptions::default() }), "learning_rate");
    bad_config(dac(DacOptions { steps: 0, ..DacOptions::default() }), "steps");
    bad_config(dac(DacOptions { batch_size: 0, ..DacOptions::default() }), "batch_size");
    let w = DacWeights { alignment: -1.0, ..DacWeights::default() };
    bad_config(dac(DacOptions { weights: w, ..DacOptions::default() }), "weights.alignment");
    let w = DacWeights { collision_end: f64::INFINITY, ..DacWeights::default() };
    bad_config(dac(DacOptions { weights: w, ..DacOptions::default() }), "weights.collision_end");
    let c = PrintConstants { platform_clearance: -0.1, ..PrintConstants::default() };
    bad_config(dac(DacOptions { constants: c, ..DacOptions::default() }), "constants.platform_clearance");
    let tgc = |o: TgcOptions| o.validate();
    bad_config(tgc(TgcOptions { steps: 0, ..TgcOptions::default() }), "steps");
    let w = TgcWeights { path_curvature_end: f64::NAN, ..TgcWeights::default() };
    bad_config(tgc(TgcOptions { weights: w, ..TgcOptions::default() }), "weights.path_curvature_end");
    let c = TgcConstants { target_spacing: 0.0, ..TgcConstants::default() };
    bad_config(tgc(TgcOptions { constants: c, ..TgcOptions::default() }), "constants.target_spacing");
    let c = TgcConstants { singular_spacing: -1.0, ..TgcConstants::default() };
    bad_config(tgc(TgcOptions { constants: c, ..TgcOptions::default() }), "constants.singular_spacing");
    let net = SirenConfig { first_omega: f64::NAN, ..TgcOptions::default().path_network };
    bad_config(tgc(TgcOptions { path_network: net, ..TgcOptions::default() }), "first_omega");
    // The optimisers refuse bad options before touching the field.
    let options = small_dac(1);
    let g = pretrain_planar_dac(&options).unwrap();
    let r = optimize_dac_layers(g, &problem, &DacOptions { learning_rate: -1.0, ..options.clone() });
    assert!(matches!(r, Err(FieldError::InvalidConfig { field: "learning_rate", .. })), "{r:?}");
    let topts = TgcOptions { pretrain_steps: 1, ..small_tgc(1) };
    let fields = init_tgc_fields(&topts).unwrap();
    let r = optimize_tgc(fields, &problem, &TgcOptions { batch_size: 0, ..topts.clone() });
    assert!(matches!(r, Err(FieldError::InvalidConfig { field: "batch_size", .. })), "{r:?}");

    // Bad pose indices.
    let g = pretrain_planar_dac(&DacOptions { pretrain_steps: 1, ..options.clone() }).unwrap();
    let n = problem.print().poses().len();
    assert!(matches!(
        dac_losses(&g, &problem, &[], 0.0, &options.constants),
        Err(FieldError::InvalidArgument(_))
    ));
    assert!(matches!(
        dac_losses(&g, &problem, &[n], 0.0, &options.constants),
        Err(FieldError::InvalidArgument(_))
    ));
    let fields = init_tgc_fields(&topts).unwrap();
    assert!(matches!(
        tgc_losses(&fields, &problem, &[0, n + 3], &topts.constants),
        Err(FieldError::InvalidArgument(_))
    ));

    // Bad directions.
    let print = || PrintProblem::from_mesh(&part, &mesh, nozzle(), 4.0, 200, 1).unwrap();
    let r = AlignProblem::new(print(), vec![Vector3::z(); n - 1]);
    assert!(matches!(r, Err(FieldError::InvalidArgument(_))), "{r:?}");
    let mut dirs = vec![Vector3::z(); n];
    dirs[3] = Vector3::new(f64::NAN, 0.0, 1.0);
    let r = AlignProblem::new(print(), dirs);
    assert!(matches!(r, Err(FieldError::NonFinite { what: "direction", index: 3 })), "{r:?}");
    let r = AlignProblem::new(print(), vec![Vector3::zeros(); n]);
    assert!(matches!(r, Err(FieldError::InvalidArgument(_))), "{r:?}");
    // Zero rows prescribe nothing and are left out of the measure.
    let mut dirs = vec![Vector3::zeros(); n];
    dirs[0] = Vector3::z() * 5.0;
    let one = AlignProblem::new(print(), dirs).unwrap();
    assert_eq!(one.directions()[0], Vector3::z());
    assert_eq!(alignment_stats(&g.to_f64().unwrap(), &one).samples, 1);
}
