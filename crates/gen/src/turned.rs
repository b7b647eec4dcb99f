//! Turned parts: a closed profile in the `(r, z)` half-plane revolved about the z axis
//! in `n` facets. Each profile edge sweeps a band of planar quads (a vertex on the axis
//! becomes one pole, an edge on the axis sweeps nothing), so the mesh is closed and
//! manifold. Its volume is the polygonal-revolution formula
//! `V = n sin(2π/n) ∬ r dr dz`: between two meridian planes the facets form the image of
//! the profile under `(r, t) -> r ((1 - t) e_k + t e_k+1)`, whose Jacobian is
//! `r sin(2π/n)`. Cross holes are not generated: they would need a boolean between the
//! revolved facets and a cylinder, which this exact construction does not do.

use std::f64::consts::TAU;

use s2g_geom::{Mesh, Point3, SplitMix64};

use crate::error::{GenError, Result, geometry};
use crate::feature::Feature;
use crate::random_prism::{chance, draw};
use crate::ring::snap;

/// Facets around the axis.
pub(crate) const TURNED_SEGMENTS: usize = 96;

/// A profile `(r, z)`, counter-clockwise with r as the first axis, `r >= 0`.
#[derive(Debug, Clone)]
pub(crate) struct Profile(pub(crate) Vec<[f64; 2]>);

impl Profile {
    /// `∬ r dr dz` over the profile (its first moment about the axis).
    fn moment(&self) -> f64 {
        let p = &self.0;
        let n = p.len();
        (0..n)
            .map(|i| {
                let (a, b) = (p[i], p[(i + 1) % n]);
                (a[0] * b[1] - b[0] * a[1]) * (a[0] + b[0])
            })
            .sum::<f64>()
            / 6.0
    }

    /// The exact volume of the `n`-facet revolution.
    pub(crate) fn volume(&self, n: usize) -> f64 {
        n as f64 * (TAU / n as f64).sin() * self.moment()
    }

    /// Revolves the profile in `n` facets.
    pub(crate) fn revolve(&self, n: usize) -> Result<Mesh> {
        let p = &self.0;
        if p.len() < 3 || p.iter().any(|q| q[0] < 0.0 || !q[0].is_finite() || !q[1].is_finite()) {
            return Err(geometry("a turned profile needs three or more points with r >= 0"));
        }
        let (cos, sin): (Vec<f64>, Vec<f64>) =
            (0..n).map(|k| (TAU * k as f64 / n as f64).sin_cos()).map(|(s, c)| (c, s)).unzip();
        let mut vertices = Vec::new();
        // first[i]: index of profile point i's vertex at angle 0 (a pole has one).
        let mut first = Vec::with_capacity(p.len());
        for q in p {
            first.push(vertices.len() as u32);
            if q[0] == 0.0 {
                vertices.push(Point3::new(0.0, 0.0, q[1]));
            } else {
                vertices.extend((0..n).map(|k| Point3::new(q[0] * cos[k], q[0] * sin[k], q[1])));
            }
        }
        let at = |i: usize, k: usize| if p[i][0] == 0.0 { first[i] } else { first[i] + (k % n) as u32 };
        let mut triangles = Vec::new();
        for i in 0..p.len() {
            let j = (i + 1) % p.len();
            let (ra, rb) = (p[i][0], p[j][0]);
            for k in 0..n {
                let (a0, a1, b0, b1) = (at(i, k), at(i, k + 1), at(j, k), at(j, k + 1));
                match (ra == 0.0, rb == 0.0) {
                    (true, true) => {}
                    (true, false) => triangles.push([a0, b1, b0]),
                    (false, true) => triangles.push([a0, a1, b0]),
                    (false, false) => {
                        triangles.push([a0, a1, b1]);
                        triangles.push([a0, b1, b0]);
                    }
                }
            }
        }
        Mesh::new(vertices, triangles).map_err(GenError::Mesh)
    }
}

/// A random turned part whose longest side (its length) is `size`: 1-4 sections whose
/// diameters change at shoulders, grooves, chamfers at the ends, and a through bore, a
/// blind bore or none. Returns the profile and its features.
pub(crate) fn turned(rng: &mut SplitMix64, size: f64) -> (Profile, Vec<Feature>) {
    let len = snap(size);
    let r_max = draw(rng, 0.15, 0.35) * size;
    let sections = 1 + rng.below(4);
    // Section boundaries: evenly spread with jitter.
    let mut zs: Vec<f64> = (0..=sections)
        .map(|k| {
            let t = k as f64 / sections as f64;
            let jitter =
                if k == 0 || k == sections { 0.0 } else { rng.uniform(-0.25, 0.25) / sections as f64 };
            snap(len * (t + jitter))
        })
        .collect();
    zs.dedup();
    let radii: Vec<f64> =
        (0..zs.len() - 1).map(|k| if k == 0 { r_max } else { draw(rng, 0.5, 1.0) * r_max }).collect();
    let min_r = radii.iter().copied().fold(f64::INFINITY, f64::min);
    let bore = match rng.below(3) {
        0 => None,
        1 => Some((draw(rng, 0.2, 0.5) * min_r, len)),
        _ => Some((draw(rng, 0.2, 0.5) * min_r, draw(rng, 0.3, 0.7) * len)),
    };
    let r_in = bore.map_or(0.0, |b| b.0);
    let mut features =
        vec![Feature::Revolved { length: len, max_diameter: 2.0 * r_max, segments: TURNED_SEGMENTS }];
    let end_chamfer = snap(0.25 * (min_r - r_in).min(len / sections as f64 / 8.0) * rng.uniform(0.2, 1.0));
    // The outer side, bottom to top.
    let mut outer: Vec<[f64; 2]> = vec![[radii[0] - end_chamfer, 0.0], [radii[0], end_chamfer]];
    features.push(Feature::TurnedChamfer { z: 0.0, size: end_chamfer });
    let top_of = |k: usize, w: &[f64]| if k + 2 == zs.len() { w[1] - end_chamfer } else { w[1] };
    for (k, w) in zs.windows(2).enumerate() {
        let r = radii[k];
        features.push(Feature::Section { z0: w[0], z1: w[1], diameter: 2.0 * r });
        if k > 0 {
            outer.push([r, w[0]]);
        }
        let room = w[1] - w[0];
        if chance(rng, 0.5) && room > 0.3 * len / sections as f64 {
            let gw = snap(room * rng.uniform(0.1, 0.25));
            let gz = snap(w[0] + room * rng.uniform(0.3, 0.7));
            let gr = snap((r - (r - r_in) * rng.uniform(0.1, 0.35)).max(r_in + 0.05 * size));
            if gr >= r {
                outer.push([r, top_of(k, w)]);
                continue;
            }
            outer.extend([[r, gz - gw / 2.0], [gr, gz - gw / 2.0], [gr, gz + gw / 2.0], [r, gz + gw / 2.0]]);
            features.push(Feature::Groove { z: gz, width: gw, diameter: 2.0 * gr });
        }
        outer.push([r, top_of(k, w)]);
    }
    let last = radii[radii.len() - 1];
    outer.push([last - end_chamfer, len]);
    features.push(Feature::TurnedChamfer { z: len, size: end_chamfer });
    let mut profile = outer;
    match bore {
        None => profile.extend([[0.0, len], [0.0, 0.0]]),
        Some((rb, depth)) if depth >= len => {
            profile.extend([[rb, len], [rb, 0.0]]);
            features.push(Feature::Bore { diameter: 2.0 * rb, depth: len });
        }
        Some((rb, depth)) => {
            profile.extend([[rb, len], [rb, snap(len - depth)], [0.0, snap(len - depth)], [0.0, 0.0]]);
            features.push(Feature::Bore { diameter: 2.0 * rb, depth });
        }
    }
    profile.dedup();
    (Profile(profile), features)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylinder_volume_is_polygon_area_times_length() {
        let p = Profile(vec![[0.0, 0.0], [2.0, 0.0], [2.0, 5.0], [0.0, 5.0]]);
        let n = 12;
        let exact = 0.5 * n as f64 * 4.0 * (TAU / n as f64).sin() * 5.0;
        assert!((p.volume(n) - exact).abs() < 1e-12);
        let m = p.revolve(n).unwrap();
        assert!((m.signed_volume() - exact).abs() < 1e-9 * exact);
    }
}
