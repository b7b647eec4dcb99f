//! Drop-cutter against brute force on random triangles and against analytic answers.

use s2g_geom::{Aabb, Cutter, DropCutter, GeomError, Mesh, MeshIndex, Point3, SplitMix64};

use crate::shapes::{cylinder, sphere};

/// The cutter's surface height above the tip at distance `d` from the axis (independent
/// of the library's profile code).
fn lift(c: &Cutter, d: f64) -> Option<f64> {
    if d > c.radius {
        return None;
    }
    let rc = c.corner_radius();
    let e = d - (c.radius - rc);
    Some(if e <= 0.0 { 0.0 } else { rc - (rc * rc - e * e).max(0.0).sqrt() })
}

/// The contact height of the point `p` for the cutter above `(x, y)`.
fn contact(c: &Cutter, p: Point3, x: f64, y: f64) -> f64 {
    let d = ((p.x - x).powi(2) + (p.y - y).powi(2)).sqrt();
    lift(c, d).map_or(f64::NEG_INFINITY, |h| p.z - h)
}

/// Brute force over one triangle: the best contact on a barycentric grid, then four rounds
/// of a finer grid around the best point so far (the contact height is concave on the
/// triangle, so the best sample is near the maximum).
fn brute_triangle(c: &Cutter, t: [Point3; 3], x: f64, y: f64) -> f64 {
    let at = |s: f64, u: f64| Point3::from(t[0].coords * (1.0 - s - u) + t[1].coords * s + t[2].coords * u);
    let n = 120;
    let (mut best, mut bs, mut bu) = (f64::NEG_INFINITY, 0.0, 0.0);
    for i in 0..=n {
        for j in 0..=n - i {
            let (s, u) = (i as f64 / n as f64, j as f64 / n as f64);
            let v = contact(c, at(s, u), x, y);
            if v > best {
                (best, bs, bu) = (v, s, u);
            }
        }
    }
    let mut delta = 1.0 / n as f64;
    for _ in 0..8 {
        let (cs, cu) = (bs, bu);
        let m = 30;
        delta /= 4.0;
        for i in -m..=m {
            for j in -m..=m {
                let (s, u) = (cs + i as f64 * delta, cu + j as f64 * delta);
                if s < 0.0 || u < 0.0 || s + u > 1.0 {
                    continue;
                }
                let v = contact(c, at(s, u), x, y);
                if v > best {
                    (best, bs, bu) = (v, s, u);
                }
            }
        }
    }
    // The edges, and the rim of the cutter's disc (where a flat end's contact with a facet
    // is: the facet's points under the rim), each a one-dimensional search.
    for (a, b) in [(0, 1), (1, 2), (2, 0)] {
        best = best.max(zoom1(|s| contact(c, t[a] + (t[b] - t[a]) * s, x, y), 0.0, 1.0));
    }
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let det = e1.x * e2.y - e1.y * e2.x;
    if det.abs() > 1e-12 {
        let rim = |a: f64| {
            let (px, py) = (x + c.radius * a.cos() - t[0].x, y + c.radius * a.sin() - t[0].y);
            let (s, u) = ((px * e2.y - py * e2.x) / det, (e1.x * py - e1.y * px) / det);
            if s >= 0.0 && u >= 0.0 && s + u <= 1.0 { contact(c, at(s, u), x, y) } else { f64::NEG_INFINITY }
        };
        best = best.max(zoom1(rim, 0.0, std::f64::consts::TAU));
    }
    best
}

/// The maximum of `f` on `[lo, hi]`: a grid of 4000 samples, then eight rounds of a grid
/// four times finer around the best sample so far.
fn zoom1(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    let n = 4000;
    let mut delta = (hi - lo) / n as f64;
    let (mut best, mut at) = (f64::NEG_INFINITY, lo);
    for i in 0..=n {
        let s = lo + i as f64 * delta;
        if f(s) > best {
            (best, at) = (f(s), s);
        }
    }
    for _ in 0..8 {
        let centre = at;
        delta /= 4.0;
        for i in -30..=30 {
            let s = (centre + i as f64 * delta).clamp(lo, hi);
            let v = f(s);
            if v > best {
                (best, at) = (v, s);
            }
        }
    }
    best
}

fn cutters() -> [Cutter; 5] {
    [
        Cutter::flat(1.0, 4.0),
        Cutter::ball(1.0, 4.0),
        Cutter::bull(1.0, 0.3, 4.0),
        Cutter::bull(1.5, 0.5, 4.0),
        Cutter::bull(0.8, 0.79, 4.0),
    ]
}

fn random_point(rng: &mut SplitMix64, s: f64) -> Point3 {
    Point3::new(s * (2.0 * rng.unit() - 1.0), s * (2.0 * rng.unit() - 1.0), s * (2.0 * rng.unit() - 1.0))
}

/// On random triangles the exact answer is never below a brute-force sample (it would
/// gouge) and never more than the brute force's resolution above the best one.
#[test]
fn random_triangles_agree_with_brute_force() {
    let mut rng = SplitMix64::new(36, 0);
    for (ci, c) in cutters().iter().enumerate() {
        let mut hits = 0;
        for k in 0..150 {
            let t = [0; 3].map(|_| random_point(&mut rng, 1.0));
            let mesh = Mesh::new(t.to_vec(), vec![[0, 1, 2]]).unwrap();
            let index = MeshIndex::new(&mesh).unwrap();
            let dc = DropCutter::new(&index, c).unwrap();
            for _ in 0..4 {
                let (x, y) = (2.4 * rng.unit() - 1.2, 2.4 * rng.unit() - 1.2);
                let want = brute_triangle(c, t, x, y);
                let got = dc.height(x, y);
                let tag = format!("cutter {ci}, triangle {k} {t:?}, at ({x}, {y})");
                match got {
                    None => assert_eq!(want, f64::NEG_INFINITY, "{tag}: no contact, brute force {want}"),
                    Some(h) => {
                        hits += 1;
                        assert!(h >= want - 1e-9, "{tag}: {h} below a sampled contact {want}");
                        assert!(h <= want + 1e-6, "{tag}: {h} above the best sampled contact {want}");
                    }
                }
            }
        }
        assert!(hits > 300, "cutter {ci}: only {hits} contacts");
    }
}

/// A random mesh of many triangles: the BVH's pruning gives the maximum over all
/// triangles' own answers, for single points and the parallel batch.
#[test]
fn pruned_search_equals_the_maximum_over_triangles() {
    let mut rng = SplitMix64::new(7, 1);
    let soup: Vec<[Point3; 3]> = (0..400)
        .map(|_| {
            let c = random_point(&mut rng, 10.0);
            [0; 3].map(|_| c + random_point(&mut rng, 1.5).coords)
        })
        .collect();
    let mesh = Mesh::from_soup(&soup).unwrap();
    let index = MeshIndex::new(&mesh).unwrap();
    let singles: Vec<MeshIndex> = soup
        .iter()
        .map(|t| MeshIndex::new(&Mesh::new(t.to_vec(), vec![[0, 1, 2]]).unwrap()).unwrap())
        .collect();
    for c in cutters() {
        let dc = DropCutter::new(&index, &c).unwrap();
        let pts: Vec<[f64; 2]> =
            (0..300).map(|_| [24.0 * rng.unit() - 12.0, 24.0 * rng.unit() - 12.0]).collect();
        let batch = dc.heights(&pts);
        for (p, b) in pts.iter().zip(&batch) {
            let want = singles
                .iter()
                .filter_map(|s| DropCutter::new(s, &c).unwrap().height(p[0], p[1]))
                .fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.max(h))));
            assert_eq!(*b, dc.height(p[0], p[1]), "batch and single differ at {p:?}");
            assert_eq!(*b, dc.height_all_triangles(p[0], p[1]), "pruned and exhaustive differ at {p:?}");
            match (want, *b) {
                (None, None) => {}
                (Some(w), Some(g)) => assert!((w - g).abs() < 1e-9, "at {p:?}: {g} vs {w}"),
                other => panic!("at {p:?}: {other:?}"),
            }
            // The interference test agrees with the height.
            if let Some(g) = *b {
                assert!(dc.interferes(p[0], p[1], g - 1e-7) && !dc.interferes(p[0], p[1], g + 1e-7));
            }
            // The search from a floor gives the same height bit for bit above it, and
            // nothing at or above it.
            for floor in
                [f64::NEG_INFINITY, -3.0, 0.0, 2.0, b.map_or(0.0, |g| g - 1e-9), b.map_or(0.0, |g| g)]
            {
                let above = dc.height_above(p[0], p[1], floor);
                match *b {
                    Some(g) if g > floor + 1e-12 => {
                        assert_eq!(above.map(f64::to_bits), Some(g.to_bits()), "at {p:?} over {floor}")
                    }
                    Some(g) if g < floor - 1e-12 => assert_eq!(above, None, "at {p:?} over {floor}"),
                    _ => assert!(above.is_none_or(|h| Some(h) == *b), "at {p:?} over {floor}: {above:?}"),
                }
                // The comparison from a floor agrees with comparing the height.
                for slack in [0.0, 1e-9, 0.01, 1.0] {
                    let want = b.is_some_and(|g| g <= floor);
                    assert_eq!(
                        dc.stops_at_most(p[0], p[1], floor, slack),
                        want,
                        "at {p:?} to {floor} - {slack}"
                    );
                }
            }
        }
    }
}

/// A large tilted plane: the tip is `plane(q) + (R - r) tan(a) + r / cos(a) - r`.
#[test]
fn tilted_plane_matches_the_normal_offset() {
    let (gx, gy): (f64, f64) = (0.3, -0.45);
    let plane = |x: f64, y: f64| 2.0 + gx * x + gy * y;
    let corners = [(-50.0, -50.0), (50.0, -50.0), (50.0, 50.0), (-50.0, 50.0)]
        .map(|(x, y)| Point3::new(x, y, plane(x, y)));
    let mesh = Mesh::new(corners.to_vec(), vec![[0, 1, 2], [0, 2, 3]]).unwrap();
    let index = MeshIndex::new(&mesh).unwrap();
    let tan: f64 = (gx * gx + gy * gy).sqrt();
    let cos = 1.0 / (1.0 + tan * tan).sqrt();
    for c in cutters() {
        let dc = DropCutter::new(&index, &c).unwrap();
        let (rr, rc) = (c.radius, c.corner_radius());
        for (x, y) in [(0.0, 0.0), (3.3, -7.1), (-20.0, 11.0), (0.05, 0.0)] {
            let want = plane(x, y) + (rr - rc) * tan + rc / cos - rc;
            let got = dc.height(x, y).unwrap();
            assert!((got - want).abs() < 1e-10, "{c:?} at ({x}, {y}): {got} vs {want}");
        }
    }
}

/// A ball over a sphere: the tip is `sqrt((Rs + r)^2 - rho^2) - r`, less at most the
/// tessellation's sagitta (the mesh is inscribed); a flat end rests on the sphere's top or,
/// off centre by more than its radius, on the circle `rho - R` from the axis.
#[test]
fn ball_and_flat_over_a_sphere() {
    let (rs, n) = (10.0, 256);
    let index = MeshIndex::new(&sphere(rs, n)).unwrap();
    // Sagitta across a facet (around and along), over the cosine of the contact normal's
    // tilt (a vertical offset of a tilted surface).
    let sag = 2.0 * rs * (1.0 - (std::f64::consts::PI / n as f64).cos());
    let ball = DropCutter::new(&index, &Cutter::ball(2.0, 8.0)).unwrap();
    let flat = DropCutter::new(&index, &Cutter::flat(2.0, 8.0)).unwrap();
    for rho in [0.0, 1.0, 3.7, 6.0, 9.0, 11.5] {
        let (x, y) = (rho * 0.6, rho * 0.8);
        let want = ((rs + 2.0f64).powi(2) - rho * rho).sqrt() - 2.0;
        let got = ball.height(x, y).unwrap();
        let tol = sag / (1.0 - (rho / (rs + 2.0)).powi(2)).sqrt();
        assert!(got <= want + 1e-9 && got >= want - tol, "ball at rho {rho}: {got} vs {want}");
        let want = if rho <= 2.0 { rs } else { (rs * rs - (rho - 2.0).powi(2)).sqrt() };
        let got = flat.height(x, y).unwrap();
        let tol = sag / (1.0 - ((rho - 2.0).max(0.0) / rs).powi(2)).sqrt();
        assert!(got <= want + 1e-9 && got >= want - tol, "flat at rho {rho}: {got} vs {want}");
    }
}

/// A ball beside a vertical cylinder touches its top rim: `H + sqrt(r^2 - (rho - Rc)^2) - r`.
#[test]
fn ball_on_a_cylinder_s_rim() {
    let (rc, h, n) = (5.0, 3.0, 512);
    let index = MeshIndex::new(&cylinder(rc, h, n)).unwrap();
    let sag = rc * (1.0 - (std::f64::consts::PI / n as f64).cos());
    let dc = DropCutter::new(&index, &Cutter::ball(1.5, 6.0)).unwrap();
    for rho in [5.1, 5.5, 6.0, 6.4] {
        let a: f64 = 0.3;
        let want = h + (1.5f64.powi(2) - (rho - rc).powi(2)).sqrt() - 1.5;
        let got = dc.height(rho * a.cos(), rho * a.sin()).unwrap();
        // An inscribed rim is farther away, so the ball sits lower, by a slope times sag.
        assert!(got <= want + 1e-9 && got >= want - 10.0 * sag, "rho {rho}: {got} vs {want}");
    }
    assert_eq!(dc.height(rc + 1.6, 0.0), None, "beyond the radius nothing is touched");
}

/// A bull nose (and the other ends) beside a horizontal edge: the tip is `z - h(d)`, the
/// profile's height at the edge's distance `d`.
#[test]
fn bull_over_a_horizontal_edge() {
    let zl = 4.0;
    let tri = vec![Point3::new(-20.0, 0.0, zl), Point3::new(20.0, 0.0, zl), Point3::new(0.0, 0.0, zl - 20.0)];
    let index = MeshIndex::new(&Mesh::new(tri, vec![[0, 1, 2]]).unwrap()).unwrap();
    for c in cutters() {
        let dc = DropCutter::new(&index, &c).unwrap();
        for d in [0.0, 0.1, 0.5, 0.69, 0.75, 0.9, 0.99, c.radius].into_iter().filter(|&d| d <= c.radius) {
            let got = dc.height(1.3, d).unwrap_or_else(|| panic!("{c:?} at d = {d}: no contact"));
            let want = zl - lift(&c, d).unwrap();
            assert!((got - want).abs() < 1e-12, "{c:?} at d = {d}: {got} vs {want}");
        }
        assert_eq!(dc.height(1.3, c.radius * 1.001), None);
    }
}

/// Random inclined edges against a dense one-dimensional search along the edge.
#[test]
fn bull_on_inclined_edges_matches_a_dense_search() {
    let mut rng = SplitMix64::new(3, 3);
    let c = Cutter::bull(2.0, 0.6, 8.0);
    for k in 0..200 {
        let (a, b) = (random_point(&mut rng, 3.0), random_point(&mut rng, 3.0));
        // A sliver far below the edge, so only the edge (and its ends) can be touched.
        let low = Point3::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y), a.z.min(b.z) - 50.0);
        let index = MeshIndex::new(&Mesh::new(vec![a, b, low], vec![[0, 1, 2]]).unwrap()).unwrap();
        let dc = DropCutter::new(&index, &c).unwrap();
        let (x, y) = (4.0 * rng.unit() - 2.0, 4.0 * rng.unit() - 2.0);
        let samples = 200_000;
        let want = (0..=samples)
            .map(|i| contact(&c, a + (b - a) * (i as f64 / samples as f64), x, y))
            .fold(f64::NEG_INFINITY, f64::max);
        let got = dc.height(x, y).unwrap_or(f64::NEG_INFINITY);
        let step = (b - a).norm() / samples as f64;
        assert!(got >= want - 1e-9 && got <= want + 10.0 * step, "edge {k}: {got} vs {want}");
    }
}

/// Turning the mesh about Z and moving it turns and moves the answer.
#[test]
fn a_moved_mesh_gives_the_moved_answer() {
    let mesh = sphere(5.0, 24);
    let (ang, t): (f64, [f64; 3]) = (0.7, [12.5, -3.0, 40.0]);
    let (s, co) = ang.sin_cos();
    let moved: Vec<Point3> = mesh
        .vertices()
        .iter()
        .map(|p| Point3::new(co * p.x - s * p.y + t[0], s * p.x + co * p.y + t[1], p.z + t[2]))
        .collect();
    let moved = Mesh::new(moved, mesh.triangles().to_vec()).unwrap();
    let (a, b) = (MeshIndex::new(&mesh).unwrap(), MeshIndex::new(&moved).unwrap());
    let mut rng = SplitMix64::new(5, 5);
    for c in cutters() {
        let (da, db) = (DropCutter::new(&a, &c).unwrap(), DropCutter::new(&b, &c).unwrap());
        for _ in 0..200 {
            let (x, y) = (14.0 * rng.unit() - 7.0, 14.0 * rng.unit() - 7.0);
            let (mx, my) = (co * x - s * y + t[0], s * x + co * y + t[1]);
            match (da.height(x, y), db.height(mx, my)) {
                (Some(h), Some(g)) => assert!((h + t[2] - g).abs() < 1e-9, "{c:?} at ({x}, {y}): {h} vs {g}"),
                (None, None) => {}
                other => panic!("{c:?} at ({x}, {y}): {other:?}"),
            }
        }
    }
}

/// No contact, NaN input, degenerate triangles and impossible cutters are answered
/// without a panic.
#[test]
fn misses_bad_input_and_degenerate_triangles() {
    let block = Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(4.0, 4.0, 2.0))).unwrap();
    let index = MeshIndex::new(&block).unwrap();
    let dc = DropCutter::new(&index, &Cutter::bull(1.0, 0.25, 4.0)).unwrap();
    assert_eq!(dc.height(-1.01, 2.0), None);
    assert_eq!(dc.height(f64::NAN, 2.0), None);
    assert_eq!(dc.height(2.0, f64::INFINITY), None);
    assert!(!dc.interferes(2.0, 2.0, f64::NAN));
    assert!(dc.interferes(2.0, 2.0, 1.0) && !dc.interferes(2.0, 2.0, 2.0));
    assert!(matches!(DropCutter::new(&index, &Cutter::ball(f64::NAN, 4.0)), Err(GeomError::InvalidTool(_))));
    let bad = s2g_geom::DropCutterOptions { edge_tolerance: 0.0 };
    assert!(matches!(
        DropCutter::new_opt(&index, &Cutter::ball(1.0, 4.0), &bad),
        Err(GeomError::InvalidArgument(_))
    ));
    // A point triangle, a needle and a collinear sliver: vertices and edges still count.
    let p = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
    let soup = [
        [p(0.0, 0.0, 1.0); 3],
        [p(3.0, 0.0, 0.0), p(3.0, 0.0, 0.0), p(3.0, 0.0, 2.0)],
        [p(0.0, 3.0, 0.0), p(1.0, 3.0, 1.0), p(2.0, 3.0, 2.0)],
    ];
    let index = MeshIndex::new(&Mesh::from_soup(&soup).unwrap()).unwrap();
    for c in cutters() {
        let dc = DropCutter::new(&index, &c).unwrap();
        for (x, y) in [(0.0, 0.0), (0.3, 0.2), (3.0, 0.5), (1.0, 3.4), (2.5, 3.0), (9.0, 9.0)] {
            let want = soup.iter().map(|t| brute_triangle(&c, *t, x, y)).fold(f64::NEG_INFINITY, f64::max);
            match dc.height(x, y) {
                Some(h) => {
                    assert!(h >= want - 1e-9 && h <= want + 1e-6, "{c:?} at ({x}, {y}): {h} vs {want}")
                }
                None => assert_eq!(want, f64::NEG_INFINITY),
            }
        }
    }
}
