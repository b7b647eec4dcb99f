//! Any-hit queries for many rays along one direction (visibility from a tool axis): the
//! triangles projected across the direction and binned in a uniform grid, each cell's
//! triangles ordered by their highest point along the direction.
//!
//! A ray from `o` along `d` can only hit a triangle whose projection contains `o`'s, so
//! the cell of `o` lists every triangle the ray may hit (boxes are grown far beyond the
//! rounding of the hit test); and one whose highest point lies below `o` (beyond rounding)
//! is not hit at `t >= 0`, so the scan of a cell stops there. The hit test itself is the
//! BVH's, so the answers are those of [`MeshIndex::ray_hits_any_cached`], exactly.

use super::bvh::{Bvh, dot, intersect};
use super::{MeshIndex, OccluderCache, finite, unit};
use crate::math::{Point3, Real, Vector3};

/// Rays along one direction against a mesh; see [`MeshIndex::parallel_rays`].
#[derive(Debug, Clone)]
pub struct ParallelRays<'a> {
    bvh: &'a Bvh,
    /// The direction (unit) and two unit vectors across it.
    dir: [f64; 3],
    across: [[f64; 3]; 2],
    /// The grid over the projected triangles: lower corner, cell size, cells per side.
    origin: [f64; 2],
    cell: f64,
    dims: [usize; 2],
    /// Cell `c` lists `ids[start[c]..start[c + 1]]`, highest triangle first.
    start: Vec<u32>,
    ids: Vec<u32>,
    /// Per triangle (index into the BVH's triangles), its highest point along `dir`.
    top: Vec<f64>,
    /// Slack of the box and depth tests, far beyond the hit test's rounding.
    tol: f64,
}

impl MeshIndex {
    /// An index for rays along `dir` (need not be unit); `None` for a zero or non-finite
    /// direction. Building costs a pass over the triangles, so it pays for itself over
    /// many rays (a few per triangle and more); [`ParallelRays::hits_any`] then answers as
    /// [`MeshIndex::ray_hits_any_cached`] does, for any origin.
    pub fn parallel_rays(&self, dir: &Vector3) -> Option<ParallelRays<'_>> {
        let d = unit(dir)?;
        let bvh = &self.bvh;
        // Two unit vectors across `d`.
        let helper = if d[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
        let a = normalised(cross3(d, helper));
        let b = cross3(d, a);
        let n = bvh.tris.len();
        let mut boxes: Vec<[f64; 4]> = Vec::with_capacity(n);
        let mut top = Vec::with_capacity(n);
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let mut scale: f64 = 0.0;
        for tri in &bvh.tris {
            let vs = tri.vertices();
            let u = vs.map(|v| dot(v, a));
            let w = vs.map(|v| dot(v, b));
            let h = vs.map(|v| dot(v, d));
            let bx = [min3(u), min3(w), max3(u), max3(w)];
            for k in 0..2 {
                lo[k] = lo[k].min(bx[k]);
                hi[k] = hi[k].max(bx[k + 2]);
            }
            scale = vs.iter().flatten().fold(scale, |s, c| s.max(c.abs()));
            boxes.push(bx);
            top.push(max3(h));
        }
        if n == 0 || !(lo[0] <= hi[0] && lo[1] <= hi[1]) {
            return None;
        }
        let tol = 1e-9 * scale.max(f64::MIN_POSITIVE);
        let (w, h) = ((hi[0] - lo[0]) + 2.0 * tol, (hi[1] - lo[1]) + 2.0 * tol);
        // About one triangle per cell along each side of a square grid.
        let side = (2.0 * (n as f64).sqrt()).ceil().clamp(1.0, 1024.0);
        let cell = (w.max(h) / side).max(f64::MIN_POSITIVE);
        let dims = [((w / cell).ceil() as usize).clamp(1, 1024), ((h / cell).ceil() as usize).clamp(1, 1024)];
        let origin = [lo[0] - tol, lo[1] - tol];
        let mut grid = ParallelRays {
            bvh,
            dir: d,
            across: [a, b],
            origin,
            cell,
            dims,
            start: Vec::new(),
            ids: Vec::new(),
            top,
            tol,
        };
        // Each triangle's cells, grown by the slack.
        let spans: Vec<(usize, usize, usize, usize)> = boxes
            .iter()
            .map(|bx| {
                let (i0, j0) = grid.cell_of(bx[0] - tol, bx[1] - tol);
                let (i1, j1) = grid.cell_of(bx[2] + tol, bx[3] + tol);
                (i0, j0, i1, j1)
            })
            .collect();
        let mut count = vec![0u32; dims[0] * dims[1] + 1];
        for &(i0, j0, i1, j1) in &spans {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    count[j * dims[0] + i + 1] += 1;
                }
            }
        }
        for c in 0..dims[0] * dims[1] {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut ids = vec![0u32; count[dims[0] * dims[1]] as usize];
        // Triangles highest first, so each cell's list comes out in that order.
        let mut order: Vec<u32> = (0..n as u32).collect();
        order.sort_by(|&x, &y| grid.top[y as usize].total_cmp(&grid.top[x as usize]).then(x.cmp(&y)));
        for &t in &order {
            let (i0, j0, i1, j1) = spans[t as usize];
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let slot = &mut fill[j * dims[0] + i];
                    ids[*slot as usize] = t;
                    *slot += 1;
                }
            }
        }
        grid.start = count;
        grid.ids = ids;
        Some(grid)
    }
}

impl ParallelRays<'_> {
    /// The cell holding projected point `(u, w)`, clamped to the grid.
    #[inline]
    fn cell_of(&self, u: f64, w: f64) -> (usize, usize) {
        let i = ((u - self.origin[0]) / self.cell).floor();
        let j = ((w - self.origin[1]) / self.cell).floor();
        let ci = if i.is_nan() { 0 } else { i.clamp(0.0, (self.dims[0] - 1) as f64) as usize };
        let cj = if j.is_nan() { 0 } else { j.clamp(0.0, (self.dims[1] - 1) as f64) as usize };
        (ci, cj)
    }

    /// Whether the segment from `origin` along the direction, of length `max_dist`, hits
    /// the mesh: the answer of [`MeshIndex::ray_hits_any_cached`] with this direction,
    /// sharing its cache convention (the triangle that blocked the last ray).
    #[inline]
    pub fn hits_any(&self, origin: &Point3, max_dist: Real, cache: &mut OccluderCache) -> bool {
        if !finite(origin) || !(max_dist >= 0.0) {
            return false;
        }
        let bvh = self.bvh;
        let o = bvh.to_local([origin.x, origin.y, origin.z]);
        let d = self.dir;
        if let Some(tri) = bvh.tris.get(cache.0 as usize)
            && intersect(tri, o, d, max_dist).is_some()
        {
            return true;
        }
        let (u, w) = (dot(o, self.across[0]), dot(o, self.across[1]));
        let outside = |x: f64, lo: f64, n: usize| !(x >= lo && x <= lo + n as f64 * self.cell);
        if outside(u, self.origin[0], self.dims[0]) || outside(w, self.origin[1], self.dims[1]) {
            return false;
        }
        let (i, j) = self.cell_of(u, w);
        let c = j * self.dims[0] + i;
        let floor = dot(o, d) - self.tol;
        for &t in &self.ids[self.start[c] as usize..self.start[c + 1] as usize] {
            if self.top[t as usize] < floor {
                break;
            }
            if intersect(&bvh.tris[t as usize], o, d, max_dist).is_some() {
                cache.0 = t;
                return true;
            }
        }
        false
    }
}

fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn normalised(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

fn min3(x: [f64; 3]) -> f64 {
    x[0].min(x[1]).min(x[2])
}

fn max3(x: [f64; 3]) -> f64 {
    x[0].max(x[1]).max(x[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::SplitMix64;
    use crate::mesh::Mesh;

    /// A closed mesh with cavities and overhangs: two stacked boxes and a floating one.
    fn scene() -> Mesh {
        let boxes = [
            ([0.0, 0.0, 0.0], [4.0, 3.0, 1.0]),
            ([1.0, 0.5, 1.0], [2.0, 1.5, 3.0]),
            ([-1.0, 0.0, 4.0], [5.0, 2.0, 4.5]),
        ];
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for (lo, hi) in boxes {
            let b = vertices.len() as u32;
            for k in 0..8 {
                vertices.push(Point3::new(
                    if k & 1 == 0 { lo[0] } else { hi[0] },
                    if k & 2 == 0 { lo[1] } else { hi[1] },
                    if k & 4 == 0 { lo[2] } else { hi[2] },
                ));
            }
            for f in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
                triangles.push([b + f[0], b + f[1], b + f[2]]);
                triangles.push([b + f[0], b + f[2], b + f[3]]);
            }
        }
        Mesh::new(vertices, triangles).expect("mesh")
    }

    #[test]
    fn parallel_rays_answer_as_the_bvh_does() {
        let mesh = scene();
        let index = MeshIndex::new(&mesh).expect("index");
        let mut rng = SplitMix64(7);
        let mut u = || -> f64 { rng.unit() };
        let (mut hits, mut total) = (0, 0);
        for _ in 0..40 {
            let dir = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5);
            // Axis-aligned directions graze the boxes' faces and edges exactly.
            for dir in [dir, Vector3::z(), -Vector3::x(), Vector3::new(0.0, 1.0, 1.0)] {
                let rays = index.parallel_rays(&dir).expect("direction");
                let (mut a, mut b) = (OccluderCache::default(), OccluderCache::default());
                for _ in 0..200 {
                    // Origins on the boxes' faces, vertices and in between.
                    let o = Point3::new(
                        (8.0 * u()).round() * 0.75 - 1.5,
                        (8.0 * u()).round() * 0.5 - 0.5,
                        (10.0 * u()).round() * 0.5 - 0.5,
                    );
                    let len = if u() < 0.2 { f64::INFINITY } else { 6.0 * u() };
                    let want = index.ray_hits_any_cached(&o, &dir, len, &mut a);
                    assert_eq!(rays.hits_any(&o, len, &mut b), want, "origin {o:?} dir {dir:?} len {len}");
                    hits += want as usize;
                    total += 1;
                }
            }
        }
        // Both answers occur often enough for the comparison to mean something.
        assert!(hits > total / 10 && hits < total * 9 / 10, "{hits} hits of {total}");
        assert!(index.parallel_rays(&Vector3::zeros()).is_none());
        assert!(index.parallel_rays(&Vector3::new(f64::NAN, 0.0, 1.0)).is_none());
    }
}
