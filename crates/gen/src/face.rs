//! The flat faces at one level of a slab stack.
//!
//! Below the level lies the cross-section `B` (the top rings of the slabs that end
//! there), above it `A` (the bottom rings of the slabs that start there). Material faces
//! up where `B` is not covered by `A`, and down where `A` overhangs `B`. With the
//! coverage count `c = [in B] - [in A]`, the faces are `c = +1` (normal +z) and `c = -1`
//! (normal -z). The boundary chain `∂B - ∂A` (each ring edge of `B` as it runs, each of
//! `A` reversed, split at every level vertex on it, opposite copies cancelled) has `c`
//! one higher on its left than on its right. Its edges are the constraints of a
//! constrained Delaunay triangulation (spade, exact predicates); a flood fill from the
//! outside (`c = 0`) across the triangles gives every triangle its `c`.

use std::collections::{HashMap, VecDeque};

use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

use crate::error::{Result, geometry};
use crate::level::{LevelPoints, MeshBuilder};
use crate::ring::Ring;

/// The chain `∂below - ∂above` at a level, as net multiplicities of directed edges
/// between level points (`(a, b)` with `a < b`; positive runs `a -> b`).
fn chain(below: &[&Ring], above: &[&Ring], points: &LevelPoints) -> Result<Vec<(usize, usize, i32)>> {
    let mut net: HashMap<(usize, usize), i32> = HashMap::new();
    let mut add = |ring: &Ring, sign: i32| -> Result<()> {
        let n = ring.0.len();
        for j in 0..n {
            let pts = points.split(ring.0[j], ring.0[(j + 1) % n]);
            for w in pts.windows(2) {
                let (a, b) = match (points.index_of(w[0]), points.index_of(w[1])) {
                    (Some(a), Some(b)) => (a, b),
                    _ => return Err(geometry("a ring vertex is missing from its level")),
                };
                let (key, s) = if a < b { ((a, b), sign) } else { ((b, a), -sign) };
                *net.entry(key).or_insert(0) += s;
            }
        }
        Ok(())
    };
    for r in below {
        add(r, 1)?;
    }
    for r in above {
        add(r, -1)?;
    }
    let mut edges: Vec<(usize, usize, i32)> =
        net.into_iter().filter(|&(_, m)| m != 0).map(|((a, b), m)| (a, b, m)).collect();
    if edges.iter().any(|e| e.2.abs() > 1) {
        return Err(geometry("two faces of a level touch along an edge (non-manifold)"));
    }
    edges.sort_unstable();
    Ok(edges)
}

/// Adds the flat faces at level `z` (see the module docs) to `mesh`.
pub(crate) fn level_faces(
    below: &[&Ring],
    above: &[&Ring],
    points: &LevelPoints,
    z: f64,
    mesh: &mut MeshBuilder,
) -> Result<()> {
    let edges = chain(below, above, points)?;
    if edges.is_empty() {
        return Ok(());
    }
    let mut cdt: ConstrainedDelaunayTriangulation<Point2<f64>> = ConstrainedDelaunayTriangulation::new();
    let mut handles: HashMap<usize, FixedVertexHandle> = HashMap::new();
    let mut local: HashMap<usize, usize> = HashMap::new();
    let mut used: Vec<usize> = edges.iter().flat_map(|e| [e.0, e.1]).collect();
    used.sort_unstable();
    used.dedup();
    for &i in &used {
        let p = points.point(i);
        let h = cdt.insert(Point2::new(p[0], p[1])).map_err(|e| geometry(format!("triangulation: {e:?}")))?;
        handles.insert(i, h);
        local.insert(h.index(), i);
    }
    let mut directed: HashMap<(usize, usize), i32> = HashMap::new();
    for &(a, b, m) in &edges {
        if cdt.try_add_constraint(handles[&a], handles[&b]).len() != 1 {
            return Err(geometry(format!("the boundary at z = {z} crosses or touches itself")));
        }
        directed.insert((a, b), m);
        directed.insert((b, a), -m);
    }
    // c(left of a -> b) = c(right) + net(a -> b), flood-filled from the outer face (c = 0).
    let crossing = |e: spade::handles::DirectedEdgeHandle<'_, Point2<f64>, (), spade::CdtEdge<()>, ()>| {
        let (a, b) = (local[&e.from().fix().index()], local[&e.to().fix().index()]);
        directed.get(&(a, b)).copied().unwrap_or(0)
    };
    let mut cover: Vec<Option<i32>> = vec![None; cdt.num_all_faces()];
    let mut queue = VecDeque::new();
    for f in cdt.inner_faces() {
        for e in f.adjacent_edges() {
            if e.rev().face().is_outer() && cover[f.fix().index()].is_none() {
                cover[f.fix().index()] = Some(crossing(e));
                queue.push_back(f.fix());
            }
        }
    }
    while let Some(fh) = queue.pop_front() {
        let f = cdt.face(fh);
        let c = cover[fh.index()].unwrap_or(0);
        for e in f.adjacent_edges() {
            let Some(g) = e.rev().face().as_inner().map(|g| g.fix()) else { continue };
            // Crossing e from f (its left) to g (its right): c drops by net(e).
            let cg = c - crossing(e);
            match cover[g.index()] {
                None => {
                    cover[g.index()] = Some(cg);
                    queue.push_back(g);
                }
                Some(old) if old != cg => return Err(geometry(format!("inconsistent faces at z = {z}"))),
                Some(_) => {}
            }
        }
    }
    for f in cdt.inner_faces() {
        let c = cover[f.fix().index()].unwrap_or(0);
        let [a, b, d] = f.vertices().map(|v| {
            let p = points.point(local[&v.fix().index()]);
            mesh.vertex(p, z)
        });
        match c {
            0 => {}
            1 => mesh.triangle([a, b, d]),
            -1 => mesh.triangle([a, d, b]),
            _ => return Err(geometry(format!("cross-sections overlap at z = {z}"))),
        }
    }
    Ok(())
}
