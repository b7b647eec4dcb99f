//! A flat bounding-volume hierarchy over triangles, built by binned SAH.
//!
//! Nodes are 32 bytes: an f32 box (rounded outwards and padded, so box tests are
//! conservative), and either two adjacent children or a run of triangles. Triangles are
//! stored in leaf order as `(v0, e1, e2)` in f64, relative to the mesh's bounding-box
//! centre so that f32 boxes keep their precision for parts far from the origin.
//! Ray queries walk the same tree collapsed to 4-wide nodes (four child boxes tested at
//! once); point queries (closest point, winding numbers) walk the binary nodes.
//! Traversal is iterative with a fixed stack; any-hit queries stop at the first hit.

// Per-axis loops index several parallel arrays at once; NaN-aware negated comparisons
// (`!(x > 0.0)`) are deliberate: they send NaN down the safe branch.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::mesh::Mesh;

/// Leaf size below which we never split.
const MIN_LEAF: usize = 2;
/// Leaf size above which we always split (if the triangles can be separated).
const MAX_LEAF: usize = 8;
/// Number of SAH bins per axis.
const BINS: usize = 16;
/// Depth after which splits become median splits, so depth stays below the stack size.
const SAH_DEPTH: usize = 64;
/// Traversal stack size (depth is at most `SAH_DEPTH + 32` for 2^32 triangles).
pub(crate) const STACK: usize = 128;
/// Relative cost of a node visit against a triangle test in the SAH.
const TRAVERSAL_COST: f64 = 1.0;

/// A BVH node: its box, and children (`count == 0`: nodes `start`, `start + 1`) or
/// triangles (`count > 0`: `tris[start..start + count]`).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct Node {
    pub min: [f32; 3],
    pub start: u32,
    pub max: [f32; 3],
    pub count: u32,
}

/// A triangle as `v0`, `e1 = v1 - v0`, `e2 = v2 - v0` in the BVH's local frame.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tri {
    pub v0: [f64; 3],
    pub e1: [f64; 3],
    pub e2: [f64; 3],
}

impl Tri {
    #[inline]
    pub fn vertices(&self) -> [[f64; 3]; 3] {
        [self.v0, add(self.v0, self.e1), add(self.v0, self.e2)]
    }
}

/// A 4-wide node: the boxes of up to four children in structure-of-arrays form (one
/// box test covers all four), and per lane a child node (`count == 0`: `wide[start]`) or
/// a run of triangles (`count > 0`: `tris[start..start + count]`). Unused lanes have the
/// empty box `[+inf, +inf]`, which no ray enters.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(64))]
pub(crate) struct Node4 {
    pub lo: [[f32; 4]; 3],
    pub hi: [[f32; 4]; 3],
    pub start: [u32; 4],
    pub count: [u32; 4],
}

/// Traversal stack of the 4-wide tree: each level pushes at most three more entries
/// than it pops, and the wide tree is no deeper than the binary one.
const WIDE_STACK: usize = 3 * STACK + 4;

/// Collapses the binary tree into 4-wide nodes: each wide node takes a binary node's
/// children and keeps opening the inner child of largest surface area until it holds
/// four (Wald et al., "Getting rid of packets", 2008). Leaves keep their triangle runs.
fn collapse(nodes: &[Node]) -> Vec<Node4> {
    const EMPTY: Node4 =
        Node4 { lo: [[f32::INFINITY; 4]; 3], hi: [[f32::INFINITY; 4]; 3], start: [0; 4], count: [0; 4] };
    let area = |n: &Node| {
        let e = [0, 1, 2].map(|a| (n.max[a] - n.min[a]) as f64);
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    };
    let mut wide = vec![EMPTY];
    // (wide node to fill, binary node whose children it takes)
    let mut work = vec![(0usize, 0usize)];
    while let Some((w, b)) = work.pop() {
        let root = &nodes[b];
        let mut kids: Vec<usize> =
            if root.count > 0 { vec![b] } else { vec![root.start as usize, root.start as usize + 1] };
        while kids.len() < 4 {
            let open = kids
                .iter()
                .enumerate()
                .filter(|&(_, &k)| nodes[k].count == 0)
                .max_by(|a, b| area(&nodes[*a.1]).total_cmp(&area(&nodes[*b.1])))
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let k = kids.swap_remove(i);
            kids.push(nodes[k].start as usize);
            kids.push(nodes[k].start as usize + 1);
        }
        for (l, &k) in kids.iter().enumerate() {
            let n = &nodes[k];
            for a in 0..3 {
                wide[w].lo[a][l] = n.min[a];
                wide[w].hi[a][l] = n.max[a];
            }
            if n.count > 0 {
                wide[w].start[l] = n.start;
                wide[w].count[l] = n.count;
            } else {
                let c = wide.len();
                wide.push(EMPTY);
                wide[w].start[l] = c as u32;
                work.push((c, k));
            }
        }
    }
    wide
}

/// Sorts up to four `(entry, node)` pairs by decreasing entry.
#[inline(always)]
fn sort_far_to_near(v: &mut [(f32, u32)]) {
    for i in 1..v.len() {
        let mut j = i;
        while j > 0 && v[j - 1].0 < v[j].0 {
            v.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// The hierarchy.
#[derive(Debug, Clone)]
pub(crate) struct Bvh {
    pub nodes: Vec<Node>,
    /// The same tree collapsed to 4-wide nodes, for ray queries.
    pub wide: Vec<Node4>,
    pub tris: Vec<Tri>,
    /// Original triangle index of `tris[i]`.
    pub ids: Vec<u32>,
    /// The local frame's origin in world coordinates.
    pub center: [f64; 3],
}

#[inline]
pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub(crate) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
#[inline]
pub(crate) fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[derive(Clone, Copy)]
struct Bounds {
    min: [f64; 3],
    max: [f64; 3],
}

impl Bounds {
    const EMPTY: Bounds = Bounds { min: [f64::INFINITY; 3], max: [f64::NEG_INFINITY; 3] };
    #[inline]
    fn grow_point(&mut self, p: [f64; 3]) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(p[a]);
            self.max[a] = self.max[a].max(p[a]);
        }
    }
    #[inline]
    fn grow(&mut self, b: &Bounds) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(b.min[a]);
            self.max[a] = self.max[a].max(b.max[a]);
        }
    }
    #[inline]
    fn half_area(&self) -> f64 {
        let e = sub(self.max, self.min);
        if e.iter().any(|&x| !(x >= 0.0)) {
            return 0.0;
        }
        e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
    }
}

impl Bvh {
    /// Builds the hierarchy; the mesh must have at least one triangle.
    pub fn build(mesh: &Mesh) -> Bvh {
        let bbox = mesh.bbox().map(|b| b.center()).unwrap_or_else(crate::math::Point3::origin);
        let center = [bbox.x, bbox.y, bbox.z];
        let n = mesh.triangles().len();
        let mut local = Vec::with_capacity(n);
        let mut boxes = Vec::with_capacity(n);
        let mut cents = Vec::with_capacity(n);
        let mut extent = 0.0f64;
        for [a, b, c] in mesh.triangle_points() {
            let v = [a, b, c].map(|p| sub([p.x, p.y, p.z], center));
            let mut bb = Bounds::EMPTY;
            for p in v {
                bb.grow_point(p);
                extent = extent.max(p[0].abs()).max(p[1].abs()).max(p[2].abs());
            }
            cents.push(scale(add(bb.min, bb.max), 0.5));
            boxes.push(bb);
            local.push(v);
        }
        // Box padding: covers f32 rounding of boxes, origins and slab products.
        let pad = (extent * 1e-5).max(1e-30);

        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes = vec![Node { min: [0.0; 3], start: 0, max: [0.0; 3], count: 0 }];
        // (node, begin, end, depth)
        let mut work = vec![(0usize, 0usize, n, 0usize)];
        let mut bins = [(Bounds::EMPTY, 0usize); BINS];
        let mut right_area = [0.0f64; BINS];
        let mut right_count = [0usize; BINS];
        while let Some((node, begin, end, depth)) = work.pop() {
            let mut nb = Bounds::EMPTY;
            let mut cb = Bounds::EMPTY;
            for &t in &order[begin..end] {
                nb.grow(&boxes[t as usize]);
                cb.grow_point(cents[t as usize]);
            }
            nodes[node].min = nb.min.map(|x| ((x - pad) as f32).next_down());
            nodes[node].max = nb.max.map(|x| ((x + pad) as f32).next_up());
            let count = end - begin;
            let make_leaf = |nodes: &mut Vec<Node>| {
                nodes[node].start = begin as u32;
                nodes[node].count = count as u32;
            };
            if count <= MIN_LEAF {
                make_leaf(&mut nodes);
                continue;
            }
            // Best SAH split over the three axes.
            let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, bin)
            if depth < SAH_DEPTH {
                for axis in 0..3 {
                    let lo = cb.min[axis];
                    let ext = cb.max[axis] - lo;
                    if !(ext > 0.0) {
                        continue;
                    }
                    let k = BINS as f64 / ext;
                    bins.fill((Bounds::EMPTY, 0));
                    for &t in &order[begin..end] {
                        let b = (((cents[t as usize][axis] - lo) * k) as usize).min(BINS - 1);
                        bins[b].0.grow(&boxes[t as usize]);
                        bins[b].1 += 1;
                    }
                    let mut acc = Bounds::EMPTY;
                    let mut cnt = 0;
                    for b in (1..BINS).rev() {
                        acc.grow(&bins[b].0);
                        cnt += bins[b].1;
                        right_area[b] = acc.half_area();
                        right_count[b] = cnt;
                    }
                    let mut acc = Bounds::EMPTY;
                    let mut cnt = 0;
                    for b in 1..BINS {
                        acc.grow(&bins[b - 1].0);
                        cnt += bins[b - 1].1;
                        if cnt == 0 || right_count[b] == 0 {
                            continue;
                        }
                        let cost = acc.half_area() * cnt as f64 + right_area[b] * right_count[b] as f64;
                        if best.is_none_or(|(c, _, _)| cost < c) {
                            best = Some((cost, axis, b));
                        }
                    }
                }
            }
            let parent_area = nb.half_area().max(f64::MIN_POSITIVE);
            let mid = match best {
                Some((cost, axis, bin)) => {
                    let split_cost = TRAVERSAL_COST + cost / parent_area;
                    if split_cost >= count as f64 && count <= MAX_LEAF {
                        make_leaf(&mut nodes);
                        continue;
                    }
                    let lo = cb.min[axis];
                    let k = BINS as f64 / (cb.max[axis] - lo);
                    let slice = &mut order[begin..end];
                    let mut i = 0;
                    for j in 0..slice.len() {
                        let b = (((cents[slice[j] as usize][axis] - lo) * k) as usize).min(BINS - 1);
                        if b < bin {
                            slice.swap(i, j);
                            i += 1;
                        }
                    }
                    begin + i
                }
                None => {
                    if count <= MAX_LEAF {
                        make_leaf(&mut nodes);
                        continue;
                    }
                    // All centroids coincide or we are too deep: a median split on the
                    // widest centroid axis keeps the tree balanced.
                    let e = sub(cb.max, cb.min);
                    let axis = if e[0] >= e[1] && e[0] >= e[2] {
                        0
                    } else if e[1] >= e[2] {
                        1
                    } else {
                        2
                    };
                    let slice = &mut order[begin..end];
                    let m = slice.len() / 2;
                    slice.select_nth_unstable_by(m, |&a, &b| {
                        cents[a as usize][axis].total_cmp(&cents[b as usize][axis])
                    });
                    begin + m
                }
            };
            let left = nodes.len();
            nodes[node].start = left as u32;
            nodes[node].count = 0;
            nodes.push(nodes[node]);
            nodes.push(nodes[node]);
            work.push((left + 1, mid, end, depth + 1));
            work.push((left, begin, mid, depth + 1));
        }
        let tris = order
            .iter()
            .map(|&t| {
                let [a, b, c] = local[t as usize];
                Tri { v0: a, e1: sub(b, a), e2: sub(c, a) }
            })
            .collect();
        let wide = collapse(&nodes);
        Bvh { nodes, wide, tris, ids: order, center }
    }

    /// `p` in the local frame.
    #[inline]
    pub fn to_local(&self, p: [f64; 3]) -> [f64; 3] {
        sub(p, self.center)
    }

    /// Whether a segment `o + t d`, `t` in `[0, tmax]`, hits any triangle (local frame).
    /// `last` is a triangle (index into `tris`, or anything out of range) tried before the
    /// tree: a ray next to one that was blocked is often blocked by the same triangle. On
    /// a hit found in the tree, `last` becomes that triangle.
    #[inline]
    pub fn any_hit(&self, o: [f64; 3], d: [f64; 3], tmax: f64, last: &mut u32) -> bool {
        if let Some(tri) = self.tris.get(*last as usize)
            && intersect(tri, o, d, tmax).is_some()
        {
            return true;
        }
        let ray = RayF32::new(o, d, tmax);
        let mut stack = [0u32; WIDE_STACK];
        let mut sp = 0usize;
        let mut node = 0usize;
        loop {
            let n = &self.wide[node];
            let t = ray.entry4(n);
            // Leaves are tested at once (a hit ends the query); inner children go on the
            // stack unsorted: for an any-hit query, sorting them by entry cost more than
            // it saved (bunny visibility: 0.64 s sorted, 0.57 s unsorted).
            for l in 0..4 {
                // Unused lanes (count 0, start 0: the root is nobody's child) are skipped
                // too, whatever the box test says.
                if !(t[l] <= ray.tmax) || (n.count[l] | n.start[l]) == 0 {
                    continue;
                }
                if n.count[l] > 0 {
                    let s = n.start[l] as usize;
                    for (j, tri) in self.tris[s..s + n.count[l] as usize].iter().enumerate() {
                        if intersect(tri, o, d, tmax).is_some() {
                            *last = (s + j) as u32;
                            return true;
                        }
                    }
                } else {
                    stack[sp] = n.start[l];
                    sp += 1;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            node = stack[sp] as usize;
        }
    }

    /// The nearest hit of `o + t d`, `t` in `[0, tmax]`: `(t, index into tris)`.
    #[inline]
    pub fn first_hit(&self, o: [f64; 3], d: [f64; 3], tmax: f64) -> Option<(f64, usize)> {
        let mut ray = RayF32::new(o, d, tmax);
        let mut best: Option<(f64, usize)> = None;
        let mut tbest = tmax;
        let mut stack = [(0u32, 0.0f32); WIDE_STACK];
        let mut sp = 0usize;
        let mut node = 0usize;
        loop {
            let n = &self.wide[node];
            let t = ray.entry4(n);
            let mut inner = [(0.0f32, 0u32); 4];
            let mut k = 0;
            for l in 0..4 {
                // Unused lanes (count 0, start 0: the root is nobody's child) are skipped
                // too, whatever the box test says.
                if !(t[l] <= ray.tmax) || (n.count[l] | n.start[l]) == 0 {
                    continue;
                }
                if n.count[l] > 0 {
                    let s = n.start[l] as usize;
                    for (i, tri) in self.tris[s..s + n.count[l] as usize].iter().enumerate() {
                        if let Some(th) = intersect(tri, o, d, tbest) {
                            tbest = th;
                            best = Some((th, s + i));
                            ray.set_tmax(th);
                        }
                    }
                } else {
                    inner[k] = (t[l], n.start[l]);
                    k += 1;
                }
            }
            sort_far_to_near(&mut inner[..k]);
            for &(tn, c) in &inner[..k] {
                stack[sp] = (c, tn);
                sp += 1;
            }
            // Pop, skipping nodes that the shrunk segment no longer reaches.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, tn) = stack[sp];
                if tn <= ray.tmax {
                    node = c as usize;
                    break;
                }
            }
        }
    }

    /// The closest point on the triangles to `p` (local frame) within squared distance
    /// `max_d2`: `(squared distance, point, index into tris)`.
    pub fn closest(&self, p: [f64; 3], max_d2: f64) -> Option<(f64, [f64; 3], usize)> {
        let mut best: Option<(f64, [f64; 3], usize)> = None;
        let mut best_d2 = max_d2;
        let mut stack = [(0u32, 0.0f64); STACK];
        let mut sp = 0usize;
        let mut node = 0usize;
        loop {
            let n = &self.nodes[node];
            if n.count > 0 {
                let s = n.start as usize;
                for (i, tri) in self.tris[s..s + n.count as usize].iter().enumerate() {
                    let q = closest_on_triangle(tri, p);
                    let e = sub(q, p);
                    let d2 = dot(e, e);
                    if d2 < best_d2 || (best.is_none() && d2 <= best_d2) {
                        best_d2 = d2;
                        best = Some((d2, q, s + i));
                    }
                }
            } else {
                let li = n.start as usize;
                let dl = box_dist2(&self.nodes[li], p);
                let dr = box_dist2(&self.nodes[li + 1], p);
                let (near, dn, far, df) = if dl <= dr { (li, dl, li + 1, dr) } else { (li + 1, dr, li, dl) };
                if dn <= best_d2 {
                    if df <= best_d2 {
                        stack[sp] = (far as u32, df);
                        sp += 1;
                    }
                    node = near;
                    continue;
                }
            }
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (cand, d) = stack[sp];
                if d <= best_d2 {
                    node = cand as usize;
                    break;
                }
            }
        }
    }
}

/// A ray in f32 for conservative box tests.
struct RayF32 {
    o: [f32; 3],
    inv: [f32; 3],
    tmax: f32,
}

impl RayF32 {
    #[inline]
    fn new(o: [f64; 3], d: [f64; 3], tmax: f64) -> Self {
        Self {
            o: o.map(|x| x as f32),
            inv: d.map(|x| 1.0 / x as f32),
            tmax: (tmax as f32).next_up() * (1.0 + 1e-6),
        }
    }
    #[inline]
    fn set_tmax(&mut self, t: f64) {
        self.tmax = (t as f32).next_up() * (1.0 + 1e-6);
    }
    /// Entry parameters of the segment into the four boxes of `n`; a lane the segment
    /// misses gets NaN (even an unbounded segment's `tmax` is not above it). Written lane
    /// by lane, which the compiler turns into SIMD.
    ///
    /// The comparisons are written as `if a < b { a } else { b }`, which is one `minps`
    /// or `maxps` (`f32::min` and `max` carry NaN fix-ups that made the box test a third
    /// of visibility's time). A NaN from `0 * inf` (origin on a slab plane of an axis the
    /// ray runs parallel to) never wins the accumulating comparisons, so that slab narrows
    /// the interval less or not at all: the test stays conservative. The empty box
    /// `[+inf, +inf]` of an unused lane gives `+inf` or `-inf` on every slab, so no ray
    /// enters it.
    #[inline(always)]
    fn entry4(&self, n: &Node4) -> [f32; 4] {
        let mut tnear = [0.0f32; 4];
        let mut tfar = [self.tmax; 4];
        for a in 0..3 {
            // The slab plane met first: the low one unless the ray runs down this axis.
            let (near, far) = if self.inv[a] < 0.0 { (&n.hi[a], &n.lo[a]) } else { (&n.lo[a], &n.hi[a]) };
            for l in 0..4 {
                let lo = (near[l] - self.o[a]) * self.inv[a];
                let hi = (far[l] - self.o[a]) * self.inv[a];
                tnear[l] = if lo > tnear[l] { lo } else { tnear[l] };
                tfar[l] = if hi < tfar[l] { hi } else { tfar[l] };
            }
        }
        let mut out = [f32::NAN; 4];
        for l in 0..4 {
            out[l] = if tnear[l] <= tfar[l] { tnear[l] } else { f32::NAN };
        }
        out
    }
}

/// Möller–Trumbore in f64: the hit parameter in `[0, tmax]`, if any. Rays in the plane of
/// the triangle do not hit it.
#[inline(always)]
pub(crate) fn intersect(tri: &Tri, o: [f64; 3], d: [f64; 3], tmax: f64) -> Option<f64> {
    let p = cross(d, tri.e2);
    let det = dot(tri.e1, p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, tri.v0);
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, tri.e1);
    let v = dot(d, q) * inv;
    if !(v >= 0.0 && u + v <= 1.0) {
        return None;
    }
    let t = dot(tri.e2, q) * inv;
    (t >= 0.0 && t <= tmax).then_some(t)
}

/// Squared distance from `p` to a node's box.
#[inline(always)]
fn box_dist2(n: &Node, p: [f64; 3]) -> f64 {
    let mut d2 = 0.0;
    for a in 0..3 {
        let lo = n.min[a] as f64;
        let hi = n.max[a] as f64;
        let e = if p[a] < lo {
            lo - p[a]
        } else if p[a] > hi {
            p[a] - hi
        } else {
            0.0
        };
        d2 += e * e;
    }
    d2
}

/// The closest point of a triangle to `p` (Ericson, Real-Time Collision Detection §5.1.5).
#[inline]
pub(crate) fn closest_on_triangle(tri: &Tri, p: [f64; 3]) -> [f64; 3] {
    let a = tri.v0;
    let ab = tri.e1;
    let ac = tri.e2;
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(ap, ab);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return add(a, ab);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return add(a, scale(ab, v));
    }
    let cp = sub(ap, ac);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return add(a, ac);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return add(a, scale(ac, w));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return add(add(a, ab), scale(sub(ac, ab), w));
    }
    let denom = va + vb + vc;
    if !(denom.abs() > 0.0) || !denom.is_finite() {
        // Degenerate triangle that none of the region tests caught: fall back to the
        // best of its three vertices.
        let cands = [a, add(a, ab), add(a, ac)];
        let mut best = cands[0];
        let mut bd = f64::INFINITY;
        for c in cands {
            let e = sub(c, p);
            let d = dot(e, e);
            if d < bd {
                bd = d;
                best = c;
            }
        }
        return best;
    }
    let inv = 1.0 / denom;
    let v = vb * inv;
    let w = vc * inv;
    add(a, add(scale(ab, v), scale(ac, w)))
}
