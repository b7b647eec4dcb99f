//! Rapids down to the level above (issue 35): a layer's entry goes down by rapid to just
//! above the previous level, which is safe only if every level above cleared all material
//! within the tool's radius around the entry point, so the levels' free regions must nest.
//! The part is OpenSCAD's example004 in millimetres (a 30 mm cube less a ball of radius 20,
//! the cavity open through all six faces), seen from an oblique direction as the shop
//! preset chose it: below the cavity's rim every level's keep-out has the same wall, and
//! each level's offset of it had chords of its own, so an entry's tool reached a few
//! micrometres past the upper level's cut into the skin it left on the wall.

use s2g_gcode::{Motion, MotionSink};
use s2g_geom::{Aabb, GridSpec, Mesh, Setup, UnitVector3, Vector3, VoxelGrid, load_mesh, voxelize};
use s2g_toolpath::{LayerPlan, PlanOptions, Tool, plan_layers, plan_setup};
use s2g_voxsim::{Cutter, SimOptions, Simulator, ToolTable};

fn example004() -> Mesh {
    let p = format!(
        "{}/../../tests/data/meshes/openscad/openscad_Old_example004.stl",
        env!("CARGO_MANIFEST_DIR")
    );
    load_mesh(&p).unwrap_or_else(|e| panic!("{p}: {e}"))
}

/// The shop preset's third setup of example004 (its tool axis), a 12 mm flat end mill,
/// 0.25 mm levels roughed 12 mm deep at half the diameter's stepover, and the stock box
/// (part frame) with the preset's 2 % margin.
fn oblique(part: &Mesh) -> (Setup, Tool, PlanOptions, Aabb) {
    let setup =
        Setup::from_direction(&UnitVector3::new_normalize(Vector3::new(0.465262, 0.702292, -0.538812)));
    let tool = Tool::flat(6.0);
    let bbox = part.bbox().expect("bbox");
    let e = bbox.extent();
    let stock = bbox.inflated(0.02 * e.x.max(e.y).max(e.z));
    let mut in_setup = Aabb::empty();
    for c in stock.corners() {
        in_setup.grow(&setup.to_setup(&c));
    }
    let opts = PlanOptions {
        layer_height: 0.25,
        roughing_depth: Some(12.0),
        stepover: 0.5,
        stock: Some(in_setup),
        nest_levels: true,
        ..PlanOptions::default()
    };
    (setup, tool, opts, stock)
}

/// Forwards motions to the simulator and counts the arcs (helical entries among them).
struct Counted<'a> {
    sim: &'a mut Simulator,
    arcs: usize,
}

impl MotionSink for Counted<'_> {
    type Error = <Simulator as MotionSink>::Error;
    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Self::Error> {
        self.arcs += usize::from(matches!(motion, Motion::Arc { .. }));
        self.sim.motion(motion)
    }
    fn source_line(&mut self, line: u64) -> Result<(), Self::Error> {
        self.sim.source_line(line)
    }
    fn finish(&mut self) -> Result<(), Self::Error> {
        self.sim.finish()
    }
}

/// Every level's free region lies inside the free region of the level above: the premise
/// of the link's safety argument, to the boolean engine's rounding (a millionth of the
/// stock's size; the chords of two offsets of one wall differed by micrometres).
#[test]
fn the_free_regions_of_an_oblique_setup_into_a_cavity_nest() {
    let part = example004();
    let (setup, tool, opts, stock) = oblique(&part);
    let (_, layers) = plan_layers::<()>(&part, &setup, &tool, &opts, None).expect("plan");
    assert!(layers.len() > 100, "{} levels", layers.len());
    let tol = 1e-6 * stock.extent().max();
    let mut worst = (0.0, 0);
    for w in layers.windows(2) {
        let [above, below]: &[LayerPlan; 2] = w.try_into().expect("two");
        let index = above.free.index();
        for p in below.free.loops().iter().flat_map(|l| l.points.iter()) {
            if !index.contains(p) {
                let out = index.boundary_distance(p, f64::INFINITY);
                if out > worst.0 {
                    worst = (out, below.index);
                }
            }
        }
    }
    assert!(worst.0 <= tol, "level {}'s free region reaches {} mm past the level above", worst.1, worst.0);
}

/// The same setup simulated from a full stock, with straight passes and with arcs fitted
/// on the part's side at the 0.005 mm (the nested keep-outs and the arcs' exact
/// check together): no rapid removes material, no cut gouges.
#[test]
fn an_oblique_setup_into_a_cavity_rapids_through_no_material() {
    let part = example004();
    let (setup, tool, opts, stock) = oblique(&part);
    let e = stock.extent();
    let h = e.x.max(e.y).max(e.z) / 128.0;
    let dims = [0, 1, 2].map(|a| ((e[a] / h).ceil() as usize).max(1));
    let spec = GridSpec::new(&stock, dims).expect("grid");
    let target = voxelize(&part, &spec).expect("voxelize");
    let cutter = Cutter::flat(tool.radius(), 100.0);
    let mut arcs = Vec::new();
    for arc_tolerance in [None, Some(0.005)] {
        // Arcs are followed within 1/64 of a voxel, as `s2g mill` simulates them.
        let sim_opts = SimOptions { arc_tolerance: 1.0 / 1024.0, ..SimOptions::default() };
        let mut sim = Simulator::new(VoxelGrid::full(spec), ToolTable::single(cutter), sim_opts)
            .expect("simulator")
            .with_target(&target)
            .expect("same grid");
        let opts = PlanOptions { arc_tolerance, ..opts.clone() };
        let mut counted = Counted { sim: &mut sim, arcs: 0 };
        plan_setup(&part, &setup, &tool, &opts, &mut counted).expect("plan");
        arcs.push(counted.arcs);
        let (report, _) = sim.into_simulation().expect("simulation").into_parts();
        assert!(report.removed_voxels > 0, "{arc_tolerance:?}: nothing cut");
        assert_eq!(
            report.gouge_voxels, 0,
            "{arc_tolerance:?}: gouges, first at line {:?}",
            report.first_gouge_line
        );
        assert_eq!(
            report.rapid_collision_voxels, 0,
            "{arc_tolerance:?}: rapids through material at lines {:?}",
            report.rapid_collision_lines
        );
    }
    assert!(arcs[1] > 2 * arcs[0], "arcs (helical entries among them) straight and fitted: {arcs:?}");
}
