//! The tool-aware reach of orientation selection (issue 35): a narrow feature is reached
//! from an axis only as deep as a tool that fits it cuts.

use s2g_geom::{Aabb, Mesh, MeshIndex, Point3, SurfaceSamples, UnitVector3, Vector3};
use s2g_orient::{ReachTool, ToolReach, VisibilityContext, VisibilityOptions, ball_clearance};

fn tool(radius: f64, depth: f64) -> ReachTool {
    ReachTool { radius, depth }
}

/// Boxes as one triangle soup (visibility and closest points need no manifold).
fn boxes(list: &[([f64; 3], [f64; 3])]) -> Mesh {
    let mut mesh = Mesh::cuboid(&Aabb::new(Point3::from(list[0].0), Point3::from(list[0].1))).unwrap();
    for (lo, hi) in &list[1..] {
        mesh.append(&Mesh::cuboid(&Aabb::new(Point3::from(*lo), Point3::from(*hi))).unwrap());
    }
    mesh
}

/// Hand-placed samples: (point, outward normal).
fn samples(list: &[([f64; 3], [f64; 3])]) -> SurfaceSamples {
    SurfaceSamples {
        points: list.iter().map(|(p, _)| Point3::from(*p)).collect(),
        normals: list.iter().map(|(_, n)| Vector3::from(*n)).collect(),
        triangles: Vec::new(),
    }
}

#[test]
fn only_the_tools_reaching_deeper_than_every_narrower_one_count() {
    let stock = Aabb::new(Point3::origin(), Point3::new(10.0, 10.0, 40.0));
    // A library's flat end mills: 3 mm reaching 21 is no use beside a 2 mm one reaching 25.
    let lib = [
        tool(3.0, 36.0),
        tool(1.5, 21.0),
        tool(0.5, 10.0),
        tool(1.0, 25.0),
        tool(2.5, 31.0),
        tool(6.0, 66.0),
    ];
    let r = ToolReach::of_tools(stock, &lib).unwrap();
    let radii: Vec<f64> = r.tools().iter().map(|t| t.radius).collect();
    assert_eq!(radii, [0.5, 1.0, 2.5, 3.0, 6.0]);
    assert_eq!(r.depth, 66.0);
    // The gap a sample has in front of it picks the deepest tool narrower than it.
    assert_eq!(r.depth_within(f64::INFINITY), 66.0);
    assert_eq!(r.depth_within(6.0), 31.0, "a 6 mm hole takes the 5 mm end mill, not the 6 mm one");
    assert_eq!(r.depth_within(6.01), 36.0);
    assert_eq!(r.depth_within(2.5), 25.0);
    assert_eq!(r.depth_within(1.5), 10.0);
    assert_eq!(r.depth_within(1.0), f64::NEG_INFINITY, "no tool fits");
    // The narrowest tool that reaches a depth.
    assert_eq!(r.narrowest_reaching(5.0), Some(0.5));
    assert_eq!(r.narrowest_reaching(30.0), Some(2.5));
    assert_eq!(r.narrowest_reaching(70.0), None);
    // Without tools, every width reaches the one depth.
    let plain = ToolReach::new(stock, 20.0);
    assert!(plain.tools().is_empty());
    assert_eq!(plain.depth_within(0.1), 20.0);
    // Unusable tools are left out; none left, no reach.
    assert!(ToolReach::of_tools(stock, &[tool(0.0, 5.0), tool(1.0, -1.0), tool(f64::NAN, 3.0)]).is_none());
    // Past the limit the narrowest and the deepest are kept: less reach, never more.
    let many: Vec<ReachTool> = (1..=40).map(|i| tool(i as f64 * 0.1, i as f64)).collect();
    let thinned = ToolReach::of_tools(stock, &many).unwrap();
    assert_eq!(thinned.tools().len(), s2g_orient::REACH_TOOLS);
    assert_eq!(thinned.depth, 40.0);
    for w in [0.5, 2.0, 3.5, 8.1] {
        let exact =
            many.iter().filter(|t| 2.0 * t.radius < w).map(|t| t.depth).fold(f64::NEG_INFINITY, f64::max);
        assert!(thinned.depth_within(w) <= exact, "width {w}");
    }
}

/// The largest ball tangent at a sample: half a slot's width on its wall, the height above
/// the floor beside it, the cap in the open.
#[test]
fn the_ball_clearance_is_the_room_in_front_of_a_sample() {
    // A 6 mm slot between two blocks on a floor.
    let mesh = boxes(&[
        ([0.0, 0.0, 0.0], [20.0, 20.0, 2.0]),
        ([0.0, 0.0, 2.0], [7.0, 20.0, 20.0]),
        ([13.0, 0.0, 2.0], [20.0, 20.0, 20.0]),
    ]);
    let index = MeshIndex::new(&mesh).unwrap();
    let x = Vector3::x();
    let (mid, _) = ball_clearance(&index, &Point3::new(7.0, 10.0, 12.0), &x, 10.0, 1e-6);
    assert!((mid - 3.0).abs() < 1e-3, "{mid}");
    let (low, away) = ball_clearance(&index, &Point3::new(7.0, 10.0, 2.8), &x, 10.0, 1e-6);
    assert!((low - 0.8).abs() < 0.05, "{low}");
    // From the floor's point the ball touches, at 45 degrees below the sample.
    assert!(away.z > 0.6 && away.x < -0.6, "away from the floor: {away:?}");
    let (open, _) = ball_clearance(&index, &Point3::new(20.0, 10.0, 12.0), &x, 4.0, 1e-6);
    assert_eq!(open, 4.0);
}

/// A plate 10 mm thick with a 6 mm square hole, under a stock 40 mm tall (a tall boss
/// elsewhere), and a library of a 5 mm end mill reaching 31 mm and a 12 mm one reaching
/// 66: from +Z the hole's walls are reached only above 9 mm (the 5 mm tool's reach),
/// however deep the wide tool reaches beside them; from -Z all the way; a wall sample
/// beside the hole's square corner by none of them; a floor beside a wall by a flat
/// bottom whose side runs along the wall.
#[test]
fn a_narrow_hole_is_reached_only_as_deep_as_a_tool_that_fits_it() {
    let mesh = boxes(&[
        ([0.0, 0.0, 0.0], [17.0, 40.0, 10.0]),
        ([23.0, 0.0, 0.0], [40.0, 40.0, 10.0]),
        ([17.0, 0.0, 0.0], [23.0, 17.0, 10.0]),
        ([17.0, 23.0, 0.0], [23.0, 40.0, 10.0]),
    ]);
    let index = MeshIndex::new(&mesh).unwrap();
    let stock = Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(40.0, 40.0, 40.0));
    let probes = samples(&[
        ([17.0, 20.0, 9.5], [1.0, 0.0, 0.0]), // 0: the hole's wall, 30.5 below the top
        ([17.0, 20.0, 5.0], [1.0, 0.0, 0.0]), // 1: 35 below the top, 5 above the bottom
        ([17.0, 17.2, 9.5], [1.0, 0.0, 0.0]), // 2: 0.2 mm from the hole's corner
        ([30.0, 20.0, 10.0], [0.0, 0.0, 1.0]), // 3: the plate's top, in the open
    ]);
    let flat = |reach| VisibilityOptions { min_cos: -0.01, reach: Some(reach), ..Default::default() };
    let single = ToolReach::new(stock, 66.0);
    let aware = ToolReach::of_tools(stock, &[tool(2.5, 31.0), tool(6.0, 66.0)]).unwrap();
    let plain = VisibilityContext::new(&mesh, &index, &probes, &flat(single)).unwrap();
    let tools = VisibilityContext::new(&mesh, &index, &probes, &flat(aware)).unwrap();
    let up = UnitVector3::new_normalize(Vector3::z());
    let down = UnitVector3::new_normalize(-Vector3::z());
    // One depth for every width: the whole wall from +Z.
    assert!((0..4).all(|i| plain.visible(i, &up)), "the single reach sees every sample");
    assert_eq!(tools.sample_depth(0), Some(31.0), "the 6 mm gap takes the 5 mm tool");
    assert_eq!(tools.sample_depth(3), Some(66.0));
    assert!(tools.visible(0, &up), "within the 5 mm tool's reach");
    assert!(!tools.visible(1, &up), "below it");
    assert!(tools.visible(1, &down), "from below the hole is 5 mm deep");
    assert!(!tools.visible(2, &up) && !tools.visible(2, &down), "a square corner takes no round tool");
    assert!(tools.visible(3, &up));

    // A pocket 30 mm deep: its floor 0.5 mm from a wall is reached by the 5 mm tool's
    // bottom, its side along the wall, though no ball of its radius fits there.
    let pocket = boxes(&[
        ([0.0, 0.0, 0.0], [40.0, 40.0, 10.0]),
        ([0.0, 0.0, 10.0], [10.0, 40.0, 40.0]),
        ([30.0, 0.0, 10.0], [40.0, 40.0, 40.0]),
    ]);
    let pocket_index = MeshIndex::new(&pocket).unwrap();
    let floor = samples(&[([10.5, 20.0, 10.0], [0.0, 0.0, 1.0])]);
    let ctx = VisibilityContext::new(&pocket, &pocket_index, &floor, &flat(aware)).unwrap();
    assert!(ctx.visible(0, &up));
    let ball_only = VisibilityOptions { tool_radius: Some(2.5), min_cos: -0.01, ..Default::default() };
    let ball = VisibilityContext::new(&pocket, &pocket_index, &floor, &ball_only).unwrap();
    assert!(!ball.visible(0, &up), "a 2.5 mm ball does not touch the floor 0.5 mm from the wall");
}

/// A plate 20 mm thick whose top has a fold along y: a V 70 degrees across (its walls 35
/// degrees off the vertical, its apex at z = 8 below x = 20) with a 2 mm fillet at its
/// bottom, over a body below it. Returns it and the fillet's bottom.
fn folded_plate() -> (Mesh, Point3) {
    let (alpha, fillet, apex, top): (f64, f64, f64, f64) = (35f64.to_radians(), 2.0, 8.0, 20.0);
    let centre = (20.0, apex + fillet / alpha.sin());
    let edge = (top - apex) * alpha.tan();
    let mut profile = vec![(0.0, top), (20.0 - edge, top)];
    // An odd number of facets: a flat one at the bottom, whose middle is the sample.
    let step = (std::f64::consts::PI - 2.0 * alpha) / 15.0;
    for k in 0..=15 {
        let phi = -std::f64::consts::PI + alpha + step * k as f64;
        profile.push((centre.0 + fillet * phi.cos(), centre.1 + fillet * phi.sin()));
    }
    profile.extend([(20.0 + edge, top), (40.0, top)]);
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for (x, z) in &profile {
        vertices.push(Point3::new(*x, 0.0, *z));
        vertices.push(Point3::new(*x, 40.0, *z));
    }
    for i in 0..profile.len() as u32 - 1 {
        let (a, b, c, d) = (2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1);
        triangles.push([a, b, c]);
        triangles.push([a, c, d]);
    }
    let mut mesh = Mesh::new(vertices, triangles).unwrap();
    let bottom = centre.1 - fillet * (0.5 * step).cos();
    mesh.append(&boxes(&[([0.0, 0.0, 0.0], [40.0, 40.0, bottom - 1.0])]));
    (mesh, Point3::new(20.0, 20.0, bottom))
}

/// A round tool wider than an open concave fold leaves a skin in it: the fold counts
/// as reached from above by the tool reaching its depth (issue 36, the bunny's creases);
/// a blind hole narrower than that tool, deeper than 1.5 times its radius, still does not.
#[test]
fn an_open_fold_narrower_than_the_tool_is_reached_and_a_narrow_blind_hole_is_not() {
    let stock = Aabb::new(Point3::origin(), Point3::new(40.0, 40.0, 40.0));
    // A 2 mm tool reaching 10 mm below the stock's top, a 12 mm one reaching 66.
    let aware = ToolReach::of_tools(stock, &[tool(1.0, 10.0), tool(6.0, 66.0)]).unwrap().with_slack(0.1);
    let opts = VisibilityOptions { min_cos: -0.01, reach: Some(aware), ..Default::default() };
    let up = UnitVector3::new_normalize(Vector3::z());

    let (fold, bottom) = folded_plate();
    let fold_index = MeshIndex::new(&fold).unwrap();
    let (room, _) = ball_clearance(&fold_index, &bottom, &Vector3::z(), 6.0, 1e-6);
    assert!((room - 2.0).abs() < 0.1, "the fold leaves the fillet's room, less than the 12 mm tool: {room}");
    let fold_samples = samples(&[(bottom.into(), [0.0, 0.0, 1.0]), ([5.0, 20.0, 20.0], [0.0, 0.0, 1.0])]);
    let ctx = VisibilityContext::new(&fold, &fold_index, &fold_samples, &opts).unwrap();
    assert!(
        ctx.visible(0, &up),
        "the fold's bottom, 30.5 mm deep: the 12 mm tool, resting on its walls, stops 3.0 mm above it, within half its radius"
    );
    assert!(ctx.visible(1, &up));

    // A 4 mm square blind hole 10 mm deep in a plate 12 mm thick.
    let hole = boxes(&[
        ([0.0, 0.0, 0.0], [40.0, 40.0, 2.0]),
        ([0.0, 0.0, 2.0], [18.0, 40.0, 12.0]),
        ([22.0, 0.0, 2.0], [40.0, 40.0, 12.0]),
        ([18.0, 0.0, 2.0], [22.0, 18.0, 12.0]),
        ([18.0, 22.0, 2.0], [22.0, 40.0, 12.0]),
    ]);
    let hole_index = MeshIndex::new(&hole).unwrap();
    let floor = samples(&[([20.0, 20.0, 2.0], [0.0, 0.0, 1.0]), ([30.0, 20.0, 12.0], [0.0, 0.0, 1.0])]);
    let ctx = VisibilityContext::new(&hole, &hole_index, &floor, &opts).unwrap();
    assert!(!ctx.visible(0, &up), "the hole's floor: the 12 mm tool stops 9.7 mm above it");
    assert!(ctx.visible(1, &up), "the plate's top, in the open");
}

/// A tool that comes within the reach's slack of the part counts as fitting: the floor of
/// a pocket 1.9 mm wide and 4 mm deep, 0.05 mm from its wall, is reached from above by the
/// 2 mm end mill (the only one reaching 4 mm) where the slack is 0.2 mm (its flat bottom
/// against the wall, its rays cast from 0.2 mm inside its rim), not where it is 0.05 mm.
#[test]
fn a_pocket_narrower_than_the_tool_by_less_than_the_slack_is_reached() {
    let mesh = boxes(&[
        ([0.0, 0.0, 0.0], [10.0, 10.0, 5.0]),
        ([0.0, 0.0, 5.0], [4.0, 10.0, 9.0]),
        ([5.9, 0.0, 5.0], [10.0, 10.0, 9.0]),
    ]);
    let index = MeshIndex::new(&mesh).unwrap();
    let stock = Aabb::new(Point3::origin(), Point3::new(10.0, 10.0, 9.0));
    let floor = samples(&[([4.05, 5.0, 5.0], [0.0, 0.0, 1.0])]);
    let up = UnitVector3::new_normalize(Vector3::z());
    let visible = |slack: f64| {
        let reach =
            ToolReach::of_tools(stock, &[tool(1.0, 30.0), tool(6.0, 66.0)]).unwrap().with_slack(slack);
        let opts = VisibilityOptions { min_cos: -0.01, reach: Some(reach), ..Default::default() };
        VisibilityContext::new(&mesh, &index, &floor, &opts).unwrap().visible(0, &up)
    };
    assert!(visible(0.2), "1.9 mm is within 0.2 of the tool's 2 mm");
    assert!(!visible(0.05), "not within 0.05");
}
