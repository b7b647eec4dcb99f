//! Freeform blends: a block whose top is a smooth height field (Gaussian bumps and dents
//! and a gentle wave over a base height) sampled on a grid, with a flat bottom on the same
//! grid and vertical sides. Closed and manifold by construction; its volume is the exact
//! integral of the piecewise-linear top, `Σ area_xy(t) (h_a + h_b + h_c) / 3` over the top
//! triangles.

use s2g_geom::{Mesh, Point3, SplitMix64};

use crate::error::{GenError, Result};
use crate::feature::Feature;
use crate::random_prism::draw;
use crate::ring::snap;

/// Grid cells along the longer side.
pub(crate) const FREEFORM_CELLS: usize = 48;

/// A built height-field block: mesh, exact volume, features.
pub(crate) struct HeightField {
    pub(crate) mesh: Mesh,
    pub(crate) volume: f64,
    pub(crate) features: Vec<Feature>,
}

/// A random freeform block whose longest side is `size`.
pub(crate) fn freeform(rng: &mut SplitMix64, size: f64) -> Result<HeightField> {
    let lx = snap(size);
    let ly = draw(rng, 0.5, 1.0) * size;
    let base = draw(rng, 0.15, 0.3) * size;
    let nx = FREEFORM_CELLS;
    let ny = ((FREEFORM_CELLS as f64 * ly / lx).round() as usize).max(8);
    let mut features = vec![Feature::HeightField { size: [lx, ly], base_height: base, grid: [nx, ny] }];
    let count = 2 + rng.below(5);
    let mut bumps = Vec::with_capacity(count);
    for _ in 0..count {
        let c = [draw(rng, -0.5, 0.5) * lx, draw(rng, -0.5, 0.5) * ly];
        let sigma = draw(rng, 0.08, 0.3) * size;
        // Dents are shallow enough that all of them together leave half the base.
        let a = if rng.unit() < 0.3 {
            -draw(rng, 0.1, 0.5) * base / count as f64
        } else {
            draw(rng, 0.1, 0.8) * base
        };
        bumps.push((c, sigma, a));
        features.push(Feature::Bump { center: c, radius: sigma, height: a });
    }
    let wave = [draw(rng, 0.3, 1.0) * lx, draw(rng, 0.3, 1.0) * ly];
    let amp = draw(rng, 0.0, 0.1) * base;
    features.push(Feature::Wave { wavelength: wave, amplitude: amp });
    let height = |x: f64, y: f64| {
        let b: f64 = bumps
            .iter()
            .map(|&(c, s, a): &([f64; 2], f64, f64)| {
                a * (-((x - c[0]).powi(2) + (y - c[1]).powi(2)) / (2.0 * s * s)).exp()
            })
            .sum();
        let w =
            amp * (std::f64::consts::TAU * x / wave[0]).sin() * (std::f64::consts::TAU * y / wave[1]).cos();
        snap(base + b + w)
    };
    let xs: Vec<f64> = (0..=nx).map(|i| snap(-lx / 2.0 + lx * i as f64 / nx as f64)).collect();
    let ys: Vec<f64> = (0..=ny).map(|j| snap(-ly / 2.0 + ly * j as f64 / ny as f64)).collect();
    let mut vertices = Vec::with_capacity(2 * (nx + 1) * (ny + 1));
    let mut tops = Vec::with_capacity((nx + 1) * (ny + 1));
    for &y in &ys {
        for &x in &xs {
            let h = height(x, y);
            tops.push(h);
            vertices.push(Point3::new(x, y, h));
        }
    }
    for &y in &ys {
        for &x in &xs {
            vertices.push(Point3::new(x, y, 0.0));
        }
    }
    let top = |i: usize, j: usize| (j * (nx + 1) + i) as u32;
    let bottom = |i: usize, j: usize| ((ny + 1) * (nx + 1) + j * (nx + 1) + i) as u32;
    let mut triangles = Vec::new();
    let mut volume = 0.0;
    for j in 0..ny {
        for i in 0..nx {
            let quad = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            for tri in [[0, 1, 2], [0, 2, 3]] {
                let [a, b, c] = tri.map(|k| quad[k]);
                triangles.push([top(a.0, a.1), top(b.0, b.1), top(c.0, c.1)]);
                triangles.push([bottom(a.0, a.1), bottom(c.0, c.1), bottom(b.0, b.1)]);
                let area = 0.5
                    * ((xs[b.0] - xs[a.0]) * (ys[c.1] - ys[a.1]) - (xs[c.0] - xs[a.0]) * (ys[b.1] - ys[a.1]));
                let hsum = tops[top(a.0, a.1) as usize]
                    + tops[top(b.0, b.1) as usize]
                    + tops[top(c.0, c.1) as usize];
                volume += area * hsum / 3.0;
            }
        }
    }
    // The boundary counter-clockwise seen from above; each step walls a vertical quad.
    let ring: Vec<(usize, usize)> = (0..nx)
        .map(|i| (i, 0))
        .chain((0..ny).map(|j| (nx, j)))
        .chain((1..=nx).rev().map(|i| (i, ny)))
        .chain((1..=ny).rev().map(|j| (0, j)))
        .collect();
    for k in 0..ring.len() {
        let (a, b) = (ring[k], ring[(k + 1) % ring.len()]);
        let (a0, b0, a1, b1) = (bottom(a.0, a.1), bottom(b.0, b.1), top(a.0, a.1), top(b.0, b.1));
        triangles.push([a0, b0, b1]);
        triangles.push([a0, b1, a1]);
    }
    let mesh = Mesh::new(vertices, triangles).map_err(GenError::Mesh)?;
    Ok(HeightField { mesh, volume, features })
}
