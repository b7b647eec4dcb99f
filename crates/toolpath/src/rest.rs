//! Rest machining: what material remains before a setup, so that later setups do not cut air.

use nalgebra::{Matrix3, Vector3};
use s2g_geom::{Point3, Setup, VoxelGrid};

use crate::region::{Point2, point_segment_distance};

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

    /// Whether any material may remain in the region a vertical cylinder of `radius`
    /// sweeps moving from `a` to `b` (setup frame), its bottom at `z0` and its top at `z1`:
    /// the points within `radius` in XY of the segment, between those heights. The
    /// default asks [`RemainingMaterial::any_in_box`] for the box around that region.
    fn any_near_segment(&self, a: &Point2, b: &Point2, radius: f64, z0: f64, z1: f64) -> bool {
        self.any_in_box(
            &Point3::new(a.x.min(b.x) - radius, a.y.min(b.y) - radius, z0),
            &Point3::new(a.x.max(b.x) + radius, a.y.max(b.y) + radius, z1),
        )
    }

    /// The spacing of the samples the material is known at (a voxel's largest edge), if
    /// any: a box narrower than it may hold none though material is around. Default: none.
    fn sample_spacing(&self) -> Option<f64> {
        None
    }
}

impl<F: Fn(&Point3, &Point3) -> bool + Sync> RemainingMaterial for F {
    fn any_in_box(&self, min: &Point3, max: &Point3) -> bool {
        self(min, max)
    }
}

/// Remaining material as a voxel grid in the PART frame (e.g. voxsim's stock after the
/// earlier setups, less the part's voxels), seen from a setup. A voxel holds material
/// when its bit is set.
///
/// Its queries are **exact** under the simulator's voxel rule (s2g-voxsim removes a voxel
/// iff its centre lies in the swept tool): a region holds material iff the centre of a
/// set voxel lies in it, the region taken in the setup frame (a rotated box is not
/// replaced by its part-frame bounding box) and closed, with the simulator's tie slack
/// ([`TIE`] of the smallest voxel edge). So a tool whose footprint misses every such
/// centre removes nothing, and the planner may skip it; the cells of a map that tile a
/// level (closed boxes) find every centre in it.
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

/// Voxel centres this fraction of the smallest voxel edge outside a queried region count as
/// inside it (s2g-voxsim's default tie tolerance).
pub const TIE: f64 = 1e-9;

/// An index range of the grid, inclusive per axis.
type Range = [(usize, usize); 3];

impl VoxelMaterial<'_> {
    /// Setup-frame point of part-frame `p`.
    fn in_setup(&self, p: &Point3) -> Point3 {
        Point3::from(self.rotation.transpose() * (p.coords - self.translation))
    }

    /// The index range of the voxels whose centres lie in the part-frame bounding box of
    /// the setup-frame box `[min, max]`; `None` when there are none.
    fn range_of(&self, min: &Point3, max: &Point3) -> Option<Range> {
        let spec = self.grid.spec();
        let centre = self.rotation * nalgebra::center(min, max).coords + self.translation;
        let reach = self.abs_rotation * ((max - min) * 0.5);
        let (lo, hi) = (centre - reach, centre + reach);
        let mut range = [(0, 0); 3];
        for (a, r) in range.iter_mut().enumerate() {
            *r = spec.center_range(lo[a], hi[a], a)?;
        }
        Some(range)
    }

    /// Whether a set voxel's centre in `range` lies in a convex region of the setup frame:
    /// `inside` tells a point in it (with the tie slack), `apart(c, h)` that no point within
    /// `h` of `c` is. Splits the range in halves: an empty range is skipped by a brick-word
    /// look, one whose extreme centres are all inside is inside whole (convexity), one whose
    /// centres' ball lies apart from the region is skipped, a single voxel is tested.
    fn any_where(
        &self,
        range: Range,
        inside: &dyn Fn(&Point3) -> bool,
        apart: &dyn Fn(&Point3, f64) -> bool,
    ) -> bool {
        let spec = self.grid.spec();
        let lo = range.map(|r| r.0);
        let hi = range.map(|r| r.1);
        if !self.grid.any_in_range(lo, hi) {
            return false;
        }
        let corner = |c: usize| {
            let pick = |a: usize| if c >> a & 1 == 0 { lo[a] } else { hi[a] };
            self.in_setup(&spec.center(pick(0), pick(1), pick(2)))
        };
        if (0..8).all(|c| inside(&corner(c))) {
            return true;
        }
        let mid = nalgebra::center(&corner(0), &corner(7));
        if apart(&mid, 0.5 * (corner(7) - corner(0)).norm()) {
            return false;
        }
        let a = (0..3).max_by_key(|&a| (hi[a] - lo[a], a)).unwrap_or(0);
        if hi[a] == lo[a] {
            // One voxel, not inside.
            return false;
        }
        let m = (lo[a] + hi[a]) / 2;
        let (mut left, mut right) = (range, range);
        left[a].1 = m;
        right[a].0 = m + 1;
        self.any_where(left, inside, apart) || self.any_where(right, inside, apart)
    }

    /// Whether the setup's axes are the part's, up to order and sign.
    fn is_axis_aligned(&self) -> bool {
        self.abs_rotation.iter().all(|&v| v.abs() < 1e-12 || (v - 1.0).abs() < 1e-12)
    }

    /// The tie slack: [`TIE`] of the smallest voxel edge.
    fn slack(&self) -> f64 {
        TIE * self.grid.spec().voxel.min()
    }
}

impl RemainingMaterial for VoxelMaterial<'_> {
    fn sample_spacing(&self) -> Option<f64> {
        Some(self.grid.spec().voxel.max())
    }

    /// Exact (see [`VoxelMaterial`]): a set voxel's centre in the setup-frame box.
    fn any_in_box(&self, min: &Point3, max: &Point3) -> bool {
        let e = self.slack();
        let grow = Vector3::repeat(e);
        let (min, max) = (min - grow, max + grow);
        if self.is_axis_aligned() {
            // The part-frame box is the box: every centre in its range is in it.
            return self
                .range_of(&min, &max)
                .is_some_and(|r| self.grid.any_in_range(r.map(|r| r.0), r.map(|r| r.1)));
        }
        let Some(range) = self.range_of(&min, &max) else { return false };
        let inside = |p: &Point3| (0..3).all(|a| p[a] >= min[a] && p[a] <= max[a]);
        let centre = nalgebra::center(&min, &max);
        let half = (max - min) * 0.5;
        let apart = |c: &Point3, h: f64| (0..3).any(|a| (c[a] - centre[a]).abs() > half[a] + h);
        self.any_where(range, &inside, &apart)
    }

    /// Exact (see [`VoxelMaterial`]): a set voxel's centre within `radius` in XY of the
    /// segment and between the heights.
    fn any_near_segment(&self, a: &Point2, b: &Point2, radius: f64, z0: f64, z1: f64) -> bool {
        let e = self.slack();
        let (r, z0, z1) = (radius + e, z0 - e, z1 + e);
        let min = Point3::new(a.x.min(b.x) - r, a.y.min(b.y) - r, z0);
        let max = Point3::new(a.x.max(b.x) + r, a.y.max(b.y) + r, z1);
        let Some(range) = self.range_of(&min, &max) else { return false };
        let near = |p: &Point3| point_segment_distance(&Point2::new(p.x, p.y), a, b);
        let inside = |p: &Point3| p.z >= z0 && p.z <= z1 && near(p) <= r;
        let apart = |c: &Point3, h: f64| c.z + h < z0 || c.z - h > z1 || near(c) > r + h;
        self.any_where(range, &inside, &apart)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use s2g_geom::{Aabb, GridSpec, SplitMix64};

    /// Every set voxel's centre in the setup frame.
    fn centres(grid: &VoxelGrid, setup: &Setup) -> Vec<Point3> {
        let inv = setup.frame.inverse();
        grid.iter_set().map(|[i, j, k]| inv * grid.spec().center(i, j, k)).collect()
    }

    /// The exact queries agree with brute force over every set voxel's centre, for the six
    /// axis setups and an oblique one, on boxes and segments placed at random (many of
    /// them grazing the sparse material), and the grown-box query they replace answered
    /// `true` on some of the regions where they rightly answer `false`.
    #[test]
    fn the_exact_queries_agree_with_brute_force() {
        let spec = GridSpec::new(&Aabb::new(Point3::origin(), Point3::new(1.0, 0.8, 0.6)), [20, 16, 12])
            .expect("spec");
        let mut grid = VoxelGrid::new(spec);
        let mut rng = SplitMix64(0x9e37_79b9_7f4a_7c15);
        for k in 0..12 {
            for j in 0..16 {
                for i in 0..20 {
                    if rng.unit() < 0.03 {
                        grid.set(i, j, k, true);
                    }
                }
            }
        }
        let mut setups = Setup::six_axes().to_vec();
        setups.push(Setup::from_direction(&nalgebra::Unit::new_normalize(Vector3::new(0.3, -0.5, 0.8))));
        let (mut outside_only, mut checked, mut found) = (0, 0, [0; 2]);
        for setup in &setups {
            let material = VoxelMaterial::new(&grid, *setup);
            let pts = centres(&grid, setup);
            let inv = setup.frame.inverse();
            let sc: Vec<Point3> = [[0.0, 0.0, 0.0], [1.0, 0.8, 0.6]]
                .iter()
                .map(|c| inv * Point3::new(c[0], c[1], c[2]))
                .collect();
            let (lo, hi) = (sc[0].inf(&sc[1]), sc[0].sup(&sc[1]));
            let at = |rng: &mut SplitMix64| {
                Point3::new(
                    rng.uniform(lo.x - 0.1, hi.x + 0.1),
                    rng.uniform(lo.y - 0.1, hi.y + 0.1),
                    rng.uniform(lo.z - 0.1, hi.z + 0.1),
                )
            };
            for _ in 0..400 {
                let (p, q) = (at(&mut rng), at(&mut rng));
                // A box 0.3-0.7 of the span, from the lower corner.
                let min = p.inf(&q);
                let max = min + (p.sup(&q) - min) * rng.uniform(0.3, 0.7);
                let brute = pts.iter().any(|c| (0..3).all(|a| c[a] >= min[a] && c[a] <= max[a]));
                assert_eq!(material.any_in_box(&min, &max), brute, "box {min:?} {max:?} in {setup:?}");
                found[0] += usize::from(brute);
                let (a, b) =
                    (Point2::new(p.x, p.y), Point2::new(p.x + 0.2 * (q.x - p.x), p.y + 0.2 * (q.y - p.y)));
                let radius = rng.uniform(0.0, 0.1);
                let (z0, z1) = (p.z.min(q.z), p.z.max(q.z));
                let brute = pts.iter().any(|c| {
                    c.z >= z0 && c.z <= z1 && point_segment_distance(&Point2::new(c.x, c.y), &a, &b) <= radius
                });
                assert_eq!(
                    material.any_near_segment(&a, &b, radius, z0, z1),
                    brute,
                    "segment {a:?} {b:?} r {radius} z {z0}..{z1} in {setup:?}"
                );
                found[1] += usize::from(brute);
                checked += 1;
                // Material within half a voxel of the footprint's box but not in the footprint.
                let h = 0.5 * spec.voxel.max();
                let grown = pts.iter().any(|c| {
                    let (x0, x1) = (a.x.min(b.x) - radius - h, a.x.max(b.x) + radius + h);
                    let (y0, y1) = (a.y.min(b.y) - radius - h, a.y.max(b.y) + radius + h);
                    c.x >= x0 && c.x <= x1 && c.y >= y0 && c.y <= y1 && c.z >= z0 - h && c.z <= z1 + h
                });
                outside_only += usize::from(grown && !brute);
            }
        }
        assert!(
            checked == 2800 && outside_only > 50,
            "{outside_only} of {checked} footprints only the grown box finds material in"
        );
        // Both answers are common.
        assert!(found.iter().all(|&f| f > 200 && f < checked - 200), "{found:?} of {checked} hold material");
    }
}
