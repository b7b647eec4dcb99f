//! Solid voxelisation of a triangle mesh by the voxel-centre rule: a voxel is set iff its
//! centre is inside the mesh.
//!
//! # Method
//! For an axis `a`, every line of voxel centres parallel to `a` (a *column*) is crossed by
//! the surface at a few points. Each triangle is rasterised onto the grid of columns in the
//! plane perpendicular to `a`: the columns whose centre falls inside the triangle's
//! projection receive a crossing `(depth along a, sign of the normal's a-component)`.
//! Points exactly on a projected edge or vertex are assigned by a top-left rule (a
//! consistent symbolic perturbation of the column centre), and each edge's function is
//! evaluated in a canonical vertex order so both triangles sharing an edge see the same
//! value: a column through a shared edge or vertex is counted exactly once, so closed
//! meshes never leak. Along each column the crossings are sorted and a winding count (not
//! a parity) is accumulated, entering faces adding one and leaving faces subtracting one;
//! a voxel is inside when the count below its centre is positive. Duplicated or opposed
//! faces therefore cancel correctly.
//!
//! A column whose crossings do not sum to zero passes through a hole (or an open sheet)
//! and is marked *unknown*. With [`VoxelizeOptions::robust`] (the default) the fill is done
//! along all three axes and each voxel takes the majority of the axes whose column through
//! it is known; voxels left undecided (no known column, or a tie) get the generalised
//! winding number of the mesh ([`crate::MeshIndex::winding_number`]) when
//! [`VoxelizeOptions::winding_fallback`] is on. Small holes therefore change only the few
//! voxels whose three columns all pass through holes, and those are answered by the
//! winding number, which degrades gracefully.

// Brick loops index words and bits by the same coordinate.
#![allow(clippy::needless_range_loop)]

use rayon::prelude::*;

use crate::error::{GeomError, Result};
use crate::math::Point3;
use crate::mesh::Mesh;
use crate::query::MeshIndex;
use crate::voxel::{BRICK, Brick, GridSpec, VoxelGrid};

/// Options of [`voxelize_opt`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelizeOptions {
    /// Fill along all three axes and vote per voxel, which tolerates small holes. Default
    /// `true`; `false` fills along Z only (about three times faster).
    pub robust: bool,
    /// Decide voxels that no consistent column decides (or where known columns tie) by the
    /// generalised winding number. Default `true`; when `false` such voxels stay clear.
    pub winding_fallback: bool,
    /// Winding number at or above which an undecided voxel is inside. Default `0.5`.
    pub winding_threshold: f64,
}

impl Default for VoxelizeOptions {
    fn default() -> Self {
        Self { robust: true, winding_fallback: true, winding_threshold: 0.5 }
    }
}

/// Solid voxelisation with the default options (see the module docs and [`voxelize_opt`]).
pub fn voxelize(mesh: &Mesh, spec: &GridSpec) -> Result<VoxelGrid> {
    voxelize_opt(mesh, spec, &VoxelizeOptions::default())
}

/// Solid voxelisation by the voxel-centre rule. An empty mesh gives an empty grid; a
/// malformed `spec` (non-finite or non-positive voxel size, zero dimension) gives
/// [`GeomError::InvalidArgument`].
pub fn voxelize_opt(mesh: &Mesh, spec: &GridSpec, opts: &VoxelizeOptions) -> Result<VoxelGrid> {
    check_spec(spec)?;
    let mut grid = VoxelGrid::new(*spec);
    if mesh.is_empty() {
        return Ok(grid);
    }
    let axes: &[usize] = if opts.robust { &[0, 1, 2] } else { &[2] };
    let fills: Vec<AxisFill> = axes.iter().map(|&a| AxisFill::compute(mesh, spec, a)).collect();

    // Combine per brick: majority of known columns; collect the undecided voxels.
    let d = spec.dims;
    let undecided: Vec<[usize; 3]> = grid
        .par_bricks_mut()
        .flat_map_iter(|(base, brick)| {
            let mut pending = Vec::new();
            if let Some(words) = whole_brick(&fills, base, d) {
                *brick = words;
                return pending;
            }
            for z in 0..BRICK.min(d[2] - base[2]) {
                for y in 0..BRICK.min(d[1] - base[1]) {
                    for x in 0..BRICK.min(d[0] - base[0]) {
                        let idx = [base[0] + x, base[1] + y, base[2] + z];
                        match vote(&fills, idx) {
                            Some(true) => brick[z] |= 1u64 << (x + BRICK * y),
                            Some(false) => {}
                            None => pending.push(idx),
                        }
                    }
                }
            }
            pending
        })
        .collect();
    if opts.winding_fallback && !undecided.is_empty() {
        let index = MeshIndex::new(mesh)?;
        let inside: Vec<bool> = undecided
            .par_iter()
            .with_min_len(64)
            .map(|&[i, j, k]| index.winding_number(&spec.center(i, j, k)) >= opts.winding_threshold)
            .collect();
        for (&[i, j, k], inside) in undecided.iter().zip(inside) {
            if inside {
                grid.set(i, j, k, true);
            }
        }
    }
    Ok(grid)
}

fn check_spec(spec: &GridSpec) -> Result<()> {
    let ok = (0..3).all(|a| {
        spec.origin[a].is_finite() && spec.voxel[a].is_finite() && spec.voxel[a] > 0.0 && spec.dims[a] > 0
    });
    let total = spec.dims.iter().try_fold(1usize, |acc, &n| acc.checked_mul(n));
    // Column indices are u32 along each axis's perpendicular plane.
    let cols_fit = (0..3).all(|a| spec.dims[a].saturating_mul(spec.dims[(a + 1) % 3]) <= u32::MAX as usize);
    if !ok || total.is_none() || !cols_fit {
        return Err(GeomError::InvalidArgument(format!("voxelize: malformed grid spec {spec:?}")));
    }
    Ok(())
}

/// One surface crossing of a column: its depth in voxel coordinates along the axis and
/// `+1` when the surface leaves the solid going up the axis, `-1` when it enters.
#[derive(Clone, Copy)]
struct Crossing {
    depth: f64,
    sign: i32,
}

/// The fill along one axis: per column, a bitset along the axis and whether it is known.
struct AxisFill {
    axis: usize,
    /// Columns along the first and second perpendicular axes.
    nb: usize,
    words: usize,
    bits: Vec<u64>,
    known: Vec<bool>,
}

/// Edge function `cross(b - a, p - a)` evaluated in a canonical vertex order, so the two
/// triangles sharing an edge get exactly opposite values.
#[inline(always)]
fn edge(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    if (a[0], a[1]) <= (b[0], b[1]) {
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    } else {
        -((a[0] - b[0]) * (p[1] - b[1]) - (a[1] - b[1]) * (p[0] - b[0]))
    }
}

/// Top-left rule: whether a point exactly on edge `a -> b` of a counter-clockwise
/// triangle belongs to it. Equivalent to perturbing the point by `(ε, ε²)`, so exactly one
/// of two triangles sharing the edge (or one of a fan around a vertex) takes it.
#[inline(always)]
fn owns_edge(a: [f64; 2], b: [f64; 2]) -> bool {
    let d = [b[0] - a[0], b[1] - a[1]];
    d[1] < 0.0 || (d[1] == 0.0 && d[0] > 0.0)
}

impl AxisFill {
    fn compute(mesh: &Mesh, spec: &GridSpec, axis: usize) -> AxisFill {
        let b = (axis + 1) % 3;
        let c = (axis + 2) % 3;
        let (nb, nc, na) = (spec.dims[b], spec.dims[c], spec.dims[axis]);
        let cols = nb * nc;
        // Grid coordinates: column (i, j) centre at (i, j), voxel k centre at depth k.
        let to_grid = |p: &Point3, ax: usize| (p[ax] - spec.origin[ax]) / spec.voxel[ax] - 0.5;
        let verts: Vec<[f64; 3]> =
            mesh.vertices().par_iter().map(|p| [to_grid(p, b), to_grid(p, c), to_grid(p, axis)]).collect();

        // Rasterise all triangles into (column, crossing) pairs.
        let hits: Vec<(u32, Crossing)> = mesh
            .triangles()
            .par_iter()
            .with_min_len(1024)
            .fold(Vec::new, |mut out, tri| {
                rasterise(tri.map(|v| verts[v as usize]), nb, nc, &mut out);
                out
            })
            .reduce(Vec::new, |mut a, mut b| {
                if a.len() < b.len() {
                    std::mem::swap(&mut a, &mut b);
                }
                a.extend_from_slice(&b);
                a
            });

        // Counting sort by column.
        let mut start = vec![0u32; cols + 1];
        for (col, _) in &hits {
            start[*col as usize + 1] += 1;
        }
        for i in 0..cols {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut sorted = vec![Crossing { depth: 0.0, sign: 0 }; hits.len()];
        for (col, x) in &hits {
            let s = &mut fill[*col as usize];
            sorted[*s as usize] = *x;
            *s += 1;
        }
        drop(hits);

        let words = na.div_ceil(64);
        let mut bits = vec![0u64; cols * words];
        let mut known = vec![true; cols];
        bits.par_chunks_mut(words).zip(known.par_iter_mut()).enumerate().with_min_len(64).for_each_init(
            Vec::new,
            |scratch, (col, (out, known))| {
                let xs = &sorted[start[col] as usize..start[col + 1] as usize];
                if xs.is_empty() {
                    return;
                }
                scratch.clear();
                scratch.extend_from_slice(xs);
                scratch.sort_unstable_by(|p, q| p.depth.total_cmp(&q.depth));
                if scratch.iter().map(|x| x.sign).sum::<i32>() != 0 {
                    *known = false;
                    return;
                }
                // The count at voxel k sums the crossings with depth <= k: a centre on
                // the surface counts as if moved by +ε along the axis, the same
                // perturbation the top-left rule applies across the column plane.
                let mut count = 0i32;
                for m in 0..scratch.len() {
                    count -= scratch[m].sign;
                    if count <= 0 {
                        continue;
                    }
                    let lo = scratch[m].depth.ceil();
                    let hi = scratch.get(m + 1).map_or(f64::INFINITY, |x| x.depth).ceil() - 1.0;
                    let lo = lo.max(0.0);
                    let hi = hi.min(na as f64 - 1.0);
                    if lo > hi {
                        continue;
                    }
                    set_range(out, lo as usize, hi as usize);
                }
            },
        );
        AxisFill { axis, nb, words, bits, known }
    }

    /// The fill's answer for voxel `idx`: `None` where its column is unknown.
    #[inline(always)]
    fn get(&self, idx: [usize; 3]) -> Option<bool> {
        let b = (self.axis + 1) % 3;
        let c = (self.axis + 2) % 3;
        let col = idx[b] + self.nb * idx[c];
        if !self.known[col] {
            return None;
        }
        let k = idx[self.axis];
        Some(self.bits[col * self.words + k / 64] >> (k % 64) & 1 == 1)
    }
}

/// The majority of the fills whose column through voxel `idx` is known; `None` for a tie
/// (or no known column).
fn vote(fills: &[AxisFill], idx: [usize; 3]) -> Option<bool> {
    let (mut known, mut inside) = (0u32, 0u32);
    for f in fills {
        if let Some(v) = f.get(idx) {
            known += 1;
            inside += v as u32;
        }
    }
    (2 * inside != known).then_some(2 * inside > known)
}

/// The voxels of the whole brick at `base` (grid dimensions `d`) when every fill knows
/// every column through it: bit `x + 8 y` of word `z`, the majority of the fills. `None`
/// for a brick cut by the grid's end or crossed by an unknown column.
fn whole_brick(fills: &[AxisFill], base: [usize; 3], d: [usize; 3]) -> Option<Brick> {
    if (0..3).any(|a| base[a] + BRICK > d[a]) || !matches!(fills.len(), 1 | 3) {
        return None;
    }
    let mut votes = [[0u64; BRICK]; 3];
    for (f, out) in fills.iter().zip(&mut votes) {
        let (a, b, c) = (f.axis, (f.axis + 1) % 3, (f.axis + 2) % 3);
        let (word, shift) = (base[a] / 64, base[a] % 64);
        for v in 0..BRICK {
            for u in 0..BRICK {
                let col = base[b] + u + f.nb * (base[c] + v);
                if !f.known[col] {
                    return None;
                }
                // The column's eight voxels along its axis, bit `t` at `base[a] + t`.
                let byte = (f.bits[col * f.words + word] >> shift) & 0xff;
                let mut idx = [0; 3];
                (idx[b], idx[c]) = (u, v);
                match a {
                    0 => out[idx[2]] |= byte << (BRICK * idx[1]),
                    1 => {
                        for t in (0..BRICK).filter(|t| byte >> t & 1 == 1) {
                            out[idx[2]] |= 1 << (idx[0] + BRICK * t);
                        }
                    }
                    _ => {
                        for t in (0..BRICK).filter(|t| byte >> t & 1 == 1) {
                            out[t] |= 1 << (idx[0] + BRICK * idx[1]);
                        }
                    }
                }
            }
        }
    }
    if fills.len() == 1 {
        return Some(votes[0]);
    }
    let [x, y, z] = votes;
    Some(std::array::from_fn(|k| (x[k] & y[k]) | (x[k] & z[k]) | (y[k] & z[k])))
}

/// Sets bits `lo..=hi` of a bitset.
fn set_range(words: &mut [u64], lo: usize, hi: usize) {
    let (wl, wh) = (lo / 64, hi / 64);
    for (w, word) in words.iter_mut().enumerate().take(wh + 1).skip(wl) {
        let from = if w == wl { lo % 64 } else { 0 };
        let to = if w == wh { hi % 64 } else { 63 };
        let mask = if to - from == 63 { u64::MAX } else { ((1u64 << (to - from + 1)) - 1) << from };
        *word |= mask;
    }
}

/// Appends the crossings of one triangle (grid coordinates `[u, v, depth]`) with the
/// columns of an `nb x nc` column grid.
#[inline]
fn rasterise(v: [[f64; 3]; 3], nb: usize, nc: usize, out: &mut Vec<(u32, Crossing)>) {
    let p = v.map(|x| [x[0], x[1]]);
    let area = edge(p[0], p[1], p[2]);
    if area == 0.0 || !area.is_finite() {
        return;
    }
    // Make the projection counter-clockwise; the sign records the original orientation.
    let (sign, p, v) = if area > 0.0 { (1, p, v) } else { (-1, [p[0], p[2], p[1]], [v[0], v[2], v[1]]) };
    let umin = p[0][0].min(p[1][0]).min(p[2][0]).ceil().max(0.0);
    let umax = p[0][0].max(p[1][0]).max(p[2][0]).floor().min(nb as f64 - 1.0);
    let vmin = p[0][1].min(p[1][1]).min(p[2][1]).ceil().max(0.0);
    let vmax = p[0][1].max(p[1][1]).max(p[2][1]).floor().min(nc as f64 - 1.0);
    if umin > umax || vmin > vmax {
        return;
    }
    let own = [owns_edge(p[1], p[2]), owns_edge(p[2], p[0]), owns_edge(p[0], p[1])];
    for j in vmin as usize..=vmax as usize {
        for i in umin as usize..=umax as usize {
            let q = [i as f64, j as f64];
            let w = [edge(p[1], p[2], q), edge(p[2], p[0], q), edge(p[0], p[1], q)];
            if (0..3).all(|e| w[e] > 0.0 || (w[e] == 0.0 && own[e])) {
                let s = w[0] + w[1] + w[2];
                let depth = if s > 0.0 {
                    (w[0] * v[0][2] + w[1] * v[1][2] + w[2] * v[2][2]) / s
                } else {
                    (v[0][2] + v[1][2] + v[2][2]) / 3.0
                };
                out.push(((i + nb * j) as u32, Crossing { depth, sign }));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box with half its top face missing (unknown columns), and three tubes open at
    /// both ends, along X, Y and Z (the fill along a tube's axis sees no wall, the other
    /// two see it inside: known columns that disagree, every pair of axes outvoting the
    /// third somewhere).
    fn leaky() -> Mesh {
        let mut tris: Vec<[Point3; 3]> = Vec::new();
        // (corner, corner, faces left out: 0..6 as in `faces`, 6 = half the top).
        let solids: [([f64; 3], [f64; 3], &[usize]); 4] = [
            ([-2.8, -2.8, -2.8], [-0.5, -0.5, -0.5], &[6]),
            ([0.2, -2.8, 0.2], [2.8, -1.2, 1.8], &[4, 5]),
            ([-2.8, 0.2, 0.2], [-1.2, 2.8, 1.8], &[2, 3]),
            ([0.2, 0.2, -2.8], [1.8, 1.8, -0.2], &[0, 1]),
        ];
        let faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        for (lo, hi, open) in solids {
            let p = |k: usize| {
                Point3::new(
                    if k & 1 == 0 { lo[0] } else { hi[0] },
                    if k & 2 == 0 { lo[1] } else { hi[1] },
                    if k & 4 == 0 { lo[2] } else { hi[2] },
                )
            };
            for (f, q) in faces.iter().enumerate() {
                if open.contains(&f) {
                    continue;
                }
                tris.push([p(q[0]), p(q[1]), p(q[2])]);
                if !(f == 1 && open.contains(&6)) {
                    tris.push([p(q[0]), p(q[2]), p(q[3])]);
                }
            }
        }
        Mesh::from_soup(&tris).expect("mesh")
    }

    #[test]
    fn whole_bricks_take_the_per_voxel_majority() {
        let mesh = leaky();
        let spec = GridSpec::new(
            &crate::Aabb::new(Point3::new(-3.0, -3.0, -3.0), Point3::new(3.0, 3.0, 3.0)),
            [61, 70, 57],
        )
        .expect("spec");
        for axes in [vec![0, 1, 2], vec![2]] {
            let fills: Vec<AxisFill> = axes.iter().map(|&a| AxisFill::compute(&mesh, &spec, a)).collect();
            let d = spec.dims;
            let (mut whole, mut unknown) = (0, 0);
            for bz in 0..d[2].div_ceil(BRICK) {
                for by in 0..d[1].div_ceil(BRICK) {
                    for bx in 0..d[0].div_ceil(BRICK) {
                        let base = [bx * BRICK, by * BRICK, bz * BRICK];
                        let votes: Vec<Option<bool>> = (0..BRICK * BRICK * BRICK)
                            .filter(|k| (0..3).all(|a| base[a] + [k % 8, k / 8 % 8, k / 64][a] < d[a]))
                            .map(|k| vote(&fills, [base[0] + k % 8, base[1] + k / 8 % 8, base[2] + k / 64]))
                            .collect();
                        match whole_brick(&fills, base, d) {
                            Some(words) => {
                                whole += 1;
                                for (k, v) in votes.iter().enumerate() {
                                    let bit = words[k / 64] >> (k % 64) & 1 == 1;
                                    assert_eq!(Some(bit), *v, "axes {axes:?} brick {base:?} voxel {k}");
                                }
                            }
                            // A whole-sized brick falls back only for an unknown column.
                            None => unknown += (votes.len() == BRICK * BRICK * BRICK) as usize,
                        }
                    }
                }
            }
            // Both paths are taken: whole bricks, and bricks left to the per-voxel vote
            // because a column through them is unknown.
            assert!(
                whole > 10 && unknown > 0,
                "axes {axes:?}: {whole} whole bricks, {unknown} crossed by unknown columns"
            );
        }
    }
}
