//! Simulation through voxsim: gouges, rapid collisions, IoU against the closure, and the
//! strategy comparison table (run with `--nocapture` to see it).

mod common;

use common::HeightField;
use s2g_gcode::{Dialect, GcodeWriter, MotionRecorder, MotionSink, ParseOptions, WriterOptions, parse_str};
use s2g_geom::{Aabb, GridSpec, Mesh, Point3, Setup, VoxelGrid, occupancy_iou, voxelize};
use s2g_toolpath::{
    LayerPlan, PlanOptions, PlanSummary, Point2, Tool, VoxelMaterial, plan_layers, plan_setup,
    plan_setup_rest, strategies,
};
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
    let cutter = Cutter::flat(tool.radius(), 10.0);
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
    for strategy in strategies().iter() {
        let opts = PlanOptions {
            layer_height: 0.05,
            strategy: strategy.clone(),
            stock: Some(stock),
            ..Default::default()
        };
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

/// The bundled bunny and OpenSCAD's example001, each normalised into the unit cube.
fn bunny_and_example001() -> [(&'static str, Mesh); 2] {
    let p = format!("{}/../../assets/stanford_bunny.stl", env!("CARGO_MANIFEST_DIR"));
    let m = s2g_geom::load_mesh(&p).unwrap_or_else(|e| panic!("{p}: {e}"));
    let bunny = s2g_geom::normalize_unit_cube(&m).expect("normalise").0;
    [("bunny", bunny), ("example001", openscad("openscad_Old_example001.stl"))]
}

/// A part's box stock, a voxel larger than the part on every side and whole voxels of 1/96
/// of its longest side (`e`), its grid and the part's voxels.
struct Stocked {
    e: f64,
    stock: Aabb,
    spec: GridSpec,
    target: VoxelGrid,
}

fn stocked(part: &Mesh) -> Stocked {
    let bb = part.bbox().expect("bbox");
    let e = bb.extent().max();
    let h = e / 96.0;
    let ext = bb.extent();
    let grow = [0, 1, 2].map(|a| ((ext[a] / h).ceil() * h - ext[a]) * 0.5 + h);
    let g = nalgebra::Vector3::new(grow[0], grow[1], grow[2]);
    let stock = Aabb::new(bb.min - g, bb.max + g);
    let spec = grid_over(&stock, h);
    let target = voxelize(part, &spec).expect("voxelize");
    Stocked { e, stock, spec, target }
}

fn openscad(name: &str) -> Mesh {
    let p = format!("{}/../../tests/data/meshes/openscad/{name}", env!("CARGO_MANIFEST_DIR"));
    let m = s2g_geom::load_mesh(&p).unwrap_or_else(|e| panic!("{p}: {e}"));
    s2g_geom::normalize_unit_cube(&m).expect("normalise").0
}

/// The set voxels' centres of a part-frame grid in a setup's frame, bucketed by (x, y).
struct Centres {
    lo: Point2,
    cell: f64,
    nx: usize,
    ny: usize,
    buckets: Vec<Vec<Point3>>,
}

impl Centres {
    fn new(grid: &VoxelGrid, setup: &Setup, cell: f64) -> Self {
        let spec = *grid.spec();
        let pts: Vec<Point3> =
            grid.iter_set().map(|[i, j, k]| setup.to_setup(&spec.center(i, j, k))).collect();
        let lo = pts
            .iter()
            .fold(Point2::new(f64::INFINITY, f64::INFINITY), |m, p| Point2::new(m.x.min(p.x), m.y.min(p.y)));
        let hi = pts.iter().fold(Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY), |m, p| {
            Point2::new(m.x.max(p.x), m.y.max(p.y))
        });
        let (nx, ny) = if pts.is_empty() {
            (0, 0)
        } else {
            (((hi.x - lo.x) / cell) as usize + 1, ((hi.y - lo.y) / cell) as usize + 1)
        };
        let mut buckets = vec![Vec::new(); nx * ny];
        for p in pts {
            let i = ((p.x - lo.x) / cell) as usize;
            let j = ((p.y - lo.y) / cell) as usize;
            buckets[j * nx + i].push(p);
        }
        Self { lo, cell, nx, ny, buckets }
    }

    /// Whether some centre lies within `rad` of `p` horizontally, with `z0 <= z <= z1`.
    fn any(&self, p: &Point2, rad: f64, z0: f64, z1: f64) -> bool {
        if self.nx == 0 {
            return false;
        }
        let range = |v: f64, lo: f64, n: usize| {
            let a = ((v - rad - lo) / self.cell).floor().max(0.0) as usize;
            let b = (((v + rad - lo) / self.cell).floor().max(-1.0) as isize).min(n as isize - 1);
            (a, b)
        };
        let (i0, i1) = range(p.x, self.lo.x, self.nx);
        let (j0, j1) = range(p.y, self.lo.y, self.ny);
        for j in j0 as isize..=j1 {
            for i in i0 as isize..=i1 {
                let hit = self.buckets[j as usize * self.nx + i as usize].iter().any(|c| {
                    c.z >= z0 && c.z <= z1 && (c.x - p.x).powi(2) + (c.y - p.y).powi(2) <= rad * rad
                });
                if hit {
                    return true;
                }
            }
        }
        false
    }
}

/// Length-weighted fraction of the layers' contour and clearing paths whose samples are in
/// air by `air(p, z, z_above)`. The samples are the planner's own (midpoints of pieces of
/// at most r/2 along each segment), so footprints nested around the planner's give
/// fractions nested around its `air_cut_fraction` exactly.
fn air_fraction(layers: &[LayerPlan], r: f64, air: impl Fn(&Point2, f64, f64) -> bool) -> f64 {
    let (mut cut, mut out) = (0.0, 0.0);
    for plan in layers {
        for path in plan.contour.iter().chain(&plan.clearing) {
            cut += path.length();
            for (a, b) in path.segments() {
                let len = (b - a).norm();
                let n = ((len / (0.5 * r)).ceil() as usize).max(1);
                let k = (0..n)
                    .filter(|&k| air(&(a + (b - a) * ((k as f64 + 0.5) / n as f64)), plan.z, plan.z_above));
                out += len * k.count() as f64 / n as f64;
            }
        }
    }
    if cut > 0.0 { out / cut } else { 0.0 }
}

/// Three parts, two setups per strategy (+Z from the full stock, then -Z with the
/// remaining material from simulating the first): path length and time of both setups,
/// and the air-cutting fraction of the second.
///
/// The remaining material given to the planner is the simulated stock less the target
/// (what is still to be cut). The planner's air fraction (no such voxel centre within half
/// a voxel of the square of half-side r/2 under the cutter's centre, over the layer's
/// slab) is checked against two independent estimates from the same voxels on the same
/// samples: "cutter" (no voxel centre under the whole cutter, grown by half a voxel: a
/// footprint containing the planner's, so never more air) and "centre" (none within r/2
/// of the centre line: a footprint inside the planner's, so never less air). Rest
/// machining must never cut more than planning the second setup blind, nor more than
/// planning it with the part counted as material ("with part": finished walls traced
/// again in air).
#[test]
fn strategy_comparison_table() {
    let parts: Vec<(&str, Mesh)> = vec![
        ("stepped pocket", stepped_pocket().mesh()),
        ("cylinder", common::cylinder(0.5, 0.5, 0.3, 0.4, 48)),
        ("example002", openscad("openscad_Old_example002.stl")),
    ];
    println!(
        "| part | strategy | setup-1 length | setup-1 time (s) | setup-2 cutting length | with part | blind | rapid length | time (s) | air fraction | cutter | centre | gouges | rapid collisions |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
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
        let base = PlanOptions {
            layer_height: e / 16.0,
            stock: Some(stock),
            measure_air_cut: true,
            ..Default::default()
        };
        let r = tool.radius();
        let (mut lengths, mut removed) = (Vec::new(), Vec::new());
        for strategy in strategies().iter() {
            let top_opts = PlanOptions { strategy: strategy.clone(), ..base.clone() };
            let (s1, r1, after_top) = simulate(VoxelGrid::full(spec), &target, &tool, |sim| {
                plan_setup(part, &top, &tool, &top_opts, sim).expect("plan top")
            });
            assert_eq!(r1.gouge_voxels, 0, "{name}: top setup gouges");
            let mut removable_grid = after_top.clone();
            removable_grid.andnot(&target).expect("same grid");
            let removable = Centres::new(&removable_grid, &bottom, 2.0 * r);
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
            let opts = PlanOptions { strategy: strategy.clone(), stock: Some(sb), ..base.clone() };
            let rest = VoxelMaterial::new(&removable_grid, bottom);
            let (summary, report, _) = simulate(after_top.clone(), &target, &tool, |sim| {
                plan_setup_rest(part, &bottom, &tool, &opts, Some(&rest), sim).expect("plan bottom")
            });
            let air = summary.air_cut_fraction.expect("rest given");
            let (_, layers) = plan_layers::<()>(part, &bottom, &tool, &opts, Some(&rest)).expect("layers");
            let grown = (0.5 * r + 0.5 * h) * std::f64::consts::SQRT_2 + 1e-9;
            let cutter = air_fraction(&layers, r, |p, z, za| !removable.any(p, grown, z - h, za + h));
            let centre = air_fraction(&layers, r, |p, z, za| !removable.any(p, 0.5 * r, z, za));
            let with_part_rest = VoxelMaterial::new(&after_top, bottom);
            let mut with_part_rec = MotionRecorder::default();
            let with_part =
                plan_setup_rest(part, &bottom, &tool, &opts, Some(&with_part_rest), &mut with_part_rec)
                    .expect("plan bottom with the part as material");
            let (blind, blind_report, _) = simulate(after_top.clone(), &target, &tool, |sim| {
                plan_setup(part, &bottom, &tool, &opts, sim).expect("plan bottom blind")
            });
            println!(
                "| {name} | {} | {:.3} | {:.2} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {:.3} | {:.3} | {:.3} | {} | {} |",
                strategy.name(),
                s1.cutting_length,
                s1.estimated_time_s,
                summary.cutting_length,
                with_part.cutting_length,
                blind.cutting_length,
                summary.rapid_length,
                summary.estimated_time_s,
                air,
                cutter,
                centre,
                report.gouge_voxels,
                report.rapid_collision_voxels
            );
            let s = strategy.name();
            assert!(
                cutter <= air + 1e-9 && air <= centre + 1e-9,
                "{name}/{s}: air fraction {air} outside [{cutter}, {centre}] of the independent estimates"
            );
            assert!(
                summary.cutting_length <= blind.cutting_length * (1.0 + 1e-9),
                "{name}/{s}: rest machining cuts {} vs {} planned blind",
                summary.cutting_length,
                blind.cutting_length
            );
            assert!(
                summary.cutting_length <= with_part.cutting_length * (1.0 + 1e-9),
                "{name}/{s}: rest machining cuts {} vs {} with the part as material",
                summary.cutting_length,
                with_part.cutting_length
            );
            assert_eq!(report.gouge_voxels, 0, "{name}/{}: gouges", strategy.name());
            assert_eq!(report.rapid_collision_voxels, 0, "{name}/{}: rapid collisions", strategy.name());
            lengths.push(summary.cutting_length);
            removed.push((report.removed_voxels, blind_report.removed_voxels));
        }
        // The blind plan goes everywhere, so what it removes is what the setup can reach:
        // rest machining removes the same material (within a voxel layer along the paths
        // it skipped as air), and cuts nothing only when the blind plan removes nothing.
        for (s, (rest_removed, blind_removed)) in removed.iter().enumerate() {
            let slack = 0.01 * *blind_removed as f64 + 8.0;
            assert!(
                *rest_removed as f64 >= *blind_removed as f64 - slack,
                "{name}/strategy {s}: rest machining removes {rest_removed} voxels, blind {blind_removed}"
            );
            assert_eq!(
                lengths[s] == 0.0,
                *blind_removed == 0,
                "{name}/strategy {s}: {lengths:?} {removed:?}"
            );
        }
    }
}

/// Roughing groups (`roughing_depth`) clear the free region once per group and only the
/// steps along the walls on the levels between: the simulated part must come out the same
/// (same voxels removed, within the voxels along paths that differ), without gouges or
/// rapids through material, with much less cutting.
#[test]
fn roughing_groups_leave_the_same_part_with_less_cutting() {
    for (name, part) in bunny_and_example001() {
        let Stocked { e, stock, spec, target } = stocked(&part);
        let tool = Tool::flat(0.03 * e);
        let base = PlanOptions { layer_height: e / 96.0, stock: Some(stock), ..Default::default() };
        let run = |opts: &PlanOptions| {
            simulate(VoxelGrid::full(spec), &target, &tool, |sim| {
                plan_setup(&part, &Setup::top(), &tool, opts, sim).expect("plan")
            })
        };
        let (whole, whole_report, whole_residual) = run(&base);
        let rough_opts = PlanOptions { roughing_depth: Some(tool.diameter()), ..base.clone() };
        let (rough, report, residual) = run(&rough_opts);
        assert_eq!(report.gouge_voxels, 0, "{name}: gouges, first at line {:?}", report.first_gouge_line);
        assert_eq!(report.rapid_collision_voxels, 0, "{name}: rapids through material");
        assert_eq!(rough.layers, whole.layers, "{name}: same levels");
        let mut differ = residual.clone();
        differ.xor(&whole_residual).expect("same grid");
        let differ = differ.count();
        println!(
            "{name}: cutting {:.2} with roughing groups, {:.2} clearing every level; {differ} of {} removed voxels differ",
            rough.cutting_length, whole.cutting_length, whole_report.removed_voxels
        );
        assert!(
            (differ as f64) <= 0.002 * whole_report.removed_voxels as f64,
            "{name}: {differ} voxels differ of {} removed ({} with roughing)",
            whole_report.removed_voxels,
            report.removed_voxels
        );
        assert!(
            rough.cutting_length < 0.6 * whole.cutting_length,
            "{name}: roughing groups cut {} against {} clearing every level",
            rough.cutting_length,
            whole.cutting_length
        );
        // The finer levels of a group trace the walls only where their keep-out differs
        // from the roughing level's: where the wall is vertical, the roughing cut stood
        // lower at the same place, so their contours (kept whole without groups) vanish.
        let contour = |opts: &PlanOptions| -> (f64, usize) {
            let (_, layers) = plan_layers::<()>(&part, &Setup::top(), &tool, opts, None).expect("layers");
            let len = layers.iter().flat_map(|l| &l.contour).map(|p| p.length()).sum();
            (len, layers.iter().filter(|l| l.contour.is_empty() && l.clearing.is_empty()).count())
        };
        let ((grouped, empty), (every, _)) = (contour(&rough_opts), contour(&base));
        println!(
            "{name}: contour length {grouped:.2} with roughing groups, {every:.2} without; {empty} empty levels"
        );
        let most = if name == "example001" { 0.5 } else { 0.7 };
        assert!(grouped < most * every, "{name}: contours {grouped} with roughing groups, {every} without");
        assert!(empty > 0, "{name}: no level left empty by its roughing level");
        // A depth below the layer height groups nothing: the program is the paper's.
        let none = PlanOptions { roughing_depth: Some(0.5 * base.layer_height), ..base.clone() };
        let (same, _, _) = run(&none);
        assert_eq!(same, whole, "{name}: a roughing depth below the layer height changes the plan");
    }
}

/// The highest part face within horizontal distance `rad` of `(x, y)` on `hf`'s cells, if
/// any cell is that near.
fn highest_within(hf: &HeightField, x: f64, y: f64, rad: f64) -> Option<f64> {
    let c = hf.cell;
    let mut best: Option<f64> = None;
    for j in 0..hf.ny {
        for i in 0..hf.nx {
            let dx = (i as f64 * c - x).max(x - (i + 1) as f64 * c).max(0.0);
            let dy = (j as f64 * c - y).max(y - (j + 1) as f64 * c).max(0.0);
            if dx.hypot(dy) <= rad {
                let h = hf.height(i as isize, j as isize);
                best = Some(best.map_or(h, |b: f64| b.max(h)));
            }
        }
    }
    best
}

/// Roughing with a radial and an axial allowance keeps a skin of that thickness on walls
/// and floors (to within a voxel) and removes the material beyond it; without the
/// allowance the same skin is cut away.
#[test]
fn roughing_with_allowance_keeps_the_skin_and_removes_the_rest() {
    let hf = stepped_pocket();
    let part = hf.mesh();
    let b = part.bbox().expect("bbox");
    let stock = Aabb::new(
        Point3::new(b.min.x - 0.05, b.min.y - 0.05, 0.0),
        Point3::new(b.max.x + 0.05, b.max.y + 0.05, 0.6),
    );
    let v = 1.0 / 160.0;
    let spec = grid_over(&stock, v);
    let target = voxelize(&part, &spec).expect("voxelize");
    let tool = Tool::flat(0.02);
    let (radial, axial) = (0.03, 0.03);
    // Per run: (skin voxels kept, skin voxels, voxels beyond the skin left, voxels beyond).
    let run = |allow: bool| {
        let opts = PlanOptions {
            layer_height: 0.05,
            stock: Some(stock),
            finishing_allowance: if allow { radial } else { 0.0 },
            axial_allowance: if allow { axial } else { 0.0 },
            ..Default::default()
        };
        let (_, report, residual) = simulate(VoxelGrid::full(spec), &target, &tool, |sim| {
            plan_setup(&part, &Setup::top(), &tool, &opts, sim).expect("plan")
        });
        assert_eq!(report.gouge_voxels, 0, "allowance {allow}: gouges");
        assert_eq!(report.rapid_collision_voxels, 0, "allowance {allow}: rapids through material");
        let [nx, ny, nz] = residual.dims();
        let (mut skin_kept, mut skin, mut beyond_left, mut beyond) = (0u64, 0u64, 0u64, 0u64);
        for j in 0..ny {
            for i in 0..nx {
                let c0 = spec.center(i, j, 0);
                let keep_below = highest_within(&hf, c0.x, c0.y, radial - v).map(|h| h + axial - v);
                let cut_above = highest_within(&hf, c0.x, c0.y, radial + v).map_or(v, |h| h + axial + v);
                for k in 0..nz {
                    if target.get(i, j, k) {
                        continue;
                    }
                    let z = spec.center(i, j, k).z;
                    if keep_below.is_some_and(|top| z < top) {
                        skin += 1;
                        skin_kept += u64::from(residual.get(i, j, k));
                    } else if z > cut_above {
                        beyond += 1;
                        beyond_left += u64::from(residual.get(i, j, k));
                    }
                }
            }
        }
        (skin_kept, skin, beyond_left, beyond)
    };
    let (kept, skin, left, beyond) = run(true);
    assert!(skin > 1000, "the skin has {skin} voxels: the test would not see it");
    assert_eq!(kept, skin, "with the allowance: {} of {skin} skin voxels cut away", skin - kept);
    assert!(
        (left as f64) <= 0.005 * beyond as f64,
        "with the allowance: {left} of {beyond} voxels beyond the skin left standing"
    );
    let (kept0, skin0, _, _) = run(false);
    assert!(
        (kept0 as f64) < 0.5 * skin0 as f64,
        "without the allowance {kept0} of {skin0} skin voxels stand: the check cannot tell"
    );
}

/// Arc fitting changes what is cut by less than 0.1 % of the removed voxels. A turned part
/// in mm (the shop corpus's stepped boss) is planned with an arc tolerance (the walls keep
/// it as allowance), written with straight moves (`fit_arcs` false) and with the
/// planner's arcs, and both texts are parsed back and simulated from the same stock: at
/// 0.005 mm (the default) and at 0.02 mm. Neither gouges nor rapids through
/// material.
#[test]
fn arc_fitted_program_cuts_what_the_straight_one_cuts() {
    let p = format!("{}/../../tests/data/meshes/shop/stepped_boss.stl", env!("CARGO_MANIFEST_DIR"));
    let part = s2g_geom::load_mesh(&p).unwrap_or_else(|e| panic!("{p}: {e}"));
    let stock = part.bbox().expect("bbox").inflated(2.0);
    let spec = grid_over(&stock, 0.5);
    let target = voxelize(&part, &spec).expect("voxelize");
    let tool = Tool::flat(3.0);
    let mut fewer = Vec::new();
    for tol in [0.005, 0.02] {
        let write = |fit_arcs: bool| {
            let opts = PlanOptions {
                layer_height: 2.0,
                strategy: strategies().get("spiral").expect("spiral"),
                stock: Some(stock),
                arc_tolerance: Some(tol),
                fit_arcs,
                ..Default::default()
            };
            let mut w = GcodeWriter::new(Vec::new(), Dialect::LinuxCnc, WriterOptions::default());
            plan_setup(&part, &Setup::top(), &tool, &opts, &mut w).expect("plan");
            w.finish().expect("writes");
            String::from_utf8(w.into_inner()).expect("utf-8")
        };
        let straight = write(false);
        let fitted = write(true);
        let cut = |text: &str| {
            // The simulator follows arcs as closely as the pipeline's does.
            let sim_opts = SimOptions { arc_tolerance: 1.0 / 1024.0, ..SimOptions::default() };
            let table = ToolTable::single(Cutter::flat(3.0, 100.0));
            let mut sim = Simulator::new(VoxelGrid::full(spec), table, sim_opts)
                .expect("simulator")
                .with_target(&target)
                .expect("same grid");
            parse_str(text, &ParseOptions::default(), &mut sim).expect("parses");
            sim.into_simulation().expect("simulation").into_parts()
        };
        let (lines, lines_fitted) = (straight.lines().count(), fitted.lines().count());
        let arcs_in =
            |text: &str| text.lines().filter(|l| l.starts_with("G2") || l.starts_with("G3")).count();
        // The planner's helical ramps are arcs in both.
        let arcs = arcs_in(&fitted) - arcs_in(&straight);
        let (r0, mut g0) = cut(&straight);
        let (r1, g1) = cut(&fitted);
        assert_eq!((r0.gouge_voxels, r1.gouge_voxels), (0, 0), "{tol} mm: gouges");
        assert_eq!(r1.rapid_collision_voxels, 0, "{tol} mm: rapids through material with arcs");
        g0.xor(&g1).expect("same grid");
        let diff = g0.count();
        let name = format!("{tol} mm: {arcs} arcs fitted, {lines_fitted} lines against {lines}");
        println!("stepped boss, {name}, {diff} voxels differ of {} removed", r0.removed_voxels);
        assert!(diff as f64 <= 1e-3 * r0.removed_voxels as f64, "{name}: {diff} voxels differ");
        fewer.push((arcs, lines - lines_fitted));
    }
    // The comparison means something only where arcs were fitted.
    let (arcs, saved) = fewer[1];
    assert!(arcs >= 20 && saved >= arcs, "0.02 mm: {arcs} arcs save {saved} lines");
}

/// The shop's entries and crossings ([`PlanOptions::lead_in`]): on the bunny and
/// example001 with roughing groups, against the paper's entries the finer levels go down
/// beside their roughing level's cut instead of ramping, clearing passes start where they
/// reach air, and the tool crosses between paths just above a level cut before; the part
/// comes out the same (within 0.2 % of the removed voxels), with no gouge and no rapid
/// through material, in less time.
#[test]
fn side_entries_and_low_crossings_cut_the_same_part_faster_and_safely() {
    for (name, part) in bunny_and_example001() {
        let Stocked { e, stock, spec, target } = stocked(&part);
        let tool = Tool::flat(0.03 * e);
        let base = PlanOptions {
            layer_height: e / 48.0,
            stock: Some(stock),
            roughing_depth: Some(tool.diameter()),
            ..Default::default()
        };
        let run = |opts: &PlanOptions| {
            simulate(VoxelGrid::full(spec), &target, &tool, |sim| {
                plan_setup(&part, &Setup::top(), &tool, opts, sim).expect("plan")
            })
        };
        let (paper, paper_report, paper_residual) = run(&base);
        let (shop, report, residual) = run(&PlanOptions { lead_in: true, ..base.clone() });
        assert_eq!(report.gouge_voxels, 0, "{name}: gouges, first at line {:?}", report.first_gouge_line);
        assert_eq!(report.rapid_collision_voxels, 0, "{name}: rapids through material");
        let mut differ = residual.clone();
        differ.xor(&paper_residual).expect("same grid");
        let differ = differ.count();
        println!(
            "{name}: {} side entries, {} low crossings, ramps and helices {} (paper {}), retracts {} (paper {}), \
             time {:.1} (paper {:.1}), {differ} voxels differ",
            shop.lead_in_entries,
            shop.low_retracts,
            shop.ramp_entries + shop.helix_entries,
            paper.ramp_entries + paper.helix_entries,
            shop.retracts,
            paper.retracts,
            shop.estimated_time_s,
            paper.estimated_time_s
        );
        assert!(
            (differ as f64) <= 0.002 * paper_report.removed_voxels as f64,
            "{name}: {differ} voxels differ"
        );
        assert!(shop.lead_in_entries > 0 && shop.low_retracts > 0, "{name}: {shop:?}");
        assert!(shop.ramp_entries + shop.helix_entries < paper.ramp_entries + paper.helix_entries, "{name}");
        assert!(shop.estimated_time_s < paper.estimated_time_s, "{name}");
        assert_eq!(
            (paper.lead_in_entries, paper.low_retracts),
            (0, 0),
            "{name}: the paper's entries changed"
        );
    }
}
