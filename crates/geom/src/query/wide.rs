//! A 4-wide BVH for ray queries, collapsed from the binary SAH tree of `bvh.rs`.
//!
//! Each node holds its four children's boxes in structure-of-arrays f32 layout (128
//! bytes, two cache lines), so one node visit tests four boxes in loops the compiler
//! vectorises. The near and far slab planes are picked once per ray from the signs of the
//! direction, so the box test needs no per-axis min/max of the two slab parameters.
//! Leaves refer to runs of the binary tree's triangles (same order, same `Tri` data).

// Per-lane loops index several arrays by the same lane; NaN-aware comparisons are
// deliberate (a NaN slab parameter is ignored, which keeps the box test conservative).
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use super::bvh::{Bvh, intersect};

/// Marks an unused child slot.
const EMPTY: u32 = u32::MAX;
/// Traversal stack size: up to 3 entries per level of a tree at most ~100 levels deep.
const STACK: usize = 320;

/// Four children: boxes per axis per lane, child node index or first triangle, and the
/// triangle count (0 for an internal child).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct Node4 {
    min: [[f32; 4]; 3],
    max: [[f32; 4]; 3],
    child: [u32; 4],
    count: [u32; 4],
}

/// The wide tree; node 0 is the root.
#[derive(Debug, Clone)]
pub(crate) struct Bvh4 {
    nodes: Vec<Node4>,
    /// A single-leaf tree (the whole mesh fits one binary leaf): its triangle count.
    root_leaf: Option<u32>,
}

/// Per-ray data for the 4-lane slab test.
struct Ray4 {
    o: [f32; 3],
    inv: [f32; 3],
    /// Whether the direction is negative per axis (then `max` is the near plane).
    neg: [bool; 3],
}

impl Ray4 {
    #[inline(always)]
    fn new(o: [f64; 3], d: [f64; 3]) -> Self {
        let inv = d.map(|x| 1.0 / x as f32);
        Self { o: o.map(|x| x as f32), inv, neg: [inv[0] < 0.0, inv[1] < 0.0, inv[2] < 0.0] }
    }

    /// Entry parameters of the four boxes; lanes that miss (or are beyond `tmax`) get +inf.
    #[inline(always)]
    fn test(&self, n: &Node4, tmax: f32) -> [f32; 4] {
        let mut tn = [0.0f32; 4];
        let mut tf = [tmax; 4];
        for a in 0..3 {
            let (near, far) = if self.neg[a] { (&n.max[a], &n.min[a]) } else { (&n.min[a], &n.max[a]) };
            for k in 0..4 {
                let t0 = (near[k] - self.o[a]) * self.inv[a];
                let t1 = (far[k] - self.o[a]) * self.inv[a];
                // `x > t` is false for NaN: a 0 * inf slab never narrows the interval.
                tn[k] = if t0 > tn[k] { t0 } else { tn[k] };
                tf[k] = if t1 < tf[k] { t1 } else { tf[k] };
            }
        }
        let mut out = [f32::INFINITY; 4];
        for k in 0..4 {
            if tn[k] <= tf[k] {
                out[k] = tn[k];
            }
        }
        out
    }
}

impl Bvh4 {
    /// Collapses a binary tree: each wide node takes the binary node's grandchildren,
    /// opening the largest internal children first, up to four.
    pub fn build(bvh: &Bvh) -> Self {
        let root = &bvh.nodes[0];
        if root.count > 0 {
            return Self { nodes: Vec::new(), root_leaf: Some(root.count) };
        }
        let mut nodes = Vec::new();
        // (binary node whose children become the wide node's lanes, wide node slot)
        let mut work = vec![(0usize, 0usize)];
        nodes.push(Node4 { min: [[0.0; 4]; 3], max: [[0.0; 4]; 3], child: [EMPTY; 4], count: [0; 4] });
        while let Some((b, w)) = work.pop() {
            let start = bvh.nodes[b].start as usize;
            let mut lanes: Vec<usize> = vec![start, start + 1];
            while lanes.len() < 4 {
                // Open the internal lane with the largest box surface.
                let pick = lanes
                    .iter()
                    .enumerate()
                    .filter(|&(_, &i)| bvh.nodes[i].count == 0)
                    .max_by(|&(_, &x), &(_, &y)| half_area(bvh, x).total_cmp(&half_area(bvh, y)))
                    .map(|(k, _)| k);
                let Some(k) = pick else { break };
                let i = lanes.swap_remove(k);
                let s = bvh.nodes[i].start as usize;
                lanes.push(s);
                lanes.push(s + 1);
            }
            let mut node = Node4 {
                min: [[f32::INFINITY; 4]; 3],
                max: [[f32::NEG_INFINITY; 4]; 3],
                child: [EMPTY; 4],
                count: [0; 4],
            };
            for (k, &i) in lanes.iter().enumerate() {
                let n = &bvh.nodes[i];
                for a in 0..3 {
                    node.min[a][k] = n.min[a];
                    node.max[a][k] = n.max[a];
                }
                if n.count > 0 {
                    node.child[k] = n.start;
                    node.count[k] = n.count;
                } else {
                    let slot = nodes.len();
                    nodes.push(node); // placeholder, overwritten when processed
                    node.child[k] = slot as u32;
                    work.push((i, slot));
                }
            }
            nodes[w] = node;
        }
        Self { nodes, root_leaf: None }
    }

    /// Whether the segment `o + t d`, `t` in `[0, tmax]`, hits any triangle.
    #[inline]
    pub fn any_hit(&self, bvh: &Bvh, o: [f64; 3], d: [f64; 3], tmax: f64) -> bool {
        if let Some(count) = self.root_leaf {
            return bvh.tris[..count as usize].iter().any(|t| intersect(t, o, d, tmax).is_some());
        }
        let ray = Ray4::new(o, d);
        let tmax32 = (tmax as f32).next_up() * (1.0 + 1e-6);
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let t = ray.test(n, tmax32);
            let order = sort4(t);
            // Leaves nearest first; internal lanes pushed far-to-near so the nearest is
            // popped next.
            for &k in &order {
                let k = k as usize;
                if t[k] == f32::INFINITY || n.child[k] == EMPTY || n.count[k] == 0 {
                    continue;
                }
                let s = n.child[k] as usize;
                if bvh.tris[s..s + n.count[k] as usize].iter().any(|tri| intersect(tri, o, d, tmax).is_some())
                {
                    return true;
                }
            }
            for &k in order.iter().rev() {
                let k = k as usize;
                if t[k] == f32::INFINITY || n.child[k] == EMPTY || n.count[k] > 0 {
                    continue;
                }
                stack[sp] = n.child[k];
                sp += 1;
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            node = stack[sp];
        }
    }

    /// The nearest hit of `o + t d`, `t` in `[0, tmax]`: `(t, index into bvh.tris)`.
    #[inline]
    pub fn first_hit(&self, bvh: &Bvh, o: [f64; 3], d: [f64; 3], tmax: f64) -> Option<(f64, usize)> {
        let mut best: Option<(f64, usize)> = None;
        let mut tbest = tmax;
        if let Some(count) = self.root_leaf {
            for (i, tri) in bvh.tris[..count as usize].iter().enumerate() {
                if let Some(t) = intersect(tri, o, d, tbest) {
                    tbest = t;
                    best = Some((t, i));
                }
            }
            return best;
        }
        let ray = Ray4::new(o, d);
        let mut tmax32 = (tmax as f32).next_up() * (1.0 + 1e-6);
        let mut stack = [(0u32, 0.0f32); STACK];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let t = ray.test(n, tmax32);
            let order = sort4(t);
            // Leaves first (nearest first), shrinking the segment as hits are found.
            for &k in &order {
                let k = k as usize;
                if t[k] > tmax32 || n.child[k] == EMPTY || n.count[k] == 0 {
                    continue;
                }
                let s = n.child[k] as usize;
                for (i, tri) in bvh.tris[s..s + n.count[k] as usize].iter().enumerate() {
                    if let Some(th) = intersect(tri, o, d, tbest) {
                        tbest = th;
                        best = Some((th, s + i));
                        tmax32 = (th as f32).next_up() * (1.0 + 1e-6);
                    }
                }
            }
            for &k in order.iter().rev() {
                let k = k as usize;
                if t[k] > tmax32 || n.child[k] == EMPTY || n.count[k] > 0 {
                    continue;
                }
                stack[sp] = (n.child[k], t[k]);
                sp += 1;
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (cand, tn) = stack[sp];
                if tn <= tmax32 {
                    node = cand;
                    break;
                }
            }
        }
    }
}

fn half_area(bvh: &Bvh, i: usize) -> f32 {
    let n = &bvh.nodes[i];
    let e = [n.max[0] - n.min[0], n.max[1] - n.min[1], n.max[2] - n.min[2]];
    e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
}

/// Lane indices ordered by increasing key (a 4-element sorting network).
#[inline(always)]
fn sort4(t: [f32; 4]) -> [u8; 4] {
    let mut idx = [0u8, 1, 2, 3];
    let swap = |i: usize, j: usize, idx: &mut [u8; 4]| {
        if t[idx[j] as usize] < t[idx[i] as usize] {
            idx.swap(i, j);
        }
    };
    swap(0, 1, &mut idx);
    swap(2, 3, &mut idx);
    swap(0, 2, &mut idx);
    swap(1, 3, &mut idx);
    swap(1, 2, &mut idx);
    idx
}
