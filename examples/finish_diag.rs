//! Where a shop run's residual and time go (issue 36 diagnosis): mills a mesh in the shop
//! preset with finishing, one setup at a time, and prints per setup the volume removed,
//! the tools and their reach; then classifies the excess material left (residual stock
//! outside the part) by thickness and by why no finisher took it: not visible from any
//! setup, visible only beyond the finisher's reach, within reach but in a concave region
//! the ball cannot touch, or finishable (a finisher that should have taken it).
//!
//! `cargo run --release --example finish_diag -- MESH [SIZE_MM] [RES]`; environment:
//! `DIAG_STRATEGY` (parallel|waterline|steep-shallow), `DIAG_NO_FINISH=1`,
//! `DIAG_RESIDUAL=FILE.stl` writes the residual (input units), `DIAG_GRID` (analysis grid,
//! default 256).

use std::time::Instant;

use shape2gcode::geom::{Aabb, GridSpec, Mesh, MeshIndex, Point3, Vector3, load_mesh, save_mesh, voxelize};
use shape2gcode::{FinishChoice, FinishStrategyKind, HeuristicPolicy, MillOptions, MillRun, Policy, Preset};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("assets/stanford_bunny.stl", String::as_str);
    let size: f64 = args.get(2).map_or(Ok(100.0), |s| s.parse())?;
    let res: usize = args.get(3).map_or(Ok(128), |s| s.parse())?;
    let mesh = load_mesh(path)?;
    let b = mesh.bbox().ok_or("empty mesh")?;
    let scale = size / b.extent().max();
    let strategy = std::env::var("DIAG_STRATEGY").ok();
    let strategy = match strategy.as_deref() {
        Some(s) => FinishStrategyKind::from_name(s).ok_or("unknown strategy")?,
        None => FinishStrategyKind::Parallel,
    };
    let finish = std::env::var("DIAG_NO_FINISH")
        .is_err()
        .then_some(FinishChoice { strategy, ..FinishChoice::default() });
    let opts = MillOptions {
        preset: Preset::Shop,
        input_scale: scale,
        resolution: res,
        finish,
        ..MillOptions::default()
    };
    if std::env::var("DIAG_REACH").is_ok() {
        return reach_sweep(&mesh, scale);
    }
    if std::env::var("DIAG_CEILING").is_ok() {
        return ceiling(&mesh, scale, res);
    }
    let t = Instant::now();
    let mut run = MillRun::new(&mesh, &opts, &mut |_| {})?;
    let mut policy = HeuristicPolicy::default();
    let stock0 = run.stock_volume();
    println!("stock volume {stock0:.0} mm^3");
    let mut before = stock0;
    while run.next_setup().is_some() {
        let features = run.features();
        let ctx = run.context(&features);
        let action = policy.choose(&ctx);
        let fin = opts.finish.map(|d| policy.finish(&ctx, d));
        run.machine_finished(action, fin, &mut |_| {})?;
        let after = run.stock_volume();
        let s = run.machined().last().ok_or("no setup")?;
        let axis = s.setup.tool_axis().into_inner();
        println!(
            "setup {}: axis ({:+.3} {:+.3} {:+.3}) T{} r{} layer {} removed {:.0} mm^3 (left {:.0}); time {:.0} s",
            run.machined().len(),
            axis.x,
            axis.y,
            axis.z,
            s.tool.number,
            s.tool.radius(),
            s.action.layer_height,
            before - after,
            after,
            s.machine_time_s.unwrap_or(0.0)
        );
        if let Some(f) = &s.finish {
            println!(
                "  finish T{} r{} reach {:.1}: rough {:.0} s finish {:.0} s, passes {} retracts {} links {}, dev max {:.3} mean {:.4}",
                f.tool.number,
                f.tool.radius(),
                f.tool.envelope().length,
                f.roughing_time_s,
                f.finishing_time_s,
                f.summary.passes,
                f.summary.retracts,
                f.summary.links,
                f.deviation.max,
                f.deviation.mean
            );
        }
        before = after;
    }
    let milled = run.finish("heuristic", &mut |_| {})?;
    let holder = &milled.simulation.holder_collisions;
    println!("holder collisions at lines {:?}", &holder[..holder.len().min(20)]);
    for (k, text) in milled.programs.iter().enumerate() {
        let lines: Vec<&str> = text.lines().collect();
        for &l in holder.iter().take(8) {
            let i = l as usize;
            if i >= 3 && i < lines.len() {
                println!(
                    "  program {} line {l}: {} | {} | {}",
                    k + 1,
                    lines[i - 3],
                    lines[i - 2],
                    lines[i - 1]
                );
            }
        }
    }

    let m = &milled.metrics;
    println!(
        "IoU {:.4} NC {:.4} CD {:.4}  time {:.0} s  ({:.1} s wall)",
        m.iou,
        m.normal_consistency,
        m.chamfer_x1000,
        milled.setups.iter().filter_map(|s| s.machine_time_s).sum::<f64>(),
        t.elapsed().as_secs_f64()
    );
    if let Ok(p) = std::env::var("DIAG_RESIDUAL") {
        save_mesh(&p, &milled.residual)?;
    }
    analyse(&mesh, scale, &milled)
}

/// The excess material (residual outside the part) by thickness and by cause.
fn analyse(mesh: &Mesh, scale: f64, milled: &shape2gcode::Milled) -> Result<(), Box<dyn std::error::Error>> {
    let sim = shape2gcode::geom::Similarity3::from_scaling(scale);
    let part = mesh.transformed(&sim);
    let residual = milled.residual.transformed(&sim);
    let n: usize = std::env::var("DIAG_GRID").ok().and_then(|s| s.parse().ok()).unwrap_or(256);
    let pb = part.bbox().ok_or("empty")?;
    let l = pb.extent().max();
    let c = pb.center();
    let cube = Aabb::new(c - Vector3::repeat(0.5 * l), c + Vector3::repeat(0.5 * l));
    let spec = GridSpec::cubic(&cube, n)?;
    let pv = voxelize(&part, &spec)?;
    let rv = voxelize(&residual, &spec)?;
    let mut excess = rv.clone();
    excess.andnot(&pv)?;
    let mut missing = pv.clone();
    missing.andnot(&rv)?;
    let vv = spec.voxel_volume();
    let inter = pv.count_and(&rv)? as f64;
    let union = pv.count() as f64 + rv.count() as f64 - inter;
    println!(
        "analysis grid {n}^3 (voxel {:.3} mm): part {:.0} mm^3, residual {:.0}, excess {:.0}, missing {:.0}; IoU here {:.4}",
        spec.voxel.x,
        pv.count() as f64 * vv,
        rv.count() as f64 * vv,
        excess.count() as f64 * vv,
        missing.count() as f64 * vv,
        inter / union
    );
    let index = MeshIndex::new(&part)?;
    // The setups: frame, finisher radius and reach, stock top along the axis.
    let stock = Aabb::new(
        Point3::from(milled.stock.min.coords * scale),
        Point3::from(milled.stock.max.coords * scale),
    );
    struct S {
        axis: Vector3,
        top: f64,
        radius: f64,
        reach: f64,
    }
    let setups: Vec<S> = milled
        .setups
        .iter()
        .map(|s| {
            let axis = s.setup.tool_axis().into_inner();
            let top = stock.corners().iter().map(|c| c.coords.dot(&axis)).fold(f64::NEG_INFINITY, f64::max);
            let (radius, reach) =
                s.finish.as_ref().map_or((s.tool.radius(), s.tool.envelope().length), |f| {
                    (f.tool.radius(), f.tool.envelope().length)
                });
            S { axis, top, radius, reach }
        })
        .collect();
    for (i, s) in setups.iter().enumerate() {
        println!(
            "  setup {}: stock top {:.1} along axis, part from {:.1} to {:.1} below it; finisher r{} reach {:.1}",
            i + 1,
            s.top,
            s.top - pb.corners().iter().map(|c| c.coords.dot(&s.axis)).fold(f64::NEG_INFINITY, f64::max),
            s.top - pb.corners().iter().map(|c| c.coords.dot(&s.axis)).fold(f64::INFINITY, f64::min),
            s.radius,
            s.reach
        );
    }
    let cells: Vec<[usize; 3]> = excess.iter_set().collect();
    use rayon::prelude::*;
    let diag = 2.0 * l;
    // Per excess voxel: (thickness bin, cause, per-setup visible & reach flags).
    let classes: Vec<(usize, usize, f64)> = cells
        .par_iter()
        .map(|&[i, j, k]| {
            let p = spec.center(i, j, k);
            let cp = index.closest_point(&p);
            let d = cp.distance;
            let bin = [0.2, 0.5, 1.0, 2.0, 5.0].iter().position(|&e| d < e).unwrap_or(5);
            let nrm = part.face_normal(cp.triangle as usize).unwrap_or_else(Vector3::z);
            let q = cp.point;
            let mut best = 0; // 0 hidden, 1 beyond reach, 2 concave, 3 finishable
            for s in &setups {
                let visible = nrm.dot(&s.axis) > -0.05
                    && !index.ray_hits_any(&(q + nrm * 1e-4 + s.axis * 1e-3), &s.axis, diag);
                if !visible {
                    continue;
                }
                let depth = s.top - q.coords.dot(&s.axis);
                if depth > s.reach {
                    best = best.max(1);
                    continue;
                }
                let ball = index.signed_distance(&(q + nrm * s.radius));
                if ball < 0.98 * s.radius {
                    best = best.max(2);
                    continue;
                }
                best = 3;
            }
            (bin, best, d)
        })
        .collect();
    let names =
        ["hidden from every setup", "beyond the finisher's reach", "concave: ball too big", "finishable"];
    let bins = ["<0.2", "0.2-0.5", "0.5-1", "1-2", "2-5", ">=5"];
    let mut table = [[0u64; 6]; 4];
    for &(bin, cause, _) in &classes {
        table[cause][bin] += 1;
    }
    println!("  excess by cause (mm^3) and distance from the part (mm): {}", bins.join(" | "));
    for (c, name) in names.iter().enumerate() {
        let row: Vec<String> = table[c].iter().map(|&n| format!("{:.0}", n as f64 * vv)).collect();
        let total: u64 = table[c].iter().sum();
        println!("    {name:30} total {:7.0}: {}", total as f64 * vv, row.join(" | "));
    }
    let pvol = pv.count() as f64 * vv;
    println!(
        "  for IoU 0.99 the excess + missing must stay under ~{:.0} mm^3 (1 % of the part)",
        0.01 * pvol
    );
    Ok(())
}

/// The scores of a perfect machining: the part's own voxels on the simulation grid,
/// meshed and smoothed as the run meshes its residual, scored as the run scores.
fn ceiling(mesh: &Mesh, scale: f64, res: usize) -> Result<(), Box<dyn std::error::Error>> {
    use shape2gcode::geom::{
        MetricOptions, Similarity3, TAUBIN_LAMBDA, TAUBIN_MU, compare, marching_cubes_voxels, taubin_smooth,
        unit_cube_normalization,
    };
    let part = mesh.transformed(&Similarity3::from_scaling(scale));
    let pb = part.bbox().ok_or("empty")?;
    let l = pb.extent().max();
    let h = l / res as f64;
    let c = pb.center();
    let lo = c - Vector3::repeat(0.5 * l + 2.0 * h);
    let hi = c + Vector3::repeat(0.5 * l + 2.0 * h);
    let spec = GridSpec { origin: lo, voxel: Vector3::repeat(h), dims: [res + 4; 3] };
    let _ = hi;
    let grid = voxelize(&part, &spec)?;
    let raw = marching_cubes_voxels(&grid)?;
    let unit = unit_cube_normalization(mesh)?;
    let back = Similarity3::from_scaling(1.0 / scale);
    for iters in [0usize, 8] {
        let m = if iters > 0 { taubin_smooth(&raw, iters, TAUBIN_LAMBDA, TAUBIN_MU)? } else { raw.clone() };
        let m_in = m.transformed(&back);
        let metrics = compare(
            &m_in.transformed(&unit.as_similarity()),
            &mesh.transformed(&unit.as_similarity()),
            &MetricOptions::default(),
        )?;
        println!(
            "ceiling at {res}^3, {iters} smoothing steps: IoU {:.4} NC {:.4} CD {:.4}",
            metrics.iou, metrics.normal_consistency, metrics.chamfer_x1000
        );
        if let Ok(p) = std::env::var("DIAG_RESIDUAL") {
            save_mesh(format!("{p}.{iters}.stl"), &m_in)?;
        }
    }
    Ok(())
}

/// Setups orientation selection finds for tools of several reaches (box stock, 2 % margin).
fn reach_sweep(mesh: &Mesh, scale: f64) -> Result<(), Box<dyn std::error::Error>> {
    use shape2gcode::geom::Similarity3;
    use shape2gcode::orient::{OrientOptions, ToolReach, select_orientations_in_stock, stock_grid_points};
    let part = mesh.transformed(&Similarity3::from_scaling(scale));
    let b = part.bbox().ok_or("empty")?;
    let stock = b.inflated(0.02 * b.extent().max());
    let samples = stock_grid_points(&stock, 32 * 32 * 32, |_| true);
    for depth in [46.0, 56.0, 66.0, 76.0, 86.0, 96.0, f64::INFINITY] {
        let opts = OrientOptions {
            min_cos: -0.5 / 256.0,
            reach: depth.is_finite().then_some(ToolReach::new(stock, depth)),
            ..OrientOptions::default()
        };
        let r = select_orientations_in_stock(&part, &samples, &opts)?;
        let dirs: Vec<String> =
            r.directions.iter().map(|d| format!("({:+.2} {:+.2} {:+.2})", d.x, d.y, d.z)).collect();
        println!(
            "reach {depth}: {} setups {:?} coverage {:?} upper {:.4} six axes {:.4}",
            dirs.len(),
            dirs,
            r.coverage,
            r.upper_bound,
            r.baselines.six_axes
        );
    }
    Ok(())
}
