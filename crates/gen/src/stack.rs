//! 2.5-D solids as stacks of slabs: the exact mesher.
//!
//! A solid is a set of [`Column`]s: a ring (counter-clockwise for material, clockwise
//! for a hole) over a z-range, straight or lofted linearly between breakpoints. The union
//! of all breakpoints cuts z into levels; between two levels every column present gives
//! one slab ring at the bottom and one at the top. The mesh is the side walls of every
//! slab's rings plus, at each level, the flat faces where the cross-section below differs
//! from the one above (see [`crate::face`]). Every wall edge is split at every vertex of
//! the same level that lies exactly on it (an exact test on the grid, see
//! [`crate::ring`]), and the flat faces are split the same way, so there is no
//! T-junction: the mesh is closed, 2-manifold and outward-wound by construction, and
//! its volume is the sum over slabs of the prismatoid formula (area times height for a
//! straight slab).

use s2g_geom::Mesh;

use crate::error::{Result, geometry};
use crate::face::level_faces;
use crate::level::{LevelPoints, MeshBuilder};
use crate::ring::{P2, Ring, shoelace, snap};

/// A ring over a z-range: at each breakpoint `z[k]` the ring `rings[k]`; in between the
/// vertices move linearly (a loft: chamfers, drafts, countersinks). Every ring has the
/// same number of vertices.
#[derive(Debug, Clone)]
pub(crate) struct Column {
    /// Breakpoints, strictly increasing, at least two.
    pub(crate) z: Vec<f64>,
    /// The ring at each breakpoint.
    pub(crate) rings: Vec<Ring>,
}

impl Column {
    /// A straight column: `ring` from `z0` to `z1`.
    pub(crate) fn straight(ring: Ring, z0: f64, z1: f64) -> Self {
        Self { z: vec![snap(z0), snap(z1)], rings: vec![ring.clone(), ring] }
    }

    /// A column lofted through `(z, ring)` breakpoints.
    pub(crate) fn lofted(stations: Vec<(f64, Ring)>) -> Self {
        let (z, rings) = stations.into_iter().map(|(z, r)| (snap(z), r)).unzip();
        Self { z, rings }
    }

    fn validate(&self, index: usize) -> Result<()> {
        let n = self.rings.first().map_or(0, |r| r.0.len());
        let ok = self.z.len() >= 2
            && self.z.len() == self.rings.len()
            && self.z.windows(2).all(|w| w[0] < w[1])
            && self.z.iter().all(|z| z.is_finite())
            && n >= 3
            && self.rings.iter().all(|r| r.0.len() == n && r.0.iter().flatten().all(|v| v.is_finite()));
        if ok { Ok(()) } else { Err(geometry(format!("column {index} is malformed"))) }
    }

    /// The ring at `z` (inside the column's range): a breakpoint's ring, or the
    /// interpolation between the two around it, snapped.
    fn ring_at(&self, z: f64) -> Ring {
        let k = self.z.partition_point(|&b| b < z);
        if k < self.z.len() && self.z[k] == z {
            return self.rings[k].clone();
        }
        let (z0, z1) = (self.z[k - 1], self.z[k]);
        let t = (z - z0) / (z1 - z0);
        let (r0, r1) = (&self.rings[k - 1].0, &self.rings[k].0);
        let pts = r0.iter().zip(r1).map(|(a, b)| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        let ring = Ring::snapped(pts);
        // Snapping can merge two vertices of a ring that shrinks to a point; keep the count.
        if ring.0.len() == r0.len() { ring } else { Ring(r0.iter().map(|p| p.map(snap)).collect()) }
    }
}

/// A built solid: its mesh and its volume by the slab formula.
pub(crate) struct Built {
    pub(crate) mesh: Mesh,
    pub(crate) volume: f64,
}

/// Meshes the solid made of `columns` (see the module docs).
pub(crate) fn build(columns: &[Column]) -> Result<Built> {
    for (i, c) in columns.iter().enumerate() {
        c.validate(i)?;
    }
    let mut levels: Vec<f64> = columns.iter().flat_map(|c| c.z.iter().copied()).collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    // rings[c][l]: column c's ring at level l, where the column spans it.
    let rings: Vec<Vec<Option<Ring>>> = columns
        .iter()
        .map(|c| {
            let (lo, hi) = (c.z[0], c.z[c.z.len() - 1]);
            levels.iter().map(|&z| (z >= lo && z <= hi).then(|| c.ring_at(z))).collect()
        })
        .collect();
    let spans =
        |c: usize, l: usize| rings[c][l].is_some() && rings[c].get(l + 1).is_some_and(Option::is_some);
    let points: Vec<LevelPoints> = (0..levels.len())
        .map(|l| {
            let present = (0..columns.len())
                .filter(|&c| spans(c, l) || (l > 0 && spans(c, l - 1)))
                .filter_map(|c| rings[c][l].as_ref());
            LevelPoints::new(present)
        })
        .collect();

    let mut mesh = MeshBuilder::default();
    let mut volume = 0.0;
    for l in 0..levels.len().saturating_sub(1) {
        for c in (0..columns.len()).filter(|&c| spans(c, l)) {
            let (rb, rt) =
                (rings[c][l].as_ref().unwrap_or(&EMPTY), rings[c][l + 1].as_ref().unwrap_or(&EMPTY));
            walls(&mut mesh, (rb, &points[l], levels[l]), (rt, &points[l + 1], levels[l + 1]));
            volume += slab_volume(rb, rt, levels[l + 1] - levels[l]);
        }
    }
    for (l, &z) in levels.iter().enumerate() {
        let below: Vec<&Ring> = (0..columns.len())
            .filter(|&c| l > 0 && spans(c, l - 1))
            .filter_map(|c| rings[c][l].as_ref())
            .collect();
        let above: Vec<&Ring> =
            (0..columns.len()).filter(|&c| spans(c, l)).filter_map(|c| rings[c][l].as_ref()).collect();
        level_faces(&below, &above, &points[l], z, &mut mesh)?;
    }
    Ok(Built { mesh: mesh.finish()?, volume })
}

static EMPTY: Ring = Ring(Vec::new());

/// The side walls of one slab ring, from `bottom` (ring, level points, z) to `top`.
fn walls(mesh: &mut MeshBuilder, bottom: (&Ring, &LevelPoints, f64), top: (&Ring, &LevelPoints, f64)) {
    let (rb, pb, zb) = bottom;
    let (rt, pt, zt) = top;
    let n = rb.0.len();
    for j in 0..n {
        let bot = pb.split(rb.0[j], rb.0[(j + 1) % n]);
        let top = pt.split(rt.0[j], rt.0[(j + 1) % n]);
        let tb = params(&bot);
        let tt = params(&top);
        let bv: Vec<u32> = bot.iter().map(|&p| mesh.vertex(p, zb)).collect();
        let tv: Vec<u32> = top.iter().map(|&p| mesh.vertex(p, zt)).collect();
        // Zip the two chains into a strip of triangles, outward for a counter-clockwise
        // ring (material on the left of a -> b).
        let (mut p, mut q) = (0, 0);
        while p + 1 < bv.len() || q + 1 < tv.len() {
            let advance_bottom = p + 1 < bv.len() && (q + 1 == tv.len() || tb[p + 1] <= tt[q + 1]);
            if advance_bottom {
                mesh.triangle([bv[p], bv[p + 1], tv[q]]);
                p += 1;
            } else {
                mesh.triangle([bv[p], tv[q + 1], tv[q]]);
                q += 1;
            }
        }
    }
}

/// Each point's parameter along the chain's first-to-last segment, 0 to 1.
fn params(chain: &[P2]) -> Vec<f64> {
    let (a, b) = (chain[0], chain[chain.len() - 1]);
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    chain.iter().map(|p| ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).collect()
}

/// The volume of a slab between rings `rb` (bottom) and `rt` (top), `h` apart: the
/// prismatoid formula `h (A_b + 4 A_m + A_t) / 6`, exact for any polyhedron whose
/// vertices lie in the two planes; `A_m` is the section half-way up of the walls as
/// [`walls`] triangulates them (each quad `a_k a_k+1 a'_k+1 a'_k` split along
/// `a_k+1 a'_k`). A straight slab is `A h`.
pub(crate) fn slab_volume(rb: &Ring, rt: &Ring, h: f64) -> f64 {
    if rb == rt {
        return rb.area() * h;
    }
    let n = rb.0.len();
    let mid = |a: P2, b: P2| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
    let mut m = Vec::with_capacity(2 * n);
    for k in 0..n {
        let k1 = (k + 1) % n;
        m.push(mid(rb.0[k], rt.0[k]));
        m.push(mid(rb.0[k1], rt.0[k]));
    }
    h * (rb.area() + 4.0 * shoelace(&m) + rt.area()) / 6.0
}
