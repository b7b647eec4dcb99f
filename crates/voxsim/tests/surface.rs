//! The height field and the surface deviation against analytic answers: a flat floor cut
//! by a flat end mill (no deviation), a ball raster on a plane (the scallop
//! `r - sqrt(r^2 - s^2/4)` and its mean over a period), and a gouge of known depth.

use s2g_gcode::{Motion, MotionSink};
use s2g_geom::{Aabb, Mesh, MeshIndex, Point3};
use s2g_voxsim::{
    Cutter, DeviationOptions, HeightField, HeightFieldOptions, SimError, ToolTable, surface_deviation,
    surface_deviation_opt, surface_deviation_reference,
};

/// Rectangles `[x0, x1] x [y0, y1]` at height `z`, facing up (`up`) or down.
fn quad(tris: &mut Vec<[Point3; 3]>, a: Point3, b: Point3, c: Point3, d: Point3) {
    tris.push([a, b, c]);
    tris.push([a, c, d]);
}

/// A 30 x 30 x 10 block with a 20 x 20 pocket 5 deep in its top, outward wound.
fn pocket_block() -> Mesh {
    let p = Point3::new;
    let mut t = Vec::new();
    let xs = [0.0, 5.0, 25.0, 30.0];
    // The rim: the 3 x 3 grid of rectangles at z = 10 without the centre (no T-junctions
    // with the pocket's corners), each counter-clockwise from above.
    for i in 0..3 {
        for j in 0..3 {
            if (i, j) != (1, 1) {
                let (x0, x1, y0, y1) = (xs[i], xs[i + 1], xs[j], xs[j + 1]);
                quad(&mut t, p(x0, y0, 10.0), p(x1, y0, 10.0), p(x1, y1, 10.0), p(x0, y1, 10.0));
            }
        }
    }
    quad(&mut t, p(5.0, 5.0, 5.0), p(25.0, 5.0, 5.0), p(25.0, 25.0, 5.0), p(5.0, 25.0, 5.0));
    // Pocket walls, facing into the pocket.
    quad(&mut t, p(5.0, 5.0, 5.0), p(5.0, 25.0, 5.0), p(5.0, 25.0, 10.0), p(5.0, 5.0, 10.0));
    quad(&mut t, p(25.0, 25.0, 5.0), p(25.0, 5.0, 5.0), p(25.0, 5.0, 10.0), p(25.0, 25.0, 10.0));
    quad(&mut t, p(25.0, 5.0, 5.0), p(5.0, 5.0, 5.0), p(5.0, 5.0, 10.0), p(25.0, 5.0, 10.0));
    quad(&mut t, p(5.0, 25.0, 5.0), p(25.0, 25.0, 5.0), p(25.0, 25.0, 10.0), p(5.0, 25.0, 10.0));
    // Outer sides and bottom.
    quad(&mut t, p(0.0, 0.0, 0.0), p(30.0, 0.0, 0.0), p(30.0, 0.0, 10.0), p(0.0, 0.0, 10.0));
    quad(&mut t, p(30.0, 0.0, 0.0), p(30.0, 30.0, 0.0), p(30.0, 30.0, 10.0), p(30.0, 0.0, 10.0));
    quad(&mut t, p(30.0, 30.0, 0.0), p(0.0, 30.0, 0.0), p(0.0, 30.0, 10.0), p(30.0, 30.0, 10.0));
    quad(&mut t, p(0.0, 30.0, 0.0), p(0.0, 0.0, 0.0), p(0.0, 0.0, 10.0), p(0.0, 30.0, 10.0));
    quad(&mut t, p(0.0, 0.0, 0.0), p(0.0, 30.0, 0.0), p(30.0, 30.0, 0.0), p(30.0, 0.0, 0.0));
    Mesh::from_soup(&t).unwrap()
}

/// A zigzag raster of tip positions along X at height `z`, passes `step` apart in Y from
/// `y0` to `y1`, from `x0` to `x1`, entered and left at `z + 20`.
fn raster(field: &mut HeightField, x: [f64; 2], y: [f64; 2], step: f64, z: f64) {
    let n = ((y[1] - y[0]) / step).round() as usize;
    let mut go = |to: Point3, rapid: bool| {
        let m = if rapid { Motion::Rapid { to } } else { Motion::Linear { to, feed: 1000.0, extrude: None } };
        field.motion(&m).unwrap();
    };
    go(Point3::new(x[0], y[0], z + 20.0), true);
    for k in 0..=n {
        let yk = y[0] + k as f64 * step;
        let (a, b) = if k % 2 == 0 { (x[0], x[1]) } else { (x[1], x[0]) };
        go(Point3::new(a, yk, z), false);
        go(Point3::new(b, yk, z), false);
    }
    go(Point3::new(x[0], y[1], z + 20.0), true);
}

#[test]
fn a_flat_pocket_floor_cut_by_a_flat_end_mill_has_no_deviation() {
    let part = MeshIndex::new(&pocket_block()).unwrap();
    let r = 2.0;
    let mut field =
        HeightField::new([-1.0, -1.0], [31.0, 31.0], ToolTable::single(Cutter::flat(r, 20.0))).unwrap();
    // Tool centres inside the pocket by the radius, 3 apart (< 2r), with a last pass at
    // the far wall.
    raster(&mut field, [5.0 + r, 25.0 - r], [5.0 + r, 25.0 - r], 3.2, 5.0);
    let d = surface_deviation(&field, &part);
    // The floor columns (the pocket's 20 x 20 without its four corner fillets) are reached;
    // those on the walls' feet, where the cutter's rim only touches, may or may not be.
    let floor = (20.0 / 0.05 + 1.0) * (20.0 / 0.05 + 1.0);
    let fillets = (4.0 - std::f64::consts::PI) * r * r / (0.05 * 0.05);
    let feet = 4.0 * (20.0 / 0.05 + 1.0);
    assert!(
        d.columns as f64 > floor - fillets - feet - 500.0 && d.columns as f64 <= floor,
        "{d:?}, floor {floor}"
    );
    assert!(d.max < 1e-9 && d.mean < 1e-9 && d.gouge_depth < 1e-9, "{d:?}");
}

#[test]
fn a_ball_raster_on_a_plane_leaves_the_analytic_scallop() {
    let part = MeshIndex::new(
        &Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(20.0, 20.0, 5.0))).unwrap(),
    )
    .unwrap();
    for (r, s) in [(3.0, 1.0), (1.5, 0.5), (3.0, 2.0)] {
        let mut field =
            HeightField::new([-5.0, -5.0], [25.0, 25.0], ToolTable::single(Cutter::ball(r, 20.0))).unwrap();
        raster(&mut field, [-4.0, 24.0], [-4.0, 24.0 + s], s, 5.0);
        let d = surface_deviation(&field, &part);
        let h = r - (r * r - s * s / 4.0).sqrt();
        assert!((d.max - h).abs() < 1e-9, "r {r} s {s}: max {} vs analytic {h}", d.max);
        // The mean over the columns of one period (spacing 0.05 divides s), by the profile.
        let m = (s / 0.05).round() as usize;
        let mean =
            (0..m).map(|k| r - (r * r - (k as f64 * 0.05 - s / 2.0).powi(2)).sqrt()).sum::<f64>() / m as f64;
        let mean = mean.max(0.0);
        assert!((d.mean - mean).abs() < 1e-3 * h.max(1e-3), "r {r} s {s}: mean {} vs {mean}", d.mean);
        assert!(d.gouge_depth < 1e-9, "{d:?}");
    }
}

/// A ball of radius `r` rastered along X 1 apart over the 20 x 20 top at z 5, its pass at
/// y = 10 lifted 2 over the surface (as a finisher lifts over a stretch its shank check
/// left out), with pass marks of `width`.
fn lifted_raster(r: f64, width: Option<f64>) -> HeightField {
    let o = HeightFieldOptions { pass_width: width, ..Default::default() };
    let mut field =
        HeightField::new_opt([-5.0, -5.0], [25.0, 25.0], ToolTable::single(Cutter::ball(r, 20.0)), &o)
            .unwrap();
    let mut go = |to: Point3, rapid: bool| {
        let m = if rapid { Motion::Rapid { to } } else { Motion::Linear { to, feed: 1000.0, extrude: None } };
        field.motion(&m).unwrap();
    };
    go(Point3::new(-4.0, -4.0, 25.0), true);
    for k in 0..=28 {
        let y = -4.0 + k as f64;
        let z = if k == 14 { 7.0 } else { 5.0 };
        let (a, b) = if k % 2 == 0 { (-4.0, 24.0) } else { (24.0, -4.0) };
        go(Point3::new(a, y, z), false);
        go(Point3::new(b, y, z), false);
    }
    go(Point3::new(-4.0, 24.0, 25.0), true);
    field
}

#[test]
fn a_pass_lifted_over_the_surface_leaves_unpassed_columns_out_of_the_max() {
    // A ball raster 1 apart on a plane, its pass at y = 10 lifted 2 over the surface (as a
    // finisher lifts over a stretch its shank check left out).
    let part = MeshIndex::new(
        &Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(20.0, 20.0, 5.0))).unwrap(),
    )
    .unwrap();
    let (r, s, w) = (3.0, 1.0, 0.75);
    let cut = |width: Option<f64>| lifted_raster(r, width);
    // Without marks the strip under the lifted pass counts: its middle is a stepover of 2.
    let full = surface_deviation(&cut(None), &part);
    let h2 = r - (r * r - 1.0f64).sqrt();
    assert!((full.max - h2).abs() < 1e-9 && full.unpassed == 0, "{full:?}");
    // With marks the columns farther than w from every pass cut on the surface (|y - 10| <
    // s - w: 9 rows of the 401 columns over the part) are reported apart, and the max is
    // that of the passed columns, w from a pass.
    let d = surface_deviation(&cut(Some(w)), &part);
    assert_eq!(d.unpassed, 9 * 401, "{d:?}");
    assert!((d.unpassed_area - 9.0 * 401.0 * 0.05 * 0.05).abs() < 1e-9, "{d:?}");
    assert!((d.unpassed_max - h2).abs() < 1e-9, "{d:?}");
    let hw = r - (r * r - w * w).sqrt();
    assert!((d.max - hw).abs() < 1e-9, "{d:?} vs {hw}");
    assert_eq!(d.columns + d.unpassed, full.columns);
    // Every column passed on the full raster.
    let mut whole = HeightField::new_opt(
        [-5.0, -5.0],
        [25.0, 25.0],
        ToolTable::single(Cutter::ball(r, 20.0)),
        &HeightFieldOptions { pass_width: Some(w), ..Default::default() },
    )
    .unwrap();
    raster(&mut whole, [-4.0, 24.0], [-4.0, 24.0], s, 5.0);
    let d = surface_deviation(&whole, &part);
    assert!(d.unpassed == 0 && (d.max - (r - (r * r - 0.25f64).sqrt())).abs() < 1e-9, "{d:?}");
    // A rapid on the surface cuts but passes over nothing.
    let mut rapid = HeightField::new_opt(
        [-5.0, -5.0],
        [25.0, 25.0],
        ToolTable::single(Cutter::ball(r, 20.0)),
        &HeightFieldOptions { pass_width: Some(w), ..Default::default() },
    )
    .unwrap();
    for x in [-4.0, 24.0] {
        rapid.motion(&Motion::Rapid { to: Point3::new(x, 10.0, 5.0) }).unwrap();
    }
    let d = surface_deviation(&rapid, &part);
    assert!(d.columns == 0 && d.unpassed > 401, "{d:?}");
}

/// A stretch of pass the finisher left out ([`HeightField::leave_out`]) takes its own strip
/// out of the reached columns: on the ball raster 1 apart with the pass at y = 10 lifted,
/// the columns within half a stepover of it (21 rows) are reported apart, not only those
/// farther than the pass width (0.75) from every pass (9 rows), and the max is the
/// raster's own scallop, half a stepover from a pass; a stretch at another height than
/// the surface's tips takes nothing out.
#[test]
fn a_left_out_stretch_takes_its_strip_out_of_the_reached_columns() {
    let part = MeshIndex::new(
        &Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(20.0, 20.0, 5.0))).unwrap(),
    )
    .unwrap();
    let r = 3.0;
    let cut = |stretch_z: Option<f64>| {
        let mut field = lifted_raster(r, Some(0.75));
        if let Some(z) = stretch_z {
            field.leave_out(&[[Point3::new(-4.0, 10.0, z), Point3::new(24.0, 10.0, z)]], 0.52);
        }
        field
    };
    let unmarked = surface_deviation(&cut(None), &part);
    assert_eq!(unmarked.unpassed, 9 * 401, "{unmarked:?}");
    let hw = r - (r * r - 0.75f64 * 0.75).sqrt();
    assert!((unmarked.max - hw).abs() < 1e-9, "{unmarked:?}");
    let d = surface_deviation(&cut(Some(5.0)), &part);
    assert_eq!(d.unpassed, 21 * 401, "{d:?}");
    assert_eq!(d.columns + d.unpassed, unmarked.columns + unmarked.unpassed);
    let half = r - (r * r - 0.25f64).sqrt();
    assert!((d.max - half).abs() < 1e-9, "{d:?} vs {half}");
    // The stretch 3 above the tips there: not the columns' own.
    assert_eq!(surface_deviation(&cut(Some(8.0)), &part), unmarked);
}

#[test]
fn a_pass_below_the_surface_is_a_gouge_of_its_depth() {
    let part = MeshIndex::new(
        &Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(20.0, 20.0, 5.0))).unwrap(),
    )
    .unwrap();
    let mut field =
        HeightField::new([-5.0, -5.0], [25.0, 25.0], ToolTable::single(Cutter::ball(2.0, 20.0))).unwrap();
    raster(&mut field, [-4.0, 24.0], [-4.0, 24.0], 1.0, 5.0);
    for to in [Point3::new(10.0, 10.0, 4.9), Point3::new(12.0, 10.0, 4.9)] {
        field.motion(&Motion::Linear { to, feed: 500.0, extrude: None }).unwrap();
    }
    let d = surface_deviation(&field, &part);
    assert!((d.gouge_depth - 0.1).abs() < 1e-9, "{d:?}");
}

#[test]
fn bad_grids_and_tilted_setups_are_errors() {
    let tools = ToolTable::single(Cutter::ball(2.0, 20.0));
    let tiny = HeightFieldOptions { spacing: 0.0, ..Default::default() };
    assert!(HeightField::new_opt([0.0, 0.0], [1.0, 1.0], tools.clone(), &tiny).is_err());
    let wide = HeightFieldOptions { pass_width: Some(f64::NAN), ..Default::default() };
    assert!(HeightField::new_opt([0.0, 0.0], [1.0, 1.0], tools.clone(), &wide).is_err());
    assert!(HeightField::new([0.0, f64::NAN], [1.0, 1.0], tools.clone()).is_err());
    assert!(HeightField::new([2.0, 0.0], [1.0, 1.0], tools.clone()).is_err());
    let mut field = HeightField::new([0.0, 0.0], [1.0, 1.0], tools).unwrap();
    let tilted =
        s2g_geom::Setup::from_direction(&s2g_geom::UnitVector3::new_normalize(s2g_geom::Vector3::x()));
    let e = field.motion(&Motion::Setup { frame: tilted.frame, rotary: [None; 3] });
    assert!(matches!(e, Err(SimError::InvalidMotion { .. })), "{e:?}");
    let e = field.motion(&Motion::Rapid { to: Point3::new(f64::NAN, 0.0, 0.0) });
    assert!(e.is_err());
}

/// A ball of radius `r` as an outward-wound closed mesh (UV sphere, `n` bands).
fn uv_sphere(c: Point3, r: f64, n: usize) -> Mesh {
    let at = |i: usize, j: usize| {
        let (th, ph) =
            (std::f64::consts::PI * i as f64 / n as f64, std::f64::consts::TAU * j as f64 / n as f64);
        c + r * nalgebra::Vector3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
    };
    let mut t = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (a, b, cc, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            if i > 0 {
                t.push([a, b, d]);
            }
            if i + 1 < n {
                t.push([b, cc, d]);
            }
        }
    }
    Mesh::from_soup(&t).unwrap()
}

/// The deviation with each row's closest-point searches bounded by its last cut point,
/// and with the gouge test of a closed part (`closed_part`: a cut point with nothing of
/// the part above it is outside without its winding number), is the reference's (every
/// search over the whole part, every winding number summed), field for field: rasters at random heights, some through the part (a
/// block and a sphere half sunk into it, two overlapping closed bodies), with passes
/// plunging into it.
#[test]
fn a_closed_part_s_quick_gouge_test_gives_the_same_deviation() {
    let block = Mesh::cuboid(&Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(30.0, 30.0, 8.0))).unwrap();
    let mut soup: Vec<[Point3; 3]> =
        block.triangles().iter().map(|f| f.map(|k| block.vertices()[k as usize])).collect();
    let ball = uv_sphere(Point3::new(15.0, 15.0, 8.0), 4.0, 24);
    soup.extend(ball.triangles().iter().map(|f| f.map(|k| ball.vertices()[k as usize])));
    let part = Mesh::from_soup(&soup).unwrap();
    let r = s2g_geom::report(&part);
    assert!(r.closed && r.consistently_oriented, "{r:?}");
    let index = MeshIndex::new(&part).unwrap();
    let mut g = s2g_geom::SplitMix64::new(36, 7);
    let (mut gouged, mut columns) = (0, 0);
    for k in 0..6 {
        let cutter = if k % 2 == 0 { Cutter::ball(2.0, 20.0) } else { Cutter::flat(1.5, 20.0) };
        let mut field = HeightField::new_opt(
            [-3.0, -3.0],
            [33.0, 33.0],
            ToolTable::single(cutter),
            &HeightFieldOptions { spacing: 0.2, ..Default::default() },
        )
        .unwrap();
        raster(&mut field, [-2.0, 32.0], [-2.0, 32.0], 1.3, g.uniform(7.0, 13.0));
        for _ in 0..4 {
            let to = Point3::new(g.uniform(0.0, 30.0), g.uniform(0.0, 30.0), g.uniform(3.0, 16.0));
            field.motion(&Motion::Linear { to, feed: 500.0, extrude: None }).unwrap();
        }
        for ball_radius in [None, Some(2.0)] {
            let o = DeviationOptions { ball_radius, ..DeviationOptions::default() };
            let quick = DeviationOptions { closed_part: true, ..o };
            let all = |_: &Point3, _: &nalgebra::Vector3<f64>| true;
            let a = surface_deviation_reference(&field, &index, &o, &all);
            assert_eq!(a, surface_deviation_opt(&field, &index, &o), "program {k}, ball {ball_radius:?}");
            assert_eq!(a, surface_deviation_opt(&field, &index, &quick), "program {k}, ball {ball_radius:?}");
            gouged += usize::from(a.gouge_depth > 0.0);
            columns += a.columns;
        }
    }
    // Both kinds of cut point are there: inside (gouges) and outside (measured columns).
    assert!(gouged >= 4, "{gouged} of 12 deviations find a gouge");
    assert!(columns > 10_000, "{columns} columns measured");
}
