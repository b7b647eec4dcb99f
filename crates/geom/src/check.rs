//! Mesh checks and light repair: weld duplicate vertices, drop degenerate faces, and
//! a [`MeshReport`] of closedness, manifoldness, orientation, volume and bodies.

use std::collections::HashMap;

use crate::aabb::Aabb;
use crate::math::{Point3, Real};
use crate::mesh::Mesh;

/// Welds vertices whose positions are bitwise equal (with `-0.0 == 0.0`), keeping
/// the first occurrence; triangles are kept and re-indexed. Deterministic.
pub(crate) fn weld_exact(mesh: &Mesh) -> Mesh {
    let mut map: HashMap<[u64; 3], u32> = HashMap::with_capacity(mesh.vertices().len());
    let mut vertices = Vec::new();
    let remap: Vec<u32> = mesh
        .vertices()
        .iter()
        .map(|p| {
            // Adding +0.0 turns -0.0 into +0.0, so both hash alike.
            let key = [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()];
            *map.entry(key).or_insert_with(|| {
                vertices.push(*p);
                (vertices.len() - 1) as u32
            })
        })
        .collect();
    rebuild(vertices, mesh, &remap)
}

fn rebuild(vertices: Vec<Point3>, mesh: &Mesh, remap: &[u32]) -> Mesh {
    let triangles = mesh.triangles().iter().map(|t| t.map(|i| remap[i as usize])).collect();
    // Indices come from `remap`, which only names vertices we pushed, and positions
    // are copied from a checked mesh: construction cannot fail.
    Mesh::new(vertices, triangles).unwrap_or_default()
}

/// Merges vertices closer than `tolerance` (Euclidean distance) by spatial hashing on
/// a grid of cell size `tolerance`: vertices are visited in index order, and each one
/// maps to the earliest kept vertex within `tolerance` in the 27 neighbouring cells,
/// or is kept itself. Kept vertices keep their own positions (no averaging), so the
/// result is deterministic and independent of hashing order. `tolerance <= 0` (or
/// NaN) merges only bitwise-equal positions.
///
/// Every triangle is kept and re-indexed, even one that collapses to repeated
/// indices; follow with [`drop_degenerate`] to remove those.
pub fn merge_vertices(mesh: &Mesh, tolerance: Real) -> Mesh {
    if tolerance.is_nan() || tolerance <= 0.0 || tolerance.is_infinite() {
        return weld_exact(mesh);
    }
    let cell = |p: &Point3| [0, 1, 2].map(|a| (p[a] / tolerance).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut vertices: Vec<Point3> = Vec::new();
    let tol2 = tolerance * tolerance;
    let remap: Vec<u32> = mesh
        .vertices()
        .iter()
        .map(|p| {
            let c = cell(p);
            let mut best: Option<u32> = None;
            for dz in -1..=1i64 {
                for dy in -1..=1i64 {
                    for dx in -1..=1i64 {
                        let key = [c[0].saturating_add(dx), c[1].saturating_add(dy), c[2].saturating_add(dz)];
                        if let Some(list) = grid.get(&key) {
                            for &k in list {
                                if (vertices[k as usize] - p).norm_squared() <= tol2
                                    && best.is_none_or(|b| k < b)
                                {
                                    best = Some(k);
                                }
                            }
                        }
                    }
                }
            }
            best.unwrap_or_else(|| {
                vertices.push(*p);
                let k = (vertices.len() - 1) as u32;
                grid.entry(c).or_default().push(k);
                k
            })
        })
        .collect();
    rebuild(vertices, mesh, &remap)
}

/// Removes triangles with a repeated vertex index or an area `<= area_eps`. The
/// vertex list is unchanged (see [`remove_unused_vertices`]).
pub fn drop_degenerate(mesh: &Mesh, area_eps: Real) -> Mesh {
    let triangles: Vec<[u32; 3]> = mesh
        .triangles()
        .iter()
        .enumerate()
        .filter(|&(t, &[a, b, c])| {
            a != b && b != c && a != c && 0.5 * mesh.triangle_cross(t).norm() > area_eps
        })
        .map(|(_, &tri)| tri)
        .collect();
    Mesh::new(mesh.vertices().to_vec(), triangles).unwrap_or_default()
}

/// Removes vertices no triangle uses, keeping the others in order.
pub fn remove_unused_vertices(mesh: &Mesh) -> Mesh {
    let mut used = vec![false; mesh.vertices().len()];
    for t in mesh.triangles() {
        for &i in t {
            used[i as usize] = true;
        }
    }
    let mut remap = vec![0u32; used.len()];
    let mut vertices = Vec::new();
    for (i, p) in mesh.vertices().iter().enumerate() {
        if used[i] {
            remap[i] = vertices.len() as u32;
            vertices.push(*p);
        }
    }
    rebuild(vertices, mesh, &remap)
}

/// Tolerances of [`report_with`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReportOptions {
    /// Vertices closer than this fraction of the bounding-box diagonal count as one
    /// before the topology is checked. Default `1e-9`.
    pub relative_merge_tolerance: Real,
    /// Triangles with an area at most this fraction of the squared bounding-box
    /// diagonal count as degenerate. Default `1e-14`.
    pub relative_degenerate_area: Real,
}

impl Default for ReportOptions {
    fn default() -> Self {
        Self { relative_merge_tolerance: 1e-9, relative_degenerate_area: 1e-14 }
    }
}

/// The checks of one mesh. Topology is evaluated after merging vertices within the
/// report's tolerance, so a triangle soup (as STL stores) is judged by its shape.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshReport {
    /// Number of triangles.
    pub triangles: usize,
    /// Number of vertices as stored.
    pub vertices: usize,
    /// Number of distinct vertices after merging.
    pub unique_vertices: usize,
    /// Stored vertices that coincide with an earlier one (`vertices - unique_vertices`).
    pub duplicate_vertices: usize,
    /// Triangles with a repeated vertex (after merging) or (near) zero area.
    pub degenerate_faces: usize,
    /// Number of distinct undirected edges.
    pub edges: usize,
    /// Edges with exactly one face.
    pub boundary_edges: usize,
    /// Edges with more than two faces.
    pub non_manifold_edges: usize,
    /// Vertices whose faces form more than one fan (bow-tie vertices).
    pub non_manifold_vertices: usize,
    /// Every edge is shared by exactly two faces (and there is at least one face).
    pub closed: bool,
    /// No edge has more than two faces and every vertex has a single fan.
    pub manifold: bool,
    /// Every edge with two faces is used once in each direction.
    pub consistently_oriented: bool,
    /// Signed enclosed volume by the divergence theorem: positive for a closed,
    /// outward-wound mesh; meaningless for an open one.
    pub volume: Real,
    /// Total surface area.
    pub area: Real,
    /// Bounding box of the vertices (`None` for no vertices).
    pub bbox: Option<Aabb>,
    /// Connected components of faces (through shared vertices, after merging).
    pub bodies: usize,
    /// `V - E + F` over the used vertices (2 per closed genus-0 body).
    pub euler_characteristic: i64,
}

/// [`report_with`] with default options.
pub fn report(mesh: &Mesh) -> MeshReport {
    report_with(mesh, &ReportOptions::default())
}

/// Checks a mesh: see [`MeshReport`] for what each field means.
///
/// ```
/// use s2g_geom::{Mesh, Point3, merge_vertices, report};
/// // A tetrahedron as a triangle soup (as STL stores it): 12 vertices, 4 faces.
/// let p = [Point3::origin(), Point3::new(1.0, 0.0, 0.0), Point3::new(0.0, 1.0, 0.0), Point3::new(0.0, 0.0, 1.0)];
/// let faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]].map(|f: [usize; 3]| f.map(|i| p[i]));
/// let soup = Mesh::from_soup(&faces).unwrap();
/// let r = report(&soup);
/// assert!(r.closed && r.manifold && r.consistently_oriented);
/// assert_eq!((r.vertices, r.unique_vertices, r.bodies), (12, 4, 1));
/// assert!((r.volume - 1.0 / 6.0).abs() < 1e-15);
/// assert_eq!(merge_vertices(&soup, 0.0).vertices().len(), 4);
/// ```
pub fn report_with(mesh: &Mesh, options: &ReportOptions) -> MeshReport {
    let bbox = mesh.bbox();
    let diag = bbox.map(|b| b.extent().norm()).unwrap_or(0.0);
    let merged = merge_vertices(mesh, options.relative_merge_tolerance * diag);
    let area_eps = options.relative_degenerate_area * diag * diag;
    let tris = merged.triangles();
    let nv = merged.vertices().len();

    let collapsed = |t: &[u32; 3]| t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
    let degenerate_faces = (0..tris.len())
        .filter(|&t| collapsed(&tris[t]) || 0.5 * merged.triangle_cross(t).norm() <= area_eps)
        .count();

    // Directed edges of the non-collapsed faces, grouped by undirected edge.
    let mut edges: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(3 * tris.len());
    for (f, t) in tris.iter().enumerate() {
        if collapsed(t) {
            continue;
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), f as u32, a < b));
        }
    }
    edges.sort_unstable();

    let mut corner_sets = UnionFind::new(3 * tris.len());
    let corner = |f: u32, v: u32| {
        let t = tris[f as usize];
        3 * f as usize + t.iter().position(|&x| x == v).unwrap_or(0)
    };
    let (mut n_edges, mut boundary, mut non_manifold_edges) = (0, 0, 0);
    let mut oriented = true;
    for group in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        n_edges += 1;
        match group.len() {
            1 => boundary += 1,
            2 => {
                if group[0].3 == group[1].3 {
                    oriented = false;
                }
                let (u, w, f1, f2) = (group[0].0, group[0].1, group[0].2, group[1].2);
                corner_sets.union(corner(f1, u), corner(f2, u));
                corner_sets.union(corner(f1, w), corner(f2, w));
            }
            _ => non_manifold_edges += 1,
        }
    }

    // Fans per vertex: distinct corner classes among the vertex's corners.
    let mut fans: Vec<(u32, usize)> = Vec::with_capacity(3 * tris.len());
    let mut bodies_uf = UnionFind::new(nv);
    let mut used = vec![false; nv];
    for (f, t) in tris.iter().enumerate() {
        if collapsed(t) {
            continue;
        }
        for k in 0..3 {
            fans.push((t[k], corner_sets.find(3 * f + k)));
            used[t[k] as usize] = true;
        }
        bodies_uf.union(t[0] as usize, t[1] as usize);
        bodies_uf.union(t[0] as usize, t[2] as usize);
    }
    fans.sort_unstable();
    fans.dedup();
    let non_manifold_vertices = fans.chunk_by(|a, b| a.0 == b.0).filter(|g| g.len() > 1).count();
    let mut roots: Vec<usize> = (0..nv).filter(|&v| used[v]).map(|v| bodies_uf.find(v)).collect();
    let used_count = roots.len();
    roots.sort_unstable();
    roots.dedup();

    let live_faces = tris.iter().filter(|t| !collapsed(t)).count();
    MeshReport {
        triangles: mesh.triangles().len(),
        vertices: mesh.vertices().len(),
        unique_vertices: nv,
        duplicate_vertices: mesh.vertices().len() - nv,
        degenerate_faces,
        edges: n_edges,
        boundary_edges: boundary,
        non_manifold_edges,
        non_manifold_vertices,
        closed: live_faces > 0 && boundary == 0 && non_manifold_edges == 0,
        manifold: non_manifold_edges == 0 && non_manifold_vertices == 0,
        consistently_oriented: oriented,
        volume: mesh.signed_volume(),
        area: mesh.area(),
        bbox,
        bodies: roots.len(),
        euler_characteristic: used_count as i64 - n_edges as i64 + live_faces as i64,
    }
}

/// Disjoint sets with path halving and union by size.
struct UnionFind {
    parent: Vec<usize>,
    size: Vec<u32>,
}

impl UnionFind {
    fn new(n: usize) -> Self {
        Self { parent: (0..n).collect(), size: vec![1; n] }
    }

    fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] != x {
            self.parent[x] = self.parent[self.parent[x]];
            x = self.parent[x];
        }
        x
    }

    fn union(&mut self, a: usize, b: usize) {
        let (mut a, mut b) = (self.find(a), self.find(b));
        if a == b {
            return;
        }
        if self.size[a] < self.size[b] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b] = a;
        self.size[a] += self.size[b];
    }
}
