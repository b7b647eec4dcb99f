//! Finishing planned ahead (`finish_paths`, on a thread and rayon pool of its own, as the
//! pipeline plans a setup's finishing beside its roughing) and written later
//! (`finish_setup_paths`) is the finishing planned and written in one go
//! (`finish_setup_left_out`): the same motions in the same order, the same summary and the
//! same points left out, whatever the pool's size. On a boss on a plate (its shank check
//! leaves points out), crossed passes with their fill passes, a filter on the points.

mod common;

use common::sphere;
use rayon::prelude::*;
use s2g_gcode::MotionRecorder;
use s2g_geom::{Aabb, Holder, Mesh, MeshIndex, Point3, Setup, Similarity3, Vector3};
use s2g_toolpath::finish::{
    Crossed, FinishError, FinishOptions, FinishingStrategy, KeepPoint, finish_paths, finish_setup_left_out,
    finish_setup_paths,
};
use s2g_toolpath::{Tool, ToolpathError};
use s2g_voxsim::Cutter;

/// A 60 x 60 x 10 plate with a 24 x 24 boss from 10 to 50 on it, a wavy dome on the boss.
fn part() -> Mesh {
    let mut m =
        Mesh::cuboid(&Aabb::new(Point3::new(-30.0, -30.0, 0.0), Point3::new(30.0, 30.0, 10.0))).unwrap();
    m.append(
        &Mesh::cuboid(&Aabb::new(Point3::new(-12.0, -12.0, 10.0), Point3::new(12.0, 12.0, 50.0))).unwrap(),
    );
    m.append(&sphere(9.0, 24, 12).transformed(&Similarity3::new(
        Vector3::new(0.0, 0.0, 50.0),
        Vector3::zeros(),
        1.0,
    )));
    m
}

#[test]
fn finishing_planned_ahead_on_its_own_pool_writes_the_motions_of_finishing_in_one_go() {
    let index = MeshIndex::new(&part()).unwrap();
    let mut cutter = Cutter::ball(5.0, 30.0);
    cutter.stickout = 56.0;
    cutter.holder = Some(Holder { radius: 17.5, length: 40.0 });
    let ball = Tool { number: 17, ..Tool::new(cutter) };
    let opts = FinishOptions {
        scallop: 0.05,
        floor: Some(0.0),
        clearance: 6.0,
        approach: 6.0,
        stock_left: Some(3.0),
        arc_tolerance: Some(0.005),
        holder_stock: Some(common::boss_roughed()),
        ..FinishOptions::default()
    };
    let strategy = Crossed::default();
    // A rest-finishing-like filter: the half x < 8 only.
    let keep = |p: &Point3| p.x < 8.0;
    let keep = Some(&keep as &dyn KeepPoint);
    let mut whole = MotionRecorder::default();
    let (sum, left) =
        finish_setup_left_out(&index, &Setup::top(), &ball, &strategy, &opts, keep, &mut whole).unwrap();
    assert!(sum.passes > 20 && left.points > 0, "{sum:?}, {} left out", left.points);
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        // Planned on another thread while this one keeps the global pool busy.
        let planned = std::thread::scope(|s| {
            let ahead =
                s.spawn(|| pool.install(|| finish_paths(&index, &ball, &strategy, &opts, keep, None)));
            let busy: f64 = (0..200_000u32).into_par_iter().map(|k| f64::from(k).sqrt()).sum();
            assert!(busy > 0.0);
            ahead.join().unwrap().unwrap()
        });
        assert_eq!(planned.left_out, left);
        let mut later = MotionRecorder::default();
        let (sum2, left2) =
            finish_setup_paths(&index, &Setup::top(), &ball, strategy.name(), &opts, planned, &mut later)
                .unwrap();
        assert_eq!(sum2, sum, "{threads} threads");
        assert_eq!(left2, left);
        assert_eq!(later.motions.len(), whole.motions.len(), "{threads} threads");
        assert!(later.motions == whole.motions, "{threads} threads: the motions differ");
    }
    // Stopped (the pipeline's verdict called the finishing off), the planning fails as
    // cancelled instead of running on.
    let stop = std::sync::atomic::AtomicBool::new(true);
    match finish_paths(&index, &ball, &strategy, &opts, keep, Some(&stop)) {
        Err(ToolpathError::Cancelled | ToolpathError::Finish(FinishError::Cancelled)) => {}
        other => panic!("expected a cancelled planning, got {:?}", other.map(|p| p.paths.len())),
    }
}
