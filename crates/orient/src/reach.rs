//! What a chosen set of setups leaves unreached: the part's surface that no setup's
//! finishing tool reaches, and the stock's material that no setup's roughing tool
//! removes, each under its own [`ToolReach`]. A cheap comparison of two setup sets
//! (orientation and reach only, no toolpaths), e.g. those chosen for a roughing end
//! mill's reach and for a shorter finishing ball's.

use s2g_geom::{Mesh, MeshIndex, Point3, Real, UnitVector3, sample_surface};

use crate::error::{OrientError, Result};
use crate::select::OrientOptions;
use crate::stock::StockSamples;
use crate::tool_reach::ToolReach;
use crate::visibility::{VisibilityContext, popcount};

/// What [`unreached`] counts for one set of setups.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Unreached {
    /// Surface samples no setup reaches with the surface's reach.
    pub surface: usize,
    /// Surface samples in all ([`OrientOptions::points`]).
    pub surface_samples: usize,
    /// Stock material samples (outside the part) no setup removes with the stock's reach.
    pub stock: usize,
    /// Stock material samples in all.
    pub material: usize,
    /// Stock samples inside the part.
    pub part: usize,
}

impl Unreached {
    /// The unreached surface as a fraction of the surface samples (0 without samples).
    pub fn surface_fraction(&self) -> Real {
        if self.surface_samples == 0 { 0.0 } else { self.surface as Real / self.surface_samples as Real }
    }

    /// The material left as a fraction of the part's stock samples, about the IoU it costs
    /// (0 without part samples).
    pub fn stock_fraction(&self) -> Real {
        if self.part == 0 { 0.0 } else { self.stock as Real / self.part as Real }
    }
}

/// For each set of tool axes in `sets`: the surface samples of `mesh` (drawn as
/// [`select_orientations`](crate::select_orientations) draws them, from `opts`) that none
/// of the set's axes sees within `surface_reach`, and the material samples of `stock`
/// (stock points; those outside the part are material) that none removes within
/// `stock_reach` (as the stock-removal term counts). `opts.reach` is not used. The same
/// samples serve every set. Errors: an empty mesh, invalid options.
pub fn unreached(
    mesh: &Mesh,
    stock: &[Point3],
    sets: &[&[UnitVector3]],
    opts: &OrientOptions,
    surface_reach: Option<ToolReach>,
    stock_reach: Option<ToolReach>,
) -> Result<Vec<Unreached>> {
    if mesh.is_empty() {
        return Err(OrientError::NoSurface("the mesh has no triangles".into()));
    }
    let diag =
        mesh.bbox().ok_or_else(|| OrientError::NoSurface("the mesh has no vertices".into()))?.extent().norm();
    let samples = sample_surface(mesh, opts.points, opts.seed)?.spatially_ordered();
    let index = MeshIndex::new(mesh)?;
    let vopts = crate::VisibilityOptions { reach: surface_reach, ..opts.visibility() };
    let ctx = VisibilityContext::new(mesh, &index, &samples, &vopts)?;
    let material = StockSamples::new(&index, mesh.vertices(), stock, diag, stock_reach);
    sets.iter()
        .map(|set| {
            let mut seen = vec![0u64; ctx.words()];
            let mut removed = vec![0u64; crate::visibility::words_for(material.material())];
            for v in set.iter() {
                seen.iter_mut().zip(ctx.row(v)).for_each(|(a, b)| *a |= b);
                removed.iter_mut().zip(material.row(v)).for_each(|(a, b)| *a |= b);
            }
            Ok(Unreached {
                surface: ctx.len() - popcount(&seen),
                surface_samples: ctx.len(),
                stock: material.material() - popcount(&removed),
                material: material.material(),
                part: material.part(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stock_grid_points;
    use s2g_geom::Aabb;

    /// A 10 mm cube on the floor of a stock 20 mm tall: from the top, a tool reaching 15 mm
    /// below the stock's top faces the cube's top and cuts all the stock over it; one
    /// reaching 5 mm faces nothing and leaves the stock's lower half.
    #[test]
    fn a_short_reach_leaves_the_surface_and_the_stock_below_it() {
        let part = Mesh::cuboid(&Aabb::new(Point3::origin(), Point3::new(10.0, 10.0, 10.0))).unwrap();
        let stock = Aabb::new(Point3::origin(), Point3::new(10.0, 10.0, 20.0));
        let points = stock_grid_points(&stock, 4096, |_| true);
        let opts = OrientOptions { points: 6000, ..OrientOptions::default() };
        let top = [UnitVector3::new_normalize(s2g_geom::Vector3::z())];
        let reach = |depth| Some(ToolReach::new(stock, depth));
        let score = |surface, material| {
            unreached(&part, &points, &[&top[..], &[]], &opts, surface, material).unwrap()
        };
        let [deep, none] = score(reach(15.0), reach(15.0))[..] else { panic!("two sets, two scores") };
        // The top face (a sixth of the area) is reached, the walls (square to the axis) are not.
        assert!((deep.surface_fraction() - 5.0 / 6.0).abs() < 0.03, "{deep:?}");
        assert_eq!(deep.stock, 0, "{deep:?}");
        assert!(deep.material > 0 && (deep.part as f64 / deep.material as f64 - 1.0).abs() < 0.1, "{deep:?}");
        // No axis: nothing reached.
        assert_eq!((none.surface, none.stock), (none.surface_samples, none.material));
        let shallow = score(reach(5.0), reach(5.0))[0];
        assert_eq!(shallow.surface, shallow.surface_samples, "{shallow:?}");
        assert!((shallow.stock as f64 / shallow.material as f64 - 0.5).abs() < 0.1, "{shallow:?}");
        // Each reach counts for its own measure only.
        let mixed = score(reach(5.0), reach(15.0))[0];
        assert_eq!((mixed.surface, mixed.stock), (shallow.surface, deep.stock));
    }
}
