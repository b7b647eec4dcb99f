//! Marching cubes: a watertight, consistently oriented triangle mesh of an iso-surface.
//!
//! # Conventions
//! * Samples form a lattice of `dims[0] x dims[1] x dims[2]` points; cells are the
//!   `(dims - 1)` cubes between them. A sample is **inside** when its value is below the iso
//!   level (`value < iso`; NaN counts as outside), so a signed distance field is negative
//!   inside. Triangles wind counter-clockwise seen from outside: a closed result has a
//!   positive [`Mesh::signed_volume`].
//! * Vertices are shared between cells (each lattice edge the surface crosses gives one
//!   vertex), so the result is watertight wherever the inside does not touch the lattice
//!   boundary; [`marching_cubes_voxels`] pads its lattice with empty samples and is always
//!   closed.
//! * Ambiguous faces are resolved by a fixed rule that depends on the face's signs only
//!   (inside corners are separated; see the `tables` module), which both cells sharing the
//!   face apply alike: every edge of the output has exactly two triangles and the surface
//!   is a 2-manifold.
//! * A crossing is placed by linear interpolation and kept at least
//!   [`McOptions::min_edge_fraction`] of the edge away from either end, so no two vertices
//!   coincide and no triangle is degenerate even when samples equal the iso level.
//!
//! # Algorithm
//! Flying-edges style, per slab of z-layers in parallel (rayon): each lattice plane is
//! classified into bit rows (64 samples per word); edge crossings are found with word XORs
//! and get their vertex at once (x and y edges per plane, z edges per layer, recorded in
//! per-plane index caches); cells whose eight corners agree are skipped 64 at a time, and
//! only the others are looked up in the case table. Slabs are merged deterministically:
//! a slab numbers the vertices of its upper boundary plane exactly as the next slab does,
//! so the output is byte-identical for any number of threads.

mod tables;

use rayon::prelude::*;

use crate::error::{GeomError, Result};
use crate::math::{Point3, Real, Vector3};
use crate::mesh::Mesh;
use crate::voxel::{BRICK, Brick, GridSpec, VoxelGrid};
use tables::TABLE;

/// Options for marching cubes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct McOptions {
    /// Smallest distance of a vertex from either end of its lattice edge, as a fraction of
    /// the edge (default `1e-3`). Keeps triangles non-degenerate where samples equal the
    /// iso level; must lie in `(0, 0.5]`.
    pub min_edge_fraction: Real,
    /// Lattice layers per parallel slab, at least 1 (default 16). Any value gives the same
    /// output; it only trades parallelism against the cost of re-classifying slab borders.
    pub slab_layers: usize,
}

impl Default for McOptions {
    fn default() -> Self {
        Self { min_edge_fraction: 1e-3, slab_layers: 16 }
    }
}

impl McOptions {
    fn check(&self) -> Result<()> {
        if !(self.min_edge_fraction > 0.0 && self.min_edge_fraction <= 0.5) || self.slab_layers == 0 {
            return Err(GeomError::InvalidArgument(format!(
                "marching cubes needs 0 < min_edge_fraction <= 0.5 and slab_layers >= 1, got {self:?}"
            )));
        }
        Ok(())
    }
}

/// Marching cubes of `field` sampled at the voxel centres of `spec` (`spec.center(i, j, k)`),
/// so the lattice is `spec.dims` samples; inside where `field < iso` (see the module docs).
/// The field is evaluated once per sample, in parallel, one slab of planes at a time (not
/// the whole grid at once). The surface is open where the inside reaches the lattice boundary.
///
/// Errors: [`GeomError::InvalidArgument`] for a spec with non-finite origin or a non-finite
/// or zero voxel size, or when the mesh would exceed `u32` vertex indices.
///
/// ```
/// use s2g_geom::{Aabb, GridSpec, Point3, SignedDistance, Sphere, marching_cubes};
/// let spec = GridSpec::new(&Aabb::unit_cube(), [64; 3]).unwrap();
/// let sphere = Sphere { center: Point3::origin(), radius: 0.4 };
/// let mesh = marching_cubes(&spec, 0.0, |p| sphere.distance(p)).unwrap();
/// let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.4f64.powi(3);
/// assert!((mesh.signed_volume() - exact).abs() < 0.01 * exact);
/// ```
pub fn marching_cubes(spec: &GridSpec, iso: Real, field: impl Fn(&Point3) -> Real + Sync) -> Result<Mesh> {
    marching_cubes_opt(spec, iso, field, &McOptions::default())
}

/// [`marching_cubes`] with options.
pub fn marching_cubes_opt(
    spec: &GridSpec,
    iso: Real,
    field: impl Fn(&Point3) -> Real + Sync,
    opts: &McOptions,
) -> Result<Mesh> {
    let origin = spec.center(0, 0, 0);
    let src = FieldSource { spec: *spec, field };
    run(&src, spec.dims, origin, spec.voxel, iso, opts)
}

/// Marching cubes on a precomputed lattice: `values[i + dims[0] * (j + dims[1] * k)]` is the
/// sample at `origin + (i, j, k) * spacing` (component-wise). Works on `f32` or `f64`.
///
/// A negative spacing (mirrored lattice) is allowed: the winding is corrected so the result
/// still faces outwards.
///
/// Errors: [`GeomError::InvalidArgument`] when `values.len()` is not the product of `dims`,
/// for a non-finite `origin`, a non-finite or zero `spacing`, or when the mesh would exceed
/// `u32` vertex indices.
pub fn marching_cubes_samples<T: McSample>(
    dims: [usize; 3],
    origin: Point3,
    spacing: Vector3,
    iso: Real,
    values: &[T],
) -> Result<Mesh> {
    marching_cubes_samples_opt(dims, origin, spacing, iso, values, &McOptions::default())
}

/// [`marching_cubes_samples`] with options.
pub fn marching_cubes_samples_opt<T: McSample>(
    dims: [usize; 3],
    origin: Point3,
    spacing: Vector3,
    iso: Real,
    values: &[T],
    opts: &McOptions,
) -> Result<Mesh> {
    let n = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
    if n != Some(values.len()) {
        return Err(GeomError::InvalidArgument(format!(
            "marching cubes: {} samples given for a {dims:?} lattice",
            values.len()
        )));
    }
    let src = SampleSource { values, plane: dims[0] * dims[1] };
    run(&src, dims, origin, spacing, iso, opts)
}

/// Marching cubes of a voxel occupancy: the lattice is the voxel centres, padded with one
/// layer of empty samples all round so the result is always closed, and every vertex sits
/// at the midpoint between a set and a clear voxel centre. The surface therefore lies half
/// a voxel inside the voxels' outer faces at flat walls (its volume is slightly below
/// [`VoxelGrid::volume`]).
///
/// Errors: as [`marching_cubes`].
pub fn marching_cubes_voxels(grid: &VoxelGrid) -> Result<Mesh> {
    marching_cubes_voxels_opt(grid, &McOptions::default())
}

/// [`marching_cubes_voxels`] with options (`min_edge_fraction` is unused: vertices sit at
/// edge midpoints).
pub fn marching_cubes_voxels_opt(grid: &VoxelGrid, opts: &McOptions) -> Result<Mesh> {
    let spec = *grid.spec();
    let d = spec.dims;
    let bricks: Vec<&Brick> = grid.bricks().map(|(_, b)| b).collect();
    let src = VoxelSource { dims: d, bdims: grid.brick_dims(), bricks };
    let origin = spec.origin - 0.5 * spec.voxel;
    run(&src, [d[0] + 2, d[1] + 2, d[2] + 2], origin, spec.voxel, 0.5, opts)
}

/// A lattice the core algorithm reads one plane at a time.
trait Source: Sync {
    /// Per-plane state a slab keeps for two planes at a time.
    type Plane: Send;
    fn new_plane(&self, len: usize) -> Self::Plane;
    /// Loads plane `k`: fills `bits` (rows of `words` words, bit `i` of row `j` set when
    /// sample `(i, j, k)` is inside) and `plane`.
    fn load(&self, k: usize, iso: Real, plane: &mut Self::Plane, bits: &mut [u64], nx: usize, words: usize);
    /// Value of sample `idx = i + nx * j` of a loaded plane.
    fn value(&self, plane: &Self::Plane, idx: usize) -> Real;
    /// Where along the edge from `(pa, ia)` to `(pb, ib)` the iso level is crossed, in (0, 1).
    #[inline]
    fn frac(&self, pa: &Self::Plane, ia: usize, pb: &Self::Plane, ib: usize, iso: Real, lo: Real) -> Real {
        let (a, b) = (self.value(pa, ia), self.value(pb, ib));
        let t = (iso - a) / (b - a);
        if t.is_finite() { t.clamp(lo, 1.0 - lo) } else { 0.5 }
    }
}

/// A sample type for [`marching_cubes_samples`]: `f32` or `f64` (sealed).
pub trait McSample: Copy + Sync + PartialOrd + Into<Real> + sealed::Sealed {
    /// The threshold `t` of this type with `v < t` exactly when `(v as f64) < iso` for
    /// every value `v` of this type.
    fn threshold(iso: Real) -> Self;
}

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

impl McSample for f64 {
    fn threshold(iso: Real) -> f64 {
        iso
    }
}

impl McSample for f32 {
    fn threshold(iso: Real) -> f32 {
        // The smallest f32 at or above `iso`: no f32 lies in [iso, t), so `v < t` and
        // `v < iso` agree for every f32 `v` (NaN stays NaN: nothing is inside).
        let t = iso as f32;
        if (t as Real) < iso { t.next_up() } else { t }
    }
}

/// Packs `row` into bits `v < threshold`.
#[inline]
fn pack_row<T: McSample>(row: &[T], threshold: T, out: &mut [u64]) {
    for (w, chunk) in out.iter_mut().zip(row.chunks(64)) {
        // Compare into bytes first (vectorises), then gather the bits.
        let mut flags = [0u8; 64];
        for (f, &v) in flags.iter_mut().zip(chunk) {
            *f = (v < threshold) as u8;
        }
        let mut bits = 0u64;
        for (b, &f) in flags.iter().enumerate() {
            bits |= (f as u64) << b;
        }
        *w = bits;
    }
}

struct SampleSource<'a, T> {
    values: &'a [T],
    plane: usize,
}

impl<T: McSample> Source for SampleSource<'_, T> {
    type Plane = usize;
    fn new_plane(&self, _len: usize) -> usize {
        0
    }
    fn load(&self, k: usize, iso: Real, plane: &mut usize, bits: &mut [u64], nx: usize, words: usize) {
        *plane = k * self.plane;
        let vals = &self.values[*plane..*plane + self.plane];
        let threshold = T::threshold(iso);
        for (row, out) in vals.chunks_exact(nx).zip(bits.chunks_exact_mut(words)) {
            pack_row(row, threshold, out);
        }
    }
    #[inline]
    fn value(&self, plane: &usize, idx: usize) -> Real {
        self.values[plane + idx].into()
    }
}

struct FieldSource<F> {
    spec: GridSpec,
    field: F,
}

impl<F: Fn(&Point3) -> Real + Sync> Source for FieldSource<F> {
    type Plane = Vec<Real>;
    fn new_plane(&self, len: usize) -> Vec<Real> {
        vec![0.0; len]
    }
    fn load(&self, k: usize, iso: Real, plane: &mut Vec<Real>, bits: &mut [u64], nx: usize, words: usize) {
        for (j, row) in plane.chunks_exact_mut(nx).enumerate() {
            for (i, v) in row.iter_mut().enumerate() {
                *v = (self.field)(&self.spec.center(i, j, k));
            }
        }
        for (row, out) in plane.chunks_exact(nx).zip(bits.chunks_exact_mut(words)) {
            pack_row(row, iso, out);
        }
    }
    #[inline]
    fn value(&self, plane: &Vec<Real>, idx: usize) -> Real {
        plane[idx]
    }
}

struct VoxelSource<'a> {
    /// Voxel dims (the lattice is two larger on each axis).
    dims: [usize; 3],
    bdims: [usize; 3],
    bricks: Vec<&'a Brick>,
}

impl Source for VoxelSource<'_> {
    type Plane = ();
    fn new_plane(&self, _len: usize) {}
    fn load(&self, k: usize, _iso: Real, _plane: &mut (), bits: &mut [u64], _nx: usize, words: usize) {
        bits.fill(0);
        let d = self.dims;
        if k == 0 || k > d[2] {
            return;
        }
        let vz = k - 1;
        let (bz, wz) = (vz / BRICK, vz % BRICK);
        for vy in 0..d[1] {
            let (by, shift) = (vy / BRICK, BRICK * (vy % BRICK));
            let out = &mut bits[(vy + 1) * words..(vy + 2) * words];
            for bx in 0..self.bdims[0] {
                let brick = self.bricks[bx + self.bdims[0] * (by + self.bdims[1] * bz)];
                let byte = (brick[wz] >> shift) & 0xff;
                if byte != 0 {
                    // Lattice sample i + 1 is voxel i.
                    let pos = 1 + BRICK * bx;
                    out[pos / 64] |= byte << (pos % 64);
                    // Bits that spill past the last word are beyond the grid, hence clear.
                    if pos % 64 > 64 - BRICK && pos / 64 + 1 < words {
                        out[pos / 64 + 1] |= byte >> (64 - pos % 64);
                    }
                }
            }
        }
    }
    #[inline]
    fn value(&self, _plane: &(), _idx: usize) -> Real {
        0.0
    }
    #[inline]
    fn frac(&self, _: &(), _: usize, _: &(), _: usize, _: Real, _: Real) -> Real {
        0.5
    }
}

/// Vertex ids inside a slab: plain ids are the slab's own vertices, `FOREIGN` ids are
/// vertices of the slab's upper boundary plane (owned by the next slab, numbered as it
/// numbers them).
const FOREIGN: u32 = 1 << 31;
const LOCAL: u32 = FOREIGN - 1;

struct SlabOut {
    vertices: Vec<Point3>,
    triangles: Vec<[u32; 3]>,
    overflow: bool,
}

struct Geometry {
    dims: [usize; 3],
    words: usize,
    origin: Point3,
    spacing: Vector3,
    iso: Real,
    lo: Real,
}

impl Geometry {
    #[inline]
    fn point(&self, i: usize, j: usize, k: usize, axis: usize, t: Real) -> Point3 {
        let mut c = [i as Real, j as Real, k as Real];
        c[axis] += t;
        Point3::new(
            self.origin.x + c[0] * self.spacing.x,
            self.origin.y + c[1] * self.spacing.y,
            self.origin.z + c[2] * self.spacing.z,
        )
    }
}

/// Bit `i` of a row of words.
#[inline]
fn bit(row: &[u64], i: usize) -> u32 {
    ((row[i >> 6] >> (i & 63)) & 1) as u32
}

/// Word `w` of a row shifted down by one bit (bit `i` becomes sample `i + 1`).
#[inline]
fn shifted(row: &[u64], w: usize) -> u64 {
    let hi = if w + 1 < row.len() { row[w + 1] << 63 } else { 0 };
    (row[w] >> 1) | hi
}

/// Mask of valid bit positions `< n` in word `w`.
#[inline]
fn valid(w: usize, n: usize) -> u64 {
    let lo = w * 64;
    if n >= lo + 64 {
        u64::MAX
    } else if n <= lo {
        0
    } else {
        (1u64 << (n - lo)) - 1
    }
}

struct Ids {
    count: u32,
    foreign: u32,
    overflow: bool,
}

impl Ids {
    #[inline]
    fn own(&mut self) -> u32 {
        let id = self.count;
        if id >= LOCAL {
            self.overflow = true;
        } else {
            self.count += 1;
        }
        id
    }
    #[inline]
    fn foreign(&mut self) -> u32 {
        let id = self.foreign;
        if id >= LOCAL {
            self.overflow = true;
        } else {
            self.foreign += 1;
        }
        FOREIGN | id
    }
}

/// Vertices on the x and y edges of one plane; `foreign` numbers them without positions.
#[allow(clippy::too_many_arguments)] // The slab's state, passed piecewise to keep borrows apart.
fn plane_vertices<S: Source>(
    src: &S,
    g: &Geometry,
    k: usize,
    plane: &S::Plane,
    bits: &[u64],
    xe: &mut [u32],
    ye: &mut [u32],
    ids: &mut Ids,
    verts: &mut Vec<Point3>,
    foreign: bool,
) {
    let [nx, ny, _] = g.dims;
    let wn = g.words;
    for j in 0..ny {
        let row = &bits[j * wn..(j + 1) * wn];
        for w in 0..wn {
            let mut m = (row[w] ^ shifted(row, w)) & valid(w, nx - 1);
            while m != 0 {
                let i = w * 64 + m.trailing_zeros() as usize;
                m &= m - 1;
                let idx = i + nx * j;
                if foreign {
                    xe[idx] = ids.foreign();
                } else {
                    let t = src.frac(plane, idx, plane, idx + 1, g.iso, g.lo);
                    xe[idx] = ids.own();
                    verts.push(g.point(i, j, k, 0, t));
                }
            }
        }
        if j + 1 < ny {
            let up = &bits[(j + 1) * wn..(j + 2) * wn];
            for w in 0..wn {
                let mut m = (row[w] ^ up[w]) & valid(w, nx);
                while m != 0 {
                    let i = w * 64 + m.trailing_zeros() as usize;
                    m &= m - 1;
                    let idx = i + nx * j;
                    if foreign {
                        ye[idx] = ids.foreign();
                    } else {
                        let t = src.frac(plane, idx, plane, idx + nx, g.iso, g.lo);
                        ye[idx] = ids.own();
                        verts.push(g.point(i, j, k, 1, t));
                    }
                }
            }
        }
    }
}

/// Runs marching cubes over the whole lattice.
fn run<S: Source>(
    src: &S,
    dims: [usize; 3],
    origin: Point3,
    spacing: Vector3,
    iso: Real,
    opts: &McOptions,
) -> Result<Mesh> {
    opts.check()?;
    if !(origin.iter().all(|c| c.is_finite()) && spacing.iter().all(|c| c.is_finite() && *c != 0.0)) {
        return Err(GeomError::InvalidArgument(format!(
            "marching cubes needs a finite origin and finite, non-zero spacing, got {origin:?} and {spacing:?}"
        )));
    }
    if dims.iter().any(|&d| d < 2) {
        return Ok(Mesh::default());
    }
    // Per-plane caches are `dims[0] * dims[1]` long, indexed with u32-sized vertex ids.
    if dims[0].checked_mul(dims[1]).is_none_or(|n| n > u32::MAX as usize) {
        return Err(GeomError::InvalidArgument(format!("marching cubes lattice {dims:?} is too large")));
    }
    // A negative spacing on an odd number of axes mirrors the lattice, which would turn
    // the triangles' winding inside out.
    let mirrored = spacing.iter().filter(|c| **c < 0.0).count() % 2 == 1;
    let g = Geometry { dims, words: dims[0].div_ceil(64), origin, spacing, iso, lo: opts.min_edge_fraction };
    let layers = dims[2] - 1;
    let slab = opts.slab_layers.min(layers);
    let nslabs = layers.div_ceil(slab);
    let outs: Vec<SlabOut> = (0..nslabs)
        .into_par_iter()
        .map_init(
            || Scratch::new(src, &g),
            |scratch, s| {
                let k0 = s * slab;
                let k1 = (k0 + slab).min(layers);
                run_slab(src, &g, scratch, k0, k1)
            },
        )
        .collect();
    merge(outs, mirrored)
}

/// Per-worker buffers, reused from slab to slab.
struct Scratch<P> {
    planes: [P; 2],
    bits: [Vec<u64>; 2],
    xe: [Vec<u32>; 2],
    ye: [Vec<u32>; 2],
    ze: Vec<u32>,
    /// Output sizes of the last slab, to reserve the next one's.
    hint: (usize, usize),
}

impl<P> Scratch<P> {
    fn new<S: Source<Plane = P>>(src: &S, g: &Geometry) -> Self {
        let len = g.dims[0] * g.dims[1];
        let bits = g.dims[1] * g.words;
        Self {
            planes: [src.new_plane(len), src.new_plane(len)],
            bits: [vec![0; bits], vec![0; bits]],
            xe: [vec![0; len], vec![0; len]],
            ye: [vec![0; len], vec![0; len]],
            ze: vec![0; len],
            hint: (0, 0),
        }
    }
}

fn run_slab<S: Source>(
    src: &S,
    g: &Geometry,
    scratch: &mut Scratch<S::Plane>,
    k0: usize,
    k1: usize,
) -> SlabOut {
    let [nx, ny, nz] = g.dims;
    let wn = g.words;
    let table = &*TABLE;
    let Scratch { planes: [p0, p1], bits: [b0, b1], xe: [xe0, xe1], ye: [ye0, ye1], ze, hint } = scratch;
    let (mut p0, mut p1, mut b0, mut b1) = (p0, p1, b0, b1);
    let (mut xe0, mut xe1, mut ye0, mut ye1) = (xe0, xe1, ye0, ye1);
    let mut ids = Ids { count: 0, foreign: 0, overflow: false };
    let mut verts = Vec::with_capacity(hint.0 + hint.0 / 8);
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(hint.1 + hint.1 / 8);

    src.load(k0, g.iso, p0, b0, nx, wn);
    plane_vertices(src, g, k0, p0, b0, xe0, ye0, &mut ids, &mut verts, false);
    for k in k0..k1 {
        src.load(k + 1, g.iso, p1, b1, nx, wn);
        // Vertices on the z edges of this layer.
        for j in 0..ny {
            let (r0, r1) = (&b0[j * wn..(j + 1) * wn], &b1[j * wn..(j + 1) * wn]);
            for w in 0..wn {
                let mut m = (r0[w] ^ r1[w]) & valid(w, nx);
                while m != 0 {
                    let i = w * 64 + m.trailing_zeros() as usize;
                    m &= m - 1;
                    let idx = i + nx * j;
                    let t = src.frac(p0, idx, p1, idx, g.iso, g.lo);
                    ze[idx] = ids.own();
                    verts.push(g.point(i, j, k, 2, t));
                }
            }
        }
        // The upper plane belongs to the next slab unless this is the last one.
        let foreign = k + 1 == k1 && k1 < nz - 1;
        plane_vertices(src, g, k + 1, p1, b1, xe1, ye1, &mut ids, &mut verts, foreign);

        // Cells of this layer.
        for j in 0..ny - 1 {
            let ra = &b0[j * wn..(j + 1) * wn];
            let rb = &b0[(j + 1) * wn..(j + 2) * wn];
            let rc = &b1[j * wn..(j + 1) * wn];
            let rd = &b1[(j + 1) * wn..(j + 2) * wn];
            for w in 0..wn {
                let any = ra[w] | rb[w] | rc[w] | rd[w];
                let all = ra[w] & rb[w] & rc[w] & rd[w];
                let any1 = shifted(ra, w) | shifted(rb, w) | shifted(rc, w) | shifted(rd, w);
                let all1 = shifted(ra, w) & shifted(rb, w) & shifted(rc, w) & shifted(rd, w);
                let mut m = (any | any1) & !(all & all1) & valid(w, nx - 1);
                while m != 0 {
                    let i = w * 64 + m.trailing_zeros() as usize;
                    m &= m - 1;
                    let case = (bit(ra, i)
                        | bit(ra, i + 1) << 1
                        | bit(rb, i) << 2
                        | bit(rb, i + 1) << 3
                        | bit(rc, i) << 4
                        | bit(rc, i + 1) << 5
                        | bit(rd, i) << 6
                        | bit(rd, i + 1) << 7) as usize;
                    let mut vid = [0u32; 12];
                    let mut em = table.edge_mask[case];
                    while em != 0 {
                        let e = em.trailing_zeros() as usize;
                        em &= em - 1;
                        vid[e] = match e {
                            0 => xe0[i + nx * j],
                            1 => xe0[i + nx * (j + 1)],
                            2 => xe1[i + nx * j],
                            3 => xe1[i + nx * (j + 1)],
                            4 => ye0[i + nx * j],
                            5 => ye0[i + 1 + nx * j],
                            6 => ye1[i + nx * j],
                            7 => ye1[i + 1 + nx * j],
                            8 => ze[i + nx * j],
                            9 => ze[i + 1 + nx * j],
                            10 => ze[i + nx * (j + 1)],
                            _ => ze[i + 1 + nx * (j + 1)],
                        };
                    }
                    let (t0, t1) = (table.offsets[case] as usize, table.offsets[case + 1] as usize);
                    tris.extend(
                        table.tris[t0..t1]
                            .iter()
                            .map(|t| [vid[t[0] as usize], vid[t[1] as usize], vid[t[2] as usize]]),
                    );
                }
            }
        }
        std::mem::swap(&mut p0, &mut p1);
        std::mem::swap(&mut b0, &mut b1);
        std::mem::swap(&mut xe0, &mut xe1);
        std::mem::swap(&mut ye0, &mut ye1);
    }
    *hint = (verts.len(), tris.len());
    SlabOut { vertices: verts, triangles: tris, overflow: ids.overflow }
}

/// Concatenates slabs, resolving foreign ids.
fn merge(outs: Vec<SlabOut>, mirrored: bool) -> Result<Mesh> {
    let too_many = || GeomError::InvalidArgument("marching cubes output exceeds u32 vertex indices".into());
    if outs.iter().any(|o| o.overflow) {
        return Err(too_many());
    }
    let mut vbase = Vec::with_capacity(outs.len() + 1);
    let mut total = 0usize;
    for o in &outs {
        vbase.push(total);
        total += o.vertices.len();
    }
    vbase.push(total);
    if total > u32::MAX as usize {
        return Err(too_many());
    }
    let ntris: usize = outs.iter().map(|o| o.triangles.len()).sum();
    let mut vertices = Vec::with_capacity(total);
    for o in &outs {
        vertices.extend_from_slice(&o.vertices);
    }
    let mut triangles = Vec::with_capacity(ntris);
    for (s, o) in outs.iter().enumerate() {
        let map = |v: u32| -> u32 {
            if v & FOREIGN != 0 {
                (vbase[s + 1] + (v & !FOREIGN) as usize) as u32
            } else {
                (vbase[s] + v as usize) as u32
            }
        };
        if mirrored {
            triangles.extend(o.triangles.iter().map(|&[a, b, c]| [map(a), map(c), map(b)]));
        } else {
            triangles.extend(o.triangles.iter().map(|t| t.map(map)));
        }
    }
    Mesh::new(vertices, triangles)
}
