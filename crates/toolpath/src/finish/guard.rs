//! The finisher's shank and holder check (issue 35): a finishing tool's shank and holder
//! must not touch the stock the roughing left, which lies near the part.
//!
//! The in-process stock is modelled conservatively from the part and the roughing tool
//! ([`RoughedStock`]): a roughing level at height `z` cleared every tool-centre position
//! `c` whose flat disc of the tool's radius `R` grown by the radial allowance `a` holds no
//! part above `z` (the level's keep-out), and with it the disc of radius `R` about `c`;
//! the levels stand a layer apart and the tip keeps the axial allowance over the faces
//! below, so above `c` no stock stands higher than `d + h`, where `d` is the flat drop
//! height of radius `R + a` at `c` and `h` the layer, the axial allowance and the arc
//! tolerance. A guard of radius `g` (the shank, from the flutes' top to the stick-out;
//! the holder above it) about the tool axis at `p` is then clear of the stock when its
//! bottom lies above `d + h` for a flat drop of radius `R + a` at `p` where `R >= g` (the
//! disc cut about `p` holds the guard's), else of radius `g + R + a` (every point of the
//! guard's disc was itself a cleared centre); or when its bottom lies above the stock's
//! top. Stock in a notch of the part narrower than the roughing tool, which a model of
//! "stock within the allowance of the part" misses, is inside such a disc. The check reads
//! the part only (a drop-cutter per guard), never a voxel grid: two BVH queries a point.

// NaN-aware negated comparisons (`!(x > 0.0)`) are deliberate: NaN takes the safe branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use s2g_geom::{Cutter, DropCutter, MeshIndex, Point3};

use super::strategy::end_run;
use crate::error::ToolpathError;

/// What the roughing left for the finisher's shank and holder check (setup frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoughedStock {
    /// The roughing's radial allowance (and arc tolerance).
    pub radial: f64,
    /// How high stock may stand above the part's highest point under a cleared position:
    /// the layer, the axial allowance and the arc tolerance.
    pub axial: f64,
    /// The roughing tool's radius.
    pub tool_radius: f64,
    /// The stock's top: no stock above it.
    pub top: f64,
    /// The stock's upward faces in the setup frame, `[nx, ny, nz, d]` with `nz > 0`: no
    /// stock where `nx x + ny y + nz z > d` (a box on an oblique axis has up to three; an
    /// unused one is `[0, 0, 1, inf]`). Over a guard's disc of radius `g` about `(x, y)`
    /// the stock is then no higher than `(d - nx x - ny y + g |(nx, ny)|) / nz` for each.
    pub faces: [[f64; 4]; 3],
    /// How far the shank and holder keep from the stock modelled above, across the axis
    /// and along it (0 lets them pass it touching). The model is exact only to the
    /// programs' tolerances: the roughing's arcs (on the part's side) and the finisher's
    /// own are fitted within the arc tolerance, and coordinates are rounded; a shank passing a wall
    /// cut to size 0.007 mm off it (stress/bushing_32's 8 mm ball beside the tube, at
    /// 256^3) met the stock those left.
    pub clearance: f64,
}

impl RoughedStock {
    /// The highest the stock can stand over the disc of radius `g` about `(x, y)`.
    fn top_over(&self, x: f64, y: f64, g: f64) -> f64 {
        self.faces
            .iter()
            .filter(|f| f[2] > 0.0)
            .map(|f| (f[3] - f[0] * x - f[1] * y + g * f[0].hypot(f[1])) / f[2])
            .fold(self.top, f64::min)
    }
}

/// The pass points the check left out ([`Guard::split`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LeftOut {
    /// How many.
    pub points: usize,
    /// The stretches of passes they stand for (tip positions, setup frame): a segment
    /// between each two consecutive points of a pass left out, and a lone one as a
    /// segment from itself to itself.
    pub stretches: Vec<[Point3; 2]>,
}

/// One guard (the shank or the holder): a flat cutter of the radius the check needs, and
/// where the guard's bottom lies above the tip.
struct Part<'a> {
    dc: DropCutter<'a>,
    /// The guard's bottom above the tip.
    bottom: f64,
    /// The guard's radius.
    radius: f64,
}

/// The shank and holder of a finishing tool against the stock left around the part
/// (setup frame, tool axis +Z).
pub(super) struct Guard<'a> {
    parts: Vec<Part<'a>>,
    stock: RoughedStock,
}

impl<'a> Guard<'a> {
    /// The guard of `cutter` (its shank where the stick-out is longer than the flutes, its
    /// holder where it has one) over `part`, against `stock`; `None` for a cutter with
    /// neither (unlimited flutes, the paper's tools).
    pub(super) fn new<E>(
        part: &'a MeshIndex,
        cutter: &Cutter,
        stock: RoughedStock,
    ) -> Result<Option<Self>, ToolpathError<E>> {
        let mut parts = Vec::new();
        let rt = stock.tool_radius;
        let mut add = |g: f64, bottom: f64| -> Result<(), ToolpathError<E>> {
            if g.is_finite() && g > 0.0 && bottom.is_finite() {
                let r = if rt >= g { rt } else { g + rt } + stock.radial + stock.clearance;
                let dc = DropCutter::new(part, &Cutter::flat(r, 1.0))
                    .map_err(|e| ToolpathError::InvalidTool(e.to_string()))?;
                parts.push(Part { dc, bottom, radius: g });
            }
            Ok(())
        };
        if let Some(n) = cutter.neck {
            add(n.radius, cutter.flute_length)?;
        }
        if cutter.stickout > cutter.shank_start() {
            add(cutter.shank_radius, cutter.shank_start())?;
        }
        if let Some(h) = cutter.holder {
            add(h.radius, cutter.stickout)?;
        }
        Ok((!parts.is_empty()).then_some(Self { parts, stock }))
    }

    /// Whether the shank and holder are clear of the stock with the tip at `p`.
    pub(super) fn clear(&self, p: &Point3) -> bool {
        let s = &self.stock;
        let c = s.clearance;
        self.parts.iter().all(|g| {
            let bottom = p.z + g.bottom;
            bottom >= s.top_over(p.x, p.y, g.radius + c) + c
                || !g.dc.interferes(p.x, p.y, bottom - s.axial - c)
        })
    }

    /// The lowest tip height over `(x, y)` at which the shank and holder are clear of the
    /// stock; `None` where no part lies under either guard.
    pub(super) fn lowest(&self, x: f64, y: f64) -> Option<f64> {
        let (s, c) = (&self.stock, self.stock.clearance);
        self.parts
            .iter()
            .filter_map(|g| {
                g.dc.height(x, y)
                    .map(|h| (h + s.axial + c).min(s.top_over(x, y, g.radius + c) + c) - g.bottom)
            })
            .reduce(f64::max)
    }

    /// `paths` with every point whose guard is not clear left out, split there, and split
    /// too between two clear points where a sample of the chord `step` apart is not; runs
    /// of fewer than two points are dropped. Returns the paths and the points left out,
    /// as stretches: a segment between each two consecutive points of a path left out,
    /// and a lone one as a segment from itself to itself.
    pub(super) fn split(&self, paths: Vec<Vec<Point3>>, step: f64) -> (Vec<Vec<Point3>>, LeftOut) {
        use rayon::prelude::*;
        let parts: Vec<(Vec<Vec<Point3>>, LeftOut)> =
            paths.into_par_iter().map(|p| self.split_one(&p, step)).collect();
        let mut left = LeftOut::default();
        let mut out = Vec::new();
        for (p, l) in parts {
            out.extend(p);
            left.points += l.points;
            left.stretches.extend(l.stretches);
        }
        (out, left)
    }

    fn split_one(&self, path: &[Point3], step: f64) -> (Vec<Vec<Point3>>, LeftOut) {
        let (mut out, mut run, mut left) = (Vec::new(), Vec::new(), LeftOut::default());
        let mut previous: Option<Point3> = None;
        for p in path {
            if !self.clear(p) {
                left.points += 1;
                left.stretches.push([previous.unwrap_or(*p), *p]);
                previous = Some(*p);
                end_run(&mut run, &mut out);
                continue;
            }
            previous = None;
            if let Some(a) = run.last()
                && !self.chord_clear(a, p, step)
            {
                end_run(&mut run, &mut out);
            }
            run.push(*p);
        }
        end_run(&mut run, &mut out);
        (out, left)
    }

    /// Whether the guard is clear at samples `step` apart along `a`-`b` (ends excluded).
    pub(super) fn chord_clear(&self, a: &Point3, b: &Point3, step: f64) -> bool {
        let d = b - a;
        let n = (d.norm() / step).ceil();
        if !(n <= 1e7) {
            return false;
        }
        let n = n.max(1.0) as usize;
        (1..n).all(|k| self.clear(&(a + d * (k as f64 / n as f64))))
    }
}

#[cfg(test)]
mod tests {
    use s2g_geom::{Aabb, Holder, Mesh};

    use super::*;

    /// A 10 mm ball with 30 mm flutes, 56 mm stick-out and a 35 mm holder.
    fn ball10() -> Cutter {
        let mut c = Cutter::ball(5.0, 30.0);
        c.stickout = 56.0;
        c.holder = Some(Holder { radius: 17.5, length: 40.0 });
        c
    }

    /// Roughed with a 12 mm end mill, 0.3 radial allowance, 2.3 of axial stock, top 60.
    const STOCK: RoughedStock = RoughedStock {
        radial: 0.3,
        axial: 2.3,
        tool_radius: 6.0,
        top: 60.0,
        faces: [[0.0, 0.0, 1.0, f64::INFINITY]; 3],
        clearance: 0.0,
    };

    fn wall() -> MeshIndex {
        // A block 20 mm wide and 45 mm tall standing on z = 0, its wall at x = 0.
        let m =
            Mesh::cuboid(&Aabb::new(Point3::new(-20.0, -10.0, 0.0), Point3::new(0.0, 10.0, 45.0))).unwrap();
        MeshIndex::new(&m).unwrap()
    }

    #[test]
    fn the_shank_beside_a_wall_taller_than_the_flutes_is_not_clear() {
        let part = wall();
        let g = Guard::new::<()>(&part, &ball10(), STOCK).unwrap().unwrap();
        // The ball at the wall's foot (its axis one radius out): the shank from 30 to 56
        // above the tip is 0 from the wall, which keeps 0.3 of stock up to 45.
        assert!(!g.clear(&Point3::new(5.0, 0.0, 0.0)));
        // The lowest clear tip there: the shank's bottom (30 above the tip) at the wall's
        // top (45) plus the axial stock (2.3).
        let low = g.lowest(5.0, 0.0).unwrap();
        assert!((low - (45.0 + 2.3 - 30.0)).abs() < 1e-9, "{low}");
        assert!(g.clear(&Point3::new(5.0, 0.0, low + 1e-6)));
        assert!(!g.clear(&Point3::new(5.0, 0.0, low - 1e-6)));
        // Where the roughing tool (6 mm radius, 0.3 allowance) could stand, the shank's
        // disc was cut: farther than 6.3 from the wall the holder decides (its bottom 56
        // above the tip, beyond 17.5 + 6 + 0.3 from the wall or above 45 + 2.3).
        assert!(!g.clear(&Point3::new(6.2, 0.0, 0.0)));
        assert!(g.clear(&Point3::new(6.4, 0.0, 0.0)));
        assert!(!g.clear(&Point3::new(10.0, 0.0, -20.0)));
        assert!(g.clear(&Point3::new(23.8 + 1e-6, 0.0, -20.0)));
        // No stock above the stock's top: the holder there is clear, however near the part.
        let low_top = RoughedStock { top: 46.0, ..STOCK };
        let g = Guard::new::<()>(&part, &ball10(), low_top).unwrap().unwrap();
        assert!(g.clear(&Point3::new(10.0, 0.0, -9.5)));
        assert!(!g.clear(&Point3::new(10.0, 0.0, -10.5)));
        // A stock face sloping down along +X at 45 degrees through (0, 0, 60), as an
        // oblique setup's: over a disc of 17.5 about x = 40 it stands at most at
        // 60 - 40 + 17.5; about x = -10 the flat top (60) bounds it.
        let n = std::f64::consts::FRAC_1_SQRT_2;
        let sloped = RoughedStock {
            faces: [[n, 0.0, n, 60.0 * n], [0.0, 0.0, 1.0, f64::INFINITY], [0.0, 0.0, 1.0, f64::INFINITY]],
            ..STOCK
        };
        assert!((sloped.top_over(40.0, 0.0, 17.5) - (60.0 - 40.0 + 17.5)).abs() < 1e-9);
        assert!((sloped.top_over(-10.0, 0.0, 17.5) - 60.0).abs() < 1e-9);
    }

    #[test]
    fn the_clearance_keeps_the_shank_and_holder_that_far_from_the_stock() {
        let part = wall();
        let spaced = RoughedStock { clearance: 0.1, ..STOCK };
        let (g0, g) = (
            Guard::new::<()>(&part, &ball10(), STOCK).unwrap().unwrap(),
            Guard::new::<()>(&part, &ball10(), spaced).unwrap().unwrap(),
        );
        // Across the axis: the shank's disc was cut out to 6.3 from the wall; 0.1 more.
        assert!(g0.clear(&Point3::new(6.35, 0.0, 0.0)));
        assert!(!g.clear(&Point3::new(6.35, 0.0, 0.0)));
        assert!(g.clear(&Point3::new(6.45, 0.0, 0.0)));
        // Along it: over the wall's top (45 + 2.3 of stock) the shank's bottom keeps 0.1.
        let (low0, low) = (g0.lowest(5.0, 0.0).unwrap(), g.lowest(5.0, 0.0).unwrap());
        assert!((low - low0 - 0.1).abs() < 1e-9, "{low0} {low}");
        assert!(g.clear(&Point3::new(5.0, 0.0, low + 1e-6)));
        assert!(!g.clear(&Point3::new(5.0, 0.0, low - 1e-6)));
        // Above the stock's top (46 here): the holder's bottom (56 above the tip) 0.1 over it.
        let low_top = RoughedStock { top: 46.0, ..spaced };
        let g = Guard::new::<()>(&part, &ball10(), low_top).unwrap().unwrap();
        assert!(g.clear(&Point3::new(10.0, 0.0, -9.85)));
        assert!(!g.clear(&Point3::new(10.0, 0.0, -9.95)));
    }

    #[test]
    fn stock_in_a_slot_narrower_than_the_roughing_tool_is_met() {
        // Two blocks 45 mm tall with an 8 mm slot between them (x in -4..4, y in -10..10):
        // the 12 mm roughing tool cannot enter it, so the slot stays full of stock.
        let mut m =
            Mesh::cuboid(&Aabb::new(Point3::new(-20.0, -10.0, 0.0), Point3::new(-4.0, 10.0, 45.0))).unwrap();
        m.append(
            &Mesh::cuboid(&Aabb::new(Point3::new(4.0, -10.0, 0.0), Point3::new(20.0, 10.0, 45.0))).unwrap(),
        );
        let part = MeshIndex::new(&m).unwrap();
        let g = Guard::new::<()>(&part, &ball10(), STOCK).unwrap().unwrap();
        // The shank about (0, 14.8) reaches 0.2 into the slot's mouth, but no part lies
        // within its radius and the allowance (the blocks' corners are 6.25 away): a check
        // of the stock within the allowance of the part alone would pass it.
        let near = DropCutter::new(&part, &Cutter::flat(5.3, 1.0)).unwrap();
        assert!(!near.interferes(0.0, 14.8, 0.0));
        assert!(!g.clear(&Point3::new(0.0, 14.8, 0.0)));
        // Beyond the roughing tool's reach of the blocks it is clear.
        assert!(g.clear(&Point3::new(0.0, 18.0, 0.0)));
    }

    #[test]
    fn a_pass_is_split_where_the_shank_meets_the_stock() {
        let part = wall();
        let g = Guard::new::<()>(&part, &ball10(), STOCK).unwrap().unwrap();
        // A pass along the wall's foot then away from it.
        let path: Vec<Point3> = (0..=40).map(|i| Point3::new(4.0 + 0.25 * f64::from(i), 0.0, 0.0)).collect();
        let (paths, left) = g.split(vec![path.clone()], 0.05);
        let dropped = left.points;
        // Points within 6.3 of the wall are left out (4.0 .. 6.25, ten of them), the
        // stretch between each two consecutive ones and the first on its own.
        assert_eq!(dropped, 10);
        assert_eq!(left.stretches.len(), 10);
        assert_eq!(left.stretches[0], [path[0], path[0]]);
        assert!(left.stretches[1..].iter().zip(path.windows(2)).all(|(s, w)| s == &[w[0], w[1]]));
        assert_eq!(dropped, path.iter().filter(|p| p.x <= 6.3).count());
        assert_eq!(paths.len(), 1);
        assert_eq!(paths[0].len(), path.len() - 10);
        assert!(paths[0].iter().all(|p| p.x > 6.3 && g.clear(p)));
        // No guard for a tool without shank or holder.
        let mut bare = Cutter::ball(5.0, f64::INFINITY);
        bare.stickout = f64::INFINITY;
        assert!(Guard::new::<()>(&part, &bare, STOCK).unwrap().is_none());
    }
}
