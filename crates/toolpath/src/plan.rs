//! Planning a setup: slicing, per-layer regions, contour and clearing paths, and the
//! streaming of motions into a [`MotionSink`] (seed 000 §3.3).

use std::borrow::Cow;
use std::collections::VecDeque;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;
use s2g_gcode::MotionSink;
use s2g_geom::{Aabb, Mesh, Point3, Setup};

use crate::error::ToolpathError;
use crate::floors::{floor_levels, with_floors};
use crate::layer::LayerPlan;
use crate::link::{Emitter, LinkParams};
use crate::options::PlanOptions;
use crate::region::{Point2, Polyline2, Region2, RegionIndex, nearest_index};
use crate::rest::RemainingMaterial;
use crate::slice::{Keepouts, flat_levels, layer_levels, setup_triangles, slab_regions};
use crate::strategy::ClearingContext;
use crate::tool::{Envelope, Tool};

/// What a planned setup amounts to.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlanSummary {
    /// Number of layers.
    pub layers: usize,
    /// Layers with nothing to cut (no remaining material).
    pub skipped_layers: usize,
    /// Length of feed moves (cuts, links, ramps, helices, plunges).
    pub cutting_length: f64,
    /// Length of rapid moves.
    pub rapid_length: f64,
    /// Machining time estimate: feed moves at their feed, rapids at `rapid_feed`, seconds.
    pub estimated_time_s: f64,
    /// Fraction of the contour and clearing length along which the central half of the
    /// cutter (a square of half-side r/2 over the layer's slab) meets no remaining
    /// material; `None` without rest information or without
    /// [`PlanOptions::measure_air_cut`].
    pub air_cut_fraction: Option<f64>,
    /// Retracts to the clearance plane.
    pub retracts: usize,
    /// Crossings between two paths of one level just above the level before it
    /// ([`PlanOptions::lead_in`]), instead of retracts.
    pub low_retracts: usize,
    /// Entries by helix, by ramp and by straight plunge (in material or in air).
    pub helix_entries: usize,
    /// Entries by zigzag ramp.
    pub ramp_entries: usize,
    /// Straight plunges.
    pub plunge_entries: usize,
    /// Entries from the side ([`PlanOptions::lead_in`]): down in air beside the path's
    /// start, then across to it.
    pub lead_in_entries: usize,
    /// The stock box used (setup frame).
    pub stock: Option<Aabb>,
}

/// The slicing of a part for one setup.
#[derive(Debug, Clone)]
pub struct SetupSlices {
    /// The stock box (setup frame).
    pub stock: Aabb,
    /// The part's bounding box in the setup frame.
    pub part_bbox: Aabb,
    /// Layer levels (setup-frame z), top down.
    pub levels: Vec<f64>,
    /// Per level: the keep-out region, the XY projection of the part above the level,
    /// exact except that holes of area below `π (r + allowance)²` are filled: no tool
    /// centre fits in them, so the tool-centre keep-out (this grown by `r + allowance`)
    /// is the exact one, and except for slivers narrower than
    /// [`sliver_width`](Self::sliver_width).
    pub keepouts: Vec<Region2>,
    /// The keep-outs are exact to within this width ([`PlanOptions::sliver_width`]).
    pub sliver_width: f64,
}

fn check_tool_opts<E>(tool: &Tool, opts: &PlanOptions) -> Result<(), ToolpathError<E>> {
    tool.validate().map_err(ToolpathError::InvalidTool)?;
    opts.validate().map_err(ToolpathError::InvalidOptions)
}

/// Slices `part` (part frame) for `setup`: stock, levels and keep-out regions.
pub fn slice_setup<E>(
    part: &Mesh,
    setup: &Setup,
    tool: &Tool,
    opts: &PlanOptions,
) -> Result<SetupSlices, ToolpathError<E>> {
    let s = slice_levels(part, setup, tool, opts)?;
    let n = s.levels.len();
    let keepouts = Keepouts::new(s.slabs, s.min_hole_area, keepout_tolerance(&s.stock)).advance(n);
    Ok(SetupSlices {
        stock: s.stock,
        part_bbox: s.part_bbox,
        levels: s.levels,
        keepouts,
        sliver_width: s.sliver_width,
    })
}

/// A setup's slicing before the keep-outs' running union: the slab regions instead.
struct Sliced {
    stock: Aabb,
    part_bbox: Aabb,
    levels: Vec<f64>,
    slabs: Vec<Region2>,
    /// Keep-out holes smaller than this are filled: `π d²` for the keep-out growth `d`
    /// (tool radius + finishing allowance), which fills them anyway.
    min_hole_area: f64,
    /// The keep-outs are exact to within this width ([`PlanOptions::sliver_width`]).
    sliver_width: f64,
}

/// The tolerance of a keep-out union simplified for its size (`Keepouts`): 1e-4 of the
/// stock's larger horizontal side (10 µm on a 100 mm part).
fn keepout_tolerance(stock: &Aabb) -> f64 {
    1e-4 * stock.extent().x.max(stock.extent().y)
}

fn slice_levels<E>(
    part: &Mesh,
    setup: &Setup,
    tool: &Tool,
    opts: &PlanOptions,
) -> Result<Sliced, ToolpathError<E>> {
    check_tool_opts(tool, opts)?;
    if part.is_empty() {
        return Err(ToolpathError::EmptyMesh);
    }
    let tris = setup_triangles(part, setup);
    let part_bbox = Aabb::from_points(tris.iter().flatten()).ok_or(ToolpathError::EmptyMesh)?;
    let stock = opts.stock.unwrap_or_else(|| part_bbox.inflated(opts.stock_margin));
    if !stock.is_valid() || (0..3).any(|a| stock.extent()[a] <= 0.0) {
        return Err(ToolpathError::InvalidStock(format!("{stock:?}")));
    }
    let top = stock.max.z;
    let mut bottom = opts.bottom.unwrap_or(part_bbox.min.z).max(stock.min.z);
    // Layer planning keeps the tool's enclosing cylinder out of the part (see `Envelope`).
    let envelope = tool.envelope();
    if envelope.length.is_finite() {
        bottom = bottom.max(top - envelope.length);
    }
    // With an axial allowance the tool tip rests that far above each flat face.
    let flats = if opts.snap_to_flats {
        let mut f = flat_levels(&tris, opts.flat_tolerance, opts.level_tolerance);
        f.iter_mut().for_each(|z| *z += opts.axial_allowance);
        f
    } else {
        Vec::new()
    };
    let mut levels = layer_levels(top, bottom, opts.layer_height, &flats, opts.level_tolerance);
    let grow = envelope.radius + opts.wall_allowance();
    if opts.floor_levels {
        let merge = 0.1 * opts.layer_height;
        let (lift, tol) = (opts.axial_allowance, opts.level_tolerance);
        let floors = floor_levels(&tris, top, &levels, grow, lift, tol, merge);
        levels = with_floors(&levels, &floors, merge);
    }
    let min_hole_area = std::f64::consts::PI * grow * grow;
    let sliver_width = opts.sliver_width.unwrap_or(1e-6 * stock.extent().x.max(stock.extent().y));
    let slabs = slab_regions(
        &tris,
        &levels,
        opts.level_tolerance - opts.axial_allowance,
        min_hole_area,
        sliver_width,
    );
    Ok(Sliced { stock, part_bbox, levels, slabs, min_hole_area, sliver_width })
}

/// The contour keep-out is grown by this fraction of the tool radius more and thinned
/// (Douglas-Peucker) by as much: its vertices keep the full distance, its chords cut up to
/// this much inside. Where the keep-out's boundary is concave (a bore, a pocket's wall)
/// the chords run the other way, into the free region, so there the tool centre keeps up
/// to twice this more than the radius from the wall (and `offset_eps` twice more, from
/// [`Region2::grown_safe`]): every bore and pocket is cut that much small. At 0.005 a
/// Ø30 bore roughed with a 12 mm end mill came out 0.06-0.07 mm small on the diameter;
/// at 0.001 it is 0.024-0.048 mm at most, 0.2-0.4 % of the tool radius.
const CONTOUR_THINNING: f64 = 0.001;

pub(crate) struct Ctx<'a> {
    pub tool: &'a Tool,
    /// What planning keeps out of the part: the tool's enclosing cylinder
    /// ([`Tool::envelope`]); every distance to the part below is measured with its radius.
    pub envelope: Envelope,
    pub opts: &'a PlanOptions,
    pub stock: Aabb,
    pub start: Point3,
    pub rest: Option<&'a dyn RemainingMaterial>,
    /// How far the keep-outs may lie inside the exact ones ([`SetupSlices::sliver_width`]).
    pub sliver_width: f64,
    /// Material reaches of recent layers, by their cell maps.
    reaches: ReachCache,
}

/// Where the tool centre may go on a level: the keep-out grown by the tool radius and the
/// finishing allowance, and the stock outline less it. A pure function of the keep-out, so
/// levels with equal keep-outs share one.
pub(crate) struct Clearance {
    /// The keep-out grown by the tool radius and the finishing allowance.
    off: Region2,
    /// The stock outline grown by the tool radius, less `off`.
    free: Region2,
    /// The keep-out itself, indexed, where arcs are fitted.
    keepout: Option<Arc<RegionIndex>>,
}

/// A level's keep-out and tool-centre keep-out, from which the next levels' grow
/// ([`Ctx::clearances`]).
#[derive(Clone)]
pub(crate) struct Nest {
    keepout: Region2,
    off: Region2,
}

/// The tool-centre region near remaining material on a level.
struct Reach {
    region: Region2,
    /// The bounding boxes of `region`'s shapes.
    boxes: Vec<(Point2, Point2)>,
    /// `region` within the stock outline grown by the tool radius, where contours are
    /// kept; built when a contour first needs it.
    clip: OnceLock<Region2>,
}

impl Reach {
    fn new(region: Region2) -> Self {
        Self { boxes: region.shape_bboxes(), region, clip: OnceLock::new() }
    }

    /// Whether `line` may meet the region: its bounding box comes within `gap` of a
    /// shape's. When not, clipping it to the region (or to a part of it) leaves nothing.
    fn may_meet(&self, line: &Polyline2, gap: f64) -> bool {
        let Some((lo, hi)) = line.bbox() else { return false };
        self.boxes
            .iter()
            .any(|(a, b)| lo.x <= b.x + gap && a.x <= hi.x + gap && lo.y <= b.y + gap && a.y <= hi.y + gap)
    }
}

/// The material reaches of the last few layers, keyed by their cell maps: neighbouring
/// layers often find material in the same cells, and the reach (a union and an offset,
/// the costliest step of a layer) is a pure function of the cells.
#[derive(Default)]
struct ReachCache {
    entries: Mutex<VecDeque<(Vec<bool>, Arc<Reach>)>>,
}

impl ReachCache {
    /// Cell maps remembered; enough for the layers planned at once to find their
    /// neighbours'.
    const CAPACITY: usize = 16;

    /// The reach of `cells`, built by `build` unless a recent layer had the same cells.
    fn get_or_build(&self, cells: Vec<bool>, build: impl FnOnce(&[bool]) -> Reach) -> Arc<Reach> {
        let lock = || self.entries.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, reach)) = lock().iter().find(|(c, _)| *c == cells) {
            return Arc::clone(reach);
        }
        // Built without the lock: another layer with the same cells may build it too, to
        // the same result.
        let reach = Arc::new(build(&cells));
        let mut entries = lock();
        if !entries.iter().any(|(c, _)| *c == cells) {
            if entries.len() == Self::CAPACITY {
                entries.pop_front();
            }
            entries.push_back((cells, Arc::clone(&reach)));
        }
        reach
    }
}

impl Ctx<'_> {
    fn stepover(&self) -> f64 {
        self.opts.stepover * self.tool.diameter()
    }

    fn centre_rect(&self) -> Region2 {
        let r = self.envelope.radius;
        Region2::rect(
            Point2::new(self.stock.min.x - r, self.stock.min.y - r),
            Point2::new(self.stock.max.x + r, self.stock.max.y + r),
        )
    }

    fn rest_cell(&self) -> f64 {
        let e = self.stock.extent();
        self.opts.rest_cell.unwrap_or_else(|| (0.5 * self.stepover()).max(e.x.max(e.y) / 256.0))
    }

    /// The material map's cell grid: cell size and number of cells along X and Y.
    fn material_grid(&self) -> (f64, usize, usize) {
        let c = self.rest_cell();
        let (lo, hi) = (self.stock.min, self.stock.max);
        let nx = (((hi.x - lo.x) / c).ceil() as usize).max(1);
        let ny = (((hi.y - lo.y) / c).ceil() as usize).max(1);
        (c, nx, ny)
    }

    /// Which cells of the material map (row by row) hold remaining material in the slab
    /// `[z, z_above]`.
    fn material_cells(&self, rest: &dyn RemainingMaterial, z: f64, z_above: f64) -> Vec<bool> {
        let (c, nx, ny) = self.material_grid();
        let (lo, hi) = (self.stock.min, self.stock.max);
        // Blocks of 8 x 8 cells are asked first, and those with material are split in
        // quarters down to single cells (a sub-box's query box lies in the block's, so an
        // empty block has no cell with material).
        const BLOCK: usize = 8;
        let query = |x0: f64, y0: f64, x1: f64, y1: f64| {
            rest.any_in_box(&Point3::new(x0, y0, z), &Point3::new(x1, y1, z_above))
        };
        let mut has = vec![false; nx * ny];
        // Blocks of cells `i0..i1` by `j0..j1` still to look at.
        let mut blocks: Vec<[usize; 4]> = Vec::new();
        for bj in (0..ny).step_by(BLOCK) {
            for bi in (0..nx).step_by(BLOCK) {
                blocks.push([bi, bj, (bi + BLOCK).min(nx), (bj + BLOCK).min(ny)]);
            }
        }
        while let Some([i0, j0, i1, j1]) = blocks.pop() {
            if i1 - i0 == 1 && j1 - j0 == 1 {
                let (x0, y0) = (lo.x + i0 as f64 * c, lo.y + j0 as f64 * c);
                has[j0 * nx + i0] = query(x0, y0, (x0 + c).min(hi.x), (y0 + c).min(hi.y));
                continue;
            }
            // The block's box, grown by a hair so that rounding cannot leave a cell's box
            // sticking out of it.
            let pad = 1e-9 * c;
            let any = query(
                lo.x + i0 as f64 * c - pad,
                lo.y + j0 as f64 * c - pad,
                (lo.x + i1 as f64 * c).min(hi.x) + pad,
                (lo.y + j1 as f64 * c).min(hi.y) + pad,
            );
            if any {
                let (im, jm) = ((i0 + i1).div_ceil(2), (j0 + j1).div_ceil(2));
                for [a0, b0, a1, b1] in
                    [[i0, j0, im, jm], [im, j0, i1, jm], [i0, jm, im, j1], [im, jm, i1, j1]]
                {
                    if a0 < a1 && b0 < b1 {
                        blocks.push([a0, b0, a1, b1]);
                    }
                }
            }
        }
        has
    }

    /// Tool-centre region near remaining material in the slab `[z, z_above]`: the cells of
    /// the material map that hold material ([`Ctx::material_cells`]) grown by the tool
    /// radius, and its part inside the stock outline grown by the radius. Shared with the
    /// recent layers that found the same cells.
    fn material_reach(&self, rest: &dyn RemainingMaterial, z: f64, z_above: f64) -> Arc<Reach> {
        let cells = self.material_cells(rest, z, z_above);
        self.reaches.get_or_build(cells, |has| Reach::new(self.cells_reach(has)))
    }

    /// The cells set in `has` (row by row over the material map), grown by the tool radius:
    /// the cells (of the map's grid, continued past the stock) whose boxes come within the
    /// radius of one of them. It holds the exact growth and lies within a cell's diagonal
    /// of it, and a raster dilation costs far less than offsetting the cells' staircase
    /// outline with round joins.
    fn cells_reach(&self, has: &[bool]) -> Region2 {
        let (c, nx, ny) = self.material_grid();
        let lo = self.stock.min;
        // Cell offsets whose boxes lie within the radius of a cell's box, and the margin of
        // cells the growth adds around the map.
        let m = (self.envelope.radius / c).ceil() as usize + 1;
        let gap = |d: usize| d.saturating_sub(1) as f64 * c;
        let reach: Vec<(usize, usize)> = (0..=2 * m)
            .flat_map(|dj| (0..=2 * m).map(move |di| (di, dj)))
            .filter(|&(di, dj)| gap(di.abs_diff(m)).hypot(gap(dj.abs_diff(m))) <= self.envelope.radius)
            .collect();
        let (wx, wy) = (nx + 2 * m, ny + 2 * m);
        // Cell `(i, j)` of the grown grid is map cell `(i - m, j - m)`; a map cell's
        // neighbour `(di, dj)` (shifted by `m`) is grown cell `(i + di, j + dj)`.
        let mut near = vec![false; wx * wy];
        for j in 0..ny {
            for i in (0..nx).filter(|&i| has[j * nx + i]) {
                for &(di, dj) in &reach {
                    near[(j + dj) * wx + i + di] = true;
                }
            }
        }
        let mut rects: Vec<Vec<[f64; 2]>> = Vec::new();
        let at = |i: usize, o: f64| o + (i as f64 - m as f64) * c;
        for j in 0..wy {
            let (y0, y1) = (at(j, lo.y), at(j + 1, lo.y));
            let mut run: Option<usize> = None;
            for i in 0..=wx {
                match (i < wx && near[j * wx + i], run) {
                    (true, None) => run = Some(i),
                    (false, Some(s)) => {
                        let (x0, x1) = (at(s, lo.x), at(i, lo.x));
                        rects.push(vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]);
                        run = None;
                    }
                    _ => {}
                }
            }
        }
        Region2::union_contours(rects)
    }

    /// Whether the cutter (the envelope's radius) meets remaining material in the slab
    /// `[z, z_above]` somewhere along `path`: an exact query for a
    /// [`crate::VoxelMaterial`] (voxel centres in the swept footprint).
    fn meets_material(&self, rest: &dyn RemainingMaterial, path: &Polyline2, z: f64, z_above: f64) -> bool {
        let r = self.envelope.radius;
        match path.points.as_slice() {
            [] => false,
            [p] => rest.any_near_segment(p, p, r, z, z_above),
            _ => path.segments().any(|(a, b)| rest.any_near_segment(&a, &b, r, z, z_above)),
        }
    }

    /// No remaining material under the central half of the cutter (the rim is left out:
    /// next to the part it always touches the part itself).
    fn is_air(&self, rest: &dyn RemainingMaterial, p: &Point2, z: f64, z_above: f64) -> bool {
        let r = 0.5 * self.envelope.radius;
        !rest.any_in_box(&Point3::new(p.x - r, p.y - r, z), &Point3::new(p.x + r, p.y + r, z_above))
    }

    /// The tool-centre keep-out of a keep-out region: grown by the tool radius and the
    /// finishing allowance.
    fn grown(&self, keepout: &Region2) -> Region2 {
        let r = self.envelope.radius;
        let thin = CONTOUR_THINNING * r;
        keepout
            .grown_safe(
                r + self.opts.wall_allowance() + thin + self.sliver_width,
                self.opts.offset_eps * r,
                self.opts.arc_step,
            )
            .thinned(thin)
    }

    /// The clearances of consecutive levels (top down) with keep-outs `keepouts`, each
    /// level's tool-centre keep-out that of the level above (`above`, for the first)
    /// joined with the growth of what its keep-out adds: `grown(K ∪ A) = grown(K) ∪
    /// grown(A)`, and where a wall does not move between levels both keep the same
    /// polygon. So the levels' free regions nest exactly, as the link's safety argument
    /// needs ([`crate::link`]). Growing each level's keep-out whole gave each its own
    /// chords and roundings, and where two levels' keep-outs share a wall (an undercut's
    /// rim) the lower level's free region reached a few micrometres past the upper's: a
    /// rapid down to the lower level then met the skin of stock the upper level left on
    /// that wall.
    fn clearances(&self, keepouts: &[&Region2], above: Option<&Nest>) -> Vec<Clearance> {
        let rect = self.centre_rect();
        let clearance = |(off, keepout): (Region2, &&Region2)| {
            let free = rect.difference(&off);
            let keepout = self.opts.arc_fit().map(|_| Arc::new(keepout.index()));
            Clearance { off, free, keepout }
        };
        if !self.opts.nest_levels {
            // Each level's keep-out grown on its own ([`PlanOptions::nest_levels`]).
            return keepouts.par_iter().map(|k| clearance((self.grown(k), k))).collect();
        }
        // The growths, in parallel; their running union is sequential.
        let added: Vec<Option<Region2>> = keepouts
            .par_iter()
            .enumerate()
            .map(|(k, keepout)| {
                let prev = if k == 0 { above.map(|a| &a.keepout) } else { Some(keepouts[k - 1]) };
                let new = match prev {
                    Some(p) => Cow::Owned(keepout.difference(p)),
                    None => Cow::Borrowed(*keepout),
                };
                (!new.is_empty() || prev.is_none()).then(|| self.grown(&new))
            })
            .collect();
        let mut offs: Vec<Region2> = Vec::with_capacity(keepouts.len());
        for add in added {
            let prev = offs.last().or(above.map(|a| &a.off));
            offs.push(match (prev, add) {
                (Some(p), Some(a)) => p.union(&a),
                (Some(p), None) => p.clone(),
                (None, a) => a.unwrap_or_else(Region2::empty),
            });
        }
        offs.into_par_iter().zip(keepouts.par_iter()).map(clearance).collect()
    }

    /// Plans one layer, whose keep-out gives `clearance` ([`Ctx::clearance`]). `roughed` is
    /// the free region of the roughing level below, whose cut (from below this layer up
    /// past its slab) already removed the material its tool centres reach: only the rest
    /// of `free` needs clearing.
    pub(crate) fn plan_layer(
        &self,
        index: usize,
        z: f64,
        z_above: f64,
        clearance: &Clearance,
        roughed: Option<(&Region2, &RegionIndex)>,
    ) -> LayerPlan {
        let r = self.envelope.radius;
        let Clearance { off, free, keepout } = clearance;
        let to_clear = match roughed {
            Some((done, _)) => Cow::Owned(free.difference(done)),
            None => Cow::Borrowed(free),
        };
        let reach = self.rest.map(|rest| self.material_reach(rest, z, z_above));
        let clearing_region = match &reach {
            Some(reach) => to_clear.intersection(&reach.region),
            None => to_clear.into_owned(),
        };
        let rect = self.centre_rect();
        // Far beyond the rounding of the boolean engine's integer grid.
        let gap = 1e-6 * (self.stock.extent().x.max(self.stock.extent().y) + 2.0 * r);
        let start = Point2::new(self.start.x, self.start.y);
        // Contour: the offset keep-out's boundary inside the stock outline; part on the
        // right of travel for climb milling (its loops come part-on-the-left).
        let mut pieces: Vec<Polyline2> = Vec::new();
        for mut lp in off.loops().into_iter().filter(|_| self.opts.contour) {
            if self.opts.climb {
                lp.reverse();
            }
            // The stock outline grown by the radius, limited to the material reach; loops
            // far from it are left out without clipping.
            match &reach {
                Some(reach) if reach.may_meet(&lp, gap) => {
                    let clip = reach.clip.get_or_init(|| rect.intersection(&reach.region));
                    pieces.extend(clip.clip_polyline(&lp));
                }
                Some(_) => {}
                None => pieces.extend(rect.clip_polyline(&lp)),
            }
        }
        // On a level above a roughing level, the contour where it runs in the roughing
        // level's free region was cut there already (the tool stood lower at the same
        // place): only the rest is kept.
        if let Some((_, done)) = roughed {
            pieces = pieces.into_iter().flat_map(|p| p.outside(done, gap)).collect();
        }
        // The reach lies up to a cell's diagonal past the tool centres that meet material:
        // a piece whose cutter meets none anywhere is left out.
        if let Some(rest) = self.rest {
            pieces.retain(|p| self.meets_material(rest, p, z, z_above));
        }
        let mut contour = Vec::with_capacity(pieces.len());
        let mut cur = start;
        while !pieces.is_empty() {
            let mut best = (f64::INFINITY, 0);
            for (i, p) in pieces.iter().enumerate() {
                let d = if p.closed {
                    p.points.get(nearest_index(&p.points, &cur)).map_or(f64::INFINITY, |q| (q - cur).norm())
                } else {
                    p.start().map_or(f64::INFINITY, |q| (q - cur).norm())
                };
                if d < best.0 {
                    best = (d, i);
                }
            }
            let mut p = pieces.swap_remove(best.1);
            p.rotate_to_nearest(&cur);
            cur = p.end().unwrap_or(cur);
            contour.push(p);
        }
        let clearing_ctx = ClearingContext {
            tool_radius: r,
            stepover: self.stepover(),
            start: cur,
            arc_step: self.opts.arc_step,
            climb: self.opts.climb,
        };
        let mut clearing = self.opts.strategy.clear(&clearing_region, &clearing_ctx);
        if let Some(rest) = self.rest {
            clearing.retain(|p| self.meets_material(rest, p, z, z_above));
        }
        let mut cut_air = (0.0, 0.0);
        for p in contour.iter().chain(&clearing) {
            cut_air.0 += p.length();
            if let Some(rest) = self.rest.filter(|_| self.opts.measure_air_cut) {
                for (a, b) in p.segments() {
                    let len = (b - a).norm();
                    let n = ((len / (0.5 * r)).ceil() as usize).max(1);
                    let air = (0..n)
                        .filter(|&k| {
                            self.is_air(rest, &(a + (b - a) * ((k as f64 + 0.5) / n as f64)), z, z_above)
                        })
                        .count();
                    cut_air.1 += len * air as f64 / n as f64;
                }
            }
        }
        let roughed = roughed.filter(|_| self.opts.lead_in).map(|(done, _)| done.clone());
        LayerPlan {
            index,
            z,
            z_above,
            free: free.clone(),
            clearing_region,
            contour,
            clearing,
            cut_air,
            roughed,
            keepout: keepout.clone(),
        }
    }
}

/// Plans every layer of a setup (without emitting): for inspection and tests. Memory grows
/// with the number of layers; [`plan_setup`] streams instead. The plans come in level
/// order (top down), which is the machining order unless
/// [`roughing_depth`](PlanOptions::roughing_depth) groups the levels.
pub fn plan_layers<E>(
    part: &Mesh,
    setup: &Setup,
    tool: &Tool,
    opts: &PlanOptions,
    rest: Option<&dyn RemainingMaterial>,
) -> Result<(SetupSlices, Vec<LayerPlan>), ToolpathError<E>> {
    let slices = slice_setup(part, setup, tool, opts)?;
    let ctx = make_ctx(&slices.stock, slices.sliver_width, tool, opts, rest);
    let groups = roughing_groups(&slices.levels, slices.stock.max.z, opts);
    let levels = Levels { z: &slices.levels, top: slices.stock.max.z, keepouts: &slices.keepouts, base: 0 };
    let mut layers: Vec<LayerPlan> = plan_groups(&ctx, &levels, &groups, None)
        .0
        .into_iter()
        .flat_map(|(rough, fine)| fine.into_iter().chain([rough]))
        .collect();
    layers.sort_by_key(|p| p.index);
    Ok((slices, layers))
}

/// One roughing group: the roughing level and the finer levels above it (down to the
/// roughing level's previous group), machined after it.
#[derive(Debug, Clone)]
struct Group {
    rough: usize,
    fine: std::ops::Range<usize>,
}

/// The levels grouped top down from the stock's `top` so that no group spans more than the
/// roughing depth (each level its own group without one).
fn roughing_groups(levels: &[f64], top: f64, opts: &PlanOptions) -> Vec<Group> {
    let depth = opts.roughing_depth.unwrap_or(0.0);
    let mut groups = Vec::new();
    let (mut start, mut top) = (0, top);
    for l in 0..levels.len() {
        let next_too_deep = levels.get(l + 1).is_none_or(|&z| top - z > depth + opts.level_tolerance);
        if next_too_deep {
            groups.push(Group { rough: l, fine: start..l });
            (start, top) = (l + 1, levels[l]);
        }
    }
    groups
}

/// The levels of a setup and the keep-outs of some of them (`keepouts[i]` is level
/// `base + i`'s).
struct Levels<'a> {
    z: &'a [f64],
    /// The stock top.
    top: f64,
    keepouts: &'a [Region2],
    base: usize,
}

impl Levels<'_> {
    fn keepout(&self, l: usize) -> &Region2 {
        &self.keepouts[l - self.base]
    }

    /// The level above level `l` (the stock top above the first).
    fn above(&self, l: usize) -> f64 {
        if l == 0 { self.top } else { self.z[l - 1] }
    }
}

/// Plans `groups` in parallel: the roughing levels first (each cuts from its level up to the
/// previous roughing level), then the finer levels, limited to what their roughing level
/// left. Returns each group's roughing plan and its finer plans, top down.
///
/// `above` is the level above the first group's first level (`None` for the setup's first
/// level); the returned one is the last level's, the next call's `above`
/// ([`Ctx::clearances`]).
fn plan_groups(
    ctx: &Ctx<'_>,
    levels: &Levels<'_>,
    groups: &[Group],
    above: Option<&Nest>,
) -> (Vec<(LayerPlan, Vec<LayerPlan>)>, Option<Nest>) {
    // The groups' levels are consecutive. Runs of levels with equal keep-outs (the part
    // adds nothing to the projection) share one clearance.
    let (first, end) = match (groups.first(), groups.last()) {
        (Some(a), Some(b)) => (a.fine.start, b.rough + 1),
        _ => return (Vec::new(), above.cloned()),
    };
    let mut distinct: Vec<usize> = Vec::new();
    let mut slot: Vec<usize> = Vec::with_capacity(end - first);
    for l in first..end {
        if distinct.last().is_none_or(|&d| levels.keepout(d) != levels.keepout(l)) {
            distinct.push(l);
        }
        slot.push(distinct.len() - 1);
    }
    let keepouts: Vec<&Region2> = distinct.iter().map(|&l| levels.keepout(l)).collect();
    let clearances = ctx.clearances(&keepouts, above);
    let clearance = |l: usize| &clearances[slot[l - first]];
    let rough: Vec<LayerPlan> = groups
        .par_iter()
        .map(|g| {
            ctx.plan_layer(g.rough, levels.z[g.rough], levels.above(g.fine.start), clearance(g.rough), None)
        })
        .collect();
    let fine: Vec<(usize, usize)> =
        groups.iter().enumerate().flat_map(|(k, g)| g.fine.clone().map(move |l| (k, l))).collect();
    let mut fine_plans: Vec<Vec<LayerPlan>> =
        groups.iter().map(|g| Vec::with_capacity(g.fine.len())).collect();
    // A roughing level's free-region index, built when a finer level first needs it (groups
    // without finer levels, or whose finer levels share its keep-out, need none).
    let indices: Vec<OnceLock<RegionIndex>> = rough.iter().map(|_| OnceLock::new()).collect();
    let planned: Vec<(usize, LayerPlan)> = fine
        .par_iter()
        .map(|&(k, l)| {
            if slot[l - first] == slot[groups[k].rough - first] {
                // The same keep-out as the roughing level's: its cut, lower down at every
                // place this level's tool may stand, left nothing here.
                return (k, LayerPlan::empty(l, levels.z[l], levels.above(l), &clearance(l).free));
            }
            let roughed = Some((&rough[k].free, indices[k].get_or_init(|| rough[k].free.index())));
            (k, ctx.plan_layer(l, levels.z[l], levels.above(l), clearance(l), roughed))
        })
        .collect();
    for (k, plan) in planned {
        fine_plans[k].push(plan);
    }
    let last = distinct
        .last()
        .zip(clearances.last())
        .map(|(&l, c)| Nest { keepout: levels.keepout(l).clone(), off: c.off.clone() });
    (rough.into_iter().zip(fine_plans).collect(), last)
}

fn make_ctx<'a>(
    stock: &Aabb,
    sliver_width: f64,
    tool: &'a Tool,
    opts: &'a PlanOptions,
    rest: Option<&'a dyn RemainingMaterial>,
) -> Ctx<'a> {
    let stock = *stock;
    let clear_z = stock.max.z + opts.clearance_height;
    let start = opts
        .safe_start
        .unwrap_or_else(|| Point3::new(stock.min.x - tool.radius(), stock.min.y - tool.radius(), clear_z));
    let envelope = tool.envelope();
    Ctx { tool, envelope, opts, stock, start, rest, sliver_width, reaches: ReachCache::default() }
}

/// Plans `part` (part frame) for `setup` and streams the program into `sink`:
/// `Motion::Setup { frame }`, tool change, spindle on, the start position (Eq. 4), then per
/// layer the contour and the clearing passes in SETUP-frame coordinates, and finally a
/// retract to the clearance plane and spindle off (no program end: the caller may add
/// further setups).
pub fn plan_setup<S: MotionSink>(
    part: &Mesh,
    setup: &Setup,
    tool: &Tool,
    opts: &PlanOptions,
    sink: &mut S,
) -> Result<PlanSummary, ToolpathError<S::Error>> {
    plan_setup_rest(part, setup, tool, opts, None, sink)
}

/// [`plan_setup`] with rest machining: areas where `rest` reports no material are skipped.
pub fn plan_setup_rest<S: MotionSink>(
    part: &Mesh,
    setup: &Setup,
    tool: &Tool,
    opts: &PlanOptions,
    rest: Option<&dyn RemainingMaterial>,
    sink: &mut S,
) -> Result<PlanSummary, ToolpathError<S::Error>> {
    plan_setup_watched(part, setup, tool, opts, rest, sink, &PlanProgress::default())
}

/// How far a setup's planning has come, shared with another thread: the planner counts
/// the levels it has emitted, and stops with [`ToolpathError::Cancelled`] soon after
/// [`cancel`](Self::cancel) (before its next batch of layers, and before each layer it
/// emits).
#[derive(Debug, Default)]
pub struct PlanProgress {
    levels: std::sync::atomic::AtomicUsize,
    done: std::sync::atomic::AtomicUsize,
    cancelled: std::sync::atomic::AtomicBool,
}

impl PlanProgress {
    /// Levels emitted (or found empty) so far, and the setup's number of levels (0 until
    /// slicing is done).
    pub fn levels(&self) -> (usize, usize) {
        use std::sync::atomic::Ordering::Relaxed;
        (self.done.load(Relaxed), self.levels.load(Relaxed))
    }

    /// Asks the planner to stop.
    pub fn cancel(&self) {
        self.cancelled.store(true, std::sync::atomic::Ordering::Relaxed);
    }

    fn check<E>(&self) -> Result<(), ToolpathError<E>> {
        if self.cancelled.load(std::sync::atomic::Ordering::Relaxed) {
            Err(ToolpathError::Cancelled)
        } else {
            Ok(())
        }
    }
}

/// [`plan_setup_rest`], reporting its progress to and taking cancellation from `progress`.
pub fn plan_setup_watched<S: MotionSink>(
    part: &Mesh,
    setup: &Setup,
    tool: &Tool,
    opts: &PlanOptions,
    rest: Option<&dyn RemainingMaterial>,
    sink: &mut S,
    progress: &PlanProgress,
) -> Result<PlanSummary, ToolpathError<S::Error>> {
    use std::sync::atomic::Ordering::Relaxed;
    progress.check()?;
    let sliced = slice_levels(part, setup, tool, opts)?;
    progress.levels.store(sliced.levels.len(), Relaxed);
    let stock = sliced.stock;
    let ctx = make_ctx(&stock, sliced.sliver_width, tool, opts, rest);
    let clear_z = stock.max.z + opts.clearance_height;
    let params = LinkParams {
        // What the tool centre keeps from the keep-outs, and what arcs may leave their path
        // by without that check: the contour's thinning (its vertices keep that much more).
        wall: ctx.envelope.radius + opts.finishing_allowance + ctx.sliver_width,
        arc_slack: CONTOUR_THINNING * ctx.envelope.radius,
        clear_z: clear_z.max(ctx.start.z),
        gap: opts.retract_gap.unwrap_or(0.5 * opts.layer_height),
        max_link: opts.max_stay_down_link.unwrap_or(2.0 * tool.diameter()),
        stock,
        enter_from_air: opts.lead_in,
        local_retract: opts.lead_in,
    };
    let mut em = Emitter::new(sink, tool, opts, params, rest);
    em.begin(setup, &ctx.start, opts.strategy.name())?;
    let mut summary = PlanSummary { layers: sliced.levels.len(), stock: Some(stock), ..Default::default() };
    let (mut cut, mut air) = (0.0, 0.0);
    let groups = roughing_groups(&sliced.levels, stock.max.z, opts);
    // Batches of whole groups, at least one, up to `layers_per_batch` levels.
    let batch = opts.layers_per_batch.max(1);
    let mut batches: Vec<std::ops::Range<usize>> = Vec::new();
    let mut g0 = 0;
    while g0 < groups.len() {
        let mut g1 = g0 + 1;
        let mut count = groups[g0].fine.len() + 1;
        while g1 < groups.len() && count + groups[g1].fine.len() < batch {
            count += groups[g1].fine.len() + 1;
            g1 += 1;
        }
        batches.push(g0..g1);
        g0 = g1;
    }
    // The levels of a batch: from its first group's first level to its last group's
    // roughing level.
    let first_level = |b: &std::ops::Range<usize>| groups[b.start].fine.start;
    let end_level = |b: &std::ops::Range<usize>| groups[b.end - 1].rough + 1;
    // The keep-outs' running union is sequential: the next batch's keep-outs are computed
    // while this batch's layers are planned.
    let mut chain = Keepouts::new(sliced.slabs, sliced.min_hole_area, keepout_tolerance(&sliced.stock));
    let mut window = batches.first().map(|b| chain.advance(end_level(b))).unwrap_or_default();
    // The tool-centre keep-out of the last level planned: the next batch's grow from it.
    let mut above: Option<Nest> = None;
    for (i, b) in batches.iter().enumerate() {
        progress.check()?;
        let levels = Levels { z: &sliced.levels, top: stock.max.z, keepouts: &window, base: first_level(b) };
        let next_end = batches.get(i + 1).map(end_level);
        let ((plans, last), next) = rayon::join(
            || plan_groups(&ctx, &levels, &groups[b.clone()], above.as_ref()),
            || next_end.map(|end| chain.advance(end)).unwrap_or_default(),
        );
        above = last;
        for (rough, fine) in &plans {
            for plan in std::iter::once(rough).chain(fine) {
                progress.check()?;
                progress.done.fetch_add(1, Relaxed);
                if plan.contour.is_empty() && plan.clearing.is_empty() {
                    summary.skipped_layers += 1;
                    continue;
                }
                cut += plan.cut_air.0;
                air += plan.cut_air.1;
                em.layer(plan)?;
            }
        }
        window = next;
    }
    em.finish()?;
    let st = em.stats();
    summary.cutting_length = st.cutting_length;
    summary.rapid_length = st.rapid_length;
    summary.estimated_time_s = st.time_s;
    summary.retracts = st.retracts;
    summary.helix_entries = st.helix;
    summary.ramp_entries = st.ramp;
    summary.plunge_entries = st.plunge;
    summary.lead_in_entries = st.lead_in;
    summary.low_retracts = st.low_retracts;
    summary.air_cut_fraction = rest
        .filter(|_| opts.measure_air_cut)
        .map(|_| if cut > 0.0 { (air / cut).clamp(0.0, 1.0) } else { 0.0 });
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_material_reach_covers_the_cells_grown_by_the_radius() {
        let stock = Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(10.0, 7.0, 1.0));
        let tool = Tool::flat(0.8);
        let opts = PlanOptions { rest_cell: Some(0.25), ..PlanOptions::default() };
        let ctx = make_ctx(&stock, 0.0, &tool, &opts, None);
        let (c, nx, ny) = ctx.material_grid();
        // Scattered cells, a solid block and a ring.
        let has: Vec<bool> = (0..nx * ny)
            .map(|k| {
                let (i, j) = (k % nx, k / nx);
                (i * 7 + j * 13) % 29 == 0 || (4..9).contains(&i) && (20..26).contains(&j) || {
                    let (x, y) = (i as f64 - 28.0, j as f64 - 14.0);
                    (6.0..8.0).contains(&x.hypot(y))
                }
            })
            .collect();
        let reach = ctx.cells_reach(&has);
        let mut rects = Vec::new();
        for (k, _) in has.iter().enumerate().filter(|(_, h)| **h) {
            let (x, y) = ((k % nx) as f64 * c, (k / nx) as f64 * c);
            rects.push(vec![[x, y], [x + c, y], [x + c, y + c], [x, y + c]]);
        }
        let cells = Region2::union_contours(rects);
        // Every point within the radius of a cell is in the reach...
        let exact = cells.offset(tool.radius(), opts.arc_step);
        let missed = exact.difference(&reach).area();
        assert!(missed < 1e-9 * exact.area(), "the reach misses {missed} of {}", exact.area());
        // ... and nothing farther than the radius and a cell's diagonal.
        let loose = cells.offset(tool.radius() + c * std::f64::consts::SQRT_2, opts.arc_step);
        let extra = reach.difference(&loose).area();
        assert!(extra < 1e-9 * reach.area(), "the reach goes {extra} beyond a cell's diagonal");
        assert!(reach.area() > exact.area() && reach.area() < loose.area());
        // No cells, no reach.
        assert!(ctx.cells_reach(&vec![false; nx * ny]).is_empty());
    }
}
