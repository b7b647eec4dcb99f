//! Generalised winding numbers (Jacobson et al. 2013), accelerated by the BVH as in
//! Barill et al. 2018, "Fast winding numbers for soups and clouds".
//!
//! The winding number of a closed, outward-wound surface is 1 inside and 0 outside; for a
//! surface with small holes it degrades gracefully (it is the solid angle the surface
//! subtends at the point, over 4π), so thresholding at 0.5 is a robust inside test.
//!
//! Near clusters are summed exactly (the Van Oosterom–Strackee solid angle of each
//! triangle); a cluster whose centre is farther than [`BETA`] times its radius from the
//! query is replaced by its dipole expansion to second order around the cluster's
//! area-weighted centroid `p̃`:
//!
//! `w ≈ (1/4π) [ N · g + Σ_ij M_ij ∂_j g_i ]`, with `g = (p̃ - q) / |p̃ - q|³`,
//! `N = Σ a_t n_t` and `M = Σ a_t n_t ⊗ (c_t - p̃)` (`a_t n_t` the area vector and `c_t`
//! the centroid of triangle `t`).

// Small fixed-size matrix loops index several arrays by the same axis.
#![allow(clippy::needless_range_loop)]

use crate::math::{Point3, Real};
use crate::query::bvh::{Bvh, add, cross, dot, scale, sub};

/// A cluster is approximated when its distance exceeds `BETA` times its radius.
pub(crate) const BETA: f64 = 2.5;

const INV_4PI: f64 = 1.0 / (4.0 * std::f64::consts::PI);

/// Expansion data for one BVH node.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Moments {
    /// Area-weighted centroid (local frame).
    center: [f64; 3],
    /// `(BETA * radius)^2`: the squared distance beyond which the expansion is used.
    far2: f64,
    /// Sum of area vectors.
    n: [f64; 3],
    /// Second-order moment `Σ a_t n_t ⊗ (c_t - p̃)`, row-major (`m[i][j] = N_i d_j`).
    m: [[f64; 3]; 3],
}

/// The winding-number tree: one [`Moments`] per BVH node.
#[derive(Debug, Clone)]
pub(crate) struct WindingTree {
    moments: Vec<Moments>,
}

impl WindingTree {
    /// Computes the moments bottom-up (children always have larger indices than parents).
    pub fn build(bvh: &Bvh) -> Self {
        let zero = Moments { center: [0.0; 3], far2: 0.0, n: [0.0; 3], m: [[0.0; 3]; 3] };
        let mut moments = vec![zero; bvh.nodes.len()];
        // Pass 1: area, area-weighted centroid sum and area-vector sum per node.
        let mut area = vec![0.0f64; bvh.nodes.len()];
        let mut csum = vec![[0.0f64; 3]; bvh.nodes.len()];
        for i in (0..bvh.nodes.len()).rev() {
            let node = bvh.nodes[i];
            if node.count > 0 {
                let s = node.start as usize;
                for tri in &bvh.tris[s..s + node.count as usize] {
                    let an = scale(cross(tri.e1, tri.e2), 0.5);
                    let a = dot(an, an).sqrt();
                    let [p0, p1, p2] = tri.vertices();
                    let c = scale(add(add(p0, p1), p2), 1.0 / 3.0);
                    area[i] += a;
                    csum[i] = add(csum[i], scale(c, a));
                    moments[i].n = add(moments[i].n, an);
                }
            } else {
                let l = node.start as usize;
                area[i] = area[l] + area[l + 1];
                csum[i] = add(csum[l], csum[l + 1]);
                moments[i].n = add(moments[l].n, moments[l + 1].n);
            }
            let box_center = [0, 1, 2].map(|a| 0.5 * (node.min[a] as f64 + node.max[a] as f64));
            moments[i].center = if area[i] > 0.0 { scale(csum[i], 1.0 / area[i]) } else { box_center };
        }
        // Pass 2: radii, which need each node's own centre: the farthest triangle vertex
        // below the node (each triangle is visited once per level, O(n log n)).
        let mut stack = Vec::new();
        for i in 0..bvh.nodes.len() {
            let pc = moments[i].center;
            let mut r2 = 0.0f64;
            stack.clear();
            stack.push(i);
            while let Some(k) = stack.pop() {
                let node = bvh.nodes[k];
                if node.count == 0 {
                    stack.push(node.start as usize);
                    stack.push(node.start as usize + 1);
                    continue;
                }
                let s = node.start as usize;
                for tri in &bvh.tris[s..s + node.count as usize] {
                    for p in tri.vertices() {
                        let e = sub(p, pc);
                        r2 = r2.max(dot(e, e));
                    }
                }
            }
            moments[i].far2 = BETA * BETA * r2;
        }
        // Second moments of internal nodes are sums over their leaves' triangles; gather
        // them by walking each leaf's triangles up to the root would be O(n log n), so we
        // accumulate raw moments Σ a n ⊗ c and shift: M = Σ a n ⊗ c - N ⊗ p̃.
        let mut raw = vec![[[0.0f64; 3]; 3]; bvh.nodes.len()];
        for i in (0..bvh.nodes.len()).rev() {
            let node = bvh.nodes[i];
            if node.count > 0 {
                let s = node.start as usize;
                for tri in &bvh.tris[s..s + node.count as usize] {
                    let an = scale(cross(tri.e1, tri.e2), 0.5);
                    let [p0, p1, p2] = tri.vertices();
                    let c = scale(add(add(p0, p1), p2), 1.0 / 3.0);
                    for (r, row) in raw[i].iter_mut().enumerate() {
                        for (col, v) in row.iter_mut().enumerate() {
                            *v += an[r] * c[col];
                        }
                    }
                }
            } else {
                let l = node.start as usize;
                for r in 0..3 {
                    for col in 0..3 {
                        raw[i][r][col] = raw[l][r][col] + raw[l + 1][r][col];
                    }
                }
            }
            let nn = moments[i].n;
            let pc = moments[i].center;
            for r in 0..3 {
                for col in 0..3 {
                    moments[i].m[r][col] = raw[i][r][col] - nn[r] * pc[col];
                }
            }
        }
        Self { moments }
    }
}

/// Solid angle of triangle `(a, b, c)` seen from the origin, positive when the origin is
/// on the side opposite the normal `(b - a) x (c - a)` (Van Oosterom & Strackee 1983).
#[inline(always)]
pub(crate) fn solid_angle(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> f64 {
    let la = dot(a, a).sqrt();
    let lb = dot(b, b).sqrt();
    let lc = dot(c, c).sqrt();
    let num = dot(a, cross(b, c));
    let den = la * lb * lc + dot(a, b) * lc + dot(a, c) * lb + dot(b, c) * la;
    2.0 * num.atan2(den)
}

impl WindingTree {
    /// The winding number at a point in the local frame of `bvh`, the tree this one was
    /// built from.
    pub(crate) fn winding_local(&self, bvh: &Bvh, q: [f64; 3]) -> f64 {
        let moments = &self.moments;
        let mut sum = 0.0f64;
        let mut stack = [0u32; 128];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let i = stack[sp] as usize;
            let mo = &moments[i];
            let r = sub(mo.center, q);
            let d2 = dot(r, r);
            if d2 > mo.far2 {
                // Second-order dipole expansion: g = r / |r|^3, ∂_j g_i = δ_ij/|r|^3 - 3 r_i r_j/|r|^5.
                let inv_d = 1.0 / d2.sqrt();
                let inv3 = inv_d * inv_d * inv_d;
                let inv5 = inv3 * inv_d * inv_d;
                let mut w = dot(mo.n, r) * inv3;
                let m = &mo.m;
                let trace = m[0][0] + m[1][1] + m[2][2];
                let mut rmr = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        rmr += r[a] * m[a][b] * r[b];
                    }
                }
                // ∂g_i/∂p̃_j contracted with M_ij, with the derivative taken with respect to
                // the source position (c_t - p̃ displaces the source).
                w += trace * inv3 - 3.0 * rmr * inv5;
                sum += w;
                continue;
            }
            let node = &bvh.nodes[i];
            if node.count > 0 {
                let s = node.start as usize;
                for tri in &bvh.tris[s..s + node.count as usize] {
                    let a = sub(tri.v0, q);
                    let b = add(a, tri.e1);
                    let c = add(a, tri.e2);
                    sum += solid_angle(a, b, c);
                }
                continue;
            }
            stack[sp] = node.start;
            stack[sp + 1] = node.start + 1;
            sp += 2;
        }
        sum * INV_4PI
    }
}

/// The exact winding number of the triangles of `bvh` at `p` (every triangle's solid angle
/// summed, no approximation).
pub(crate) fn exact_winding(bvh: &Bvh, p: &Point3) -> Real {
    let q = bvh.to_local([p.x, p.y, p.z]);
    let s: f64 = bvh
        .tris
        .iter()
        .map(|tri| {
            let a = sub(tri.v0, q);
            solid_angle(a, add(a, tri.e1), add(a, tri.e2))
        })
        .sum();
    s * INV_4PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::Mesh;
    use crate::query::MeshIndex;

    #[test]
    fn expansion_error_decays_at_third_order() {
        // A bumpy open patch: its far field must follow the dipole expansion.
        let mut v = Vec::new();
        let mut t = Vec::new();
        let n = 6;
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                v.push(Point3::new(x, y, 0.3 * (3.0 * x).sin() * y));
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = (j * (n + 1) + i) as u32;
                t.push([a, a + 1, a + n as u32 + 2]);
                t.push([a, a + n as u32 + 2, a + n as u32 + 1]);
            }
        }
        let index = MeshIndex::new(&Mesh::new(v, t).unwrap()).unwrap();
        let mo = index.winding.moments[0];
        let mut prev = f64::INFINITY;
        for k in 1..5 {
            let d = 2.0f64.powi(k + 1);
            let q = Point3::new(0.5 + 0.3 * d, 0.4 - 0.5 * d, 0.2 + 0.8 * d);
            let exact = index.winding_number_exact(&q);
            let ql = index.bvh.to_local([q.x, q.y, q.z]);
            let r = sub(mo.center, ql);
            let d2 = dot(r, r);
            let inv_d = 1.0 / d2.sqrt();
            let inv3 = inv_d.powi(3);
            let inv5 = inv3 * inv_d * inv_d;
            let m = &mo.m;
            let mut rmr = 0.0;
            for a in 0..3 {
                for b in 0..3 {
                    rmr += r[a] * m[a][b] * r[b];
                }
            }
            let w1 = dot(mo.n, r) * inv3 * INV_4PI;
            let w2 = w1 + (m[0][0] + m[1][1] + m[2][2]) * inv3 * INV_4PI - 3.0 * rmr * inv5 * INV_4PI;
            let (e1, e2) = ((w1 - exact).abs(), (w2 - exact).abs());
            eprintln!("d {d}: exact {exact:.3e} first-order err {e1:.3e} second-order err {e2:.3e}");
            assert!(e2 < e1 || e2 < 1e-12, "second order no better than first at distance {d}");
            assert!(e2 < prev / 10.0, "second-order error decays too slowly at distance {d}");
            prev = e2;
        }
    }
}
