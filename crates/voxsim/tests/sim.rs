//! Integration tests of the simulator: closed-form volumes, carver agreement, planted faults.

use std::f64::consts::PI;

use s2g_gcode::{ArcDirection, Motion, MotionSink, Plane};
use s2g_geom::{Aabb, GridSpec, Isometry3, Point3, Rotation3, Vector3, VoxelGrid};
use s2g_voxsim::{
    BeadProfile, Carver, Cutter, Holder, Neck, SimError, SimOptions, Simulation, Simulator, ToolTable,
};

fn p(x: f64, y: f64, z: f64) -> Point3 {
    Point3::new(x, y, z)
}

fn full_box(min: Point3, max: Point3, n: usize) -> VoxelGrid {
    VoxelGrid::full(GridSpec::cubic(&Aabb::new(min, max), n).expect("valid box"))
}

fn lin(to: Point3) -> Motion<'static> {
    Motion::Linear { to, feed: 600.0, extrude: None }
}

/// Feeds `(line, motion)` pairs and finishes.
fn run(mut sim: Simulator, motions: &[(u64, Motion<'_>)]) -> Simulation {
    for (line, m) in motions {
        sim.source_line(*line).unwrap();
        sim.motion(m).unwrap();
    }
    sim.finish().unwrap();
    sim.into_simulation().unwrap()
}

fn numbered(ms: Vec<Motion<'static>>) -> Vec<(u64, Motion<'static>)> {
    ms.into_iter().enumerate().map(|(i, m)| (i as u64 + 1, m)).collect()
}

fn check(what: &str, got: f64, want: f64, tol: f64) {
    assert!((got - want).abs() <= tol, "{what}: got {got:.4} mm3, want {want:.4} +- {tol:.4}");
}

/// Open-top slot programs (flat and ball) against closed forms, at two resolutions and
/// with the setup rotated (stock rotated accordingly).
mod closed_forms {
    use super::*;

    /// Program-frame stock [0,40]x[0,20]x[0,10]; plunge at x=8 to z=6, slot to x=30.
    fn slot(cutter: Cutter, n: usize, frame: Option<Isometry3>) -> Simulation {
        let (lo, hi) = (p(0., 0., 0.), p(40., 20., 10.));
        let (stock, mut ms) = match frame {
            None => (full_box(lo, hi, n), vec![]),
            Some(f) => {
                let a = f * lo;
                let b = f * hi;
                let img = full_box(a.inf(&b), a.sup(&b), n);
                (img, vec![Motion::Setup { frame: f, rotary: [None; 3] }])
            }
        };
        ms.extend([
            Motion::Rapid { to: p(8., 10., 15.) },
            lin(p(8., 10., 6.)),
            lin(p(30., 10., 6.)),
            Motion::Rapid { to: p(30., 10., 15.) },
        ]);
        let sim = Simulator::new(stock, ToolTable::single(cutter), SimOptions::default()).unwrap();
        run(sim, &numbered(ms))
    }

    fn frames() -> Vec<(&'static str, Option<Isometry3>)> {
        let rot = Rotation3::from_axis_angle(&Vector3::x_axis(), PI / 2.0);
        let rot2 = Rotation3::from_axis_angle(&Vector3::y_axis(), -PI / 2.0);
        vec![
            ("identity", None),
            ("rot x 90 + shift", Some(Isometry3::from_parts(Vector3::new(5., 7., -3.).into(), rot))),
            ("rot y -90", Some(Isometry3::from_parts(Vector3::new(-2., 1., 4.).into(), rot2))),
        ]
    }

    #[test]
    fn flat_slot_is_a_stadium_prism() {
        let (r, l, depth) = (3.0, 22.0, 4.0);
        let want = (2.0 * r * l + PI * r * r) * depth;
        let area = 2.0 * (2.0 * r * l + PI * r * r) + (2.0 * l + 2.0 * PI * r) * depth;
        for n in [80, 160] {
            for (name, f) in frames() {
                let s = slot(Cutter::flat(r, 20.0), n, f);
                let h = s.residual().spec().voxel.x;
                // Voxel-centre rule: misclassified voxels straddle the surface; their net
                // volume is bounded by surface area * h / 2.
                check(
                    &format!("flat slot n={n} {name}"),
                    s.report().removed_volume_mm3,
                    want,
                    area * h / 2.0,
                );
                assert!(s.report().rapid_collision_lines.is_empty(), "{name}: {:?}", s.report());
                assert!(s.report().holder_collisions.is_empty(), "{name}: {:?}", s.report());
                let t = 31.0 / 600.0 * 60.0 + 9.0 / 5000.0 * 60.0;
                assert!(
                    (s.report().machining_time_s - t).abs() < 1e-9,
                    "time {}",
                    s.report().machining_time_s
                );
            }
        }
    }

    #[test]
    fn ball_slot_is_half_capsule_plus_prism() {
        let (r, l) = (3.0, 22.0);
        // Ball centre at z = 9; stock top at 10.
        let want = PI * r * r * l / 2.0 + 2.0 / 3.0 * PI * r.powi(3) + (2.0 * r * l + PI * r * r) * 1.0;
        let area =
            2.0 * (2.0 * r * l + PI * r * r) + (PI * r * l + 2.0 * PI * r * r) + (2.0 * l + 2.0 * PI * r);
        for n in [80, 160] {
            for (name, f) in frames() {
                let s = slot(Cutter::ball(r, 20.0), n, f);
                let h = s.residual().spec().voxel.x;
                check(
                    &format!("ball slot n={n} {name}"),
                    s.report().removed_volume_mm3,
                    want,
                    area * h / 2.0,
                );
            }
        }
    }

    /// Volume of a cutter solid (flat: rc = 0; ball: rc = r).
    fn tool_volume(r: f64, rc: f64, lf: f64) -> f64 {
        let rp = r - rc;
        PI * r * r * lf - 2.0 * PI * (rp * rc * rc * (1.0 - PI / 4.0) + rc.powi(3) / 6.0)
    }

    /// Embedded sweeps (stock encloses the whole swept tool): Cavalieri gives
    /// `V = vol(tool) + length * area(projection along the move)`; any setup rotation.
    #[test]
    fn embedded_sweeps_match_cavalieri_under_any_rotation() {
        let (r, lf) = (2.5, 8.0);
        let cutters = [(Cutter::flat(r, lf), 0.0), (Cutter::ball(r, lf), r), (Cutter::bull(r, 1.0, lf), 1.0)];
        let rots = [
            Isometry3::identity(),
            Isometry3::from_parts(
                Vector3::new(1.3, -0.7, 2.1).into(),
                Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(Vector3::new(1., 2., 3.)), 0.7),
            ),
        ];
        for n in [100, 160] {
            for (ci, (c, rc)) in cutters.iter().enumerate() {
                for (ri, f) in rots.iter().enumerate() {
                    for (kind, a, b) in [
                        ("sideways", p(-8., 0., -4.), p(8., 0., -4.)),
                        ("plunge", p(0., 0., 4.), p(0., 0., -8.)),
                    ] {
                        let stock = full_box(p(-25., -25., -25.), p(25., 25., 25.), n);
                        let h = stock.spec().voxel.x;
                        let opts = SimOptions { start: Some(a), check_holder: false, ..Default::default() };
                        let sim = Simulator::new(stock, ToolTable::single(*c), opts).unwrap();
                        let s = run(sim, &[(1, Motion::Setup { frame: *f, rotary: [None; 3] }), (2, lin(b))]);
                        // After an indexed setup the first move is a positioning move: redo with
                        // the setup first and the start given in the new frame.
                        let _ = s;
                        let stock = full_box(p(-25., -25., -25.), p(25., 25., 25.), n);
                        let mut sim = Simulator::new(
                            stock,
                            ToolTable::single(*c),
                            SimOptions { check_holder: false, ..Default::default() },
                        )
                        .unwrap();
                        sim.motion(&Motion::Setup { frame: *f, rotary: [None; 3] }).unwrap();
                        sim.motion(&Motion::Rapid { to: a }).unwrap();
                        sim.motion(&lin(b)).unwrap();
                        let s = sim.into_simulation().unwrap();
                        let len = (b - a).norm();
                        let proj = if kind == "plunge" {
                            PI * r * r
                        } else {
                            2.0 * r * lf - 2.0 * rc * rc * (1.0 - PI / 4.0)
                        };
                        let want = tool_volume(r, *rc, lf) + len * proj;
                        let area = len * 2.0 * (2.0 * r + lf) + 2.0 * PI * r * (r + lf);
                        check(
                            &format!("embedded {kind} cutter {ci} rot {ri} n={n}"),
                            s.report().removed_volume_mm3,
                            want,
                            area * h / 2.0,
                        );
                    }
                }
            }
        }
    }

    /// Flat tool along planar and helical arcs: `V = int_{rho-R}^{rho+R} [Lf (theta + 2w) +
    /// k 2 w theta] r dr` with `cos w = (r^2 + rho^2 - R^2) / (2 r rho)` and `k = |dz/dphi|`
    /// (planar: the annulus sector times Lf plus pi R^2 Lf).
    #[test]
    fn arcs_and_helices_match_integrals() {
        let (r, lf, rho, theta) = (2.0, 6.0, 10.0, PI / 2.0);
        for (name, dz, dir, rot) in [
            ("planar ccw", 0.0f64, ArcDirection::CounterClockwise, false),
            ("helix ccw", -3.0, ArcDirection::CounterClockwise, false),
            ("helix cw", -3.0, ArcDirection::Clockwise, false),
            ("helix ccw rotated", -3.0, ArcDirection::CounterClockwise, true),
        ] {
            let k = dz.abs() / theta;
            let steps = 200_000;
            let mut want = 0.0;
            for i in 0..steps {
                let rr = rho - r + (i as f64 + 0.5) / steps as f64 * 2.0 * r;
                let w = ((rr * rr + rho * rho - r * r) / (2.0 * rr * rho)).clamp(-1.0, 1.0).acos();
                want += (lf * (theta + 2.0 * w) + k * 2.0 * w * theta) * rr * (2.0 * r / steps as f64);
            }
            for n in [100, 160] {
                let stock = full_box(p(-20., -20., -20.), p(20., 20., 20.), n);
                let h = stock.spec().voxel.x;
                let sim = Simulator::new(
                    stock,
                    ToolTable::single(Cutter::flat(r, lf)),
                    SimOptions { check_holder: false, ..Default::default() },
                )
                .unwrap();
                // CW goes from (0, rho) to (rho, 0); CCW the other way: the same quarter.
                let (a, b) = match dir {
                    ArcDirection::CounterClockwise => (p(rho, 0., 0.), p(0., rho, dz)),
                    ArcDirection::Clockwise => (p(0., rho, 0.), p(rho, 0., dz)),
                };
                let mut ms = vec![];
                if rot {
                    let f = Isometry3::from_parts(
                        Vector3::new(0.5, -1.0, 0.25).into(),
                        Rotation3::from_axis_angle(
                            &nalgebra::Unit::new_normalize(Vector3::new(-1., 0.5, 2.)),
                            0.9,
                        ),
                    );
                    ms.push(Motion::Setup { frame: f, rotary: [None; 3] });
                }
                ms.push(Motion::Rapid { to: a });
                ms.push(Motion::Arc {
                    to: b,
                    center: p(0., 0., 0.),
                    plane: Plane::XY,
                    direction: dir,
                    turns: 0,
                    feed: 300.0,
                    extrude: None,
                });
                let s = run(sim, &numbered(ms));
                let area = 2.0 * theta * rho * 2.0 * r * 2.0
                    + 2.0 * (theta * (rho + r) + 2.0 * PI * r) * (lf + dz.abs());
                check(&format!("{name} n={n}"), s.report().removed_volume_mm3, want, area * h / 2.0);
                let arc_len = ((theta * rho).powi(2) + dz * dz).sqrt();
                assert!((s.report().feed_length_mm - arc_len).abs() < 1e-9, "{name}: arc length");
            }
        }
    }
}

/// Exact and dexel carvers agree.
mod agreement {
    use super::*;

    /// Symmetric difference of the residuals over removed voxels.
    fn compare(name: &str, stock: &VoxelGrid, tools: &ToolTable, ms: &[(u64, Motion<'_>)]) -> (u64, u64) {
        let go = |carver| {
            let opts = SimOptions { carver, ..Default::default() };
            run(Simulator::new(stock.clone(), tools.clone(), opts).unwrap(), ms)
        };
        let (e, d) = (go(Carver::Exact), go(Carver::Dexel));
        let mut x = e.residual().clone();
        x.xor(d.residual()).unwrap();
        let diff = x.count();
        let removed = e.report().removed_voxels;
        assert!(removed > 1000, "{name}: too little removed ({removed}) to compare");
        assert!(diff as f64 <= 1e-3 * removed as f64, "{name}: {diff} of {removed} voxels differ");
        assert_eq!(
            e.report().removed_voxels.abs_diff(d.report().removed_voxels),
            diff,
            "{name}: reported counts disagree with the residuals"
        );
        (diff, removed)
    }

    pub(crate) fn zigzag(x0: f64, x1: f64, y0: f64, y1: f64, step: f64, z: f64) -> Vec<Motion<'static>> {
        let mut ms = vec![Motion::Rapid { to: p(x0, y0, z + 5.0) }, lin(p(x0, y0, z))];
        let mut y = y0;
        let mut fwd = true;
        while y <= y1 + 1e-9 {
            ms.push(lin(p(if fwd { x1 } else { x0 }, y, z)));
            fwd = !fwd;
            y += step;
            if y <= y1 + 1e-9 {
                ms.push(lin(p(if fwd { x0 } else { x1 }, y, z)));
            }
        }
        ms.push(Motion::Rapid { to: p(x0, y0, z + 5.0) });
        ms
    }

    #[test]
    fn pocket_and_raster_programs() {
        let stock = full_box(p(0., 0., 0.), p(40., 40., 10.), 128);
        for (name, c) in [
            ("flat", Cutter::flat(1.5, 12.0)),
            ("ball", Cutter::ball(1.5, 12.0)),
            ("bull", Cutter::bull(2.0, 0.5, 12.0)),
        ] {
            let tools = ToolTable::single(c);
            let ms = numbered(zigzag(5.0, 35.0, 5.0, 35.0, 2.1, 6.3));
            compare(&format!("zigzag {name}"), &stock, &tools, &ms);
            // A raster over a bumpy surface with z varying along each pass.
            let mut ms = vec![Motion::Rapid { to: p(2.0, 2.0, 15.0) }];
            for j in 0..12 {
                let y = 2.0 + 3.0 * j as f64;
                for i in 0..=60 {
                    let x = 2.0 + 0.6 * i as f64;
                    let z = 6.0 + 1.5 * (0.3 * x).sin() * (0.2 * y).cos();
                    ms.push(lin(p(x, y, z)));
                }
            }
            compare(&format!("raster {name}"), &stock, &tools, &numbered(ms));
        }
    }

    /// Batches of thousands of moves (binned on the thread pool, carved brick by brick in
    /// program order) leave exactly the stock that one move per batch leaves.
    #[test]
    fn batch_size_does_not_change_the_result() {
        let stock = full_box(p(0., 0., 0.), p(40., 40., 10.), 96);
        let tools = ToolTable::single(Cutter::flat(1.5, 12.0));
        let mut ms = zigzag(5.0, 35.0, 5.0, 35.0, 2.1, 6.3);
        ms.extend(zigzag(3.0, 37.0, 4.0, 36.0, 1.3, 4.1));
        let ms = numbered(ms);
        let go = |batch_moves| {
            let opts = SimOptions { batch_moves, ..Default::default() };
            run(Simulator::new(stock.clone(), tools.clone(), opts).unwrap(), &ms)
        };
        let (one, many) = (go(1), go(4096));
        assert!(ms.len() > 64, "enough moves for a pooled batch: {}", ms.len());
        assert!(one.report().removed_voxels > 10_000, "{}", one.report().removed_voxels);
        assert_eq!(one.report().removed_voxels, many.report().removed_voxels);
        let mut x = one.residual().clone();
        x.xor(many.residual()).unwrap();
        assert_eq!(x.count(), 0, "residuals differ");
    }

    /// The 3-axis, single-tool programs of tests/data: a stock box from a bit below the
    /// lowest cutting move up to the top of the cutting moves. Every program is either
    /// compared or skipped for a stated reason, and the compared ones are named, so a
    /// program cannot drop out of the comparison unnoticed.
    #[test]
    fn data_programs() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/cnc/programs");
        let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
        names.sort();
        let mut compared = Vec::new();
        let mut skipped = Vec::new();
        for path in names {
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            let text = std::fs::read_to_string(&path).unwrap();
            let mut rec = s2g_gcode::MotionRecorder::default();
            if let Err(e) = s2g_gcode::parse_str(&text, &Default::default(), &mut rec) {
                panic!("{name}: {e}");
            }
            let tools = rec.motions.iter().filter(|(_, m)| matches!(m, Motion::ToolChange { .. })).count();
            let rotary = rec.motions.iter().any(|(_, m)| matches!(m, Motion::Setup { .. }));
            let mut bb: Option<Aabb> = None;
            for (_, m) in &rec.motions {
                if let Motion::Linear { to, .. } | Motion::Arc { to, .. } = m {
                    bb.get_or_insert_with(|| Aabb::new(*to, *to)).grow(to);
                }
            }
            let reason = match bb {
                _ if tools > 1 => Some(format!("{tools} tools")),
                _ if rotary => Some("rotary setups".to_string()),
                None => Some("no cutting moves".to_string()),
                Some(bb) if !bb.is_valid() => Some("degenerate extent".to_string()),
                Some(_) => None,
            };
            if let Some(reason) = reason {
                skipped.push(format!("{name} ({reason})"));
                continue;
            }
            let bb = bb.unwrap();
            let e = bb.extent();
            let r = 0.02 * e.x.max(e.y).max(1.0);
            let lo = bb.min - Vector3::new(2.0 * r, 2.0 * r, 0.5 * r.max(e.z * 0.1));
            let hi = p(bb.max.x + 2.0 * r, bb.max.y + 2.0 * r, bb.min.z + 0.5 * r + 0.5 * e.z);
            let spec = GridSpec::cubic(&Aabb::new(lo, hi), 160).unwrap_or_else(|e| panic!("{name}: {e}"));
            let stock = VoxelGrid::full(spec);
            let t = ToolTable::single(Cutter::flat(r, 4.0 * r.max(e.z)));
            let (diff, removed) = compare(&name, &stock, &t, &rec.motions);
            compared.push(format!("{name}: {diff} of {removed} voxels differ"));
        }
        eprintln!("compared:\n  {}\nskipped:\n  {}", compared.join("\n  "), skipped.join("\n  "));
        let got: Vec<&str> = compared.iter().map(|c| c.split(':').next().unwrap()).collect();
        assert_eq!(got, EXPECTED_COMPARED, "the set of compared programs changed\nskipped: {skipped:?}");
    }

    /// The programs of tests/data/cnc/programs (copies of ../shared/data/cnc/programs):
    /// all of them are single-tool and 3-axis.
    const EXPECTED_COMPARED: &[&str] = &[
        "arc-r_modal.nc",
        "arc-zx-plane_g18.nc",
        "dxf2gcode_join.ngc",
        "estlcam_circle_a.gcode",
        "freecad_path_test_linuxcnc_00.ngc",
        "helical-thread-milling_g91.nc",
        "insulpro_piping_percent.nc",
        "mach3_plasma_thc.gcode",
        "one-inch-circle_g20_N.nc",
        "tweakie_packed_words.gcode",
    ];
}

/// Planted faults are found at the right line.
mod faults {
    use super::*;

    fn target() -> VoxelGrid {
        // Part: the stock minus a 2 mm skin on top; stock [0,30]x[0,30]x[0,12].
        let mut t = VoxelGrid::new(*full_box(p(0., 0., 0.), p(30., 30., 12.), 60).spec());
        t.set_where(|q| q.z < 10.0);
        t
    }

    fn clean() -> Vec<Motion<'static>> {
        let mut ms = vec![Motion::Rapid { to: p(-5., 2., 20.) }, Motion::Rapid { to: p(-5., 2., 10.5) }];
        ms.extend(agreement::zigzag(-5.0, 35.0, 2.0, 28.0, 2.0, 10.5).into_iter().skip(1));
        ms.push(Motion::Rapid { to: p(-5., 2., 20.) });
        ms
    }

    fn sim(ms: &[(u64, Motion<'_>)]) -> Simulation {
        let stock = full_box(p(0., 0., 0.), p(30., 30., 12.), 60);
        let s = Simulator::new(stock, ToolTable::single(Cutter::flat(1.5, 10.0)), SimOptions::default())
            .unwrap()
            .with_target(&target())
            .unwrap();
        run(s, ms)
    }

    #[test]
    fn clean_program_has_no_faults() {
        let s = sim(&numbered(clean()));
        let r = s.report();
        assert!(r.removed_voxels > 1000, "{r:?}");
        assert_eq!((r.gouge_voxels, r.first_gouge_line), (0, None), "{r:?}");
        assert!(r.rapid_collision_lines.is_empty() && r.holder_collisions.is_empty(), "{r:?}");
    }

    #[test]
    fn planted_gouge_rapid_and_holder_faults_are_located() {
        let base = clean();
        for at in [5usize, 12, 20] {
            let (x, y) = match &base[at - 1] {
                Motion::Linear { to, .. } => (to.x.clamp(3.0, 27.0), to.y),
                _ => (15.0, 15.0),
            };
            // Gouge: a feed dip into the part.
            let mut ms = base.clone();
            ms.insert(at, lin(p(x, y, 9.0)));
            let s = sim(&numbered(ms));
            assert_eq!(s.report().first_gouge_line, Some(at as u64 + 1), "gouge at {at}: {:?}", s.report());
            assert!(s.report().rapid_collision_lines.is_empty(), "gouge at {at}");
            // Rapid through material: retract, dive diagonally into uncut stock (the fault),
            // retract straight up, come back over the last point and descend straight down.
            let prev = base[at - 1].end_point().unwrap();
            let mut ms = base.clone();
            let up = p(prev.x, prev.y, 20.0);
            let fault = [up, p(20.0, 26.0, 10.8), p(20.0, 26.0, 20.0), up, prev];
            for (i, to) in fault.into_iter().enumerate() {
                ms.insert(at + i, Motion::Rapid { to });
            }
            let s = sim(&numbered(ms));
            assert_eq!(
                s.report().rapid_collision_lines,
                vec![at as u64 + 2],
                "rapid at {at}: {:?}",
                s.report()
            );
            assert_eq!(s.report().first_gouge_line, None, "rapid at {at}");
        }
        // Holder: 2 mm flutes, 3.5 mm deep. The plunge (line 3) is clean: the flutes clear
        // the hole the shank then enters. The sideways move (line 4) drags the shank
        // through the top 1.5 mm of stock.
        let stock = full_box(p(0., 0., 0.), p(30., 30., 12.), 60);
        let mut c = Cutter::flat(1.5, 2.0);
        c.holder = Some(Holder { radius: 10.0, length: 20.0 });
        let s = run(
            Simulator::new(stock, ToolTable::single(c), SimOptions::default()).unwrap(),
            &numbered(vec![
                Motion::Rapid { to: p(10., 10., 20.) },
                lin(p(10., 10., 11.0)),
                lin(p(10., 10., 8.5)),
                lin(p(20., 10., 8.5)),
            ]),
        );
        assert_eq!(s.report().holder_collisions, vec![4], "{:?}", s.report());
        // 1.5 mm of stock above the flutes, shank radius 1.5 mm, 10 mm long: about 2 R * 10 * 1.5.
        let v = s.report().holder_collision_voxels as f64 * 0.125;
        assert!(v > 0.5 * 45.0, "holder collision volume {v}");
    }

    /// A long-reach end mill: 2 mm of flutes of radius 1.5, a neck of radius 1.4 up to 8 mm,
    /// then a shank of radius 3. Plunged 3.5 mm (line 3), its neck follows the flutes down
    /// the hole they cut: clean, where the same tool without the neck drags its shank
    /// through the hole's top 1.5 mm. Moved sideways at that depth (line 4), the neck meets
    /// the stock above the flutes' slot: a holder collision, where flutes as long as the
    /// neck would have cut it. Plunged 9 mm, past the neck's reach, the shank collides.
    #[test]
    fn a_long_reach_tool_s_neck_is_checked_as_a_body_of_its_own() {
        let mut necked = Cutter::flat(1.5, 2.0);
        necked.shank_radius = 3.0;
        necked.stickout = 20.0;
        necked.neck = Some(Neck { radius: 1.4, reach: 8.0 });
        necked.validate().expect("a valid cutter");
        let collisions = |c: Cutter, depth: f64, sideways: bool| {
            let stock = full_box(p(0., 0., 0.), p(30., 30., 12.), 60);
            let mut ms = vec![
                Motion::Rapid { to: p(10., 10., 20.) },
                lin(p(10., 10., 12.5)),
                lin(p(10., 10., 12.0 - depth)),
            ];
            if sideways {
                ms.push(lin(p(20., 10., 12.0 - depth)));
            }
            let s = run(
                Simulator::new(stock, ToolTable::single(c), SimOptions::default()).unwrap(),
                &numbered(ms),
            );
            s.report().holder_collisions.clone()
        };
        assert_eq!(collisions(necked, 3.5, false), Vec::<u64>::new(), "the neck follows the flutes down");
        assert_eq!(collisions(Cutter { neck: None, ..necked }, 3.5, false), vec![3], "the shank at once");
        assert_eq!(collisions(necked, 3.5, true), vec![4], "the neck above the slot");
        let long_flutes = Cutter { neck: None, flute_length: 8.0, ..necked };
        assert_eq!(collisions(long_flutes, 3.5, true), Vec::<u64>::new(), "flutes as long as the neck");
        assert_eq!(collisions(necked, 9.0, false), vec![3], "the shank past the neck's reach");
    }

    /// A rapid descending beside the stock's wall with the tool reaching a micrometre past
    /// a column of voxel centres (program rounding, chords of arcs) grazes them: they are
    /// cut, but it is no collision. Reaching a tenth of a voxel past them is one. Both the
    /// exact and the dexel carver.
    #[test]
    fn rapids_that_only_graze_the_stock_are_not_collisions() {
        // Voxels of 0.5 mm: the first column of centres is at x = 0.25, one at y = 15.25.
        let r = 1.5;
        for carver in [Carver::Exact, Carver::Dexel] {
            for (past, collides) in [(1e-3, false), (0.05, true)] {
                let x = 0.25 - r + past;
                let stock = full_box(p(0., 0., 0.), p(30., 30., 12.), 60);
                let opts = SimOptions { carver, ..SimOptions::default() };
                let sim = Simulator::new(stock, ToolTable::single(Cutter::flat(r, 30.0)), opts).unwrap();
                let ms = [Motion::Rapid { to: p(x, 15.25, 20.0) }, Motion::Rapid { to: p(x, 15.25, 5.0) }];
                let s = run(sim, &numbered(ms.to_vec()));
                let rep = s.report();
                // The centres at z = 5.25 ... 11.75 of the one column within reach.
                assert_eq!(rep.removed_voxels, 14, "{carver:?}, {past} mm past: {rep:?}");
                let want: (Vec<u64>, u64) = if collides { (vec![2], 14) } else { (vec![], 0) };
                assert_eq!(
                    (rep.rapid_collision_lines.clone(), rep.rapid_collision_voxels),
                    want,
                    "{carver:?}, {past} mm past"
                );
            }
        }
    }
}

/// The paper's A1 approaches the exact carver as the density grows.
#[test]
fn paper_baseline_converges_toward_exact() {
    // Facing passes whose ends lie outside the stock and whose floor lies on voxel faces: the
    // set A1 samples from coincides there with the exact flat-end sweep.
    let stock = full_box(p(0., 0., 0.), p(20., 20., 4.), 40);
    let (r, z) = (1.0, 2.0);
    let mut ms = vec![Motion::Rapid { to: p(-3., 1.0, z) }];
    for j in 0..9 {
        // Serpentine: every connection lies outside the stock.
        let y = 1.0 + 2.0 * j as f64;
        let (a, b) = if j % 2 == 0 { (-3.0, 23.0) } else { (23.0, -3.0) };
        ms.push(lin(p(a, y, z)));
        ms.push(lin(p(b, y, z)));
    }
    let ms = numbered(ms);
    let t = ToolTable::single(Cutter::flat(r, 2.0 * r));
    let go = |carver| {
        run(
            Simulator::new(stock.clone(), t.clone(), SimOptions { carver, ..Default::default() }).unwrap(),
            &ms,
        )
    };
    let exact = go(Carver::Exact);
    let mut last = f64::INFINITY;
    for density in [4.0, 32.0, 256.0, 2048.0] {
        let a1 = go(Carver::PaperMonteCarlo { samples_per_unit: density, seed: 7 });
        let mut x = a1.residual().clone();
        x.xor(exact.residual()).unwrap();
        let rel = x.count() as f64 / exact.report().removed_voxels as f64;
        assert!(rel < last, "density {density}: mismatch {rel} did not shrink from {last}");
        last = rel;
    }
    assert!(last < 0.02, "A1 at the highest density still differs by {last}");
}

#[test]
fn deposited_beads_have_closed_form_volumes() {
    let (w, hgt, l) = (0.8, 0.4, 12.0);
    for n in [100, 200] {
        for (name, prof, want) in [
            ("rectangle", BeadProfile::Rectangle { width: w, height: hgt }, w * hgt * l),
            ("stadium", BeadProfile::Stadium { width: w, height: hgt }, w * hgt * l + PI * w * w / 4.0 * hgt),
            ("circle", BeadProfile::Circle { diameter: w }, PI * w * w / 4.0 * l + PI * w.powi(3) / 6.0),
        ] {
            let grid = VoxelGrid::new(GridSpec::cubic(&Aabb::new(p(0., 0., 0.), p(20., 5., 5.)), n).unwrap());
            let h = grid.spec().voxel.x;
            let sim = Simulator::depositor(grid, prof, SimOptions::default()).unwrap();
            let ms = numbered(vec![
                Motion::Rapid { to: p(4., 2.5, 2.0) },
                Motion::Linear { to: p(4. + l, 2.5, 2.0), feed: 1200.0, extrude: Some(0.5) },
                Motion::Linear { to: p(4. + l, 4.5, 2.0), feed: 1200.0, extrude: Some(-0.5) },
            ]);
            let s = run(sim, &ms);
            let area = 2.0 * w * l + 2.0 * hgt * l + 2.0 * w * hgt + PI * w * hgt;
            check(&format!("{name} bead n={n}"), s.report().deposited_volume_mm3, want, area * h / 2.0);
            assert_eq!(s.report().removed_voxels, 0);
        }
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let stock = full_box(p(0., 0., 0.), p(10., 10., 10.), 20);
    for c in [
        Cutter::flat(0.0, 5.0),
        Cutter::flat(f64::NAN, 5.0),
        Cutter::ball(2.0, 3.0),
        Cutter::bull(2.0, 2.5, 10.0),
        Cutter::bull(2.0, -0.1, 10.0),
    ] {
        let e = Simulator::new(stock.clone(), ToolTable::single(c), SimOptions::default());
        assert!(matches!(e, Err(SimError::InvalidTool(_))), "{c:?} accepted");
    }
    let mut s =
        Simulator::new(stock.clone(), ToolTable::single(Cutter::flat(1.0, 5.0)), SimOptions::default())
            .unwrap();
    s.source_line(7).unwrap();
    let e = s.motion(&Motion::Linear { to: p(f64::NAN, 0., 0.), feed: 100.0, extrude: None });
    assert!(matches!(e, Err(SimError::InvalidMotion { line: 7, .. })), "{e:?}");
    // Zero-length moves, zero feed and degenerate arcs are fine.
    s.motion(&Motion::Rapid { to: p(5., 5., 20.) }).unwrap();
    s.motion(&Motion::Linear { to: p(5., 5., 20.), feed: 0.0, extrude: None }).unwrap();
    s.motion(&Motion::Arc {
        to: p(5., 5., 8.),
        center: p(5., 5., 20.),
        plane: Plane::XY,
        direction: ArcDirection::Clockwise,
        turns: 0,
        feed: 100.0,
        extrude: None,
    })
    .unwrap();
    let sim = s.into_simulation().unwrap();
    assert_eq!(sim.report().feedless_moves, 1);
    let other = full_box(p(0., 0., 0.), p(10., 10., 10.), 30);
    let r = Simulator::new(stock, ToolTable::single(Cutter::flat(1.0, 5.0)), SimOptions::default())
        .unwrap()
        .with_target(&other);
    assert!(matches!(r, Err(SimError::GridMismatch)));
}

/// A setup change reported on the same line as a move is simultaneous: the tool pivots about
/// its fixed tip from +Z to +X. Expected volume by quadrature in cylindrical coordinates
/// about the pivot axis (Y): at radius rho and height y the covered angle is the tool's
/// angular window widened by the 90 degree turn.
#[test]
fn simultaneous_axis_change_sweeps_the_fan() {
    let (r, lf) = (2.0, 8.0);
    let half = PI / 2.0;
    let covered = |rho: f64, y: f64| -> f64 {
        let s = (r * r - y * y).max(0.0).sqrt();
        if rho <= lf {
            let a = (s / rho).min(1.0).asin();
            2.0 * a + half
        } else {
            let lo = (lf / rho).acos();
            let hi = (s / rho).min(1.0).asin();
            if hi < lo { 0.0 } else { 2.0 * (hi - lo + half) - (half - 2.0 * lo).max(0.0) }
        }
    };
    let (ny, nr) = (400, 2000);
    let rmax = (lf * lf + r * r).sqrt();
    let mut want = 0.0;
    for j in 0..ny {
        let y = -r + (j as f64 + 0.5) * 2.0 * r / ny as f64;
        for i in 0..nr {
            let rho = (i as f64 + 0.5) * rmax / nr as f64;
            want += covered(rho, y) * rho * (rmax / nr as f64) * (2.0 * r / ny as f64);
        }
    }
    for n in [120, 200] {
        let stock = full_box(p(-20., -20., -20.), p(20., 20., 20.), n);
        let h = stock.spec().voxel.x;
        let opts = SimOptions { check_holder: false, ..Default::default() };
        let mut sim = Simulator::new(stock, ToolTable::single(Cutter::flat(r, lf)), opts).unwrap();
        sim.source_line(1).unwrap();
        sim.motion(&Motion::Rapid { to: p(0., 0., 0.) }).unwrap();
        sim.source_line(2).unwrap();
        let frame = Isometry3::rotation(Vector3::y() * half);
        sim.motion(&Motion::Setup { frame, rotary: [None, Some(90.0), None] }).unwrap();
        sim.motion(&lin(p(0., 0., 0.))).unwrap();
        let s = sim.into_simulation().unwrap();
        let area = 2.0 * half * (lf + r).powi(2) + half * (lf + r) * 2.0 * r + 2.0 * PI * r * (r + lf);
        check(&format!("pivot fan n={n}"), s.report().removed_volume_mm3, want, area * h / 2.0);
    }
}

/// A tool added after construction cuts with its own radius once selected, and an
/// invalid one is refused: the same plunge removes a 1 mm hole with the default tool and
/// a 3 mm one after `T7`.
#[test]
fn an_added_tool_cuts_with_its_own_radius() {
    let (lo, hi) = (p(0., 0., 0.), p(20., 20., 10.));
    let plunge = |tool: Option<u32>| {
        let mut sim = Simulator::new(
            full_box(lo, hi, 80),
            ToolTable::single(Cutter::flat(1.0, 20.0)),
            SimOptions::default(),
        )
        .unwrap();
        assert!(sim.add_tool(8, Cutter::flat(f64::NAN, 20.0)).is_err(), "a NaN radius");
        sim.add_tool(7, Cutter::flat(3.0, 20.0)).unwrap();
        let mut ms = vec![];
        if let Some(t) = tool {
            ms.push(Motion::ToolChange { tool: t });
        }
        ms.extend([Motion::Rapid { to: p(10., 10., 15.) }, lin(p(10., 10., 5.))]);
        run(sim, &numbered(ms)).report().removed_volume_mm3
    };
    let depth = 5.0;
    check("default tool", plunge(None), PI * 1.0 * depth, 0.1 * PI * depth);
    check("tool 7", plunge(Some(7)), PI * 9.0 * depth, 0.05 * PI * 9.0 * depth);
}

/// A tilting head's tool axis (`Motion::ToolAxis`) is not simulated: along `+Z` it changes
/// nothing, off it the simulator refuses it with a typed error instead of cutting along
/// the wrong axis.
#[test]
fn a_tilted_head_is_refused_not_cut_along_z() {
    let sim = || {
        Simulator::new(
            full_box(p(0., 0., 0.), p(20., 20., 10.), 40),
            ToolTable::single(Cutter::flat(1.0, 20.0)),
            SimOptions::default(),
        )
        .unwrap()
    };
    let plunge = [Motion::Rapid { to: p(10., 10., 15.) }, lin(p(10., 10., 5.))];
    let plain = run(sim(), &numbered(plunge.to_vec())).report().removed_volume_mm3;
    let vertical =
        [vec![Motion::ToolAxis { axis: Vector3::z(), rotary: [None; 3] }], plunge.to_vec()].concat();
    assert_eq!(run(sim(), &numbered(vertical)).report().removed_volume_mm3, plain);
    let mut s = sim();
    let tilted = Motion::ToolAxis { axis: Vector3::new(0.0, 0.6, 0.8), rotary: [None; 3] };
    assert!(matches!(s.motion(&tilted), Err(SimError::InvalidMotion { .. })));
}
