//! FDM reconstruction (seed 004): G-code to beads, solid and tubes, on real slicer output
//! (Cura `;LAYER:`, PrusaSlicer `;LAYER_CHANGE` with absolute and relative E, Slic3r without
//! layer markers) and on synthetic programs with known beads.

use shape2gcode::geom::{Mesh, Point3, load_mesh, report, save_mesh};
use shape2gcode::{
    BeadShape, Deposition, FdmError, FdmOptions, FdmOutput, Reconstruction, deposit_beads, extract_beads,
    profile_width, reconstruct, render_layer, render_result, save_step, sweep_spine,
};

use super::common::data;

const CUBES: [&str; 4] = [
    "cura_cube10_infill20_grid.gcode",
    "prusa_cube10_infill20_rectilinear.gcode",
    "slic3r_cube10_infill20_comments.gcode",
    "prusa_cube10_infill20_relative_e.gcode",
];
const DOGBONE: &str = "prusa_dogbone_iso527_1A_infill100.gcode";
const PROFILES: [BeadShape; 3] = [BeadShape::Slot, BeadShape::Rect, BeadShape::Circle];

fn gcode(name: &str) -> String {
    let p = data(&format!("fdm/gcode/{name}"));
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn run(name: &str, text: &str, profile: BeadShape, output: FdmOutput) -> Reconstruction {
    let opts = FdmOptions { profile, output, ..Default::default() };
    reconstruct(text, &opts).unwrap_or_else(|e| panic!("{name} {profile:?} {output:?}: {e}"))
}

/// XY extents of the mesh above `z_min` (the skirt and purge lines lie in the first layer)
/// and the Z range of the whole mesh (Cura purges at Z 0.28, so the cut is at 0.5).
fn extents(mesh: &Mesh, z_min: f64) -> ([f64; 2], [f64; 2]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let (mut z0, mut z1) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in mesh.vertices() {
        z0 = z0.min(v.z);
        z1 = z1.max(v.z);
        if v.z > z_min {
            for a in 0..2 {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
            }
        }
    }
    ([hi[0] - lo[0], hi[1] - lo[1]], [z0, z1])
}

#[test]
fn fdm_cube_solids_hold_the_extruded_volume_and_the_model_box() {
    for name in CUBES {
        let text = gcode(name);
        for profile in PROFILES {
            let r = run(name, &text, profile, FdmOutput::Solid);
            let rep = &r.report;
            let what = format!("{name} {profile:?}");
            assert!(rep.watertight, "{what}: solid not closed/manifold");
            assert_eq!(rep.layers, 50, "{what}: layers");
            assert!((rep.layer_height_mm - 0.2).abs() < 1e-6, "{what}: layer height {}", rep.layer_height_mm);
            assert!(rep.volume_error.abs() <= 0.03, "{what}: volume error {:+.4}", rep.volume_error);
            // As sliced, overlapping beads share volume: the raw union is below the extruded
            // volume, by a few percent for the flat profiles (more for circles, which overlap
            // between layers).
            let raw =
                rep.raw_voxel_volume_mm3.expect("solid has a raw volume") / rep.extruded_volume_mm3 - 1.0;
            let floor = if profile == BeadShape::Circle { -0.35 } else { -0.08 };
            assert!((floor..=0.005).contains(&raw), "{what}: raw union volume error {raw:+.4}");
            if profile != BeadShape::Circle {
                let half = 0.5 * rep.bead_width_mm;
                let (xy, z) = extents(&r.mesh, 0.5);
                for (a, e) in xy.iter().enumerate() {
                    assert!((e - 10.0).abs() <= half, "{what}: extent {a} is {e}, model 10 +- {half}");
                }
                assert!(z[0].abs() <= half && (z[1] - 10.0).abs() <= half, "{what}: z range {z:?}");
            }
        }
    }
}

#[test]
fn fdm_solid_passes_geoms_independent_checks_and_is_deterministic() {
    let name = CUBES[1];
    let text = gcode(name);
    let a = run(name, &text, BeadShape::Slot, FdmOutput::Solid);
    let m = report(&a.mesh);
    assert!(m.closed && m.manifold && m.consistently_oriented, "{name}: geom report {m:?}");
    assert!(
        (m.volume - a.report.solid_volume_mm3).abs() <= 1e-6 * m.volume,
        "{name}: volumes {} vs {}",
        m.volume,
        a.report.solid_volume_mm3
    );
    let b = run(name, &text, BeadShape::Slot, FdmOutput::Solid);
    assert!(a.mesh == b.mesh, "{name}: two runs differ");
}

#[test]
fn fdm_raster_agrees_with_voxsim_depositor() {
    let name = CUBES[1];
    let text = gcode(name);
    for profile in PROFILES {
        let opts = FdmOptions { profile, ..Default::default() };
        let ex = extract_beads(&text, &opts).expect("beads");
        let raster = deposit_beads(&ex, &opts, 1.0).expect("raster");
        let vs = deposit_beads(&ex, &FdmOptions { deposition: Deposition::Voxsim, ..opts.clone() }, 1.0)
            .expect("voxsim");
        let mut x = raster.clone();
        x.xor(&vs).expect("same grid");
        let n = raster.count();
        // voxsim groups beads by width (1 um quantum) and deposits the group's mean.
        assert!(
            (x.count() as f64) <= 0.01 * n as f64,
            "{name} {profile:?}: raster and voxsim differ in {} of {n} voxels",
            x.count()
        );
    }
}

#[test]
fn fdm_tubes_one_closed_body_per_spine() {
    for name in CUBES.iter().chain([&DOGBONE]) {
        let text = gcode(name);
        for profile in PROFILES {
            let r = run(name, &text, profile, FdmOutput::Tubes);
            let rep = &r.report;
            let what = format!("{name} {profile:?} tubes");
            assert!(rep.watertight, "{what}: a tube is open");
            assert_eq!(rep.bodies, rep.spines, "{what}: bodies");
            // Tubes are sized to the extruded volume per segment: rectangles exactly (mitred
            // joints trade wedges), slots within their joints, circles lose the 16-gon's
            // 2.6 % of the disc.
            let tol = match profile {
                BeadShape::Rect => 0.005,
                BeadShape::Slot => 0.02,
                BeadShape::Circle => 0.04,
            };
            assert!(rep.volume_error.abs() <= tol, "{what}: volume error {:+.4}", rep.volume_error);
        }
    }
}

/// A 10 mm square perimeter on two layers with known bead area `A = 0.08 mm^2`.
fn square_program(relative: bool) -> String {
    let fil = std::f64::consts::PI * 0.875 * 0.875;
    let e = 0.08 * 10.0 / fil;
    let mut s = String::from("G21\nG90\n");
    s += if relative { "M83\n" } else { "M82\n" };
    let mut acc = 0.0;
    for (l, z) in [0.2, 0.4].into_iter().enumerate() {
        s += &format!(";LAYER:{l}\nG0 X0 Y0 Z{z}\n");
        for (x, y) in [(10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)] {
            acc += e;
            let ew = if relative { e } else { acc };
            s += &format!("G1 X{x} Y{y} E{ew:.6} F1800\n");
        }
    }
    s
}

#[test]
fn fdm_bead_sizes_from_extrusion_and_overrides() {
    for relative in [false, true] {
        let text = square_program(relative);
        let ex = extract_beads(&text, &FdmOptions::default()).expect("square");
        assert_eq!((ex.spines.len(), ex.beads.len(), ex.layers), (2, 8, 2), "relative {relative}");
        for (l, h) in ex.layer_heights.iter().enumerate() {
            assert!((h - 0.2).abs() < 1e-12, "relative {relative}: layer {l} height {h}");
        }
        for b in &ex.beads {
            assert!((b.area - 0.08).abs() < 1e-6, "relative {relative}: area {}", b.area);
        }
        assert!((ex.extruded_volume - 6.4).abs() < 1e-4, "extruded {}", ex.extruded_volume);
        assert!((profile_width(BeadShape::Rect, 0.08, 0.2) - 0.4).abs() < 1e-12);
        let slot = 0.4 + 0.2 * (1.0 - std::f64::consts::PI / 4.0);
        assert!((profile_width(BeadShape::Slot, 0.08, 0.2) - slot).abs() < 1e-12);
    }
    let text = square_program(false);
    let fixed = FdmOptions {
        profile: BeadShape::Rect,
        width: Some(0.5),
        layer_height: Some(0.25),
        ..Default::default()
    };
    let ex = extract_beads(&text, &fixed).expect("square, fixed sizes");
    assert!(ex.beads.iter().all(|b| (b.area - 0.125).abs() < 1e-12 && b.height == 0.25));
    // A closed square spine becomes a ring: rect ring volume = A * centre-line length.
    let (mut v, mut t) = (Vec::new(), Vec::new());
    let opts = FdmOptions { profile: BeadShape::Rect, ..Default::default() };
    let ex = extract_beads(&text, &opts).expect("square");
    sweep_spine(&ex.spines[0], &[0.08; 4], 0.2, &opts, &mut v, &mut t);
    let ring = Mesh::new(v, t).expect("ring mesh");
    let r = report(&ring);
    assert!(r.closed && r.manifold && r.consistently_oriented, "ring {r:?}");
    assert_eq!(r.euler_characteristic, 0, "a closed spine is a torus");
    assert!((r.volume - 3.2).abs() < 1e-9, "ring volume {}", r.volume);
    // An open straight spine: a capped prism of volume A * L.
    let (mut v, mut t) = (Vec::new(), Vec::new());
    let line = [Point3::new(0.0, 0.0, 0.2), Point3::new(5.0, 0.0, 0.2), Point3::new(5.0, 3.0, 0.2)];
    sweep_spine(&line, &[0.08, 0.08], 0.2, &opts, &mut v, &mut t);
    let r = report(&Mesh::new(v, t).expect("prism"));
    assert!(r.closed && r.manifold && r.consistently_oriented && r.euler_characteristic == 2, "{r:?}");
    assert!((r.volume - 0.64).abs() < 1e-9, "L volume {}", r.volume);
}

#[test]
fn fdm_truncated_and_corrupt_programs() {
    let name = CUBES[1];
    let text = gcode(name);
    let full = run(name, &text, BeadShape::Rect, FdmOutput::Tubes).report;
    // Cut in the middle of a line.
    let mut cut = text.len() * 3 / 5;
    while text.as_bytes()[cut - 1] == b'\n' || text.as_bytes()[cut] == b'\n' || !text.is_char_boundary(cut) {
        cut += 1;
    }
    let line = text[..cut].lines().count();
    let part = run(name, &text[..cut], BeadShape::Rect, FdmOutput::Tubes).report;
    assert!(
        part.warnings.iter().any(|w| w.starts_with(&format!("line {line}:"))),
        "truncated at line {line}: warnings {:?}",
        part.warnings
    );
    assert!(
        part.extruded_volume_mm3 > 0.3 * full.extruded_volume_mm3
            && part.extruded_volume_mm3 < 0.9 * full.extruded_volume_mm3,
        "truncated volume {} of {}",
        part.extruded_volume_mm3,
        full.extruded_volume_mm3
    );
    assert!(part.watertight);
    // A corrupt line in the middle: skipped with a warning naming it, or an error when strict.
    let mut lines: Vec<&str> = text.lines().collect();
    lines.insert(1499, "G1 X1..2 Y3 E0.5");
    let bad = lines.join("\n") + "\n";
    let r = run(name, &bad, BeadShape::Rect, FdmOutput::Tubes).report;
    assert!(r.warnings.iter().any(|w| w.starts_with("line 1500:")), "warnings {:?}", r.warnings);
    let strict = FdmOptions { strict: true, ..Default::default() };
    match reconstruct(&bad, &strict) {
        Err(FdmError::Gcode(m)) => assert!(m.contains(":1500:"), "strict error {m}"),
        other => panic!("strict: expected a G-code error, got {:?}", other.map(|r| r.report)),
    }
    // Nothing extruded.
    for junk in ["", "\u{0}\u{1}binary\u{ff}\n@@@\n", "G0 X1 Y1\nG1 X2 Y2 F100\n"] {
        match reconstruct(junk, &FdmOptions::default()) {
            Err(FdmError::NoExtrusion { .. }) => {}
            other => panic!("{junk:?}: expected NoExtrusion, got {:?}", other.map(|r| r.report)),
        }
    }
    // Bad options are errors, not panics.
    let neg = FdmOptions { width: Some(-1.0), ..Default::default() };
    assert!(matches!(reconstruct(&text, &neg), Err(FdmError::InvalidOption(_))));
}

#[test]
fn fdm_dogbone_at_full_infill() {
    let text = gcode(DOGBONE);
    let r = run(DOGBONE, &text, BeadShape::Slot, FdmOutput::Solid);
    let rep = &r.report;
    assert!(rep.watertight, "dogbone solid not closed/manifold");
    assert_eq!(rep.layers, 20, "dogbone layers");
    assert!(rep.volume_error.abs() <= 0.03, "dogbone volume error {:+.4}", rep.volume_error);
    // The model: 170 x 20 x 4 mm, 9600.6 mm^3; at 100 % infill the solid is close to it.
    let half = 0.5 * rep.bead_width_mm;
    let (xy, z) = extents(&r.mesh, 0.5);
    assert!((xy[0] - 170.0).abs() <= half && (xy[1] - 20.0).abs() <= half, "dogbone extents {xy:?}");
    assert!(z[0].abs() <= half && (z[1] - 4.0).abs() <= half, "dogbone z {z:?}");
    assert!((rep.solid_volume_mm3 / 9600.62 - 1.0).abs() < 0.05, "dogbone volume {}", rep.solid_volume_mm3);
    eprintln!("dogbone solid: {:?}", rep.stage_seconds);
}

/// `prusa-slicer --info`: an independent reader of STEP (through OpenCASCADE) and of 3MF.
/// It runs headless (no display, no `xvfb-run`). `.ci/run` installs it; a missing one
/// fails the test rather than skipping the check.
fn prusa_info(path: &std::path::Path) -> std::process::Child {
    std::process::Command::new("prusa-slicer")
        .arg("--info")
        .arg(path)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| {
            panic!(
                "prusa-slicer --info {}: {e}. PrusaSlicer is the independent STEP and 3MF reader of \
                 these tests: install it with `apt-get install -y --no-install-recommends prusa-slicer` \
                 (Debian/Ubuntu; .ci/run does this)",
                path.display()
            )
        })
}

/// The facets and volume `prusa-slicer --info` reports for its one file.
fn prusa_facets_and_volume(what: &str, child: std::process::Child) -> (usize, f64) {
    let out = child.wait_with_output().expect("prusa-slicer ran");
    let text = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{what}: prusa-slicer --info failed ({}):\n{text}", out.status);
    let field = |k: &str| {
        text.lines()
            .find_map(|l| {
                l.trim()
                    .strip_prefix(k)
                    .and_then(|r| r.trim().strip_prefix('='))
                    .map(|v| v.trim().to_string())
            })
            .unwrap_or_else(|| panic!("{what}: no {k} in prusa-slicer --info output:\n{text}"))
    };
    assert_eq!(field("manifold"), "yes", "{what}: PrusaSlicer finds the mesh not manifold");
    (field("number_of_facets").parse().expect("facets"), field("volume").parse().expect("volume"))
}

#[test]
fn fdm_step_export_reads_back() {
    // OpenCASCADE needs about 1 ms of CPU per facet (the cube's 150k-facet solid at
    // 0.2 mm takes minutes), so the reader checks the cube's tubes (10k facets), the
    // cube's solid at 0.8 mm (19k facets, with voids and 400 bodies) and a small
    // two-layer square; the cube's solid at 0.2 mm is checked structurally. The
    // readers run in parallel with the reconstructions.
    let name = CUBES[1];
    let cube = gcode(name);
    let square = square_program(false);
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = [
        ("cube tubes", &cube, FdmOutput::Tubes, BeadShape::Rect, None, true),
        ("cube solid", &cube, FdmOutput::Solid, BeadShape::Slot, Some(0.2), false),
        ("coarse cube solid", &cube, FdmOutput::Solid, BeadShape::Slot, Some(0.8), true),
        ("square solid", &square, FdmOutput::Solid, BeadShape::Slot, None, true),
    ];
    let mut readers = Vec::new();
    for (what, text, output, profile, res, read_back) in cases {
        let opts = FdmOptions { profile, output, resolution: res, ..Default::default() };
        let r = reconstruct(text, &opts).expect("reconstructs");
        let path = dir.path().join(format!("{}.step", what.replace(' ', "_")));
        save_step(&path, &r.mesh).expect("STEP written");
        let step = std::fs::read_to_string(&path).expect("STEP read");
        assert!(step.starts_with("ISO-10303-21;") && step.trim_end().ends_with("END-ISO-10303-21;"));
        assert!(step.contains("AUTOMOTIVE_DESIGN"), "{what}: AP214 schema");
        let faces = step.matches("FACE_SURFACE(").count();
        assert_eq!(faces, r.mesh.triangles().len(), "{what}: one face per triangle");
        if output == FdmOutput::Tubes {
            assert_eq!(step.matches("=FACETED_BREP(").count(), r.report.spines, "{what}: one body per spine");
        } else {
            // Every void surface of the solid is a void of a body.
            let voids = step.matches("ORIENTED_CLOSED_SHELL(").count();
            let shells = step.matches("=CLOSED_SHELL(").count();
            assert_eq!(
                shells,
                step.matches("=FACETED_BREP(").count() + step.matches("=BREP_WITH_VOIDS(").count() + voids
            );
            if what == "coarse cube solid" {
                assert!(voids > 0, "{what}: the reader should see a solid with voids");
            }
        }
        if read_back {
            readers.push((what, prusa_info(&path), faces, r.report.solid_volume_mm3));
        }
    }
    for (what, child, faces, v) in readers {
        let (facets, volume) = prusa_facets_and_volume(what, child);
        assert_eq!(facets, faces, "{what}: OpenCASCADE facets");
        assert!((volume - v).abs() <= 0.002 * v, "{what}: OpenCASCADE volume {volume} vs {v}");
    }
}

#[test]
fn fdm_3mf_export_reads_back() {
    // PrusaSlicer's own 3MF reader (not OpenCASCADE) takes the 150k-facet solid in ~1 s.
    let name = CUBES[1];
    let dir = tempfile::tempdir().expect("temp dir");
    let opts = FdmOptions { resolution: Some(0.2), ..Default::default() };
    let r = reconstruct(&gcode(name), &opts).expect("reconstructs");
    let path = dir.path().join("cube_solid.3mf");
    save_mesh(&path, &r.mesh).expect("3MF written");
    let reader = prusa_info(&path);
    let back = load_mesh(&path).expect("3MF loads");
    assert!(back == r.mesh, "3MF round trip is exact");
    let (facets, volume) = prusa_facets_and_volume("cube solid 3MF", reader);
    assert_eq!(facets, r.mesh.triangles().len(), "PrusaSlicer facets");
    let v = r.report.solid_volume_mm3;
    // PrusaSlicer holds coordinates in f32.
    assert!((volume - v).abs() <= 1e-4 * v, "PrusaSlicer volume {volume} vs {v}");
}

#[test]
fn fdm_layer_render_covers_the_beads() {
    let text = square_program(false);
    let opts = FdmOptions::default();
    let r = reconstruct(&text, &opts).expect("square");
    let px = 40.0;
    let img = render_layer(&r.extrusion, 0, BeadShape::Slot, px).expect("layer 0 has beads");
    let painted = img.rgb.chunks(3).filter(|c| c != &[250, 250, 252]).count() as f64 / (px * px);
    // A 10 mm square ring of 0.4 mm equal-area beads: 10.4^2 - 9.6^2 = 16 mm^2, minus the
    // rounding of the four outer corners.
    let ring = 16.0 - (4.0 - std::f64::consts::PI) * 0.04;
    assert!((painted - ring).abs() < 0.03 * ring, "painted {painted} mm^2, ring {ring} mm^2");
    assert!(render_layer(&r.extrusion, 7, BeadShape::Slot, px).is_none(), "no layer 7");
    let png = render_result(&r.mesh, 128).expect("mesh").to_png();
    assert!(png.starts_with(b"\x89PNG"), "PNG signature");
}

#[test]
fn fdm_climbing_beads_go_through_voxsim() {
    // A flat 10 mm line, then a ramp climbing 1 mm over 10 mm (non-planar printing): the
    // raster takes the flat bead, voxsim the ramp; all-voxsim must agree.
    let fil = std::f64::consts::PI * 0.875 * 0.875;
    let ramp_len = (100.0f64 + 1.0).sqrt();
    let e1 = 0.08 * 10.0 / fil;
    let e2 = e1 + 0.08 * ramp_len / fil;
    let text = format!(
        "G21\nG90\nM82\n;LAYER:0\nG0 X0 Y0 Z0.2\nG1 X10 Y0 E{e1:.6} F1200\nG0 X0 Y5 Z0.2\nG1 X10 Y5 Z1.2 E{e2:.6}\n"
    );
    let opts = FdmOptions { profile: BeadShape::Rect, match_volume: false, ..Default::default() };
    let ex = extract_beads(&text, &opts).expect("ramp program");
    assert_eq!(ex.beads.len(), 2, "two beads");
    let raster = deposit_beads(&ex, &opts, 1.0).expect("raster + voxsim");
    let vs = deposit_beads(&ex, &FdmOptions { deposition: Deposition::Voxsim, ..opts.clone() }, 1.0)
        .expect("voxsim");
    let mut x = raster.clone();
    x.xor(&vs).expect("same grid");
    assert!(
        (x.count() as f64) <= 0.02 * raster.count() as f64,
        "raster+voxsim and voxsim differ in {} of {} voxels",
        x.count(),
        raster.count()
    );
    // A rectangle swept along a climbing path is a sheared prism: w h L_xy per bead.
    let expect = 2.0 * 0.4 * 0.2 * 10.0;
    let v = raster.volume();
    assert!((v - expect).abs() <= 0.1 * expect, "ramp solid volume {v}, expected {expect}");
}
