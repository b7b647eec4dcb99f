//! Rest machining: what material remains before a setup, so that later setups do not cut air.

use nalgebra::{Matrix3, Vector3};
use s2g_geom::{Point3, Setup, VoxelGrid};

/// The material that remains to be cut before this setup, queried in the SETUP frame:
/// the stock left by earlier setups *less the finished part*. (The part may be included,
/// and then walls that are already finished are traced again in air, but never cut
/// into: the keep-out, not this map, protects the part.)
///
/// One required method; it must be conservative (answer `true` when unsure), since a
/// `false` makes the planner skip that area.
pub trait RemainingMaterial: Sync {
    /// Whether any material may remain in the axis-aligned box `[min, max]` (setup frame).
    fn any_in_box(&self, min: &Point3, max: &Point3) -> bool;
}

impl<F: Fn(&Point3, &Point3) -> bool + Sync> RemainingMaterial for F {
    fn any_in_box(&self, min: &Point3, max: &Point3) -> bool {
        self(min, max)
    }
}

/// Remaining material as a voxel grid in the PART frame (e.g. voxsim's stock after the
/// earlier setups, less the part's voxels), seen from a setup. A voxel holds material
/// when its bit is set; a box query looks at every voxel whose centre lies within half a
/// voxel of the box's part-frame bounding box.
#[derive(Debug, Clone, Copy)]
pub struct VoxelMaterial<'a> {
    grid: &'a VoxelGrid,
    /// Setup to part: rotation, its entrywise absolute value, translation.
    rotation: Matrix3<f64>,
    abs_rotation: Matrix3<f64>,
    translation: Vector3<f64>,
}

impl<'a> VoxelMaterial<'a> {
    /// The remaining material `grid` (part frame), queried in the frame of `setup`.
    pub fn new(grid: &'a VoxelGrid, setup: Setup) -> Self {
        let rotation = setup.frame.rotation.to_rotation_matrix().into_inner();
        Self { grid, rotation, abs_rotation: rotation.abs(), translation: setup.frame.translation.vector }
    }
}

impl RemainingMaterial for VoxelMaterial<'_> {
    fn any_in_box(&self, min: &Point3, max: &Point3) -> bool {
        let spec = self.grid.spec();
        // The part-frame bounding box of the rotated box: its centre moved, and its half
        // extents through |R| (the same box the eight corners would span, for one
        // transform instead of eight).
        let centre = self.rotation * nalgebra::center(min, max).coords + self.translation;
        // Most boxes a planner asks lie in material: the voxel holding the box's centre
        // has its centre within half a voxel of the box, so it is one of the voxels the
        // range below looks at, and when it is set the answer is known.
        let at = |a: usize| {
            let f = (centre[a] - spec.origin[a]) / spec.voxel[a];
            // Truncation is floor for the non-negative values kept.
            (f >= 0.0 && f < spec.dims[a] as f64).then_some(f as usize)
        };
        if let (Some(i), Some(j), Some(k)) = (at(0), at(1), at(2))
            && self.grid.get(i, j, k)
        {
            return true;
        }
        let reach = self.abs_rotation * ((max - min) * 0.5);
        let (lo, hi) = (centre - reach, centre + reach);
        let mut range = [(0, 0); 3];
        for a in 0..3 {
            let h = 0.5 * spec.voxel[a];
            match spec.center_range(lo[a] - h, hi[a] + h, a) {
                Some(r) => range[a] = r,
                None => return false,
            }
        }
        self.grid.any_in_range(range.map(|r| r.0), range.map(|r| r.1))
    }
}
