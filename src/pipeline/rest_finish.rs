//! Rest finishing across setups: a setup's finisher leaves out the surface an earlier
//! setup's finisher has finished already, so that the setups' finishing passes share the
//! part's surface rather than each cover all it sees.
//!
//! The point of contact of a ball whose tip is at a cutter-location point is the part's
//! closest point to the ball's centre, and the direction from there to the centre is the
//! surface's normal at it. An earlier setup finished that point when its ball reaches it:
//! the normal leans towards its tool axis within its strategy's slope limit (a parallel
//! raster keeps the scallop height only on gentle slopes; waterline passes take the steep
//! ones), its ball touching there (centre one radius out along the normal) is clear of the
//! part and is where that ball lowered along its axis stops (a concave corner tighter than
//! it, or a point under an overhang, is not reached; the drop-cutter decides), and lies
//! above its finisher's floor (the depth its tool reaches).

use super::job::Job;
use crate::geom::{Cutter, DropCutter, Mesh, MeshIndex, Point3, Setup, Vector3};
use crate::policy::FinishStrategyKind;
use crate::toolpath::finish::{KeepPoint, part_in_setup_frame};

/// What an earlier setup's finisher finished.
struct Earlier {
    setup: Setup,
    /// The part in its frame, for its ball's drop-cutter.
    index: MeshIndex,
    /// Its tool axis, in the part frame.
    axis: Vector3,
    radius: f64,
    /// Lowest tip height finished, in its frame.
    floor: f64,
    /// The least cosine between the surface's normal and the axis where its strategy
    /// keeps the scallop height.
    min_cos: f64,
}

/// The points of a setup's finishing that no earlier setup finished ([`KeepPoint`]).
pub(super) struct Unfinished {
    /// The part, in the part frame.
    part: MeshIndex,
    /// The setup being finished, and its ball's radius.
    setup: Setup,
    radius: f64,
    earlier: Vec<Earlier>,
}

/// The least cosine between the surface normal and the tool axis where `kind` finishes to
/// the scallop height: a parallel raster's stepover is set for flat ground, and on a slope
/// `a` its passes lie `1 / cos a` farther apart along the surface, the scallop growing
/// about as `1 / cos^2 a` (50 degrees: 2.4 times); waterline passes are spaced for the
/// steep walls, and steep-and-shallow takes every slope.
fn min_cos(kind: FinishStrategyKind) -> f64 {
    match kind {
        FinishStrategyKind::Parallel => 50f64.to_radians().cos(),
        FinishStrategyKind::Waterline | FinishStrategyKind::SteepShallow | FinishStrategyKind::Crossed => {
            85f64.to_radians().cos()
        }
    }
}

impl Unfinished {
    /// Setup `jobs[i]`'s finishing, after the finishers of `jobs[..i]`; `None` when no
    /// earlier setup was finished.
    pub(super) fn new(part: &Mesh, jobs: &[Job], i: usize) -> Result<Option<Self>, crate::geom::GeomError> {
        let Some(current) = jobs.get(i).and_then(|j| j.finish.as_ref().map(|f| (j, f))) else {
            return Ok(None);
        };
        let earlier: Vec<Earlier> = jobs[..i]
            .iter()
            .filter_map(|job| {
                let f = job.finish.as_ref()?;
                let zs = part.vertices().iter().map(|v| job.setup.to_setup(v).z);
                let (lo, hi) = zs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), z| (a.min(z), b.max(z)));
                let floor = job.finish_options(f, [lo, hi]).floor.unwrap_or(lo);
                let axis = job.setup.tool_axis().into_inner();
                Some(Earlier {
                    index: MeshIndex::new(&part_in_setup_frame(part, &job.setup)).ok()?,
                    setup: job.setup,
                    axis,
                    radius: f.tool.radius(),
                    floor,
                    min_cos: min_cos(f.choice.strategy),
                })
            })
            .collect();
        if earlier.is_empty() {
            return Ok(None);
        }
        Ok(Some(Self {
            part: MeshIndex::new(part)?,
            setup: current.0.setup,
            radius: current.1.tool.radius(),
            earlier,
        }))
    }

    /// Whether an earlier setup finished the surface where the ball at `c` (its centre,
    /// part frame) touches it.
    fn finished(&self, c: &Point3) -> bool {
        let contact = self.part.closest_point(c);
        if contact.distance.is_nan() || contact.distance <= 1e-9 {
            return false;
        }
        let q = contact.point;
        let n = (c - q) / contact.distance;
        self.earlier.iter().any(|e| {
            if n.dot(&e.axis) < e.min_cos {
                return false;
            }
            let centre = e.setup.to_setup(&(q + n * e.radius));
            if centre.z - e.radius < e.floor {
                return false;
            }
            // Its ball, lowered along its axis over that centre, stops there.
            let Ok(dc) = DropCutter::new(&e.index, &Cutter::ball(e.radius, 4.0 * e.radius)) else {
                return false;
            };
            // (`stops_at_most`: the same answer as comparing `height`, searched from just below.)
            dc.stops_at_most(centre.x, centre.y, centre.z - e.radius + 1e-3 * e.radius, 3e-3 * e.radius)
        })
    }
}

impl Unfinished {
    /// Whether no earlier setup finished the surface point `q` of outward normal `n` (both
    /// in this setup's frame), which this setup's ball touches with its centre at
    /// `q + radius n`.
    pub(super) fn keeps_contact(&self, q: &Point3, n: &Vector3) -> bool {
        !self.finished(&self.setup.to_part(&(q + n * self.radius)))
    }
}

impl KeepPoint for Unfinished {
    fn keep(&self, tip: &Point3) -> bool {
        let centre = self.setup.to_part(&Point3::new(tip.x, tip.y, tip.z + self.radius));
        !self.finished(&centre)
    }
}
