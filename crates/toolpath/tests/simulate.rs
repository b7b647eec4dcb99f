//! Simulation through voxsim: gouges, rapid collisions, IoU against the closure, and the
//! strategy comparison table (run with `--nocapture` to see it).

mod common;

use common::HeightField;
use s2g_geom::{Aabb, GridSpec, Mesh, Setup, VoxelGrid, occupancy_iou, voxelize};
use s2g_toolpath::{PlanOptions, PlanSummary, Strategy, Tool, VoxelMaterial, plan_setup, plan_setup_rest};
use s2g_voxsim::{Cutter, SimOptions, SimReport, Simulator, ToolTable};

fn stepped_pocket() -> HeightField {
    HeightField::new(10, 8, 0.1, |i, j| {
        if (1..4).contains(&i) && (2..6).contains(&j) {
            0.15
        } else if i >= 6 {
            0.3
        } else {
            0.5
        }
    })
}

/// A grid over `bounds` with cubic voxels of side `h` (the box must be a whole number of voxels).
fn grid_over(bounds: &Aabb, h: f64) -> GridSpec {
    let e = bounds.extent();
    let dims = [0, 1, 2].map(|a| ((e[a] / h).round() as usize).max(1));
    GridSpec::new(bounds, dims).expect("valid grid")
}

fn simulate(
    stock: VoxelGrid,
    target: &VoxelGrid,
    tool: &Tool,
    run: impl FnOnce(&mut Simulator) -> PlanSummary,
) -> (PlanSummary, SimReport, VoxelGrid) {
    let cutter = Cutter::flat(tool.radius, 10.0);
    let mut sim = Simulator::new(stock, ToolTable::single(cutter), SimOptions::default())
        .expect("simulator")
        .with_target(target)
        .expect("same grid");
    let summary = run(&mut sim);
    let s = sim.into_simulation().expect("simulation");
    let (report, residual) = s.into_parts();
    (summary, report, residual)
}

#[test]
fn stepped_block_with_pocket_machines_without_gouges_to_iou_099() {
    let hf = stepped_pocket();
    let part = hf.mesh();
    let stock = part.bbox().expect("bbox");
    let spec = grid_over(&stock, 1.0 / 160.0);
    let target = voxelize(&part, &spec).expect("voxelize");
    let tool = Tool::flat(0.02);
    for strategy in [Strategy::Zigzag { angle_deg: 0.0 }, Strategy::Periphery, Strategy::Spiral] {
        let opts = PlanOptions { layer_height: 0.05, strategy, stock: Some(stock), ..Default::default() };
        let (summary, report, residual) = simulate(VoxelGrid::full(spec), &target, &tool, |sim| {
            plan_setup(&part, &Setup::top(), &tool, &opts, sim).expect("plan")
        });
        let (iou, _) = occupancy_iou(&residual, &target).expect("same grid");
        let name = strategy.name();
        assert_eq!(report.gouge_voxels, 0, "{name}: gouges, first at line {:?}", report.first_gouge_line);
        assert_eq!(report.rapid_collision_voxels, 0, "{name}: rapids through material");
        assert!(report.holder_collisions.is_empty(), "{name}: holder collisions");
        assert!(iou >= 0.99, "{name}: IoU {iou} < 0.99 ({summary:?})");
    }
}

fn openscad(name: &str) -> Mesh {
    let p = format!("{}/../../tests/data/meshes/openscad/{name}", env!("CARGO_MANIFEST_DIR"));
    let m = s2g_geom::load_mesh(&p).unwrap_or_else(|e| panic!("{p}: {e}"));
    s2g_geom::normalize_unit_cube(&m).expect("normalise").0
}

/// Three parts, two setups (+Z then -Z with the remaining material from simulating the
/// first): path length, time and air-cutting fraction of the second setup per strategy.
#[test]
fn strategy_comparison_table() {
    let parts: Vec<(&str, Mesh)> = vec![
        ("stepped pocket", stepped_pocket().mesh()),
        ("cylinder", common::cylinder(0.5, 0.5, 0.3, 0.4, 48)),
        ("example002", openscad("openscad_Old_example002.stl")),
    ];
    println!(
        "| part | strategy | setup-2 cutting length | rapid length | time (s) | air fraction | gouges | rapid collisions |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (name, part) in &parts {
        let bb = part.bbox().expect("bbox");
        let e = bb.extent().max();
        let stock = Aabb::new(bb.min, bb.max);
        let h = e / 64.0;
        // Whole voxels: grow the box to a multiple of h.
        let ext = stock.extent();
        let grow = [0, 1, 2].map(|a| ((ext[a] / h).ceil() * h - ext[a]) * 0.5);
        let stock = Aabb::new(
            stock.min - nalgebra::Vector3::new(grow[0], grow[1], grow[2]),
            stock.max + nalgebra::Vector3::new(grow[0], grow[1], grow[2]),
        );
        let spec = grid_over(&stock, h);
        let target = voxelize(part, &spec).expect("voxelize");
        let tool = Tool::flat(0.02 * e);
        let top = Setup::top();
        let bottom = Setup::six_axes()[1];
        let base = PlanOptions { layer_height: e / 16.0, stock: Some(stock), ..Default::default() };
        let (_, r1, after_top) = simulate(VoxelGrid::full(spec), &target, &tool, |sim| {
            plan_setup(part, &top, &tool, &base, sim).expect("plan top")
        });
        assert_eq!(r1.gouge_voxels, 0, "{name}: top setup gouges");
        let mut lengths = Vec::new();
        for strategy in [Strategy::Zigzag { angle_deg: 0.0 }, Strategy::Periphery, Strategy::Spiral] {
            // The stock box in the bottom setup's frame.
            let inv = bottom.frame.inverse();
            let corners: Vec<_> = (0..8)
                .map(|c| {
                    inv * nalgebra::Point3::new(
                        if c & 1 == 0 { stock.min.x } else { stock.max.x },
                        if c & 2 == 0 { stock.min.y } else { stock.max.y },
                        if c & 4 == 0 { stock.min.z } else { stock.max.z },
                    )
                })
                .collect();
            let sb = Aabb::from_points(&corners).expect("corners");
            let opts = PlanOptions { strategy, stock: Some(sb), ..base.clone() };
            let rest = VoxelMaterial { grid: &after_top, setup: bottom };
            let (summary, report, _) = simulate(after_top.clone(), &target, &tool, |sim| {
                plan_setup_rest(part, &bottom, &tool, &opts, Some(&rest), sim).expect("plan bottom")
            });
            let air = summary.air_cut_fraction.expect("rest given");
            println!(
                "| {name} | {} | {:.3} | {:.3} | {:.2} | {:.3} | {} | {} |",
                strategy.name(),
                summary.cutting_length,
                summary.rapid_length,
                summary.estimated_time_s,
                air,
                report.gouge_voxels,
                report.rapid_collision_voxels
            );
            assert!((0.0..=1.0).contains(&air), "{name}: air fraction {air}");
            assert_eq!(report.gouge_voxels, 0, "{name}/{}: gouges", strategy.name());
            assert_eq!(report.rapid_collision_voxels, 0, "{name}/{}: rapid collisions", strategy.name());
            lengths.push(summary.cutting_length);
        }
        assert!(lengths.iter().all(|&l| l > 0.0), "{name}: every strategy cuts something: {lengths:?}");
    }
}
