//! Scallop closed forms against a simulated cross-section, and parallel finishing's
//! adaptive sampling against its own tolerance.

use s2g_geom::{Cutter, DropCutter, Mesh, MeshIndex, Point3};
use s2g_toolpath::finish::{
    FinishError, ParallelFinishOptions, parallel_finish, parallel_finish_opt, scallop_height,
    stepover_for_scallop,
};

/// A plane `z = x tan(a)` as two large triangles.
fn slope_plane(a: f64) -> Mesh {
    let z = |x: f64| x * a.tan();
    let c =
        [(-60.0, -60.0), (60.0, -60.0), (60.0, 60.0), (-60.0, 60.0)].map(|(x, y)| Point3::new(x, y, z(x)));
    Mesh::new(c.to_vec(), vec![[0, 1, 2], [0, 2, 3]]).unwrap()
}

/// The cutter's lower outline above the tip at distance `d` (independent of the library).
fn lift(c: &Cutter, d: f64) -> f64 {
    if d > c.radius {
        return f64::INFINITY;
    }
    let rc = c.corner_radius();
    let e = d - (c.radius - rc);
    if e <= 0.0 { 0.0 } else { rc - (rc * rc - e * e).max(0.0).sqrt() }
}

/// The scallop by simulation: two passes' tips from drop-cutter on a tilted plane mesh,
/// the material left between them sampled densely, measured normal to the plane.
fn simulated_scallop(c: &Cutter, s: f64, a: f64) -> f64 {
    let index = MeshIndex::new(&slope_plane(a)).unwrap();
    let dc = DropCutter::new(&index, c).unwrap();
    let (t0, t1) = (dc.height(0.0, 0.0).unwrap(), dc.height(s, 0.0).unwrap());
    let n = 400_000;
    let (lo, hi) = (-c.radius, s + c.radius);
    let mut worst: f64 = 0.0;
    // Between the two contact points only (elsewhere other passes cut).
    let contact = if a == 0.0 { 0.0 } else { (c.radius - c.corner_radius()) + c.corner_radius() * a.sin() };
    for i in 0..=n {
        let x = lo + (hi - lo) * i as f64 / n as f64;
        if x < contact || x > s + contact {
            continue;
        }
        let env = (t0 + lift(c, x.abs())).min(t1 + lift(c, (x - s).abs()));
        worst = worst.max(env - x * a.tan());
    }
    worst * a.cos()
}

fn cutters() -> [Cutter; 4] {
    [
        Cutter::ball(3.0, 10.0),
        Cutter::bull(4.0, 1.0, 10.0),
        Cutter::bull(2.0, 1.5, 10.0),
        Cutter::flat(3.0, 10.0),
    ]
}

#[test]
fn scallop_height_matches_a_simulated_cross_section() {
    for c in cutters() {
        for a in [0.0f64, 0.1, 0.5, 1.0] {
            for s in [0.2, 0.8, 1.7] {
                let want = simulated_scallop(&c, s, a);
                let got = scallop_height(&c, s, a).unwrap();
                let res = (s + 2.0 * c.radius) / 400_000.0 * (1.0 + a.tan());
                assert!((got - want).abs() <= 1e-9 + res, "{c:?} slope {a} stepover {s}: {got} vs {want}");
            }
        }
    }
}

#[test]
fn closed_forms_invert_the_scallop_height() {
    let ball = Cutter::ball(3.0, 10.0);
    for (h, a) in [(0.01, 0.0), (0.01, 0.6), (0.002, 1.2), (0.1, 0.3)] {
        let s = stepover_for_scallop(&ball, h, a).unwrap();
        let want = 2.0 * a.cos() * (2.0 * 3.0 * h - h * h).sqrt();
        assert!((s - want).abs() < 1e-12, "ball {h} {a}: {s} vs {want}");
        assert!((scallop_height(&ball, s, a).unwrap() - h).abs() < 1e-9, "ball {h} {a}");
    }
    let bull = Cutter::bull(4.0, 1.0, 10.0);
    let s = stepover_for_scallop(&bull, 0.01, 0.0).unwrap();
    assert!((s - (6.0 + 2.0 * (0.02f64 - 1e-4).sqrt())).abs() < 1e-12);
    for (h, a) in [(0.01, 0.0), (0.01, 0.2), (0.005, 0.7), (0.05, 1.3)] {
        let s = stepover_for_scallop(&bull, h, a).unwrap();
        assert!((scallop_height(&bull, s, a).unwrap() - h).abs() < 1e-9, "bull {h} {a}: stepover {s}");
        // And the stepover is the largest: a little more leaves a higher scallop.
        assert!(scallop_height(&bull, s * 1.001, a).unwrap() > h, "bull {h} {a}");
    }
    let flat = Cutter::flat(3.0, 10.0);
    assert_eq!(stepover_for_scallop(&flat, 0.01, 0.0).unwrap(), 6.0);
    let s = stepover_for_scallop(&flat, 0.01, 0.4).unwrap();
    assert!((s - 0.01 / 0.4f64.sin()).abs() < 1e-12);
    assert!((scallop_height(&flat, s, 0.4).unwrap() - 0.01).abs() < 1e-9);
    // Slope correction: the steeper the surface, the closer the passes.
    let s0 = stepover_for_scallop(&bull, 0.01, 0.0).unwrap();
    let s1 = stepover_for_scallop(&bull, 0.01, 0.5).unwrap();
    assert!(s1 < s0, "{s1} vs {s0}");
}

#[test]
fn scallop_arguments_are_checked() {
    let ball = Cutter::ball(1.0, 4.0);
    assert!(matches!(scallop_height(&ball, f64::NAN, 0.0), Err(FinishError::InvalidOptions(_))));
    assert!(matches!(scallop_height(&ball, 5.0, 0.0), Err(FinishError::InvalidOptions(_))));
    assert!(matches!(scallop_height(&ball, 0.5, 1.6), Err(FinishError::InvalidOptions(_))));
    assert!(matches!(stepover_for_scallop(&ball, 0.0, 0.0), Err(FinishError::InvalidOptions(_))));
    assert!(matches!(
        stepover_for_scallop(&Cutter::ball(-1.0, 4.0), 0.01, 0.0),
        Err(FinishError::InvalidTool(_))
    ));
    assert_eq!(scallop_height(&ball, 0.0, 0.3).unwrap(), 0.0);
}

/// The bundled bunny scaled to 50 mm, its lowest corner at the origin.
fn bunny_50mm() -> Mesh {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
    let mesh = s2g_geom::load_mesh(path).unwrap();
    let b = mesh.bbox().unwrap();
    let s = 50.0 / b.extent().max();
    mesh.transformed(&s2g_geom::Similarity3::new(-b.min.coords * s, nalgebra::Vector3::zeros(), s))
}

/// Over the bunny every segment is within the tolerance of the drop-cutter surface at its
/// midpoint (or no longer than `min_step`), every point is on that surface and in the
/// rectangle, and passes are `stepover` apart along the angle, alternating direction.
#[test]
fn parallel_finish_refines_to_its_tolerance() {
    let index = MeshIndex::new(&bunny_50mm()).unwrap();
    let dc = DropCutter::new(&index, &Cutter::ball(2.0, 10.0)).unwrap();
    let opts = ParallelFinishOptions { angle: 0.4, stepover: 1.5, ..ParallelFinishOptions::default() };
    let (min, max) = ([-3.0, -2.0], [53.0, 52.0]);
    let paths = parallel_finish_opt(&dc, min, max, &opts).unwrap();
    assert_eq!(paths, parallel_finish_opt(&dc, min, max, &opts).unwrap(), "deterministic");
    let (dir, normal) = ([0.4f64.cos(), 0.4f64.sin()], [-(0.4f64.sin()), 0.4f64.cos()]);
    // Pass k lies at offset `first + k stepover` across the angle, centred on the rectangle.
    let corners = [[min[0], min[1]], [max[0], min[1]], [max[0], max[1]], [min[0], max[1]]];
    let offs: Vec<f64> = corners.iter().map(|c| c[0] * normal[0] + c[1] * normal[1]).collect();
    let (olo, ohi) = offs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &o| (a.min(o), b.max(o)));
    let count = ((ohi - olo) / 1.5).floor() + 1.0;
    let first = 0.5 * (olo + ohi) - 0.5 * (count - 1.0) * 1.5;
    let mut refined = 0;
    for path in &paths {
        assert!(path.len() >= 2);
        let off = path[0].x * normal[0] + path[0].y * normal[1];
        let k = ((off - first) / 1.5).round();
        assert!((off - first - k * 1.5).abs() < 1e-9, "a pass at offset {off} is not on the stepover grid");
        let t = |p: &Point3| p.x * dir[0] + p.y * dir[1];
        let forward = t(&path[1]) > t(&path[0]);
        assert_eq!(forward, k as i64 % 2 == 0, "pass {k} direction (zigzag)");
        for p in path {
            assert!((p.x * normal[0] + p.y * normal[1] - off).abs() < 1e-9, "pass {k} is straight");
            assert!(
                p.x >= min[0] - 1e-9 && p.x <= max[0] + 1e-9 && p.y >= min[1] - 1e-9 && p.y <= max[1] + 1e-9
            );
            assert_eq!(Some(p.z), dc.height(p.x, p.y));
        }
        for w in path.windows(2) {
            let len = ((w[1].x - w[0].x).powi(2) + (w[1].y - w[0].y).powi(2)).sqrt();
            assert!(len <= opts.sample_step + 1e-9);
            if len > opts.min_step {
                let (mx, my) = (0.5 * (w[0].x + w[1].x), 0.5 * (w[0].y + w[1].y));
                let zm = dc.height(mx, my).unwrap();
                assert!(
                    (zm - 0.5 * (w[0].z + w[1].z)).abs() <= opts.tolerance,
                    "pass {k}: chord off at ({mx}, {my})"
                );
            }
            if len < 0.99 * opts.sample_step / 2.0 {
                refined += 1;
            }
        }
    }
    assert!(refined > 100, "curved surface refined: {refined}");
}

/// On a flat top the passes keep their first, uniform samples; a floor joins the part
/// where the cutter touches nothing.
#[test]
fn flat_areas_stay_coarse_and_the_floor_fills_gaps() {
    let block =
        Mesh::cuboid(&s2g_geom::Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(10.0, 10.0, 2.0))).unwrap();
    let index = MeshIndex::new(&block).unwrap();
    let dc = DropCutter::new(&index, &Cutter::ball(1.0, 4.0)).unwrap();
    let opts = ParallelFinishOptions { stepover: 1.0, ..ParallelFinishOptions::default() };
    let paths = parallel_finish_opt(&dc, [2.0, 2.0], [8.0, 8.0], &opts).unwrap();
    assert_eq!(paths.len(), 7);
    assert!(paths.iter().all(|p| p.len() == 7 && p.iter().all(|q| q.z == 2.0)), "{paths:?}");
    // Wider than the block: without a floor each pass is cut where nothing is touched.
    let wide = parallel_finish_opt(&dc, [-5.0, 4.0], [15.0, 4.0], &opts).unwrap();
    assert_eq!(wide.len(), 1);
    let first = wide[0].first().unwrap();
    assert!((first.x - -1.0).abs() < 0.03, "contact starts one radius off the block: {first:?}");
    let with_floor = ParallelFinishOptions { floor: Some(-1.0), ..opts };
    let filled = parallel_finish_opt(&dc, [-5.0, 4.0], [15.0, 4.0], &with_floor).unwrap();
    assert_eq!(filled.len(), 1);
    assert_eq!(filled[0].first().unwrap().z, -1.0);
    assert!(parallel_finish(&dc, [0.0, 0.0], [f64::NAN, 1.0]).is_err());
    let bad = ParallelFinishOptions { stepover: 0.0, ..opts };
    assert!(matches!(
        parallel_finish_opt(&dc, [0.0, 0.0], [1.0, 1.0], &bad),
        Err(FinishError::InvalidOptions(_))
    ));
}
