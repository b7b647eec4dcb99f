//! Mesh smoothing: Laplacian (umbrella operator) and Taubin's lambda/mu smoothing.
//!
//! Both move vertices only (the connectivity is kept) and use uniform weights: each vertex
//! moves towards the mean of its edge neighbours, `p += f * (mean(N(p)) - p)`. Laplacian
//! smoothing shrinks a closed surface; Taubin ("Curve and surface smoothing without
//! shrinkage", ICCV 1995) alternates a shrinking step `lambda > 0` and an inflating step
//! `mu < -lambda`, a low-pass filter that approximately preserves volume.

use rayon::prelude::*;

use crate::error::{GeomError, Result};
use crate::math::{Point3, Real, Vector3};
use crate::mesh::Mesh;

/// Taubin's default shrinking factor.
pub const TAUBIN_LAMBDA: Real = 0.5;
/// Taubin's default inflating factor (`mu < -lambda`).
pub const TAUBIN_MU: Real = -0.53;

/// Vertex neighbours in compressed rows: `adj[start[v]..start[v + 1]]`, sorted, unique.
struct Neighbours {
    start: Vec<usize>,
    adj: Vec<u32>,
}

impl Neighbours {
    fn new(mesh: &Mesh) -> Self {
        let n = mesh.vertices().len();
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(mesh.triangles().len() * 6);
        for &[a, b, c] in mesh.triangles() {
            for (u, v) in [(a, b), (b, c), (c, a)] {
                if u != v {
                    pairs.push((u, v));
                    pairs.push((v, u));
                }
            }
        }
        pairs.par_sort_unstable();
        pairs.dedup();
        let mut start = vec![0usize; n + 1];
        for &(u, _) in &pairs {
            start[u as usize + 1] += 1;
        }
        for v in 0..n {
            start[v + 1] += start[v];
        }
        Self { start, adj: pairs.into_iter().map(|(_, v)| v).collect() }
    }
}

/// One umbrella step `p += f * (mean(N(p)) - p)` from `src` into `dst`.
fn step(nb: &Neighbours, src: &[Point3], dst: &mut [Point3], f: Real) {
    dst.par_iter_mut().enumerate().for_each(|(v, out)| {
        let ns = &nb.adj[nb.start[v]..nb.start[v + 1]];
        let p = src[v];
        *out = if ns.is_empty() {
            p
        } else {
            let sum: Vector3 = ns.iter().map(|&u| src[u as usize].coords).sum();
            p + f * (sum / ns.len() as Real - p.coords)
        };
    });
}

fn smooth(mesh: &Mesh, factors: &[Real], iterations: usize) -> Result<Mesh> {
    let nb = Neighbours::new(mesh);
    let mut a = mesh.vertices().to_vec();
    let mut b = a.clone();
    for _ in 0..iterations {
        for &f in factors {
            step(&nb, &a, &mut b, f);
            std::mem::swap(&mut a, &mut b);
        }
    }
    // Mesh::new rejects coordinates that diverged to infinity (extreme factors).
    Mesh::new(a, mesh.triangles().to_vec())
}

/// Laplacian smoothing with uniform (umbrella) weights: `iterations` steps of
/// `p += lambda * (mean(N(p)) - p)`. Shrinks closed surfaces. Vertices without neighbours
/// stay put.
///
/// Errors: [`GeomError::InvalidArgument`] when `lambda` is not finite, or when the
/// coordinates diverge (possible only for `lambda` outside `[0, 1]`).
pub fn laplacian_smooth(mesh: &Mesh, iterations: usize, lambda: Real) -> Result<Mesh> {
    if !lambda.is_finite() {
        return Err(GeomError::InvalidArgument(format!("laplacian_smooth: lambda = {lambda}")));
    }
    smooth(mesh, &[lambda], iterations)
}

/// Taubin lambda/mu smoothing: each iteration is one umbrella step with `lambda` (> 0)
/// followed by one with `mu` (< `-lambda`), which removes high-frequency noise while
/// approximately preserving volume. Usual values are [`TAUBIN_LAMBDA`] and [`TAUBIN_MU`].
///
/// Errors: [`GeomError::InvalidArgument`] unless `lambda > 0` and `mu < -lambda` (both
/// finite), or when the coordinates diverge.
pub fn taubin_smooth(mesh: &Mesh, iterations: usize, lambda: Real, mu: Real) -> Result<Mesh> {
    if !(lambda.is_finite() && mu.is_finite() && lambda > 0.0 && mu < -lambda) {
        return Err(GeomError::InvalidArgument(format!(
            "taubin_smooth needs lambda > 0 and mu < -lambda, got lambda = {lambda}, mu = {mu}"
        )));
    }
    smooth(mesh, &[lambda, mu], iterations)
}
