//! What the walls and the flat faces of a slab stack share: the mesh under construction
//! (vertices shared by exact position) and each level's points, which split every edge
//! lying in that level.

use std::collections::HashMap;

use s2g_geom::{Mesh, Point3};

use crate::error::{GenError, Result};
use crate::ring::{P2, Ring};

/// The mesh under construction: vertices shared by exact position.
#[derive(Default)]
pub(crate) struct MeshBuilder {
    vertices: Vec<Point3>,
    index: HashMap<[u64; 3], u32>,
    triangles: Vec<[u32; 3]>,
}

impl MeshBuilder {
    /// The index of the vertex at `(p, z)`, added on first use.
    pub(crate) fn vertex(&mut self, p: P2, z: f64) -> u32 {
        let key = [p[0] + 0.0, p[1] + 0.0, z + 0.0].map(f64::to_bits);
        *self.index.entry(key).or_insert_with(|| {
            self.vertices.push(Point3::new(p[0], p[1], z));
            (self.vertices.len() - 1) as u32
        })
    }

    /// Adds a triangle by vertex indices (counter-clockwise seen from outside).
    pub(crate) fn triangle(&mut self, t: [u32; 3]) {
        self.triangles.push(t);
    }

    /// The finished mesh.
    pub(crate) fn finish(self) -> Result<Mesh> {
        Mesh::new(self.vertices, self.triangles).map_err(GenError::Mesh)
    }
}

/// The vertices of one level, sorted by `(x, y)` and distinct: the candidates that split
/// the edges lying in that level.
pub(crate) struct LevelPoints(Vec<P2>);

impl LevelPoints {
    pub(crate) fn new<'a>(rings: impl Iterator<Item = &'a Ring>) -> Self {
        let mut v: Vec<P2> = rings.flat_map(|r| r.0.iter().copied()).collect();
        v.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
        v.dedup();
        Self(v)
    }

    /// The index of `p`, which must be one of the level's points.
    pub(crate) fn index_of(&self, p: P2) -> Option<usize> {
        self.0.binary_search_by(|q| q[0].total_cmp(&p[0]).then(q[1].total_cmp(&p[1]))).ok()
    }

    /// The point at `i`.
    pub(crate) fn point(&self, i: usize) -> P2 {
        self.0[i]
    }

    /// The edge `a -> b` with every level point strictly inside it inserted, in order.
    pub(crate) fn split(&self, a: P2, b: P2) -> Vec<P2> {
        let (lo, hi) = (a[0].min(b[0]), a[0].max(b[0]));
        let (ylo, yhi) = (a[1].min(b[1]), a[1].max(b[1]));
        let start = self.0.partition_point(|p| p[0] < lo);
        let d = [b[0] - a[0], b[1] - a[1]];
        let mut inner: Vec<(f64, P2)> = self.0[start..]
            .iter()
            .take_while(|p| p[0] <= hi)
            .filter(|p| p[1] >= ylo && p[1] <= yhi && **p != a && **p != b)
            // Exact on the grid: see the module docs of `ring`.
            .filter(|p| d[0] * (p[1] - a[1]) - d[1] * (p[0] - a[0]) == 0.0)
            .map(|p| ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1], *p))
            .collect();
        inner.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut out = Vec::with_capacity(inner.len() + 2);
        out.push(a);
        out.extend(inner.into_iter().map(|(_, p)| p));
        out.push(b);
        out
    }
}
