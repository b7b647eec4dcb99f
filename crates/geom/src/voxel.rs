//! [`VoxelGrid`]: bit-packed occupancy over an axis-aligned box, stored in 8x8x8 bricks.
//!
//! A brick is 512 bits (`[u64; 8]`), one word per z-slice of 8x8 voxels, bit
//! `x + 8 y` in word `z`. Bricks are stored densely in x-fastest order, so a
//! 256^3 grid takes 2 MiB and a 1024^3 grid 128 MiB. Bricks are the unit of
//! parallel work ([`VoxelGrid::par_bricks_mut`]).

use rayon::prelude::*;

use crate::aabb::Aabb;
use crate::error::{GeomError, Result};
use crate::math::{Point3, Real, Vector3};

/// Edge length of a brick in voxels.
pub const BRICK: usize = 8;

/// One 8x8x8 block of voxels: bit `x + 8 y` of word `z`.
pub type Brick = [u64; BRICK];

/// Where a grid sits in space: lower corner, voxel size per axis and voxel counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpec {
    /// Lower corner of voxel (0, 0, 0).
    pub origin: Point3,
    /// Edge length of a voxel along each axis.
    pub voxel: Vector3,
    /// Number of voxels along each axis.
    pub dims: [usize; 3],
}

impl GridSpec {
    /// `dims` voxels spanning `bounds` exactly.
    pub fn new(bounds: &Aabb, dims: [usize; 3]) -> Result<Self> {
        if !bounds.is_valid() || dims.contains(&0) {
            return Err(GeomError::InvalidArgument(format!(
                "voxel grid needs a valid box and non-zero dimensions, got {bounds:?} and {dims:?}"
            )));
        }
        let e = bounds.extent();
        if (0..3).any(|i| e[i] <= 0.0) {
            return Err(GeomError::InvalidArgument("voxel grid box has zero extent".into()));
        }
        let voxel = Vector3::new(e.x / dims[0] as Real, e.y / dims[1] as Real, e.z / dims[2] as Real);
        Ok(Self { origin: bounds.min, voxel, dims })
    }

    /// Cubic voxels: `n` voxels along the box's longest axis, and as many of the same
    /// size as cover each other axis (the box is grown symmetrically to a whole number).
    pub fn cubic(bounds: &Aabb, n: usize) -> Result<Self> {
        if !bounds.is_valid() || n == 0 {
            return Err(GeomError::InvalidArgument(format!(
                "cubic grid needs a valid box and n > 0, got {bounds:?}, {n}"
            )));
        }
        let e = bounds.extent();
        let h = e.max() / n as Real;
        if h <= 0.0 {
            return Err(GeomError::InvalidArgument("voxel grid box has zero extent".into()));
        }
        let mut dims = [0; 3];
        let mut origin = bounds.min;
        for i in 0..3 {
            dims[i] = ((e[i] / h - 1e-9).ceil() as usize).max(1);
            origin[i] -= 0.5 * (dims[i] as Real * h - e[i]);
        }
        Ok(Self { origin, voxel: Vector3::repeat(h), dims })
    }

    /// The box the grid covers.
    pub fn bounds(&self) -> Aabb {
        let d = Vector3::new(self.dims[0] as Real, self.dims[1] as Real, self.dims[2] as Real);
        Aabb::new(self.origin, self.origin + self.voxel.component_mul(&d))
    }

    /// Total number of voxels.
    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Whether the grid has no voxel (never true for a constructed spec).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Volume of one voxel.
    pub fn voxel_volume(&self) -> Real {
        self.voxel.product()
    }

    /// Centre of voxel `(i, j, k)`.
    #[inline]
    pub fn center(&self, i: usize, j: usize, k: usize) -> Point3 {
        Point3::new(
            self.origin.x + (i as Real + 0.5) * self.voxel.x,
            self.origin.y + (j as Real + 0.5) * self.voxel.y,
            self.origin.z + (k as Real + 0.5) * self.voxel.z,
        )
    }

    /// The voxel containing `p`, `None` outside the grid.
    #[inline]
    pub fn index_of(&self, p: &Point3) -> Option<[usize; 3]> {
        let mut out = [0; 3];
        for a in 0..3 {
            let f = ((p[a] - self.origin[a]) / self.voxel[a]).floor();
            if !(f >= 0.0 && f < self.dims[a] as Real) {
                return None;
            }
            out[a] = f as usize;
        }
        Some(out)
    }

    /// Continuous voxel coordinate of `p` along axis `a` (voxel `i` spans `[i, i + 1)`).
    #[inline]
    pub fn coord(&self, p: &Point3, a: usize) -> Real {
        (p[a] - self.origin[a]) / self.voxel[a]
    }

    /// The inclusive index range of voxels whose centres may lie in `[lo, hi]` along
    /// axis `a`, clamped to the grid; `None` when empty.
    #[inline]
    pub fn center_range(&self, lo: Real, hi: Real, a: usize) -> Option<(usize, usize)> {
        let first = ceil((lo - self.origin[a]) / self.voxel[a] - 0.5).max(0.0);
        let last = floor((hi - self.origin[a]) / self.voxel[a] - 0.5).min(self.dims[a] as Real - 1.0);
        (first <= last).then_some((first as usize, last as usize))
    }

    /// Number of bricks along each axis.
    pub fn brick_dims(&self) -> [usize; 3] {
        self.dims.map(|d| d.div_ceil(BRICK))
    }
}

/// `x.floor()` without a libm call (x86-64 without SSE4.1 has no rounding instruction,
/// and voxel range queries are hot); exact for every `f64`, NaN and infinities included.
#[inline]
fn floor(x: Real) -> Real {
    if x.abs() < 4503599627370496.0 {
        let t = x as i64 as Real;
        if t > x { t - 1.0 } else { t }
    } else {
        x
    }
}

/// `x.ceil()` without a libm call; see [`floor`].
#[inline]
fn ceil(x: Real) -> Real {
    -floor(-x)
}

/// A bit-packed occupancy grid (see the module docs for the layout).
#[derive(Clone, PartialEq)]
pub struct VoxelGrid {
    spec: GridSpec,
    bdims: [usize; 3],
    bricks: Vec<Brick>,
}

impl std::fmt::Debug for VoxelGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VoxelGrid").field("spec", &self.spec).field("count", &self.count()).finish()
    }
}

impl VoxelGrid {
    /// An empty (all clear) grid.
    pub fn new(spec: GridSpec) -> Self {
        let bdims = spec.brick_dims();
        Self { spec, bdims, bricks: vec![[0; BRICK]; bdims.iter().product()] }
    }

    /// A grid with every voxel set.
    pub fn full(spec: GridSpec) -> Self {
        let mut g = Self::new(spec);
        g.fill(true);
        g
    }

    /// Where the grid sits.
    pub fn spec(&self) -> &GridSpec {
        &self.spec
    }

    /// Voxel counts per axis.
    pub fn dims(&self) -> [usize; 3] {
        self.spec.dims
    }

    /// Brick counts per axis.
    pub fn brick_dims(&self) -> [usize; 3] {
        self.bdims
    }

    /// Bytes of voxel storage.
    pub fn heap_bytes(&self) -> usize {
        self.bricks.len() * std::mem::size_of::<Brick>()
    }

    /// Index into `bricks` of brick `(bx, by, bz)`.
    #[inline]
    fn brick_index(&self, bx: usize, by: usize, bz: usize) -> usize {
        bx + self.bdims[0] * (by + self.bdims[1] * bz)
    }

    #[inline]
    fn locate(&self, i: usize, j: usize, k: usize) -> (usize, usize, u64) {
        let b = self.brick_index(i / BRICK, j / BRICK, k / BRICK);
        let bit = (i % BRICK) + BRICK * (j % BRICK);
        (b, k % BRICK, 1u64 << bit)
    }

    /// Whether voxel `(i, j, k)` is set; `false` outside the grid.
    #[inline]
    pub fn get(&self, i: usize, j: usize, k: usize) -> bool {
        let d = self.spec.dims;
        if i >= d[0] || j >= d[1] || k >= d[2] {
            return false;
        }
        let (b, w, m) = self.locate(i, j, k);
        self.bricks[b][w] & m != 0
    }

    /// Whether any voxel with indices in `lo..=hi` (per axis; clamped to the grid) is set.
    /// Works a brick at a time with word masks, so a large empty box costs one look per
    /// brick word rather than one per voxel.
    pub fn any_in_range(&self, lo: [usize; 3], hi: [usize; 3]) -> bool {
        let d = self.spec.dims;
        if d.contains(&0) {
            return false;
        }
        let hi = [hi[0].min(d[0] - 1), hi[1].min(d[1] - 1), hi[2].min(d[2] - 1)];
        if (0..3).any(|a| lo[a] > hi[a]) {
            return false;
        }
        // Within-brick index range of axis `a` in brick `b`.
        let span = |a: usize, b: usize| {
            let base = b * BRICK;
            (lo[a].max(base) - base, hi[a].min(base + BRICK - 1) - base)
        };
        for bz in lo[2] / BRICK..=hi[2] / BRICK {
            let (z0, z1) = span(2, bz);
            for by in lo[1] / BRICK..=hi[1] / BRICK {
                let (y0, y1) = span(1, by);
                for bx in lo[0] / BRICK..=hi[0] / BRICK {
                    let (x0, x1) = span(0, bx);
                    let brick = &self.bricks[self.brick_index(bx, by, bz)];
                    let row = (0xffu64 >> (BRICK - 1 - (x1 - x0))) << x0;
                    let mask = (y0..=y1).fold(0u64, |m, y| m | row << (BRICK * y));
                    if brick[z0..=z1].iter().any(|&w| w & mask != 0) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Sets or clears voxel `(i, j, k)`; ignored outside the grid.
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, k: usize, value: bool) {
        let d = self.spec.dims;
        if i >= d[0] || j >= d[1] || k >= d[2] {
            return;
        }
        let (b, w, m) = self.locate(i, j, k);
        if value {
            self.bricks[b][w] |= m;
        } else {
            self.bricks[b][w] &= !m;
        }
    }

    /// Mask of the bits of brick `(bx, by, bz)` that lie inside the grid, per word.
    fn brick_mask(&self, bx: usize, by: usize, bz: usize) -> Brick {
        let d = self.spec.dims;
        let nx = (d[0] - bx * BRICK).min(BRICK);
        let ny = (d[1] - by * BRICK).min(BRICK);
        let nz = (d[2] - bz * BRICK).min(BRICK);
        let row = if nx == BRICK { 0xff } else { (1u64 << nx) - 1 };
        let mut slice = 0u64;
        for y in 0..ny {
            slice |= row << (BRICK * y);
        }
        let mut out = [0; BRICK];
        for w in out.iter_mut().take(nz) {
            *w = slice;
        }
        out
    }

    /// Sets every voxel to `value`.
    pub fn fill(&mut self, value: bool) {
        let [bx, by, _] = self.bdims;
        let masks: Vec<Brick> = (0..self.bricks.len())
            .map(|b| if value { self.brick_mask(b % bx, (b / bx) % by, b / (bx * by)) } else { [0; BRICK] })
            .collect();
        self.bricks = masks;
    }

    /// Number of set voxels.
    pub fn count(&self) -> u64 {
        self.bricks.par_iter().map(|b| b.iter().map(|w| w.count_ones() as u64).sum::<u64>()).sum()
    }

    /// Volume of the set voxels.
    pub fn volume(&self) -> Real {
        self.count() as Real * self.spec.voxel_volume()
    }

    fn zip_with(&mut self, other: &VoxelGrid, f: impl Fn(u64, u64) -> u64 + Sync) -> Result<()> {
        if self.spec != other.spec {
            return Err(GeomError::GridMismatch);
        }
        self.bricks.par_iter_mut().zip(other.bricks.par_iter()).for_each(|(a, b)| {
            for w in 0..BRICK {
                a[w] = f(a[w], b[w]);
            }
        });
        Ok(())
    }

    /// `self |= other`.
    pub fn or(&mut self, other: &VoxelGrid) -> Result<()> {
        self.zip_with(other, |a, b| a | b)
    }

    /// `self &= other`.
    pub fn and(&mut self, other: &VoxelGrid) -> Result<()> {
        self.zip_with(other, |a, b| a & b)
    }

    /// `self &= !other`.
    pub fn andnot(&mut self, other: &VoxelGrid) -> Result<()> {
        self.zip_with(other, |a, b| a & !b)
    }

    /// `self ^= other`.
    pub fn xor(&mut self, other: &VoxelGrid) -> Result<()> {
        self.zip_with(other, |a, b| a ^ b)
    }

    /// Number of voxels set in both grids.
    pub fn count_and(&self, other: &VoxelGrid) -> Result<u64> {
        if self.spec != other.spec {
            return Err(GeomError::GridMismatch);
        }
        Ok(self
            .bricks
            .par_iter()
            .zip(other.bricks.par_iter())
            .map(|(a, b)| (0..BRICK).map(|w| (a[w] & b[w]).count_ones() as u64).sum::<u64>())
            .sum())
    }

    /// Flips every voxel inside the grid.
    pub fn invert(&mut self) {
        let [bx, by, _] = self.bdims;
        let masks: Vec<Brick> =
            (0..self.bricks.len()).map(|b| self.brick_mask(b % bx, (b / bx) % by, b / (bx * by))).collect();
        for (brick, mask) in self.bricks.iter_mut().zip(masks) {
            for w in 0..BRICK {
                brick[w] = !brick[w] & mask[w];
            }
        }
    }

    /// The indices of set voxels, brick by brick.
    pub fn iter_set(&self) -> impl Iterator<Item = [usize; 3]> + '_ {
        let [bx, by, _] = self.bdims;
        self.bricks.iter().enumerate().flat_map(move |(b, brick)| {
            let base = [(b % bx) * BRICK, ((b / bx) % by) * BRICK, (b / (bx * by)) * BRICK];
            brick.iter().enumerate().flat_map(move |(z, &word)| {
                BitIter(word).map(move |bit| [base[0] + bit % BRICK, base[1] + bit / BRICK, base[2] + z])
            })
        })
    }

    /// The bricks with the voxel index of their lower corner, for parallel edits.
    /// Bits that fall outside the grid (in the last, partial bricks) must stay clear.
    pub fn par_bricks_mut(&mut self) -> impl IndexedParallelIterator<Item = ([usize; 3], &mut Brick)> {
        let [bx, by, _] = self.bdims;
        self.bricks.par_iter_mut().enumerate().map(move |(b, brick)| {
            ([(b % bx) * BRICK, ((b / bx) % by) * BRICK, (b / (bx * by)) * BRICK], brick)
        })
    }

    /// The bricks with the voxel index of their lower corner.
    pub fn bricks(&self) -> impl ExactSizeIterator<Item = ([usize; 3], &Brick)> {
        let [bx, by, _] = self.bdims;
        self.bricks.iter().enumerate().map(move |(b, brick)| {
            ([(b % bx) * BRICK, ((b / bx) % by) * BRICK, (b / (bx * by)) * BRICK], brick)
        })
    }

    /// Sets every voxel whose centre satisfies `inside`, in parallel over bricks.
    pub fn set_where(&mut self, inside: impl Fn(&Point3) -> bool + Sync) {
        let spec = self.spec;
        let d = spec.dims;
        self.par_bricks_mut().for_each(|(base, brick)| {
            for (z, slab) in brick.iter_mut().enumerate().take(BRICK.min(d[2] - base[2])) {
                for y in 0..BRICK.min(d[1] - base[1]) {
                    for x in 0..BRICK.min(d[0] - base[0]) {
                        if inside(&spec.center(base[0] + x, base[1] + y, base[2] + z)) {
                            *slab |= 1u64 << (x + BRICK * y);
                        }
                    }
                }
            }
        });
    }
}

/// Iterates the set bit positions of a word.
struct BitIter(u64);

impl Iterator for BitIter {
    type Item = usize;
    #[inline]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let t = self.0.trailing_zeros() as usize;
        self.0 &= self.0 - 1;
        Some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(n: [usize; 3]) -> GridSpec {
        GridSpec::new(&Aabb::new(Point3::origin(), Point3::new(n[0] as Real, n[1] as Real, n[2] as Real)), n)
            .unwrap()
    }

    #[test]
    fn get_set_count_and_partial_bricks() {
        let mut g = VoxelGrid::new(spec([13, 9, 17]));
        assert_eq!(g.count(), 0);
        g.set(12, 8, 16, true);
        g.set(0, 0, 0, true);
        g.set(13, 0, 0, true); // outside: ignored
        assert!(g.get(12, 8, 16) && g.get(0, 0, 0) && !g.get(1, 0, 0));
        assert_eq!(g.count(), 2);
        assert_eq!(g.iter_set().collect::<Vec<_>>(), vec![[0, 0, 0], [12, 8, 16]]);
        g.fill(true);
        assert_eq!(g.count(), 13 * 9 * 17);
        g.invert();
        assert_eq!(g.count(), 0);
    }

    #[test]
    fn boolean_ops_match_counts() {
        let s = spec([20, 20, 20]);
        let mut a = VoxelGrid::new(s);
        a.set_where(|p| p.x < 10.0);
        let mut b = VoxelGrid::new(s);
        b.set_where(|p| p.y < 5.0);
        assert_eq!(a.count(), 4000);
        assert_eq!(a.count_and(&b).unwrap(), 1000);
        let mut u = a.clone();
        u.or(&b).unwrap();
        assert_eq!(u.count(), 4000 + 2000 - 1000);
        let mut d = a.clone();
        d.andnot(&b).unwrap();
        assert_eq!(d.count(), 3000);
        let mut x = a.clone();
        x.xor(&b).unwrap();
        assert_eq!(x.count(), 4000);
        assert!(a.or(&VoxelGrid::new(spec([8, 8, 8]))).is_err());
    }

    #[test]
    fn index_and_center_round_trip() {
        let s = GridSpec::cubic(&Aabb::unit_cube(), 256).unwrap();
        assert_eq!(s.dims, [256; 3]);
        for &(i, j, k) in &[(0, 0, 0), (255, 17, 128), (3, 255, 254)] {
            assert_eq!(s.index_of(&s.center(i, j, k)), Some([i, j, k]));
        }
        assert_eq!(s.center_range(-0.5, 0.5, 0), Some((0, 255)));
        assert_eq!(s.center_range(0.6, 0.7, 0), None);
    }

    #[test]
    fn a_1024_cube_fits_in_128_mib() {
        let s = GridSpec::cubic(&Aabb::unit_cube(), 1024).unwrap();
        let g = VoxelGrid::new(s);
        assert_eq!(g.heap_bytes(), 128 << 20);
    }

    #[test]
    fn any_in_range_agrees_with_a_voxel_loop() {
        use rand::{RngExt, SeedableRng, rngs::StdRng};
        let mut rng = StdRng::seed_from_u64(5);
        let n = [21, 14, 19];
        let mut g = VoxelGrid::new(spec(n));
        for _ in 0..12 {
            g.set(rng.random_range(0..n[0]), rng.random_range(0..n[1]), rng.random_range(0..n[2]), true);
        }
        let (mut hits, mut cases) = (0, 0);
        for _ in 0..3000 {
            let mut lo = [0; 3];
            let mut hi = [0; 3];
            for a in 0..3 {
                let (x, y) = (rng.random_range(0..n[a] + 3), rng.random_range(0..n[a] + 3));
                (lo[a], hi[a]) = (x.min(y), x.max(y));
            }
            let want =
                (lo[2]..=hi[2]).any(|k| (lo[1]..=hi[1]).any(|j| (lo[0]..=hi[0]).any(|i| g.get(i, j, k))));
            assert_eq!(g.any_in_range(lo, hi), want, "{lo:?}..={hi:?}");
            hits += usize::from(want);
            cases += 1;
        }
        assert!(hits > 300 && hits < cases - 300, "both answers are exercised: {hits} of {cases}");
        assert!(!g.any_in_range([5, 0, 0], [4, 13, 18]), "an empty range");
    }

    #[test]
    fn floor_and_ceil_match_the_std_ones() {
        let cases =
            [0.0, -0.0, 0.5, -0.5, 1.0, -1.0, 2.5, -2.5, 1e15 + 0.5, -1e15 - 0.5, 4503599627370497.0, 1e300];
        for x in cases.into_iter().chain([
            Real::INFINITY,
            Real::NEG_INFINITY,
            Real::MIN_POSITIVE,
            -Real::MIN_POSITIVE,
        ]) {
            assert_eq!(floor(x), x.floor(), "floor {x}");
            assert_eq!(ceil(x), x.ceil(), "ceil {x}");
        }
        assert!(floor(Real::NAN).is_nan() && ceil(Real::NAN).is_nan());
    }
}
