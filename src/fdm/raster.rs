//! Layer-raster deposition of horizontal beads: each Z slice of voxels is a 2-D bitmap
//! filled row by row with the analytic X interval of every bead that covers the slice
//! (a capsule, a rectangle or, for the circle profile, the capsule of the circle's chord at
//! that height), slices in parallel, then packed into the grid's bricks in parallel.
//! Same voxel-centre rule as voxsim's exact engine.

use rayon::prelude::*;

use super::{Bead, BeadShape, profile_width};
use crate::geom::{BRICK, GridSpec, VoxelGrid};

/// One bead's plan-view shape in one slice.
#[derive(Debug, Clone, Copy)]
pub(super) struct Piece {
    pub(super) a: [f64; 2],
    pub(super) b: [f64; 2],
    pub(super) r: f64,
    pub(super) round: bool,
}

/// Whether a bead is horizontal enough for the raster (its ends' Z differ by at most half
/// a voxel); the others go to voxsim.
pub(super) fn is_flat(b: &Bead, dz: f64) -> bool {
    (b.a.z - b.b.z).abs() <= 0.5 * dz
}

/// The bead's (plan half-width, bottom, top) and whether its ends are round.
fn extent(b: &Bead, profile: BeadShape, scale: f64) -> (f64, f64, f64, bool) {
    let top = 0.5 * (b.a.z + b.b.z);
    let area = b.area * scale;
    match profile {
        BeadShape::Rect => (0.5 * area / b.height, top - b.height, top, false),
        BeadShape::Slot => (0.5 * area / b.height, top - b.height, top, true),
        BeadShape::Circle => {
            let d = profile_width(BeadShape::Circle, area, b.height);
            (0.5 * d, top - d, top, true)
        }
    }
}

/// Rasterises the flat beads `idx` of `beads` with areas scaled by `scale` into `grid`.
pub(super) fn raster(
    grid: &mut VoxelGrid,
    beads: &[Bead],
    idx: &[usize],
    profile: BeadShape,
    scale: f64,
    eps: f64,
) {
    let spec = *grid.spec();
    let [nx, ny, nz] = spec.dims;
    let wpr = nx.div_ceil(64);
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); nz];
    for &i in idx {
        let (_, lo, hi, _) = extent(&beads[i], profile, scale);
        if let Some((k0, k1)) = spec.center_range(lo - eps, hi + eps, 2) {
            for bucket in &mut buckets[k0..=k1] {
                bucket.push(i as u32);
            }
        }
    }
    let slices: Vec<Vec<u64>> = buckets
        .par_iter()
        .enumerate()
        .map(|(k, list)| {
            let mut bits = Vec::new();
            if list.is_empty() {
                return bits;
            }
            bits.resize(ny * wpr, 0u64);
            let zc = spec.origin.z + (k as f64 + 0.5) * spec.voxel.z;
            for &i in list {
                let b = &beads[i as usize];
                let (hw, lo, hi, round) = extent(b, profile, scale);
                let r = if profile == BeadShape::Circle {
                    let c = 0.5 * (lo + hi);
                    let dz = zc - c;
                    (hw * hw - dz * dz).max(0.0).sqrt()
                } else {
                    hw
                };
                if r <= 0.0 {
                    continue;
                }
                let p = Piece { a: [b.a.x, b.a.y], b: [b.b.x, b.b.y], r, round };
                fill_piece(&spec, &p, eps, &mut bits, wpr);
            }
            bits
        })
        .collect();
    grid.par_bricks_mut().for_each(|(base, brick)| {
        let w = base[0] / 64;
        let off = base[0] % 64;
        for (z, word) in brick.iter_mut().enumerate() {
            let k = base[2] + z;
            if k >= nz {
                break;
            }
            let s = &slices[k];
            if s.is_empty() {
                continue;
            }
            for y in 0..BRICK {
                let j = base[1] + y;
                if j >= ny {
                    break;
                }
                let row = (s[j * wpr + w] >> off) & 0xff;
                *word |= row << (BRICK * y);
            }
        }
    });
}

/// The X interval of row `yc` inside the piece, if any.
pub(super) fn interval(p: &Piece, yc: f64) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let (dx, dy) = (p.b[0] - p.a[0], p.b[1] - p.a[1]);
    let len = dx.hypot(dy);
    if p.round {
        for c in [p.a, p.b] {
            let d = yc - c[1];
            if d.abs() <= p.r {
                let s = (p.r * p.r - d * d).sqrt();
                lo = lo.min(c[0] - s);
                hi = hi.max(c[0] + s);
            }
        }
    }
    if len > 0.0 {
        let (nx, ny) = (-dy / len * p.r, dx / len * p.r);
        let q = [
            [p.a[0] + nx, p.a[1] + ny],
            [p.b[0] + nx, p.b[1] + ny],
            [p.b[0] - nx, p.b[1] - ny],
            [p.a[0] - nx, p.a[1] - ny],
        ];
        for e in 0..4 {
            let (u, v) = (q[e], q[(e + 1) % 4]);
            let (du, dv) = (u[1] - yc, v[1] - yc);
            if du == 0.0 && dv == 0.0 {
                lo = lo.min(u[0].min(v[0]));
                hi = hi.max(u[0].max(v[0]));
            } else if du * dv <= 0.0 {
                let x = u[0] + (yc - u[1]) * (v[0] - u[0]) / (v[1] - u[1]);
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
    }
    (lo <= hi).then_some((lo, hi))
}

fn fill_piece(spec: &GridSpec, p: &Piece, eps: f64, bits: &mut [u64], wpr: usize) {
    let ylo = p.a[1].min(p.b[1]) - p.r;
    let yhi = p.a[1].max(p.b[1]) + p.r;
    let Some((j0, j1)) = spec.center_range(ylo - eps, yhi + eps, 1) else { return };
    for j in j0..=j1 {
        let yc = spec.origin.y + (j as f64 + 0.5) * spec.voxel.y;
        let Some((x0, x1)) = interval(p, yc) else { continue };
        let Some((i0, i1)) = spec.center_range(x0 - eps, x1 + eps, 0) else { continue };
        fill_bits(&mut bits[j * wpr..(j + 1) * wpr], i0, i1);
    }
}

/// Sets bits `i0..=i1` of a row.
fn fill_bits(row: &mut [u64], i0: usize, i1: usize) {
    let (w0, w1) = (i0 / 64, i1 / 64);
    let lo_mask = !0u64 << (i0 % 64);
    let hi_mask = !0u64 >> (63 - i1 % 64);
    if w0 == w1 {
        row[w0] |= lo_mask & hi_mask;
        return;
    }
    row[w0] |= lo_mask;
    for w in &mut row[w0 + 1..w1] {
        *w = !0;
    }
    row[w1] |= hi_mask;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_bits_spans_words() {
        let mut row = vec![0u64; 3];
        fill_bits(&mut row, 60, 130);
        let n: u32 = row.iter().map(|w| w.count_ones()).sum();
        assert_eq!(n, 71);
        assert_eq!(row[0], 0xf << 60);
        fill_bits(&mut row, 3, 3);
        assert_eq!(row[0] & 0xff, 8);
    }

    #[test]
    fn capsule_interval_matches_distance() {
        let p = Piece { a: [0.0, 0.0], b: [3.0, 4.0], r: 0.5, round: true };
        for yc in [-0.4, 0.0, 1.3, 4.2] {
            let (lo, hi) = interval(&p, yc).expect("row crosses the capsule");
            // Both ends lie at distance r from the segment.
            for x in [lo, hi] {
                let t = ((x * 3.0 + yc * 4.0) / 25.0).clamp(0.0, 1.0);
                let d = (x - 3.0 * t).hypot(yc - 4.0 * t);
                assert!((d - 0.5).abs() < 1e-9, "row {yc}: x {x} is at {d}");
            }
        }
        assert!(interval(&p, 4.6).is_none());
    }
}
