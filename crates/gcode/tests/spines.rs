//! Extrusion spines (seed 004 §2.1-2.2) on real slicer output: a 10 mm cube,
//! 20 % infill, 0.2 mm layers, sliced by Cura, PrusaSlicer and Slic3r.

use std::f64::consts::PI;
use std::path::PathBuf;

use s2g_gcode::{ParseOptions, Spine, SpineBuilder, SpineOptions, SpineRule, parse_file};

const FILES: [&str; 3] = [
    "cura_cube10_infill20_grid.gcode",
    "prusa_cube10_infill20_rectilinear.gcode",
    "slic3r_cube10_infill20_comments.gcode",
];

/// All three slicers were set up for a 235 x 235 mm bed (PrusaSlicer and Slic3r
/// state `bed_shape = 0x0,235x0,235x235,0x235`; Cura's Ender 3 definition has the
/// same size) and centre the cube on it: the part spans 112.5..122.5 in X and Y.
const PART_MIN_XY: f64 = 117.5 - 5.0;

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/fdm/gcode").join(name)
}

fn spines(name: &str, rule: SpineRule) -> Vec<Spine> {
    let mut b = SpineBuilder::new(SpineOptions { rule, ..Default::default() });
    parse_file(path(name), &ParseOptions::default(), &mut b).unwrap_or_else(|e| panic!("{name}: {e}"));
    b.into_spines()
}

/// Independent of the parser: the filament (mm) pushed on lines that move in XY,
/// from the E words as written (M82/M83, G90/G91 and `G92 E` handled).
fn scanned_extrusion(text: &str) -> f64 {
    let (mut e_rel, mut g91) = (false, false);
    let (mut e_last, mut total) = (0.0, 0.0);
    for line in text.lines() {
        let code = line.split(';').next().unwrap_or("").trim();
        let words: Vec<&str> = code.split_whitespace().collect();
        let val = |l: char| words.iter().find(|w| w.starts_with(l)).and_then(|w| w[1..].parse::<f64>().ok());
        match words.first().copied() {
            Some("M82") => e_rel = false,
            Some("M83") => e_rel = true,
            Some("G90") => g91 = false,
            Some("G91") => g91 = true,
            Some("G92") => {
                if let Some(e) = val('E') {
                    e_last = e;
                }
            }
            Some("G0") | Some("G1") => {
                if let Some(e) = val('E') {
                    let inc = if e_rel || g91 { e } else { e - e_last };
                    e_last = if e_rel || g91 { e_last + e } else { e };
                    if inc > 0.0 && (val('X').is_some() || val('Y').is_some()) {
                        total += inc;
                    }
                }
            }
            _ => {}
        }
    }
    total
}

#[test]
fn spines_of_three_slicers() {
    let area = PI * 0.875 * 0.875;
    for name in FILES {
        let text = std::fs::read_to_string(path(name)).expect("read");
        let s = spines(name, SpineRule::ExtrusionIncrement);
        assert!(!s.is_empty(), "{name}: no spines");

        // Layers: 50 at 0.2 mm, every index used.
        let mut layers: Vec<usize> = s.iter().map(|s| s.layer).collect();
        layers.dedup();
        let max = layers.iter().copied().max().unwrap_or(0);
        assert_eq!(max + 1, 50, "{name}: layer count");
        assert!(layers.windows(2).all(|w| w[1] >= w[0]), "{name}: layers must not go back");
        let mut distinct = layers.clone();
        distinct.sort_unstable();
        distinct.dedup();
        assert_eq!(distinct.len(), 50, "{name}: distinct layers");

        // Volume: the spines hold the filament the file pushes.
        let vol: f64 = s.iter().map(Spine::volume).sum();
        let want = scanned_extrusion(&text) * area;
        assert!(want > 100.0, "{name}: scanner found only {want} mm^3");
        let rel = (vol - want).abs() / want;
        assert!(rel < 0.02, "{name}: spine volume {vol:.2} vs scanned {want:.2} mm^3 ({:.2} %)", rel * 100.0);

        // Geometry: above the first layer (skirt, purge line) and apart from the
        // skirt, every spine point lies in the cube's footprint.
        for sp in s.iter().filter(|s| s.layer >= 1) {
            if sp.kind.as_deref().is_some_and(|k| k.to_ascii_lowercase().contains("skirt")) {
                continue;
            }
            for p in &sp.points {
                let (x, y) = (p.x - PART_MIN_XY, p.y - PART_MIN_XY);
                assert!(
                    (-0.05..=10.05).contains(&x) && (-0.05..=10.05).contains(&y),
                    "{name}: layer {} point {p} outside the cube footprint",
                    sp.layer
                );
                assert!(p.z > 0.0 && p.z <= 10.2, "{name}: z {} out of (0, 10.2]", p.z);
            }
            assert_eq!(sp.volumes.len() + 1, sp.points.len(), "{name}: one volume per segment");
            assert!(sp.volumes.iter().all(|v| *v > 0.0), "{name}: extruding segments have volume");
        }
        // The top layer sits at 10 mm.
        let top = s.iter().filter(|s| s.layer == 49).flat_map(|s| &s.points).map(|p| p.z).fold(0.0, f64::max);
        assert!((top - 10.0).abs() < 1e-9, "{name}: top layer z {top}");
    }
}

/// The paper's flag rule treats every G1 as printed. PrusaSlicer travels with G1
/// moves without E, so under that rule spines run across travels: longer spines
/// with zero-volume segments (the count need not drop, as `;TYPE:` changes still
/// split them). Cura travels with G0, where the rules agree
/// on the printed geometry apart from retract-only moves.
#[test]
fn paper_flags_differ_on_g1_travels() {
    for name in [FILES[1], FILES[2]] {
        let inc = spines(name, SpineRule::ExtrusionIncrement);
        let paper = spines(name, SpineRule::PaperFlags);
        let zero = |s: &[Spine]| s.iter().flat_map(|s| &s.volumes).filter(|v| **v <= 0.0).count();
        let len = |s: &[Spine]| s.iter().map(Spine::length).sum::<f64>();
        assert_eq!(zero(&inc), 0, "{name}: increment rule keeps only extruding segments");
        assert!(
            zero(&paper) > 100,
            "{name}: paper rule should take G1 travels as printed ({})",
            zero(&paper)
        );
        assert!(len(&paper) > len(&inc) * 1.05, "{name}: paper length {} vs {}", len(&paper), len(&inc));
        // Same filament either way: the rule only changes which travels join spines.
        let v = |s: &[Spine]| s.iter().map(Spine::volume).sum::<f64>();
        assert!((v(&paper) - v(&inc)).abs() / v(&inc) < 0.02, "{name}: volumes {} vs {}", v(&paper), v(&inc));
    }
    // Cura uses G0 for travel: both rules give nearly the same printed length.
    let inc = spines(FILES[0], SpineRule::ExtrusionIncrement);
    let paper = spines(FILES[0], SpineRule::PaperFlags);
    let len = |s: &[Spine]| s.iter().map(Spine::length).sum::<f64>();
    let rel = (len(&paper) - len(&inc)).abs() / len(&inc);
    assert!(rel < 0.05, "cura: rule lengths differ by {:.1} %", rel * 100.0);
}

/// Our Marlin writer, our parser and the spine builder agree: a program of
/// extruding lines and XY arcs (with retractions and travels between them) comes
/// back as one spine per printed run, holding all the filament, with arcs
/// linearised on their circle.
#[test]
fn spines_of_written_marlin_program() {
    use nalgebra::Point3;
    use s2g_gcode::{
        ArcDirection, Dialect, Marker, Motion, MotionRecorder, Plane, WriterOptions, write_program,
    };
    use std::borrow::Cow;

    let mut ms = Vec::new();
    let mut filament = 0.0;
    let mut runs = 0;
    for layer in 0..3 {
        let z = 0.2 * (layer + 1) as f64;
        ms.push(Motion::Marker(Marker::Layer { index: Some(layer), z: None }));
        for k in 0..4 {
            let (cx, cy) = (50.0 + 30.0 * k as f64, 50.0);
            ms.push(Motion::Rapid { to: Point3::new(cx + 10.0, cy, z) });
            ms.push(Motion::Linear { to: Point3::new(cx + 10.0, cy, z), feed: 2400.0, extrude: Some(0.8) });
            ms.push(Motion::Marker(Marker::Type(Cow::Borrowed("WALL-OUTER"))));
            ms.push(Motion::Arc {
                to: Point3::new(cx - 10.0, cy, z),
                center: Point3::new(cx, cy, z),
                plane: Plane::XY,
                direction: ArcDirection::CounterClockwise,
                turns: 0,
                feed: 1200.0,
                extrude: Some(1.5),
            });
            ms.push(Motion::Linear {
                to: Point3::new(cx - 10.0, cy - 5.0, z),
                feed: 1200.0,
                extrude: Some(0.25),
            });
            ms.push(Motion::Linear {
                to: Point3::new(cx - 10.0, cy - 5.0, z),
                feed: 2400.0,
                extrude: Some(-0.8),
            });
            filament += 1.75;
            runs += 1;
        }
    }
    let text = write_program(Dialect::Marlin, WriterOptions::default(), &ms).expect("writes");
    let mut rec = MotionRecorder::default();
    let summary = parse_str_checked(&text, &mut rec);
    assert!(summary.errors.is_empty(), "{:?}\n{text}", summary.errors);
    let mut b = SpineBuilder::default();
    for (_, m) in &rec.motions {
        let _ = s2g_gcode::MotionSink::motion(&mut b, m);
    }
    let s = b.into_spines();
    assert_eq!(s.len(), runs, "one spine per run\n{text}");
    let area = PI * 0.875 * 0.875;
    let vol: f64 = s.iter().map(Spine::volume).sum();
    assert!((vol - filament * area).abs() < 1e-3, "volume {vol} vs {}", filament * area);
    assert_eq!(s.iter().map(|s| s.layer).max(), Some(2));
    for sp in &s {
        assert!(sp.points.len() > 20, "arc should be linearised: {} points", sp.points.len());
        assert_eq!(sp.kind.as_deref(), Some("WALL-OUTER"));
        // All but the last point lie on the 10 mm circle of this run.
        let c = Point3::new(sp.points[0].x - 10.0, 50.0, sp.points[0].z);
        for p in &sp.points[..sp.points.len() - 1] {
            let r = (p.x - c.x).hypot(p.y - c.y);
            assert!((r - 10.0).abs() < 2e-3, "point {p} at radius {r}");
        }
    }
}

fn parse_str_checked(text: &str, rec: &mut s2g_gcode::MotionRecorder) -> s2g_gcode::ParseSummary {
    s2g_gcode::parse_str(text, &ParseOptions::default(), rec).expect("infallible sink")
}
