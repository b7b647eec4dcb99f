//! The order and direction in which a finishing strategy's passes are machined, so that
//! each pass starts near where the previous one ended and the emitter can feed across
//! instead of retracting to the clearance plane: among the next few passes (the
//! strategy's order is kept within a window, so a waterline still works down its levels),
//! the one with the nearest entry, a closed loop started at its nearest point, an open
//! pass from its nearer end.

use s2g_geom::Point3;

/// How many of the strategy's next passes are weighed for the nearest entry.
const WINDOW: usize = 48;

/// Whether `p` is a closed loop (its last point repeats its first).
fn closed(p: &[Point3]) -> bool {
    p.len() > 2 && p.first() == p.last()
}

/// The entry of `p` nearest to `at`: its squared distance, the point's index, and whether
/// an open pass is entered at its end.
fn entry(p: &[Point3], at: &Point3) -> (f64, usize, bool) {
    let d = |q: &Point3| (q - at).norm_squared();
    if closed(p) {
        let (i, best) = p[..p.len() - 1]
            .iter()
            .enumerate()
            .map(|(i, q)| (i, d(q)))
            .fold((0, f64::INFINITY), |b, x| if x.1 < b.1 { x } else { b });
        return (best, i, false);
    }
    let (first, last) = (d(&p[0]), d(&p[p.len() - 1]));
    if last < first { (last, p.len() - 1, true) } else { (first, 0, false) }
}

/// `paths` reordered and turned for short links (see the module docs).
pub(super) fn link_order(paths: Vec<Vec<Point3>>) -> Vec<Vec<Point3>> {
    let mut pending: std::collections::VecDeque<Vec<Point3>> =
        paths.into_iter().filter(|p| p.len() >= 2).collect();
    let mut out = Vec::with_capacity(pending.len());
    let mut at: Option<Point3> = None;
    while !pending.is_empty() {
        let Some(cur) = at else {
            let first = pending.pop_front().unwrap_or_default();
            at = first.last().copied();
            out.push(first);
            continue;
        };
        let w = pending.len().min(WINDOW);
        let (k, (_, i, reverse)) = (0..w)
            .map(|k| (k, entry(&pending[k], &cur)))
            .fold((0, (f64::INFINITY, 0, false)), |b, x| if x.1.0 < b.1.0 { x } else { b });
        let Some(mut p) = pending.remove(k) else { break };
        if closed(&p) && i > 0 {
            p.pop();
            p.rotate_left(i);
            p.push(p[0]);
        } else if reverse {
            p.reverse();
        }
        at = p.last().copied();
        out.push(p);
    }
    out
}
