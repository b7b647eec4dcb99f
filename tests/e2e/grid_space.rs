//! The paper's action space as its 256³ grid sees it, on a coarser grid
//! (`MillOptions::paper_space_scale`, `--space grid`; issue 37, "an environment where
//! actions matter"): on a 64³ grid the paper's own tools are 0.06-0.64 voxel and every
//! choice of tool mills the same voxels, while the scaled space's are 0.26-2.56 voxels and
//! fixed fine and fixed coarse part.

use s2g_gen::{GenOptions, Kind, generate};
use shape2gcode::{
    ActionSpace, EvalOptions, FixedPolicy, MillError, MillOptions, SetupCount, evaluate_part, mill,
};

/// The space at 64³: the paper's lengths times 4, so its radii are 0.256-2.56 voxels and
/// its layers 0.5-4; at 256³ it is the paper's own.
#[test]
fn the_grid_space_resolves_the_paper_s_tools() {
    let space = ActionSpace::paper_at_resolution(64);
    let paper = ActionSpace::paper();
    assert_eq!(ActionSpace::paper_at_resolution(256), paper);
    let voxels = |v: &[f64]| v.iter().map(|x| x * 64.0).collect::<Vec<f64>>();
    let r = voxels(&space.radii);
    assert!((r[0] - 0.256).abs() < 1e-12 && (r[3] - 2.56).abs() < 1e-12, "{r:?}");
    let h = voxels(&space.layer_heights);
    assert!((h[0] - 0.5).abs() < 1e-12 && (h[3] - 4.0).abs() < 1e-12, "{h:?}");
    assert!(voxels(&paper.radii).iter().all(|&r| r < 1.0), "no tool of the paper's is a voxel");
    assert!(r[3] - r[0] > 2.0, "the extremes differ by more than two voxels of radius: {r:?}");
    let opts = MillOptions { paper_space_scale: 4.0, ..MillOptions::default() };
    assert_eq!(opts.action_space(), space.scaled(opts.paper_scale_mm));
}

/// A generated prismatic part (pockets, holes, slots) at 48³, three setups: in the grid
/// space fixed fine mills it markedly closer than fixed coarse, and in the paper's space
/// the two are much closer.
#[test]
fn fixed_fine_and_fixed_coarse_part_in_the_grid_space() {
    let part = generate(38, 0, &GenOptions { kind: Kind::Prismatic, size: 100.0 }).unwrap();
    let gap = |scale: f64| {
        let opts = MillOptions {
            resolution: 48,
            paper_space_scale: scale,
            orient_points: 1024,
            orient_candidates: 64,
            metric_samples: 2000,
            setups: SetupCount::Exactly(3),
            flank_walls: false,
            ..MillOptions::default()
        };
        let policies = vec!["fixed-fine".to_string(), "fixed-coarse".to_string()];
        let r =
            evaluate_part(&part.name, &part.mesh, &policies, &EvalOptions::default(), &opts, &mut |_, _| {})
                .unwrap();
        let iou = |name: &str| r.runs.iter().find(|(k, _)| k.policy == name).unwrap().1.iou;
        let time = |name: &str| r.runs.iter().find(|(k, _)| k.policy == name).unwrap().1.machining_time_s;
        assert!(time("fixed-fine") > time("fixed-coarse"), "the fine tool takes longer");
        iou("fixed-fine") - iou("fixed-coarse")
    };
    let grid = gap(ActionSpace::paper_space_scale(48));
    let paper = gap(1.0);
    assert!(grid > 0.04, "fine - coarse in the grid space: {grid}");
    assert!(grid > paper + 0.03, "grid space {grid} against the paper's {paper}");
}

/// A scale that is not positive and finite is a typed error, not a panic.
#[test]
fn a_bad_space_scale_is_an_error() {
    let part = generate(38, 0, &GenOptions { kind: Kind::Prismatic, size: 100.0 }).unwrap();
    for scale in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let opts = MillOptions {
            resolution: 16,
            orient_points: 256,
            paper_space_scale: scale,
            ..MillOptions::default()
        };
        let action = shape2gcode::Action {
            tool_radius: 1.0,
            layer_height: 1.0,
            strategy: shape2gcode::StrategyKind::ZIGZAG,
        };
        let err = mill(&part.mesh, &mut FixedPolicy(action), &opts, &mut |_| {}).unwrap_err();
        assert!(matches!(err, MillError::InvalidOption(ref m) if m.contains("paper_space_scale")), "{err}");
    }
}
