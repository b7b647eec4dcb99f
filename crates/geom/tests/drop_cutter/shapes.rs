//! Tessellated test shapes.

use s2g_geom::{Mesh, Point3};

/// A UV sphere of radius `r` at the origin with `n` segments around and `n / 2` rings.
pub fn sphere(r: f64, n: usize) -> Mesh {
    let m = n / 2;
    let mut v = vec![Point3::new(0.0, 0.0, -r)];
    for i in 1..m {
        let th = std::f64::consts::PI * i as f64 / m as f64 - std::f64::consts::FRAC_PI_2;
        for k in 0..n {
            let ph = std::f64::consts::TAU * k as f64 / n as f64;
            v.push(Point3::new(r * th.cos() * ph.cos(), r * th.cos() * ph.sin(), r * th.sin()));
        }
    }
    v.push(Point3::new(0.0, 0.0, r));
    let top = (v.len() - 1) as u32;
    let ring = |i: usize, k: usize| (1 + (i - 1) * n + k % n) as u32;
    let mut t = Vec::new();
    for k in 0..n {
        t.push([0, ring(1, k + 1), ring(1, k)]);
        t.push([top, ring(m - 1, k), ring(m - 1, k + 1)]);
        for i in 1..m - 1 {
            t.push([ring(i, k), ring(i, k + 1), ring(i + 1, k + 1)]);
            t.push([ring(i, k), ring(i + 1, k + 1), ring(i + 1, k)]);
        }
    }
    Mesh::new(v, t).unwrap()
}

/// A closed vertical cylinder of radius `r` from `z = 0` to `h`, `n` segments.
pub fn cylinder(r: f64, h: f64, n: usize) -> Mesh {
    let mut v = vec![Point3::new(0.0, 0.0, 0.0), Point3::new(0.0, 0.0, h)];
    for k in 0..n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        v.push(Point3::new(r * a.cos(), r * a.sin(), 0.0));
        v.push(Point3::new(r * a.cos(), r * a.sin(), h));
    }
    let (b, tp) = (|k: usize| (2 + 2 * (k % n)) as u32, |k: usize| (3 + 2 * (k % n)) as u32);
    let mut t = Vec::new();
    for k in 0..n {
        t.push([0, b(k + 1), b(k)]);
        t.push([1, tp(k), tp(k + 1)]);
        t.push([b(k), b(k + 1), tp(k + 1)]);
        t.push([b(k), tp(k + 1), tp(k)]);
    }
    Mesh::new(v, t).unwrap()
}
