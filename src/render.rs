//! A small software renderer for `s2g mill --render`: the simulated part from a few
//! angles, machined surfaces red and untouched stock grey (as CIMCO shows it, seed
//! 000 Figure 4), plus a top view of one setup's toolpath.
//!
//! Flat-shaded triangles into a z-buffer, orthographic views; no GPU, no window.

use crate::geom::{Aabb, Mesh, Point3, Vector3};
use crate::trace::PathTrace;

/// An RGB image, row-major, 8 bits per channel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height * 3` bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    fn new(width: usize, height: usize, background: [u8; 3]) -> Self {
        Self { width, height, rgb: background.repeat(width * height) }
    }

    fn put(&mut self, x: usize, y: usize, c: [u8; 3]) {
        let i = 3 * (y * self.width + x);
        self.rgb[i..i + 3].copy_from_slice(&c);
    }

    /// Copies `other` with its top-left corner at `(x0, y0)`.
    fn blit(&mut self, other: &Image, x0: usize, y0: usize) {
        for y in 0..other.height.min(self.height.saturating_sub(y0)) {
            for x in 0..other.width.min(self.width.saturating_sub(x0)) {
                let i = 3 * (y * other.width + x);
                self.put(x0 + x, y0 + y, [other.rgb[i], other.rgb[i + 1], other.rgb[i + 2]]);
            }
        }
    }

    /// The image as PNG bytes.
    pub fn to_png(&self) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            // Writing into a Vec cannot fail for a well-formed header and a buffer of the right size.
            if let Ok(mut w) = enc.write_header() {
                let _ = w.write_image_data(&self.rgb);
            }
        }
        out
    }
}

const BACKGROUND: [u8; 3] = [250, 250, 252];
const STOCK_GREY: [f64; 3] = [0.62, 0.63, 0.66];
const CUT_RED: [f64; 3] = [0.86, 0.16, 0.12];

/// An orthographic camera looking along `-dir` (so `dir` points from the scene to the eye).
struct View {
    right: Vector3,
    up: Vector3,
    toward_eye: Vector3,
}

impl View {
    fn new(toward_eye: Vector3) -> Self {
        let toward_eye = toward_eye.normalize();
        let world_up = if toward_eye.z.abs() > 0.99 { Vector3::y() } else { Vector3::z() };
        let right = world_up.cross(&toward_eye).normalize();
        let up = toward_eye.cross(&right);
        Self { right, up, toward_eye }
    }
}

/// What a panel maps to pixels: the scene box's centre and the pixels per unit.
struct Frame {
    center: Point3,
    scale: f64,
    size: usize,
}

impl Frame {
    fn fit(bounds: &Aabb, size: usize) -> Self {
        let diag = bounds.extent().norm().max(1e-12);
        Self { center: bounds.center(), scale: 0.92 * size as f64 / diag, size }
    }

    /// Screen x, y (pixels, y down) and depth (larger is nearer).
    fn project(&self, view: &View, p: &Point3) -> (f64, f64, f64) {
        let d = p - self.center;
        let h = self.size as f64 / 2.0;
        (h + d.dot(&view.right) * self.scale, h - d.dot(&view.up) * self.scale, d.dot(&view.toward_eye))
    }
}

/// Renders one view of `mesh`; `colour_of(t)` gives triangle `t`'s base colour.
fn render_mesh(mesh: &Mesh, view: &View, frame: &Frame, colour_of: &dyn Fn(usize) -> [f64; 3]) -> Image {
    let n = frame.size;
    let mut img = Image::new(n, n, BACKGROUND);
    let mut depth = vec![f64::NEG_INFINITY; n * n];
    let light = (view.toward_eye * 0.8 + view.up * 0.45 + view.right * 0.3).normalize();
    for t in 0..mesh.triangles().len() {
        let Some(normal) = mesh.face_normal(t) else { continue };
        let facing = normal.dot(&view.toward_eye);
        if facing <= 0.0 {
            continue; // back face
        }
        let shade = 0.35 + 0.65 * normal.dot(&light).max(0.0);
        let base = colour_of(t);
        let c = base.map(|v| (v * shade * 255.0).clamp(0.0, 255.0) as u8);
        let [a, b, cc] = mesh.triangle(t).map(|p| frame.project(view, &p));
        fill_triangle(&mut img, &mut depth, [a, b, cc], c);
    }
    img
}

/// Fills a screen-space triangle with a constant colour, with a depth test.
fn fill_triangle(img: &mut Image, depth: &mut [f64], v: [(f64, f64, f64); 3], c: [u8; 3]) {
    let (w, h) = (img.width as f64, img.height as f64);
    let min_x = v.iter().map(|p| p.0).fold(f64::INFINITY, f64::min).floor().max(0.0);
    let max_x = v.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max).ceil().min(w - 1.0);
    let min_y = v.iter().map(|p| p.1).fold(f64::INFINITY, f64::min).floor().max(0.0);
    let max_y = v.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max).ceil().min(h - 1.0);
    if !(min_x <= max_x && min_y <= max_y) {
        return;
    }
    let area = (v[1].0 - v[0].0) * (v[2].1 - v[0].1) - (v[2].0 - v[0].0) * (v[1].1 - v[0].1);
    if area.abs() < 1e-12 {
        return;
    }
    for y in min_y as usize..=max_y as usize {
        for x in min_x as usize..=max_x as usize {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let e =
                |a: (f64, f64, f64), b: (f64, f64, f64)| (b.0 - a.0) * (py - a.1) - (px - a.0) * (b.1 - a.1);
            let w0 = e(v[1], v[2]) / area;
            let w1 = e(v[2], v[0]) / area;
            let w2 = 1.0 - w0 - w1;
            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                continue;
            }
            let z = w0 * v[0].2 + w1 * v[1].2 + w2 * v[2].2;
            let i = y * img.width + x;
            if z > depth[i] {
                depth[i] = z;
                img.put(x, y, c);
            }
        }
    }
}

/// Draws a line segment (no depth test) in `c`.
fn draw_line(img: &mut Image, a: (f64, f64), b: (f64, f64), c: [u8; 3]) {
    let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).clamp(1, 1 << 16);
    for s in 0..=steps {
        let t = s as f64 / steps as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        if x >= 0.0 && y >= 0.0 && (x as usize) < img.width && (y as usize) < img.height {
            img.put(x as usize, y as usize, c);
        }
    }
}

/// Renders the residual stock from three angles and one toolpath panel, side by side.
///
/// A residual triangle is grey when it lies on the original stock box (untouched
/// material) and red when a cut made it.
pub fn render_machining(
    residual: &Mesh,
    stock: &Aabb,
    trace: Option<(&PathTrace, Vector3)>,
    panel: usize,
) -> Image {
    let panel = panel.max(64);
    let tol = 0.75 * stock.extent().max() / 256.0;
    let on_stock_face =
        |p: &Point3| (0..3).any(|a| (p[a] - stock.min[a]).abs() < tol || (p[a] - stock.max[a]).abs() < tol);
    let colour_of = |t: usize| {
        let [a, b, c] = residual.triangle(t);
        if on_stock_face(&a) && on_stock_face(&b) && on_stock_face(&c) { STOCK_GREY } else { CUT_RED }
    };
    let frame = Frame::fit(stock, panel);
    let views = [Vector3::new(1.0, -1.3, 0.9), Vector3::new(-1.2, 1.0, 0.7), Vector3::new(0.6, 0.8, -0.9)];
    let panels = views.len() + usize::from(trace.is_some());
    let mut img = Image::new(panel * panels, panel, BACKGROUND);
    for (i, v) in views.iter().enumerate() {
        let view = View::new(*v);
        img.blit(&render_mesh(residual, &view, &frame, &colour_of), i * panel, 0);
    }
    if let Some((trace, axis)) = trace {
        // Look down the setup's tool axis at the part in light grey, with one layer of the
        // path over it: the median of the levels the path cuts at (all layers at once
        // would paint the panel solid).
        let view = View::new(axis);
        let mut p = render_mesh(residual, &view, &frame, &|_| [0.85, 0.85, 0.87]);
        let level = median_level(trace, &axis, 1e-6 * stock.extent().max());
        let on_level = |q: &Point3| level.is_none_or(|(h, tol)| (q.coords.dot(&axis) - h).abs() <= tol);
        for (a, b, cutting) in trace.segments.iter().filter(|(a, b, _)| on_level(a) && on_level(b)) {
            let (ax, ay, _) = frame.project(&view, a);
            let (bx, by, _) = frame.project(&view, b);
            let c = if *cutting { [20, 70, 200] } else { [150, 200, 150] };
            draw_line(&mut p, (ax, ay), (bx, by), c);
        }
        img.blit(&p, views.len() * panel, 0);
    }
    img
}

/// The median height along `axis` among the levels at which the trace cuts (cutting
/// segments perpendicular to the axis), with the tolerance that groups a level.
fn median_level(trace: &PathTrace, axis: &Vector3, tol: f64) -> Option<(f64, f64)> {
    let h = |q: &Point3| q.coords.dot(axis);
    let mut levels: Vec<f64> = trace
        .segments
        .iter()
        .filter(|(a, b, c)| *c && (h(a) - h(b)).abs() <= tol)
        .map(|(a, _, _)| h(a))
        .collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup_by(|a, b| (*a - *b).abs() <= tol);
    levels.get(levels.len() / 2).map(|&m| (m, tol))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(min: f64, max: f64) -> Mesh {
        Mesh::cuboid(&Aabb::new(Point3::new(min, min, min), Point3::new(max, max, max))).unwrap()
    }

    /// A trace of far more moves than its capacity keeps at most that many, only moves
    /// along a level, and levels spread over the whole program (every 2^k-th).
    #[test]
    fn untouched_stock_is_grey_and_a_cut_block_shows_red() {
        let stock = Aabb::new(Point3::new(-0.5, -0.5, -0.5), Point3::new(0.5, 0.5, 0.5));
        let grey = render_machining(&cube(-0.5, 0.5), &stock, None, 64);
        let red = render_machining(&cube(-0.3, 0.3), &stock, None, 64);
        let count_red = |img: &Image| img.rgb.chunks(3).filter(|c| c[0] > 120 && c[1] < 80).count();
        assert_eq!(count_red(&grey), 0, "the untouched stock must not be red");
        assert!(count_red(&red) > 64 * 3, "a block cut smaller than its stock must be red");
        let png = red.to_png();
        assert_eq!(&png[1..4], b"PNG");
    }
}
