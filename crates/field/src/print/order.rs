//! Print order on a layer: contours before infill, each group by nearest neighbour from
//! where the nozzle is (a closed path starts at its vertex nearest the nozzle, an open
//! one at its nearer end), and consecutive infill lines whose ends lie close joined into
//! one zig-zag path, so travel stays short.

use s2g_geom::Point3;

use super::extract::{PathKind, PrintPath};

fn is_closed(p: &PrintPath) -> bool {
    p.points.len() > 3 && (p.points[0] - p.points[p.points.len() - 1]).norm() < 1e-9
}

/// A closed loop (last item = first) started at item `i`.
fn rotate_loop<T: Copy>(v: &mut Vec<T>, i: usize) {
    v.pop();
    v.rotate_left(i);
    let first = v[0];
    v.push(first);
}

/// The path turned to start nearest `from`: a closed path rotated, an open one reversed
/// when its far end is nearer.
fn start_near(mut p: PrintPath, from: &Point3) -> PrintPath {
    let d = |q: &Point3| (q - from).norm_squared();
    if is_closed(&p) {
        let n = p.points.len() - 1;
        let i = (0..n).min_by(|&a, &b| d(&p.points[a]).total_cmp(&d(&p.points[b]))).unwrap_or(0);
        rotate_loop(&mut p.points, i);
        rotate_loop(&mut p.axes, i);
        rotate_loop(&mut p.thickness, i);
    } else if d(&p.points[p.points.len() - 1]) < d(&p.points[0]) {
        p.points.reverse();
        p.axes.reverse();
        p.thickness.reverse();
    }
    p
}

fn distance_to(p: &PrintPath, from: &Point3) -> f64 {
    if is_closed(p) {
        p.points.iter().map(|q| (q - from).norm_squared()).fold(f64::INFINITY, f64::min)
    } else {
        (p.points[0] - from).norm_squared().min((p.points[p.points.len() - 1] - from).norm_squared())
    }
}

/// Orders `paths` from `from` (see the module docs), joining infill lines whose ends lie
/// within `join`; returns them and where the nozzle ends.
pub(crate) fn order_paths(paths: Vec<PrintPath>, from: Point3, join: f64) -> (Vec<PrintPath>, Point3) {
    let (mut contours, mut rest): (Vec<_>, Vec<_>) =
        paths.into_iter().partition(|p| p.kind == PathKind::Contour);
    let mut at = from;
    let mut out: Vec<PrintPath> = Vec::new();
    for group in [&mut contours, &mut rest] {
        while !group.is_empty() {
            let i = (0..group.len())
                .min_by(|&a, &b| distance_to(&group[a], &at).total_cmp(&distance_to(&group[b], &at)))
                .unwrap_or(0);
            let p = start_near(group.swap_remove(i), &at);
            at = p.points[p.points.len() - 1];
            match out.last_mut() {
                Some(last)
                    if last.kind == PathKind::Infill
                        && p.kind == PathKind::Infill
                        && (p.points[0] - last.points[last.points.len() - 1]).norm() < join =>
                {
                    last.points.extend(p.points);
                    last.axes.extend(p.axes);
                    last.thickness.extend(p.thickness);
                }
                _ => out.push(p),
            }
        }
    }
    (out, at)
}
