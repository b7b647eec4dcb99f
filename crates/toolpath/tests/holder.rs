//! The finisher's shank and holder check (issue 35), simulated: a square boss taller than
//! the finishing ball's flutes on a plate, roughed with a 12 mm end mill leaving 0.3 mm,
//! then finished with a 10 mm ball whose shank is as wide as its flutes. Without the
//! check ([`FinishOptions::holder_stock`] `None`) the ball finishes the boss's foot and its
//! shank rubs the allowance left on the boss's wall above its flutes; with it the simulator
//! finds no shank or holder contact, the points it left out are counted, and the finished
//! surface's deviation reports the foot no pass went over apart from its max.

mod common;

use common::boss_roughed;
use s2g_gcode::{Motion, MotionRecorder, MotionSink};
use s2g_geom::{Aabb, GridSpec, Holder, Mesh, MeshIndex, Point3, Setup, VoxelGrid, voxelize};
use s2g_toolpath::finish::stepover_for_scallop;
use s2g_toolpath::finish::{
    FinishOptions, FinishSummary, LeftOut, Parallel, RoughedStock, finish_setup_left_out,
};
use s2g_toolpath::{PlanOptions, Tool, plan_setup};
use s2g_voxsim::{
    Cutter, DeviationOptions, HeightField, HeightFieldOptions, SimOptions, SimReport, Simulator,
    SurfaceDeviation, ToolTable, surface_deviation_opt,
};

/// A 60 x 60 x 10 plate with a 24 x 24 boss from 10 to 50 on it.
fn boss_on_plate() -> Mesh {
    let mut m =
        Mesh::cuboid(&Aabb::new(Point3::new(-30.0, -30.0, 0.0), Point3::new(30.0, 30.0, 10.0))).unwrap();
    m.append(
        &Mesh::cuboid(&Aabb::new(Point3::new(-12.0, -12.0, 10.0), Point3::new(12.0, 12.0, 50.0))).unwrap(),
    );
    m
}

/// A library-like tool: flutes, stick-out and a 35 mm holder.
fn tool(number: u32, mut cutter: Cutter, stickout: f64) -> Tool {
    cutter.stickout = stickout;
    cutter.holder = Some(Holder { radius: 17.5, length: 40.0 });
    Tool { number, ..Tool::new(cutter) }
}

/// Roughs the part, then finishes it with `holder_stock`; the simulator's report, the
/// finisher's summary and the finished surface's deviation (columns a pass went over and
/// the finisher did not leave out; with `mark_left_out` false, the left-out stretches
/// are not given to the measure).
fn mill(holder_stock: Option<RoughedStock>) -> (SimReport, FinishSummary, SurfaceDeviation) {
    mill_marked(holder_stock, true)
}

fn mill_marked(
    holder_stock: Option<RoughedStock>,
    mark_left_out: bool,
) -> (SimReport, FinishSummary, SurfaceDeviation) {
    let part = boss_on_plate();
    // Voxels of 0.5 mm whose centres lie 0.25 off the boss's walls, inside the allowance.
    let stock = Aabb::new(Point3::new(-31.0, -31.0, -1.0), Point3::new(31.0, 31.0, 51.0));
    let spec = GridSpec::new(&stock, [124, 124, 104]).unwrap();
    let target = voxelize(&part, &spec).unwrap();
    let rough = tool(9, Cutter::flat(6.0, 36.0), 66.0);
    let ball = tool(17, Cutter::ball(5.0, 30.0), 56.0);
    let popts = PlanOptions {
        layer_height: 2.0,
        finishing_allowance: 0.3,
        axial_allowance: 0.3,
        stock: Some(stock),
        ..PlanOptions::default()
    };
    let mut rec = MotionRecorder::default();
    plan_setup(&part, &Setup::top(), &rough, &popts, &mut rec).unwrap();
    let index = MeshIndex::new(&part).unwrap();
    let fopts = FinishOptions {
        scallop: 0.05,
        floor: Some(0.0),
        clearance: 6.0,
        approach: 6.0,
        stock_left: Some(3.0),
        holder_stock,
        ..FinishOptions::default()
    };
    let (summary, left_out): (FinishSummary, LeftOut) =
        finish_setup_left_out(&index, &Setup::top(), &ball, &Parallel::default(), &fopts, None, &mut rec)
            .unwrap();
    assert_eq!(left_out.points, summary.guarded_points);
    let tools = ToolTable::single(rough.cutter).with(9, rough.cutter).with(17, ball.cutter);
    let mut sim = Simulator::new(VoxelGrid::full(spec), tools, SimOptions::default())
        .unwrap()
        .with_target(&target)
        .unwrap();
    for (_, m) in &rec.motions {
        if !matches!(m, Motion::Setup { .. }) {
            sim.motion(m).unwrap();
        }
    }
    let (report, _) = sim.into_simulation().unwrap().into_parts();
    // The finishing moves (from its tool change on) in a height field that marks where
    // a pass went, three quarters of the stepover either side.
    let stepover = stepover_for_scallop(&ball.cutter, 0.05, 0.0).unwrap();
    let hopts = HeightFieldOptions {
        spacing: 0.25,
        pass_width: Some(0.75 * stepover),
        ..HeightFieldOptions::default()
    };
    let mut field =
        HeightField::new_opt([-36.0, -36.0], [36.0, 36.0], ToolTable::single(ball.cutter), &hopts).unwrap();
    if mark_left_out {
        field.leave_out(&left_out.stretches, 0.5 * stepover);
    }
    let start = rec.motions.iter().position(|(_, m)| matches!(m, Motion::ToolChange { tool: 17 })).unwrap();
    for (_, m) in &rec.motions[start..] {
        field.motion(m).unwrap();
    }
    let dopts = DeviationOptions { ball_radius: Some(5.0), floor: Some(0.0), ..DeviationOptions::default() };
    (report, summary, surface_deviation_opt(&field, &index, &dopts))
}

#[test]
fn the_finishers_shank_keeps_off_the_allowance_on_a_wall_taller_than_its_flutes() {
    let stock = boss_roughed();
    let (checked, summary, dev) = mill(Some(stock));
    assert_eq!(checked.gouge_voxels, 0);
    assert!(
        checked.holder_collisions.is_empty(),
        "holder collisions at lines {:?}",
        checked.holder_collisions
    );
    // The boss's foot, within the roughing tool's reach of its wall, is left out.
    assert!(summary.guarded_points > 0);
    let (unchecked, bare, bare_dev) = mill(None);
    assert_eq!(bare.guarded_points, 0);
    // The deviation leaves the foot no pass went over out of its max and reports it apart:
    // the roughing's 0.3 mm stays there, and every column the unchecked finish counts is
    // either passed or not with the check.
    assert_eq!(bare_dev.unpassed, 0, "{bare_dev:?}");
    assert!(dev.unpassed > 0 && dev.unpassed_max > 0.29, "{dev:?}");
    assert!(dev.max < 0.29, "{dev:?}");
    assert_eq!(dev.columns + dev.unpassed, bare_dev.columns, "{dev:?} {bare_dev:?}");
    assert!(
        !unchecked.holder_collisions.is_empty(),
        "the unchecked finish meets no stock: the test shows nothing"
    );
}

/// The columns beside the strip the shank check left out are the left-out passes' own
/// (nearer them than the kept pass beside the strip): the kept pass came within the
/// height field's pass width (three quarters of a stepover) of them, but its ball's
/// flank leaves there what the left-out pass would have cut, more than the scallop. Given
/// the left-out stretches, the measure reports them apart (not reached), and the max over
/// the rest keeps the scallop target plus 0.02 mm (on the bunny such columns gave setup
/// 1's 0.0391 mm maximum: the nearest pass point, 0.087 mm from the ball's tip, was one
/// the check had left out, the nearest kept one 0.43 mm).
#[test]
fn the_strip_the_shank_check_leaves_out_is_not_reached() {
    let stock = boss_roughed();
    let (_, _, marked) = mill_marked(Some(stock), true);
    let (_, _, unmarked) = mill_marked(Some(stock), false);
    println!("left-out stretches unmarked: {unmarked:?}\nmarked: {marked:?}");
    assert!(unmarked.max > 0.05 + 0.02, "{unmarked:?}");
    assert!(marked.max <= 0.05 + 0.02, "{marked:?}");
    // The same columns, some moved from the reached to the left out.
    assert_eq!(marked.columns + marked.unpassed, unmarked.columns + unmarked.unpassed);
    assert!(marked.unpassed > unmarked.unpassed, "{marked:?} {unmarked:?}");
}
