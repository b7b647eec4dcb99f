//! The solid: beads deposited on a voxel grid, matched to the extruded volume, then
//! marching cubes; and the fast checks of the indexed meshes it makes.

use super::*;

pub(super) fn solid_profile(profile: BeadShape, area: f64, height: f64) -> BeadProfile {
    match profile {
        BeadShape::Rect => BeadProfile::Rectangle { width: area / height, height },
        BeadShape::Slot => BeadProfile::Stadium { width: area / height, height },
        BeadShape::Circle => BeadProfile::Circle { diameter: profile_width(BeadShape::Circle, area, height) },
    }
}

/// The grid the solid is deposited on: `res` in X/Y, layer-aligned in Z.
pub fn solid_grid_spec(ex: &Extrusion, opts: &FdmOptions) -> Result<GridSpec, FdmError> {
    opts.validate()?;
    let h_med = ex.median_height();
    let a_med = ex.median_area();
    if ex.beads.is_empty() || h_med.is_nan() || h_med <= 0.0 || a_med.is_nan() || a_med <= 0.0 {
        return Err(FdmError::NoExtrusion { lines: ex.lines, errors: 0 });
    }
    let res = opts.resolution.unwrap_or(0.25 * (a_med / h_med));
    let kz = (h_med / res).round().max(1.0);
    let dz = h_med / kz;
    let (mut lo, mut hi) = (Point3::from([f64::INFINITY; 3]), Point3::from([f64::NEG_INFINITY; 3]));
    for b in &ex.beads {
        let p = solid_profile(opts.profile, b.area, b.height);
        let (r, depth) = match p {
            BeadProfile::Rectangle { width, height } | BeadProfile::Stadium { width, height } => {
                (0.5 * width * std::f64::consts::SQRT_2, height)
            }
            BeadProfile::Circle { diameter } => (0.5 * diameter, diameter),
        };
        for q in [b.a, b.b] {
            lo = Point3::new(lo.x.min(q.x - r), lo.y.min(q.y - r), lo.z.min(q.z - depth));
            hi = Point3::new(hi.x.max(q.x + r), hi.y.max(q.y + r), hi.z.max(q.z));
        }
    }
    // Align Z to the layer boundaries: the lowest bead bottom sits on a voxel face.
    let origin = Point3::new(lo.x - res, lo.y - res, lo.z - dz);
    let voxel = Vector3::new(res, res, dz);
    let mut dims = [0usize; 3];
    for i in 0..3 {
        let n = ((hi[i] - origin[i]) / voxel[i]).ceil() + 1.0;
        if !(1.0..1e9).contains(&n) {
            return Err(FdmError::TooManyVoxels { voxels: u64::MAX, limit: opts.max_voxels });
        }
        dims[i] = n as usize;
    }
    let voxels = dims.iter().map(|&d| d as u64).product::<u64>();
    if voxels > opts.max_voxels {
        return Err(FdmError::TooManyVoxels { voxels, limit: opts.max_voxels });
    }
    let max = origin + Vector3::new(dims[0] as f64 * res, dims[1] as f64 * res, dims[2] as f64 * dz);
    Ok(GridSpec::new(&Aabb::new(origin, max), dims)?)
}

/// Deposits every bead, areas scaled by `area_scale`, on [`solid_grid_spec`]'s grid with
/// [`FdmOptions::deposition`] (no volume matching: see [`solid_mesh`]).
pub fn deposit_beads(ex: &Extrusion, opts: &FdmOptions, area_scale: f64) -> Result<VoxelGrid, FdmError> {
    let spec = solid_grid_spec(ex, opts)?;
    if !(area_scale.is_finite() && area_scale > 0.0) {
        return Err(FdmError::InvalidOption(format!("area scale must be finite and > 0, got {area_scale}")));
    }
    let mut grid = VoxelGrid::new(spec);
    let eps = SimOptions::default().tie_tolerance * spec.voxel.min();
    let (flat, steep): (Vec<usize>, Vec<usize>) = match opts.deposition {
        Deposition::Raster => (0..ex.beads.len()).partition(|&i| raster::is_flat(&ex.beads[i], spec.voxel.z)),
        Deposition::Voxsim => (Vec::new(), (0..ex.beads.len()).collect()),
    };
    raster::raster(&mut grid, &ex.beads, &flat, opts.profile, area_scale, eps);
    voxsim_deposit(grid, &ex.beads, &steep, opts, area_scale)
}

/// Deposits `idx` with voxsim's additive mode, one depositor per bead size.
pub(super) fn voxsim_deposit(
    mut grid: VoxelGrid,
    beads: &[Bead],
    idx: &[usize],
    opts: &FdmOptions,
    scale: f64,
) -> Result<VoxelGrid, FdmError> {
    let q = opts.size_quantum;
    // Group by quantised (width, height): BTreeMap for a deterministic order.
    let mut groups: BTreeMap<(i64, i64), Vec<usize>> = BTreeMap::new();
    for &i in idx {
        let b = &beads[i];
        let w = profile_width(opts.profile, b.area * scale, b.height);
        groups.entry(((w / q).round() as i64, (b.height / q).round() as i64)).or_default().push(i);
    }
    for idx in groups.values() {
        // The group's length-weighted mean area keeps its volume exact whatever the quantum.
        let n = idx.len() as f64;
        let h = idx.iter().map(|&i| beads[i].height).sum::<f64>() / n;
        let len: f64 = idx.iter().map(|&i| beads[i].length()).sum();
        let area = if len > 0.0 {
            idx.iter().map(|&i| beads[i].area * beads[i].length()).sum::<f64>() / len
        } else {
            beads[idx[0]].area
        } * scale;
        let mut sim =
            Simulator::depositor(grid, solid_profile(opts.profile, area, h), SimOptions::default())?;
        let mut at: Option<Point3> = None;
        for &i in idx {
            let b = &beads[i];
            if at != Some(b.a) {
                sim.motion(&Motion::Rapid { to: b.a })?;
            }
            sim.motion(&Motion::Linear { to: b.b, feed: 1800.0, extrude: Some(1.0) })?;
            at = Some(b.b);
        }
        grid = sim.into_simulation()?.into_parts().1;
    }
    Ok(grid)
}

/// A naive baseline of [`deposit_beads`] for benchmarks: one bead at a time, single
/// thread, every voxel of the bead's bounding box tested against the bead (rectangle
/// cross-section with round ends, the slot solid). Same grid as the solid.
pub fn deposit_beads_naive(ex: &Extrusion, opts: &FdmOptions) -> Result<VoxelGrid, FdmError> {
    let spec = solid_grid_spec(ex, opts)?;
    let mut grid = VoxelGrid::new(spec);
    for b in &ex.beads {
        let r = 0.5 * b.area / b.height;
        let lo = Point3::new(b.a.x.min(b.b.x) - r, b.a.y.min(b.b.y) - r, b.a.z.min(b.b.z) - b.height);
        let hi = Point3::new(b.a.x.max(b.b.x) + r, b.a.y.max(b.b.y) + r, b.a.z.max(b.b.z));
        let (Some((i0, i1)), Some((j0, j1)), Some((k0, k1))) = (
            spec.center_range(lo.x, hi.x, 0),
            spec.center_range(lo.y, hi.y, 1),
            spec.center_range(lo.z, hi.z, 2),
        ) else {
            continue;
        };
        let (ax, ay) = (b.a.x, b.a.y);
        let (dx, dy) = (b.b.x - ax, b.b.y - ay);
        let dd = dx * dx + dy * dy;
        for k in k0..=k1 {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let c = spec.center(i, j, k);
                    let t = if dd > 0.0 {
                        (((c.x - ax) * dx + (c.y - ay) * dy) / dd).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let (px, py) = (ax + t * dx - c.x, ay + t * dy - c.y);
                    let top = b.a.z + t * (b.b.z - b.a.z);
                    if px * px + py * py <= r * r && c.z <= top && c.z >= top - b.height {
                        grid.set(i, j, k, true);
                    }
                }
            }
        }
    }
    Ok(grid)
}

/// The solid of [`solid_mesh`].
#[derive(Debug, Clone)]
pub struct Solid {
    /// Marching cubes of the grid: closed and manifold.
    pub mesh: Mesh,
    /// The deposited voxels.
    pub grid: VoxelGrid,
    /// The factor the bead areas (widths) were scaled by to match the extruded volume (1 without).
    pub area_scale: f64,
    /// Voxel volume of the beads as sliced (scale 1), mm^3: below the extruded volume by
    /// what overlapping beads share.
    pub raw_volume: f64,
    /// Depositions run (more than one when matching the volume).
    pub depositions: usize,
    /// Seconds spent depositing (all rounds).
    pub deposit_seconds: f64,
    /// Seconds spent in marching cubes.
    pub mesh_seconds: f64,
}

/// The solid: beads deposited ([`deposit_beads`]), widths scaled until the voxel volume
/// matches the extruded volume when [`FdmOptions::match_volume`] is set (a proportional
/// step, then secant steps on the deposited volume as a function of the scale), then
/// marching cubes.
pub fn solid_mesh(ex: &Extrusion, opts: &FdmOptions) -> Result<Solid, FdmError> {
    let t = Instant::now();
    let mut scale = 1.0;
    let mut grid = deposit_beads(ex, opts, scale)?;
    let mut raw_volume = grid.volume();
    let mut depositions = 1;
    if opts.match_volume && ex.extruded_volume > 0.0 {
        let target = ex.extruded_volume;
        raw_volume = grid.volume();
        // Safeguarded secant on volume(scale): a bracket [lo, hi] once found, secant steps
        // inside it (bisection otherwise); the first step assumes the union's volume grows
        // at a third of the rate of the widths (most beads are packed between neighbours).
        let mut lo: Option<(f64, f64)> = None;
        let mut hi: Option<(f64, f64)> = None;
        let mut prev: Option<(f64, f64)> = None;
        while depositions < opts.match_iterations {
            let v = grid.volume();
            let err = v / target - 1.0;
            if !(err.is_finite() && v > 0.0) || err.abs() <= opts.match_tolerance {
                break;
            }
            if err < 0.0 {
                lo = Some((scale, v));
            } else {
                hi = Some((scale, v));
            }
            let mut next = scale * (1.0 - 3.0 * err);
            if let Some((s0, v0)) = prev {
                let slope = (v - v0) / (scale - s0);
                let secant = scale + (target - v) / slope;
                if slope.is_finite() && slope > 0.0 && secant.is_finite() {
                    next = secant;
                }
            }
            if let (Some((a, _)), Some((b, _))) = (lo, hi)
                && !(next > a.min(b) && next < a.max(b))
            {
                next = 0.5 * (a + b);
            }
            next = next.clamp(1.0 / opts.max_area_scale, opts.max_area_scale);
            if next == scale {
                break;
            }
            prev = Some((scale, v));
            scale = next;
            grid = deposit_beads(ex, opts, scale)?;
            depositions += 1;
        }
    }
    let deposit_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mesh = marching_cubes_voxels(&grid)?;
    let mesh_seconds = t.elapsed().as_secs_f64();
    Ok(Solid { mesh, grid, area_scale: scale, raw_volume, depositions, deposit_seconds, mesh_seconds })
}

/// Fast checks of an indexed mesh whose bodies share vertices only along real edges (as
/// marching cubes and [`tube_mesh`] make them): every directed edge appears once and its
/// reverse once (closed, edge-manifold, consistently oriented); bodies by shared vertices;
/// signed volume.
pub fn indexed_check(mesh: &Mesh) -> (bool, usize, f64) {
    let tris = mesh.triangles();
    let v = mesh.vertices();
    let mut edges: Vec<u64> = tris
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| ((a as u64) << 32) | b as u64)
        .collect();
    edges.par_sort_unstable();
    let ok = !tris.is_empty()
        && edges.par_windows(2).all(|w| w[0] != w[1])
        && edges.par_iter().all(|&e| edges.binary_search(&e.rotate_right(32)).is_ok());
    // Union-find over vertices.
    let mut parent: Vec<u32> = (0..v.len() as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    let mut used = vec![false; v.len()];
    for t in tris {
        for &i in t {
            used[i as usize] = true;
        }
        for k in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let bodies = (0..v.len() as u32).filter(|&i| used[i as usize] && find(&mut parent, i) == i).count();
    let vol: f64 = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| v[i as usize].coords);
            a.dot(&b.cross(&c)) / 6.0
        })
        .sum();
    (ok, bodies, vol)
}
