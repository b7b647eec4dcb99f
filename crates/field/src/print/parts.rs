//! Parts that need curved layers, as closed meshes made here (like
//! [`bent_arm_mesh`](crate::bent_arm_mesh)): bands of a 2-D profile in the XZ plane swept
//! along Y.

use s2g_geom::{Mesh, Point3};

use crate::error::{FieldError, Result};

/// The names of the built-in printing parts ([`print_part`]).
pub const PRINT_PARTS: [&str; 4] = ["arm", "arch", "overhang-arch", "bracket"];

/// A built-in printing part by name ([`PRINT_PARTS`]), at the size `s2g field print --part`
/// and the `print_parts` example print it: the bent arm of `support_free` (radius 6,
/// column 12, bend 16 through 60 degrees, arm 24), the arch on two feet (centreline
/// radius 14, band 6 wide, pillars 10 high, 10 deep), the overhanging arch on one foot
/// (the same band turning over through 120 degrees from a pillar 10 high) and the bracket
/// with a tip (post 6 wide and 12 high, bend 10, arm 20 tapering to 2, 10 deep).
///
/// Errors: [`FieldError::InvalidArgument`] for another name.
pub fn print_part(name: &str) -> Result<Mesh> {
    match name {
        "arm" => crate::bent_arm_mesh(6.0, 12.0, 16.0, 60.0, 24.0, 32, 12),
        "arch" => arch_mesh(14.0, 6.0, 10.0, 10.0, 48),
        "overhang-arch" => overhang_arch_mesh(14.0, 6.0, 10.0, 120.0, 10.0, 32),
        "bracket" => bracket_mesh(6.0, 12.0, 10.0, 20.0, 2.0, 10.0, 24),
        _ => Err(FieldError::InvalidArgument(format!(
            "unknown part {name} (the built-in parts: {})",
            PRINT_PARTS.join(", ")
        ))),
    }
}

/// A closed mesh of the band between the `inner` and `outer` chains (points `(x, z)` of
/// the XZ plane, station by station), extruded from `y = 0` to `y = depth`: both ends of
/// the band are flat faces.
fn band_mesh(inner: &[(f64, f64)], outer: &[(f64, f64)], depth: f64) -> Result<Mesh> {
    let n = inner.len();
    if n < 2 || outer.len() != n || !(depth.is_finite() && depth > 0.0) {
        return Err(FieldError::InvalidArgument("a band needs two or more stations and a depth > 0".into()));
    }
    let mut vertices = Vec::with_capacity(4 * n);
    for s in 0..n {
        for (x, z) in [inner[s], outer[s]] {
            vertices.push(Point3::new(x, 0.0, z));
            vertices.push(Point3::new(x, depth, z));
        }
    }
    // Vertex of station s, side (0 inner, 1 outer), face (0 at y = 0, 1 at y = depth).
    let v = |s: usize, side: usize, face: usize| (4 * s + 2 * side + face) as u32;
    let mut tris = Vec::with_capacity(8 * n + 4);
    let mut quad = |a: u32, b: u32, c: u32, d: u32| {
        tris.push([a, b, c]);
        tris.push([a, c, d]);
    };
    for s in 0..n - 1 {
        quad(v(s, 0, 0), v(s, 1, 0), v(s + 1, 1, 0), v(s + 1, 0, 0));
        quad(v(s + 1, 0, 1), v(s + 1, 1, 1), v(s, 1, 1), v(s, 0, 1));
        quad(v(s, 0, 0), v(s + 1, 0, 0), v(s + 1, 0, 1), v(s, 0, 1));
        quad(v(s + 1, 1, 0), v(s, 1, 0), v(s, 1, 1), v(s + 1, 1, 1));
    }
    quad(v(0, 1, 0), v(0, 0, 0), v(0, 0, 1), v(0, 1, 1));
    quad(v(n - 1, 0, 0), v(n - 1, 1, 0), v(n - 1, 1, 1), v(n - 1, 0, 1));
    let mesh = Mesh::new(vertices, tris).map_err(FieldError::geom)?;
    Ok(if mesh.signed_volume() < 0.0 { mesh.flipped() } else { mesh })
}

fn check(values: &[f64]) -> Result<()> {
    if values.iter().all(|v| v.is_finite() && *v > 0.0) {
        Ok(())
    } else {
        Err(FieldError::InvalidArgument("part dimensions must be finite and > 0".into()))
    }
}

/// An overhanging arch standing on the platform `z = 0`: two pillars `pillar` high whose
/// centrelines are `2 radius` apart, joined by a half-circle of centreline radius `radius`,
/// the band `width` wide and `depth` deep along Y (`segments` facets on the half-circle).
/// Planar layers leave the arch's underside a ceiling at its crown.
///
/// Errors: [`FieldError::InvalidArgument`] unless every length is finite and `> 0`,
/// `width < 2 radius` and `2 <= segments <= 100 000`.
pub fn arch_mesh(radius: f64, width: f64, pillar: f64, depth: f64, segments: usize) -> Result<Mesh> {
    check(&[radius, width, pillar, depth])?;
    if width >= 2.0 * radius || !(2..=100_000).contains(&segments) {
        return Err(FieldError::InvalidArgument(
            "arch: width must be below the span, 2..=100000 segments".into(),
        ));
    }
    let (ri, ro) = (radius - 0.5 * width, radius + 0.5 * width);
    let (mut inner, mut outer) = (vec![(-ri, 0.0)], vec![(-ro, 0.0)]);
    for k in 0..=segments {
        let a = std::f64::consts::PI * (1.0 - k as f64 / segments as f64);
        inner.push((ri * a.cos(), pillar + ri * a.sin()));
        outer.push((ro * a.cos(), pillar + ro * a.sin()));
    }
    inner.push((ri, 0.0));
    outer.push((ro, 0.0));
    band_mesh(&inner, &outer, depth)
}

/// A one-footed overhanging arch standing on the platform `z = 0`: a pillar `pillar` high
/// (its centreline at `x = -radius`) that turns towards `+X` on an arc of centreline radius
/// `radius` about `(0, pillar)` through `sweep_deg` degrees (90: a quarter arch whose free
/// end runs out level; 180: a half arch whose free end points down), cut off radially, so
/// that the free end hangs over the platform; the band `width` wide and `depth` deep along
/// Y (`segments` facets on the arc). Planar layers leave the arc's underside, from its
/// crown to its end, a ceiling; layers that turn with the band print it without support.
///
/// Errors: [`FieldError::InvalidArgument`] unless every length is finite and `> 0`,
/// `width < 2 radius`, `0 < sweep_deg <= 180` and `2 <= segments <= 100 000`.
pub fn overhang_arch_mesh(
    radius: f64,
    width: f64,
    pillar: f64,
    sweep_deg: f64,
    depth: f64,
    segments: usize,
) -> Result<Mesh> {
    check(&[radius, width, pillar, sweep_deg, depth])?;
    if width >= 2.0 * radius || sweep_deg > 180.0 || !(2..=100_000).contains(&segments) {
        return Err(FieldError::InvalidArgument(
            "overhanging arch: width must be below 2 radius, sweep in (0, 180], 2..=100000 segments".into(),
        ));
    }
    let (ri, ro) = (radius - 0.5 * width, radius + 0.5 * width);
    let (mut inner, mut outer) = (vec![(-ri, 0.0)], vec![(-ro, 0.0)]);
    let sweep = sweep_deg.to_radians();
    for k in 0..=segments {
        let a = std::f64::consts::PI - sweep * k as f64 / segments as f64;
        inner.push((ri * a.cos(), pillar + ri * a.sin()));
        outer.push((ro * a.cos(), pillar + ro * a.sin()));
    }
    band_mesh(&inner, &outer, depth)
}

/// A bracket with a tip standing on the platform `z = 0`: a post `width` wide rising
/// `post` high, turning towards `+X` on a quarter circle of centreline radius `bend`, and
/// running out horizontally for `arm`, tapering to a tip `tip` wide; `depth` deep along Y
/// (`segments` facets on the bend). Planar layers leave the arm's underside a ceiling.
///
/// Errors: [`FieldError::InvalidArgument`] unless every length is finite and `> 0`,
/// `width < 2 bend`, `tip <= width` and `2 <= segments <= 100 000`.
pub fn bracket_mesh(
    width: f64,
    post: f64,
    bend: f64,
    arm: f64,
    tip: f64,
    depth: f64,
    segments: usize,
) -> Result<Mesh> {
    check(&[width, post, bend, arm, tip, depth])?;
    if width >= 2.0 * bend || tip > width || !(2..=100_000).contains(&segments) {
        return Err(FieldError::InvalidArgument(
            "bracket: width < 2 bend, tip <= width, 2..=100000 segments".into(),
        ));
    }
    let h = 0.5 * width;
    // The post's centreline is x = 0; the bend's centre is (bend, post); inner is +X.
    let (mut inner, mut outer) = (vec![(h, 0.0)], vec![(-h, 0.0)]);
    for k in 0..=segments {
        let a = std::f64::consts::FRAC_PI_2 * k as f64 / segments as f64;
        let (c, s) = (a.cos(), a.sin());
        inner.push((bend - (bend - h) * c, post + (bend - h) * s));
        outer.push((bend - (bend + h) * c, post + (bend + h) * s));
    }
    let steps = 4;
    for k in 1..=steps {
        let f = k as f64 / steps as f64;
        let half = h + (0.5 * tip - h) * f;
        let x = bend + arm * f;
        inner.push((x, post + bend - half));
        outer.push((x, post + bend + half));
    }
    band_mesh(&inner, &outer, depth)
}
