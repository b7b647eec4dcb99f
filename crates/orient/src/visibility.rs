//! Visibility of surface samples from tool directions, as bitsets.
//!
//! # Convention
//!
//! A direction `v` here is the **tool axis**, pointing from the part towards the
//! spindle (the setup's +Z in the part frame, [`s2g_geom::Setup::tool_axis`]). The tool
//! travels along `-v` to reach the part. A sample `p` with outward normal `n` is
//! reachable from `v` when `n . v > 0` and the ray from `p + eps n` along `+v` leaves
//! the part's bounding box without hitting the part.
//!
//! The Shape2Gcode paper (seed 000, §3.1) writes "casting a ray from p along -v": its
//! `v` is the *approach* direction of the tool (spindle towards part). Both describe the
//! same ray, from the point back towards the spindle; only the sign of `v` differs.

use rayon::prelude::*;
use s2g_geom::{
    Aabb, Mesh, MeshIndex, OccluderCache, ParallelRays, Point3, Real, SurfaceSamples, UnitVector3, Vector3,
};

use crate::directions::orthonormal_basis;
use crate::error::{OrientError, Result};
use crate::tool_reach::{ToolReach, ball_clearance, sample_gaps};

/// How visibility is decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VisibilityOptions {
    /// Offset of each ray's origin along the sample's normal, relative to the part's
    /// bounding-box diagonal, so that the ray does not hit the sample's own triangle.
    /// Default `1e-5`.
    pub eps: Real,
    /// A sample is only visible from `v` when `n . v > min_cos`. Default `0.0` (the
    /// paper's front-facing test); raise it to forbid grazing cuts.
    pub min_cos: Real,
    /// Tool-aware mode: the radius of a ball-end tool (part units). The ball touching the
    /// sample (centre at `p + r n`) and the cylinder above it along `v` must be free:
    /// checked by the ray from the ball's centre and `tool_rays` rays from its equator
    /// (perpendicular to `v`), all along `+v`. `None` (default): the paper's single ray.
    pub tool_radius: Option<Real>,
    /// Number of offset rays in tool-aware mode. Default `8`.
    pub tool_rays: usize,
    /// Skip the ray for samples on *supporting* triangles (the whole mesh lies on or
    /// below the triangle's plane, e.g. convex-hull facets): a ray that rises off such a
    /// plane cannot hit anything, so these samples are visible exactly when front-facing.
    /// Exact, not an approximation; only used without `tool_radius`, and only on meshes of
    /// at most `hull_cull_max_work` triangle-vertex pairs. Default `true`.
    pub hull_cull: bool,
    /// Work cap of the supporting-triangle test (triangles x vertices). Default `4e8`.
    pub hull_cull_max_work: f64,
    /// How deep the tools reach into the stock: a sample is visible from `v` only where it
    /// lies at most [`ToolReach::depth`] below the stock's top along `v`. `None` (default):
    /// tools of unlimited length, as in the paper.
    pub reach: Option<ToolReach>,
}

impl Default for VisibilityOptions {
    fn default() -> Self {
        Self {
            eps: 1e-5,
            min_cos: 0.0,
            tool_radius: None,
            tool_rays: 8,
            hull_cull: true,
            hull_cull_max_work: 4e8,
            reach: None,
        }
    }
}

/// Which triangles support the mesh: every vertex lies on or below the triangle's plane
/// (within `tol`). Degenerate triangles never do. In parallel over triangles; the
/// vertices most likely to violate (extremes along 26 directions) are tried first.
pub fn supporting_triangles(mesh: &Mesh, tol: Real) -> Vec<bool> {
    let verts = mesh.vertices();
    let mut order: Vec<usize> = Vec::new();
    for dx in -1i32..=1 {
        for dy in -1i32..=1 {
            for dz in -1i32..=1 {
                if dx == 0 && dy == 0 && dz == 0 {
                    continue;
                }
                let d = Vector3::new(dx as Real, dy as Real, dz as Real);
                let best = (0..verts.len())
                    .max_by(|&a, &b| verts[a].coords.dot(&d).total_cmp(&verts[b].coords.dot(&d)));
                if let Some(b) = best
                    && !order.contains(&b)
                {
                    order.push(b);
                }
            }
        }
    }
    let first: Vec<usize> = order.clone();
    order.extend((0..verts.len()).filter(|i| !first.contains(i)));
    (0..mesh.triangles().len())
        .into_par_iter()
        .map(|t| {
            let Some(n) = mesh.face_normal(t) else { return false };
            let a = mesh.triangle(t)[0];
            let h = n.dot(&a.coords) + tol;
            order.iter().all(|&i| n.dot(&verts[i].coords) <= h)
        })
        .collect()
}

/// Number of `u64` words for a bitset over `n` items.
#[inline]
pub fn words_for(n: usize) -> usize {
    n.div_ceil(64)
}

/// Number of set bits.
#[inline]
pub fn popcount(bits: &[u64]) -> usize {
    bits.iter().map(|w| w.count_ones() as usize).sum()
}

/// Surface samples prepared for visibility queries against a mesh's BVH.
pub struct VisibilityContext<'a> {
    index: &'a MeshIndex,
    points: &'a [Point3],
    normals: &'a [Vector3],
    /// The part's bounding box, grown by the ray offset.
    bbox: Aabb,
    eps: Real,
    opts: VisibilityOptions,
    /// Samples on supporting triangles (bitset), when the hull cull is on.
    supported: Option<Vec<u64>>,
    /// The mesh's vertices, for the support height of a direction.
    vertices: Vec<Point3>,
    /// With a tool-aware reach, what each sample leaves room for ([`SampleRoom`]).
    room: Option<SampleRoom>,
}

/// How near, as a share of its radius, the narrowest tool reaching a sample's depth must
/// come to a sample whose ball clearance is less than that radius (a concave fold of the
/// surface narrower than the tool) for the sample to count as reached (issue 36): the
/// bundled bunny's folds are 1 to 3 mm across and the tools reaching them 4 to 6 mm in
/// radius, which leave a skin there that the simulation's half voxel does not cover, yet
/// no setup more cuts it better. A blind hole narrower than the tool stops it more than
/// half its radius above the floor wherever the hole is deeper than 1.5 times the radius.
const FOLD_SKIN: Real = 0.5;

/// What a tool-aware reach knows of each sample's surroundings, direction aside.
struct SampleRoom {
    /// How deep below the stock's top the sample is reached: [`ToolReach::depth_within`]
    /// its gap (a tool no narrower than the gap does not fit).
    depths: Vec<Real>,
    /// The radius of the largest ball tangent to the surface at the sample that holds no
    /// part ([`ball_clearance`]), at most the widest tool's: a tool no wider fits there
    /// without more rays.
    clearance: Vec<Real>,
    /// The unit direction from the part's point that bounds that ball to the sample (zero
    /// where the ball reached the cap): away from the wall beside a floor.
    away: Vec<Vector3>,
}

/// Where a tool is tried beside a sample: its point and outward normal, the tool's
/// radius, how far off the point the tool stands, and how far inside the tool's rim its
/// rays start (the reach's slack): a tool that comes within the slack of the part
/// elsewhere counts as clear of it, as a tool no wider than the sample's ball clearance
/// plus the slack fits without rays (gearwheel_40t's tooth gaps, about the 1 mm end
/// mill's width at their roots, count as reached from +Z and -Z).
struct Place<'p> {
    p: &'p Point3,
    n: &'p Vector3,
    r: Real,
    standoff: Real,
    give: Real,
}

/// The rays of one direction: its axis, what its rays share, the occluder of the last.
struct Rays<'r, 'a> {
    v: &'r Vector3,
    probe: &'r Probe<'a>,
    cache: &'r mut OccluderCache,
}

/// What the rays of one direction share.
struct Probe<'a> {
    /// The triangles binned across the direction, when a row of rays pays for it
    /// (answers as the BVH does, faster for a whole row of samples).
    rays: Option<ParallelRays<'a>>,
    /// `orthonormal_basis(v)`, for the offset rays of tool-aware mode.
    basis: (Vector3, Vector3),
    /// The support height `max over vertices of v . x`, plus the grown margin: past the
    /// plane `v . x = top` a ray along `v` cannot meet the part, so rays stop there (on
    /// oblique directions well before the bounding box's exit).
    top: Real,
    /// The lowest height `v . x` the tools reach ([`ToolReach::floor`]); `-inf` without
    /// a reach.
    floor: Real,
    /// The stock's top along the direction ([`ToolReach::top`]), from which a tool-aware
    /// reach's per-sample depths count.
    stock_top: Real,
}

impl std::fmt::Debug for VisibilityContext<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("VisibilityContext")
            .field("points", &self.points.len())
            .field("bbox", &self.bbox)
            .field("eps", &self.eps)
            .finish()
    }
}

impl<'a> VisibilityContext<'a> {
    /// Prepares `samples` of `mesh`, whose BVH is `index`. Errors on invalid options, a
    /// mesh without vertices or mismatched sample arrays.
    pub fn new(
        mesh: &Mesh,
        index: &'a MeshIndex,
        samples: &'a SurfaceSamples,
        opts: &VisibilityOptions,
    ) -> Result<Self> {
        let bbox = mesh.bbox().ok_or_else(|| OrientError::NoSurface("the mesh has no vertices".into()))?;
        let n = samples.points.len();
        if samples.normals.len() != n || !(samples.triangles.len() == n || samples.triangles.is_empty()) {
            return Err(OrientError::InvalidArgument(format!(
                "{} sample points but {} normals and {} triangle ids",
                n,
                samples.normals.len(),
                samples.triangles.len()
            )));
        }
        if !(opts.eps.is_finite() && opts.eps >= 0.0 && opts.min_cos.is_finite() && opts.min_cos < 1.0) {
            return Err(OrientError::InvalidArgument(format!(
                "visibility needs eps >= 0 and min_cos < 1, got {} and {}",
                opts.eps, opts.min_cos
            )));
        }
        if let Some(r) = opts.tool_radius
            && !(r.is_finite() && r >= 0.0)
        {
            return Err(OrientError::InvalidArgument(format!("tool radius must be >= 0, got {r}")));
        }
        if let Some(r) = &opts.reach
            && !(r.depth.is_finite()
                && r.depth >= 0.0
                && r.stock.min.coords.iter().chain(r.stock.max.coords.iter()).all(|v| v.is_finite()))
        {
            return Err(OrientError::InvalidArgument(format!(
                "tool reach needs a finite stock and depth >= 0, got {:?} and {}",
                r.stock, r.depth
            )));
        }
        let diag = bbox.extent().norm();
        let eps = opts.eps * diag;
        let grow = eps + opts.tool_radius.unwrap_or(0.0);
        let work = mesh.triangles().len() as f64 * mesh.vertices().len() as f64;
        let supported = (opts.hull_cull
            && opts.tool_radius.is_none()
            && work <= opts.hull_cull_max_work
            && samples.triangles.len() == n
            && n > 0)
            .then(|| {
                // Far below the ray offset, so a ray rising off the plane clears every vertex.
                let flags = supporting_triangles(mesh, 1e-9 * diag);
                let mut bits = vec![0u64; words_for(n)];
                for (i, &t) in samples.triangles.iter().enumerate() {
                    if flags.get(t as usize).copied().unwrap_or(false) {
                        bits[i / 64] |= 1 << (i % 64);
                    }
                }
                bits
            });
        let room = opts.reach.filter(|r| !r.tools().is_empty()).map(|r| {
            let gaps = sample_gaps(index, &samples.points, &samples.normals, eps, diag);
            let widest = r.tools().last().map_or(0.0, |t| t.radius);
            let (clearance, away) = (&samples.points, &samples.normals, &gaps)
                .into_par_iter()
                .map(|(p, n, &gap)| ball_clearance(index, p, n, (0.5 * gap).min(widest), eps))
                .unzip();
            SampleRoom { depths: gaps.iter().map(|&w| r.depth_within(w)).collect(), clearance, away }
        });
        Ok(Self {
            index,
            points: &samples.points,
            normals: &samples.normals,
            bbox: bbox.inflated(grow),
            eps,
            opts: *opts,
            supported,
            vertices: mesh.vertices().to_vec(),
            room,
        })
    }

    /// With a tool-aware reach, how deep below the stock's top sample `i` is reached
    /// ([`ToolReach::depth_within`] the free distance in front of it); `None` otherwise.
    pub fn sample_depth(&self, i: usize) -> Option<Real> {
        self.room.as_ref().and_then(|r| r.depths.get(i).copied())
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Number of samples on supporting triangles (whose rays are skipped), 0 when the
    /// cull is off.
    pub fn supported_samples(&self) -> usize {
        self.supported.as_ref().map_or(0, |s| popcount(s))
    }

    /// Number of `u64` words in one direction's bitset.
    pub fn words(&self) -> usize {
        words_for(self.points.len())
    }

    /// Distance from `o` along `v` to the exit of the (grown) bounding box; 0 outside.
    #[inline]
    fn exit_distance(&self, o: &Point3, v: &Vector3) -> Real {
        let mut t = Real::INFINITY;
        for a in 0..3 {
            if v[a] > 0.0 {
                t = t.min((self.bbox.max[a] - o[a]) / v[a]);
            } else if v[a] < 0.0 {
                t = t.min((self.bbox.min[a] - o[a]) / v[a]);
            }
        }
        if t.is_finite() { t.max(0.0) } else { 0.0 }
    }

    /// The shared data of direction `v`'s rays, for a row of `samples` samples.
    fn probe(&self, v: &UnitVector3, samples: usize) -> Probe<'a> {
        let top = self.vertices.iter().map(|p| v.dot(&p.coords)).fold(Real::NEG_INFINITY, Real::max);
        let grow = self.eps + self.opts.tool_radius.unwrap_or(0.0);
        // Binning a triangle costs about as much as a ray, and about half the samples of
        // a row (the front-facing ones) cast one.
        let worth = 2 * self.index.num_triangles() <= samples;
        let rays = worth.then(|| self.index.parallel_rays(v)).flatten();
        let (floor, stock_top) = self.levels(v);
        Probe { rays, basis: orthonormal_basis(v), top: top + grow, floor, stock_top }
    }

    /// The lowest height along `v` the tools reach ([`ToolReach::floor`]) and the stock's
    /// top along it ([`ToolReach::top`]), the top computed once: `-inf` and `inf` without
    /// a reach.
    fn levels(&self, v: &Vector3) -> (Real, Real) {
        self.opts.reach.map_or((Real::NEG_INFINITY, Real::INFINITY), |r| {
            let top = r.top(v);
            (top - r.depth, top)
        })
    }

    /// Whether a ray from `o` along `v` leaves the box, or passes the support plane of
    /// `probe`, without hitting the part.
    /// `cache` holds the triangle that blocked the last ray of the run.
    #[inline]
    fn free(&self, o: &Point3, v: &Vector3, probe: &Probe<'_>, cache: &mut OccluderCache) -> bool {
        let t = self.exit_distance(o, v).min(probe.top - v.dot(&o.coords));
        t <= 0.0
            || !match &probe.rays {
                Some(rays) => rays.hits_any(o, t, cache),
                None => self.index.ray_hits_any_cached(o, v, t, cache),
            }
    }

    /// Whether sample `i` is visible from tool axis `v` (see the module docs).
    /// `probe` is `self.probe(v)`.
    #[inline]
    fn visible_with(&self, i: usize, v: &Vector3, probe: &Probe<'_>, cache: &mut OccluderCache) -> bool {
        let n = &self.normals[i];
        if n.dot(v).partial_cmp(&self.opts.min_cos) != Some(std::cmp::Ordering::Greater) {
            return false;
        }
        let p = &self.points[i];
        let h = v.dot(&p.coords);
        if h < probe.floor {
            return false;
        }
        // Tool-aware reach: only as deep as a tool that fits reaches; where the sample's
        // room is less than the narrowest tool reaching its depth, that tool must fit
        // there (below).
        let mut tight = None;
        if let (Some(room), Some(reach)) = (&self.room, &self.opts.reach) {
            let depth = probe.stock_top - h;
            if depth > room.depths[i] {
                return false;
            }
            tight = reach
                .narrowest_reaching(depth)
                .filter(|&r| r > room.clearance[i] + reach.slack)
                .zip(Some(room.away[i]));
        }
        let slack = self.opts.reach.map_or(0.0, |r| r.slack);
        // A round tool wider than a fold of the surface leaves a skin in it: counted
        // reached where the tool comes within `FOLD_SKIN` of its radius (a crease of the
        // bunny), not where it stops further off (a hole's floor below a tool too wide).
        let fits = |r: Real, away: Vector3, cache: &mut OccluderCache| {
            let mut ray = Rays { v, probe, cache };
            self.ball_free(&Place { p, n, r, standoff: (FOLD_SKIN * r).max(slack), give: slack }, &mut ray)
                || self.flat_free(&Place { p, n, r, standoff: slack, give: slack }, &away, &mut ray)
        };
        match self.opts.tool_radius {
            None => {
                let seen = self.supported.as_ref().is_some_and(|s| s[i / 64] >> (i % 64) & 1 == 1)
                    || self.free(&(p + n * self.eps), v, probe, cache);
                seen && tight.is_none_or(|(r, away)| fits(r, away, cache))
            }
            Some(r) => match tight {
                Some((t, away)) if t > r => fits(t, away, cache),
                _ => self
                    .ball_free(&Place { p, n, r, standoff: 0.0, give: 0.0 }, &mut Rays { v, probe, cache }),
            },
        }
    }

    /// Whether a flat end mill of radius `place.r` along the axis whose bottom's rim
    /// passes through the sample point (or `standoff` off it), its centre `r` from it
    /// along `away` (projected across the axis), and the cylinder above it are free: a
    /// floor beside a wall, which the tool's bottom cuts with its side against the wall.
    /// False where `away` has no part across the axis.
    fn flat_free(&self, place: &Place<'_>, away: &Vector3, ray: &mut Rays<'_, '_>) -> bool {
        let v = ray.v;
        let Some(w) = (away - v * v.dot(away)).try_normalize(1e-9) else { return false };
        let c = place.p + place.n * (self.eps + place.standoff) + w * place.r;
        self.disc_free(&c, (place.r - place.give).max(0.0), ray)
    }

    /// Whether a ball of radius `place.r` `standoff` off the sample point (along its
    /// normal) and the cylinder above it along the axis are free: the ray from the ball's
    /// centre and `tool_rays` rays from its equator.
    fn ball_free(&self, place: &Place<'_>, ray: &mut Rays<'_, '_>) -> bool {
        let c = place.p + place.n * (place.r + place.standoff + self.eps);
        self.disc_free(&c, (place.r - place.give).max(0.0), ray)
    }

    /// Whether the disc of radius `r` centred on `c` across the axis and the cylinder
    /// above it are free: the ray from `c` along the axis and `tool_rays` rays from the
    /// disc's rim.
    fn disc_free(&self, c: &Point3, r: Real, ray: &mut Rays<'_, '_>) -> bool {
        let Rays { v, probe, cache } = ray;
        if !self.free(c, v, probe, cache) {
            return false;
        }
        let k = self.opts.tool_rays;
        (0..k).all(|j| {
            let t = std::f64::consts::TAU * j as Real / k as Real;
            let off = (probe.basis.0 * t.cos() + probe.basis.1 * t.sin()) * r;
            self.free(&(c + off), v, probe, cache)
        })
    }

    /// Whether sample `i` is visible from tool axis `v`. One sample does not pay for the
    /// support plane (a pass over every vertex): its rays run to the box's exit, which
    /// gives the same answer.
    pub fn visible(&self, i: usize, v: &UnitVector3) -> bool {
        let (floor, stock_top) = self.levels(v);
        let probe = Probe { rays: None, basis: orthonormal_basis(v), top: Real::INFINITY, floor, stock_top };
        i < self.points.len() && self.visible_with(i, v, &probe, &mut OccluderCache::default())
    }

    /// Writes the bitset of samples visible from `v` into `out` (`words()` long),
    /// sequentially.
    pub fn row_into(&self, v: &UnitVector3, out: &mut [u64]) {
        self.fill_words(v, &self.probe(v, self.points.len()), 0, out);
    }

    fn fill_words(&self, v: &UnitVector3, probe: &Probe<'_>, first_word: usize, out: &mut [u64]) {
        self.fill_words_masked(v, probe, first_word, out, None);
    }

    /// Fills `out` with visibility bits, skipping (leaving clear) the samples set in `skip`.
    fn fill_words_masked(
        &self,
        v: &UnitVector3,
        probe: &Probe<'_>,
        first_word: usize,
        out: &mut [u64],
        skip: Option<&[u64]>,
    ) {
        let n = self.points.len();
        // Samples are in spatial order, so consecutive rays start close together.
        let mut cache = OccluderCache::default();
        for (w, word) in out.iter_mut().enumerate() {
            let base = (first_word + w) * 64;
            let valid = if n - base.min(n) >= 64 { u64::MAX } else { (1u64 << (n - base.min(n))) - 1 };
            let mut todo = valid & !skip.map_or(0, |s| s[first_word + w]);
            let mut bits = 0u64;
            while todo != 0 {
                let b = todo.trailing_zeros() as usize;
                todo &= todo - 1;
                if self.visible_with(base + b, v, probe, &mut cache) {
                    bits |= 1 << b;
                }
            }
            *word = bits;
        }
    }

    /// The bitset of samples visible from `v` among those *not* set in `skip` (samples in
    /// `skip` come out clear), in parallel over the samples. Coverage of a union only
    /// needs the samples that the rest does not cover yet, so this is what refinement and
    /// incremental coverage use. `skip` must be `words()` long.
    pub fn row_masked(&self, v: &UnitVector3, skip: &[u64]) -> Result<Vec<u64>> {
        if skip.len() != self.words() {
            return Err(OrientError::InvalidArgument(format!(
                "mask has {} words, expected {}",
                skip.len(),
                self.words()
            )));
        }
        let todo = self.points.len() - popcount(skip).min(self.points.len());
        let probe = self.probe(v, todo);
        let mut out = vec![0u64; self.words()];
        out.par_chunks_mut(8)
            .enumerate()
            .for_each(|(c, chunk)| self.fill_words_masked(v, &probe, c * 8, chunk, Some(skip)));
        Ok(out)
    }

    /// The bitset of samples visible from `v`, computed in parallel over the samples
    /// (for one direction at a time, e.g. refinement).
    pub fn row(&self, v: &UnitVector3) -> Vec<u64> {
        let probe = self.probe(v, self.points.len());
        let mut out = vec![0u64; self.words()];
        out.par_chunks_mut(8).enumerate().for_each(|(c, chunk)| self.fill_words(v, &probe, c * 8, chunk));
        out
    }

    /// The visibility matrix of all samples against `dirs`, in parallel over directions.
    pub fn matrix(&self, dirs: &[UnitVector3]) -> VisibilityMatrix {
        let words = self.words();
        let mut bits = vec![0u64; dirs.len() * words];
        if words > 0 {
            bits.par_chunks_mut(words).zip(dirs.par_iter()).for_each(|(row, v)| self.row_into(v, row));
        }
        VisibilityMatrix { points: self.len(), words, directions: dirs.to_vec(), bits }
    }

    /// The visibility matrix, in parallel over samples (each worker walks every
    /// direction for a block of 64 samples); the alternative schedule to [`Self::matrix`].
    pub fn matrix_by_points(&self, dirs: &[UnitVector3]) -> VisibilityMatrix {
        let words = self.words();
        let probes: Vec<Probe<'_>> = dirs.iter().map(|v| self.probe(v, self.points.len())).collect();
        // Column blocks: block w holds word w of every direction.
        let blocks: Vec<Vec<u64>> = (0..words)
            .into_par_iter()
            .map(|w| {
                let mut col = vec![0u64; dirs.len()];
                for (d, v) in dirs.iter().enumerate() {
                    self.fill_words(v, &probes[d], w, std::slice::from_mut(&mut col[d]));
                }
                col
            })
            .collect();
        let mut bits = vec![0u64; dirs.len() * words];
        for (w, col) in blocks.iter().enumerate() {
            for (d, &x) in col.iter().enumerate() {
                bits[d * words + w] = x;
            }
        }
        VisibilityMatrix { points: self.len(), words, directions: dirs.to_vec(), bits }
    }
}

/// Which samples are visible from which directions: one bitset (`u64` words, sample
/// `i` is bit `i % 64` of word `i / 64`) per direction.
#[derive(Debug, Clone, PartialEq)]
pub struct VisibilityMatrix {
    points: usize,
    words: usize,
    directions: Vec<UnitVector3>,
    bits: Vec<u64>,
}

impl VisibilityMatrix {
    /// A matrix from per-direction bitsets; errors when a row has the wrong length.
    pub fn from_rows(points: usize, rows: Vec<(UnitVector3, Vec<u64>)>) -> Result<Self> {
        let words = words_for(points);
        let mut m = Self { points, words, directions: Vec::new(), bits: Vec::new() };
        for (d, r) in rows {
            m.push(d, &r)?;
        }
        Ok(m)
    }

    /// Appends a direction and its bitset; returns its index.
    pub fn push(&mut self, direction: UnitVector3, row: &[u64]) -> Result<usize> {
        if row.len() != self.words {
            return Err(OrientError::InvalidArgument(format!(
                "visibility row has {} words, expected {}",
                row.len(),
                self.words
            )));
        }
        self.directions.push(direction);
        // Clear bits past the last sample so that counts stay exact.
        let start = self.bits.len();
        self.bits.extend_from_slice(row);
        let tail = self.points % 64;
        if tail != 0 && self.words > 0 {
            let last = start + self.words - 1;
            self.bits[last] &= (1u64 << tail) - 1;
        }
        Ok(self.directions.len() - 1)
    }

    /// Number of samples.
    pub fn points(&self) -> usize {
        self.points
    }

    /// Number of words per row.
    pub fn words(&self) -> usize {
        self.words
    }

    /// The directions, one per row.
    pub fn directions(&self) -> &[UnitVector3] {
        &self.directions
    }

    /// Number of directions.
    pub fn len(&self) -> usize {
        self.directions.len()
    }

    /// Whether there is no direction.
    pub fn is_empty(&self) -> bool {
        self.directions.is_empty()
    }

    /// The bitset of direction `d`.
    #[inline]
    pub fn row(&self, d: usize) -> &[u64] {
        &self.bits[d * self.words..(d + 1) * self.words]
    }

    /// Whether sample `i` is visible from direction `d`.
    pub fn get(&self, i: usize, d: usize) -> bool {
        i < self.points && self.row(d)[i / 64] >> (i % 64) & 1 == 1
    }

    /// The union of the rows in `set`.
    pub fn union(&self, set: &[usize]) -> Vec<u64> {
        let mut u = vec![0u64; self.words];
        for &d in set {
            for (a, b) in u.iter_mut().zip(self.row(d)) {
                *a |= b;
            }
        }
        u
    }

    /// Number of samples visible from at least one direction of `set`.
    pub fn covered(&self, set: &[usize]) -> usize {
        popcount(&self.union(set))
    }

    /// Fraction of samples visible from at least one direction of `set` (0 without samples).
    pub fn coverage(&self, set: &[usize]) -> Real {
        self.fraction(self.covered(set))
    }

    /// `covered` samples as a fraction of all (0 without samples): [`Self::coverage`] of a
    /// set whose [`Self::covered`] count is known.
    pub(crate) fn fraction(&self, covered: usize) -> Real {
        if self.points == 0 { 0.0 } else { covered as Real / self.points as Real }
    }

    /// Fraction of samples visible from any direction: the upper bound on coverage.
    pub fn upper_bound(&self) -> Real {
        self.coverage(&(0..self.len()).collect::<Vec<_>>())
    }
}
