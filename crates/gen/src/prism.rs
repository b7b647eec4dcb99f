//! Prismatic (2.5-D) parts: a base outline with an edge treatment or full-width bands
//! (steps, open slots, T-slots), and features that cut into it or stand on it. Each
//! becomes [`Column`]s for the exact mesher ([`crate::stack`]); the callers (the random
//! generator, the shop parts) keep features apart so that no two rings cross or touch.

use crate::error::Result;
use crate::feature::Feature;
use crate::ring::{P2, Ring, circle, rounded_rect, rounded_rect_centered, snap, stadium};
use crate::stack::{Built, Column, build};

/// Chords per quarter arc of a rounded corner.
pub(crate) const CORNER_SEGMENTS: usize = 8;
/// Sides of a hole or boss.
pub(crate) const CIRCLE_SEGMENTS: usize = 48;
/// Sides of a disc outline.
pub(crate) const DISC_SEGMENTS: usize = 96;

/// The base outline, centred on the z axis.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Outline {
    /// A rectangle of half sides `h` with corner radius `r`.
    Rect { h: [f64; 2], r: f64 },
    /// A disc of radius `r`.
    Disc { r: f64 },
}

impl Outline {
    /// The outline inset by `d` (a rounded corner's radius shrinks by `d`, a sharp one
    /// stays sharp).
    fn inset(&self, d: f64) -> Ring {
        match *self {
            Outline::Rect { h, r } => {
                let rr = if r > 0.0 { r - d } else { 0.0 };
                rounded_rect_centered([0.0, 0.0], [h[0] - d, h[1] - d], rr, CORNER_SEGMENTS)
            }
            Outline::Disc { r } => circle([0.0, 0.0], r - d, DISC_SEGMENTS),
        }
    }
}

/// A treatment of the base's top edge, or of its walls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Edge {
    None,
    Chamfer(f64),
    /// Radius and facets.
    Fillet(f64, usize),
    /// Draft angle, radians.
    Draft(f64),
}

impl Edge {
    /// How far the outline moves in at the top.
    pub(crate) fn inset(&self, height: f64) -> f64 {
        match *self {
            Edge::None => 0.0,
            Edge::Chamfer(c) => c,
            Edge::Fillet(r, _) => r,
            Edge::Draft(a) => height * a.tan(),
        }
    }
}

/// A band removed across the whole part between two heights: values `lo..hi` of y
/// (`across_y`, a channel along x) or of x.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Band {
    pub(crate) across_y: bool,
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) z0: f64,
    pub(crate) z1: f64,
}

/// A prismatic part under construction.
#[derive(Debug, Clone)]
pub(crate) struct Prism {
    pub(crate) outline: Outline,
    pub(crate) height: f64,
    pub(crate) edge: Edge,
    pub(crate) bands: Vec<Band>,
    pub(crate) columns: Vec<Column>,
    pub(crate) features: Vec<Feature>,
}

impl Prism {
    /// A base of `outline` and `height` with a top-edge treatment (no bands).
    pub(crate) fn new(outline: Outline, height: f64, edge: Edge) -> Self {
        let height = snap(height);
        let mut features = vec![match outline {
            Outline::Rect { h, r } => {
                Feature::Block { size: [2.0 * h[0], 2.0 * h[1], height], corner_radius: r }
            }
            Outline::Disc { r } => Feature::Disc { diameter: 2.0 * r, height, segments: DISC_SEGMENTS },
        }];
        match edge {
            Edge::None => {}
            Edge::Chamfer(c) => features.push(Feature::Chamfer { size: c }),
            Edge::Fillet(r, steps) => features.push(Feature::Fillet { radius: r, steps }),
            Edge::Draft(a) => features.push(Feature::Draft { angle_deg: a.to_degrees() }),
        }
        Self { outline, height, edge, bands: Vec::new(), columns: Vec::new(), features }
    }

    /// The base's columns: one lofted column, or pieces between the bands.
    fn base_columns(&self) -> Vec<Column> {
        let h = self.height;
        if self.bands.is_empty() {
            let o = &self.outline;
            let stations = match self.edge {
                Edge::None => vec![(0.0, o.inset(0.0)), (h, o.inset(0.0))],
                Edge::Chamfer(c) => vec![(0.0, o.inset(0.0)), (h - c, o.inset(0.0)), (h, o.inset(c))],
                Edge::Fillet(r, k) => {
                    let mut s = vec![(0.0, o.inset(0.0))];
                    for j in 0..=k {
                        let t = std::f64::consts::FRAC_PI_2 * j as f64 / k as f64;
                        s.push((h - r + r * t.sin(), o.inset(r * (1.0 - t.cos()))));
                    }
                    s
                }
                Edge::Draft(a) => vec![(0.0, o.inset(0.0)), (h, o.inset(h * a.tan()))],
            };
            return vec![Column::lofted(stations)];
        }
        let Outline::Rect { h: half, r } = self.outline else { return Vec::new() };
        let mut zs: Vec<f64> = vec![0.0, h];
        zs.extend(self.bands.iter().flat_map(|b| [b.z0, b.z1]));
        zs.sort_by(f64::total_cmp);
        zs.dedup();
        let mut out = Vec::new();
        for w in zs.windows(2) {
            let active: Vec<&Band> = self.bands.iter().filter(|b| b.z0 <= w[0] && w[1] <= b.z1).collect();
            let xs = intervals(-half[0], half[0], active.iter().filter(|b| !b.across_y));
            let ys = intervals(-half[1], half[1], active.iter().filter(|b| b.across_y));
            for &(x0, x1) in &xs {
                for &(y0, y1) in &ys {
                    let corner =
                        |x: f64, y: f64| if x.abs() == half[0] && y.abs() == half[1] { r } else { 0.0 };
                    let radii = [corner(x1, y0), corner(x1, y1), corner(x0, y1), corner(x0, y0)];
                    out.push(Column::straight(
                        rounded_rect(x0, y0, x1, y1, radii, CORNER_SEGMENTS),
                        w[0],
                        w[1],
                    ));
                }
            }
        }
        out
    }

    /// Meshes the part.
    pub(crate) fn build(&self) -> Result<Built> {
        let mut columns = self.base_columns();
        columns.extend(self.columns.iter().cloned());
        build(&columns)
    }

    /// A step: the top lowered to `z` for `x >= x_from`.
    pub(crate) fn step(&mut self, x_from: f64, z: f64) {
        let (x_from, z) = (snap(x_from), snap(z));
        self.bands.push(Band { across_y: false, lo: x_from, hi: f64::INFINITY, z0: z, z1: self.height });
        self.features.push(Feature::Step { x_from, z });
    }

    /// An open channel along x, `width` wide around `y`, `depth` deep.
    pub(crate) fn open_slot(&mut self, y: f64, width: f64, depth: f64) {
        let (lo, hi, z0) = (snap(y - width / 2.0), snap(y + width / 2.0), snap(self.height - depth));
        self.bands.push(Band { across_y: true, lo, hi, z0, z1: self.height });
        self.features.push(Feature::OpenSlot { center_y: y, width, depth });
    }

    /// A T-slot along x around `y`: neck `(width, depth)` from the top, head
    /// `(width, height)` below it.
    pub(crate) fn t_slot(&mut self, y: f64, neck: [f64; 2], head: [f64; 2]) {
        let zn = snap(self.height - neck[1]);
        let zh = snap(zn - head[1]);
        let band =
            |w: f64, z0, z1| Band { across_y: true, lo: snap(y - w / 2.0), hi: snap(y + w / 2.0), z0, z1 };
        self.bands.push(band(neck[0], zn, self.height));
        self.bands.push(band(head[0], zh, zn));
        self.features.push(Feature::TSlot {
            center_y: y,
            neck_width: neck[0],
            neck_depth: neck[1],
            head_width: head[0],
            head_height: head[1],
        });
    }

    /// A hole of diameter `d` from `z_top` down to `z_bottom`, with a countersink leg `cs`.
    pub(crate) fn hole(&mut self, c: P2, d: f64, z_top: f64, z_bottom: f64, cs: f64) {
        let ring = |extra: f64| circle(c, d / 2.0 + extra, CIRCLE_SEGMENTS).reversed();
        let column = if cs > 0.0 {
            Column::lofted(vec![(z_bottom, ring(0.0)), (z_top - cs, ring(0.0)), (z_top, ring(cs))])
        } else {
            Column::straight(ring(0.0), z_bottom, z_top)
        };
        self.columns.push(column);
        self.features.push(Feature::Hole {
            center: c,
            diameter: d,
            z_top,
            depth: z_top - z_bottom,
            countersink: cs,
        });
    }

    /// A counterbored hole: hole `d` from `z_bottom` up, bore `bd` for the top `bdepth`.
    pub(crate) fn counterbore(&mut self, c: P2, d: f64, bd: f64, bdepth: f64, z_top: f64, z_bottom: f64) {
        let zb = z_top - bdepth;
        self.columns.push(Column::straight(circle(c, d / 2.0, CIRCLE_SEGMENTS).reversed(), z_bottom, zb));
        self.columns.push(Column::straight(circle(c, bd / 2.0, CIRCLE_SEGMENTS).reversed(), zb, z_top));
        self.features.push(Feature::Counterbore {
            center: c,
            diameter: d,
            bore_diameter: bd,
            bore_depth: bdepth,
            z_top,
            depth: z_top - z_bottom,
        });
    }

    /// A rounded-rectangle pocket of half sides `h`, corner radius `r`, from `z_top`
    /// down to `z_bottom`, its walls drafted by `draft` radians (inset at the floor).
    pub(crate) fn pocket(&mut self, c: P2, h: [f64; 2], r: f64, z_top: f64, z_bottom: f64, draft: f64) {
        let ring = |d: f64| rounded_rect_centered(c, [h[0] - d, h[1] - d], r - d, CORNER_SEGMENTS).reversed();
        let inset = (z_top - z_bottom) * draft.tan();
        self.columns.push(Column::lofted(vec![(z_bottom, ring(inset)), (z_top, ring(0.0))]));
        self.features.push(Feature::Pocket {
            center: c,
            size: [2.0 * h[0], 2.0 * h[1]],
            corner_radius: r,
            z_top,
            depth: z_top - z_bottom,
            draft_deg: draft.to_degrees(),
        });
    }

    /// A round pocket of diameter `d`.
    pub(crate) fn circular_pocket(&mut self, c: P2, d: f64, z_top: f64, z_bottom: f64) {
        self.columns.push(Column::straight(circle(c, d / 2.0, CIRCLE_SEGMENTS).reversed(), z_bottom, z_top));
        self.features.push(Feature::CircularPocket {
            center: c,
            diameter: d,
            z_top,
            depth: z_top - z_bottom,
        });
    }

    /// An obround slot of `length` (end to end) and `width`.
    pub(crate) fn slot(&mut self, c: P2, length: f64, width: f64, along_x: bool, z_top: f64, z_bottom: f64) {
        let ring = stadium(c, (length - width) / 2.0, width / 2.0, along_x, CORNER_SEGMENTS).reversed();
        self.columns.push(Column::straight(ring, z_bottom, z_top));
        self.features.push(Feature::Slot {
            center: c,
            length,
            width,
            along_x,
            z_top,
            depth: z_top - z_bottom,
        });
    }

    /// A round boss of diameter `d` on the face at `z_base`, `height` tall, with a top
    /// chamfer leg `ch`.
    pub(crate) fn boss(&mut self, c: P2, d: f64, z_base: f64, height: f64, ch: f64) {
        let ring = |inset: f64| circle(c, d / 2.0 - inset, CIRCLE_SEGMENTS);
        let top = z_base + height;
        let column = if ch > 0.0 {
            Column::lofted(vec![(z_base, ring(0.0)), (top - ch, ring(0.0)), (top, ring(ch))])
        } else {
            Column::straight(ring(0.0), z_base, top)
        };
        self.columns.push(column);
        self.features.push(Feature::Boss { center: c, diameter: d, z_base, height, chamfer: ch });
    }

    /// A rib of half sides `h` on the face at `z_base`, `height` tall.
    pub(crate) fn rib(&mut self, c: P2, h: [f64; 2], z_base: f64, height: f64) {
        let ring = rounded_rect_centered(c, h, 0.0, 1);
        self.columns.push(Column::straight(ring, z_base, z_base + height));
        self.features.push(Feature::Rib { center: c, size: [2.0 * h[0], 2.0 * h[1]], z_base, height });
    }

    #[cfg(test)]
    /// A ring of another shape cut from `z_bottom` to `z_top` (already clockwise).
    pub(crate) fn raw_cut(&mut self, ring: Ring, z_bottom: f64, z_top: f64) {
        self.columns.push(Column::straight(ring, z_bottom, z_top));
    }
}

/// `[lo, hi]` minus the bands' `lo..hi` ranges, as sorted intervals.
fn intervals<'a>(lo: f64, hi: f64, bands: impl Iterator<Item = &'a &'a Band>) -> Vec<(f64, f64)> {
    let mut cuts: Vec<(f64, f64)> =
        bands.map(|b| (b.lo.max(lo), b.hi.min(hi))).filter(|c| c.0 < c.1).collect();
    cuts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out = Vec::new();
    let mut at = lo;
    for (a, b) in cuts {
        if a > at {
            out.push((at, a));
        }
        at = at.max(b);
    }
    if at < hi {
        out.push((at, hi));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{Edge, Outline, Prism};
    use s2g_geom::report;

    fn check(p: &Prism, expect: Option<f64>) {
        let b = p.build().unwrap();
        let r = report(&b.mesh);
        assert!(r.closed && r.manifold && r.consistently_oriented, "{r:?}");
        let v = b.mesh.signed_volume();
        assert!((v - b.volume).abs() <= 1e-9 * b.volume, "{v} vs {}", b.volume);
        if let Some(e) = expect {
            assert!((v - e).abs() <= 1e-9 * e, "{v} vs {e}");
        }
    }

    #[test]
    fn simple_solids() {
        let mut p = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 0.0 }, 20.0, Edge::None);
        check(&p, Some(100.0 * 60.0 * 20.0));
        p.raw_cut(crate::ring::rounded_rect(-10.0, -10.0, 10.0, 10.0, [0.0; 4], 1).reversed(), 5.0, 20.0);
        check(&p, Some(100.0 * 60.0 * 20.0 - 400.0 * 15.0));
        p.raw_cut(crate::ring::rounded_rect(-5.0, -5.0, 5.0, 5.0, [0.0; 4], 1).reversed(), 0.0, 5.0);
        check(&p, Some(100.0 * 60.0 * 20.0 - 400.0 * 15.0 - 500.0));
        let mut t = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 5.0 }, 40.0, Edge::None);
        t.t_slot(0.0, [12.0, 12.0], [22.0, 10.0]);
        check(&t, None);
        let mut s = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 5.0 }, 40.0, Edge::None);
        s.step(10.0, 20.0);
        s.open_slot(-10.0, 8.0, 5.0);
        check(&s, None);
        let mut c = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 8.0 }, 20.0, Edge::Chamfer(2.0));
        c.pocket([0.0, 0.0], [20.0, 10.0], 4.0, 20.0, 10.0, 0.1);
        c.hole([35.0, 0.0], 6.0, 20.0, 0.0, 1.0);
        c.boss([-35.0, 0.0], 12.0, 20.0, 10.0, 1.0);
        c.counterbore([35.0, 20.0], 6.0, 10.0, 4.0, 20.0, 0.0);
        c.slot([-30.0, -20.0], 20.0, 6.0, true, 20.0, 15.0);
        c.rib([0.0, 20.0], [15.0, 2.0], 20.0, 8.0);
        check(&c, None);
        let f = Prism::new(Outline::Disc { r: 40.0 }, 20.0, Edge::Fillet(4.0, 5));
        check(&f, None);
        let d = Prism::new(Outline::Rect { h: [50.0, 30.0], r: 8.0 }, 20.0, Edge::Draft(0.05));
        check(&d, None);
    }
}
