//! Shared helpers: analytic parts built in code, independent checks.
#![allow(dead_code)] // Each test binary uses a different subset.

use s2g_gcode::{Marker, Motion, MotionRecorder, Plane};
use s2g_geom::{Aabb, Mesh, MeshIndex, Point3, Setup, SignedDistance};
use s2g_toolpath::finish::RoughedStock;
use s2g_toolpath::{LayerPlan, Point2, Polyline2, RegionIndex, point_segment_distance};

/// Signed distance to an indexed region's boundary (negative inside).
pub fn sd(idx: &RegionIndex, p: &Point2) -> f64 {
    let d = idx.boundary_distance(p, f64::INFINITY);
    if idx.contains(p) { -d } else { d }
}

/// A height-field part on an `nx x ny` grid of square cells of side `cell` starting at the
/// origin: cell (i, j) is a column from z = 0 to `h(i, j)` (> 0). Watertight (with
/// T-junctions), outward counter-clockwise winding.
pub struct HeightField {
    pub nx: usize,
    pub ny: usize,
    pub cell: f64,
    pub h: Vec<f64>,
}

impl HeightField {
    pub fn new(nx: usize, ny: usize, cell: f64, f: impl Fn(usize, usize) -> f64) -> Self {
        let mut h = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                h.push(f(i, j));
            }
        }
        Self { nx, ny, cell, h }
    }

    pub fn height(&self, i: isize, j: isize) -> f64 {
        if i < 0 || j < 0 || i as usize >= self.nx || j as usize >= self.ny {
            0.0
        } else {
            self.h[j as usize * self.nx + i as usize]
        }
    }

    pub fn mesh(&self) -> Mesh {
        let c = self.cell;
        let mut soup: Vec<[Point3; 3]> = Vec::new();
        let mut quad = |a: Point3, b: Point3, cc: Point3, d: Point3| {
            soup.push([a, b, cc]);
            soup.push([a, cc, d]);
        };
        for j in 0..self.ny as isize {
            for i in 0..self.nx as isize {
                let h = self.height(i, j);
                let (x0, y0, x1, y1) = (i as f64 * c, j as f64 * c, (i + 1) as f64 * c, (j + 1) as f64 * c);
                // Top (normal +z) and bottom (normal -z).
                quad(
                    Point3::new(x0, y0, h),
                    Point3::new(x1, y0, h),
                    Point3::new(x1, y1, h),
                    Point3::new(x0, y1, h),
                );
                quad(
                    Point3::new(x0, y0, 0.0),
                    Point3::new(x0, y1, 0.0),
                    Point3::new(x1, y1, 0.0),
                    Point3::new(x1, y0, 0.0),
                );
                // Walls where this column is taller than its neighbour, facing the neighbour.
                let hx = self.height(i + 1, j);
                if h > hx {
                    quad(
                        Point3::new(x1, y0, hx),
                        Point3::new(x1, y1, hx),
                        Point3::new(x1, y1, h),
                        Point3::new(x1, y0, h),
                    );
                }
                let hx = self.height(i - 1, j);
                if h > hx {
                    quad(
                        Point3::new(x0, y1, hx),
                        Point3::new(x0, y0, hx),
                        Point3::new(x0, y0, h),
                        Point3::new(x0, y1, h),
                    );
                }
                let hy = self.height(i, j + 1);
                if h > hy {
                    quad(
                        Point3::new(x1, y1, hy),
                        Point3::new(x0, y1, hy),
                        Point3::new(x0, y1, h),
                        Point3::new(x1, y1, h),
                    );
                }
                let hy = self.height(i, j - 1);
                if h > hy {
                    quad(
                        Point3::new(x0, y0, hy),
                        Point3::new(x1, y0, hy),
                        Point3::new(x1, y0, h),
                        Point3::new(x0, y0, h),
                    );
                }
            }
        }
        Mesh::from_soup(&soup).expect("finite soup")
    }

    /// Exact horizontal distance from (x, y) to the material strictly above `z + tol`.
    pub fn distance_above(&self, p: &Point2, z: f64, tol: f64) -> f64 {
        let c = self.cell;
        let mut best = f64::INFINITY;
        for j in 0..self.ny {
            for i in 0..self.nx {
                if self.h[j * self.nx + i] > z + tol {
                    let dx = (i as f64 * c - p.x).max(p.x - (i + 1) as f64 * c).max(0.0);
                    let dy = (j as f64 * c - p.y).max(p.y - (j + 1) as f64 * c).max(0.0);
                    best = best.min((dx * dx + dy * dy).sqrt());
                }
            }
        }
        best
    }
}

/// A closed prism over a regular `n`-gon inscribed in the circle (cx, cy, radius), z in [0, h].
pub fn cylinder(cx: f64, cy: f64, radius: f64, h: f64, n: usize) -> Mesh {
    let mut soup = Vec::new();
    let p = |k: usize, z: f64| {
        let a = std::f64::consts::TAU * (k % n) as f64 / n as f64;
        Point3::new(cx + radius * a.cos(), cy + radius * a.sin(), z)
    };
    let top = Point3::new(cx, cy, h);
    let bot = Point3::new(cx, cy, 0.0);
    for k in 0..n {
        soup.push([top, p(k, h), p(k + 1, h)]);
        soup.push([bot, p(k + 1, 0.0), p(k, 0.0)]);
        soup.push([p(k, 0.0), p(k + 1, 0.0), p(k + 1, h)]);
        soup.push([p(k, 0.0), p(k + 1, h), p(k, h)]);
    }
    Mesh::from_soup(&soup).expect("finite")
}

/// Points along a path, spaced at most `step`.
pub fn samples(path: &Polyline2, step: f64) -> Vec<Point2> {
    let mut out = Vec::new();
    for (a, b) in path.segments() {
        let n = (((b - a).norm() / step).ceil() as usize).max(1);
        for k in 0..n {
            out.push(a + (b - a) * (k as f64 / n as f64));
        }
    }
    if let Some(e) = path.end() {
        out.push(e);
    }
    out
}

/// A bucket grid over path segments for "distance to the nearest path" queries.
pub struct PathGrid {
    segs: Vec<(Point2, Point2)>,
    origin: Point2,
    cell: f64,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<u32>>,
}

impl PathGrid {
    pub fn new(paths: &[&Polyline2], lo: Point2, hi: Point2, cell: f64) -> Self {
        let nx = (((hi.x - lo.x) / cell).ceil() as usize).max(1);
        let ny = (((hi.y - lo.y) / cell).ceil() as usize).max(1);
        let mut g = Self { segs: Vec::new(), origin: lo, cell, nx, ny, cells: vec![Vec::new(); nx * ny] };
        for p in paths {
            let segs: Vec<(Point2, Point2)> =
                if p.points.len() == 1 { vec![(p.points[0], p.points[0])] } else { p.segments().collect() };
            for (a, b) in segs {
                let id = g.segs.len() as u32;
                g.segs.push((a, b));
                let (i0, j0) = g.cell_of(&Point2::new(a.x.min(b.x), a.y.min(b.y)));
                let (i1, j1) = g.cell_of(&Point2::new(a.x.max(b.x), a.y.max(b.y)));
                for j in j0..=j1 {
                    for i in i0..=i1 {
                        g.cells[j * nx + i].push(id);
                    }
                }
            }
        }
        g
    }

    fn cell_of(&self, p: &Point2) -> (usize, usize) {
        let i = ((p.x - self.origin.x) / self.cell).floor().clamp(0.0, (self.nx - 1) as f64) as usize;
        let j = ((p.y - self.origin.y) / self.cell).floor().clamp(0.0, (self.ny - 1) as f64) as usize;
        (i, j)
    }

    /// Whether some segment is within `d` (<= cell) of `p`.
    pub fn within(&self, p: &Point2, d: f64) -> bool {
        let (ci, cj) = self.cell_of(p);
        for j in cj.saturating_sub(1)..=(cj + 1).min(self.ny - 1) {
            for i in ci.saturating_sub(1)..=(ci + 1).min(self.nx - 1) {
                for &s in &self.cells[j * self.nx + i] {
                    let (a, b) = self.segs[s as usize];
                    if point_segment_distance(p, &a, &b) <= d {
                        return true;
                    }
                }
            }
        }
        false
    }
}

/// Material points of a layer (inside the stock rectangle, outside the keep-out, and
/// within 0.98 r of the free region: the tool can reach them) not within `r (1 + 1e-6)` of
/// the layer's contour or clearing paths. Sampled on a grid of spacing `step`.
pub fn uncovered(
    plan: &LayerPlan,
    keepout: &s2g_toolpath::Region2,
    lo: Point2,
    hi: Point2,
    r: f64,
    step: f64,
) -> Vec<Point2> {
    let paths: Vec<&Polyline2> = plan.contour.iter().chain(&plan.clearing).collect();
    let grid = PathGrid::new(
        &paths,
        Point2::new(lo.x - 2.0 * r, lo.y - 2.0 * r),
        Point2::new(hi.x + 2.0 * r, hi.y + 2.0 * r),
        1.01 * r,
    );
    let free = plan.free.index();
    let keep = keepout.index();
    let mut out = Vec::new();
    let nx = ((hi.x - lo.x) / step).floor() as usize;
    let ny = ((hi.y - lo.y) / step).floor() as usize;
    for j in 0..=ny {
        for i in 0..=nx {
            let q = Point2::new(lo.x + i as f64 * step + 0.37 * step, lo.y + j as f64 * step + 0.41 * step);
            if q.x > hi.x || q.y > hi.y || keep.contains(&q) {
                continue;
            }
            let reachable = free.contains(&q) || free.boundary_distance(&q, r) < 0.98 * r;
            if reachable && !grid.within(&q, r * (1.0 + 1e-6)) {
                out.push(q);
            }
        }
    }
    out
}

/// Moves of a recorded program: (is_rapid, from, to).
pub fn moves(rec: &MotionRecorder) -> Vec<(bool, Point3, Point3)> {
    let mut out = Vec::new();
    let mut pos: Option<Point3> = None;
    for (_, m) in &rec.motions {
        let (rapid, to) = match m {
            Motion::Rapid { to } => (true, *to),
            Motion::Linear { to, .. } | Motion::Arc { to, .. } => (false, *to),
            _ => continue,
        };
        if let Some(p) = pos {
            out.push((rapid, p, to));
        }
        pos = Some(to);
    }
    out
}

/// An oracle, independent of the planner's regions, of what the tool body (a vertical
/// cylinder from the tip up) must stay out of: the horizontal distance from `p` to the
/// part's material above the level `z` (0 where `p` lies under the part).
pub trait Above {
    fn above(&self, p: &Point2, z: f64) -> f64;
}

impl Above for HeightField {
    fn above(&self, p: &Point2, z: f64) -> f64 {
        self.distance_above(p, z, 1e-7)
    }
}

/// [`Above`] for a triangle mesh through geom's BVH closest-point query: at each level the
/// part's triangles (setup frame) are clipped to `z >= level + tol` and flattened onto the
/// plane z = 0, so the 3-D distance from `(x, y, 0)` to that flat soup is exactly the
/// horizontal distance to the material above the level. A query between two levels uses
/// the level below it (more material: conservative).
pub struct MeshAbove {
    levels: Vec<f64>,
    index: Vec<Option<MeshIndex>>,
}

impl MeshAbove {
    pub fn new(part: &Mesh, setup: &Setup, levels: &[f64], tol: f64) -> Self {
        let tris: Vec<[Point3; 3]> = part.triangle_points().map(|t| t.map(|p| setup.to_setup(&p))).collect();
        let index = levels
            .iter()
            .map(|&z| {
                let mut soup = Vec::new();
                for t in &tris {
                    let poly = clip_above(t, z + tol);
                    for k in 1..poly.len().saturating_sub(1) {
                        soup.push([poly[0], poly[k], poly[k + 1]].map(|p| Point3::new(p.x, p.y, 0.0)));
                    }
                }
                (!soup.is_empty())
                    .then(|| MeshIndex::new(&Mesh::from_soup(&soup).expect("finite")).expect("index"))
            })
            .collect();
        Self { levels: levels.to_vec(), index }
    }
}

impl Above for MeshAbove {
    fn above(&self, p: &Point2, z: f64) -> f64 {
        // Levels descend: the first one at or below z.
        let l = self.levels.partition_point(|&lv| lv > z + 1e-12);
        assert!(l < self.levels.len(), "query at z {z} below the lowest level {:?}", self.levels.last());
        match &self.index[l] {
            Some(idx) => idx.closest_point(&Point3::new(p.x, p.y, 0.0)).distance,
            None => f64::INFINITY,
        }
    }
}

/// The part of a triangle with `z >= bound` (Sutherland-Hodgman; a convex polygon).
fn clip_above(tri: &[Point3; 3], bound: f64) -> Vec<Point3> {
    let mut out = Vec::with_capacity(4);
    for i in 0..3 {
        let (a, b) = (tri[i], tri[(i + 1) % 3]);
        let (ia, ib) = (a.z >= bound, b.z >= bound);
        if ia {
            out.push(a);
        }
        if ia != ib {
            let mut p = a + (b - a) * ((bound - a.z) / (b.z - a.z));
            p.z = bound;
            out.push(p);
        }
    }
    out
}

/// The true part for 3-D signed-distance checks: a distance field in the part frame, the
/// setup that maps setup coordinates into it, and how sparsely [`check_program`] asks it
/// (every `every`-th cutting sample: the winding-number sign near the surface is the
/// test's costliest query).
pub struct Truth<'a> {
    pub sdf: &'a dyn SignedDistance,
    pub setup: Setup,
    pub every: usize,
}

impl Truth<'_> {
    /// Checks a tool-tip position (setup frame) against the part's signed distance: the tip
    /// is not inside the part, and the point on the tool axis one radius above the tip is
    /// outside the part and at least `r` from its surface (everything above the level is
    /// at least `r` away horizontally, everything below at least `r` vertically).
    pub fn check_tip(&self, what: &str, tip: &Point3, r: f64) {
        let d0 = self.sdf.distance(&self.setup.to_part(tip));
        assert!(d0 >= -1e-6, "{what}: tool tip {tip:?} is inside the part (signed distance {d0})");
        let lifted = Point3::new(tip.x, tip.y, tip.z + r);
        let d1 = self.sdf.distance(&self.setup.to_part(&lifted));
        assert!(d1 >= r - 1e-7, "{what}: tool axis at {lifted:?} is {d1} from the part (< r = {r})");
    }
}

/// Allowed tool-centre positions while cutting: within the stock's outline grown by the
/// tool radius in x and y (the cutter's side may reach the stock's side faces from
/// outside, never further), and between the stock bottom and the clearance plane in z.
pub fn inside_stock(p: &Point3, stock: &Aabb, r: f64, clear_z: f64) -> bool {
    let e = 1e-9;
    p.x >= stock.min.x - r - e
        && p.x <= stock.max.x + r + e
        && p.y >= stock.min.y - r - e
        && p.y <= stock.max.y + r + e
        && p.z >= stock.min.z - e
        && p.z <= clear_z + e
}

/// What a program check saw.
#[derive(Debug, Default)]
pub struct ProgramCounts {
    pub cutting_points: usize,
    pub sd_checks: usize,
    pub rapids_below_top: usize,
    pub helices: usize,
}

/// Checks a recorded single-setup program (setup-frame coordinates):
/// - every feed move (lines sampled every `step` of travel, helices over their whole circle) keeps
///   the tool centre inside the stock allowance ([`inside_stock`]) and at least `r` from
///   the material above its tip (`above`; and the part's signed distance with `truth`);
/// - rapids run either at or above the stock top, or straight down, never below the
///   deepest level machined before the current layer began (material below it remains),
///   or straight up from the tool's position, and never with part material above within
///   `r` of the tool centre.
#[allow(clippy::too_many_arguments)] // A test helper: each argument is one piece of the setup.
pub fn check_program(
    name: &str,
    rec: &MotionRecorder,
    stock: &Aabb,
    r: f64,
    clear_z: f64,
    above: &dyn Above,
    truth: Option<&Truth<'_>>,
    step: f64,
) -> ProgramCounts {
    assert!(
        matches!(rec.motions.first(), Some((_, Motion::Setup { .. }))),
        "{name}: first motion is the setup"
    );
    let top = stock.max.z;
    let mut counts = ProgramCounts::default();
    let mut pos: Option<Point3> = None;
    let mut layer: Option<f64> = None;
    let mut machined = top;
    let mut travelled = 0.0;
    let check_cut = |q: &Point3, counts: &mut ProgramCounts| {
        counts.cutting_points += 1;
        let sd_check = truth.filter(|t| counts.cutting_points.is_multiple_of(t.every.max(1)));
        assert!(
            inside_stock(q, stock, r, clear_z),
            "{name}: cutting at {q:?} outside the stock allowance {stock:?} (r {r})"
        );
        let d = above.above(&Point2::new(q.x, q.y), q.z);
        assert!(d >= r - 1e-7, "{name}: cutting at {q:?} is {d} from the part above (< r = {r})");
        if let Some(t) = sd_check {
            counts.sd_checks += 1;
            t.check_tip(name, q, r);
        }
    };
    for (_, m) in &rec.motions {
        match m {
            Motion::Marker(Marker::Layer { z: Some(z), .. }) => {
                if let Some(prev) = layer {
                    machined = prev;
                }
                layer = Some(*z);
            }
            Motion::Rapid { to } => {
                if let Some(a) = pos {
                    let b = *to;
                    let over = a.z >= top - 1e-12 && b.z >= top - 1e-12;
                    let vertical = (a.x - b.x).abs() < 1e-12 && (a.y - b.y).abs() < 1e-12;
                    assert!(over || vertical, "{name}: horizontal rapid below the stock top {a:?} -> {b:?}");
                    if !over {
                        counts.rapids_below_top += 1;
                        let lowest = a.z.min(b.z);
                        // Retracts leave from the tool's own position; descents must stop
                        // above the material that remains.
                        assert!(
                            b.z >= a.z || b.z >= machined - 1e-9,
                            "{name}: rapid to {b:?} goes below {machined}, the deepest level machined so far"
                        );
                        let d = above.above(&Point2::new(b.x, b.y), lowest);
                        assert!(d >= r - 1e-7, "{name}: rapid down to {b:?} meets the part ({d} < r = {r})");
                    }
                }
                pos = Some(*to);
            }
            Motion::Linear { to, .. } => {
                // Every end point against the stock; the oracles at points spaced `step`
                // along the travelled path (not per move: arcs come as many tiny moves).
                let a = pos.unwrap_or(*to);
                assert!(
                    inside_stock(to, stock, r, clear_z),
                    "{name}: cutting to {to:?} outside the stock allowance {stock:?} (r {r})"
                );
                let len = (to - a).norm();
                let total = travelled + len;
                let n = (total / step).floor() as usize;
                for k in 1..=n {
                    let t = (k as f64 * step - travelled) / len;
                    check_cut(&(a + (to - a) * t), &mut counts);
                }
                travelled = total - n as f64 * step;
                pos = Some(*to);
            }
            Motion::Arc { to, center, plane, .. } => {
                assert_eq!(*plane, Plane::XY, "{name}: arcs only in the XY plane");
                let a = pos.expect("an arc starts somewhere");
                counts.helices += 1;
                // The whole circle (superset of the swept arc) at the lower end of the helix.
                let rad = ((a.x - center.x).powi(2) + (a.y - center.y).powi(2)).sqrt();
                let n = ((std::f64::consts::TAU * rad / step).ceil() as usize).max(8);
                let z = a.z.min(to.z);
                for k in 0..n {
                    let t = std::f64::consts::TAU * k as f64 / n as f64;
                    check_cut(
                        &Point3::new(center.x + rad * t.cos(), center.y + rad * t.sin(), z),
                        &mut counts,
                    );
                }
                check_cut(&Point3::new(a.x, a.y, a.z.max(to.z)), &mut counts);
                pos = Some(*to);
            }
            _ => {}
        }
    }
    counts
}

/// A UV sphere of radius `r` about the origin, `nu` segments around and `nv` from pole to
/// pole, outward wound, its vertices on the sphere.
pub fn sphere(r: f64, nu: usize, nv: usize) -> Mesh {
    let mut v = vec![Point3::new(0.0, 0.0, r)];
    for j in 1..nv {
        let t = std::f64::consts::PI * j as f64 / nv as f64;
        for i in 0..nu {
            let p = std::f64::consts::TAU * i as f64 / nu as f64;
            v.push(Point3::new(r * t.sin() * p.cos(), r * t.sin() * p.sin(), r * t.cos()));
        }
    }
    v.push(Point3::new(0.0, 0.0, -r));
    let south = (v.len() - 1) as u32;
    let at = |j: usize, i: usize| (1 + (j - 1) * nu + i % nu) as u32;
    let mut t = Vec::new();
    for i in 0..nu {
        t.push([0, at(1, i), at(1, i + 1)]);
        t.push([south, at(nv - 1, i + 1), at(nv - 1, i)]);
        for j in 1..nv - 1 {
            t.push([at(j, i), at(j + 1, i), at(j + 1, i + 1)]);
            t.push([at(j, i), at(j + 1, i + 1), at(j, i + 1)]);
        }
    }
    Mesh::new(v, t).expect("sphere")
}

/// What the boss's roughing left: a 0.3 mm radial allowance, stock up to 2.3 mm above the
/// part under a cleared position, a 12 mm end mill, the stock's top at 51.
pub fn boss_roughed() -> RoughedStock {
    RoughedStock {
        radial: 0.3,
        axial: 2.3,
        tool_radius: 6.0,
        top: 51.0,
        faces: [[0.0, 0.0, 1.0, 51.0]; 3],
        clearance: 0.0,
    }
}
