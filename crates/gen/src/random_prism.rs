//! Random prismatic parts: a base (a rectangle with rounded corners or a disc) with a
//! top-edge treatment (chamfer, fillet, drafted walls) or full-width bands (a step, an
//! open slot, a T-slot), then 2-7 features placed by rejection so that their footprints
//! keep a gap from each other, from the outline and from the bands.

use s2g_geom::SplitMix64;

use crate::prism::{Edge, Outline, Prism};
use crate::ring::{P2, snap};

/// A uniform draw in `[lo, hi)`, snapped to the grid.
pub(crate) fn draw(rng: &mut SplitMix64, lo: f64, hi: f64) -> f64 {
    snap(rng.uniform(lo, hi))
}

/// Whether a draw with probability `p` succeeds.
pub(crate) fn chance(rng: &mut SplitMix64, p: f64) -> bool {
    rng.unit() < p
}

/// Where features may go: inside the outline inset by `margin`, outside the bands
/// (grown by `gap`) and the footprints already taken (grown by `gap`).
struct Layout {
    outline: Outline,
    margin: f64,
    gap: f64,
    /// Forbidden `[x0, y0, x1, y1]` boxes.
    taken: Vec<[f64; 4]>,
}

impl Layout {
    /// Whether the box of half extents `e` around `c` fits.
    fn fits(&self, c: P2, e: P2) -> bool {
        let b = [c[0] - e[0], c[1] - e[1], c[0] + e[0], c[1] + e[1]];
        let inside = match self.outline {
            Outline::Rect { h, .. } => {
                b[0] >= -h[0] + self.margin
                    && b[2] <= h[0] - self.margin
                    && b[1] >= -h[1] + self.margin
                    && b[3] <= h[1] - self.margin
            }
            Outline::Disc { r } => {
                let far = (c[0].abs() + e[0]).hypot(c[1].abs() + e[1]);
                far <= r - self.margin
            }
        };
        let g = self.gap;
        inside
            && self
                .taken
                .iter()
                .all(|t| b[2] + g <= t[0] || t[2] + g <= b[0] || b[3] + g <= t[1] || t[3] + g <= b[1])
    }

    /// A centre where a box of half extents `e` fits, from up to 24 tries, and the box
    /// taken.
    fn place(&mut self, rng: &mut SplitMix64, e: P2) -> Option<P2> {
        let reach = match self.outline {
            Outline::Rect { h, .. } => h,
            Outline::Disc { r } => [r, r],
        };
        for _ in 0..24 {
            let c = [
                snap(rng.uniform(-reach[0] + e[0], reach[0] - e[0])),
                snap(rng.uniform(-reach[1] + e[1], reach[1] - e[1])),
            ];
            if self.fits(c, e) {
                self.taken.push([c[0] - e[0], c[1] - e[1], c[0] + e[0], c[1] + e[1]]);
                return Some(c);
            }
        }
        None
    }
}

/// A random prismatic part whose longest side is `size`.
pub(crate) fn prismatic(rng: &mut SplitMix64, size: f64) -> Prism {
    let s = size;
    let disc = chance(rng, 0.2);
    let height = draw(rng, 0.12, 0.35) * s;
    let bands_mode = !disc && chance(rng, 0.45);
    let edge = if bands_mode {
        Edge::None
    } else {
        match rng.below(5) {
            0 => Edge::Chamfer(draw(rng, 0.05, 0.12) * height),
            1 => Edge::Fillet(draw(rng, 0.08, 0.2) * height, 4),
            2 => Edge::Draft(draw(rng, 1.0, 5.0).to_radians()),
            _ => Edge::None,
        }
    };
    let inset = edge.inset(height);
    let outline = if disc {
        Outline::Disc { r: snap(s / 2.0) }
    } else {
        let h = [snap(s / 2.0), snap(s / 2.0 * rng.uniform(0.5, 1.0))];
        let mut r = if chance(rng, 0.3) { 0.0 } else { draw(rng, 0.03, 0.12) * 2.0 * h[1] };
        if r > 0.0 && inset > 0.0 {
            r = snap(r.max(inset + 0.02 * s));
        }
        Outline::Rect { h, r }
    };
    let mut part = Prism::new(outline, height, edge);
    let gap = snap(0.02 * s);
    let corner = match outline {
        Outline::Rect { r, .. } => 0.42 * r,
        Outline::Disc { .. } => 0.0,
    };
    let mut layout = Layout { outline, margin: gap + inset + corner, gap, taken: Vec::new() };
    if bands_mode && let Outline::Rect { h, .. } = outline {
        add_bands(rng, &mut part, &mut layout, h);
    }
    for _ in 0..2 + rng.below(6) {
        add_feature(rng, &mut part, &mut layout, s);
    }
    part
}

/// One or two full-width bands, and their boxes taken from the layout.
fn add_bands(rng: &mut SplitMix64, part: &mut Prism, layout: &mut Layout, h: [f64; 2]) {
    let height = part.height;
    let wide = 4.0 * h[0];
    let variant = rng.below(4);
    if variant == 0 || variant == 3 {
        let xs = snap(-h[0] + 2.0 * h[0] * rng.uniform(0.45, 0.75));
        part.step(xs, draw(rng, 0.35, 0.7) * height);
        layout.taken.push([xs, -wide, wide, wide]);
    }
    if variant == 1 {
        let c = snap(h[1] * rng.uniform(-0.15, 0.15));
        let w1 = snap(2.0 * h[1] * rng.uniform(0.12, 0.2));
        let w2 = snap(w1 * rng.uniform(1.6, 2.2));
        let neck = draw(rng, 0.3, 0.45) * height;
        let head = draw(rng, 0.2, 0.3) * height;
        part.t_slot(c, [w1, neck], [w2, head]);
        layout.taken.push([-wide, c - w2 / 2.0, wide, c + w2 / 2.0]);
    }
    if variant >= 2 {
        let c = snap(h[1] * rng.uniform(-0.2, 0.2));
        let w = snap(2.0 * h[1] * rng.uniform(0.12, 0.25));
        part.open_slot(c, w, draw(rng, 0.2, 0.5) * height);
        layout.taken.push([-wide, c - w / 2.0, wide, c + w / 2.0]);
    }
}

/// One feature at a free place, if one is found.
fn add_feature(rng: &mut SplitMix64, part: &mut Prism, layout: &mut Layout, s: f64) {
    let h = part.height;
    match rng.below(11) {
        0..=2 => pocket(rng, part, layout, s),
        3 | 4 => {
            let d = draw(rng, 0.03, 0.08) * s;
            let cs = if chance(rng, 0.3) { snap(d * rng.uniform(0.15, 0.3)) } else { 0.0 };
            let bottom = if chance(rng, 0.6) { 0.0 } else { snap(h * rng.uniform(0.3, 0.7)) };
            if let Some(c) = layout.place(rng, [d / 2.0 + cs; 2]) {
                part.hole(c, d, h, bottom, cs);
            }
        }
        5 => {
            let d = draw(rng, 0.03, 0.06) * s;
            let bd = snap(d * rng.uniform(1.5, 1.9));
            let depth = draw(rng, 0.2, 0.4) * h;
            if let Some(c) = layout.place(rng, [bd / 2.0; 2]) {
                part.counterbore(c, d, bd, depth, h, 0.0);
            }
        }
        6 => {
            let w = draw(rng, 0.04, 0.08) * s;
            let len = snap(w * rng.uniform(2.0, 5.0));
            let along_x = chance(rng, 0.5);
            let bottom = if chance(rng, 0.4) { 0.0 } else { snap(h * rng.uniform(0.4, 0.8)) };
            let e = if along_x { [len / 2.0, w / 2.0] } else { [w / 2.0, len / 2.0] };
            if let Some(c) = layout.place(rng, e) {
                part.slot(c, len, w, along_x, h, bottom);
            }
        }
        7 | 8 => boss(rng, part, layout, s),
        9 => {
            let t = draw(rng, 0.02, 0.04) * s;
            let len = draw(rng, 0.15, 0.4) * s;
            let e = if chance(rng, 0.5) { [len / 2.0, t / 2.0] } else { [t / 2.0, len / 2.0] };
            let height = draw(rng, 0.2, 0.6) * h;
            if let Some(c) = layout.place(rng, e) {
                part.rib(c, e, h, height);
            }
        }
        _ => {
            let d = draw(rng, 0.08, 0.2) * s;
            let bottom = snap(h * rng.uniform(0.4, 0.8));
            if let Some(c) = layout.place(rng, [d / 2.0; 2]) {
                part.circular_pocket(c, d, h, bottom);
            }
        }
    }
}

/// A pocket, optionally drafted, with a deeper pocket or a through hole in its floor.
fn pocket(rng: &mut SplitMix64, part: &mut Prism, layout: &mut Layout, s: f64) {
    let h = part.height;
    let half = [draw(rng, 0.06, 0.18) * s, draw(rng, 0.06, 0.18) * s];
    let small = half[0].min(half[1]);
    let r = snap(small * rng.uniform(0.15, 0.45));
    let floor = snap(h * rng.uniform(0.4, 0.8));
    let depth = h - floor;
    let mut draft = if chance(rng, 0.3) { draw(rng, 1.0, 5.0).to_radians() } else { 0.0 };
    let inset = depth * draft.tan();
    if r < inset + 0.01 * s {
        draft = 0.0;
    }
    let inset = depth * draft.tan();
    let Some(c) = layout.place(rng, half) else { return };
    part.pocket(c, half, r, h, floor, draft);
    // The floor, with the room it leaves for a feature inside it.
    let room = [half[0] - inset - layout.gap, half[1] - inset - layout.gap];
    if chance(rng, 0.4) {
        let sub = [snap(room[0] * rng.uniform(0.3, 0.6)), snap(room[1] * rng.uniform(0.3, 0.6))];
        let off = [
            snap((room[0] - sub[0]) * rng.uniform(-1.0, 1.0)),
            snap((room[1] - sub[1]) * rng.uniform(-1.0, 1.0)),
        ];
        let rr = snap(sub[0].min(sub[1]) * rng.uniform(0.2, 0.45));
        let bottom = snap((floor - h * rng.uniform(0.1, 0.3)).max(0.15 * h));
        part.pocket([c[0] + off[0], c[1] + off[1]], sub, rr, floor, bottom, 0.0);
    } else if chance(rng, 0.5) {
        let d = snap(2.0 * room[0].min(room[1]) * rng.uniform(0.2, 0.5));
        part.hole(c, d, floor, 0.0, 0.0);
    }
}

/// A round boss on the top face, optionally chamfered, optionally with a hole.
fn boss(rng: &mut SplitMix64, part: &mut Prism, layout: &mut Layout, s: f64) {
    let h = part.height;
    let d = draw(rng, 0.08, 0.2) * s;
    let height = draw(rng, 0.2, 0.6) * h;
    let ch = if chance(rng, 0.4) { snap((d / 2.0).min(height / 2.0) * rng.uniform(0.1, 0.3)) } else { 0.0 };
    let Some(c) = layout.place(rng, [d / 2.0; 2]) else { return };
    part.boss(c, d, h, height, ch);
    if chance(rng, 0.5) {
        let dh = snap(d * rng.uniform(0.25, 0.45));
        let top = h + height;
        let bottom = if chance(rng, 0.5) { 0.0 } else { snap(top - height * rng.uniform(0.3, 0.8)) };
        part.hole(c, dh, top, bottom, 0.0);
    }
}
