//! Arc fitting ([`MillOptions::arc_tolerance`]) on the bundled bunny at 100 mm in the shop
//! preset: the programs with arcs against the same plan written straight
//! ([`MillOptions::fit_arcs`] false), simulated from the same stock on the same grid.

use shape2gcode::geom::{Mesh, VoxelGrid, load_mesh};
use shape2gcode::{FinishChoice, HeuristicPolicy, MillOptions, MillRun, Milled, Policy, Preset};

use super::common::data;

/// One run: its programs' lines and motion blocks in G2/G3 mode, its result and the
/// simulated stock.
struct Run {
    lines: u64,
    arcs: usize,
    milled: Milled,
    residual: VoxelGrid,
}

/// Blocks that move in G2/G3 mode (the mode is modal: a block without a G word keeps it).
fn arc_blocks(text: &str) -> usize {
    let mut mode = 0;
    let mut n = 0;
    for line in text.lines() {
        let code = line.split('(').next().unwrap_or("");
        for word in code.split_whitespace() {
            if let Some(g) = word.strip_prefix('G').and_then(|g| g.parse::<u32>().ok())
                && g <= 3
            {
                mode = g;
            }
        }
        let moves = code.split_whitespace().any(|w| w.starts_with(['X', 'Y', 'Z']));
        n += usize::from(moves && (mode == 2 || mode == 3));
    }
    n
}

/// Mills `mesh` with the heuristic policy, as [`shape2gcode::mill`] does, keeping the
/// simulated stock.
fn run(mesh: &Mesh, opts: &MillOptions) -> Run {
    let mut policy = HeuristicPolicy::default();
    let mut run = MillRun::new(mesh, opts, &mut |_| {}).expect("run");
    while run.next_setup().is_some() {
        let features = run.features();
        let ctx = run.context(&features);
        let action = policy.choose(&ctx);
        let finish = opts.finish.map(|d| policy.finish(&ctx, d));
        run.machine_finished(action, finish, &mut |_| {}).expect("setup");
    }
    let residual = run.residual_grid();
    let milled = run.finish(&policy.name(), &mut |_| {}).expect("finish");
    let lines = milled.setups.iter().map(|s| s.lines).sum();
    let arcs = milled.setups.iter().map(|s| arc_blocks(&s.text)).sum();
    Run { lines, arcs, milled, residual }
}

/// The bunny at 100 mm in the shop preset (default library, aluminium, 256^3), finished
/// or not.
fn bunny_options(finish: bool) -> (Mesh, MillOptions) {
    let path = data("meshes/classic/stanford_bunny.stl");
    let mesh = load_mesh(&path).expect("bunny");
    let (lo, hi) = mesh.bbox().map(|b| (b.min, b.max)).expect("bbox");
    let longest = (hi - lo).max();
    let opts = MillOptions {
        preset: Preset::Shop,
        input_scale: 100.0 / longest,
        // Finished as `s2g mill --preset shop` finishes by default.
        finish: finish.then(FinishChoice::default),
        ..MillOptions::default()
    };
    (mesh, opts)
}

/// Compares the bunny's programs with arcs at `tol` against the same plan written straight
/// (and, with `plain`, against the programs without an arc tolerance): prints a row,
/// checks safety and the simulated difference, and returns the lines straight and with
/// arcs.
fn compare(finish: bool, tol: f64, plain: bool) -> (u64, u64) {
    let (mesh, opts) = bunny_options(finish);
    let straight = run(&mesh, &MillOptions { arc_tolerance: Some(tol), fit_arcs: false, ..opts.clone() });
    let fitted = run(&mesh, &MillOptions { arc_tolerance: Some(tol), ..opts.clone() });
    let plain = plain.then(|| run(&mesh, &opts));
    for (name, r) in [("straight", Some(&straight)), ("fitted", Some(&fitted)), ("plain", plain.as_ref())] {
        let Some(r) = r else { continue };
        assert_eq!(r.milled.simulation.gouge_voxels, 0, "{name}: gouges");
        assert_eq!(r.milled.rapid_collisions(), 0, "{name}: rapids through material");
        assert!(r.milled.simulation.holder_collisions.is_empty(), "{name}: holder collisions");
    }
    let mut diff = straight.residual.clone();
    diff.xor(&fitted.residual).expect("same grid");
    let differ = diff.count();
    let removed = straight.milled.simulation.removed_voxels;
    println!(
        "bunny 100 mm, shop, {}, {tol} mm: {} lines without arcs (IoU {}), {} straight (IoU {:.5}), \
         {} with {} arc blocks (IoU {:.5}): {:.1} % fewer; {differ} of {removed} removed voxels \
         differ ({:.4} %)",
        if finish { "finished" } else { "roughing only" },
        plain.as_ref().map_or("-".into(), |p| p.lines.to_string()),
        plain.as_ref().map_or("-".into(), |p| format!("{:.5}", p.milled.metrics.iou)),
        straight.lines,
        straight.milled.metrics.iou,
        fitted.lines,
        fitted.arcs,
        fitted.milled.metrics.iou,
        100.0 * (1.0 - fitted.lines as f64 / straight.lines as f64),
        100.0 * differ as f64 / removed as f64,
    );
    assert!((differ as f64) < 1e-3 * removed as f64, "{tol} mm: {differ} of {removed} removed voxels differ");
    (straight.lines, fitted.lines)
}

/// Issue 35's acceptance on the bundled bunny at 100 mm as `s2g mill --preset shop --size
/// 100` mills it (finished): arcs at the 0.005 mm take at least 40 % of the lines
/// of the same plan written straight away, with no gouge, rapid or holder collision, and
/// what the fitted programs cut differs from what the straight ones cut by less than
/// 0.1 % of the removed voxels (about 80 s).
#[test]
fn arcs_take_forty_percent_of_the_bunnys_lines_and_cut_the_same() {
    let (straight, fitted) = compare(true, 0.005, false);
    assert!(fitted as f64 <= 0.6 * straight as f64, "{fitted} lines with arcs, {straight} straight");
}

/// The bunny's roughing alone (`--no-finish`): at least 10 % fewer lines at 0.005 mm, the
/// same cut (about 30 s).
#[test]
fn arcs_shorten_the_bunnys_roughing_and_cut_the_same() {
    let (straight, fitted) = compare(false, 0.005, false);
    assert!(fitted as f64 <= 0.9 * straight as f64, "{fitted} lines with arcs, {straight} straight");
}
