//! The simulation grid, and where its voxel boundaries fall along each axis.

use super::super::api::{MillError, MillOptions, Preset, Stock};
use crate::geom::{Aabb, GridSpec, Mesh, MetricOptions, Point3, Vector3};
use nalgebra::Similarity3;

/// The simulation grid. The paper's cube of stock keeps the grid over it (the scorer's
/// grid, `resolution` voxels along the stock's side). Any other stock gets cubic voxels
/// of about `1/resolution` of the part's longest side, covering the stock, with the voxel
/// planes, where [`face_grid`] says (the shop preset's default), where [`face_lattice`] puts them: through the part's flat faces across the axes
/// (the voxel within 2 % of that size), so that the residual's marching cubes put those
/// faces where the part has them and every scorer, whatever its grid, finds them there (a
/// plane two thirds of a voxel from a flange's underside moved the residual's face 0.16 mm
/// up over 2,500 mm^2: 1.2 % of a 60 mm bushing's volume, 6 % to a scorer of 1 mm cells
/// whose centres fell in between). Otherwise, along an axis with no such face, and for a
/// part with none, the lattice of the scorer's grid (the part's bounding box centred in a cube of
/// its longest side). A stock more than 1.25 times the part's longest side keeps the grid
/// over the stock, which bounds the grid's size.
pub(super) fn simulation_grid(
    stock: &Aabb,
    part: &Mesh,
    part_box: &Aabb,
    opts: &MillOptions,
) -> Result<GridSpec, MillError> {
    let cubic = GridSpec::cubic(stock, opts.resolution)?;
    let l = part_box.extent().max();
    let h0 = l / opts.resolution as f64;
    if (opts.preset == Preset::Paper && opts.stock == Stock::Preset)
        || !(h0 > 0.0 && h0.is_finite())
        || stock.extent().max() > 1.25 * l
    {
        return Ok(cubic);
    }
    let chosen = if face_grid(opts) { face_lattice(part, h0) } else { None };
    let (h, planes) = chosen.unwrap_or((h0, [None; 3]));
    let c = part_box.center();
    let (mut origin, mut dims) = (stock.min, [0; 3]);
    for a in 0..3 {
        let base = planes[a].unwrap_or(c[a] - 0.5 * l);
        origin[a] = base + ((stock.min[a] - base) / h + 1e-9).floor() * h;
        dims[a] = (((stock.max[a] - origin[a]) / h - 1e-9).ceil() as usize).max(1);
    }
    Ok(GridSpec { origin, voxel: Vector3::repeat(h), dims })
}

/// Whether the simulation grid's planes go through the part's flat faces:
/// [`MillOptions::face_grid`], in the shop preset (the paper preset's grid is the paper's).
pub(super) fn face_grid(opts: &MillOptions) -> bool {
    opts.face_grid && opts.preset == Preset::Shop
}

/// The least distance, in voxels, that [`face_lattice`] leaves between a flat face and the
/// plane of a row of voxel centres where it can: a face through the centres leaves each
/// of their voxels to rounding (the part's inside test, a floor's tool exactly at the
/// centre), and 1/256 of a voxel decides them all one way (rounding is some 1e-12 of it)
/// for the cost of moving the faces on planes as little.
const CENTRE_CLEARANCE: f64 = 1.0 / 256.0;

/// Voxel sizes [`face_lattice`] tries besides those that fit an axis's two largest faces:
/// `h0` times `1 + j / 400` for `j` in -8..=8.
const SIZE_STEPS: i32 = 8;

/// The voxel size, within 2 % of `h0`, and per axis a coordinate of the lattice of that
/// spacing, that put the part's flat faces across the axes (facets whose normal is an
/// axis, to 1e-9) nearest the lattice's planes: the least misplaced volume, each face's
/// area times its distance from the nearest plane, summed over the three axes. The sizes
/// tried are [`SIZE_STEPS`]' and, per axis, the two nearest `h0` that divide the distance
/// between its two largest faces; of sizes as good the nearest `h0` (the finer of two as
/// near), of offsets as good the one through the largest face; then moved by
/// [`off_centres`] off any face that lies on a row of voxel centres. An axis
/// with no such face has none; `None` when the part has no such face or `h0` is not
/// positive.
pub(super) fn face_lattice(part: &Mesh, h0: f64) -> Option<(f64, [Option<f64>; 3])> {
    if !(h0 > 0.0 && h0.is_finite()) {
        return None;
    }
    let planes = [0, 1, 2].map(|a| flat_planes(part, a));
    if planes.iter().all(Vec::is_empty) {
        return None;
    }
    let (lo, hi) = (h0 * (1.0 - 0.02), h0 * (1.0 + 0.02));
    let mut sizes: Vec<f64> = (-SIZE_STEPS..=SIZE_STEPS).map(|j| h0 * (1.0 + f64::from(j) / 400.0)).collect();
    // The sizes that put an axis's two largest faces both on planes.
    for p in &planes {
        let mut by_area: Vec<&(f64, f64)> = p.iter().collect();
        by_area.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.total_cmp(&b.0)));
        if let [a, b, ..] = by_area[..] {
            let span = (a.0 - b.0).abs();
            let n = (span / hi).ceil().max(1.0);
            sizes.extend([n, n + 1.0].map(|n| span / n).into_iter().filter(|h| (lo..=hi).contains(h)));
        }
    }
    sizes.sort_by(|a, b| (a - h0).abs().total_cmp(&(b - h0).abs()).then(a.total_cmp(b)));
    let mut best: Option<(f64, f64, [Option<f64>; 3])> = None;
    for h in sizes {
        let per_axis = planes.each_ref().map(|p| best_offset(p, h));
        let cost: f64 = per_axis.iter().flatten().map(|&(_, k)| k).sum();
        if best.as_ref().is_none_or(|&(_, b, _)| cost < b - 1e-9 * b.max(1.0)) {
            best = Some((h, cost, per_axis.map(|o| o.map(|(t, _)| t))));
        }
    }
    best.map(|(h, _, t)| {
        let mut t = t;
        for (t, p) in t.iter_mut().zip(&planes) {
            *t = t.map(|t| off_centres(p, t, h));
        }
        (h, t)
    })
}

/// The lattice coordinate `t` (spacing `h`) where no plane of `planes` (coordinate, area)
/// lies within [`CENTRE_CLEARANCE`] of a voxel centre's plane (`t + (k + 1/2) h`), or else
/// moved by one or two clearances, up first, to whichever leaves the nearest face farthest
/// from them.
fn off_centres(planes: &[(f64, f64)], t: f64, h: f64) -> f64 {
    let gap = |s: f64| {
        planes
            .iter()
            .map(|&(c, _)| {
                let r = (c - t) / h - s;
                (r - r.floor() - 0.5).abs()
            })
            .fold(f64::INFINITY, f64::min)
    };
    if gap(0.0) >= CENTRE_CLEARANCE {
        return t;
    }
    let mut best = (0.0, gap(0.0));
    for k in [1.0, -1.0, 2.0, -2.0] {
        let g = gap(k * CENTRE_CLEARANCE);
        if g > best.1 + 1e-12 {
            best = (k * CENTRE_CLEARANCE, g);
        }
    }
    t + best.0 * h
}

/// The planes across `axis` that hold flat faces of the part (facets whose normal is the
/// axis, to 1e-9): (coordinate, area), in coordinate order, faces within 1e-6 mm merged.
fn flat_planes(part: &Mesh, axis: usize) -> Vec<(f64, f64)> {
    let mut planes: Vec<(i64, f64)> = Vec::new();
    for t in 0..part.triangles().len() {
        let cross = part.triangle_cross(t);
        let twice = cross.norm();
        if twice.is_nan() || twice <= 0.0 || cross[axis].abs() < (1.0 - 1e-9) * twice {
            continue;
        }
        let p = part.triangle(t);
        let at = (p[0][axis] + p[1][axis] + p[2][axis]) / 3.0;
        planes.push(((at * 1e6).round() as i64, 0.5 * twice));
    }
    planes.sort_by_key(|&(k, _)| k);
    let mut merged: Vec<(i64, f64)> = Vec::new();
    for (k, area) in planes {
        match merged.last_mut() {
            Some(m) if m.0 == k => m.1 += area,
            _ => merged.push((k, area)),
        }
    }
    merged.into_iter().map(|(k, a)| (k as f64 * 1e-6, a)).collect()
}

/// Of the lattices of spacing `h` through one of `planes` (coordinate, area), the one
/// with the least misplaced volume (area times distance from the nearest plane of the
/// lattice, summed), the largest plane first among equals: (its coordinate, that volume).
fn best_offset(planes: &[(f64, f64)], h: f64) -> Option<(f64, f64)> {
    let off = |x: f64| {
        let r = x / h;
        (r - r.round()).abs() * h
    };
    let cost = |t: f64| planes.iter().map(|&(c, a)| a * off(c - t)).sum::<f64>();
    let mut order: Vec<usize> = (0..planes.len()).collect();
    order.sort_by(|&i, &j| planes[j].1.total_cmp(&planes[i].1).then(i.cmp(&j)));
    let mut best: Option<(f64, f64)> = None;
    for i in order {
        let t = planes[i].0;
        let k = cost(t);
        if best.is_none_or(|(_, b)| k < b - 1e-9 * b.max(1.0)) {
            best = Some((t, k));
        }
    }
    best
}

/// The report's scorer on the simulation grid's lattice (with
/// [`face_grid`]): cells of the grid's voxel, or of a whole fraction of it
/// near the scorer's `1/resolution` of the unit cube, aligned with its voxels, over a cube
/// that covers the unit cube. So the scorer's voxel-centre rule agrees with the
/// simulation's on every cell, as the lattice of the unit cube did with the grid on it.
/// `to_unit` maps the grid's frame to the scorer's; `opts` is left as it is where the grid
/// is not cubic or the map is degenerate.
pub(super) fn scorer_on_grid(opts: &mut MetricOptions, spec: &GridSpec, to_unit: &Similarity3<f64>) {
    let h = spec.voxel.x;
    if spec.voxel.y != h || spec.voxel.z != h {
        return;
    }
    let o = to_unit * spec.origin;
    let h_u = to_unit.scaling() * h;
    let m = (h_u * opts.resolution as f64).round().max(1.0);
    let cell = h_u / m;
    if !(cell > 0.0 && cell.is_finite()) {
        return;
    }
    let (b0, b1) = (opts.bounds.min, opts.bounds.max);
    let lo = Point3::from([0, 1, 2].map(|a| o[a] + ((b0[a] - o[a]) / cell + 1e-9).floor() * cell));
    let n = (0..3).map(|a| ((b1[a] - lo[a]) / cell - 1e-9).ceil()).fold(1.0, f64::max);
    if n > 4.0 * opts.resolution as f64 {
        return;
    }
    opts.bounds = Aabb::new(lo, lo + Vector3::repeat(n * cell));
    opts.resolution = n as usize;
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
        // and the flange's top (3,200) outweigh the boss's top (400); along X and Y, the
        // flange's sides (480 each) the boss's (540).
        let flange = block([-30.0, -30.0, 0.0], [30.0, 30.0, 8.0]);
        let boss = block([-10.0, -10.0, 8.0], [10.0, 10.0, 35.0]);
        let mut v = flange.vertices().to_vec();
        let mut t = flange.triangles().to_vec();
        let n = v.len() as u32;
        v.extend_from_slice(boss.vertices());
        t.extend(boss.triangles().iter().map(|&[a, b, c]| [a + n, b + n, c + n]));
        let part = Mesh::new(v, t).unwrap();
        let h0 = 60.0 / 128.0;
        let (h, [x, y, z]) = face_lattice(&part, h0).unwrap();
        assert!((h / h0 - 1.0).abs() <= 0.02 + 1e-12, "{h}");
        let (x, y, z) = (x.unwrap(), y.unwrap(), z.unwrap());
        // 8 / h0 = 17.07 and 35 / h0 = 74.67: the centred lattice of the part's box (17.5 -
        // 30) misses the bottom by 2/3 of a voxel. The size chosen puts less volume off the
        // planes than h0's centred lattice, and than 8 / 17, which puts both large faces
        // along Z on planes but the sides off.
        assert!(off(0.0, 17.5 - 30.0, h0) > 0.3 * h0);
        let misplaced = |h: f64, t: [f64; 3]| {
            let faces: [(usize, f64, f64); 10] = [
                (2, 0.0, 3600.0),
                (2, 8.0, 3200.0),
                (2, 35.0, 400.0),
                (0, -30.0, 480.0),
                (0, 30.0, 480.0),
                (0, -10.0, 540.0),
                (0, 10.0, 540.0),
                (1, -30.0, 480.0),
                (1, 30.0, 480.0),
                (1, -10.0, 540.0),
            ];
            faces.iter().map(|&(a, c, area)| area * off(c, t[a], h)).sum::<f64>() + 540.0 * off(10.0, t[1], h)
        };
        let centred = [-30.0, -30.0, 17.5 - 30.0];
        let chosen = misplaced(h, [x, y, z]);
        assert!(chosen < 0.5 * misplaced(h0, centred), "{chosen}");
        for t in [-30.0, -10.0] {
            assert!(chosen <= misplaced(8.0 / 17.0, [t, t, 0.0]) + 1e-9, "{chosen}");
        }
    }

    /// The closed cuboids `boxes` as one mesh (they may touch: [`face_lattice`] reads
    /// facets only).
    fn blocks(boxes: &[([f64; 3], [f64; 3])]) -> Mesh {
        let (mut v, mut t) = (Vec::new(), Vec::new());
        for &(lo, hi) in boxes {
            let b = block(lo, hi);
            let n = v.len() as u32;
            v.extend_from_slice(b.vertices());
            t.extend(b.triangles().iter().map(|&[a, b, c]| [a + n, b + n, c + n]));
        }
        Mesh::new(v, t).unwrap()
    }

    #[test]
    fn no_flat_face_lies_on_a_row_of_voxel_centres() {
        // An L-bracket (l_bracket's faces): a 100 x 60 x 10 plate, an upright 12 thick to z
        // 70, and an 11 x 11 counterbore floor at z 5. Along Z 10 / 13 mm puts the plate's
        // faces and the top on planes (100 / 128 = 0.78 mm asked) and the floor at 6.5
        // voxels, on the centres of a row; it is moved off them, the other faces kept on
        // their planes.
        let part = blocks(&[
            ([-50.0, -30.0, 0.0], [50.0, 30.0, 10.0]),
            ([-50.0, -30.0, 10.0], [-38.0, 30.0, 70.0]),
            ([0.0, -20.5, 5.0], [11.0, -9.5, 10.0]),
        ]);
        let h0 = 100.0 / 128.0;
        let (h, t) = face_lattice(&part, h0).unwrap();
        assert!((h - 10.0 / 13.0).abs() < 1e-12, "{h}");
        let z = t[2].unwrap();
        assert!((off(5.0, 0.0, h) - 0.5 * h).abs() < 1e-12);
        // Distance from the nearest plane of voxel centres.
        let centre = |c: f64, t: f64| 0.5 * h - off(c, t, h);
        for a in 0..3 {
            for &(c, _) in &flat_planes(&part, a) {
                let t = t[a].unwrap();
                assert!(centre(c, t) >= CENTRE_CLEARANCE * h * (1.0 - 1e-9), "{c} along {a}: {t} {h}");
            }
        }
        for c in [0.0, 10.0, 70.0] {
            assert!(off(c, z, h) <= 2.0 * CENTRE_CLEARANCE * h + 1e-12, "{c}: {z}");
        }
        // A lattice already off the centres stays where it is; one face on them moves by at
        // most two clearances.
        let planes = [(0.0, 10.0), (1.0, 1.0)];
        assert_eq!(off_centres(&planes, 0.0, 0.3), 0.0);
        let moved = off_centres(&planes, 0.0, 2.0);
        assert!(moved != 0.0 && moved.abs() <= 2.0 * CENTRE_CLEARANCE * 2.0 + 1e-12, "{moved}");
        assert!(centre(1.0, moved) > 0.0);
    }

    #[test]
    fn the_paper_preset_s_grid_is_the_same_with_or_without_the_face_grid() {
        // A plate whose faces fall off the scorer's lattice, in a box stock (not the paper's
        // cube): the paper preset keeps the centred lattice; the shop preset moves it.
        let part = block([0.0, 0.0, 0.2], [50.0, 50.0, 10.5]);
        let part_box = part.bbox().unwrap();
        let stock = part_box.inflated(1.0);
        let grid = |preset: Preset, face_grid: bool| {
            let opts = MillOptions {
                preset,
                stock: Stock::BoxSize([52.0, 52.0, 12.3]),
                resolution: 128,
                face_grid,
                ..MillOptions::default()
            };
            simulation_grid(&stock, &part, &part_box, &opts).unwrap()
        };
        assert_eq!(grid(Preset::Paper, true), grid(Preset::Paper, false));
        assert_ne!(grid(Preset::Shop, true), grid(Preset::Shop, false));
        assert_eq!(grid(Preset::Shop, false), grid(Preset::Paper, false));
        assert!(MillOptions::default().face_grid);
    }

    #[test]
    fn a_part_with_no_flat_face_across_an_axis_has_no_lattice_there() {
        // A tetrahedron whose faces all slope: no facet's normal is an axis.
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.2], [0.3, 1.0, 0.1], [0.2, 0.3, 1.0]];
        let v = v.iter().map(|&p| Point3::from(p)).collect();
        let part = Mesh::new(v, vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]).unwrap();
        assert_eq!(face_lattice(&part, 0.1), None);
        assert_eq!(face_lattice(&block([0.0; 3], [1.0; 3]), 0.0), None);
        // A right prism on the triangle (0, 0), (2, 0), (0, 1), z 0 to 1: faces across every
        // axis; sheared along X by 0.3 y, its face at x = 0 slopes: none across X.
        let prism = |shear: f64| {
            let v = [
                [0.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [2.0, 0.0, 1.0],
                [0.0, 1.0, 1.0],
            ];
            let v = v.iter().map(|p| Point3::new(p[0] + shear * p[1], p[1], p[2])).collect();
            let t =
                vec![[0, 2, 1], [3, 4, 5], [0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5]];
            face_lattice(&Mesh::new(v, t).unwrap(), 0.1).unwrap().1
        };
        let [x, y, z] = prism(0.0);
        assert!(x.is_some() && y.is_some() && z.is_some(), "{x:?} {y:?} {z:?}");
        let [x, y, z] = prism(0.3);
        assert!(x.is_none() && y.is_some() && z.is_some(), "{x:?} {y:?} {z:?}");
    }

    #[test]
    fn the_simulation_grid_s_planes_hold_a_plate_s_faces() {
        // A 50 x 50 x 10.3 plate from z 0.2 (10.3 is no whole number of 50/128 mm voxels;
        // the lattice centred on the part's box misses the bottom by 0.18 voxel): within 2 %
        // of that voxel, each of its faces lies within 0.05 voxel of the grid's planes,
        // wherever the stock's margin puts the grid's corner; the grid covers the stock.
        let part = block([0.0, 0.0, 0.2], [50.0, 50.0, 10.5]);
        let part_box = part.bbox().unwrap();
        let stock = part_box.inflated(1.0);
        let opts =
            MillOptions { preset: Preset::Shop, resolution: 128, face_grid: true, ..MillOptions::default() };
        let g = simulation_grid(&stock, &part, &part_box, &opts).unwrap();
        let h = g.voxel.z;
        assert!(g.voxel.x == h && g.voxel.y == h);
        assert!((h / (50.0 / 128.0) - 1.0).abs() <= 0.02 + 1e-12, "{h}");
        assert!(off(0.2, 5.35 - 25.0, 50.0 / 128.0) > 0.15 * 50.0 / 128.0);
        for (a, c) in [(0, 0.0), (0, 50.0), (1, 0.0), (1, 50.0), (2, 0.2), (2, 10.5)] {
            assert!(off(c, g.origin[a], h) < 0.05 * h, "{c} along {a}: {:?} {h}", g.origin);
        }
        for a in 0..3 {
            assert!(g.origin[a] <= stock.min[a] + 1e-9);
            assert!(g.origin[a] + g.dims[a] as f64 * h >= stock.max[a] - 1e-9);
        }
    }

    #[test]
    fn the_report_s_scorer_lies_on_the_simulation_grid_s_lattice() {
        // A grid of 0.47 mm voxels from (-1.3, -0.7, -1.1) mm; the scorer's frame maps 60 mm
        // to 1 about the part's centre (17.5 mm up).
        let spec =
            GridSpec { origin: Point3::new(-1.3, -0.7, -1.1), voxel: Vector3::repeat(0.47), dims: [140; 3] };
        let to_unit = Similarity3::new(Vector3::new(0.0, 0.0, -17.5 / 60.0), Vector3::zeros(), 1.0 / 60.0);
        let mut opts = MetricOptions::default();
        scorer_on_grid(&mut opts, &spec, &to_unit);
        let n = opts.resolution as f64;
        let cell = opts.bounds.extent().x / n;
        // Half the grid's voxel (0.47 / 60 is two of 1/256), its planes on the grid's.
        assert!((cell - 0.47 / 60.0 / 2.0).abs() < 1e-12, "{cell}");
        let o = to_unit * spec.origin;
        for a in 0..3 {
            assert!((opts.bounds.extent()[a] - n * cell).abs() < 1e-9);
            let k = (opts.bounds.min[a] - o[a]) / cell;
            assert!((k - k.round()).abs() < 1e-6, "{k}");
            assert!(opts.bounds.min[a] <= -0.5 && opts.bounds.max[a] >= 0.5);
        }
        // A grid that is not cubic leaves the scorer as it was.
        let mut plain = MetricOptions::default();
        let odd = GridSpec { voxel: Vector3::new(0.47, 0.5, 0.47), ..spec };
        scorer_on_grid(&mut plain, &odd, &to_unit);
        assert_eq!(plain.resolution, 256);
        assert_eq!(plain.bounds, MetricOptions::default().bounds);
    }
}
