//! Roughing, then finishing with a ball end mill (issue 36): on a small shop part,
//! finishing brings the residual nearer the part (Chamfer down, normal consistency up)
//! than the same roughing alone, gouges nothing, and reports its tools, scallop, times
//! (roughing + finishing = the setup's machine time) and surface deviation. A setup
//! whose faces are all prismatic (flat floors, walls along the tool) is not finished:
//! its roughing cuts them to size.

use shape2gcode::geom::load_mesh;
use shape2gcode::{
    Action, FinishChoice, FixedPolicy, HeuristicPolicy, MillOptions, MillRun, Milled, Preset, SetupFinish,
    StrategyKind, mill,
};

use super::common::{assert_same_programs, data};

fn boss(finish: Option<FinishChoice>) -> Milled {
    shop_part("stepped_boss", finish)
}

/// The shop preset at `resolution`, scored at 100,000 samples (at 4,000 the Chamfer distance
/// moves by more between seeds than finishing moves it), each setup's own program roughed
/// and finished: no rest-roughing programs (with them the finishing moves into a setup's
/// last rest program; `stock.rs` tests them).
fn shop_options(resolution: usize, finish: Option<FinishChoice>) -> MillOptions {
    MillOptions {
        preset: Preset::Shop,
        resolution,
        orient_points: 2048,
        metric_samples: 100_000,
        finish,
        surface_spacing: 0.25,
        rest_roughing: 0,
        ..MillOptions::default()
    }
}

fn shop_part(name: &str, finish: Option<FinishChoice>) -> Milled {
    let mesh = load_mesh(data(&format!("meshes/shop/{name}.stl"))).unwrap();
    // 80 x 80 x 45 mm. (At half the size, with a 6 mm rougher and ball, the parallel
    // finisher's raster leaves the allowance on the walls along it, and the residual's
    // Chamfer distance rises: 0.706 against 0.687 at 96^3.)
    let opts = shop_options(96, finish);
    let action = Action { tool_radius: 5.0, layer_height: 2.0, strategy: StrategyKind::ZIGZAG };
    mill(&mesh, &mut FixedPolicy(action), &opts, &mut |_| {}).unwrap()
}

#[test]
fn finishing_brings_the_part_nearer_than_roughing_alone_and_reports_itself() {
    let choice = FinishChoice { scallop: 0.02, ..FinishChoice::default() };
    let rough = boss(None);
    let fine = boss(Some(choice));
    let (r, f) = (&rough.metrics, &fine.metrics);
    assert!(
        rough.is_safe() && fine.is_safe(),
        "gouges or rapids: rough {:?}, finish {:?}",
        rough.simulation.gouge_voxels,
        fine.simulation.gouge_voxels
    );
    assert_eq!(fine.simulation.gouge_voxels, 0);
    assert!(
        f.chamfer_x1000 < r.chamfer_x1000,
        "Chamfer x1000: finished {} >= rough {}",
        f.chamfer_x1000,
        r.chamfer_x1000
    );
    assert!(
        f.normal_consistency > r.normal_consistency,
        "NC: finished {} <= rough {}",
        f.normal_consistency,
        r.normal_consistency
    );
    assert!(rough.setups.iter().all(|s| s.finish.is_none()));
    let report = fine.report_json(false);
    // The boss's chamfer and the bore's countersink face the top setup; the bottom and the
    // bore's wall, seen from below, are prismatic.
    assert!(fine.setups.iter().any(|s| s.finish.is_some()), "no setup finished");
    for (i, s) in fine.setups.iter().enumerate() {
        let up = s.setup.tool_axis().z > 0.9;
        assert_eq!(s.finish.is_some(), up, "setup {} (axis {:?})", i + 1, s.setup.tool_axis());
        let Some(fin) = s.finish.as_ref() else { continue };
        // The rule: the largest ball no wider than the 10 mm roughing tool that reaches.
        assert!(matches!(fin.tool.cutter.shape, shape2gcode::geom::CutterShape::Ball(_)));
        assert!(fin.tool.radius() <= s.tool.radius(), "setup {}: finisher wider than the rougher", i + 1);
        assert!(!fin.gouged(), "setup {}: gouge {} mm", i + 1, fin.deviation.gouge_depth);
        assert!(fin.deviation.gouge_depth <= SetupFinish::GOUGE_TOLERANCE);
        assert!(fin.summary.passes > 0 && fin.deviation.columns > 0, "setup {}: {:?}", i + 1, fin.summary);
        let total = s.machine_time_s.expect("the shop's machine times the program");
        assert!(fin.roughing_time_s > 0.0 && fin.finishing_time_s > 0.0, "setup {}: {fin:?}", i + 1);
        assert!(
            (fin.roughing_time_s + fin.finishing_time_s - total).abs() <= 1e-6 * total,
            "setup {}: {} + {} != {total}",
            i + 1,
            fin.roughing_time_s,
            fin.finishing_time_s
        );
        // The program changes to the finishing tool after the roughing.
        let (rt, ft) = (format!("T{} M6", s.tool.number), format!("T{} M6", fin.tool.number));
        let (a, b) = (s.text.find(&rt), s.text.find(&ft));
        assert!(a.is_some() && b.is_some() && a < b, "setup {}: no {rt} then {ft}", i + 1);
        let js = &report["setups"][i];
        for key in ["roughing_time_s", "finishing_time_s", "tools", "scallop_mm", "surface_deviation"] {
            assert!(!js[key].is_null(), "setup {}: no {key} in the report", i + 1);
        }
        assert_eq!(js["scallop_mm"], 0.02);
        // The columns no pass went over are reported apart, their area by the spacing.
        let sd = &js["surface_deviation"];
        assert_eq!(sd["unpassed_columns"], fin.deviation.unpassed);
        let area = sd["unpassed_area_mm2"].as_f64().expect("unpassed_area_mm2");
        assert!((area - fin.deviation.unpassed as f64 * 0.25 * 0.25).abs() < 1e-6, "setup {}: {sd}", i + 1);
        assert_eq!(js["tools"], serde_json::json!([s.tool.number, fin.tool.number]));
    }
}

#[test]
fn a_prismatic_part_is_roughed_to_size_and_not_finished() {
    // The L-bracket's faces are flat floors and walls along the tool in every setup: the
    // finished run's programs are the roughing-only run's, setups, tools and levels alike.
    let rough = shop_part("l_bracket", None);
    let fine = shop_part("l_bracket", Some(FinishChoice::default()));
    assert!(fine.setups.iter().all(|s| s.finish.is_none()), "a setup of the bracket was finished");
    assert_same_programs(&fine.programs, &rough.programs);
    assert_eq!(fine.metrics.iou, rough.metrics.iou);
    assert_eq!(fine.metrics.chamfer_x1000, rough.metrics.chamfer_x1000);
}

/// A 40 x 20 x 12 mm block whose top +x edge is cut back 6 mm (a sloped face from x = 34
/// at the top to x = 40 at the bottom): every setup's faces are mostly prismatic.
fn chamfered_block() -> shape2gcode::geom::Mesh {
    use shape2gcode::geom::{Aabb, Mesh, Point3};
    let b = Mesh::cuboid(&Aabb::new(Point3::origin(), Point3::new(40.0, 20.0, 12.0))).unwrap();
    let (mut v, t) = b.into_parts();
    v.iter_mut().filter(|p| p.x == 40.0 && p.z == 12.0).for_each(|p| p.x = 34.0);
    Mesh::new(v, t).unwrap()
}

#[test]
fn a_mostly_prismatic_setup_is_roughed_as_without_finishing() {
    // Where at most half a setup's faces are sculpted the ball finishes only those, and
    // where it does not reach the roughing's steps stay: the roughing must be the
    // roughing-only run's (same layers), not deeper layers left for a ball.
    let part = chamfered_block();
    let run = |finish| {
        mill(&part, &mut HeuristicPolicy::default(), &shop_options(64, finish), &mut |_| {}).unwrap()
    };
    let rough = run(None);
    let fine = run(Some(FinishChoice::default()));
    assert!(rough.is_safe() && fine.is_safe());
    assert_eq!(fine.setups.len(), rough.setups.len());
    assert!(fine.setups.iter().any(|s| s.finish.is_some()), "the chamfer was not finished");
    for (i, (f, r)) in fine.setups.iter().zip(&rough.setups).enumerate() {
        assert_eq!(f.action, r.action, "setup {}: the finished run roughs otherwise", i + 1);
    }
    // The ball only takes material away: less stock, nearer the part on both measures.
    let volume = |m: &Milled| m.residual.signed_volume();
    assert!(
        volume(&fine) < volume(&rough),
        "finishing left more stock: {} >= {}",
        volume(&fine),
        volume(&rough)
    );
    let (r, f) = (&rough.metrics, &fine.metrics);
    assert!(f.chamfer_x1000 < r.chamfer_x1000, "Chamfer x1000: {} >= {}", f.chamfer_x1000, r.chamfer_x1000);
    assert!(
        f.normal_consistency > r.normal_consistency,
        "NC: {} <= {}",
        f.normal_consistency,
        r.normal_consistency
    );
}

/// The setups of a finishing run on a part less prismatic than `PRISMATIC_PART` (0.75):
/// orientation selection plans them for the roughing's reach and for the shorter ball's,
/// and the run takes the set that leaves less unreached, ties to the roughing's. On
/// example004 (a cube less a sphere) judged by the longest end mill's reach
/// (`tool_aware_reach: false`) the ball's set leaves less stock and is taken; with the
/// tool-aware reach (`true`) the roughing's set leaves less and is; on example006 the
/// two leave the same, and the finished run machines the roughing-only run's setups.
#[test]
fn a_finishing_run_takes_the_setups_that_leave_less_unreached() {
    let run = |name: &str, tool_aware_reach: bool, finish: Option<FinishChoice>| {
        let mesh = load_mesh(data(&format!("meshes/openscad/{name}.stl"))).unwrap();
        let longest = mesh.bbox().unwrap().extent().max();
        // As `s2g mill MESH --preset shop --size 100 --res 128 --finish`.
        let opts = MillOptions {
            preset: Preset::Shop,
            resolution: 128,
            input_scale: 100.0 / longest,
            finish,
            tool_aware_reach,
            ..MillOptions::default()
        };
        MillRun::new(&mesh, &opts, &mut |_| {}).unwrap()
    };
    let same_set = |a: &[_], b: &[_]| a.len() == b.len() && a.iter().all(|d| b.contains(d));
    for (name, tool_aware_reach, ball) in [
        ("openscad_Old_example004", false, true),
        ("openscad_Old_example004", true, false),
        ("openscad_Old_example006", true, false),
    ] {
        let rough = run(name, tool_aware_reach, None);
        let fine = run(name, tool_aware_reach, Some(FinishChoice::default()));
        assert_eq!(rough.setup_choice(), None, "{name}: a roughing-only run plans one set");
        let choice = fine.setup_choice().unwrap_or_else(|| panic!("{name}: two sets planned"));
        let left = |u: &shape2gcode::orient::Unreached| u.stock_fraction() + u.surface_fraction();
        assert_eq!(choice.took_ball, ball, "{name}: {choice:?}");
        assert_eq!(choice.took_ball, left(&choice.ball) < left(&choice.rough), "{name}: {choice:?}");
        let (r, f) = (&rough.orientation().directions, &fine.orientation().directions);
        assert_eq!(same_set(r, f), !ball, "{name}: roughing-only {r:?}, finished {f:?}");
    }
}
