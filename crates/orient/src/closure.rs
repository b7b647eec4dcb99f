//! Visibility-based reconstruction (seed 000 §3.2): for a setup, the part with every
//! region the tool cannot see from its side filled, i.e. the *height closure* along the
//! setup's tool axis.
//!
//! A point is in the closure iff it is inside the part or there is part material above
//! it along the tool axis (it is occluded from the tool), and it is not below the part's
//! lowest point along that axis (there the fixture is; nothing is machined). For a closed
//! mesh that is the region below the top-most surface crossing of each line parallel to
//! the tool axis, down to the part's lowest height,
//! so the closure is computed from a **height map**: the mesh's triangles are
//! rasterised (z-buffer, keeping the maximum height) into a 2-D grid perpendicular to
//! the tool axis, exactly and in `O(triangles + texels)`, without ray casts.
//!
//! - Tool axis along a grid axis (±X, ±Y, ±Z): the height map's texels are the voxel
//!   columns themselves, so the closure is exact at voxel centres (a height field from
//!   that side reproduces its own voxelisation).
//! - Any other axis: the height map lies in the setup frame with texels of a third of the
//!   smallest voxel edge, and each voxel centre looks up the texel it falls in (error at
//!   most one texel sideways at walls parallel to the axis).
//!
//! In both cases the part's own voxelisation is added, so the closure always contains
//! the part even where rasterisation and voxelisation round differently.

use s2g_geom::{
    GridSpec, Mesh, Point3, Real, Setup, Vector3, VoxelGrid, laplacian_smooth, marching_cubes_voxels,
    voxelize,
};

use crate::error::{OrientError, Result};

/// Texels per voxel edge of the height map for tool axes off the grid axes: the nearest
/// texel is at most half a texel (a sixth of a voxel) away from a voxel centre.
const GENERAL_TEXELS_PER_VOXEL: Real = 3.0;

/// Largest height map we allocate (texels), a guard against absurd cell sizes.
const MAX_TEXELS: usize = 1 << 28;

/// The top-most surface height of a mesh over a 2-D grid perpendicular to a direction.
///
/// Coordinates: `q = rows . p + shift` maps a part-frame point `p` to `(u, v, w)`, where
/// `w` is the height along the tool axis and `(u, v)` the position in the grid's plane.
#[derive(Debug, Clone, PartialEq)]
pub struct HeightMap {
    rows: [Vector3; 3],
    shift: Vector3,
    origin: [Real; 2],
    cell: [Real; 2],
    dims: [usize; 2],
    heights: Vec<Real>,
    lowest: Real,
}

impl HeightMap {
    /// The height map of `mesh` in the setup frame of `setup` (`u, v, w` = setup `x, y,
    /// z`), with square texels of edge `cell`, covering the mesh's footprint plus one texel.
    /// Errors: empty mesh, non-positive cell, more than 2^28 texels.
    pub fn in_setup_frame(mesh: &Mesh, setup: &Setup, cell: Real) -> Result<Self> {
        if mesh.is_empty() {
            return Err(OrientError::NoSurface("the mesh has no triangles".into()));
        }
        if !(cell.is_finite() && cell > 0.0) {
            return Err(OrientError::InvalidArgument(format!("height-map cell must be > 0, got {cell}")));
        }
        let (rows, shift) = setup_rows(setup);
        let (lo, hi) = footprint(mesh.vertices().iter(), &rows, &shift);
        let origin = [lo[0] - cell, lo[1] - cell];
        let dims = [
            (((hi[0] - origin[0]) / cell).ceil() as usize + 1).max(1),
            (((hi[1] - origin[1]) / cell).ceil() as usize + 1).max(1),
        ];
        Self::rasterize(mesh, rows, shift, origin, [cell; 2], dims)
    }

    fn rasterize(
        mesh: &Mesh,
        rows: [Vector3; 3],
        shift: Vector3,
        origin: [Real; 2],
        cell: [Real; 2],
        dims: [usize; 2],
    ) -> Result<Self> {
        let texels = dims[0].checked_mul(dims[1]).filter(|&n| n <= MAX_TEXELS).ok_or_else(|| {
            OrientError::InvalidArgument(format!("height map of {dims:?} texels is too large"))
        })?;
        let mut heights = vec![Real::NEG_INFINITY; texels];
        let q: Vec<Vector3> = mesh.vertices().iter().map(|p| map(&rows, &shift, p)).collect();
        let lowest = q.iter().map(|p| p.z).fold(Real::INFINITY, Real::min);
        for tri in mesh.triangles() {
            let [a, b, c] = tri.map(|i| q[i as usize]);
            let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
            // Triangles seen edge-on add nothing that their neighbours do not.
            let scale = (b - a).xy().norm_squared().max((c - a).xy().norm_squared());
            if area.abs().partial_cmp(&(1e-14 * scale)) != Some(std::cmp::Ordering::Greater) {
                continue;
            }
            let tol = 1e-9 * area.abs();
            let range = |k: usize| {
                let lo = a[k].min(b[k]).min(c[k]);
                let hi = a[k].max(b[k]).max(c[k]);
                let first = ((lo - origin[k]) / cell[k] - 0.5).ceil().max(0.0);
                let last = ((hi - origin[k]) / cell[k] - 0.5).floor().min(dims[k] as Real - 1.0);
                (first <= last).then_some((first as usize, last as usize))
            };
            let (Some((i0, i1)), Some((j0, j1))) = (range(0), range(1)) else { continue };
            for j in j0..=j1 {
                let y = origin[1] + (j as Real + 0.5) * cell[1];
                for i in i0..=i1 {
                    let x = origin[0] + (i as Real + 0.5) * cell[0];
                    // Edge functions, normalised so that they sum to 1 (barycentrics).
                    let l0 = (b.x - x) * (c.y - y) - (b.y - y) * (c.x - x);
                    let l1 = (c.x - x) * (a.y - y) - (c.y - y) * (a.x - x);
                    let l2 = area - l0 - l1;
                    let inside = if area > 0.0 {
                        l0 >= -tol && l1 >= -tol && l2 >= -tol
                    } else {
                        l0 <= tol && l1 <= tol && l2 <= tol
                    };
                    if inside {
                        let h = (l0 * a.z + l1 * b.z + l2 * c.z) / area;
                        let t = &mut heights[i + dims[0] * j];
                        if h > *t {
                            *t = h;
                        }
                    }
                }
            }
        }
        Ok(Self { rows, shift, origin, cell, dims, heights, lowest })
    }

    /// Texel counts `(u, v)`.
    pub fn dims(&self) -> [usize; 2] {
        self.dims
    }

    /// Texel edge lengths `(u, v)`.
    pub fn cell(&self) -> [Real; 2] {
        self.cell
    }

    /// Lower corner of texel `(0, 0)` in `(u, v)`.
    pub fn origin(&self) -> [Real; 2] {
        self.origin
    }

    /// Height of the top-most surface over texel `(i, j)`; `None` where the column misses
    /// the part or outside the map.
    pub fn height(&self, i: usize, j: usize) -> Option<Real> {
        if i >= self.dims[0] || j >= self.dims[1] {
            return None;
        }
        let h = self.heights[i + self.dims[0] * j];
        h.is_finite().then_some(h)
    }

    /// Height over the texel containing `(u, v)`.
    pub fn height_at(&self, u: Real, v: Real) -> Option<Real> {
        let i = ((u - self.origin[0]) / self.cell[0]).floor();
        let j = ((v - self.origin[1]) / self.cell[1]).floor();
        if !(i >= 0.0 && j >= 0.0) {
            return None;
        }
        self.height(i as usize, j as usize)
    }

    /// Maps a part-frame point to `(u, v, w)`.
    pub fn to_map(&self, p: &Point3) -> Vector3 {
        map(&self.rows, &self.shift, p)
    }

    /// The part's lowest height `w` (the closure's floor).
    pub fn lowest(&self) -> Real {
        self.lowest
    }

    /// Whether a part-frame point is in the closure: at or below the top-most surface over
    /// it and not below the part's lowest height, with tolerance `tol` in height.
    pub fn occluded(&self, p: &Point3, tol: Real) -> bool {
        let q = self.to_map(p);
        q.z >= self.lowest - tol && self.height_at(q.x, q.y).is_some_and(|h| q.z <= h + tol)
    }

    /// The closure's cross-section at height `w`: texels whose top-most surface is at or
    /// above `w` (in the setup frame for [`HeightMap::in_setup_frame`]); empty below the
    /// part's lowest height.
    pub fn section(&self, w: Real) -> Section {
        let mut bits = vec![0u64; (self.dims[0] * self.dims[1]).div_ceil(64)];
        for (t, &h) in self.heights.iter().enumerate() {
            if h >= w && w >= self.lowest {
                bits[t / 64] |= 1 << (t % 64);
            }
        }
        Section { origin: self.origin, cell: self.cell, dims: self.dims, bits }
    }
}

/// A 2-D occupancy bitmap: a cross-section of a closure at one height. Cell `(i, j)`
/// spans `origin + [i, i + 1) x [j, j + 1)` cells; bit `i + dims[0] j`.
#[derive(Debug, Clone, PartialEq)]
pub struct Section {
    /// Lower corner of cell `(0, 0)`.
    pub origin: [Real; 2],
    /// Cell edge lengths.
    pub cell: [Real; 2],
    /// Cell counts.
    pub dims: [usize; 2],
    bits: Vec<u64>,
}

impl Section {
    /// Whether cell `(i, j)` is occupied (`false` outside).
    pub fn get(&self, i: usize, j: usize) -> bool {
        if i >= self.dims[0] || j >= self.dims[1] {
            return false;
        }
        let t = i + self.dims[0] * j;
        self.bits[t / 64] >> (t % 64) & 1 == 1
    }

    /// Number of occupied cells.
    pub fn count(&self) -> usize {
        self.bits.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Occupied area.
    pub fn area(&self) -> Real {
        self.count() as Real * self.cell[0] * self.cell[1]
    }

    /// Centre of cell `(i, j)`.
    pub fn center(&self, i: usize, j: usize) -> [Real; 2] {
        [self.origin[0] + (i as Real + 0.5) * self.cell[0], self.origin[1] + (j as Real + 0.5) * self.cell[1]]
    }
}

/// The setup's part-to-setup map as rows and shift: `to_setup(p) = rows . p + shift`.
fn setup_rows(setup: &Setup) -> ([Vector3; 3], Vector3) {
    let r = setup.frame.rotation.to_rotation_matrix();
    let m = r.matrix().transpose();
    let rows = [m.row(0).transpose(), m.row(1).transpose(), m.row(2).transpose()];
    let shift = -(m * setup.frame.translation.vector);
    (rows, shift)
}

#[inline]
fn map(rows: &[Vector3; 3], shift: &Vector3, p: &Point3) -> Vector3 {
    Vector3::new(rows[0].dot(&p.coords), rows[1].dot(&p.coords), rows[2].dot(&p.coords)) + shift
}

/// `(u, v)` bounds of points under the map.
fn footprint<'a>(
    points: impl Iterator<Item = &'a Point3>,
    rows: &[Vector3; 3],
    shift: &Vector3,
) -> ([Real; 2], [Real; 2]) {
    let mut lo = [Real::INFINITY; 2];
    let mut hi = [Real::NEG_INFINITY; 2];
    for p in points {
        let q = map(rows, shift, p);
        for k in 0..2 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    (lo, hi)
}

/// The height map used for a closure on `spec`: voxel columns when the tool axis is a
/// grid axis, else the setup frame with texels of a third of the smallest voxel edge
/// over the grid's footprint.
fn closure_map(mesh: &Mesh, setup: &Setup, spec: &GridSpec) -> Result<HeightMap> {
    let axis = setup.tool_axis();
    if let Some(a) = (0..3).find(|&a| axis[a].abs() > 1.0 - 1e-12) {
        let (b, c) = match a {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let e = |k: usize| Vector3::ith(k, 1.0);
        let rows = [e(b), e(c), e(a) * axis[a].signum()];
        return HeightMap::rasterize(
            mesh,
            rows,
            Vector3::zeros(),
            [spec.origin[b], spec.origin[c]],
            [spec.voxel[b], spec.voxel[c]],
            [spec.dims[b], spec.dims[c]],
        );
    }
    let cell = spec.voxel.min() / GENERAL_TEXELS_PER_VOXEL;
    let (rows, shift) = setup_rows(setup);
    let b = spec.bounds();
    let corners: Vec<Point3> = (0..8)
        .map(|k| {
            Point3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            )
        })
        .collect();
    let (lo, hi) = footprint(corners.iter(), &rows, &shift);
    let dims = [
        (((hi[0] - lo[0]) / cell).ceil() as usize).max(1),
        (((hi[1] - lo[1]) / cell).ceil() as usize).max(1),
    ];
    HeightMap::rasterize(mesh, rows, shift, lo, [cell; 2], dims)
}

/// The height map's closure alone (without the part's voxelisation) on `spec`.
fn map_closure(map: &HeightMap, spec: &GridSpec) -> VoxelGrid {
    let tol = 1e-9 * spec.bounds().extent().norm();
    let mut g = VoxelGrid::new(*spec);
    g.set_where(|c| map.occluded(c, tol));
    g
}

/// The height closure of `mesh` for `setup` on the part-frame grid `spec` (see the
/// module docs for the method): a voxel is set iff its centre is inside the part, or
/// below the part's top-most surface along the setup's tool axis and not below the
/// part's lowest point along it.
///
/// Errors: an empty mesh, or voxelisation failing.
pub fn height_closure(mesh: &Mesh, setup: &Setup, spec: &GridSpec) -> Result<VoxelGrid> {
    if mesh.is_empty() {
        return Err(OrientError::NoSurface("the mesh has no triangles".into()));
    }
    let map = closure_map(mesh, setup, spec)?;
    let mut g = map_closure(&map, spec);
    g.or(&voxelize(mesh, spec)?)?;
    Ok(g)
}

/// The cross-section of the closure of `mesh` for `setup` at height `z` in the setup
/// frame, on square cells of edge `cell` (setup-frame `x, y`). For many heights, build
/// [`HeightMap::in_setup_frame`] once and call [`HeightMap::section`].
pub fn closure_section(mesh: &Mesh, setup: &Setup, z: Real, cell: Real) -> Result<Section> {
    Ok(HeightMap::in_setup_frame(mesh, setup, cell)?.section(z))
}

/// Settings of the smooth reconstructed mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReconstructOptions {
    /// Laplacian smoothing iterations after marching cubes. Default `10`.
    pub smooth_iterations: usize,
    /// Laplacian step (0 < lambda <= 1). Default `0.5`.
    pub smooth_lambda: Real,
}

impl Default for ReconstructOptions {
    fn default() -> Self {
        Self { smooth_iterations: 10, smooth_lambda: 0.5 }
    }
}

/// A setup's reconstruction: the closure as voxels and as a smooth mesh.
#[derive(Debug, Clone)]
pub struct Reconstruction {
    /// The height closure on the part-frame grid.
    pub grid: VoxelGrid,
    /// Marching cubes of `grid`, then Laplacian smoothing (part frame).
    pub mesh: Mesh,
}

/// The smooth mesh of a closure grid: marching cubes, then Laplacian smoothing.
pub fn closure_mesh(grid: &VoxelGrid, opts: &ReconstructOptions) -> Result<Mesh> {
    if !(opts.smooth_lambda > 0.0 && opts.smooth_lambda <= 1.0) {
        return Err(OrientError::InvalidArgument(format!(
            "smoothing lambda must be in (0, 1], got {}",
            opts.smooth_lambda
        )));
    }
    let mc = marching_cubes_voxels(grid)?;
    Ok(laplacian_smooth(&mc, opts.smooth_iterations, opts.smooth_lambda)?)
}

/// Seed 000 §3.2 for one setup: [`height_closure`] and [`closure_mesh`].
pub fn reconstruct(
    mesh: &Mesh,
    setup: &Setup,
    spec: &GridSpec,
    opts: &ReconstructOptions,
) -> Result<Reconstruction> {
    let grid = height_closure(mesh, setup, spec)?;
    let mesh = closure_mesh(&grid, opts)?;
    Ok(Reconstruction { grid, mesh })
}

#[cfg(test)]
mod tests {
    use super::*;
    use s2g_geom::Aabb;

    /// A closed axis-aligned box mesh, outward winding.
    fn box_mesh(min: Point3, max: Point3) -> Mesh {
        Mesh::cuboid(&Aabb::new(min, max)).unwrap()
    }

    #[test]
    fn box_height_map_is_its_top_everywhere_inside() {
        let m = box_mesh(Point3::new(-1.0, -2.0, 0.0), Point3::new(1.0, 2.0, 3.0));
        let map = HeightMap::in_setup_frame(&m, &Setup::top(), 0.1).unwrap();
        let s = map.section(1.0);
        // 2 x 4 footprint in 0.1 cells: 20 x 40 cells, edges exactly on cell boundaries.
        assert_eq!(s.count(), 800, "section of the box at z = 1");
        assert!((s.area() - 8.0).abs() < 1e-9);
        assert_eq!(map.section(3.0 + 1e-9).count(), 0);
        assert_eq!(map.height_at(0.05, 0.05), Some(3.0));
        assert_eq!(map.height_at(1.5, 0.05), None);
        // From below, the "top" is the bottom face at z = 0, seen as height 0 along -Z.
        let below = Setup::from_direction(&s2g_geom::UnitVector3::new_normalize(-Vector3::z()));
        let map = HeightMap::in_setup_frame(&m, &below, 0.1).unwrap();
        assert!(
            map.height_at(
                map.to_map(&Point3::new(0.05, 0.05, 0.0)).x,
                map.to_map(&Point3::new(0.05, 0.05, 0.0)).y
            )
            .is_some_and(|h| h.abs() < 1e-12)
        );
    }

    #[test]
    fn overhang_is_filled_only_under_the_roof() {
        // A "T": a thin stem with a wide roof; from +Z the space under the roof is filled,
        // from -Z it is not.
        let mut t = box_mesh(Point3::new(-0.22, -0.22, 0.0), Point3::new(0.22, 0.22, 1.0));
        t.append(&box_mesh(Point3::new(-1.0, -1.0, 1.0), Point3::new(1.0, 1.0, 1.5)));
        let spec =
            GridSpec::new(&Aabb::new(Point3::new(-1.0, -1.0, 0.0), Point3::new(1.0, 1.0, 1.5)), [20, 20, 15])
                .unwrap();
        let top = map_closure(&closure_map(&t, &Setup::top(), &spec).unwrap(), &spec);
        assert_eq!(top.count(), 20 * 20 * 15, "from +Z the T closes to its bounding box");
        let down = Setup::from_direction(&s2g_geom::UnitVector3::new_normalize(-Vector3::z()));
        let bottom = map_closure(&closure_map(&t, &down, &spec).unwrap(), &spec);
        // From -Z: over the stem (4 x 4 voxel columns) everything above z = 0 is occluded;
        // elsewhere everything above the roof's underside.
        assert_eq!(bottom.count(), 4 * 4 * 15 + (20 * 20 - 4 * 4) * 5, "closure from -Z");
    }
}
