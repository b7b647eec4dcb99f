//! The simulation grid, and where its voxel boundaries fall along each axis.

use super::super::api::{MillError, MillOptions, Preset, Stock};
use crate::geom::{Aabb, GridSpec, Mesh, Vector3};

/// The simulation grid. The paper's cube of stock keeps the grid over it (the scorer's
/// grid, `resolution` voxels along the stock's side). Any other stock gets cubic voxels
/// of `1/resolution` of the part's longest side, covering the stock, with the voxel
/// boundaries along each axis where [`face_lattice`] puts them: through the part's flat
/// faces across that axis (the largest first), so that the residual's marching cubes put
/// those faces where the part has them and every scorer, whatever its grid, finds them
/// there (a boundary two thirds of a voxel from a flange's underside moved the residual's
/// face 0.16 mm up over 2,500 mm^2: 1.2 % of a 60 mm bushing's volume, 6 % to a scorer of 1 mm
/// cells whose centres fell in between). An axis with no such face keeps the lattice of the
/// scorer's grid (the part's bounding box centred in a cube of its longest side). A stock
/// more than 1.25 times the part's longest side keeps the grid over the stock, which
/// bounds the grid's size.
pub(super) fn simulation_grid(
    stock: &Aabb,
    part: &Mesh,
    part_box: &Aabb,
    opts: &MillOptions,
) -> Result<GridSpec, MillError> {
    let cubic = GridSpec::cubic(stock, opts.resolution)?;
    let l = part_box.extent().max();
    let h = l / opts.resolution as f64;
    if (opts.preset == Preset::Paper && opts.stock == Stock::Preset)
        || !(h > 0.0 && h.is_finite())
        || stock.extent().max() > 1.25 * l
    {
        return Ok(cubic);
    }
    let c = part_box.center();
    let (mut origin, mut dims) = (stock.min, [0; 3]);
    for a in 0..3 {
        let base = face_lattice(part, a, h).unwrap_or(c[a] - 0.5 * l);
        origin[a] = base + ((stock.min[a] - base) / h + 1e-9).floor() * h;
        dims[a] = (((stock.max[a] - origin[a]) / h - 1e-9).ceil() as usize).max(1);
    }
    Ok(GridSpec { origin, voxel: Vector3::repeat(h), dims })
}

/// A coordinate along `axis` for a lattice of spacing `h` that puts the part's flat faces
/// across that axis on or nearest its planes: of the planes that hold such faces (facets
/// whose normal is the axis, to 1e-9), the one whose lattice has the least area-weighted
/// distance from all of them, the largest plane first among equals. `None` when the part
/// has no such face or `h` is not positive.
pub(super) fn face_lattice(part: &Mesh, axis: usize, h: f64) -> Option<f64> {
    if !(h > 0.0 && h.is_finite()) {
        return None;
    }
    // (plane coordinate in 1e-6 mm, area), summed per plane in coordinate order.
    let mut planes: Vec<(i64, f64)> = Vec::new();
    for t in 0..part.triangles().len() {
        let cross = part.triangle_cross(t);
        let twice = cross.norm();
        if !(twice > 0.0) || cross[axis].abs() < (1.0 - 1e-9) * twice {
            continue;
        }
        let p = part.triangle(t);
        let at = (p[0][axis] + p[1][axis] + p[2][axis]) / 3.0;
        planes.push(((at * 1e6).round() as i64, 0.5 * twice));
    }
    planes.sort_by_key(|&(k, _)| k);
    let mut merged: Vec<(f64, f64)> = Vec::new();
    let mut last = None;
    for (k, area) in planes {
        if last == Some(k) {
            if let Some(m) = merged.last_mut() {
                m.1 += area;
            }
        } else {
            merged.push((k as f64 * 1e-6, area));
            last = Some(k);
        }
    }
    let off = |x: f64| {
        let r = x / h;
        (r - r.round()).abs() * h
    };
    let cost = |t: f64| merged.iter().map(|&(c, a)| a * off(c - t)).sum::<f64>();
    let mut order: Vec<usize> = (0..merged.len()).collect();
    order.sort_by(|&i, &j| merged[j].1.total_cmp(&merged[i].1).then(i.cmp(&j)));
    let mut best: Option<(f64, f64)> = None;
    for i in order {
        let t = merged[i].0;
        let k = cost(t);
        if best.is_none_or(|(_, b)| k < b - 1e-12 * b.abs().max(1.0)) {
            best = Some((t, k));
        }
    }
    best.map(|(t, _)| t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Point3;

    fn block(lo: [f64; 3], hi: [f64; 3]) -> Mesh {
        Mesh::cuboid(&Aabb::new(Point3::from(lo), Point3::from(hi))).unwrap()
    }

    /// The boundary of whichever lattice through `t` of spacing `h` lies nearest `x`.
    fn off(x: f64, t: f64, h: f64) -> f64 {
        let r = (x - t) / h;
        (r - r.round()).abs() * h
    }

    #[test]
    fn the_lattice_goes_through_the_largest_flat_faces() {
        // A 60 x 60 flange 8 thick under a 20 x 20 boss to 35: along Z the bottom (3,600 mm^2)
        // and the flange's top (3,200) outweigh the boss's top (400); along X, its faces.
        let flange = block([-30.0, -30.0, 0.0], [30.0, 30.0, 8.0]);
        let boss = block([-10.0, -10.0, 8.0], [10.0, 10.0, 35.0]);
        let mut v = flange.vertices().to_vec();
        let mut t = flange.triangles().to_vec();
        let n = v.len() as u32;
        v.extend_from_slice(boss.vertices());
        t.extend(boss.triangles().iter().map(|&[a, b, c]| [a + n, b + n, c + n]));
        let part = Mesh::new(v, t).unwrap();
        let h = 60.0 / 128.0;
        let z = face_lattice(&part, 2, h).unwrap();
        // 8 / h = 17.07: both large faces lie within 0.04 mm of the lattice; the centred
        // lattice of the part's box (17.5 - 30) misses the bottom by 2/3 of a voxel.
        assert!(off(0.0, z, h) < 0.04 && off(8.0, z, h) < 0.04, "{z}");
        assert!(off(0.0, 17.5 - 30.0, h) > 0.3 * h);
        let x = face_lattice(&part, 0, h).unwrap();
        assert!(off(-30.0, x, h) < 1e-9 && off(30.0, x, h) < 1e-9, "{x}");
    }

    #[test]
    fn a_part_with_no_flat_face_across_an_axis_has_no_lattice_there() {
        // A tetrahedron whose faces all slope: no facet's normal is an axis.
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.2], [0.3, 1.0, 0.1], [0.2, 0.3, 1.0]];
        let v = v.iter().map(|&p| Point3::from(p)).collect();
        let part = Mesh::new(v, vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]).unwrap();
        for a in 0..3 {
            assert_eq!(face_lattice(&part, a, 0.1), None);
        }
        assert_eq!(face_lattice(&block([0.0; 3], [1.0; 3]), 2, 0.0), None);
    }

    #[test]
    fn the_simulation_grid_s_planes_hold_a_plate_s_faces() {
        // A 50 x 50 x 10.3 plate from z 0.2: its bottom and top on the grid's planes along
        // Z wherever the stock's margin puts the grid's corner (10.3 is not a whole number
        // of 50/128 mm voxels, so the larger face wins: both are as large, the lower first).
        let part = block([0.0, 0.0, 0.2], [50.0, 50.0, 10.5]);
        let part_box = part.bbox().unwrap();
        let stock = part_box.inflated(1.0);
        let opts = MillOptions { preset: Preset::Shop, resolution: 128, ..MillOptions::default() };
        let g = simulation_grid(&stock, &part, &part_box, &opts).unwrap();
        let h = g.voxel.z;
        assert!((h - 50.0 / 128.0).abs() < 1e-12);
        assert!(off(0.2, g.origin.z, h) < 1e-9, "{:?}", g.origin);
        assert!(off(0.0, g.origin.x, h) < 1e-9 && off(50.0, g.origin.y, h) < 1e-9);
        for a in 0..3 {
            assert!(g.origin[a] <= stock.min[a] + 1e-9);
            assert!(g.origin[a] + g.dims[a] as f64 * h >= stock.max[a] - 1e-9);
        }
    }
}
