//! The paper's rewards (seed 000 Eqs. 10-13) against an independent computation on a
//! small simulated case: a flat-end slot in a block whose target either reaches into the
//! slot (gouged) or stays below it (preserved).
//!
//! Eq. 10: R_s = sum over target voxels of V_s / |V_t|; Eq. 11: R_f = IoU(V_n, V_t);
//! Eq. 12: R_MRR = removed voxels / t_cut; Eq. 13: R = l_s R_s + l_f R_f + l_MRR R_MRR,
//! with the paper's weights l_s = 1, l_f = 1, l_MRR = 0.1 (Appendix A.1).

use s2g_gcode::{Motion, MotionSink};
use s2g_geom::{Aabb, GridSpec, Point3, VoxelGrid};
use s2g_voxsim::{Cutter, RewardWeights, SimError, SimOptions, Simulation, Simulator, ToolTable, rewards};

const FEED: f64 = 600.0; // mm/min
const RAPID: f64 = 5000.0; // mm/min (the default rapid rate)
const R: f64 = 3.0; // tool radius
const SLOT: (f64, f64) = (8.0, 30.0); // slot from x=8 to x=30 at y=10
const FLOOR: f64 = 6.0; // slot floor; the stock top is z=10

fn p(x: f64, y: f64, z: f64) -> Point3 {
    Point3::new(x, y, z)
}

/// Stock [0,40]x[0,20]x[0,10] on 1 mm voxels: centres sit on half-millimetres, so no
/// centre lies on the slot's boundary (distance 3 from the axis, or z = 6).
fn spec() -> GridSpec {
    GridSpec::cubic(&Aabb::new(p(0., 0., 0.), p(40., 20., 10.)), 40).unwrap()
}

/// The target part: every voxel whose centre is below `top`.
fn target_below(top: f64) -> VoxelGrid {
    let mut t = VoxelGrid::new(spec());
    t.set_where(|c| c.z < top);
    t
}

/// Plunge at the slot's start to the floor, feed to its end, rapid out. The tool starts
/// at (8, 10, 15), so every move is timed: feed 9 + 22 mm at 600 mm/min, rapid 9 mm.
fn slot(target: Option<&VoxelGrid>) -> Simulation {
    let opts = SimOptions { start: Some(p(SLOT.0, 10., 15.)), ..SimOptions::default() };
    let mut sim =
        Simulator::new(VoxelGrid::full(spec()), ToolTable::single(Cutter::flat(R, 4.0 * R)), opts).unwrap();
    if let Some(t) = target {
        sim = sim.with_target(t).unwrap();
    }
    let moves = [
        Motion::Linear { to: p(SLOT.0, 10., FLOOR), feed: FEED, extrude: None },
        Motion::Linear { to: p(SLOT.1, 10., FLOOR), feed: FEED, extrude: None },
        Motion::Rapid { to: p(SLOT.1, 10., 15.) },
    ];
    for (i, m) in moves.iter().enumerate() {
        sim.source_line(i as u64 + 1).unwrap();
        sim.motion(m).unwrap();
    }
    sim.finish().unwrap();
    sim.into_simulation().unwrap()
}

/// Whether a voxel centre lies in the slot's swept volume (a stadium prism above the floor).
fn in_slot(c: &Point3) -> bool {
    let x = c.x.clamp(SLOT.0, SLOT.1);
    let d2 = (c.x - x).powi(2) + (c.y - 10.0).powi(2);
    d2 <= R * R && c.z > FLOOR
}

/// Independent Eqs. 10-12 by counting voxels one by one.
fn by_hand(residual: &VoxelGrid, target: &VoxelGrid, t_cut: f64) -> (f64, f64, f64) {
    let [nx, ny, nz] = residual.dims();
    let (mut t, mut kept, mut union, mut removed) = (0u64, 0u64, 0u64, 0u64);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let (s, v) = (residual.get(i, j, k), target.get(i, j, k));
                t += v as u64;
                kept += (s && v) as u64;
                union += (s || v) as u64;
                removed += !s as u64; // the stock starts full (V_0 = 1)
            }
        }
    }
    (kept as f64 / t as f64, kept as f64 / union as f64, removed as f64 / t_cut)
}

fn close(what: &str, got: f64, want: f64) {
    assert!((got - want).abs() <= 1e-9 * want.abs().max(1.0), "{what}: got {got}, want {want}");
}

#[test]
fn default_weights_are_the_papers() {
    let w = RewardWeights::default();
    assert_eq!((w.lambda_s, w.lambda_f, w.lambda_mrr), (1.0, 1.0, 0.1));
}

#[test]
fn the_simulated_slot_is_the_stadium_prism_and_timed_as_written() {
    let sim = slot(None);
    let r = sim.residual();
    let [nx, ny, nz] = r.dims();
    let mut removed = 0u64;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let c = r.spec().center(i, j, k);
                assert_eq!(r.get(i, j, k), !in_slot(&c), "voxel {i},{j},{k} at {c}");
                removed += in_slot(&c) as u64;
            }
        }
    }
    assert!(removed > 0);
    assert_eq!(sim.report().removed_voxels, removed);
    let t = (9.0 + 22.0) / FEED * 60.0 + 9.0 / RAPID * 60.0;
    close("machining time", sim.report().machining_time_s, t);
}

#[test]
fn a_gouging_slot_loses_preservation_and_the_terms_match_a_hand_count() {
    // The target reaches z = 7: the slot's bottom voxel layer (centres at z = 6.5) is in it.
    let target = target_below(7.0);
    let sim = slot(Some(&target));
    let rep = sim.report();
    let (rs, rf, rmrr) = by_hand(sim.residual(), &target, rep.machining_time_s);
    assert!(rs < 1.0, "R_s = {rs}: the slot gouges");
    // The gouged voxels are exactly the slot voxels with centres below z = 7.
    let t = target.count();
    let kept = sim.residual().count_and(&target).unwrap();
    assert!(rep.gouge_voxels > 0);
    assert_eq!(rep.gouge_voxels, t - kept);
    assert_eq!(rep.gouge_voxels * 4, rep.removed_voxels, "one of the slot's four voxel layers");
    assert_eq!(rep.first_gouge_line, Some(1), "the plunge gouges first");

    let w = sim.rewards(&target, &RewardWeights::default()).unwrap();
    close("R_s", w.preservation, rs);
    close("R_f", w.final_iou, rf);
    close("R_MRR", w.mrr, rmrr);
    close("total", w.total, rs + rf + 0.1 * rmrr);
    // The free function gives the same numbers.
    let free = rewards(sim.residual(), &target, rep, &RewardWeights::default()).unwrap();
    assert_eq!(free, w);
    // Other weights combine the same terms.
    let ww = RewardWeights { lambda_s: 2.0, lambda_f: 0.5, lambda_mrr: 0.0 };
    let w2 = sim.rewards(&target, &ww).unwrap();
    close("weighted total", w2.total, 2.0 * rs + 0.5 * rf);
}

#[test]
fn a_slot_above_the_target_preserves_it_and_scores_higher() {
    let (low, high) = (target_below(5.0), target_below(7.0));
    let safe = slot(Some(&low));
    assert_eq!(safe.report().gouge_voxels, 0);
    assert_eq!(safe.report().first_gouge_line, None);
    let w = safe.rewards(&low, &RewardWeights::default()).unwrap();
    let (rs, rf, rmrr) = by_hand(safe.residual(), &low, safe.report().machining_time_s);
    assert_eq!(w.preservation, 1.0);
    close("R_s", rs, 1.0);
    close("R_f", w.final_iou, rf);
    // The residual contains the target: IoU is |target| / |residual|.
    close("R_f closed form", w.final_iou, low.count() as f64 / safe.residual().count() as f64);
    close("R_MRR", w.mrr, rmrr);
    close("total", w.total, 1.0 + rf + 0.1 * rmrr);
    // Same program, same removal rate; the gouging case preserves less.
    let gouge = slot(Some(&high));
    let wg = gouge.rewards(&high, &RewardWeights::default()).unwrap();
    assert_eq!(wg.mrr, w.mrr);
    assert!(wg.preservation < w.preservation);
}

#[test]
fn degenerate_cases() {
    // No moves: nothing removed, zero time, so R_MRR = 0; an empty target is preserved.
    let sim = Simulator::new(
        VoxelGrid::full(spec()),
        ToolTable::single(Cutter::flat(R, 4.0 * R)),
        SimOptions::default(),
    )
    .unwrap()
    .into_simulation()
    .unwrap();
    let empty = VoxelGrid::new(spec());
    let w = sim.rewards(&empty, &RewardWeights::default()).unwrap();
    assert_eq!(w.mrr, 0.0);
    assert_eq!(w.preservation, 1.0);
    assert_eq!(w.final_iou, 0.0, "full stock against an empty target");
    close("total", w.total, 1.0);
    // A target on another grid is an error, not a panic.
    let other = VoxelGrid::new(GridSpec::cubic(&Aabb::new(p(0., 0., 0.), p(40., 20., 10.)), 20).unwrap());
    assert!(matches!(sim.rewards(&other, &RewardWeights::default()), Err(SimError::GridMismatch)));
}
