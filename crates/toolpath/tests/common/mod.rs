//! Shared helpers: analytic parts built in code, independent checks.
#![allow(dead_code)] // Each test binary uses a different subset.

use s2g_gcode::{Motion, MotionRecorder};
use s2g_geom::{Mesh, Point3};
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
