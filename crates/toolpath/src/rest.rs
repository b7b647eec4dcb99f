//! Rest machining: what material remains before a setup, so that later setups do not cut air.

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
    /// The remaining material, part frame.
    pub grid: &'a VoxelGrid,
    /// The setup whose frame queries are given in.
    pub setup: Setup,
}

impl RemainingMaterial for VoxelMaterial<'_> {
    fn any_in_box(&self, min: &Point3, max: &Point3) -> bool {
        let spec = self.grid.spec();
        let mut lo = Point3::from([f64::INFINITY; 3]);
        let mut hi = Point3::from([f64::NEG_INFINITY; 3]);
        for c in 0..8 {
            let p = Point3::new(
                if c & 1 == 0 { min.x } else { max.x },
                if c & 2 == 0 { min.y } else { max.y },
                if c & 4 == 0 { min.z } else { max.z },
            );
            let q = self.setup.to_part(&p);
            lo = lo.inf(&q);
            hi = hi.sup(&q);
        }
        let mut range = [(0, 0); 3];
        for a in 0..3 {
            let h = 0.5 * spec.voxel[a];
            match spec.center_range(lo[a] - h, hi[a] + h, a) {
                Some(r) => range[a] = r,
                None => return false,
            }
        }
        for k in range[2].0..=range[2].1 {
            for j in range[1].0..=range[1].1 {
                for i in range[0].0..=range[0].1 {
                    if self.grid.get(i, j, k) {
                        return true;
                    }
                }
            }
        }
        false
    }
}
