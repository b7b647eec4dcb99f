//! `shape2gcode::mill` on every closed mesh of the corpus: safe programs that LinuxCNC
//! accepts, the quality targets, independent re-scoring and determinism.

use shape2gcode::gcode::{ParseOptions, RotaryAxes, parse_str};
use shape2gcode::geom::{
    Aabb, GridSpec, Mesh, MetricOptions, Point3, Vector3, VoxelGrid, load_mesh, save_mesh,
    unit_cube_normalization, voxelize,
};
use shape2gcode::voxsim::{Cutter, SimOptions, Simulator, ToolTable};
use shape2gcode::{
    ActionSpace, HeuristicPolicy, MillError, MillOptions, Milled, ProgramLayout, SetupCount, SetupProgram,
    mill,
};

use super::common::{closed_meshes, data, rs274_errors};

fn mill_file(path: &std::path::Path, opts: &MillOptions) -> (Mesh, Milled) {
    let mesh = load_mesh(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let milled = mill(&mesh, &mut HeuristicPolicy::default(), opts, &mut |_| {})
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (mesh, milled)
}

/// Setup `i` of `name` neither gouges the part nor rapids through material.
fn assert_setup_safe(name: &str, i: usize, s: &SetupProgram) {
    assert_eq!(s.gouge_voxels, 0, "{name}: setup {} gouges the part", i + 1);
    assert!(
        s.rapid_collision_lines.is_empty(),
        "{name}: setup {} rapids through material at lines {:?}",
        i + 1,
        s.rapid_collision_lines
    );
}

/// Every closed mesh mills with zero gouges and zero rapid collisions, every program
/// runs through `rs274` without error, and with the heuristic policy the OpenSCAD parts
/// reach mean IoU >= 0.90 and mean normal consistency >= 0.92 (the paper: 0.848 / 0.922).
///
/// The grid is 128^3 rather than `s2g mill`'s 256^3 to keep CI within its budget (the
/// heuristic's finest layer is one voxel, so this also halves the layers); the closing
/// note of the mill issue has the same table at 256^3.
#[test]
fn every_closed_mesh_mills_safely_and_meets_the_quality_targets() {
    let dir = tempfile::tempdir().unwrap();
    let opts = MillOptions { resolution: 128, ..MillOptions::default() };
    let (mut iou, mut nc, mut n) = (0.0, 0.0, 0);
    let mut table =
        String::from("| part | setups | IoU | F1 | CD x1000 | NC | T (s) |\n|---|---|---|---|---|---|---|\n");
    for path in closed_meshes() {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let (_, m) = mill_file(&path, &opts);
        assert_programs_safe_and_accepted(&name, &m, dir.path());
        let q = &m.metrics;
        table += &format!(
            "| {name} | {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.0} |\n",
            m.setups.len(),
            q.iou,
            q.f1,
            q.chamfer_x1000,
            q.normal_consistency,
            m.simulation.machining_time_s
        );
        if path.to_string_lossy().contains("openscad") {
            iou += q.iou;
            nc += q.normal_consistency;
            n += 1;
        }
    }
    println!("{table}");
    let (iou, nc) = (iou / n as f64, nc / n as f64);
    assert!(iou >= 0.90, "mean IoU on the OpenSCAD parts is {iou:.4} < 0.90\n{table}");
    assert!(nc >= 0.92, "mean normal consistency on the OpenSCAD parts is {nc:.4} < 0.92\n{table}");
}

/// Every setup of `m` is safe ([`assert_setup_safe`]) and its program, written into
/// `dir`, runs through `rs274` without error.
fn assert_programs_safe_and_accepted(name: &str, m: &Milled, dir: &std::path::Path) {
    for (i, s) in m.setups.iter().enumerate() {
        assert_setup_safe(name, i, s);
        let program = dir.join(format!("{name}.{}.ngc", i + 1));
        std::fs::write(&program, &s.text).unwrap();
        let errors = rs274_errors(&program);
        assert!(errors.is_empty(), "{name}: rs274 rejects setup {}: {errors:?}", i + 1);
    }
}

/// `s2g mill`'s default policy, the learned one shipped in the crate, also mills every
/// closed mesh with zero gouges and zero rapid collisions into programs `rs274` accepts
/// (its finer layers and spiral clearing are other programs than the heuristic's).
#[cfg(feature = "learn")]
#[test]
fn every_closed_mesh_mills_safely_with_the_shipped_learned_policy() {
    let dir = tempfile::tempdir().unwrap();
    let opts = MillOptions { resolution: 128, ..MillOptions::default() };
    let mut policy = shape2gcode::LearnedPolicy::bundled().unwrap();
    for path in closed_meshes() {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let mesh = load_mesh(&path).unwrap();
        let m = mill(&mesh, &mut policy, &opts, &mut |_| {}).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.policy, "learned", "{name}: the learned policy chose every setup");
        assert_programs_safe_and_accepted(&name, &m, dir.path());
    }
}

/// A finer level of a roughing group skips the stretches of its contour that run in the
/// roughing level's free region (the roughing cut reached there from lower down), and
/// keeps the rest. On `example004`'s first, oblique setup at 256^3, with a 1 mm tool on
/// layers of half a voxel, the roughing level's free region has a 1.7 mm gap along one
/// straight stretch of the finer levels' contour. The test for "this stretch runs in it"
/// sampled the stretch at the region index's cell and missed the gap, so the finer levels
/// left that wall uncut and the next level's rapid descent met it (two rapids through
/// material). The test is exact now.
#[test]
fn a_finer_level_cuts_its_contour_across_a_gap_in_the_roughing_level_s_free_region() {
    assert_example004_setup_1_safe(256, 1.0, 0.1953125);
}

/// `example004`'s first setup (an oblique one), milled on a `resolution`^3 grid with a
/// zigzag of tool radius `radius` on layers `layer` thick, neither gouges nor rapids
/// through material.
fn assert_example004_setup_1_safe(resolution: usize, radius: f64, layer: f64) {
    use shape2gcode::{Action, MillRun, StrategyKind};
    let mesh = load_mesh(data("meshes/openscad/openscad_Old_example004.stl")).unwrap();
    let opts = MillOptions { resolution, ..MillOptions::default() };
    let mut run = MillRun::new(&mesh, &opts, &mut |_| {}).unwrap();
    let action = Action { tool_radius: radius, layer_height: layer, strategy: StrategyKind::ZIGZAG };
    run.machine(action, &mut |_| {}).unwrap();
    assert_setup_safe("openscad_Old_example004", 0, &run.machined()[0]);
}

/// Zigzag passes never cross the keep-out where a horizontal edge of the clearing region
/// (the material map's staircase) lies exactly on a pass line. On `example004`'s first
/// setup at 64^3 with a 0.75 mm tool on 0.3 mm layers, a rounding in the first line of an
/// edge dropped one crossing of such a line, the rest paired wrongly, and a pass ran
/// through the part (155 gouged voxels).
#[test]
fn zigzag_passes_along_a_staircase_edge_stay_out_of_the_part() {
    assert_example004_setup_1_safe(64, 0.75, 0.3);
}

/// A fixed action whose radius is outside the action space (2 mm; the paper preset's
/// largest is 1 mm) gets a tool of its own, and the simulator cuts with that radius: the
/// programs select a tool number past the space's, and the LetterBlock comes out whole.
/// (The simulator used to take such a tool for tool 1, the 0.1 mm one, and left most of
/// the stock: IoU 0.44.)
#[test]
fn a_radius_outside_the_action_space_is_simulated_with_its_own_tool() {
    use shape2gcode::{Action, FixedPolicy, StrategyKind};
    let mesh = load_mesh(data("meshes/openscad/openscad_Basics_LetterBlock.stl")).unwrap();
    let opts = MillOptions {
        resolution: 48,
        orient_points: 1024,
        setups: SetupCount::Exactly(2),
        ..MillOptions::default()
    };
    let space = opts.action_space();
    assert!(space.radii.iter().all(|&r| r < 2.0), "{:?}", space.radii);
    let action = Action { tool_radius: 2.0, layer_height: 0.78125, strategy: StrategyKind::ZIGZAG };
    let m = mill(&mesh, &mut FixedPolicy(action), &opts, &mut |_| {}).unwrap();
    let tool = format!("T{} M6", space.radii.len() + 1);
    for (i, s) in m.setups.iter().enumerate() {
        assert_setup_safe("LetterBlock", i, s);
        assert!(s.text.contains(&tool), "setup {}: no {tool}", i + 1);
    }
    assert!(m.metrics.iou > 0.95, "IoU {}", m.metrics.iou);
}

/// Every program ends where its planner left the tool, on the clearance plane above the
/// stock: no `G53 G0 Z0` footer, which a reader that knows no work offset (the simulator,
/// `rs274`) takes for work Z0, a rapid plunge into the part wherever the last pass ended
/// over it (a 1 mm spiral on the LetterBlock ended at its corner and gouged 384 voxels).
#[test]
fn programs_end_on_the_clearance_plane() {
    let path = data("meshes/openscad/openscad_Basics_LetterBlock.stl");
    let opts = MillOptions { resolution: 64, setups: SetupCount::Exactly(2), ..MillOptions::default() };
    let (_, m) = mill_file(&path, &opts);
    for (i, s) in m.setups.iter().enumerate() {
        assert!(!s.text.contains("G53"), "setup {}: a machine-coordinate move", i + 1);
        let z: Vec<f64> = s
            .text
            .split_whitespace()
            .filter_map(|w| w.strip_prefix('Z').and_then(|v| v.parse().ok()))
            .collect();
        let top = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        assert_eq!(z.last(), Some(&top), "setup {}: the last Z word is not the clearance plane", i + 1);
    }
}

/// The report's metrics agree with a recomputation from the residual mesh as written to
/// disk, by other code than `geom::compare`: IoU and F1 counted voxel by voxel here;
/// Chamfer distance and normal consistency from this test's own area-weighted sampler
/// (another random stream) with brute-force nearest neighbours. The surface metrics are
/// estimates from 8,000 samples a side, so they agree within sampling noise, not exactly:
/// normal consistency within four standard errors of the difference of two such estimates
/// (from this sample's spread; about 0.009 here, where five other seeds of this test's
/// sampler spread over 0.936-0.943).
#[test]
fn report_metrics_agree_with_an_independent_recomputation_from_the_written_residual() {
    let path = data("meshes/openscad/openscad_Old_example002.stl");
    let opts = MillOptions { orient_points: 4096, resolution: 128, ..MillOptions::default() };
    let (mesh, m) = mill_file(&path, &opts);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("residual.stl");
    save_mesh(&file, &m.residual).unwrap();
    let residual = load_mesh(&file).unwrap();

    let unit = unit_cube_normalization(&mesh).unwrap().as_similarity();
    let spec = GridSpec::new(&MetricOptions::default().bounds, [256; 3]).unwrap();
    let a = voxelize(&residual.transformed(&unit), &spec).unwrap();
    let b = voxelize(&mesh.transformed(&unit), &spec).unwrap();
    let count = |g: &VoxelGrid| g.iter_set().count() as f64;
    let both = a.iter_set().filter(|&[i, j, k]| b.get(i, j, k)).count() as f64;
    let (na, nb) = (count(&a), count(&b));
    let iou = both / (na + nb - both);
    let f1 = 2.0 * both / (na + nb);
    // The STL file stores f32 coordinates: a handful of boundary voxels may flip.
    assert!((iou - m.metrics.iou).abs() < 2e-3, "IoU: report {} vs recomputed {iou}", m.metrics.iou);
    assert!((f1 - m.metrics.f1).abs() < 2e-3, "F1: report {} vs recomputed {f1}", m.metrics.f1);
    assert!(m.metrics.iou > 0.5, "a milled part resembles its target (IoU {})", m.metrics.iou);

    let n = opts.metric_samples;
    let sa = samples(&residual.transformed(&unit), n, 0xA11CE);
    let sb = samples(&mesh.transformed(&unit), n, 0xB0B);
    let (ab, ab_nc, ab_var) = nearest_one_way(&sa, &sb);
    let (ba, ba_nc, ba_var) = nearest_one_way(&sb, &sa);
    // Standard error of one estimate of NC; the report's is another, independent one.
    let se = 0.5 * (ab_var / sa.len() as f64 + ba_var / sb.len() as f64).sqrt();
    let nc_tol = 4.0 * std::f64::consts::SQRT_2 * se;
    let chamfer = 1000.0 * (ab + ba);
    let nc = 0.5 * (ab_nc + ba_nc);
    let got = (m.metrics.chamfer_x1000, m.metrics.normal_consistency);
    eprintln!(
        "Chamfer x1000 {:.4} vs recomputed {chamfer:.4}; NC {:.4} vs {nc:.4} (+- {nc_tol:.4})",
        got.0, got.1
    );
    assert!(
        (chamfer - got.0).abs() <= 0.10 * chamfer.max(got.0) + 0.01,
        "Chamfer x1000: report {} vs recomputed {chamfer}",
        got.0
    );
    assert!(nc_tol < 0.03, "8,000 samples pin normal consistency down: standard error {se}");
    assert!(
        (nc - got.1).abs() <= nc_tol,
        "normal consistency: report {} vs recomputed {nc} +- {nc_tol}",
        got.1
    );
}

/// `n` points on `mesh`, area-weighted, each with its triangle's unit normal (SplitMix64
/// stream from `seed`, uniform in each triangle by the square-root rule).
fn samples(mesh: &Mesh, n: usize, seed: u64) -> Vec<(Point3, Vector3)> {
    let mut state = seed;
    let mut unit = move || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let v = mesh.vertices();
    let tris: Vec<[Point3; 3]> =
        mesh.triangles().iter().map(|t| [v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]]).collect();
    let mut cum = Vec::with_capacity(tris.len());
    let mut total = 0.0;
    for [a, b, c] in &tris {
        total += 0.5 * (b - a).cross(&(c - a)).norm();
        cum.push(total);
    }
    (0..n)
        .map(|_| {
            let u = unit() * total;
            let k = cum.partition_point(|&c| c < u).min(tris.len() - 1);
            let [a, b, c] = tris[k];
            let (r1, r2) = (unit().sqrt(), unit());
            let p = a + (b - a) * (r1 * (1.0 - r2)) + (c - a) * (r1 * r2);
            (p, (b - a).cross(&(c - a)).normalize())
        })
        .collect()
}

/// Mean squared distance from each sample of `from` to its nearest in `to`, and the mean
/// and variance of |cos| between their normals, by brute force.
fn nearest_one_way(from: &[(Point3, Vector3)], to: &[(Point3, Vector3)]) -> (f64, f64, f64) {
    let (mut d2, mut cos, mut cos2) = (0.0, 0.0, 0.0);
    for (p, n) in from {
        let (best, q) = to
            .iter()
            .map(|(q, m)| ((q - p).norm_squared(), m))
            .fold((f64::INFINITY, n), |acc, x| if x.0 < acc.0 { x } else { acc });
        let c = n.dot(q).abs();
        d2 += best;
        cos += c;
        cos2 += c * c;
    }
    let k = from.len() as f64;
    let mean = cos / k;
    (d2 / k, mean, (cos2 / k - mean * mean).max(0.0))
}

/// The same input and seed give byte-identical programs and reports (timings left out).
#[test]
fn two_runs_give_identical_programs_and_reports() {
    let path = data("meshes/openscad/openscad_Basics_LetterBlock.stl");
    let opts = MillOptions { orient_points: 2048, resolution: 96, ..MillOptions::default() };
    let (_, a) = mill_file(&path, &opts);
    let (_, b) = mill_file(&path, &opts);
    assert_eq!(a.programs, b.programs, "programs differ between two runs");
    let ja = serde_json::to_string(&a.report_json(false)).unwrap();
    let jb = serde_json::to_string(&b.report_json(false)).unwrap();
    assert_eq!(ja, jb, "reports differ between two runs");
}

/// A run told not to keep its programs ([`MillRun::keep_programs`], what the learning
/// environment does) streams each program from the planner to the simulator and ends
/// exactly where a run that keeps them does: same report, same line counts, no text.
#[test]
fn a_run_that_keeps_no_program_text_ends_where_one_that_keeps_it_does() {
    use shape2gcode::{MillRun, Policy};
    let path = data("meshes/openscad/openscad_Basics_LetterBlock.stl");
    let mesh = load_mesh(&path).unwrap();
    let opts = MillOptions {
        orient_points: 1024,
        resolution: 48,
        setups: SetupCount::Exactly(2),
        ..MillOptions::default()
    };
    let run = |keep: bool| {
        let mut run = MillRun::new(&mesh, &opts, &mut |_| {}).unwrap();
        run.keep_programs(keep);
        let mut policy = HeuristicPolicy::default();
        while run.next_setup().is_some() {
            let features = run.features();
            let action = policy.choose(&run.context(&features));
            run.machine(action, &mut |_| {}).unwrap();
        }
        run.finish("heuristic", &mut |_| {}).unwrap()
    };
    let (kept, streamed) = (run(true), run(false));
    assert_eq!(kept.setups.len(), 2);
    for (k, s) in kept.setups.iter().zip(&streamed.setups) {
        assert!(k.lines > 100, "a program of {} lines", k.lines);
        assert_eq!(k.lines, k.text.lines().count() as u64, "lines counted by the parser");
        assert_eq!(k.lines, s.lines);
        assert!(s.text.is_empty(), "the streamed run kept {} bytes", s.text.len());
    }
    assert!(streamed.programs.iter().all(String::is_empty));
    assert!(
        !kept.trace.segments.is_empty() && streamed.trace.segments.is_empty(),
        "the trace is a program's"
    );
    let (a, b) = (kept.report_json(false), streamed.report_json(false));
    assert_eq!(serde_json::to_string(&a).unwrap(), serde_json::to_string(&b).unwrap());
}

/// `evaluate` builds the paper's tables: a policy row is the mean of what `mill` gives for
/// that policy on each part, and Table 4 has one row per removed strategy plus the
/// contour ablation, each a complete, safe run.
#[test]
fn evaluation_tables_are_means_of_single_runs() {
    use shape2gcode::evaluate;
    let names = ["fdm/models/cube10.stl", "meshes/openscad/openscad_Old_example002.stl"];
    let parts: Vec<(String, Mesh)> =
        names.iter().map(|n| (n.to_string(), load_mesh(data(n)).unwrap())).collect();
    let opts =
        MillOptions { orient_points: 512, resolution: 24, metric_samples: 2000, ..MillOptions::default() };
    let policies = ["heuristic".to_string(), "coarse".to_string()];
    // A seed group of the two rows' policies: its members are not milled again.
    let group = shape2gcode::SeedGroup { name: "both".into(), members: policies.to_vec() };
    // Table 4 of the heuristic, a row of Table 1 too (by default it is the learned policy's).
    let eval = shape2gcode::EvalOptions {
        seed_groups: vec![group],
        ablated: "heuristic".into(),
        ..Default::default()
    };
    let mut runs = 0;
    let tables = evaluate(&parts, &policies, &eval, &opts, &mut |_, _| runs += 1).unwrap();
    assert_eq!(tables.policies.len(), 3);
    assert_eq!(tables.ablation.len(), 1 + 3 + 1, "none removed, three strategies, contour");
    assert_eq!(runs, parts.len() * (2 + 3 + 1), "runs announced");
    let both = &tables.policies[2];
    assert_eq!(both.name, "both");
    let mean = 0.5 * (tables.policies[0].iou + tables.policies[1].iou);
    assert!((both.iou - mean).abs() < 1e-12, "group {} vs rows' mean {mean}", both.iou);
    let ci = both.ci95.expect("two members give an interval");
    let spread = (tables.policies[0].iou - tables.policies[1].iou).abs();
    // Two members: the half-width is t(1) * |a - b| / 2 with t(1) = 12.706.
    assert!((ci.iou - 12.706 * spread / 2.0).abs() < 1e-9, "{ci:?}, spread {spread}");
    let mean_iou: f64 = parts
        .iter()
        .map(|(_, m)| mill(m, &mut HeuristicPolicy::default(), &opts, &mut |_| {}).unwrap().metrics.iou)
        .sum::<f64>()
        / parts.len() as f64;
    let row = &tables.policies[0];
    assert_eq!(row.name, "heuristic");
    assert!((row.iou - mean_iou).abs() < 1e-12, "table {} vs direct {mean_iou}", row.iou);
    assert_eq!(tables.ablation[0].iou, row.iou, "'none removed' is the heuristic row");
    for r in tables.policies.iter().chain(&tables.ablation) {
        assert!((0.0..=1.0).contains(&r.iou) && (0.0..=1.0).contains(&r.normal_consistency), "{r:?}");
        // The contour ablation (clearing only) can come out unsafe: the cube10 part at
        // 24^3 does (open in the toolpath issue). Every configuration `s2g mill` runs is
        // safe.
        if r.name != "without contour" {
            assert_eq!(r.unsafe_parts, 0, "{r:?}");
        }
    }
    let c = tables.orientation.as_ref().expect("Table 2 is computed by default");
    assert!(c.ours <= c.upper_bound + 1e-12 && c.six_axes <= c.upper_bound + 1e-12, "{c:?}");
}

/// The rotary layout writes one 3+2 program for all setups: rotary words before each
/// setup's moves, zero gouges and rapid collisions, accepted by `rs274`, read back by a
/// plain one-pass parse to the same simulation, and scoring the part within 0.01 IoU of
/// the per-setup programs. Both kinematics are run, B/C with a tilt range of [-180, 0]
/// so that every tilt takes the flipped branch (B = -theta, C + 180); a range that
/// excludes a setup's tilt is a typed error.
#[test]
fn rotary_layout_is_one_safe_program_scoring_like_the_per_setup_programs() {
    let path = data("meshes/openscad/openscad_Old_example002.stl");
    // Three setups keep it quick and still include a tilt near 180 degrees.
    let base = MillOptions {
        orient_points: 1024,
        resolution: 64,
        setups: SetupCount::Exactly(3),
        ..MillOptions::default()
    };
    let (mesh, per) = mill_file(&path, &base);
    let n = per.setups.len();
    assert_eq!(n, 3, "setups");
    assert_eq!(per.programs.len(), n);
    assert!(per.is_safe(), "per-setup layout is unsafe");
    let dir = tempfile::tempdir().unwrap();
    let mut table = format!(
        "| layout | IoU | NC |\n|---|---|---|\n| per-setup | {:.4} | {:.4} |\n",
        per.metrics.iou, per.metrics.normal_consistency
    );
    for (axes, letter, range) in
        [(RotaryAxes::AC, 'A', [-180.0, 180.0]), (RotaryAxes::BC, 'B', [-180.0, 0.0])]
    {
        let name = format!("{axes:?} range {range:?}");
        let opts =
            MillOptions { layout: ProgramLayout::Rotary(axes), rotary_tilt_range_deg: range, ..base.clone() };
        let (_, rot) = mill_file(&path, &opts);
        assert_eq!(rot.programs.len(), 1, "{name}: one program");
        assert_eq!(rot.setups.len(), n, "{name}: same setups");
        let text = &rot.programs[0];
        let joined: String = rot.setups.iter().map(|s| s.text.as_str()).collect();
        assert_eq!(&joined, text, "{name}: the sections joined are the program");
        for s in &rot.setups {
            assert_eq!(s.lines, s.text.lines().count() as u64, "{name}: section lines");
        }
        // One rotary block per setup, after that setup's comment, with the stated angles.
        let blocks: Vec<&str> = text.lines().filter(|l| l.starts_with(&format!("G0 {letter}"))).collect();
        assert_eq!(blocks.len(), n, "{name}: rotary blocks {blocks:?}");
        for (i, (s, p)) in rot.setups.iter().zip(&per.setups).enumerate() {
            assert!(s.text.contains(&format!("(SETUP {}: ", i + 1)), "{name}: setup {} comment", i + 1);
            let a = s.rotary_deg.unwrap_or_else(|| panic!("{name}: setup {} has no angles", i + 1));
            let tilt = if axes == RotaryAxes::AC { a[0] } else { a[1] };
            assert!((range[0]..=range[1]).contains(&tilt), "{name}: setup {} tilt {tilt}", i + 1);
            assert!(blocks[i].contains(" C"), "{name}: {}", blocks[i]);
            let d = (s.setup.tool_axis().into_inner() - p.setup.tool_axis().into_inner()).norm();
            assert!(d < 1e-5, "{name}: setup {} tool axis differs by {d}", i + 1);
            assert_setup_safe(&name, i, s);
        }
        assert_eq!(rot.simulation.gouge_voxels, 0, "{name}: gouges");
        assert_eq!(rot.rapid_collisions(), 0, "{name}: rapid collisions");

        let program = dir.path().join(format!("{axes:?}.ngc"));
        std::fs::write(&program, text).unwrap();
        let errors = rs274_errors(&program);
        assert!(errors.is_empty(), "{name}: rs274 rejects the program: {errors:?}");

        // An independent read-back: the finished text parsed in one plain pass into a fresh
        // simulator removes exactly what mill's simulation removed.
        let k = base.paper_scale_mm;
        let stock =
            Aabb::new(Point3::new(-0.5 * k, -0.5 * k, -0.5 * k), Point3::new(0.5 * k, 0.5 * k, 0.5 * k));
        let diag = stock.extent().norm();
        let space = ActionSpace::paper().scaled(k);
        let mut tools = ToolTable::single(Cutter::flat(rot.setups[0].action.tool_radius, diag));
        for s in &rot.setups {
            let r = s.action.tool_radius;
            let number = space.radii.iter().position(|&x| x == r).map_or(1, |i| i as u32 + 1);
            tools = tools.with(number, Cutter::flat(r, diag));
        }
        let spec = GridSpec::cubic(&stock, base.resolution).unwrap();
        let sopts = SimOptions { rapid_rate_mm_per_min: 5000.0, ..SimOptions::default() };
        let mut sim = Simulator::new(VoxelGrid::full(spec), tools, sopts).unwrap();
        let popts = ParseOptions { rotary: Some(axes), ..ParseOptions::default() };
        let summary = parse_str(text, &popts, &mut sim).unwrap();
        assert!(summary.errors.is_empty(), "{name}: {:?}", summary.errors);
        let again = sim.into_simulation().unwrap();
        assert_eq!(
            again.report().removed_voxels,
            rot.simulation.removed_voxels,
            "{name}: a plain re-read removes a different volume"
        );

        table += &format!("| {name} | {:.4} | {:.4} |\n", rot.metrics.iou, rot.metrics.normal_consistency);
        let d = (rot.metrics.iou - per.metrics.iou).abs();
        assert!(
            d <= 0.01,
            "{name}: IoU {} vs per-setup {} (|d| = {d:.4})\n{table}",
            rot.metrics.iou,
            per.metrics.iou
        );
    }
    println!("{table}");

    // A tilt range that leaves out the steepest setup's tilt (with either sign) is an error.
    let steepest = per
        .setups
        .iter()
        .map(|s| s.setup.tool_axis().z.clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0, f64::max);
    assert!(steepest > 1.0, "example002 has a tilted setup");
    let opts = MillOptions {
        layout: ProgramLayout::Rotary(RotaryAxes::BC),
        rotary_tilt_range_deg: [0.0, steepest - 1.0],
        ..base.clone()
    };
    match mill(&mesh, &mut HeuristicPolicy::default(), &opts, &mut |_| {}) {
        Err(MillError::Unreachable { letter, tilt_deg, range_deg, .. }) => {
            assert_eq!(letter, 'B');
            assert!(tilt_deg > range_deg[1], "tilt {tilt_deg} vs range {range_deg:?}");
        }
        other => panic!("expected an unreachable setup, got {:?}", other.map(|m| m.setups.len())),
    }
}

/// With `flank_walls` a box's walls are reachable from the axis above them: every setup
/// is axis-aligned, no face is terraced, and the box scores better (at 48^3: NC 0.974
/// against 0.947, IoU 0.937 against 0.925); the paper's front-facing test prefers oblique
/// corner directions that see three faces each.
#[test]
fn flank_walls_give_a_box_axis_aligned_setups() {
    let part = Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(50.0, 30.0, 20.0))).unwrap();
    // Visibility alone: the stock-removal term would add setups to the front-facing run.
    let base =
        MillOptions { orient_points: 2048, resolution: 48, stock_removal: false, ..MillOptions::default() };
    let run = |flank_walls| {
        mill(
            &part,
            &mut HeuristicPolicy::default(),
            &MillOptions { flank_walls, ..base.clone() },
            &mut |_| {},
        )
        .unwrap()
    };
    let aligned =
        |m: &Milled| m.setups.iter().all(|s| s.setup.tool_axis().iter().any(|c| c.abs() > 1.0 - 1e-9));
    let flank = run(true);
    assert!(
        aligned(&flank),
        "axes {:?}",
        flank.setups.iter().map(|s| s.setup.tool_axis()).collect::<Vec<_>>()
    );
    flank.setups.iter().enumerate().for_each(|(i, s)| assert_setup_safe("flank box", i, s));
    let front = run(false);
    assert!(!aligned(&front), "the front-facing test chose axis-aligned setups for a box");
    let (f, b) = (&flank.metrics, &front.metrics);
    assert!(
        f.normal_consistency > b.normal_consistency + 0.01,
        "NC {} vs {}",
        f.normal_consistency,
        b.normal_consistency
    );
    assert!(f.iou > b.iou, "IoU {} vs {}", f.iou, b.iou);
}

/// The stress corpus mills with the default policy (the learned one; the heuristic without
/// the `learn` feature): zero gouges, zero rapids
/// through material, programs `rs274` accepts, and the part comes out (IoU against the
/// mesh at this coarse grid). Before the sliver fix the flanged bushings (a cross hole in
/// a tube, 96 and 256 facets per circle) never finished.
#[test]
fn every_stress_part_mills_safely_with_the_default_policy() {
    let dir = tempfile::tempdir().unwrap();
    let opts = MillOptions { resolution: 128, ..MillOptions::default() };
    let mut policy = super::common::default_policy();
    let meshes = super::common::stress_meshes();
    assert!(meshes.len() >= 10, "the stress corpus has {} parts", meshes.len());
    let mut table = String::new();
    for path in meshes {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let mesh = load_mesh(&path).unwrap();
        let m = mill(&mesh, policy.as_mut(), &opts, &mut |_| {}).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_programs_safe_and_accepted(&name, &m, dir.path());
        table += &format!("{name}: IoU {:.4}\n", m.metrics.iou);
        // The others come out whole; these are at most two voxels thick at this grid (0.6
        // mm walls on a 60 mm tray, a 2 mm bar and a 3 mm tube 200 and 150 mm long), so
        // their IoU measures the grid (at 256^3: 0.996, 0.996 and 0.83).
        if !["thin_walls", "long_bar", "long_tube"].contains(&name.as_str()) {
            assert!(m.metrics.iou >= 0.9, "{name}: IoU {:.4}\n{table}", m.metrics.iou);
        }
    }
    println!("{table}");
}

/// The running keep-out union stays as small as the part's outline: on the flanged
/// bushing with a cross hole (96 facets per circle), whose tube walls near the hole are
/// numerically vertical slivers, every level's keep-out has fewer boundary vertices than
/// the mesh has triangles (it grew past 460,000 within 40 levels when the slivers were
/// unioned in), and with the slivers left out it still contains the exact cross-section
/// (points sampled just inside the part at each level lie in the keep-out).
#[test]
fn the_keep_outs_of_a_part_with_slivers_stay_small_and_conservative() {
    use shape2gcode::toolpath::{PlanOptions, Point2, Tool, slice_setup};
    let mesh = load_mesh(data("meshes/stress/bushing_96.stl")).unwrap();
    let setup = shape2gcode::geom::Setup::top();
    let tool = Tool::flat(0.5);
    let opts = PlanOptions { layer_height: 0.1, ..PlanOptions::default() };
    let slices = slice_setup::<()>(&mesh, &setup, &tool, &opts).unwrap();
    assert!(slices.levels.len() > 300, "{} levels", slices.levels.len());
    let most = slices.keepouts.iter().map(|k| k.vertex_count()).max().unwrap();
    assert!(
        most < mesh.triangles().len(),
        "a keep-out of {most} vertices for {} triangles",
        mesh.triangles().len()
    );
    assert!(slices.sliver_width > 0.0 && slices.sliver_width < 1e-3, "{}", slices.sliver_width);
    // The tube (outer radius 16) stands above z = 8: at every level below its top, points
    // just inside its wall are in the keep-out, and the bore (radius 10) is not.
    for (z, k) in slices.levels.iter().zip(&slices.keepouts).filter(|(z, _)| **z > 8.5 && **z < 31.5) {
        for a in (0..360).step_by(5) {
            let (s, c) = (a as f64).to_radians().sin_cos();
            let wall = Point2::new(15.9 * c, 15.9 * s);
            assert!(k.index().contains(&wall), "z {z}: the wall at {a} degrees is outside the keep-out");
            let bore = Point2::new(9.0 * c, 9.0 * s);
            assert!(!k.index().contains(&bore), "z {z}: the bore at {a} degrees is in the keep-out");
        }
    }
}

/// grbl has no tool changer: its programs pause (`M0`) for the operator to fit the tool a
/// comment names, and the simulator must cut with that tool, not with the table's first.
/// (It cut with the first, 0.1 mm, so a 1 mm plan left walls everywhere: the bunny's grbl
/// programs at 128^3 had 474 rapids through material and IoU 0.908 against 0.99.) The
/// grbl and LinuxCNC programs of one plan mill the same part.
#[test]
fn grbl_programs_are_simulated_with_the_tool_the_operator_fits() {
    use shape2gcode::gcode::Dialect;
    let path = data("meshes/openscad/openscad_Old_example001.stl");
    let opts = MillOptions { resolution: 96, ..MillOptions::default() };
    let (_, lcnc) = mill_file(&path, &opts);
    let (_, grbl) = mill_file(&path, &MillOptions { dialect: Dialect::Grbl, ..opts });
    // The test means something only when a setup's tool is not the table's first.
    assert!(
        grbl.setups.iter().any(|s| s.text.contains("(tool change T") && !s.text.contains("(tool change T1)")),
        "every setup uses T1"
    );
    for (i, s) in grbl.setups.iter().enumerate() {
        assert_setup_safe("example001 (grbl)", i, s);
    }
    assert!(
        (grbl.metrics.iou - lcnc.metrics.iou).abs() < 2e-3,
        "grbl IoU {} against LinuxCNC {}",
        grbl.metrics.iou,
        lcnc.metrics.iou
    );
}

/// With an arc tolerance, runs of moves on a circle become G2/G3 arcs: fewer lines, the
/// part milled as safely (the walls keep the tolerance as allowance, so no arc comes
/// nearer the part than planned; without it the bunny's arcs gouged), `rs274` accepts the
/// programs, and the part comes out as without arcs.
#[test]
fn arc_fitted_programs_are_shorter_and_as_safe() {
    let dir = tempfile::tempdir().unwrap();
    let path = data("meshes/classic/gearwheel_40t.bin.stl");
    let opts = MillOptions { resolution: 96, ..MillOptions::default() };
    let (_, lines) = mill_file(&path, &opts);
    let (_, arcs) = mill_file(&path, &MillOptions { arc_tolerance: Some(0.01), ..opts });
    let count = |m: &Milled| m.setups.iter().map(|s| s.lines).sum::<u64>();
    let arc_blocks: usize = arcs
        .setups
        .iter()
        .map(|s| s.text.lines().filter(|l| l.starts_with("G2 ") || l.starts_with("G3 ")).count())
        .sum();
    assert!(arc_blocks > 100, "{arc_blocks} arcs");
    assert!(count(&arcs) < count(&lines), "{} lines with arcs, {} without", count(&arcs), count(&lines));
    assert_programs_safe_and_accepted("gearwheel-arcs", &arcs, dir.path());
    assert!(
        (arcs.metrics.iou - lines.metrics.iou).abs() < 5e-3,
        "IoU {} with arcs, {} without",
        arcs.metrics.iou,
        lines.metrics.iou
    );
}
