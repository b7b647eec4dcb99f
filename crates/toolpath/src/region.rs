//! [`Region2`]: a 2-D multipolygon (outer boundaries with holes) and [`Polyline2`], with
//! booleans and offsets delegated to `i_overlay`.
//!
//! Orientation convention (that of `i_overlay`): outer boundaries counter-clockwise,
//! holes clockwise, so the filled region is always on the left of a boundary.

use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay_rule::OverlayRule;
use i_overlay::float::clip::FloatClip;
use i_overlay::float::simplify::SimplifyShape;
use i_overlay::float::single::SingleFloatOverlay;
use i_overlay::mesh::float::outline::offset::OutlineOffset;
use i_overlay::mesh::float::style::{LineJoin, OutlineStyle};
use i_overlay::string::clip::ClipRule;

/// A point in the plane.
pub type Point2 = nalgebra::Point2<f64>;
/// A vector in the plane.
pub type Vector2 = nalgebra::Vector2<f64>;

type Raw = [f64; 2];

/// A polyline in the plane; `closed` loops return to their first point (which is not repeated).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Polyline2 {
    /// Vertices in order.
    pub points: Vec<Point2>,
    /// Whether the last point connects back to the first.
    pub closed: bool,
}

impl Polyline2 {
    /// An open polyline.
    pub fn open(points: Vec<Point2>) -> Self {
        Self { points, closed: false }
    }

    /// A closed loop.
    pub fn closed(points: Vec<Point2>) -> Self {
        Self { points, closed: true }
    }

    /// Length, including the closing segment of a loop.
    pub fn length(&self) -> f64 {
        let mut l: f64 = self.points.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
        if self.closed && self.points.len() > 2 {
            l += (self.points[0] - self.points[self.points.len() - 1]).norm();
        }
        l
    }

    /// The segments, including the closing one of a loop.
    pub fn segments(&self) -> impl Iterator<Item = (Point2, Point2)> + '_ {
        let n = self.points.len();
        let m = if self.closed && n > 2 { n } else { n.saturating_sub(1) };
        (0..m).map(move |i| (self.points[i], self.points[(i + 1) % n]))
    }

    /// The first point, if any.
    pub fn start(&self) -> Option<Point2> {
        self.points.first().copied()
    }

    /// The point where the path ends (the start again for a loop).
    pub fn end(&self) -> Option<Point2> {
        if self.closed { self.points.first().copied() } else { self.points.last().copied() }
    }

    /// Signed area of the loop (positive when counter-clockwise).
    pub fn signed_area(&self) -> f64 {
        signed_area(self.points.iter().map(|p| [p.x, p.y]))
    }

    /// For a loop: rotates the vertex order so that it starts at the vertex nearest `p`.
    pub fn rotate_to_nearest(&mut self, p: &Point2) {
        if !self.closed || self.points.is_empty() {
            return;
        }
        let i = nearest_index(&self.points, p);
        self.points.rotate_left(i);
    }

    /// Bounding box `(min, max)` of the vertices; `None` when there are none.
    pub fn bbox(&self) -> Option<(Point2, Point2)> {
        bbox_of(self.points.iter().map(|p| [p.x, p.y]))
    }

    /// The pieces of the polyline outside `region` (given by its index): segments that
    /// stay inside it or within `tol` of its boundary are left out, in the original
    /// direction of travel. A polyline with no such segment comes back whole.
    pub fn outside(self, region: &RegionIndex, tol: f64) -> Vec<Polyline2> {
        let n = self.points.len();
        let segs = if self.closed { n } else { n.saturating_sub(1) };
        let inside: Vec<bool> = (0..segs)
            .map(|i| region.segment_inside(&self.points[i], &self.points[(i + 1) % n], tol))
            .collect();
        if !inside.contains(&true) {
            return vec![self];
        }
        // Start where a kept run begins: after an inside segment (a loop) or at the start.
        let first = if self.closed { inside.iter().position(|&x| x).map_or(0, |i| i + 1) } else { 0 };
        let mut out = Vec::new();
        let mut run: Vec<Point2> = Vec::new();
        for k in 0..segs {
            let i = (first + k) % segs;
            if inside[i] {
                // A run holds no point or two and more.
                if !run.is_empty() {
                    out.push(Polyline2::open(std::mem::take(&mut run)));
                }
            } else {
                if run.is_empty() {
                    run.push(self.points[i]);
                }
                run.push(self.points[(i + 1) % n]);
            }
        }
        if run.len() >= 2 {
            out.push(Polyline2::open(run));
        }
        out
    }

    /// Reverses the direction of travel (a loop keeps its start point).
    pub fn reverse(&mut self) {
        if self.closed && self.points.len() > 1 {
            self.points[1..].reverse();
        } else {
            self.points.reverse();
        }
    }
}

/// Bounding box `(min, max)` of `points`; `None` when there are none.
fn bbox_of(points: impl IntoIterator<Item = Raw>) -> Option<(Point2, Point2)> {
    let mut points = points.into_iter();
    let first = points.next()?;
    let (lo, hi) = points.fold((first, first), |(lo, hi), p| {
        ([lo[0].min(p[0]), lo[1].min(p[1])], [hi[0].max(p[0]), hi[1].max(p[1])])
    });
    Some((Point2::new(lo[0], lo[1]), Point2::new(hi[0], hi[1])))
}

pub(crate) fn nearest_index(points: &[Point2], p: &Point2) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (i, q) in points.iter().enumerate() {
        let d = (q - p).norm_squared();
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}

fn signed_area(pts: impl Iterator<Item = Raw> + Clone) -> f64 {
    let v: Vec<Raw> = pts.collect();
    let n = v.len();
    if n < 3 {
        return 0.0;
    }
    let mut a = 0.0;
    for i in 0..n {
        let p = v[i];
        let q = v[(i + 1) % n];
        a += p[0] * q[1] - q[0] * p[1];
    }
    0.5 * a
}

/// A filled 2-D region: a set of shapes, each an outer boundary (counter-clockwise)
/// followed by its holes (clockwise). Produced only by this module's operations, so
/// its boundaries never cross.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Region2 {
    shapes: Vec<Vec<Vec<Raw>>>,
}

impl Region2 {
    /// The empty region.
    pub fn empty() -> Self {
        Self::default()
    }

    /// Whether the region has no shape.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// The axis-aligned rectangle `[min, max]` (empty when degenerate or not finite).
    pub fn rect(min: Point2, max: Point2) -> Self {
        let finite = min.coords.iter().chain(max.coords.iter()).all(|c| c.is_finite());
        if !(min.x < max.x && min.y < max.y && finite) {
            return Self::empty();
        }
        Self { shapes: vec![vec![vec![[min.x, min.y], [max.x, min.y], [max.x, max.y], [min.x, max.y]]]] }
    }

    /// The union of simple polygons given by their vertices, each in either orientation.
    /// Polygons with fewer than three vertices, non-finite coordinates or no area are skipped.
    pub fn from_polygons<'a>(polygons: impl IntoIterator<Item = &'a [Point2]>) -> Self {
        let contours: Vec<Vec<Raw>> = polygons
            .into_iter()
            .filter_map(|poly| {
                let c: Vec<Raw> = poly.iter().map(|p| [p.x, p.y]).collect();
                ccw_contour(c)
            })
            .collect();
        Self::union_contours(contours)
    }

    /// Union of counter-clockwise contours (non-zero fill).
    pub(crate) fn union_contours(contours: Vec<Vec<Raw>>) -> Self {
        if contours.is_empty() {
            return Self::empty();
        }
        Self { shapes: contours.simplify_shape(FillRule::NonZero) }
    }

    /// The shapes: for each, the outer boundary then the holes, as point lists.
    pub fn shapes(&self) -> impl Iterator<Item = Vec<Vec<Point2>>> + '_ {
        self.shapes
            .iter()
            .map(|s| s.iter().map(|c| c.iter().map(|p| Point2::new(p[0], p[1])).collect()).collect())
    }

    /// Number of shapes (connected components).
    pub fn shape_count(&self) -> usize {
        self.shapes.len()
    }

    /// Total number of boundary vertices.
    pub fn vertex_count(&self) -> usize {
        self.shapes.iter().flatten().map(Vec::len).sum()
    }

    /// Every boundary loop as a closed polyline (outer counter-clockwise, holes clockwise).
    pub fn loops(&self) -> Vec<Polyline2> {
        self.shapes
            .iter()
            .flatten()
            .map(|c| Polyline2::closed(c.iter().map(|p| Point2::new(p[0], p[1])).collect()))
            .collect()
    }

    /// Each connected component as its own region.
    pub fn components(&self) -> Vec<Region2> {
        self.shapes.iter().map(|s| Region2 { shapes: vec![s.clone()] }).collect()
    }

    /// Area.
    pub fn area(&self) -> f64 {
        self.shapes.iter().flatten().map(|c| signed_area(c.iter().copied())).sum()
    }

    /// Bounding box `(min, max)`; `None` when empty.
    pub fn bbox(&self) -> Option<(Point2, Point2)> {
        bbox_of(self.shapes.iter().flatten().flatten().copied())
    }

    /// The bounding box of each shape (that of its outer boundary, which holds its holes).
    pub(crate) fn shape_bboxes(&self) -> Vec<(Point2, Point2)> {
        self.shapes.iter().filter_map(|s| bbox_of(s.first()?.iter().copied())).collect()
    }

    fn boolean(&self, other: &Region2, rule: OverlayRule) -> Region2 {
        Region2 { shapes: self.shapes.overlay(&other.shapes, rule, FillRule::NonZero) }
    }

    /// `self ∪ other`.
    pub fn union(&self, other: &Region2) -> Region2 {
        if other.is_empty() {
            return self.clone();
        }
        if self.is_empty() {
            return other.clone();
        }
        self.boolean(other, OverlayRule::Union)
    }

    /// `self ∖ other`.
    pub fn difference(&self, other: &Region2) -> Region2 {
        if self.is_empty() || other.is_empty() {
            return self.clone();
        }
        self.boolean(other, OverlayRule::Difference)
    }

    /// `self ∩ other`.
    pub fn intersection(&self, other: &Region2) -> Region2 {
        if self.is_empty() || other.is_empty() {
            return Region2::empty();
        }
        self.boolean(other, OverlayRule::Intersect)
    }

    /// The region grown (`distance > 0`) or shrunk (`distance < 0`) with round joins.
    ///
    /// Arcs are polygons with at most `arc_step` radians per segment (clamped by
    /// `i_overlay` to `[0.01π, 0.25π]`). The distance is scaled by `1 / cos(arc_step / 2)`
    /// so that every chord lies outside the exact arc: a grown region always contains the
    /// exact Minkowski sum and a shrunk one is always inside the exact erosion.
    pub fn offset(&self, distance: f64, arc_step: f64) -> Region2 {
        if self.is_empty() || distance == 0.0 || !distance.is_finite() {
            return self.clone();
        }
        let step = arc_step.clamp(0.01 * std::f64::consts::PI, 0.25 * std::f64::consts::PI);
        let d = distance / (0.5 * step).cos();
        let style = OutlineStyle::new(d).line_join(LineJoin::Round(step));
        Region2 { shapes: self.shapes.outline(&style) }
    }

    /// The region with every vertex closer than `eps` to the previously kept vertex of its
    /// loop removed (loops left with fewer than three vertices vanish). The boundary moves
    /// by less than `eps`.
    pub fn simplified(&self, eps: f64) -> Region2 {
        let contours: Vec<Vec<Vec<Raw>>> = self
            .shapes
            .iter()
            .map(|s| {
                s.iter()
                    .filter_map(|c| {
                        let mut out: Vec<Raw> = Vec::with_capacity(c.len());
                        for p in c {
                            if out.last().is_none_or(|q: &Raw| (p[0] - q[0]).hypot(p[1] - q[1]) >= eps) {
                                out.push(*p);
                            }
                        }
                        while out.len() > 1 && {
                            let (a, b) = (out[0], out[out.len() - 1]);
                            (a[0] - b[0]).hypot(a[1] - b[1]) < eps
                        } {
                            out.pop();
                        }
                        (out.len() >= 3).then_some(out)
                    })
                    .collect()
            })
            .filter(|s: &Vec<Vec<Raw>>| !s.is_empty())
            .collect();
        Region2 { shapes: contours }.cleaned()
    }

    /// The region with each loop thinned by Douglas-Peucker at `tol`: every vertex left out
    /// lies within `tol` of the loop that remains, and every point of that loop within `tol`
    /// of the original, so the boundary moves by at most `tol`. Unlike
    /// [`simplified`](Self::simplified), which only merges vertices closer than its `eps`,
    /// this folds long runs of short segments that are nearly straight or gently curved
    /// (the rounded staircases that offsets of cell unions are made of) into a few
    /// vertices. Loops thinner than `tol` vanish; the result is re-run through a union, so
    /// it is a valid region even where thinning made a loop cross itself.
    pub fn thinned(&self, tol: f64) -> Region2 {
        self.thinned_with_vanished(tol).0
    }

    /// [`thinned`](Self::thinned), and whether a part of the region vanished (an outer
    /// loop thinner than `tol`).
    pub(crate) fn thinned_with_vanished(&self, tol: f64) -> (Region2, bool) {
        if !(tol > 0.0) {
            return (self.clone(), false);
        }
        let mut vanished = false;
        let shapes: Vec<Vec<Vec<Raw>>> = self
            .shapes
            .iter()
            .filter_map(|s| {
                // A shape is its outer loop, then its holes.
                let outer = s.first().and_then(|c| thin_loop(c, tol));
                vanished |= outer.is_none();
                let holes = s.iter().skip(1).filter_map(|c| thin_loop(c, tol));
                outer.map(|o| std::iter::once(o).chain(holes).collect::<Vec<_>>())
            })
            .collect();
        (Region2 { shapes }.cleaned(), vanished)
    }

    /// A region with fewer vertices that contains this one and lies within `2.5 tol` of it:
    /// each loop thinned at `tol` ([`thinned`](Self::thinned)), grown by 1.5 `tol`, and
    /// every shape of this region with a vertex left outside that (a loop thinner than
    /// `tol` that the thinning dropped) added back whole, grown as much. For a running union whose
    /// boundary has become a fine sawtooth (`Keepouts`): the keep-outs grown from it stay
    /// conservative.
    pub(crate) fn simplified_outward(&self, tol: f64) -> Region2 {
        if self.is_empty() || !(tol > 0.0) {
            return self.clone();
        }
        let grown = self.thinned(tol).offset(1.5 * tol, std::f64::consts::FRAC_PI_8);
        let index = grown.index();
        let lost: Vec<Vec<Vec<Raw>>> = self
            .shapes
            .iter()
            .filter(|s| s.iter().flatten().any(|v| !index.contains(&Point2::new(v[0], v[1]))))
            .cloned()
            .collect();
        match lost.is_empty() {
            true => grown,
            false => grown.union(&Region2 { shapes: lost }.offset(1.5 * tol, std::f64::consts::FRAC_PI_8)),
        }
    }

    /// The region with zero-width spikes removed: a vertex whose neighbours lie within `tol`
    /// of each other, the boundary going out to it and straight back, goes together with
    /// the neighbour after it. `i_overlay`'s outlines of long, finely divided boundaries
    /// come with such slits, reaching back to the boundary being grown; filling them moves
    /// no boundary by more than `tol` and adds no area worth the name.
    pub fn without_spikes(mut self, tol: f64) -> Region2 {
        for shape in &mut self.shapes {
            for c in shape.iter_mut() {
                let mut i = 0;
                while c.len() > 3 && i < c.len() {
                    let n = c.len();
                    let (a, b) = (c[(i + n - 1) % n], c[(i + 1) % n]);
                    if (a[0] - b[0]).hypot(a[1] - b[1]) < tol {
                        // Drop the tip and the returning neighbour, then look again just
                        // before: removing one spike can expose another.
                        let j = (i + 1) % n;
                        let (hi, lo) = if i > j { (i, j) } else { (j, i) };
                        c.remove(hi);
                        c.remove(lo);
                        i = i.saturating_sub(2);
                    } else {
                        i += 1;
                    }
                }
            }
            shape.retain(|c| c.len() >= 3);
        }
        self.shapes.retain(|s| !s.is_empty());
        self
    }

    /// The region with its holes of area below `min_area` filled.
    ///
    /// A hole of area below `π r²` holds no disc of radius `r`, so every point of it lies
    /// within `r` of the region: growing by `r` or more gives the same region with or
    /// without it. The union of a mesh's projected triangles is full of such holes (slivers
    /// between neighbours that the integer snapping of the boolean engine does not close),
    /// and they cost every later boolean on the region.
    pub fn with_small_holes_filled(mut self, min_area: f64) -> Region2 {
        for shape in &mut self.shapes {
            let mut outer = true;
            shape.retain(|c| std::mem::take(&mut outer) || -signed_area(c.iter().copied()) >= min_area);
        }
        self
    }

    /// Re-runs the region through a union so that its boundaries are valid again.
    fn cleaned(self) -> Region2 {
        if self.is_empty() {
            return self;
        }
        Region2 { shapes: self.shapes.simplify_shape(FillRule::NonZero) }
    }

    /// A grown region that is guaranteed to contain every point within `distance` of this
    /// region (the exact Minkowski sum with a disc), for tool-centre keep-outs.
    ///
    /// The region is first thinned at `eps` ([`Region2::thinned`]) and rid of its spikes
    /// and slits narrower than `eps` ([`Region2::without_spikes`]), then grown by
    /// `distance + eps` with [`Region2::offset`], whose own zero-width spikes are removed;
    /// then every vertex and edge midpoint of the result is
    /// checked against this region's exact boundary, and where the offset came out too close
    /// (numerical notches of the offset engine) the capsules of the nearby edges are
    /// added.
    ///
    /// The thinning and the spike removal come first because the offset engine's cost
    /// explodes on boundaries with many hairline slits and near-collinear runs (the
    /// running union of a rounded box's long, steep facets, OpenSCAD's example006, made
    /// single offsets take 10 to 50 s); the growth by `eps` more, and the check against
    /// the exact boundary, keep the result conservative.
    pub fn grown_safe(&self, distance: f64, eps: f64, arc_step: f64) -> Region2 {
        if self.is_empty() || !(distance > 0.0) {
            return self.clone();
        }
        let eps = eps.max(0.0);
        let mut off =
            self.thinned(eps).without_spikes(eps).offset(distance + eps, arc_step).without_spikes(eps);
        let index = self.index();
        let mut caps: Vec<Vec<Raw>> = Vec::new();
        let mut seen = std::collections::BTreeSet::new();
        for c in off.shapes.iter().flatten() {
            let n = c.len();
            for i in 0..n {
                let a = c[i];
                let b = c[(i + 1) % n];
                for q in [Point2::new(a[0], a[1]), Point2::new(0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]))] {
                    if index.any_edge_within(&q, distance * (1.0 - 1e-9)) && !index.contains(&q) {
                        for e in index.edges_near(&q, distance + eps) {
                            if seen.insert(e) {
                                let [ax, ay, bx, by] = index.edges[e as usize];
                                caps.push(capsule(ax, ay, bx, by, distance + eps, arc_step));
                            }
                        }
                    }
                }
            }
        }
        if !caps.is_empty() {
            off = off.union(&Region2::union_contours(caps));
        }
        off
    }

    /// Clips a polyline to the region (boundary included); returns the inside pieces,
    /// each in the original direction of travel. A loop that lies wholly inside comes back whole.
    pub fn clip_polyline(&self, line: &Polyline2) -> Vec<Polyline2> {
        if self.is_empty() || line.points.len() < 2 {
            return Vec::new();
        }
        let mut raw: Vec<Raw> = line.points.iter().map(|p| [p.x, p.y]).collect();
        if line.closed {
            raw.push(raw[0]);
        }
        let rule = ClipRule { invert: false, boundary_included: true };
        let pieces = raw.clip_by(&self.shapes, FillRule::NonZero, rule);
        let total: f64 = line.length();
        let out: Vec<Polyline2> = pieces
            .into_iter()
            .filter(|p| p.len() >= 2)
            .map(|p| Polyline2::open(p.into_iter().map(|q| Point2::new(q[0], q[1])).collect()))
            .collect();
        let kept: f64 = out.iter().map(Polyline2::length).sum();
        if line.closed && (total - kept).abs() <= 1e-9 * total.max(1e-300) {
            // Wholly inside: keep the loop itself (and its start point).
            return vec![line.clone()];
        }
        out
    }

    /// Builds the edge index used by point and segment queries.
    pub fn index(&self) -> RegionIndex {
        RegionIndex::new(self)
    }
}

/// Orients a contour counter-clockwise; `None` if degenerate or not finite.
pub(crate) fn ccw_contour(mut c: Vec<Raw>) -> Option<Vec<Raw>> {
    if c.len() < 3 || !c.iter().flatten().all(|v| v.is_finite()) {
        return None;
    }
    let a = signed_area(c.iter().copied());
    if a == 0.0 || !a.is_finite() {
        return None;
    }
    if a < 0.0 {
        c.reverse();
    }
    Some(c)
}

/// A uniform grid over a region's boundary edges, for fast exact inside tests, segment
/// containment and distance to the boundary.
#[derive(Debug, Clone)]
pub struct RegionIndex {
    edges: Vec<[f64; 4]>,
    origin: [f64; 2],
    cell: f64,
    dims: [usize; 2],
    cells: Vec<Vec<u32>>,
}

impl RegionIndex {
    fn new(region: &Region2) -> Self {
        let mut edges = Vec::new();
        for c in region.shapes.iter().flatten() {
            let n = c.len();
            for i in 0..n {
                let a = c[i];
                let b = c[(i + 1) % n];
                if a != b {
                    edges.push([a[0], a[1], b[0], b[1]]);
                }
            }
        }
        let (lo, hi) = match region.bbox() {
            Some(b) => b,
            None => (Point2::origin(), Point2::new(1.0, 1.0)),
        };
        let w = (hi.x - lo.x).max(1e-300);
        let h = (hi.y - lo.y).max(1e-300);
        // About two edges per cell on average.
        let target = (edges.len() as f64 / 2.0).max(1.0);
        let cell = ((w * h) / target).sqrt().max(w.max(h) / 4096.0).max(1e-300);
        let dims = [((w / cell).ceil() as usize).clamp(1, 4096), ((h / cell).ceil() as usize).clamp(1, 4096)];
        let mut cells = vec![Vec::new(); dims[0] * dims[1]];
        let mut idx = Self { edges: Vec::new(), origin: [lo.x, lo.y], cell, dims, cells: Vec::new() };
        for (e, ed) in edges.iter().enumerate() {
            let (i0, j0) = idx.cell_of(ed[0].min(ed[2]), ed[1].min(ed[3]));
            let (i1, j1) = idx.cell_of(ed[0].max(ed[2]), ed[1].max(ed[3]));
            for j in j0..=j1 {
                for i in i0..=i1 {
                    cells[j * dims[0] + i].push(e as u32);
                }
            }
        }
        idx.edges = edges;
        idx.cells = cells;
        idx
    }

    fn cell_of(&self, x: f64, y: f64) -> (usize, usize) {
        let i = ((x - self.origin[0]) / self.cell).floor();
        let j = ((y - self.origin[1]) / self.cell).floor();
        let ci = if i.is_nan() { 0 } else { i.clamp(0.0, (self.dims[0] - 1) as f64) as usize };
        let cj = if j.is_nan() { 0 } else { j.clamp(0.0, (self.dims[1] - 1) as f64) as usize };
        (ci, cj)
    }

    /// Whether `p` is inside the region (even-odd over all boundary loops; points exactly
    /// on the boundary may go either way).
    pub fn contains(&self, p: &Point2) -> bool {
        if self.edges.is_empty() {
            return false;
        }
        let (ci, cj) = self.cell_of(p.x, p.y);
        let y = p.y;
        // Only this row's cells can hold edges spanning y; count each crossing once by
        // accepting it only in the cell that holds its x.
        let mut inside = false;
        for i in ci..self.dims[0] {
            let x0 = self.origin[0] + i as f64 * self.cell;
            let x1 = if i + 1 == self.dims[0] { f64::INFINITY } else { x0 + self.cell };
            let x0 = if i == 0 { f64::NEG_INFINITY } else { x0 };
            for &e in &self.cells[cj * self.dims[0] + i] {
                let [ax, ay, bx, by] = self.edges[e as usize];
                if (ay > y) != (by > y) {
                    let x = ax + (y - ay) / (by - ay) * (bx - ax);
                    if x > p.x && x >= x0 && x < x1 {
                        inside = !inside;
                    }
                }
            }
        }
        inside
    }

    /// Distance from `p` to the nearest boundary edge, searching no farther than `max`
    /// (returns `max` or more when nothing is nearer).
    pub fn boundary_distance(&self, p: &Point2, max: f64) -> f64 {
        let mut best = f64::INFINITY;
        let (ci, cj) = self.cell_of(p.x, p.y);
        let rings = ((max / self.cell).ceil().min(1e9) as usize)
            .saturating_add(1)
            .min(self.dims[0].max(self.dims[1]));
        for ring in 0..=rings {
            let i0 = ci.saturating_sub(ring);
            let j0 = cj.saturating_sub(ring);
            let i1 = (ci + ring).min(self.dims[0] - 1);
            let j1 = (cj + ring).min(self.dims[1] - 1);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    if i.abs_diff(ci).max(j.abs_diff(cj)) != ring {
                        continue;
                    }
                    for &e in &self.cells[j * self.dims[0] + i] {
                        let [ax, ay, bx, by] = self.edges[e as usize];
                        best =
                            best.min(point_segment_distance(p, &Point2::new(ax, ay), &Point2::new(bx, by)));
                    }
                }
            }
            // Anything in later rings is at least `ring * cell` away.
            if best <= ring as f64 * self.cell || ring as f64 * self.cell > max {
                break;
            }
        }
        best
    }

    /// The nearest boundary point to `p` within `max` of it, if any.
    pub fn nearest_boundary_point(&self, p: &Point2, max: f64) -> Option<Point2> {
        if !(max > 0.0) || self.edges.is_empty() {
            return None;
        }
        let mut best: Option<(f64, Point2)> = None;
        for e in self.edge_ids_around(p, max) {
            let [ax, ay, bx, by] = self.edges[e as usize];
            let (a, b) = (Point2::new(ax, ay), Point2::new(bx, by));
            let ab = b - a;
            let l2 = ab.norm_squared();
            let t = if l2 > 0.0 { ((p - a).dot(&ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
            let q = a + ab * t;
            let d = (p - q).norm();
            if d <= max && best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, q));
            }
        }
        best.map(|(_, q)| q)
    }

    /// Whether a boundary edge comes nearer `p` than `d`: `boundary_distance(p, d) < d`,
    /// answered at the first such edge, with edges whose box lies `d` or more away skipped
    /// and squared distances compared (no division or root for most edges).
    pub fn any_edge_within(&self, p: &Point2, d: f64) -> bool {
        if !(d > 0.0) {
            return false;
        }
        let d2 = d * d;
        self.edge_ids_around(p, d).map(|e| self.edges[e as usize]).any(|[ax, ay, bx, by]| {
            let far = ax.min(bx) - p.x >= d
                || p.x - ax.max(bx) >= d
                || ay.min(by) - p.y >= d
                || p.y - ay.max(by) >= d;
            !far && point_segment_distance_squared(p, &Point2::new(ax, ay), &Point2::new(bx, by)) < d2
        })
    }

    /// Boundary edge `e`: `[ax, ay, bx, by]`.
    pub(crate) fn edge(&self, e: u32) -> [f64; 4] {
        self.edges[e as usize]
    }

    /// Indices of the boundary edges within `d` of `p` (ascending).
    fn edges_near(&self, p: &Point2, d: f64) -> Vec<u32> {
        let mut out: Vec<u32> = self
            .edge_ids_around(p, d)
            .filter(|&e| {
                let [ax, ay, bx, by] = self.edges[e as usize];
                point_segment_distance(p, &Point2::new(ax, ay), &Point2::new(bx, by)) <= d
            })
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The edges listed in the cells that the square `p ± d` meets (an edge listed in
    /// several of them comes once per cell): every edge within `d` of `p` is among them.
    fn edge_ids_around(&self, p: &Point2, d: f64) -> impl Iterator<Item = u32> + '_ {
        self.edge_ids_in(Point2::new(p.x - d, p.y - d), Point2::new(p.x + d, p.y + d))
    }

    /// The edges listed in the cells that the box `lo`-`hi` meets (an edge listed in
    /// several of them comes once per cell): every edge that meets the box is among them.
    pub(crate) fn edge_ids_in(&self, lo: Point2, hi: Point2) -> impl Iterator<Item = u32> + '_ {
        let (i0, j0) = self.cell_of(lo.x, lo.y);
        let (i1, j1) = self.cell_of(hi.x, hi.y);
        (j0..=j1)
            .flat_map(move |j| (i0..=i1).flat_map(move |i| self.cells[j * self.dims[0] + i].iter().copied()))
    }

    /// Whether the closed segment `a`-`b` stays inside the region, with boundary contact
    /// up to `tol` allowed. Exact: no boundary edge crosses it properly, and between the
    /// places where the boundary touches it (edge ends within `tol` of it, edges meeting
    /// it) each piece is inside or within `tol` of the boundary. The boundary meets a
    /// piece's interior nowhere, so its midpoint decides the piece: a gap in the region
    /// narrower than any sampling step is still found.
    pub fn segment_inside(&self, a: &Point2, b: &Point2, tol: f64) -> bool {
        if self.edges.is_empty() {
            return false;
        }
        let ab = b - a;
        let len2 = ab.norm_squared();
        let along = |p: &Point2| if len2 > 0.0 { ((p - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
        let mut cuts = vec![0.0, 1.0];
        let lo = Point2::new(a.x.min(b.x) - tol, a.y.min(b.y) - tol);
        let hi = Point2::new(a.x.max(b.x) + tol, a.y.max(b.y) + tol);
        let len = len2.sqrt().max(1e-300);
        for e in self.edge_ids_in(lo, hi) {
            let [ax, ay, bx, by] = self.edges[e as usize];
            let (c, d) = (Point2::new(ax, ay), Point2::new(bx, by));
            if proper_cross(a, b, &c, &d, tol) {
                return false;
            }
            for q in [&c, &d] {
                if point_segment_distance(q, a, b) <= tol {
                    cuts.push(along(q));
                }
            }
            // An edge whose ends lie on either side of the segment's line meets it where it
            // crosses the line (if that is on the segment).
            let (dc, dd) = (orient(a, b, &c) / len, orient(a, b, &d) / len);
            if (dc < 0.0 && dd > 0.0) || (dc > 0.0 && dd < 0.0) {
                let x = c + (d - c) * (dc / (dc - dd));
                if point_segment_distance(&x, a, b) <= tol {
                    cuts.push(along(&x));
                }
            }
        }
        cuts.sort_by(f64::total_cmp);
        cuts.dedup();
        cuts.windows(2).all(|w| {
            let p = a + ab * (0.5 * (w[0] + w[1]));
            self.contains(&p) || self.boundary_distance(&p, tol) <= tol
        })
    }
}

/// A counter-clockwise polygon containing every point within `rho` of segment a-b
/// (round ends circumscribed with at most `arc_step` radians per segment).
fn capsule(ax: f64, ay: f64, bx: f64, by: f64, rho: f64, arc_step: f64) -> Vec<Raw> {
    let step = arc_step.clamp(0.01 * std::f64::consts::PI, 0.25 * std::f64::consts::PI);
    let n = (std::f64::consts::PI / step).ceil().max(2.0) as usize;
    let rr = rho / (0.5 * std::f64::consts::PI / n as f64).cos();
    let th = (by - ay).atan2(bx - ax);
    let mut out = Vec::with_capacity(2 * n + 2);
    for k in 0..=n {
        let a = th - 0.5 * std::f64::consts::PI + std::f64::consts::PI * k as f64 / n as f64;
        out.push([bx + rr * a.cos(), by + rr * a.sin()]);
    }
    for k in 0..=n {
        let a = th + 0.5 * std::f64::consts::PI + std::f64::consts::PI * k as f64 / n as f64;
        out.push([ax + rr * a.cos(), ay + rr * a.sin()]);
    }
    out
}

/// Douglas-Peucker on a closed loop: split at its first vertex and the vertex farthest
/// from it, each half thinned at `tol`. `None` when fewer than three vertices remain.
fn thin_loop(c: &[Raw], tol: f64) -> Option<Vec<Raw>> {
    let n = c.len();
    if n < 3 {
        return None;
    }
    let p = |i: usize| Point2::new(c[i % n][0], c[i % n][1]);
    let far =
        (1..n).max_by(|&i, &j| (p(i) - p(0)).norm_squared().total_cmp(&(p(j) - p(0)).norm_squared()))?;
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[far] = true;
    // Index ranges of the loop, `n` standing for vertex 0 again.
    let mut stack = vec![(0, far), (far, n)];
    while let Some((a, b)) = stack.pop() {
        let (pa, pb) = (p(a), p(b));
        let worst = (a + 1..b)
            .map(|i| (i, point_segment_distance(&p(i), &pa, &pb)))
            .max_by(|x, y| x.1.total_cmp(&y.1));
        if let Some((i, d)) = worst
            && d > tol
        {
            keep[i] = true;
            stack.push((a, i));
            stack.push((i, b));
        }
    }
    let out: Vec<Raw> = (0..n).filter(|&i| keep[i]).map(|i| c[i]).collect();
    (out.len() >= 3).then_some(out)
}

/// Distance from `p` to the segment `a`-`b`.
pub fn point_segment_distance(p: &Point2, a: &Point2, b: &Point2) -> f64 {
    point_segment_distance_squared(p, a, b).sqrt()
}

/// The square of [`point_segment_distance`].
fn point_segment_distance_squared(p: &Point2, a: &Point2, b: &Point2) -> f64 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let t = if l2 > 0.0 { ((p - a).dot(&ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + ab * t)).norm_squared()
}

fn orient(a: &Point2, b: &Point2, c: &Point2) -> f64 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// Proper crossing of segments `p`-`q` and `a`-`b`: each strictly separates the other's
/// endpoints by more than `tol` (so touching and collinear overlaps do not count).
fn proper_cross(p: &Point2, q: &Point2, a: &Point2, b: &Point2, tol: f64) -> bool {
    let lpq = (q - p).norm().max(1e-300);
    let lab = (b - a).norm().max(1e-300);
    let d1 = orient(p, q, a) / lpq;
    let d2 = orient(p, q, b) / lpq;
    let d3 = orient(a, b, p) / lab;
    let d4 = orient(a, b, q) / lab;
    ((d1 > tol && d2 < -tol) || (d1 < -tol && d2 > tol))
        && ((d3 > tol && d4 < -tol) || (d3 < -tol && d4 > tol))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `any_edge_within` answers `boundary_distance(p, d) < d` on a square with a disc-shaped
    /// hole (edges of every direction), at points inside, outside and on the boundary's
    /// scale, for distances from far below to far above the index's cell.
    /// A disc whose boundary is a fine sawtooth (20,000 vertices, teeth 5 µm deep) and a
    /// separate island thinner than the tolerance: the simplified region has a few hundred
    /// vertices, holds every vertex of the original, the island included, and none of its
    /// vertices lies farther than 2.5 tolerances from it.
    #[test]
    fn simplified_outward_holds_the_region_within_its_distance() {
        let n = 20_000;
        let saw: Vec<Point2> = (0..n)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / n as f64;
                let r = 30.0 + if i % 2 == 0 { 0.005 } else { 0.0 };
                Point2::new(r * a.cos(), r * a.sin())
            })
            .collect();
        let sliver = [
            Point2::new(40.0, 0.0),
            Point2::new(50.0, 0.0),
            Point2::new(50.0, 0.004),
            Point2::new(40.0, 0.004),
        ];
        let region = Region2::from_polygons([saw.as_slice(), sliver.as_slice()]);
        assert!(region.vertex_count() > 10_000);
        let tol = 0.01;
        let simple = region.simplified_outward(tol);
        assert!(simple.vertex_count() < 1_000, "{} vertices", simple.vertex_count());
        let (inside, outside) = (simple.index(), region.index());
        for v in region.shapes().flatten().flatten() {
            assert!(inside.contains(&v), "{v} left out");
        }
        for v in simple.shapes().flatten().flatten() {
            assert!(
                outside.contains(&v) || outside.boundary_distance(&v, 1.0) <= 2.5 * tol,
                "{v} too far out"
            );
        }
        assert_eq!(Region2::empty().simplified_outward(tol), Region2::empty());
    }

    #[test]
    fn any_edge_within_agrees_with_the_boundary_distance() {
        let outer = Region2::rect(Point2::new(0.0, 0.0), Point2::new(6.0, 4.0));
        let hole = Region2::rect(Point2::new(1.8, 1.8), Point2::new(2.2, 2.2)).offset(1.0, 0.05);
        let index = outer.difference(&hole).index();
        let (mut near, mut cases) = (0, 0);
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut unit = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..4000 {
            let p = Point2::new(-1.0 + 8.0 * unit(), -1.0 + 6.0 * unit());
            let d = 0.001 * 3000f64.powf(unit());
            let want = index.boundary_distance(&p, d) < d;
            assert_eq!(index.any_edge_within(&p, d), want, "{p:?} within {d}");
            near += usize::from(want);
            cases += 1;
        }
        assert!(near > 400 && near < cases - 400, "both answers: {near} of {cases}");
        assert!(!index.any_edge_within(&Point2::new(0.5, 0.5), 0.0));
    }

    #[test]
    fn square_minus_hole_area_offset_and_queries() {
        let outer = Region2::rect(Point2::new(0.0, 0.0), Point2::new(4.0, 4.0));
        let hole = Region2::rect(Point2::new(1.0, 1.0), Point2::new(3.0, 3.0));
        let ring = outer.difference(&hole);
        assert!((ring.area() - 12.0).abs() < 1e-6, "area {}", ring.area());
        let grown = hole.offset(0.5, 0.05);
        let exact = 4.0 + 4.0 * 2.0 * 0.5 + std::f64::consts::PI * 0.25;
        assert!(grown.area() >= exact - 1e-6 && grown.area() < exact * 1.01, "grown {}", grown.area());
        let shrunk = outer.offset(-0.5, 0.05);
        // Erosion is conservative: never larger than exact (9), and within the chord tolerance.
        assert!(shrunk.area() <= 9.0 + 1e-9 && shrunk.area() > 8.99, "shrunk {}", shrunk.area());
        let idx = ring.index();
        assert!(idx.contains(&Point2::new(0.5, 0.5)));
        assert!(!idx.contains(&Point2::new(2.0, 2.0)));
        assert!(!idx.contains(&Point2::new(5.0, 2.0)));
        assert!((idx.boundary_distance(&Point2::new(0.5, 2.0), 10.0) - 0.5).abs() < 1e-9);
        assert!(idx.segment_inside(&Point2::new(0.5, 0.5), &Point2::new(3.5, 0.5), 1e-9));
        assert!(!idx.segment_inside(&Point2::new(0.5, 0.5), &Point2::new(3.5, 3.5), 1e-9));
    }

    /// A segment along the tops of two boxes is not inside their union: it crosses the
    /// gap between them. The gap (1.1 wide) falls between the points a test sampled at the
    /// index's cell (1.5 here) would look at; the gap is found at any width, and the
    /// segments on either side of it stay inside.
    #[test]
    fn a_segment_across_a_narrow_gap_is_not_inside() {
        let p = |x: f64, y: f64| Point2::new(x, y);
        for gap in [1.1, 0.3, 1e-3] {
            let left = Region2::rect(p(0.0, 0.0), p(3.2, 1.0));
            let right = Region2::rect(p(3.2 + gap, 0.0), p(9.0, 1.0));
            let idx = left.union(&right).index();
            assert!(!idx.segment_inside(&p(0.0, 1.0), &p(9.0, 1.0), 1e-9), "gap {gap}: along the tops");
            assert!(!idx.segment_inside(&p(0.5, 0.5), &p(8.5, 0.5), 1e-9), "gap {gap}: through the middle");
            assert!(idx.segment_inside(&p(0.0, 1.0), &p(3.2, 1.0), 1e-9), "gap {gap}: the left top");
            assert!(
                idx.segment_inside(&p(3.2 + 2.0 * gap, 0.5), &p(8.5, 0.5), 1e-9),
                "gap {gap}: in the right box"
            );
        }
        // Two triangles whose tips touch the segment's line: the segment between the tips
        // is outside, though the boundary meets it only at those two points.
        let tips = [p(0.0, 0.0), p(4.0, 2.0), p(0.0, 2.0), p(9.0, 0.0), p(9.0, 2.0), p(5.0, 2.0)];
        let idx = Region2::from_polygons([&tips[..3], &tips[3..]]).index();
        assert!(!idx.segment_inside(&p(0.0, 2.0), &p(9.0, 2.0), 1e-9));
        assert!(idx.segment_inside(&p(5.0, 2.0), &p(9.0, 2.0), 1e-9));
    }

    /// Holes below the area are filled, larger ones kept; and a hole of area below `π r²`
    /// is covered by growing the region by `r` anyway, so the grown regions agree.
    #[test]
    fn small_holes_are_filled_and_growth_covers_them() {
        let outer = Region2::rect(Point2::new(0.0, 0.0), Point2::new(10.0, 10.0));
        // A 0.2 x 0.2 hole (area 0.04) and a 3 x 3 one (area 9).
        let small = Region2::rect(Point2::new(1.0, 1.0), Point2::new(1.2, 1.2));
        let large = Region2::rect(Point2::new(5.0, 5.0), Point2::new(8.0, 8.0));
        let holed = outer.difference(&small).difference(&large);
        let r: f64 = 0.15;
        let min_area = std::f64::consts::PI * r * r;
        assert!(0.04 < min_area && min_area < 9.0);
        let filled = holed.clone().with_small_holes_filled(min_area);
        assert_eq!(holed.loops().len(), 3);
        assert_eq!(filled.loops().len(), 2, "the small hole is filled, the large kept");
        assert!((filled.area() - (100.0 - 9.0)).abs() < 1e-6, "area {}", filled.area());
        let (a, b) = (holed.offset(r, 0.05), filled.offset(r, 0.05));
        assert!((a.area() - b.area()).abs() < 1e-6, "grown {} vs {}", a.area(), b.area());
        assert_eq!(a.loops().len(), b.loops().len());
        // Nothing is filled below the smallest hole's area.
        assert_eq!(holed.clone().with_small_holes_filled(0.01).loops().len(), 3);
    }

    #[test]
    fn bounding_boxes_of_regions_shapes_and_polylines() {
        let two = Region2::rect(Point2::new(0.0, 0.0), Point2::new(1.0, 2.0))
            .union(&Region2::rect(Point2::new(3.0, -1.0), Point2::new(4.0, 0.5)));
        assert_eq!(two.bbox(), Some((Point2::new(0.0, -1.0), Point2::new(4.0, 2.0))));
        let mut boxes = two.shape_bboxes();
        boxes.sort_by(|a, b| a.0.x.total_cmp(&b.0.x));
        assert_eq!(
            boxes,
            vec![
                (Point2::new(0.0, 0.0), Point2::new(1.0, 2.0)),
                (Point2::new(3.0, -1.0), Point2::new(4.0, 0.5))
            ]
        );
        assert_eq!(Region2::empty().bbox(), None);
        let line =
            Polyline2::open(vec![Point2::new(2.0, 1.0), Point2::new(-1.0, 3.0), Point2::new(0.0, -2.0)]);
        assert_eq!(line.bbox(), Some((Point2::new(-1.0, -2.0), Point2::new(2.0, 3.0))));
        assert_eq!(Polyline2::open(Vec::new()).bbox(), None);
    }

    #[test]
    fn clip_keeps_direction_and_whole_loops() {
        let r = Region2::rect(Point2::new(0.0, 0.0), Point2::new(2.0, 2.0));
        let line = Polyline2::open(vec![Point2::new(-1.0, 1.0), Point2::new(3.0, 1.0)]);
        let out = r.clip_polyline(&line);
        assert_eq!(out.len(), 1);
        assert!(out[0].points[0].x < out[0].points[1].x, "direction kept: {out:?}");
        let lp = Polyline2::closed(vec![Point2::new(0.5, 0.5), Point2::new(1.5, 0.5), Point2::new(1.0, 1.5)]);
        assert_eq!(r.clip_polyline(&lp), vec![lp.clone()]);
    }

    #[test]
    fn pieces_outside_a_region_keep_their_direction() {
        let done = Region2::rect(Point2::new(0.0, 0.0), Point2::new(2.0, 2.0)).index();
        let p = |x: f64, y: f64| Point2::new(x, y);
        // A loop along the region's boundary on two sides and outside it on the others.
        let lp = Polyline2::closed(vec![
            p(0.0, 0.0),
            p(2.0, 0.0),
            p(2.0, 2.0),
            p(3.0, 2.0),
            p(3.0, -1.0),
            p(0.0, -1.0),
        ]);
        let out = lp.clone().outside(&done, 1e-9);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(out[0].points, vec![p(2.0, 2.0), p(3.0, 2.0), p(3.0, -1.0), p(0.0, -1.0), p(0.0, 0.0)]);
        assert!(!out[0].closed);
        // Reversed, the piece runs the other way.
        let mut back = lp.clone();
        back.reverse();
        let out = back.outside(&done, 1e-9);
        assert_eq!(out.len(), 1);
        assert_eq!(out[0].start(), Some(p(0.0, 0.0)));
        assert_eq!(out[0].end(), Some(p(2.0, 2.0)));
        // Wholly outside: the loop itself; wholly inside or on the boundary: nothing.
        let far = Polyline2::closed(vec![p(5.0, 5.0), p(6.0, 5.0), p(6.0, 6.0)]);
        assert_eq!(far.clone().outside(&done, 1e-9), vec![far]);
        let on = Polyline2::closed(vec![p(0.0, 0.0), p(2.0, 0.0), p(2.0, 2.0), p(0.0, 2.0)]);
        assert!(on.outside(&done, 1e-9).is_empty());
        // An open line crossing the region keeps its two outer ends.
        let line = Polyline2::open(vec![p(-1.0, 1.0), p(0.5, 1.0), p(1.5, 1.0), p(3.0, 1.0)]);
        let out = line.outside(&done, 1e-9);
        assert_eq!(out.len(), 2, "{out:?}");
        assert_eq!((out[0].start(), out[1].end()), (Some(p(-1.0, 1.0)), Some(p(3.0, 1.0))));
    }

    /// A staircase of 0.5-wide cells around a hole, grown by 1 with round joins (what a
    /// clearing region made of material-map cells looks like): thinning at 0.02 keeps the
    /// boundary within 0.02 both ways and drops two thirds of its vertices.
    #[test]
    fn thinning_moves_the_boundary_by_at_most_its_tolerance() {
        let cells: Vec<Vec<Raw>> = (0..40)
            .flat_map(|j| {
                // A disc of radius 8 in cells of 0.5, less a disc of radius 3.
                (0..40).filter_map(move |i| {
                    let (x, y) = (i as f64 * 0.5 - 10.0, j as f64 * 0.5 - 10.0);
                    let d = (x + 0.25).hypot(y + 0.25);
                    (d < 8.0 && d > 3.0).then(|| vec![[x, y], [x + 0.5, y], [x + 0.5, y + 0.5], [x, y + 0.5]])
                })
            })
            .collect();
        let region = Region2::union_contours(cells).offset(1.0, 0.1);
        let tol = 0.02;
        let thin = region.thinned(tol);
        assert_eq!(thin.loops().len(), region.loops().len());
        assert!(
            2 * thin.vertex_count() < region.vertex_count(),
            "{} of {} vertices left",
            thin.vertex_count(),
            region.vertex_count()
        );
        let (a, b) = (region.index(), thin.index());
        let slack = tol + 1e-6;
        for (from, to) in [(&region, &b), (&thin, &a)] {
            for lp in from.loops() {
                for (p, q) in lp.segments() {
                    for t in [0.0, 0.5] {
                        let x = p + (q - p) * t;
                        let d = to.boundary_distance(&x, 1.0);
                        assert!(d <= slack, "({:.4}, {:.4}) is {d} from the other boundary", x.x, x.y);
                    }
                }
            }
        }
        let perimeter: f64 = region.loops().iter().map(Polyline2::length).sum();
        assert!((thin.area() - region.area()).abs() <= tol * perimeter);
        // A loop thinner than the tolerance goes; no tolerance changes nothing.
        let sliver = Region2::rect(Point2::new(0.0, 0.0), Point2::new(5.0, 0.01));
        let bump = Region2 { shapes: vec![vec![vec![[0.0, 0.0], [5.0, 0.0], [2.5, 0.01]]]] };
        assert!(bump.thinned(tol).is_empty());
        assert_eq!(sliver.thinned(0.0), sliver);
    }

    #[test]
    fn spikes_are_removed_and_nothing_else_moves() {
        // A square whose top edge has a zero-width slit down to (1, 0.2) (base points
        // 1e-6 apart, as i_overlay's outlines have them), and a clean corner elsewhere.
        let c = vec![
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 2.0],
            [1.0 + 5e-7, 2.0],
            [1.0, 0.2],
            [1.0 - 5e-7, 2.0],
            [0.0, 2.0],
        ];
        let r = Region2 { shapes: vec![vec![c]] };
        let index = r.index();
        assert!(index.boundary_distance(&Point2::new(1.0, 0.3), 1.0) < 0.2, "the slit is in the boundary");
        let clean = r.clone().without_spikes(1e-4);
        let ring = &clean.shapes[0][0];
        assert_eq!(ring.len(), 5, "tip and returning point gone: {ring:?}");
        assert!(ring.iter().all(|p| p[1] != 0.2));
        assert!((clean.area() - 4.0).abs() < 1e-5, "area {}", clean.area());
        assert!(clean.index().boundary_distance(&Point2::new(1.0, 0.3), 1.0) > 0.29);
        // Without spikes nothing changes.
        let sq = Region2::rect(Point2::new(0.0, 0.0), Point2::new(2.0, 2.0));
        assert_eq!(sq.clone().without_spikes(1e-4), sq);
    }
}
