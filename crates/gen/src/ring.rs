//! Closed planar rings (cross-section boundaries) on the generator's coordinate grid.
//!
//! Every coordinate is snapped to multiples of [`QUANTUM`] (2^-12 mm). With coordinates
//! below 2^11 in magnitude a grid value has at most 23 significant bits, so it is exact in
//! f32 (the binary STL stores what we computed, bit for bit) and the 2-D orientation
//! determinant of three grid points is exact in f64 (products of 24-bit differences fit in
//! 53 bits): "does this vertex lie on that edge" has an exact answer.

use std::f64::consts::{FRAC_PI_2, TAU};

/// The coordinate grid: 2^-12 (about 0.24 µm in millimetres).
pub const QUANTUM: f64 = 1.0 / 4096.0;

/// The largest coordinate magnitude the grid keeps exact in f32 (2^11).
pub const MAX_COORD: f64 = 2048.0;

/// Snaps `v` to the grid.
pub(crate) fn snap(v: f64) -> f64 {
    (v / QUANTUM).round() * QUANTUM
}

/// A 2-D point.
pub(crate) type P2 = [f64; 2];

/// A closed ring of grid points, without a repeated closing point. Counter-clockwise
/// bounds material (its inside is solid); clockwise bounds a hole.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Ring(pub(crate) Vec<P2>);

impl Ring {
    /// A ring from points, snapped to the grid, with consecutive duplicates (after
    /// snapping, the closing pair included) removed.
    pub(crate) fn snapped(points: impl IntoIterator<Item = P2>) -> Self {
        let mut out: Vec<P2> = Vec::new();
        for p in points {
            let q = [snap(p[0]), snap(p[1])];
            if out.last() != Some(&q) {
                out.push(q);
            }
        }
        while out.len() > 1 && out.first() == out.last() {
            out.pop();
        }
        Ring(out)
    }

    /// The same ring wound the other way (a hole from an outline).
    pub(crate) fn reversed(mut self) -> Self {
        self.0.reverse();
        self
    }

    /// Signed area by the shoelace formula: positive counter-clockwise.
    pub(crate) fn area(&self) -> f64 {
        shoelace(&self.0)
    }
}

/// Signed area of a closed polygon (shoelace).
pub(crate) fn shoelace(p: &[P2]) -> f64 {
    let n = p.len();
    let mut s = 0.0;
    for i in 0..n {
        let (a, b) = (p[i], p[(i + 1) % n]);
        s += a[0] * b[1] - b[0] * a[1];
    }
    0.5 * s
}

/// Points of an arc of `segments` chords around `c` from angle `a0`, `sweep` radians,
/// both ends included.
fn arc(c: P2, r: f64, a0: f64, sweep: f64, segments: usize) -> impl Iterator<Item = P2> {
    (0..=segments).map(move |j| {
        let a = a0 + sweep * j as f64 / segments as f64;
        [c[0] + r * a.cos(), c[1] + r * a.sin()]
    })
}

/// A counter-clockwise rectangle `[x0, x1] x [y0, y1]` whose corners are rounded with
/// the radii `[lower right, upper right, upper left, lower left]` (0 keeps a corner
/// sharp), each quarter arc in `segments` chords.
pub(crate) fn rounded_rect(x0: f64, y0: f64, x1: f64, y1: f64, radii: [f64; 4], segments: usize) -> Ring {
    let corners = [
        ([x1, y0], [-1.0, 1.0], -FRAC_PI_2),
        ([x1, y1], [-1.0, -1.0], 0.0),
        ([x0, y1], [1.0, -1.0], FRAC_PI_2),
        ([x0, y0], [1.0, 1.0], std::f64::consts::PI),
    ];
    let mut pts = Vec::new();
    for (k, (corner, inward, a0)) in corners.into_iter().enumerate() {
        let r = radii[k];
        if r > 0.0 {
            let c = [corner[0] + inward[0] * r, corner[1] + inward[1] * r];
            pts.extend(arc(c, r, a0, FRAC_PI_2, segments));
        } else {
            pts.push(corner);
        }
    }
    Ring::snapped(pts)
}

/// A counter-clockwise rounded rectangle centred at `c` with half sides `h` and one
/// corner radius.
pub(crate) fn rounded_rect_centered(c: P2, h: [f64; 2], r: f64, segments: usize) -> Ring {
    rounded_rect(c[0] - h[0], c[1] - h[1], c[0] + h[0], c[1] + h[1], [r; 4], segments)
}

/// A counter-clockwise regular `n`-gon of circumradius `r` around `c` (a circle).
pub(crate) fn circle(c: P2, r: f64, n: usize) -> Ring {
    Ring::snapped((0..n).map(|k| {
        let a = TAU * k as f64 / n as f64;
        [c[0] + r * a.cos(), c[1] + r * a.sin()]
    }))
}

/// A counter-clockwise stadium (obround slot outline) centred at `c`: two semicircles
/// of radius `r` whose centres are `half_length` either side of `c` along x (`along_x`)
/// or y, each in `segments` chords.
pub(crate) fn stadium(c: P2, half_length: f64, r: f64, along_x: bool, segments: usize) -> Ring {
    let (u, a0) = if along_x { ([1.0, 0.0], -FRAC_PI_2) } else { ([0.0, 1.0], 0.0) };
    let c1 = [c[0] + u[0] * half_length, c[1] + u[1] * half_length];
    let c0 = [c[0] - u[0] * half_length, c[1] - u[1] * half_length];
    let pts = arc(c1, r, a0, std::f64::consts::PI, segments).chain(arc(
        c0,
        r,
        a0 + std::f64::consts::PI,
        std::f64::consts::PI,
        segments,
    ));
    Ring::snapped(pts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_are_counter_clockwise_with_expected_areas() {
        let sq = rounded_rect(0.0, 0.0, 2.0, 1.0, [0.0; 4], 4);
        assert_eq!(sq.0.len(), 4);
        assert_eq!(sq.area(), 2.0);
        let n = 64;
        let c = circle([1.0, 2.0], 3.0, n);
        let exact = 0.5 * n as f64 * 9.0 * (TAU / n as f64).sin();
        assert!((c.area() - exact).abs() < 1e-2, "{} vs {exact}", c.area());
        let st = stadium([0.0, 0.0], 2.0, 1.0, true, 16);
        assert!(st.area() > 0.0 && st.area() < 8.0 + std::f64::consts::PI);
        assert!(st.reversed().area() < 0.0);
        let rr = rounded_rect_centered([0.0, 0.0], [2.0, 1.0], 0.5, 8);
        assert_eq!(rr.0.len(), 36);
        assert!(rr.0.iter().all(|p| p.iter().all(|v| (v / QUANTUM).fract() == 0.0)));
    }
}
