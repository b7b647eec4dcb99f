//! Direction-aligned printing layers (DAC, Eq. 38) and layer-toolpath co-optimisation
//! (TGC, Eq. 39) on a bent arm (§5.2-5.3, §7.2-7.3 of seed 002).
//!
//! The prescribed direction is the arm's axis ([`bent_arm_axis`]): the direction of the
//! bending stress of the arm loaded at its free end, which fibres and layers should follow.
//! Planar layers cut straight across it in the column (90°) and at 30° along the arm.
//!
//! For the planar start and the optimised fields the example prints: the mean and the
//! largest angle between the prescribed direction and the layers (0° when the direction
//! lies in the layer: Eq. 18), the fraction of poses within 10°, the nozzle poses (nozzle
//! along the layer normal, sampled densely) that hit printed material or the platform; for
//! TGC also the mean angle between the toolpath tangent (iso-curves of the path field on
//! the layers) and the prescribed direction and the path spacing's coefficient of
//! variation; then one JSON line. The DAC angles are also given per region (column, bend,
//! arm): the column's bottom stands on the platform, where a nozzle turned horizontal would
//! dip below it, so Eq. 38 keeps those layers tilted.
//!
//! ```text
//! cargo run --release -p s2g-field --example aligned_layers [-- --steps N --tgc-steps N
//!     --batch N --grid MM --lr LR --seed S --omega W0 --zero-gradient W --ablation true]
//! ```
//!
//! TGC has no collision term (Table 1); its nozzle counts are measured, not optimised.
//!
//! `--ablation true` also runs DAC without the collision terms (weight 0), the ablation of
//! Fig. 16(d1, d2).

use std::time::Instant;

use s2g_field::{
    AlignProblem, AlignmentStats, Backend, DacOptions, MeshSdf, PathStats, PrintCollisionCount, PrintProblem,
    SirenF64, TgcOptions, Tool, alignment_stats, bent_arm_axis, bent_arm_mesh, init_tgc_fields,
    layer_alignment, optimize_dac_layers, optimize_tgc, path_stats, pretrain_planar_dac, print_collisions,
};
use s2g_geom::Vector3;

const COLUMN: f64 = 12.0;
const BEND_RADIUS: f64 = 16.0;
const BEND_DEG: f64 = 60.0;

fn row(name: &str, a: &AlignmentStats, c: &PrintCollisionCount) {
    println!(
        "{name:<22} {:>9.1} ° {:>9.1} ° {:>10.1} % {:>8} of {:<4} {:>8} of {:<4}",
        a.mean_deg,
        a.max_deg,
        100.0 * a.fraction_within_10,
        c.part,
        c.poses,
        c.platform,
        c.poses
    );
}

/// Mean alignment angle of `g` in the column, the bend and the arm.
fn regions(g: &SirenF64, problem: &AlignProblem<'_>) -> [f64; 3] {
    let nz = problem.print().normalization();
    let mut sums = [(0.0, 0usize); 3];
    for (p, d) in problem.print().poses().iter().zip(problem.directions()) {
        let u = nz.to_unit(p);
        let (_, grad) = g.value_gradient([u.x, u.y, u.z]);
        let Some(angle) = layer_alignment(&Vector3::from(grad), d) else { continue };
        let t = d.x.atan2(d.z).to_degrees();
        let k = if t < 1e-6 {
            0
        } else if t < BEND_DEG - 1e-6 {
            1
        } else {
            2
        };
        sums[k].0 += angle;
        sums[k].1 += 1;
    }
    sums.map(|(s, n)| s / n.max(1) as f64)
}

/// The command line: DAC's and TGC's options, the pose grid, whether to run the ablation.
fn parse_args() -> Result<(DacOptions, TgcOptions, f64, bool), Box<dyn std::error::Error>> {
    let mut dac = DacOptions::default();
    let mut tgc = TgcOptions::default();
    let mut grid = 2.5;
    let mut ablation = false;
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        match flag.as_str() {
            "--steps" => dac.steps = value.parse()?,
            "--tgc-steps" => tgc.steps = value.parse()?,
            "--batch" => (dac.batch_size, tgc.batch_size) = (value.parse()?, value.parse()?),
            "--grid" => grid = value.parse()?,
            "--lr" => (dac.learning_rate, tgc.learning_rate) = (value.parse()?, value.parse()?),
            "--seed" => (dac.seed, tgc.seed) = (value.parse()?, value.parse()?),
            "--ablation" => ablation = value.parse()?,
            "--omega" => {
                (dac.network.first_omega, tgc.layer_network.first_omega) = (value.parse()?, value.parse()?)
            }
            "--zero-gradient" => {
                (dac.weights.zero_gradient, tgc.weights.zero_gradient) = (value.parse()?, value.parse()?)
            }
            _ => return Err(format!("unknown flag {flag}").into()),
        }
    }
    Ok((dac, tgc, grid, ablation))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (dac, tgc, grid, ablation) = parse_args()?;
    let t0 = Instant::now();
    let arm = bent_arm_mesh(6.0, COLUMN, BEND_RADIUS, BEND_DEG, 24.0, 32, 12)?;
    let part = MeshSdf::new(&arm)?;
    let nozzle = Tool { axial_offset: 1.0, axial_step: 3.0, ..Tool::cylinder(2.5, 30.0) };
    let check = Tool { axial_step: 1.5, ring_points: 24, ..nozzle };
    let print = PrintProblem::from_mesh(&part, &arm, nozzle, grid, 500, dac.seed)?;
    let problem = AlignProblem::from_field(print, |p| bent_arm_axis(p, COLUMN, BEND_RADIUS, BEND_DEG))?;
    let (points, directions) = problem.unit_samples();
    println!(
        "bent arm: {} triangles; {} poses on a {grid} mm grid, each with the arm's axis as its direction",
        arm.triangles().len(),
        problem.print().poses().len()
    );
    let by_region = |name: &str, g: &SirenF64| {
        let [c, b, a] = regions(g, &problem);
        println!("{name:<22} mean angle in the column {c:.1} °, the bend {b:.1} °, the arm {a:.1} °");
    };
    let measure =
        |g: &SirenF64| -> Result<(AlignmentStats, PrintCollisionCount), Box<dyn std::error::Error>> {
            Ok((alignment_stats(g, &problem), print_collisions(g, problem.print(), &check)?.0))
        };

    // DAC: planar start, Eq. 38.
    let planar = pretrain_planar_dac(&dac)?;
    let planar_host = planar.to_f64()?;
    let (planar_align, planar_hits) = measure(&planar_host)?;
    let (g, dac_report) = optimize_dac_layers(planar.clone(), &problem, &dac)?;
    let g = g.to_f64()?;
    let (dac_align, dac_hits) = measure(&g)?;
    let ablated = if ablation {
        let options = DacOptions {
            weights: s2g_field::DacWeights { collision_start: 0.0, collision_end: 0.0, ..dac.weights },
            ..dac.clone()
        };
        let (g, _) = optimize_dac_layers(planar, &problem, &options)?;
        let g = g.to_f64()?;
        Some((measure(&g)?, g))
    } else {
        None
    };
    println!("DAC final losses (alignment, collision, platform, spacing, zero-gradient, curvature):");
    println!("  {:?} -> {:?}", dac_report.initial_losses, dac_report.final_losses);
    println!(
        "{:<22} {:>11} {:>11} {:>12} {:>14} {:>14}",
        "layers", "mean angle", "max angle", "within 10°", "nozzle hits", "below platform"
    );
    row("planar", &planar_align, &planar_hits);
    row("DAC (Eq. 38)", &dac_align, &dac_hits);
    if let Some(((a, c), _)) = &ablated {
        row("DAC, no collision term", a, c);
    }
    by_region("planar", &planar_host);
    by_region("DAC (Eq. 38)", &g);
    if let Some((_, g)) = &ablated {
        by_region("DAC, no collision term", g);
    }
    println!("DAC optimisation {:.1} s ({} steps)", dac_report.seconds, dac_report.steps);

    // TGC: planar G and random P, optimised together by Eq. 39.
    let fields = init_tgc_fields(&tgc)?;
    let (g0, p0) = (fields.layer.to_f64()?, fields.path.to_f64()?);
    let (tgc0_align, tgc0_hits) = measure(&g0)?;
    let path0 = path_stats(&g0, &p0, &points, &directions, Backend::default())?;
    let (fields, tgc_report) = optimize_tgc(fields, &problem, &tgc)?;
    let (g1, p1) = (fields.layer.to_f64()?, fields.path.to_f64()?);
    let (tgc_align, tgc_hits) = measure(&g1)?;
    let path1 = path_stats(&g1, &p1, &points, &directions, Backend::default())?;
    println!(
        "TGC losses (layer alignment, layer spacing, zero-gradient, layer curvature, path spacing, \
         path curvature, path alignment, path continuity):"
    );
    println!("  {:?} -> {:?}", tgc_report.initial_losses, tgc_report.final_losses);
    row("TGC start (planar G)", &tgc0_align, &tgc0_hits);
    row("TGC (Eq. 39)", &tgc_align, &tgc_hits);
    let path_row = |name: &str, s: &PathStats| {
        println!(
            "{name:<22} path tangent {:>5.1} ° off the direction, |∇_s P| mean {:.3}, cv {:.3}, mean |κ_g| {:.2}",
            s.mean_angle_deg, s.spacing_mean, s.spacing_cv, s.mean_abs_curvature
        )
    };
    path_row("TGC start (random P)", &path0);
    path_row("TGC (Eq. 39)", &path1);
    println!(
        "TGC optimisation {:.1} s ({} steps); total {:.1} s",
        tgc_report.seconds,
        tgc_report.steps,
        t0.elapsed().as_secs_f64()
    );
    let ablation_json = match &ablated {
        Some(((a, c), _)) => format!(
            ",\"dac_no_collision\":{{\"mean_angle_deg\":{:.2},\"colliding_poses\":{},\"platform_poses\":{}}}",
            a.mean_deg, c.part, c.platform
        ),
        None => String::new(),
    };
    println!(
        "{{\"poses\":{},\"dac\":{{\"mean_angle_deg\":{{\"before\":{:.2},\"after\":{:.2}}},\"colliding_poses\":{{\"before\":{},\"after\":{}}},\
         \"platform_poses\":{{\"before\":{},\"after\":{}}},\"steps\":{},\"seconds\":{:.1}}}{ablation_json},\
         \"tgc\":{{\"mean_angle_deg\":{{\"before\":{:.2},\"after\":{:.2}}},\"path_angle_deg\":{{\"before\":{:.2},\"after\":{:.2}}},\
         \"path_spacing_cv\":{{\"before\":{:.3},\"after\":{:.3}}},\"colliding_poses\":{{\"before\":{},\"after\":{}}},\"platform_poses\":{{\"before\":{},\"after\":{}}},\"steps\":{},\"seconds\":{:.1}}}}}",
        planar_hits.poses,
        planar_align.mean_deg,
        dac_align.mean_deg,
        planar_hits.part,
        dac_hits.part,
        planar_hits.platform,
        dac_hits.platform,
        dac_report.steps,
        dac_report.seconds,
        tgc0_align.mean_deg,
        tgc_align.mean_deg,
        path0.mean_angle_deg,
        path1.mean_angle_deg,
        path0.spacing_cv,
        path1.spacing_cv,
        tgc0_hits.part,
        tgc_hits.part,
        tgc0_hits.platform,
        tgc_hits.platform,
        tgc_report.steps,
        tgc_report.seconds
    );
    Ok(())
}
