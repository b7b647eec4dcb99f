//! Spatial queries of `MeshIndex` against analytic shapes and independent computations.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use s2g_geom::{
    Aabb, BoxShape, GeomError, Isometry3, Mesh, MeshIndex, OccluderCache, Point3, Rotation3, SignedDistance,
    Similarity3, Vector3,
};

/// The closed, outward box `[min, max]`.
fn box_mesh(min: Point3, max: Point3) -> Mesh {
    Mesh::cuboid(&Aabb::new(min, max)).unwrap()
}

/// A regular tetrahedron-ish mesh, outward wound.
fn tetrahedron() -> Mesh {
    let v = vec![
        Point3::new(0.0, 0.0, 0.0),
        Point3::new(1.0, 0.0, 0.0),
        Point3::new(0.0, 1.0, 0.0),
        Point3::new(0.0, 0.0, 1.0),
    ];
    Mesh::new(v, vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]).unwrap()
}

fn bunny() -> Mesh {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/stanford_bunny.stl");
    s2g_geom::load_mesh(path).unwrap_or_else(|e| panic!("loading {path}: {e}"))
}

fn random_unit(rng: &mut StdRng) -> Vector3 {
    loop {
        let v = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

fn random_point(rng: &mut StdRng, lo: f64, hi: f64) -> Point3 {
    Point3::new(rng.random_range(lo..hi), rng.random_range(lo..hi), rng.random_range(lo..hi))
}

/// Analytic first hit of a ray with the surface of an axis-aligned box, with the slab
/// method: `(t, outward normal)`; `None` for a miss. Also returns a margin: how far the ray
/// is from grazing an edge (small margins are skipped as ambiguous).
fn slab_hit(min: &Point3, max: &Point3, o: &Point3, d: &Vector3) -> (Option<(f64, Vector3)>, f64) {
    let mut tnear = f64::NEG_INFINITY;
    let mut tfar = f64::INFINITY;
    let (mut an, mut af) = (0, 0);
    for a in 0..3 {
        let inv = 1.0 / d[a];
        let (t1, t2) = ((min[a] - o[a]) * inv, (max[a] - o[a]) * inv);
        let (lo, hi) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
        if lo > tnear {
            tnear = lo;
            an = a;
        }
        if hi < tfar {
            tfar = hi;
            af = a;
        }
    }
    let margin = (tfar - tnear).abs();
    if tnear > tfar || tfar < 0.0 {
        return (None, margin);
    }
    let (t, axis, entering) = if tnear >= 0.0 { (tnear, an, true) } else { (tfar, af, false) };
    let mut n = Vector3::zeros();
    // Entering through a face: the normal opposes the ray; leaving: it follows it.
    n[axis] = if entering { -d[axis].signum() } else { d[axis].signum() };
    (Some((t, n)), margin)
}

/// 1,000 seeded random rays against a box mesh, placed by `iso`, vs the analytic slab test.
fn check_rays_against_box(iso: &Isometry3, seed: u64) {
    let (min, max) = (Point3::new(-1.0, -0.5, 0.0), Point3::new(2.0, 1.0, 3.0));
    let sim = Similarity3::from_isometry(*iso, 1.0);
    let mesh = box_mesh(min, max).transformed(&sim);
    let index = MeshIndex::new(&mesh).unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    let mut hits = 0;
    let mut checked = 0;
    for r in 0..1000 {
        let o_local = random_point(&mut rng, -3.0, 5.0);
        // Half the rays aim at a random point of the box, half go anywhere.
        let d_local = if r % 2 == 0 {
            let target = Point3::new(
                rng.random_range(min.x..max.x),
                rng.random_range(min.y..max.y),
                rng.random_range(min.z..max.z),
            );
            (target - o_local).normalize()
        } else {
            random_unit(&mut rng)
        };
        let (expect, margin) = slab_hit(&min, &max, &o_local, &d_local);
        let o = iso * o_local;
        let d = iso * d_local;
        let got = index.cast_ray(&o, &d, f64::INFINITY);
        let any = index.ray_hits_any(&o, &d, f64::INFINITY);
        assert_eq!(got.is_some(), any, "ray {r} (seed {seed}): cast_ray and ray_hits_any disagree");
        if margin < 1e-6 {
            continue; // grazing an edge: either answer is right
        }
        checked += 1;
        match (expect, got) {
            (None, None) => {}
            (Some((t, n)), Some(hit)) => {
                hits += 1;
                assert!(
                    (hit.distance - t).abs() < 1e-9,
                    "ray {r}: distance {} vs analytic {t}",
                    hit.distance
                );
                assert!((hit.point - (o + d * t)).norm() < 1e-9, "ray {r}: hit point");
                assert!(
                    (hit.normal - iso * n).norm() < 1e-9,
                    "ray {r}: normal {:?} vs {:?}",
                    hit.normal,
                    iso * n
                );
                // A shorter segment that stops before the hit misses; one just past hits.
                assert!(
                    !index.ray_hits_any(&o, &d, t * (1.0 - 1e-9) - 1e-9),
                    "ray {r}: hit before its distance"
                );
                assert!(index.ray_hits_any(&o, &d, t + 1e-9), "ray {r}: no hit at its distance");
            }
            (e, g) => panic!("ray {r} (seed {seed}, {o_local:?} + t {d_local:?}): analytic {e:?}, got {g:?}"),
        }
    }
    assert!(hits > 200 && checked > 990, "too few informative rays: {hits} hits of {checked}");
}

#[test]
fn random_rays_match_the_analytic_box() {
    check_rays_against_box(&Isometry3::identity(), 1);
}

#[test]
fn random_rays_match_the_rotated_and_translated_box() {
    let iso = Isometry3::from_parts(
        nalgebra::Translation3::new(120.0, -35.5, 17.25),
        Rotation3::from_euler_angles(0.3, -1.1, 2.4),
    );
    check_rays_against_box(&iso, 2);
}

#[test]
fn closest_point_and_signed_distance_match_the_analytic_box() {
    for (k, iso) in [
        Isometry3::identity(),
        Isometry3::from_parts(
            nalgebra::Translation3::new(-7.0, 3.0, 250.0),
            Rotation3::from_euler_angles(-0.7, 0.4, 1.9),
        ),
    ]
    .iter()
    .enumerate()
    {
        let shape = BoxShape { min: Point3::new(-1.0, -0.5, 0.0), max: Point3::new(2.0, 1.0, 3.0) };
        let mesh = box_mesh(shape.min, shape.max).transformed(&Similarity3::from_isometry(*iso, 1.0));
        let index = MeshIndex::new(&mesh).unwrap();
        let mut rng = StdRng::seed_from_u64(10 + k as u64);
        for i in 0..1000 {
            let pl = random_point(&mut rng, -3.0, 5.0);
            let p = iso * pl;
            let want = shape.distance(&pl);
            let cp = index.closest_point(&p);
            assert!(
                (cp.distance - want.abs()).abs() < 1e-9,
                "point {i} ({pl:?}, placement {k}): {cp:?} vs {want}"
            );
            assert!(((cp.point - p).norm() - cp.distance).abs() < 1e-9, "point {i}: closest point off");
            assert!(
                shape.distance(&iso.inverse_transform_point(&cp.point)).abs() < 1e-9,
                "point {i}: not on box"
            );
            let sd = index.signed_distance(&p);
            if want.abs() > 1e-9 {
                assert!((sd - want).abs() < 1e-9, "point {i} ({pl:?}, placement {k}): sd {sd} vs {want}");
                assert_eq!(index.contains(&p), want < 0.0, "point {i}: contains");
            }
            assert!((SignedDistance::distance(&index, &p) - sd).abs() == 0.0);
        }
    }
}

#[test]
fn winding_number_of_closed_meshes_is_one_inside_and_zero_outside() {
    let tet = MeshIndex::new(&tetrahedron()).unwrap();
    let cube = MeshIndex::new(&box_mesh(Point3::new(-1.0, -1.0, -1.0), Point3::new(1.0, 1.0, 1.0))).unwrap();
    let mut rng = StdRng::seed_from_u64(3);
    for i in 0..2000 {
        let p = random_point(&mut rng, -1.5, 1.5);
        // The far field is a second-order expansion: a few 1e-3 of error, never near 0.5.
        let w = tet.winding_number(&p);
        let inside = p.x > 0.0 && p.y > 0.0 && p.z > 0.0 && p.x + p.y + p.z < 1.0;
        assert!((w - if inside { 1.0 } else { 0.0 }).abs() < 0.01, "tetrahedron, point {i} {p:?}: w = {w}");
        let exact = tet.winding_number_exact(&p);
        assert!(
            (exact - if inside { 1.0 } else { 0.0 }).abs() < 1e-9,
            "tetrahedron, point {i}: exact {exact}"
        );
        let w = cube.winding_number(&p);
        let inside = p.iter().all(|c| c.abs() < 1.0);
        assert!((w - if inside { 1.0 } else { 0.0 }).abs() < 0.01, "cube, point {i} {p:?}: w = {w}");
        let exact = cube.winding_number_exact(&p);
        assert!((exact - if inside { 1.0 } else { 0.0 }).abs() < 1e-9, "cube, point {i}: exact {exact}");
    }
}

#[test]
fn winding_number_tolerates_a_missing_face() {
    // A cube [-1, 1]^3 without its +z face.
    let closed = box_mesh(Point3::new(-1.0, -1.0, -1.0), Point3::new(1.0, 1.0, 1.0));
    let (v, mut t) = closed.into_parts();
    t.drain(2..4);
    let open = MeshIndex::new(&Mesh::new(v, t).unwrap()).unwrap();
    // The centre sees five of the six faces.
    let w = open.winding_number(&Point3::origin());
    assert!((w - 5.0 / 6.0).abs() < 1e-9, "open cube centre: w = {w}");
    let mut rng = StdRng::seed_from_u64(4);
    for i in 0..2000 {
        let p = random_point(&mut rng, -2.0, 2.0);
        let inside = p.iter().all(|c| c.abs() < 1.0);
        // Near the open face the field is genuinely ambiguous: skip a slab around it.
        if (p.z - 1.0).abs() < 0.6 && p.x.abs() < 1.2 && p.y.abs() < 1.2 {
            continue;
        }
        if inside && p.iter().any(|c| c.abs() > 0.98) {
            continue;
        }
        assert_eq!(open.contains(&p), inside, "open cube, point {i} {p:?}: w = {}", open.winding_number(&p));
    }
}

#[test]
fn fast_winding_number_matches_the_exact_sum_on_the_bunny() {
    let mesh = bunny();
    let index = MeshIndex::new(&mesh).unwrap();
    let bb = mesh.bbox().unwrap().inflated(0.1 * mesh.bbox().unwrap().extent().max());
    let mut rng = StdRng::seed_from_u64(5);
    let mut worst = 0.0f64;
    for _ in 0..300 {
        let p = Point3::new(
            rng.random_range(bb.min.x..bb.max.x),
            rng.random_range(bb.min.y..bb.max.y),
            rng.random_range(bb.min.z..bb.max.z),
        );
        let fast = index.winding_number(&p);
        let exact = index.winding_number_exact(&p);
        worst = worst.max((fast - exact).abs());
        // Second-order far field at BETA = 2.5: errors of a few percent at worst, well
        // away from the 0.5 threshold wherever the exact value is not near it.
        assert!((fast - exact).abs() < 0.05, "bunny at {p:?}: fast {fast} vs exact {exact}");
        if (exact - 0.5).abs() > 0.05 {
            assert_eq!(fast >= 0.5, exact >= 0.5, "bunny at {p:?}: inside test flips");
        }
    }
    eprintln!("bunny fast winding: worst error {worst:.2e} over 300 points");
}

#[test]
fn sign_of_distance_agrees_with_winding_and_rays_on_the_bunny() {
    let mesh = bunny();
    let index = MeshIndex::new(&mesh).unwrap();
    let bb = mesh.bbox().unwrap();
    let nudge = 1e-9 * bb.extent().max();
    let mut rng = StdRng::seed_from_u64(6);
    let pts: Vec<Point3> = (0..2000)
        .map(|_| {
            Point3::new(
                rng.random_range(bb.min.x..bb.max.x),
                rng.random_range(bb.min.y..bb.max.y),
                rng.random_range(bb.min.z..bb.max.z),
            )
        })
        .collect();
    let sd = index.par_signed_distance(&pts);
    let inside = index.par_contains(&pts);
    let mut disagree_parity = 0;
    for (i, p) in pts.iter().enumerate() {
        let w = index.winding_number(p);
        assert_eq!(sd[i] < 0.0, w >= 0.5, "point {i} {p:?}: sd {} and winding {w}", sd[i]);
        assert_eq!(inside[i], w >= 0.5, "point {i}: par_contains");
        assert!((sd[i].abs() - index.closest_point(p).distance).abs() == 0.0);
        // Independent check: parity of ray crossings along a random direction.
        let d = random_unit(&mut rng);
        let mut o = *p;
        let mut crossings = 0;
        while let Some(hit) = index.cast_ray(&o, &d, f64::INFINITY) {
            crossings += 1;
            o = hit.point + d * nudge;
            if crossings > 1000 {
                break;
            }
        }
        if (crossings % 2 == 1) != inside[i] && sd[i].abs() > 1e-6 {
            disagree_parity += 1;
        }
    }
    // The bunny has small holes, so parity is only nearly always right.
    assert!(disagree_parity <= 10, "winding and ray parity disagree on {disagree_parity} of 2000 points");
}

#[test]
fn queries_transform_with_the_mesh() {
    let mesh = bunny();
    let sim = Similarity3::from_parts(
        nalgebra::Translation3::new(31.0, -12.5, 400.0),
        Rotation3::from_euler_angles(1.2, 0.1, -2.2),
        1.0,
    );
    let a = MeshIndex::new(&mesh).unwrap();
    let b = MeshIndex::new(&mesh.transformed(&sim)).unwrap();
    let bb = mesh.bbox().unwrap();
    let scale = bb.extent().max();
    let mut rng = StdRng::seed_from_u64(7);
    let mut hits = 0;
    for i in 0..500 {
        let p = Point3::new(
            rng.random_range(bb.min.x..bb.max.x),
            rng.random_range(bb.min.y..bb.max.y),
            rng.random_range(bb.min.z..bb.max.z),
        );
        let d = random_unit(&mut rng);
        let (ha, hb) = (a.cast_ray(&p, &d, f64::INFINITY), b.cast_ray(&(sim * p), &(sim * d), f64::INFINITY));
        match (ha, hb) {
            (Some(x), Some(y)) => {
                hits += 1;
                assert!((x.distance - y.distance).abs() < 1e-9 * scale, "ray {i}: {x:?} vs {y:?}");
                assert!((sim * x.point - y.point).norm() < 1e-8 * scale, "ray {i}: hit point");
                if x.triangle == y.triangle {
                    assert!((sim * x.normal - y.normal).norm() < 1e-9, "ray {i}: normal");
                }
            }
            (None, None) => {}
            (x, y) => panic!("ray {i} from {p:?} along {d:?}: {x:?} vs transformed {y:?}"),
        }
        let (ca, cb) = (a.closest_point(&p), b.closest_point(&(sim * p)));
        assert!((ca.distance - cb.distance).abs() < 1e-9 * scale, "point {i}: {ca:?} vs {cb:?}");
        // The trees differ (the boxes are axis-aligned), so the far-field errors differ.
        let (wa, wb) = (a.winding_number(&p), b.winding_number(&(sim * p)));
        assert!((wa - wb).abs() < 0.05, "point {i}: winding {wa} vs transformed {wb}");
        if (wa - 0.5).abs() > 0.05 {
            assert_eq!(a.contains(&p), b.contains(&(sim * p)), "point {i}: contains");
        }
    }
    assert!(hits > 100, "only {hits} hits");
}

#[test]
fn any_hit_agrees_with_a_brute_force_loop_on_the_bunny() {
    let mesh = bunny();
    let index = MeshIndex::new(&mesh).unwrap();
    let samples = s2g_geom::sample_surface(&mesh, 400, 8).unwrap();
    let mut rng = StdRng::seed_from_u64(8);
    let scale = mesh.bbox().unwrap().extent().max();
    let mut checked = 0;
    let (mut cache, mut cache_hits) = (OccluderCache::default(), 0);
    for (i, (p, n)) in samples.points.iter().zip(&samples.normals).enumerate() {
        let o = p + n * 1e-6 * scale;
        let d = random_unit(&mut rng);
        // Brute force: the nearest Möller–Trumbore hit over all triangles.
        let mut best = f64::INFINITY;
        for [a, b, c] in mesh.triangle_points() {
            let (e1, e2) = (b - a, c - a);
            let pv = d.cross(&e2);
            let det = e1.dot(&pv);
            if det.abs() < 1e-300 {
                continue;
            }
            let s = o - a;
            let u = s.dot(&pv) / det;
            let q = s.cross(&e1);
            let v = d.dot(&q) / det;
            let t = e2.dot(&q) / det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= 0.0 {
                best = best.min(t);
            }
        }
        let hit = index.cast_ray(&o, &d, f64::INFINITY);
        match hit {
            Some(h) => {
                assert!((h.distance - best).abs() < 1e-9 * scale, "ray {i}: {} vs brute {best}", h.distance)
            }
            None => assert!(best.is_infinite(), "ray {i}: missed, brute force hits at {best}"),
        }
        assert_eq!(index.ray_hits_any(&o, &d, scale * 10.0), best.is_finite(), "ray {i}: any-hit");
        assert_eq!(index.ray_hits_any(&o, &d, f64::INFINITY), best.is_finite(), "ray {i}: unbounded any-hit");
        // The occluder cache carries the last blocking triangle from ray to ray: it must
        // never change the answer, whether the remembered triangle blocks this ray or not.
        assert_eq!(
            index.ray_hits_any_cached(&o, &d, scale * 10.0, &mut cache),
            best.is_finite(),
            "ray {i}: any-hit with the cache"
        );
        if best.is_finite() {
            assert!(
                !index.ray_hits_any(&o, &d, best * (1.0 - 1e-7)),
                "ray {i}: any-hit before the first hit"
            );
            assert!(
                !index.ray_hits_any_cached(&o, &d, best * (1.0 - 1e-7), &mut cache),
                "ray {i}: cached any-hit before the first hit"
            );
            cache_hits += usize::from(index.ray_hits_any_cached(&o, &d, best * (1.0 + 1e-7), &mut cache));
        }
        checked += 1;
    }
    assert_eq!(checked, 400);
    assert!(cache_hits > 100, "the cached query finds the hits: {cache_hits}");
}

#[test]
fn degenerate_inputs_give_documented_fallbacks() {
    assert!(matches!(MeshIndex::new(&Mesh::default()), Err(GeomError::EmptyMesh)));
    let index = MeshIndex::new(&tetrahedron()).unwrap();
    let nan = Point3::new(f64::NAN, 0.0, 0.0);
    let o = Point3::new(0.1, 0.1, -1.0);
    assert!(index.cast_ray(&o, &Vector3::zeros(), 10.0).is_none());
    assert!(!index.ray_hits_any(&o, &Vector3::zeros(), 10.0));
    assert!(index.cast_ray(&nan, &Vector3::z(), 10.0).is_none());
    assert!(!index.ray_hits_any(&o, &Vector3::new(f64::NAN, 0.0, 1.0), 10.0));
    assert!(index.cast_ray(&o, &Vector3::z(), f64::NAN).is_none());
    assert!(index.cast_ray(&o, &Vector3::z(), 10.0).is_some());
    assert!(index.ray_hits_any(&o, &Vector3::z(), f64::INFINITY));
    assert!(!index.ray_hits_any(&o, &Vector3::z(), 0.5));
    let cp = index.closest_point(&nan);
    assert!(cp.distance.is_nan() && cp.triangle == u32::MAX);
    assert!(!index.contains(&nan));
    assert!(index.signed_distance(&nan).is_nan());
    // A mesh of only degenerate triangles: queries answer "nothing there" without panicking.
    let flat = Mesh::new(
        vec![Point3::origin(), Point3::new(1.0, 0.0, 0.0), Point3::new(2.0, 0.0, 0.0)],
        vec![[0, 1, 2]],
    )
    .unwrap();
    let flat = MeshIndex::new(&flat).unwrap();
    assert!(flat.cast_ray(&Point3::new(1.0, 0.0, -1.0), &Vector3::z(), 10.0).is_none());
    assert!((flat.closest_point(&Point3::new(1.0, 1.0, 0.0)).distance - 1.0).abs() < 1e-12);
    assert_eq!(flat.winding_number(&Point3::new(1.0, 1.0, 0.0)), 0.0);
}

#[test]
fn batch_queries_match_single_queries() {
    let mesh = bunny();
    let index = MeshIndex::new(&mesh).unwrap();
    let bb = mesh.bbox().unwrap();
    let mut rng = StdRng::seed_from_u64(9);
    let rays: Vec<(Point3, Vector3)> = (0..3000)
        .map(|_| {
            let p = Point3::new(
                rng.random_range(bb.min.x..bb.max.x),
                rng.random_range(bb.min.y..bb.max.y),
                rng.random_range(bb.min.z..bb.max.z),
            );
            (p, random_unit(&mut rng))
        })
        .collect();
    let batch = index.par_cast_rays(&rays, 1.0);
    let any = index.par_ray_hits_any(&rays, 1.0);
    for (i, (o, d)) in rays.iter().enumerate() {
        assert_eq!(batch[i], index.cast_ray(o, d, 1.0), "ray {i}");
        assert_eq!(any[i], batch[i].is_some(), "ray {i}");
    }
    let pts: Vec<Point3> = rays.iter().map(|r| r.0).collect();
    let cps = index.par_closest_points(&pts);
    let ws = index.par_winding_number(&pts);
    for (i, p) in pts.iter().enumerate() {
        assert_eq!(cps[i], index.closest_point(p), "point {i}");
        assert_eq!(ws[i], index.winding_number(p), "point {i}");
    }
}
