//! Integration tests of s2g-orient on the bundled meshes and on shapes built in code.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use s2g_geom::{
    Aabb, GridSpec, Mesh, MeshIndex, Point3, Rotation3, Setup, Similarity3, UnitVector3, Vector3, load_mesh,
    sample_surface, voxelize,
};
use s2g_orient::{
    HeightMap, OrientOptions, Strategy, VisibilityContext, VisibilityOptions, candidate_directions,
    closure_mesh, height_closure, random_direction, select_orientations, select_orientations_in_stock,
    stock_grid_points,
};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/data/meshes");

/// The closed meshes of the test corpus (the acceptance set).
const CLOSED: &[&str] = &[
    "openscad/openscad_Advanced_offset.stl",
    "openscad/openscad_Basics_LetterBlock.stl",
    "openscad/openscad_Basics_text_on_cube.stl",
    "openscad/openscad_Old_example001.stl",
    "openscad/openscad_Old_example002.stl",
    "openscad/openscad_Old_example004.stl",
    "openscad/openscad_Old_example007.stl",
    "openscad/openscad_Old_example016.stl",
    "classic/stanford_bunny.stl",
    "classic/gearwheel_40t.bin.stl",
];

fn load(name: &str) -> Mesh {
    load_mesh(format!("{DATA}/{name}")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A quad `a b c d` as two triangles, wound so that their normal agrees with `outward`.
fn quad(out: &mut Vec<[Point3; 3]>, q: [Point3; 4], outward: Vector3) {
    let [a, b, c, d] = q;
    if (b - a).cross(&(c - a)).dot(&outward) >= 0.0 {
        out.extend([[a, b, c], [a, c, d]]);
    } else {
        out.extend([[a, c, b], [a, d, c]]);
    }
}

/// A closed height-field solid: cells of size `s`, cell `(i, j)` of height `h[j][i] > 0`
/// above z = 0.
fn height_field(h: &[Vec<f64>], s: f64) -> Mesh {
    let ny = h.len();
    let nx = h[0].len();
    let at = |i: usize, j: usize| if i < nx && j < ny { h[j][i] } else { 0.0 };
    let p = |x: usize, y: usize, z: f64| Point3::new(x as f64 * s, y as f64 * s, z);
    let mut t = Vec::new();
    for (j, row) in h.iter().enumerate() {
        for (i, &z) in row.iter().enumerate() {
            quad(&mut t, [p(i, j, z), p(i + 1, j, z), p(i + 1, j + 1, z), p(i, j + 1, z)], Vector3::z());
            quad(
                &mut t,
                [p(i, j, 0.0), p(i + 1, j, 0.0), p(i + 1, j + 1, 0.0), p(i, j + 1, 0.0)],
                -Vector3::z(),
            );
        }
    }
    // Walls between x-neighbours (including the outside, height 0), facing the lower side.
    for j in 0..ny {
        for i in 0..=nx {
            let left = if i == 0 { 0.0 } else { at(i - 1, j) };
            let right = at(i, j);
            if left != right {
                let (lo, hi) = (left.min(right), left.max(right));
                let out = if left > right { Vector3::x() } else { -Vector3::x() };
                quad(&mut t, [p(i, j, lo), p(i, j + 1, lo), p(i, j + 1, hi), p(i, j, hi)], out);
            }
        }
    }
    for i in 0..nx {
        for j in 0..=ny {
            let front = if j == 0 { 0.0 } else { at(i, j - 1) };
            let back = at(i, j);
            if front != back {
                let (lo, hi) = (front.min(back), front.max(back));
                let out = if front > back { Vector3::y() } else { -Vector3::y() };
                quad(&mut t, [p(i, j, lo), p(i + 1, j, lo), p(i + 1, j, hi), p(i, j, hi)], out);
            }
        }
    }
    Mesh::from_soup(&t).unwrap()
}

fn box_mesh(min: Point3, max: Point3) -> Mesh {
    Mesh::cuboid(&s2g_geom::Aabb::new(min, max)).unwrap()
}

fn iou(a: &s2g_geom::VoxelGrid, b: &s2g_geom::VoxelGrid) -> f64 {
    let inter = a.count_and(b).unwrap() as f64;
    inter / ((a.count() + b.count()) as f64 - inter)
}

#[test]
fn acceptance_five_setups_beat_plain_greedy_on_the_closed_meshes() {
    // "With 5 setups": no early stop at a coverage target.
    let opts = OrientOptions { coverage_target: 1.0, ..Default::default() };
    let mut ours = 0.0;
    let mut plain = 0.0;
    let mut lines = Vec::new();
    for name in CLOSED {
        let mesh = load(name);
        let r = select_orientations(&mesh, &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
        let b = &r.baselines;
        let c = r.final_coverage();
        lines.push(format!(
            "{name}: ours {:.4} swap {:.4} plain {:.4} six {:.4} r5 {:.4} r6 {:.4} ub {:.4} ({:.2} s)",
            c,
            b.swap_search,
            b.plain_greedy,
            b.six_axes,
            b.random5,
            b.random6,
            r.upper_bound,
            r.stage_seconds.total
        ));
        assert!(r.directions.len() <= 5 && r.directions.len() == r.setups.len(), "{name}");
        assert!(
            c >= b.swap_search && b.swap_search >= b.plain_greedy,
            "{name}: search lost ground: {}",
            lines.last().unwrap()
        );
        assert!(r.upper_bound >= c - 1e-12, "{name}: coverage above the upper bound");
        assert!(r.coverage.windows(2).all(|w| w[0] <= w[1]), "{name}: coverage curve not monotone");
        for (d, s) in r.directions.iter().zip(&r.setups) {
            assert!((s.tool_axis().into_inner() - d.into_inner()).norm() < 1e-9, "{name}: setup axis");
        }
        ours += c;
        plain += b.plain_greedy;
    }
    let n = CLOSED.len() as f64;
    eprintln!("{}\nmean: ours {:.4}, plain greedy {:.4}", lines.join("\n"), ours / n, plain / n);
    assert!(ours / n >= 0.973, "mean coverage {:.4} < 0.973:\n{}", ours / n, lines.join("\n"));
}

#[test]
fn six_setups_never_lose_to_the_six_axes() {
    let opts = OrientOptions {
        points: 4096,
        max_setups: 6,
        coverage_target: 1.0,
        baseline_trials: 0,
        ..Default::default()
    };
    for name in CLOSED {
        let r = select_orientations(&load(name), &opts).unwrap();
        assert!(
            r.final_coverage() >= r.baselines.six_axes,
            "{name}: {} with 6 setups < six axes {}",
            r.final_coverage(),
            r.baselines.six_axes
        );
    }
}

#[test]
fn coverage_does_not_depend_on_the_mesh_rotation() {
    let mut rng = StdRng::seed_from_u64(11);
    let opts = OrientOptions { baseline_trials: 0, ..Default::default() };
    for name in ["classic/stanford_bunny.stl", "openscad/openscad_Old_example007.stl"] {
        let mesh = load(name);
        let base = select_orientations(&mesh, &opts).unwrap().final_coverage();
        let axis = random_direction(&mut rng);
        let angle = rng.random::<f64>() * std::f64::consts::TAU;
        let rot = Similarity3::from_parts(
            nalgebra::Translation3::new(3.0, -1.0, 2.0),
            Rotation3::from_axis_angle(&axis, angle),
            1.0,
        );
        let turned = select_orientations(&mesh.transformed(&rot), &opts).unwrap().final_coverage();
        assert!(
            (base - turned).abs() <= 0.005,
            "{name}: {base} vs {turned} after rotating by {angle} about {axis:?}"
        );
    }
}

#[test]
fn results_are_deterministic() {
    let mesh = load("openscad/openscad_Old_example002.stl");
    let opts = OrientOptions { points: 2048, candidates: 128, seed: 5, ..Default::default() };
    let a = select_orientations(&mesh, &opts).unwrap();
    let b = select_orientations(&mesh, &opts).unwrap();
    assert_eq!((&a.directions, &a.coverage, &a.baselines), (&b.directions, &b.coverage, &b.baselines));
    assert_eq!(a.upper_bound.to_bits(), b.upper_bound.to_bits());
    // The plain strategy returns exactly the plain-greedy baseline.
    let p = select_orientations(&mesh, &OrientOptions { strategy: Strategy::PlainGreedy, ..opts }).unwrap();
    assert_eq!(p.final_coverage(), p.baselines.plain_greedy);
    assert_eq!(p.final_coverage(), a.baselines.plain_greedy);
    let mut x: Vec<_> = p.directions.iter().map(|d| d.into_inner().as_slice().to_vec()).collect();
    let mut y: Vec<_> =
        a.baselines.plain_greedy_directions.iter().map(|d| d.into_inner().as_slice().to_vec()).collect();
    x.sort_by(|a, b| a.partial_cmp(b).unwrap());
    y.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(x, y, "plain strategy and plain baseline chose different directions");
    assert!(a.final_coverage() >= a.baselines.plain_greedy);
}

/// Ray-triangle intersection (Moller-Trumbore), for the brute-force reference.
fn ray_hits(o: &Point3, d: &Vector3, tri: &[Point3; 3]) -> bool {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = d.cross(&e2);
    let det = e1.dot(&p);
    if det.abs() < 1e-14 {
        return false;
    }
    let s = o - tri[0];
    let u = s.dot(&p) / det;
    let q = s.cross(&e1);
    let v = d.dot(&q) / det;
    let t = e2.dot(&q) / det;
    (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && t > 0.0
}

#[test]
fn visibility_matches_brute_force_ray_casting() {
    for name in ["openscad/openscad_Old_example002.stl", "classic/gearwheel_40t.bin.stl"] {
        let mesh = load(name);
        let bbox = mesh.bbox().unwrap();
        let samples = sample_surface(&mesh, 700, 3).unwrap();
        let index = MeshIndex::new(&mesh).unwrap();
        let vopts = VisibilityOptions::default();
        let ctx = VisibilityContext::new(&mesh, &index, &samples, &vopts).unwrap();
        let dirs: Vec<UnitVector3> = candidate_directions(24);
        let m = ctx.matrix(&dirs);
        assert_eq!(m, ctx.matrix_by_points(&dirs), "{name}: the two schedules disagree");
        let no_cull = VisibilityOptions { hull_cull: false, ..vopts };
        let m2 = VisibilityContext::new(&mesh, &index, &samples, &no_cull).unwrap().matrix(&dirs);
        assert!(ctx.supported_samples() > 0, "{name}: no sample on a supporting triangle");
        assert_eq!(m, m2, "{name}: the supporting-triangle cull changed the answer");
        let eps = vopts.eps * bbox.extent().norm();
        let tris: Vec<[Point3; 3]> = mesh.triangle_points().collect();
        let mut mismatches = 0;
        for (d, v) in dirs.iter().enumerate() {
            assert_eq!(ctx.row(v), m.row(d), "{name}: parallel row differs");
            for i in 0..samples.len() {
                let n = samples.normals[i];
                let o = samples.points[i] + n * eps;
                let expect = n.dot(v) > 0.0 && !tris.iter().any(|t| ray_hits(&o, v, t));
                if expect != m.get(i, d) {
                    mismatches += 1;
                }
            }
        }
        let total = samples.len() * dirs.len();
        assert!(
            mismatches * 1000 <= total,
            "{name}: {mismatches} of {total} pairs disagree with brute force"
        );
    }
}

#[test]
fn rows_of_many_samples_answer_as_single_rays_do() {
    // Enough samples per triangle that full rows bin the triangles across each direction
    // (`MeshIndex::parallel_rays`) instead of walking the BVH; `visible` never bins.
    for (name, tool_radius) in
        [("openscad/openscad_Old_example002.stl", None), ("openscad/openscad_Old_example002.stl", Some(0.5))]
    {
        let mesh = load(name);
        let samples = sample_surface(&mesh, 4 * mesh.triangles().len() + 64, 5).unwrap();
        let index = MeshIndex::new(&mesh).unwrap();
        let vopts = VisibilityOptions { tool_radius, tool_rays: 4, ..VisibilityOptions::default() };
        let ctx = VisibilityContext::new(&mesh, &index, &samples, &vopts).unwrap();
        let mut dirs: Vec<UnitVector3> = candidate_directions(16);
        dirs.push(UnitVector3::new_normalize(Vector3::new(0.0, 1.0, 1.0)));
        let m = ctx.matrix(&dirs);
        let mut seen = 0;
        for (d, v) in dirs.iter().enumerate() {
            for i in 0..samples.len() {
                assert_eq!(
                    m.get(i, d),
                    ctx.visible(i, v),
                    "{name} {tool_radius:?}: sample {i} direction {v:?}"
                );
                seen += m.get(i, d) as usize;
            }
        }
        let total = samples.len() * dirs.len();
        assert!(seen > total / 10 && seen < total * 9 / 10, "{name}: {seen} of {total} visible");
    }
}

#[test]
fn convex_parts_see_exactly_their_front_faces() {
    let cube = box_mesh(Point3::new(-1.0, -2.0, -0.5), Point3::new(2.0, 1.0, 1.5));
    let samples = sample_surface(&cube, 3000, 1).unwrap();
    let index = MeshIndex::new(&cube).unwrap();
    let ctx = VisibilityContext::new(&cube, &index, &samples, &VisibilityOptions::default()).unwrap();
    assert_eq!(ctx.supported_samples(), samples.len(), "every box face supports the box");
    let dirs = candidate_directions(64);
    let m = ctx.matrix(&dirs);
    for (d, v) in dirs.iter().enumerate() {
        for i in 0..samples.len() {
            assert_eq!(m.get(i, d), samples.normals[i].dot(v) > 0.0, "box sample {i} direction {v:?}");
        }
    }
    // Two opposite diagonals see all six faces: selection must find full coverage with <= 2 setups.
    let r = select_orientations(&cube, &OrientOptions { points: 3000, ..Default::default() }).unwrap();
    assert!(
        r.final_coverage() >= 0.99 && r.directions.len() <= 2,
        "box: {:?} {:?}",
        r.directions,
        r.coverage
    );
}

#[test]
fn tool_aware_visibility_rejects_a_slot_narrower_than_the_tool() {
    // A 10 x 10 base with a 1-wide slot between two walls, 4 deep.
    let mut h = vec![vec![6.0; 20]; 4];
    for row in &mut h {
        row[9] = 2.0;
        row[10] = 2.0;
    }
    let part = height_field(&h, 0.5);
    let samples = sample_surface(&part, 4000, 2).unwrap();
    let index = MeshIndex::new(&part).unwrap();
    let up = UnitVector3::new_normalize(Vector3::z());
    let floor: Vec<usize> = (0..samples.len())
        .filter(|&i| {
            let p = samples.points[i];
            (p.z - 2.0).abs() < 1e-9 && p.x > 4.6 && p.x < 5.4 && p.y > 0.3 && p.y < 1.7
        })
        .collect();
    assert!(floor.len() > 10, "too few slot-floor samples ({})", floor.len());
    let plain = VisibilityContext::new(&part, &index, &samples, &VisibilityOptions::default()).unwrap();
    let tool = VisibilityOptions { tool_radius: Some(0.75), ..Default::default() };
    let aware = VisibilityContext::new(&part, &index, &samples, &tool).unwrap();
    let thin = VisibilityOptions { tool_radius: Some(0.2), ..Default::default() };
    let small = VisibilityContext::new(&part, &index, &samples, &thin).unwrap();
    for &i in &floor {
        assert!(plain.visible(i, &up), "slot floor sample {i} should be visible to a ray");
        assert!(!aware.visible(i, &up), "slot floor sample {i} should be out of reach of a 1.5 mm ball");
    }
    // Centre-line floor samples stay reachable for a tool that fits.
    let centre: Vec<&usize> = floor.iter().filter(|&&i| (samples.points[i].x - 5.0).abs() < 0.2).collect();
    assert!(centre.iter().all(|&&i| small.visible(i, &up)), "a 0.4 mm ball fits in the 1 mm slot");
}

#[test]
fn stepped_block_closure_from_the_top_is_the_part() {
    let h = vec![vec![1.0, 1.0, 2.0, 3.0], vec![1.0, 2.5, 2.5, 3.0], vec![0.5, 2.0, 2.0, 1.5]];
    let part = height_field(&h, 1.0);
    let bounds = part.bbox().unwrap().inflated(0.25);
    let spec = GridSpec::cubic(&bounds, 64).unwrap();
    let solid = voxelize(&part, &spec).unwrap();
    let closure = height_closure(&part, &Setup::top(), &spec).unwrap();
    let top = iou(&closure, &solid);
    assert!(top >= 0.99, "stepped block: IoU {top}");
    // Sections in the setup frame: area at height z is the area of the cells at least z high.
    let map = HeightMap::in_setup_frame(&part, &Setup::top(), 0.05).unwrap();
    for z in [0.25, 0.75, 1.25, 1.75, 2.25, 2.75] {
        let expect: f64 = h.iter().flatten().filter(|&&c| c >= z).count() as f64;
        let area = map.section(z).area();
        assert!((area - expect).abs() < 1e-6, "section at {z}: {area} vs {expect}");
    }
    // From below (tool axis -Z) a point is occluded when material lies under it, so the
    // closure is the footprint's prism from z = 0 up to the part's top (its lowest point
    // seen from below).
    let below = Setup::from_direction(&UnitVector3::new_normalize(-Vector3::z()));
    let under = height_closure(&part, &below, &spec).unwrap();
    let mut prism = s2g_geom::VoxelGrid::new(spec);
    prism.set_where(|c| c.x > 0.0 && c.x < 4.0 && c.y > 0.0 && c.y < 3.0 && c.z > 0.0 && c.z < 3.0);
    let got = iou(&under, &prism);
    assert!(got >= 0.99, "closure from below vs the footprint prism: IoU {got}");
    let smooth = closure_mesh(&closure, &Default::default()).unwrap();
    assert!(smooth.signed_volume() > 0.8 * part.signed_volume(), "smoothed closure lost volume");
}

#[test]
fn closures_contain_the_part_on_every_closed_mesh_and_random_direction() {
    let mut rng = StdRng::seed_from_u64(4);
    for name in CLOSED {
        let mesh = load(name);
        let spec = GridSpec::cubic(&mesh.bbox().unwrap().inflated(1e-3), 48).unwrap();
        let solid = voxelize(&mesh, &spec).unwrap();
        for _ in 0..2 {
            let setup = Setup::from_direction(&random_direction(&mut rng));
            let c = height_closure(&mesh, &setup, &spec).unwrap();
            assert_eq!(c.count_and(&solid).unwrap(), solid.count(), "{name}: closure misses part voxels");
            assert!(c.count() >= solid.count());
        }
    }
}

#[test]
fn closure_agrees_with_per_voxel_ray_casting() {
    // Independent method: a voxel centre outside the part is in the closure iff a ray from
    // it along the tool axis hits the part (and it is not below the part's lowest point).
    let mut rng = StdRng::seed_from_u64(9);
    for name in ["classic/stanford_bunny.stl", "openscad/openscad_Old_example016.stl"] {
        let mesh = load(name);
        let index = MeshIndex::new(&mesh).unwrap();
        let spec = GridSpec::cubic(&mesh.bbox().unwrap().inflated(1e-3), 48).unwrap();
        let solid = voxelize(&mesh, &spec).unwrap();
        for _ in 0..2 {
            let dir = random_direction(&mut rng);
            let closure = height_closure(&mesh, &Setup::from_direction(&dir), &spec).unwrap();
            let lowest = mesh.vertices().iter().map(|p| p.coords.dot(&dir)).fold(f64::INFINITY, f64::min);
            let mut reference = s2g_geom::VoxelGrid::new(spec);
            reference
                .set_where(|c| c.coords.dot(&dir) >= lowest && index.ray_hits_any(c, &dir, f64::INFINITY));
            reference.or(&solid).unwrap();
            let got = iou(&closure, &reference);
            eprintln!("{name} from {dir:?}: IoU {got}");
            assert!(got >= 0.98, "{name} from {dir:?}: closure vs ray casting IoU {got}");
        }
    }
}

#[test]
fn bad_input_gives_errors_not_panics() {
    let empty = Mesh::default();
    assert!(select_orientations(&empty, &OrientOptions::default()).is_err());
    let mesh = box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0));
    for bad in [
        OrientOptions { points: 0, ..Default::default() },
        OrientOptions { max_setups: 0, ..Default::default() },
        OrientOptions { coverage_target: f64::NAN, ..Default::default() },
        OrientOptions { coverage_target: 1.5, ..Default::default() },
        OrientOptions { tool_radius: Some(-1.0), ..Default::default() },
        OrientOptions { ray_eps: f64::INFINITY, ..Default::default() },
    ] {
        assert!(select_orientations(&mesh, &bad).is_err(), "accepted {bad:?}");
    }
    // Inside-out: every ray starts inside; the documented fallback is one +Z setup.
    let r =
        select_orientations(&mesh.flipped(), &OrientOptions { points: 500, ..Default::default() }).unwrap();
    assert_eq!(r.directions.len(), 1);
    assert!(r.final_coverage() < 0.05, "inside-out box covered {}", r.final_coverage());
    let spec = GridSpec::cubic(&Aabb::unit_cube(), 8).unwrap();
    assert!(height_closure(&empty, &Setup::top(), &spec).is_err());
    assert!(HeightMap::in_setup_frame(&mesh, &Setup::top(), 0.0).is_err());
    assert!(HeightMap::in_setup_frame(&mesh, &Setup::top(), 1e-9).is_err(), "absurd texel count accepted");
}

/// The stock-removal term: on a flat plate in a cube of stock the chosen setups leave no
/// more removable stock than allowed, see as much of the surface as the coverage target
/// asks, and without stock samples selection is the visibility-only one.
#[test]
fn setups_for_a_flat_plate_cut_away_its_stock() {
    let plate = box_mesh(Point3::new(-0.5, -0.1, -0.08), Point3::new(0.5, 0.1, 0.08));
    let cube = Aabb::new(Point3::new(-0.5, -0.5, -0.5), Point3::new(0.5, 0.5, 0.5));
    let stock = stock_grid_points(&cube, 32 * 32 * 32, |_| true);
    assert_eq!(stock.len(), 32 * 32 * 32);
    for min_cos in [0.0, -1e-3] {
        let opts = OrientOptions {
            points: 4096,
            candidates: 128,
            baseline_trials: 0,
            min_cos,
            ..Default::default()
        };
        let plain = select_orientations(&plate, &opts).unwrap();
        let with = select_orientations_in_stock(&plate, &stock, &opts).unwrap();
        assert_eq!(select_orientations_in_stock(&plate, &[], &opts).unwrap().directions, plain.directions);
        let s = with.stock.expect("a stock report");
        let allowed = (opts.stock_removal.max_left * s.part as f64).floor() as usize;
        assert!(s.part > 0 && s.material + s.part == stock.len(), "{s:?}");
        assert!(s.left <= s.unreachable + allowed, "min_cos {min_cos}: {s:?}");
        assert!(
            with.final_coverage() >= plain.final_coverage().min(opts.coverage_target) - 1e-12,
            "coverage {} against {}",
            with.final_coverage(),
            plain.final_coverage()
        );
        assert!(with.directions.len() <= opts.max_setups);
        // The term changes nothing it does not report.
        if !s.changed {
            assert_eq!(with.directions, plain.directions);
        }
    }
}

/// A tool reaches only so deep below the stock's top along its axis: a tall bar's side,
/// seen from an axis tilted 45 degrees from it, is visible all the way down without a
/// reach and only down to the reach with one (the stock's top along the tilted axis being
/// its highest corner), and what a setup cannot reach does not count towards coverage.
#[test]
fn a_tool_reach_hides_what_lies_deeper_than_it() {
    use s2g_orient::ToolReach;
    let bar = Aabb::new(Point3::new(-5.0, -5.0, -50.0), Point3::new(5.0, 5.0, 50.0));
    let mesh = Mesh::cuboid(&bar).unwrap();
    let index = MeshIndex::new(&mesh).unwrap();
    let samples = sample_surface(&mesh, 4000, 3).unwrap();
    let v = UnitVector3::new_normalize(Vector3::new(1.0, 0.0, 1.0));
    let depth = 20.0;
    let reach = ToolReach::new(bar, depth);
    let plain = VisibilityContext::new(&mesh, &index, &samples, &VisibilityOptions::default()).unwrap();
    let limited = VisibilityContext::new(
        &mesh,
        &index,
        &samples,
        &VisibilityOptions { reach: Some(reach), ..Default::default() },
    )
    .unwrap();
    // The stock's top along v is the corner (5, *, 50): v . x = 55 / sqrt 2.
    let floor = reach.floor(&v.into_inner());
    assert!((floor - (55.0 / 2f64.sqrt() - depth)).abs() < 1e-12);
    let (mut deep, mut shallow) = (0, 0);
    for (i, (p, n)) in samples.points.iter().zip(&samples.normals).enumerate() {
        // The +X side: every point faces v and nothing hides it.
        if n.x < 0.99 {
            continue;
        }
        assert!(plain.visible(i, &v), "sample {i} at {p:?}");
        let within = v.dot(&p.coords) >= floor;
        assert_eq!(limited.visible(i, &v), within, "sample {i} at {p:?}");
        if within { shallow += 1 } else { deep += 1 }
    }
    assert!(deep > 50 && shallow > 20, "{deep} deep, {shallow} shallow");
    let row = |c: &VisibilityContext<'_>| c.matrix(&[v]).coverage(&[0]);
    assert!(row(&limited) < row(&plain), "{} vs {}", row(&limited), row(&plain));
    // A negative or infinite depth is refused.
    for bad in [-1.0, f64::INFINITY] {
        let opts = VisibilityOptions { reach: Some(ToolReach::new(bar, bad)), ..Default::default() };
        assert!(VisibilityContext::new(&mesh, &index, &samples, &opts).is_err(), "depth {bad}");
    }
}
