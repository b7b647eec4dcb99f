//! Waterline loops against analytic offsets of a cylinder, boxes and a sphere.

use s2g_geom::{Aabb, Cutter, DropCutter, GeomError, Mesh, MeshIndex, Point3, WaterlineOptions};

use crate::shapes::{cylinder, sphere};

/// Twice the signed area of a closed loop (positive counter-clockwise).
fn area(l: &[Point3]) -> f64 {
    (0..l.len())
        .map(|i| {
            let (a, b) = (l[i], l[(i + 1) % l.len()]);
            a.x * b.y - a.y * b.x
        })
        .sum::<f64>()
        / 2.0
}

fn loops(mesh: &Mesh, c: &Cutter, z: f64, step: f64) -> Vec<Vec<Point3>> {
    let index = MeshIndex::new(mesh).unwrap();
    let dc = DropCutter::new(&index, c).unwrap();
    let wl = dc.waterline_opt(z, &WaterlineOptions { step, ..WaterlineOptions::default() }).unwrap();
    for l in &wl {
        assert!(l.len() >= 3 && l.iter().all(|p| p.z == z), "loops are at z = {z}");
    }
    wl
}

/// Around a vertical cylinder the loop is the circle at the wall plus the cutter's radius
/// at the height of the cylinder's top above the tip (the full radius lower down).
#[test]
fn a_vertical_cylinder_gives_one_circle() {
    let (rc, h, n) = (5.0, 3.0, 512);
    let mesh = cylinder(rc, h, n);
    let inscribed = (std::f64::consts::PI / n as f64).cos();
    let bull = Cutter::bull(2.0, 0.5, 8.0);
    let cases = [
        (Cutter::ball(1.5, 6.0), 1.0, 1.5),
        (bull, 1.0, 2.0),
        (bull, h - 0.25, 1.5 + (0.25f64 - 0.0625).sqrt()),
        (Cutter::flat(1.0, 4.0), 2.9, 1.0),
    ];
    for (c, z, offset) in cases {
        let wl = loops(&mesh, &c, z, 0.2);
        assert_eq!(wl.len(), 1, "{c:?} at {z}");
        for p in &wl[0] {
            let r = (p.x * p.x + p.y * p.y).sqrt();
            assert!(
                r <= rc + offset + 1e-5 && r >= rc * inscribed + offset - 1e-5,
                "{c:?} at {z}: radius {r}"
            );
        }
        let want = std::f64::consts::PI * (rc + offset).powi(2);
        let got = area(&wl[0]);
        assert!(got > 0.0 && (got - want).abs() < 0.002 * want, "{c:?} at {z}: area {got} vs {want}");
    }
    assert!(loops(&mesh, &Cutter::ball(1.5, 6.0), h + 0.01, 0.2).is_empty(), "above the top nothing is cut");
}

/// The distance from `(x, y)` to the rectangle `[x0, x1] x [y0, y1]`.
fn to_rect(x: f64, y: f64, r: [f64; 4]) -> f64 {
    let dx = (r[0] - x).max(x - r[1]).max(0.0);
    let dy = (r[2] - y).max(y - r[3]).max(0.0);
    (dx * dx + dy * dy).sqrt()
}

/// Around a box every loop point is the offset's distance from the box's outline, and a
/// moved box gives moved loops.
#[test]
fn a_box_gives_its_rounded_offset() {
    let r = [0.0, 10.0, 0.0, 6.0];
    let mesh = Mesh::cuboid(&Aabb::new(Point3::new(r[0], r[2], 0.0), Point3::new(r[1], r[3], 4.0))).unwrap();
    let cases = [
        (Cutter::flat(1.0, 4.0), 2.0, 1.0),
        (Cutter::ball(1.0, 4.0), 3.5, 0.75f64.sqrt()),
        (Cutter::bull(1.5, 0.5, 4.0), 3.75, 1.0 + (0.25f64 - 0.0625).sqrt()),
    ];
    for (c, z, offset) in cases {
        let wl = loops(&mesh, &c, z, 0.25);
        assert_eq!(wl.len(), 1, "{c:?}");
        for p in &wl[0] {
            let d = to_rect(p.x, p.y, r);
            assert!((d - offset).abs() < 1e-5, "{c:?} at {z}: ({}, {}) is {d} from the box", p.x, p.y);
        }
        let want = 60.0 + 2.0 * offset * 16.0 + std::f64::consts::PI * offset * offset;
        let got = area(&wl[0]);
        assert!(got > 0.0 && (got - want).abs() < 0.01 * want, "{c:?}: area {got} vs {want}");
        // Moved by (3, -2, 1): the same loop, moved.
        let t = s2g_geom::Similarity3::new(
            nalgebra::Vector3::new(3.0, -2.0, 1.0),
            nalgebra::Vector3::zeros(),
            1.0,
        );
        let moved = loops(&mesh.transformed(&t), &c, z + 1.0, 0.25);
        assert_eq!(moved.len(), 1);
        for p in &moved[0] {
            let d = to_rect(p.x - 3.0, p.y + 2.0, r);
            assert!((d - offset).abs() < 1e-5, "moved {c:?}: {d}");
        }
    }
}

/// A square frame (four boxes round a hole): the outer loop runs counter-clockwise at the
/// offset, the hole's loop clockwise at the offset inside the hole (sharp corners there).
#[test]
fn a_frame_gives_an_outer_and_a_hole_loop() {
    let bar = |x0: f64, y0: f64, x1: f64, y1: f64| {
        Mesh::cuboid(&Aabb::new(Point3::new(x0, y0, 0.0), Point3::new(x1, y1, 4.0))).unwrap()
    };
    let mut mesh = bar(0.0, 0.0, 20.0, 5.0);
    for b in [bar(0.0, 15.0, 20.0, 20.0), bar(0.0, 5.0, 5.0, 15.0), bar(15.0, 5.0, 20.0, 15.0)] {
        mesh.append(&b);
    }
    let wl = loops(&mesh, &Cutter::flat(1.0, 4.0), 2.0, 0.3);
    assert_eq!(wl.len(), 2);
    let (outer, hole): (Vec<_>, Vec<_>) = wl.iter().partition(|l| area(l) > 0.0);
    assert_eq!((outer.len(), hole.len()), (1, 1));
    for p in hole[0] {
        let d = (p.x - 5.0).min(15.0 - p.x).min(p.y - 5.0).min(15.0 - p.y);
        assert!((d - 1.0).abs() < 1e-5, "hole loop point ({}, {}) is {d} from the walls", p.x, p.y);
    }
    assert!((area(hole[0]) + 64.0).abs() < 0.05, "hole area {}", area(hole[0]));
    for p in outer[0] {
        assert!((to_rect(p.x, p.y, [0.0, 20.0, 0.0, 20.0]) - 1.0).abs() < 1e-5);
    }
}

/// Around a sphere a ball's loop is the circle `sqrt((Rs + r)^2 - c^2)` for its centre at
/// height `c` above the sphere's (inside by at most the tessellation's error).
#[test]
fn a_sphere_gives_one_circle() {
    let (rs, n) = (10.0, 256);
    let mesh = sphere(rs, n);
    let sag = 2.0 * rs * (1.0 - (std::f64::consts::PI / n as f64).cos());
    for (z, r) in [(3.0, 2.0), (-1.0, 1.0), (8.5, 1.5)] {
        let c = z + r;
        let want = ((rs + r) * (rs + r) - c * c).sqrt();
        let wl = loops(&mesh, &Cutter::ball(r, 4.0 * r), z, 0.25);
        assert_eq!(wl.len(), 1, "z {z}");
        let tol = sag * (rs + r) / want;
        for p in &wl[0] {
            let got = (p.x * p.x + p.y * p.y).sqrt();
            assert!(got <= want + 1e-5 && got >= want - tol - 1e-5, "z {z}: radius {got} vs {want}");
        }
        assert!(area(&wl[0]) > 0.0);
    }
}

#[test]
fn bad_waterline_arguments_are_refused() {
    let mesh = sphere(1.0, 16);
    let index = MeshIndex::new(&mesh).unwrap();
    let dc = DropCutter::new(&index, &Cutter::ball(0.5, 2.0)).unwrap();
    assert!(matches!(dc.waterline(f64::NAN), Err(GeomError::InvalidArgument(_))));
    for step in [0.0, -1.0, f64::NAN] {
        let o = WaterlineOptions { step, ..WaterlineOptions::default() };
        assert!(matches!(dc.waterline_opt(0.0, &o), Err(GeomError::InvalidArgument(_))));
    }
    let o = WaterlineOptions { step: 1e-4, max_nodes: 1000, ..WaterlineOptions::default() };
    assert!(matches!(dc.waterline_opt(0.0, &o), Err(GeomError::InvalidArgument(_))));
    assert!(dc.waterline(5.0).unwrap().is_empty());
}

/// On a random soup of triangles (many loops, holes, ambiguous cells) the loops' signed
/// areas add up to the area where the cutter would cut in, measured on a fine grid: every
/// loop is closed, oriented with that region on its left, and none is missing.
#[test]
fn random_soup_loops_bound_the_interference_region() {
    let mut rng = s2g_geom::SplitMix64::new(11, 2);
    let soup: Vec<[Point3; 3]> = (0..80)
        .map(|_| {
            let c = Point3::new(20.0 * rng.unit(), 20.0 * rng.unit(), 4.0 * rng.unit());
            [0; 3].map(|_| {
                c + nalgebra::Vector3::new(
                    3.0 * rng.unit() - 1.5,
                    3.0 * rng.unit() - 1.5,
                    3.0 * rng.unit() - 1.5,
                )
            })
        })
        .collect();
    let index = MeshIndex::new(&Mesh::from_soup(&soup).unwrap()).unwrap();
    for c in [Cutter::ball(0.6, 4.0), Cutter::bull(0.8, 0.3, 4.0), Cutter::flat(0.5, 4.0)] {
        let dc = DropCutter::new(&index, &c).unwrap();
        let z = 2.5;
        let wl = dc.waterline_opt(z, &WaterlineOptions { step: 0.1, ..WaterlineOptions::default() }).unwrap();
        assert!(wl.len() >= 3, "{c:?}: {} loops", wl.len());
        let total: f64 = wl.iter().map(|l| area(l)).sum();
        let h = 0.04;
        let mut inside = 0usize;
        for i in 0..650 {
            for j in 0..650 {
                let (x, y) = (-3.0 + (i as f64 + 0.5) * h, -3.0 + (j as f64 + 0.5) * h);
                inside += dc.interferes(x, y, z) as usize;
            }
        }
        let want = inside as f64 * h * h;
        assert!(
            (total - want).abs() < 0.005 * want,
            "{c:?}: loops enclose {total}, the region is {want}, {} loops",
            wl.len()
        );
    }
}
