//! Stock and fixture: flat parts lose all their stock (the stock-removal term of setup
//! selection), the stock options are the simulator's starting stock, and a datum moves the
//! programs' origin without changing the cut.

use super::common::assert_same_programs;
use shape2gcode::gcode::{Motion, MotionSink, ParseOptions, parse_str};
use shape2gcode::geom::{Mesh, Point3};
use shape2gcode::{Datum, FinishChoice, HeuristicPolicy, MillOptions, MillRun, Milled, Preset, Stock, mill};

/// A simple polygon in the XZ plane, counter-clockwise seen from -Y, extruded from y = 0
/// to y = `depth`: a flat part of the kind slicers test with.
fn extruded(profile: &[[f64; 2]], depth: f64) -> Mesh {
    let n = profile.len() as u32;
    let mut vertices: Vec<Point3> = profile.iter().map(|p| Point3::new(p[0], 0.0, p[1])).collect();
    vertices.extend(profile.iter().map(|p| Point3::new(p[0], depth, p[1])));
    let mut triangles = Vec::new();
    for [a, b, c] in ear_clip(profile) {
        triangles.push([a, b, c]);
        triangles.push([c + n, b + n, a + n]);
    }
    for i in 0..n {
        let j = (i + 1) % n;
        triangles.push([i, i + n, j]);
        triangles.push([j, i + n, j + n]);
    }
    Mesh::new(vertices, triangles).expect("a valid extrusion")
}

/// Triangles of a simple counter-clockwise polygon by ear clipping.
fn ear_clip(p: &[[f64; 2]]) -> Vec<[u32; 3]> {
    let cross =
        |o: [f64; 2], a: [f64; 2], b: [f64; 2]| (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    let mut left: Vec<usize> = (0..p.len()).collect();
    let mut out = Vec::new();
    while left.len() > 3 {
        let k = left.len();
        let ear = (0..k)
            .find(|&i| {
                let (a, b, c) = (left[(i + k - 1) % k], left[i], left[(i + 1) % k]);
                cross(p[a], p[b], p[c]) > 0.0
                    && left.iter().filter(|&&q| q != a && q != b && q != c).all(|&q| {
                        !(cross(p[a], p[b], p[q]) >= 0.0
                            && cross(p[b], p[c], p[q]) >= 0.0
                            && cross(p[c], p[a], p[q]) >= 0.0)
                    })
            })
            .expect("a simple polygon has an ear");
        let (a, b, c) = (left[(ear + k - 1) % k], left[ear], left[(ear + 1) % k]);
        out.push([a as u32, b as u32, c as u32]);
        left.remove(ear);
    }
    out.push([left[0] as u32, left[1] as u32, left[2] as u32]);
    out
}

/// A bridge after PrusaSlicer's test shape: a 50 x 10 x 8 mm bar on two 5 mm piers with a
/// 40 x 5 mm opening under its span.
fn bridge() -> Mesh {
    extruded(&[[0., 0.], [5., 0.], [5., 5.], [45., 5.], [45., 0.], [50., 0.], [50., 8.], [0., 8.]], 10.0)
}

/// A stand of our own in the spirit of PrusaSlicer's ipadstand: a 98 x 30 mm profile
/// (base, sloping lip, back rest) 10 mm thick.
fn stand() -> Mesh {
    extruded(
        &[
            [0., 0.],
            [98., 0.],
            [98., 20.],
            [88., 20.],
            [78., 8.],
            [20., 8.],
            [20., 30.],
            [12., 30.],
            [0., 14.],
        ],
        10.0,
    )
}

fn mill_with(mesh: &Mesh, opts: &MillOptions) -> Milled {
    mill(mesh, &mut HeuristicPolicy::default(), opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:#}"))
}

/// The flat parts reach IoU 0.9 in the paper preset and 0.98 in the shop preset (issue
/// 35's targets; visibility alone gives about 0.1 in the paper preset), safely. At `s2g
/// mill`'s 256, where the simulation grid is the scorer's (at coarser grids a face may lie
/// up to a voxel off between the two, 2-4 % of a 10 mm thick part, and the paper preset's
/// 128^3 puts 13 voxels across the stand); the shop preset's box of stock around a flat
/// part keeps it cheap. `s2g mill` on PrusaSlicer's own meshes gives the figures in the
/// issue's closing note.
///
/// Finished as the shop preset finishes by default (`s2g mill --preset shop`), too: the
/// roughing cuts the walls to size, since the ball's raster never descends a part's outer
/// walls (with the roughing's former 0.3 mm allowance PrusaSlicer's bridge and ipadstand
/// kept it there: IoU 0.948 and 0.965 at 256^3).
#[test]
fn flat_parts_lose_all_their_stock_in_both_presets() {
    let finished = Some(FinishChoice::default());
    for (name, part) in [("bridge", bridge()), ("stand", stand())] {
        for (preset, finish, target) in
            [(Preset::Paper, None, 0.9), (Preset::Shop, None, 0.98), (Preset::Shop, finished, 0.98)]
        {
            let opts = MillOptions { preset, resolution: 256, finish, ..MillOptions::default() };
            let m = mill_with(&part, &opts);
            assert!(
                m.metrics.iou >= target,
                "{name} {preset:?} finished {}: IoU {:.4} < {target} with setups {:?}",
                finish.is_some(),
                m.metrics.iou,
                m.orientation.directions
            );
            assert!(m.is_safe(), "{name} {preset:?}: gouges {}", m.simulation.gouge_voxels);
        }
    }
}

/// Visibility alone (the paper's selection, the named baseline) sees every face of the
/// bridge from two setups and leaves the stock under one of them; the term changes the
/// setups and says how much stock visibility left.
#[test]
fn visibility_alone_leaves_the_stock_of_a_flat_part() {
    let base = MillOptions { resolution: 64, stock_removal: false, ..MillOptions::default() };
    let plain = mill_with(&bridge(), &base);
    let with = mill_with(&bridge(), &MillOptions { stock_removal: true, ..base });
    assert!(plain.metrics.iou < 0.5, "visibility alone: IoU {:.4}", plain.metrics.iou);
    assert!(
        with.metrics.iou > plain.metrics.iou + 0.4,
        "{:.4} vs {:.4}",
        with.metrics.iou,
        plain.metrics.iou
    );
    assert!(plain.orientation.stock.is_none());
    let s = with.orientation.stock.expect("the term's report");
    assert!(s.changed && s.left < s.left_by_visibility / 10, "{s:?}");
    let report = with.report_json(false);
    assert_eq!(report["orientation"]["stock_removal"]["left"], s.left);
}

/// Each stock option is the simulator's starting stock: its volume on the grid (256
/// voxels along the part) is the option's within a voxel layer, and a stock that does not
/// hold the part is refused.
#[test]
fn stock_options_are_the_simulated_stock() {
    let part = bridge();
    let pi = std::f64::consts::PI;
    let cases = [
        (Stock::Preset, 52.0 * 12.0 * 10.0),
        (Stock::BoxSize([60.0, 20.0, 16.0]), 60.0 * 20.0 * 16.0),
        (Stock::BoxCorners { min: [-2.0, -1.0, -3.0], max: [55.0, 12.0, 9.0] }, 57.0 * 13.0 * 12.0),
        (Stock::Cylinder { diameter: 16.0, length: 56.0, axis: 0 }, pi * 64.0 * 56.0),
    ];
    for (stock, volume) in cases {
        let opts = MillOptions { preset: Preset::Shop, resolution: 256, stock, ..MillOptions::default() };
        let run = MillRun::new(&part, &opts, &mut |_| {}).unwrap_or_else(|e| panic!("{stock:?}: {e:#}"));
        let simulated = run.stock_volume();
        assert!(
            (simulated / volume - 1.0).abs() < 0.03,
            "{stock:?}: simulated {simulated:.1} mm3, expected {volume:.1}"
        );
    }
    // The shop preset's stock has a margin of 2 % of the part's longest side (1 mm here).
    for stock in [
        Stock::BoxSize([40.0, 20.0, 16.0]),
        Stock::Cylinder { diameter: 9.0, length: 60.0, axis: 0 },
        Stock::BoxSize([60.0, -20.0, 16.0]),
    ] {
        let opts = MillOptions { preset: Preset::Shop, resolution: 32, stock, ..MillOptions::default() };
        assert!(MillRun::new(&part, &opts, &mut |_| {}).is_err(), "{stock:?} must be refused");
    }
}

/// Feed moves of a program, in program coordinates.
#[derive(Default)]
struct Feeds(Vec<Point3>);

impl MotionSink for Feeds {
    type Error = std::convert::Infallible;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        if let Motion::Linear { to, .. } = m {
            self.0.push(*to);
        }
        Ok(())
    }
}

/// A datum states G54 in each program's header and the report, puts the stock top at
/// Z0 (and its centre or corner at X0 Y0), and cuts exactly what the run without one cuts.
#[test]
fn a_datum_moves_the_program_origin_and_not_the_cut() {
    let part = stand();
    let base = MillOptions { preset: Preset::Shop, resolution: 64, ..MillOptions::default() };
    let plain = mill_with(&part, &base);
    for datum in [Datum::TopCentre, Datum::Corner] {
        let m = mill_with(&part, &MillOptions { datum: Some(datum), ..base.clone() });
        assert!(
            (m.metrics.iou - plain.metrics.iou).abs() < 1e-3,
            "{datum:?}: {} vs {}",
            m.metrics.iou,
            plain.metrics.iou
        );
        assert_eq!(m.simulation.gouge_voxels, 0);
        let report = m.report_json(false);
        assert_eq!(report["datum"]["work_offset"], "G54");
        assert_eq!(report["datum"]["origins"].as_array().map(Vec::len), Some(m.setups.len()));
        for (i, (text, s)) in m.programs.iter().zip(&m.setups).enumerate() {
            let head: String = text.lines().take(4).collect::<Vec<_>>().join("\n");
            assert!(head.contains("WCS G54 X0 Y0 Z0"), "{datum:?} setup {}: header\n{head}", i + 1);
            let mut feeds = Feeds::default();
            parse_str(text, &ParseOptions::default(), &mut feeds).expect("parses");
            let r = s.action.tool_radius;
            // Feed moves start at most half a layer above the stock top.
            let top = feeds.0.iter().map(|p| p.z).fold(f64::NEG_INFINITY, f64::max);
            assert!(top <= s.action.layer_height, "{datum:?} setup {}: feed at Z{top}", i + 1);
            let lo = feeds.0.iter().fold([f64::INFINITY; 2], |a, p| [a[0].min(p.x), a[1].min(p.y)]);
            let hi = feeds.0.iter().fold([f64::NEG_INFINITY; 2], |a, p| [a[0].max(p.x), a[1].max(p.y)]);
            let half = 0.5 * m.stock.extent().norm() + r + 1e-6;
            match datum {
                // The tool centre stays within a radius of the stock's outline, which
                // starts at X0 Y0.
                Datum::Corner => assert!(lo[0] >= -r - 1e-6 && lo[1] >= -r - 1e-6, "{lo:?}"),
                // The stock's centre is X0 Y0.
                Datum::TopCentre => {
                    assert!(lo.iter().chain(&hi).all(|c| c.abs() <= half), "{lo:?} {hi:?} beyond {half}")
                }
            }
        }
    }
    assert!(plain.report_json(false).get("datum").is_none(), "no datum unless asked");
}

/// A 40 x 20 mm block 10 mm thick with a slot 4.5 mm wide and 8 mm deep across its top:
/// narrower than the 8 mm end mill that roughs it.
fn slotted_block() -> Mesh {
    extruded(
        &[[0., 0.], [40., 0.], [40., 20.], [22.25, 20.], [22.25, 12.], [17.75, 12.], [17.75, 20.], [0., 20.]],
        10.0,
    )
}

/// Rest roughing (issue 35): every setup roughed with an 8 mm end mill leaves the 4.5 mm
/// slot full; the rest pass with the library's smaller end mill over the simulated
/// in-process stock cuts it out, safely (no gouge, rapid through material or holder
/// contact), and its programs say which setup they machine again with which tool.
#[test]
fn rest_roughing_cuts_the_slot_the_roughing_tool_is_too_wide_for() {
    let part = slotted_block();
    let slot = 4.5 * 8.0 * 10.0;
    let run = |rest: usize| rest_run(&part, rest, MillOptions::default().rest_continue, None);
    let (without, with) = (run(0), run(2));
    for m in [&without, &with] {
        assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
        assert!(m.simulation.holder_collisions.is_empty(), "holder {:?}", m.simulation.holder_collisions);
    }
    assert!(without.setups.iter().all(|s| s.rest_of.is_none() && s.tool.diameter() == 8.0));
    let rest: Vec<_> = with.setups.iter().filter(|s| s.rest_of.is_some()).collect();
    assert!(!rest.is_empty(), "no rest-roughing program");
    // 8 mm, then at most 0.7 times as wide each pass: 5 mm (still too wide), then 3 mm.
    for s in &rest {
        assert!(s.tool.diameter() < 8.0, "rest tool of {} mm", s.tool.diameter());
        assert!(s.text.contains("rest roughing of setup"), "the program does not say what it is");
    }
    let tools: Vec<_> = with
        .setups
        .iter()
        .map(|s| (s.rest_of, s.tool.diameter(), s.setup.tool_axis().into_inner()))
        .collect();
    assert!(rest.iter().any(|s| s.tool.diameter() < 4.5), "no rest tool fits the slot: {tools:?}");
    assert_eq!(with.programs.len(), with.setups.len());
    // The slot is 360 mm^3 of a 7,640 mm^3 part: cut out, the IoU gains most of its share.
    let gain = with.metrics.iou - without.metrics.iou;
    let share = slot / (40.0 * 20.0 * 10.0 - slot);
    assert!(
        gain > 0.6 * share,
        "IoU {} -> {} (slot share {share:.4})",
        without.metrics.iou,
        with.metrics.iou
    );
    let removed = (with.simulation.removed_volume_mm3 - without.simulation.removed_volume_mm3) / slot;
    assert!(removed > 0.7, "the rest pass removed {removed:.2} of the slot's volume");
}

/// The slotted block with 3 mm chamfers along its top edges: faces a ball finishes (a
/// setup with none is roughed to size and not finished).
fn chamfered_slotted_block() -> Mesh {
    extruded(
        &[
            [0., 0.],
            [40., 0.],
            [40., 17.],
            [37., 20.],
            [22.25, 20.],
            [22.25, 12.],
            [17.75, 12.],
            [17.75, 20.],
            [3., 20.],
            [0., 17.],
        ],
        10.0,
    )
}

/// The slotted block milled in the shop preset with an 8 mm end mill, `rest` passes at most
/// and `more` of the part's volume for a pass ([`MillOptions::rest_continue`]), finished where
/// `finish` says.
fn rest_run(part: &Mesh, rest: usize, more: f64, finish: Option<FinishChoice>) -> Milled {
    rest_run_opts(part, rest, more, finish, None, 64)
}

/// [`rest_run`] with the tool library `tools` and no finishing.
fn rest_run_with(
    part: &Mesh,
    rest: usize,
    more: f64,
    tools: Option<shape2gcode::toolpath::library::ToolLibrary>,
) -> Milled {
    rest_run_opts(part, rest, more, None, tools, 64)
}

fn rest_run_opts(
    part: &Mesh,
    rest: usize,
    more: f64,
    finish: Option<FinishChoice>,
    tools: Option<shape2gcode::toolpath::library::ToolLibrary>,
    resolution: usize,
) -> Milled {
    let opts =
        MillOptions { tools, rest_roughing: rest, rest_continue: more, finish, resolution, ..rest_options() };
    fixed_run(part, &opts)
}

/// The options of [`rest_run`]: the shop preset at 64^3, few samples.
fn rest_options() -> MillOptions {
    MillOptions {
        preset: Preset::Shop,
        resolution: 64,
        orient_points: 2048,
        metric_samples: 2000,
        surface_spacing: 0.5,
        ..MillOptions::default()
    }
}

/// `part` milled with `opts`, every setup roughed with an 8 mm end mill at 2 mm layers.
fn fixed_run(part: &Mesh, opts: &MillOptions) -> Milled {
    let mut run = MillRun::new(part, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:#}"));
    let action = shape2gcode::Action {
        tool_radius: 4.0,
        layer_height: 2.0,
        strategy: shape2gcode::StrategyKind::ZIGZAG,
    };
    while run.next_setup().is_some() {
        run.machine(action, &mut |_| {}).unwrap_or_else(|e| panic!("{e:#} ({e:?})"));
    }
    run.finish("fixed", &mut |_| {}).unwrap_or_else(|e| panic!("{e:#}"))
}

/// The three-tool rest chain on `part` with the default library (`with`) and without the
/// tools `left_out` picks (`without`), both checked safe: no gouge, no rapid through
/// material, no holder collision.
fn with_and_without(
    part: &Mesh,
    left_out: impl Fn(&shape2gcode::toolpath::library::LibraryTool) -> bool,
) -> (Milled, Milled) {
    let run = |all: bool| {
        let mut lib = MillOptions::default().library().clone();
        if !all {
            lib.tools.retain(|t| !left_out(t));
        }
        rest_run_with(part, 3, MillOptions::default().rest_continue, Some(lib))
    };
    let (with, without) = (run(true), run(false));
    for m in [&with, &without] {
        assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
        assert!(m.simulation.holder_collisions.is_empty(), "holder {:?}", m.simulation.holder_collisions);
    }
    (with, without)
}

/// Asserts that the run `with` more rest passes removed more than `least` of a feature of
/// `volume` mm³ beyond what the run `without` them did, and scores a higher IoU.
fn rest_took(with: &Milled, without: &Milled, volume: f64, least: f64) {
    let removed = (with.simulation.removed_volume_mm3 - without.simulation.removed_volume_mm3) / volume;
    let tools = with.setups.iter().map(|s| (s.rest_of, s.tool.diameter())).collect::<Vec<_>>();
    assert!(removed > least, "the rest passes removed {removed:.2} of the feature's volume: {tools:?}");
    assert!(with.metrics.iou > without.metrics.iou, "IoU {} -> {}", without.metrics.iou, with.metrics.iou);
}

/// A shop's order (issue 35): each setup roughed, rest-roughed, then finished, before the
/// next setup. Every rest program follows its own setup's program (or an earlier rest
/// program of the same setup), the setup's finishing is in its last program only, and in
/// that program the rest tool cuts before the finishing tool is changed in.
#[test]
fn each_setup_is_rest_roughed_before_it_is_finished_and_before_the_next_setup() {
    let choice = FinishChoice { scallop: 0.05, ..FinishChoice::default() };
    let chamfered = chamfered_slotted_block();
    let m = rest_run(&chamfered, 2, 0.0, Some(choice));
    assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
    // The programs grouped by setup, in machining order.
    let mut groups: Vec<Vec<&shape2gcode::SetupProgram>> = Vec::new();
    for s in &m.setups {
        match s.rest_of {
            None => groups.push(vec![s]),
            Some(k) => {
                assert_eq!(k, groups.len(), "a rest program of setup {k} after setup {}'s", groups.len());
                groups.last_mut().expect("a rest program after its setup's").push(s);
            }
        }
    }
    assert_eq!(groups.len(), m.orientation.setups.len());
    assert!(groups.iter().any(|g| g.len() > 1), "no setup was rest-roughed");
    let mut checked = 0;
    for (k, g) in groups.iter().enumerate() {
        let last = g.len() - 1;
        for (n, s) in g.iter().enumerate() {
            assert!(
                s.finish.is_none() || n == last,
                "setup {}, program {n} of {}: finishing before the last",
                k + 1,
                g.len()
            );
        }
        if last > 0
            && let Some(fin) = g[last].finish.as_ref()
        {
            checked += 1;
            let rest = g[last];
            let change = |t: u32| {
                rest.text.find(&format!("T{t} M6")).unwrap_or_else(|| panic!("no T{t} M6 in setup {}", k + 1))
            };
            assert!(
                change(rest.tool.number) < change(fin.tool.number),
                "setup {}: the finishing tool T{} comes before the rest tool T{}",
                k + 1,
                fin.tool.number,
                rest.tool.number
            );
            assert!(rest.tool.diameter() < g[0].tool.diameter());
            // The programs before the last do not change to the finishing tool either: the
            // own program's finishing, tentative until its roughing is simulated, was left
            // out once a rest pass was found worth it.
            for s in &g[..last] {
                let fin_change = format!("T{} M6", fin.tool.number);
                assert!(
                    !s.text.contains(&fin_change),
                    "setup {}: {fin_change} before its last program",
                    k + 1
                );
            }
        }
    }
    assert!(checked > 0, "no setup both rest-roughed and finished");
}

/// A setup whose rest rule finds no pass worth it (no material is enough for one) is planned,
/// written and simulated once, its finishing following its roughing in the program once the
/// roughing is simulated: its programs, the simulated stock, the report and the finished
/// surface's deviation are those of the run without rest roughing, which finishes each
/// setup's program with no question asked.
#[test]
fn a_setup_no_rest_pass_is_for_cuts_what_the_run_without_rest_roughing_cuts() {
    let choice = FinishChoice { scallop: 0.05, ..FinishChoice::default() };
    // Chamfered: its setups that see a chamfer are finished (a prismatic setup is not).
    let part = chamfered_slotted_block();
    let asked = rest_run(&part, 2, 1e6, Some(choice));
    let plain = rest_run(&part, 0, 1e6, Some(choice));
    assert!(asked.setups.iter().all(|s| s.rest_of.is_none()));
    assert!(asked.setups.iter().any(|s| s.finish.is_some()), "no setup is finished");
    assert_same_programs(&asked.programs, &plain.programs);
    assert_eq!(asked.simulation.removed_voxels, plain.simulation.removed_voxels);
    assert_eq!(asked.simulation.gouge_voxels, plain.simulation.gouge_voxels);
    assert_eq!(asked.residual.vertices(), plain.residual.vertices());
    let deviation = |m: &Milled| {
        m.setups
            .iter()
            .map(|s| s.finish.as_ref().map(|f| (f.deviation.max.to_bits(), f.deviation.mean.to_bits())))
            .collect::<Vec<_>>()
    };
    assert_eq!(deviation(&asked), deviation(&plain));
}

/// A 40 x 20 x 12 mm block with a slot 2.6 mm wide and 3 mm deep along its top: narrower
/// than the 3 mm end mill, the second rest tool after an 8 mm roughing one (8, 5, 3, 2).
fn narrow_slot_block() -> Mesh {
    extruded(
        &[[0., 0.], [40., 0.], [40., 12.], [21.3, 12.], [21.3, 9.], [18.7, 9.], [18.7, 12.], [0., 12.]],
        20.0,
    )
}

/// The rest chain goes down the library while material it may reach is left (issue 35): a
/// slot narrower than the second rest tool stays full with two passes, is cut by the third
/// tool where a third pass may follow, and with a volume no leftover reaches, no setup
/// gets a rest pass. With the library less its 2 mm end mill reaching 25 mm (T34), which
/// in a setup deeper than the 3 mm one reaches is the second rest tool after the 5 mm.
#[test]
fn a_slot_narrower_than_the_second_rest_tool_is_cut_by_a_third() {
    let part = narrow_slot_block();
    let slot = 2.6 * 3.0 * 20.0;
    let mut lib = MillOptions::default().library().clone();
    lib.tools.retain(|t| t.cutter.is_t_slot() || t.cutter.neck.is_none_or(|n| n.reach < 25.0));
    let run = |rest: usize, more: f64| rest_run_opts(&part, rest, more, None, Some(lib.clone()), 64);
    let two = run(2, 0.0);
    let three = run(3, 0.002);
    let capped = run(3, 1e9);
    for m in [&two, &three, &capped] {
        assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
    }
    let tools = |m: &Milled| m.setups.iter().map(|s| (s.rest_of, s.tool.diameter())).collect::<Vec<_>>();
    assert!(
        three.setups.iter().any(|s| s.tool.diameter() < 2.6),
        "no tool fits the slot: {:?}",
        tools(&three)
    );
    assert!(two.setups.iter().all(|s| s.tool.diameter() >= 3.0), "{:?}", tools(&two));
    rest_took(&three, &two, slot, 0.6);
    // No rest program where no pass may reach enough.
    for k in 1..=capped.orientation.setups.len() {
        let n = capped.setups.iter().filter(|s| s.rest_of == Some(k)).count();
        assert!(n <= 1, "setup {k}: {n} rest programs: {:?}", tools(&capped));
    }
    assert!(capped.setups.len() < three.setups.len(), "{:?} / {:?}", tools(&capped), tools(&three));
}

/// A rest pass runs only for material it is for (issue 35): over a block whose 12 mm slot
/// the 8 mm roughing tool clears, what is left is the roughing's terraces and the slot's
/// corners, so with the default least volume no setup is rest-roughed; every face is
/// prismatic, so no setup is finished either and the programs are the roughing-only run's
/// (a setup with sculpted faces leaves to its finisher what it takes, `rest_left`); with
/// none asked for, every setup gets its rest pass, and the part is the same to within the
/// terraces the rest pass leaves as they are.
#[test]
fn no_rest_pass_where_the_finisher_takes_what_is_left() {
    let wide = extruded(
        &[[0., 0.], [40., 0.], [40., 20.], [26., 20.], [26., 12.], [14., 12.], [14., 20.], [0., 20.]],
        10.0,
    );
    let choice = FinishChoice { scallop: 0.05, ..FinishChoice::default() };
    let default = rest_run(&wide, 3, MillOptions::default().rest_continue, Some(choice));
    let every = rest_run(&wide, 3, 0.0, Some(choice));
    for m in [&default, &every] {
        assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
    }
    // The part is prismatic: roughed to size, not finished, and its rest passes are those
    // of the roughing alone (none with the default least volume).
    let rough = rest_run(&wide, 3, MillOptions::default().rest_continue, None);
    assert!(default.setups.iter().all(|s| s.rest_of.is_none() && s.finish.is_none()));
    assert_eq!(default.programs, rough.programs);
    assert!(every.setups.iter().any(|s| s.rest_of.is_some()), "no rest pass with none asked for");
    assert!(
        (default.metrics.iou - every.metrics.iou).abs() < 0.01,
        "IoU {} without rest passes, {} with",
        default.metrics.iou,
        every.metrics.iou
    );
    let time = |m: &Milled| m.setups.iter().filter_map(|s| s.machine_time_s).sum::<f64>();
    assert!(
        time(&default) < time(&every),
        "{} s without rest passes, {} s with",
        time(&default),
        time(&every)
    );
}

/// A rest pass runs for a narrow groove the finisher does not enter, and at levels that
/// take it (issue 35; the turned shaft's 2.5 mm grooves, troughs seen from the side): over
/// a 40 x 20 x 12 mm block with a groove 2.2 mm wide along its top, its sides 1 mm deep and
/// its floor a V 1 mm deeper, finished, only the 2 mm end mill of the rest chain (8, then
/// 5, 3, 2) enters the groove, and at the roughing's 2 mm levels (the top face, then 2 mm
/// below it) it would cut none of it: above the lower level the V's flanks keep it out.
/// With the default least volume the 2 mm pass runs at levels no farther apart than its
/// radius: its lowest, 0.73 mm into the groove, takes 0.49 of it (2.19 x 0.73 x 20 mm³ of
/// 66), and the IoU rises over a run with no rest pass. The groove is sized in mm, the
/// grid at 0.16 mm voxels (13 across it, 12 down it): counted in voxels the removal is off
/// the exact one by at most a voxel across and a voxel down (0.15 of the groove), so more
/// than a third, whatever the lattice; nothing without the pass or at the roughing's
/// levels. (At 0.63 mm voxels the same program counted 0.71 of it on one lattice and 0.47
/// on the face grid's.)
#[test]
fn a_narrow_groove_the_finisher_does_not_enter_gets_its_rest_pass() {
    let part = extruded(
        &[
            [0., 0.],
            [40., 0.],
            [40., 12.],
            [21.1, 12.],
            [21.1, 11.],
            [20., 10.],
            [18.9, 11.],
            [18.9, 12.],
            [0., 12.],
        ],
        20.0,
    );
    let groove = (2.2 * 1.0 + 0.5 * 2.2 * 1.0) * 20.0;
    let choice = FinishChoice { scallop: 0.05, ..FinishChoice::default() };
    let run = |more: f64| rest_run_opts(&part, 3, more, Some(choice), None, 256);
    let (default, none) = (run(MillOptions::default().rest_continue), run(1e9));
    for m in [&default, &none] {
        assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
    }
    let tools = |m: &Milled| {
        m.setups
            .iter()
            .map(|s| (s.rest_of, s.tool.diameter(), s.finish.as_ref().map(|f| f.tool.diameter())))
            .collect::<Vec<_>>()
    };
    assert!(none.setups.iter().all(|s| s.rest_of.is_none()), "{:?}", tools(&none));
    assert!(
        default.setups.iter().any(|s| s.rest_of.is_some() && s.tool.diameter() < 2.2),
        "no rest tool narrower than the groove: {:?}",
        tools(&default)
    );
    // What the 2 mm flat rest tool can take: the groove's walls 2.2 mm apart from z 12 to
    // z 11, and the V down to z 11 - 0.2 / 2.2 (where its flanks are 2 mm apart, the floor
    // level `PlanOptions::floor_levels` adds), (2.2 + 0.5 (2.2 + 2.0) 0.2 / 2.2) 20 = 47.8
    // mm^3, 0.72 of the groove; the rest pass measures 0.63 at 256^3 (without the floor
    // level, at its two regular levels 11.88 and 11.27 only, 0.43).
    rest_took(&default, &none, groove, 0.6);
}

/// A `x` by `y` by `z` mm block with a square-cornered pocket over `[px0, px1] x [py0,
/// py1]` from its top down to `floor`.
fn pocketed_block([x, y, z]: [f64; 3], [px0, px1, py0, py1]: [f64; 4], floor: f64) -> Mesh {
    let p = Point3::new;
    let mut soup: Vec<[Point3; 3]> = Vec::new();
    // Each quad counter-clockwise seen from outside the part.
    let mut quad = |a: Point3, b: Point3, c: Point3, d: Point3| soup.extend([[a, b, c], [a, c, d]]);
    quad(p(0., 0., 0.), p(0., y, 0.), p(x, y, 0.), p(x, 0., 0.));
    quad(p(0., 0., 0.), p(x, 0., 0.), p(x, 0., z), p(0., 0., z));
    quad(p(x, 0., 0.), p(x, y, 0.), p(x, y, z), p(x, 0., z));
    quad(p(x, y, 0.), p(0., y, 0.), p(0., y, z), p(x, y, z));
    quad(p(0., y, 0.), p(0., 0., 0.), p(0., 0., z), p(0., y, z));
    quad(p(0., 0., z), p(x, 0., z), p(px1, py0, z), p(px0, py0, z));
    quad(p(x, 0., z), p(x, y, z), p(px1, py1, z), p(px1, py0, z));
    quad(p(x, y, z), p(0., y, z), p(px0, py1, z), p(px1, py1, z));
    quad(p(0., y, z), p(0., 0., z), p(px0, py0, z), p(px0, py1, z));
    quad(p(px0, py0, floor), p(px1, py0, floor), p(px1, py1, floor), p(px0, py1, floor));
    quad(p(px1, py0, floor), p(px0, py0, floor), p(px0, py0, z), p(px1, py0, z));
    quad(p(px1, py1, floor), p(px1, py0, floor), p(px1, py0, z), p(px1, py1, z));
    quad(p(px0, py1, floor), p(px1, py1, floor), p(px1, py1, z), p(px0, py1, z));
    quad(p(px0, py0, floor), p(px0, py1, floor), p(px0, py1, z), p(px0, py0, z));
    Mesh::from_soup(&soup).expect("a closed block")
}

/// A pocket's square corners get a rest pass (issue 35; example002's square cross holes):
/// roughed with the 8 mm end mill, a 14 mm pocket 6 mm deep keeps a fillet of radius 4 in
/// each corner, 82 mm³ in all, along the corners' bisectors. The rest rule finds it for
/// the next tool of the chain, the 5 mm end mill (50 mm³ of it lie outside the 5 mm
/// tool's own fillets), whose pass removes more than a quarter of it; lowering the rest
/// tool at six places at 0.95 of its radius, none on a bisector, the rule found too little
/// there for the 5 mm end mill (on main this test fails at the tool).
#[test]
fn a_pocket_s_square_corners_get_the_next_rest_tool() {
    let part = pocketed_block([40., 30., 12.], [13., 27., 8., 22.], 6.0);
    let fillets = 4.0 * (1.0 - std::f64::consts::FRAC_PI_4) * 16.0 * 6.0;
    let default = rest_run(&part, 1, MillOptions::default().rest_continue, None);
    let none = rest_run(&part, 0, 0.0, None);
    for m in [&default, &none] {
        assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
        assert!(m.simulation.holder_collisions.is_empty(), "holder {:?}", m.simulation.holder_collisions);
    }
    let tools = default.setups.iter().map(|s| (s.rest_of, s.tool.diameter())).collect::<Vec<_>>();
    assert!(default.setups.iter().any(|s| s.rest_of.is_some() && s.tool.diameter() == 5.0), "{tools:?}");
    rest_took(&default, &none, fillets, 0.25);
}

/// A narrow deep slot only a long-reach end mill reaches (issue 35: the LetterBlock's
/// strokes, the gear's tooth gaps): 2.9 mm wide, 16 mm long, 8 mm deep, roughed with the
/// 8 mm end mill. The rest chain passes over the 5 and 3 mm end mills (too wide for it) to
/// a 2 mm one: the plain one's 3 mm shank keeps it to its 6 mm of flutes below the stock's
/// top, the long-reach one (T32, neck to 12 mm) cuts the slot to its floor. Without the
/// long-reach tools in the library the slot's lowest 2 mm (93 mm³) stay; with them more
/// than half of that goes, with no holder collision (its neck and shank are simulated).
#[test]
fn a_narrow_deep_slot_is_cut_by_a_long_reach_end_mill() {
    let part = pocketed_block([30., 20., 14.], [7., 23., 8.55, 11.45], 6.0);
    let (with, without) = with_and_without(&part, |t| t.cutter.neck.is_some());
    let tools = with.setups.iter().map(|s| (s.rest_of, s.tool.number)).collect::<Vec<_>>();
    assert!(with.setups.iter().any(|s| s.rest_of.is_some() && s.tool.number == 32), "{tools:?}");
    rest_took(&with, &without, 2.9 * 16.0 * 2.0, 0.5);
}

/// T-slot cutters (issue 35) on the shop parts' T-slot block (100 x 60 x 40 mm, a T-slot
/// along X: neck 12 x 12 mm, wings 22 mm wide and 10 high from z 18 to 28): the wings are
/// an undercut from +Z, and the X setups' end mills reach only so far in from the slot's
/// ends. Without the library's T-slot cutters the middle of the wings stays; with them one
/// undercut pass enters the disc from the slot's open end at the wings' height (every cut
/// between their floor and roof less the disc's thickness), the neck through the slot
/// above, and takes it, safely (no gouge, no rapid through material, the neck, shank and
/// holder touching no stock), in a program that changes to the cutter.
#[test]
fn a_t_slot_cutter_takes_the_wings_from_the_side() {
    let part = s2g_gen::shop_part(4).expect("the T-slot block");
    assert_eq!(part.name, "t_slot_block");
    let lib = shape2gcode::default_tool_library().clone();
    let mut plain = lib.clone();
    plain.tools.retain(|t| !t.cutter.is_t_slot());
    let run = |tools| {
        let opts = MillOptions {
            tools: Some(tools),
            preset: Preset::Shop,
            resolution: 64,
            orient_points: 2048,
            metric_samples: 2000,
            ..MillOptions::default()
        };
        mill_with(&part.mesh, &opts)
    };
    let (without, with) = (run(plain), run(lib));
    for m in [&without, &with] {
        assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
        assert!(m.simulation.holder_collisions.is_empty(), "holder {:?}", m.simulation.holder_collisions);
    }
    assert!(without.setups.iter().all(|s| !s.tool.cutter.is_t_slot()));
    let slots: Vec<_> = with.setups.iter().filter(|s| s.tool.cutter.is_t_slot()).collect();
    assert_eq!(slots.len(), 1, "one undercut pass");
    let s = slots[0];
    assert!(s.rest_of.is_some() && s.text.contains("undercut pass of setup"), "{}", &s.text[..400]);
    let n = s.tool.number;
    for word in [format!("T{n} M6"), format!("G43 H{n}")] {
        assert!(s.text.contains(&word), "no {word:?}");
    }
    // Every feed move at a level between the wings' floor and their roof less the disc.
    let t = s.tool.cutter.flute_length;
    let mut cuts = 0;
    let mut z = f64::NAN;
    for line in s.text.lines().filter(|l| !l.starts_with('(')) {
        if let Some(w) = line.split_whitespace().find(|w| w.starts_with('Z')) {
            z = w[1..].parse().unwrap_or(f64::NAN);
        }
        let first = line.split_whitespace().next().unwrap_or("");
        if ["G1", "G2", "G3"].contains(&first)
            || (first.starts_with('X') || first.starts_with('Y')) && z < 30.0
        {
            assert!((18.0..=28.0 - t).contains(&z), "a cut at z {z}: {line}");
            cuts += 1;
        }
    }
    assert!(cuts > 10, "{cuts} cuts");
    let removed = with.simulation.removed_volume_mm3 - without.simulation.removed_volume_mm3;
    assert!(removed > 500.0, "the undercut pass removed {removed:.0} mm^3");
    assert!(
        with.metrics.iou > without.metrics.iou + 0.003,
        "IoU {} -> {}",
        without.metrics.iou,
        with.metrics.iou
    );
}

/// A slot deeper than the plain 3 mm end mill reaches (example007's cross slots, 4 mm wide
/// and 22 mm below its top): 4 x 12 mm, 24 mm deep in a 30 x 20 x 30 mm block, open only
/// from above. The 3 mm end mill's holder stops it about 18 mm down, the 2 mm one reaching
/// 12 mm (T32) shallower; without the 2 mm end mill reaching 25 mm (T34) in the library the
/// slot's lowest 6 mm (288 mm³) stay. With it, the rest rule takes it (of the tools after
/// the 5 mm one it reaches deepest, and the stiffer 3 mm one takes less), and more than half
/// of that goes, with no gouge, rapid through material or holder collision (its neck and
/// shank are simulated).
#[test]
fn a_slot_deeper_than_the_3_mm_end_mill_reaches_is_cut_by_the_25_mm_long_reach_one() {
    let part = pocketed_block([30., 20., 30.], [13., 17., 4., 16.], 6.0);
    let reaches_25 = |t: &shape2gcode::toolpath::library::LibraryTool| {
        !t.cutter.is_t_slot() && t.cutter.neck.is_some_and(|n| n.reach >= 25.0)
    };
    let lib = MillOptions::default().library().clone();
    assert!(lib.tools.iter().any(reaches_25), "a long-reach end mill to 25 mm");
    let (with, without) = with_and_without(&part, reaches_25);
    let tools = with.setups.iter().map(|s| (s.rest_of, s.tool.number)).collect::<Vec<_>>();
    assert!(with.setups.iter().any(|s| s.rest_of.is_some() && s.tool.number == 34), "{tools:?}");
    rest_took(&with, &without, 4.0 * 12.0 * 6.0, 0.5);
}

/// The feed moves of a program: from, to, feed.
#[derive(Default)]
struct Moves(Option<Point3>, Vec<(Point3, Point3, f64)>);

impl MotionSink for Moves {
    type Error = std::convert::Infallible;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        let (to, feed) = match m {
            Motion::Rapid { to, .. } => (*to, None),
            Motion::Linear { to, feed, .. } => (*to, Some(*feed)),
            Motion::Arc { to, .. } => (*to, None),
            _ => return Ok(()),
        };
        if let (Some(from), Some(f)) = (self.0, feed) {
            self.1.push((from, to, f));
        }
        self.0 = Some(to);
        Ok(())
    }
}

/// Entries fed as a CAM engineer feeds them: a ramp into material at the cutting feed
/// unless its descent would then outrun the plunge feed, a descent in air at the cutting
/// feed, a straight plunge into material at the plunge feed. On a block with a 4 x 12 mm slot 24 mm deep the rest tools ramp
/// into the slot and go down in air beside the block. (Before, every entry crawled at the
/// plunge feed: on the gear the 1 mm end mill's 1,456 entries, 1,184 of them in air, took
/// 2,250 of its 4,180 s.)
#[test]
fn ramps_and_descents_in_air_are_fed_at_the_cutting_feed_within_the_plunge_feed() {
    let part = pocketed_block([30., 20., 30.], [13., 17., 4., 16.], 6.0);
    let m = rest_run_with(&part, 3, MillOptions::default().rest_continue, None);
    assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
    let (mut ramps, mut in_air, mut plunges) = (0, 0, 0);
    for (i, s) in m.setups.iter().enumerate() {
        let mut moves = Moves::default();
        parse_str(&s.text, &ParseOptions::default(), &mut moves).expect("parses");
        let (feed, plunge) = (s.tool.feed, s.tool.plunge_feed);
        let close = |a: f64, b: f64| (a - b).abs() <= 2e-3 * b.max(1.0);
        for (from, to, f) in moves.1 {
            let drop = from.z - to.z;
            if drop <= 1e-6 {
                continue;
            }
            let run = (to.x - from.x).hypot(to.y - from.y);
            let len = run.hypot(drop);
            let at = format!("setup {} T{}: {from:?} -> {to:?} F{f}", i + 1, s.tool.number);
            if run > 1e-3 {
                ramps += 1;
                assert!(f * drop / len <= plunge * 1.01, "a ramp descends faster than F{plunge}: {at}");
                assert!(close(f, feed.min(plunge * len / drop)), "a ramp fed slower than it may: {at}");
            } else if close(f, feed) {
                in_air += 1;
            } else {
                assert!(close(f, plunge), "{at}");
                plunges += 1;
            }
        }
    }
    assert!(ramps > 0 && in_air > 0, "ramp legs {ramps}, descents in air {in_air}, plunges {plunges}");
}

/// Between two paths the tool crosses above the stock's top, where nothing lies, rather
/// than at the clearance plane: on a block with a slot, every roughing and rest program
/// crosses from one path to the next below the clearance plane it starts at, and the
/// simulation finds no rapid through material. (Before, where no
/// level's free region held the crossing, the tool rose to the clearance plane: on the
/// gear's 1 mm end mill 1,456 times, 10 mm up and down between tooth gaps.)
#[test]
fn between_paths_the_tool_crosses_just_above_the_stock_not_at_the_clearance_plane() {
    let part = pocketed_block([30., 20., 30.], [13., 17., 4., 16.], 6.0);
    let m = rest_run_with(&part, 3, MillOptions::default().rest_continue, None);
    assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
    let mut crossings = 0;
    for (i, s) in m.setups.iter().enumerate() {
        let mut moves = Rapids::default();
        parse_str(&s.text, &ParseOptions::default(), &mut moves).expect("parses");
        let clear = moves.1.first().map_or(f64::INFINITY, |m| m.1.z);
        let (first, last) = (moves.2.unwrap_or(0), moves.3.unwrap_or(0));
        for (k, (from, to)) in moves.1.iter().enumerate() {
            let across = (to.x - from.x).hypot(to.y - from.y) > 1e-6;
            if across && k > first && k < last {
                crossings += 1;
                let at = format!("setup {} T{}: {from:?} -> {to:?}", i + 1, s.tool.number);
                assert!(to.z < clear - 1e-6, "crossed at the clearance plane Z{clear}: {at}");
            }
        }
    }
    assert!(crossings > 0, "no crossing between paths");
}

/// The rapids of a program (from, to) and the indices (into them) of the first and last
/// rapid after which a feed move follows.
#[derive(Default)]
struct Rapids(Option<Point3>, Vec<(Point3, Point3)>, Option<usize>, Option<usize>);

impl MotionSink for Rapids {
    type Error = std::convert::Infallible;
    fn motion(&mut self, m: &Motion<'_>) -> Result<(), Self::Error> {
        let to = match m {
            Motion::Rapid { to, .. } => {
                if let Some(from) = self.0 {
                    self.1.push((from, *to));
                }
                *to
            }
            Motion::Linear { to, .. } | Motion::Arc { to, .. } => {
                let k = self.1.len().saturating_sub(1);
                self.2.get_or_insert(k);
                self.3 = Some(k);
                *to
            }
            _ => return Ok(()),
        };
        self.0 = Some(to);
        Ok(())
    }
}

/// With `face_grid` the simulation's voxel planes go through the part's flat faces (issue
/// 35; the stress bushings): an inverted T 30 mm wide and 40 voxels deep (at 64 voxels over
/// 30 mm), its boss 16 voxels wide from 24, its flange's top 6 voxels up and its boss's top
/// 20.5, whose box centred in a cube of its longest side (the lattice without the option)
/// puts the flange's top a quarter voxel off the grid's planes. The residual's marching
/// cubes then put the flange's top a quarter voxel (0.12 mm) too high, and a scorer whose
/// cell centres fall in between counts a whole layer of cells as stock left; on the planes
/// through the part's largest flat faces it is where the part has it.
#[test]
fn the_simulation_s_voxel_planes_go_through_the_part_s_flat_faces() {
    let h = 30.0 / 64.0;
    let (f, top) = (6.0 * h, 20.5 * h);
    let (b0, b1) = (24.0 * h, 40.0 * h);
    let part = extruded(
        &[[0.0, 0.0], [30.0, 0.0], [30.0, f], [b1, f], [b1, top], [b0, top], [b0, f], [0.0, f]],
        40.0 * h,
    );
    let opts = MillOptions {
        preset: Preset::Shop,
        resolution: 64,
        orient_points: 2048,
        metric_samples: 2000,
        face_grid: true,
        ..MillOptions::default()
    };
    let m =
        mill(&part, &mut HeuristicPolicy::default(), &opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:#}"));
    assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
    // The residual's highest point over the flange on either side of the boss, away from
    // its edges: the flange's top.
    let over = |x0: f64, x1: f64| {
        m.residual
            .vertices()
            .iter()
            .filter(|p| (x0..=x1).contains(&p.x) && (4.0..=16.0).contains(&p.y))
            .map(|p| p.z)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    for (x0, x1) in [(2.0, 8.0), (22.0, 28.0)] {
        let z = over(x0, x1);
        assert!((z - f).abs() < 0.01 * h, "the flange's top at {z} over x {x0}..{x1}, the part's at {f}");
    }
    // The boss's top, half a voxel off any lattice through the flange's faces (on its
    // voxel centres, which the lattice leaves by 1/256 of a voxel), is within a voxel.
    let z = over(12.0, 18.0);
    assert!((z - top).abs() <= h, "the boss's top at {z}, the part's at {top}");
}

/// A closed mesh of the cells `filled(i, j, k)` holds on a grid of `n` cells of `cell` mm:
/// one outward quad per face between a filled cell and an empty one (no two filled cells
/// may meet along an edge alone).
fn cells(n: [usize; 3], cell: f64, filled: impl Fn(usize, usize, usize) -> bool) -> Mesh {
    let at = |i: usize, j: usize, k: usize| i < n[0] && j < n[1] && k < n[2] && filled(i, j, k);
    let mut soup: Vec<[Point3; 3]> = Vec::new();
    for (i, j, k) in (0..n[0]).flat_map(|i| (0..n[1]).flat_map(move |j| (0..n[2]).map(move |k| (i, j, k)))) {
        if !at(i, j, k) {
            continue;
        }
        for axis in 0..3 {
            for side in [0usize, 1] {
                let mut c = [i, j, k];
                if side == 1 {
                    c[axis] += 1;
                } else if c[axis] == 0 {
                    c[axis] = usize::MAX;
                } else {
                    c[axis] -= 1;
                }
                if c[axis] != usize::MAX && at(c[0], c[1], c[2]) {
                    continue;
                }
                // The face's corners, counter-clockwise seen from outside.
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let corner = |du: usize, dv: usize| {
                    let mut q = [i as f64, j as f64, k as f64];
                    q[axis] += side as f64;
                    q[u] += du as f64;
                    q[v] += dv as f64;
                    Point3::new(q[0] * cell, q[1] * cell, q[2] * cell)
                };
                let (a, b, c, d) = (corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1));
                if side == 1 {
                    soup.extend([[a, b, c], [a, c, d]]);
                } else {
                    soup.extend([[a, c, b], [a, d, c]]);
                }
            }
        }
    }
    Mesh::from_soup(&soup).expect("a closed union of cells")
}

/// Orientation selection knows which tool fits where (issue 35's tool-aware reach; the
/// stress bushings' bolt holes): a 40 x 40 x 6 mm plate with a 12 x 12 mm post 30 mm tall
/// in its middle, a 4 mm square hole across the post along X, and four 4 mm square holes
/// through the plate 2 mm beside the post, from a stock the part's own box. Only the 3 mm
/// end mill (and narrower) fits the plate's holes, and its 35 mm holder at 21 mm
/// stick-out keeps it 21 mm below the stock's top, 15 mm above the plate, as the post
/// stands in the way; from below the holes are 6 mm deep. Judged by the longest end
/// mill's reach (66 mm) the holes counted as reached from +Z, and +Z with +X (the cross
/// hole, the bottom's flank) covered everything: no setup from below, the holes stayed
/// full (without [`MillOptions::tool_aware_reach`] this test fails there). With it a setup
/// from below is chosen and its rest passes cut them through.
#[test]
fn holes_beside_a_tall_post_are_cut_from_below_where_the_tool_that_fits_them_reaches() {
    // 2 mm cells: plate k < 3, post 14..26 mm to 36 mm, holes 2 x 2 cells.
    let holes = [[4usize, 9], [14, 9], [9, 4], [9, 14]];
    let in_hole = |i: usize, j: usize| {
        holes.iter().any(|h| (h[0]..h[0] + 2).contains(&i) && (h[1]..h[1] + 2).contains(&j))
    };
    let post = |i: usize, j: usize, k: usize| {
        (7..13).contains(&i) && (7..13).contains(&j) && !((9..11).contains(&j) && (9..11).contains(&k))
    };
    let part = cells([20, 20, 18], 2.0, |i, j, k| if k < 3 { !in_hole(i, j) } else { post(i, j, k) });
    let opts = MillOptions { stock: Stock::BoxSize([40.0, 40.0, 36.0]), ..rest_options() };
    let m = fixed_run(&part, &opts);
    assert!(m.is_safe(), "gouges {}, rapids {}", m.simulation.gouge_voxels, m.rapid_collisions());
    assert!(m.simulation.holder_collisions.is_empty(), "holder {:?}", m.simulation.holder_collisions);
    let axes: Vec<_> = m.setups.iter().map(|s| (s.setup.tool_axis().into_inner(), s.tool.number)).collect();
    assert!(m.setups.iter().any(|s| s.setup.tool_axis().z < -0.9), "no setup from below: {axes:?}");
    // The holes' middles, half way through the plate, are cut.
    let residual = shape2gcode::geom::MeshIndex::new(&m.residual).expect("a residual");
    for h in holes {
        let centre = Point3::new(2.0 * h[0] as f64 + 2.0, 2.0 * h[1] as f64 + 2.0, 3.0);
        assert!(!residual.contains(&centre), "the hole at {centre:?} is left: {axes:?}");
    }
}
