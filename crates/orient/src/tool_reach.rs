//! The tool-aware reach of orientation selection (issue 35): how deep below the stock's
//! top a setup's tools cut ([`ToolReach`]), and, with the tools by width, how much room a
//! surface sample leaves a tool ([`sample_gaps`], [`ball_clearance`]), so that a narrow
//! feature counts as reached only as deep as a tool that fits it cuts.

use rayon::prelude::*;
use s2g_geom::{Aabb, MeshIndex, Point3, Real, Vector3};

/// The reach of a setup's tools ([`VisibilityOptions::reach`](crate::VisibilityOptions::reach)): a tool fitted in its holder
/// cuts at most `depth` below the top of the stock along its axis (the stock's highest
/// corner along the axis, as a setup's first layer starts there), so a surface deeper
/// than that is not reached from that axis, however visible. Oblique axes on a box stock
/// start at a corner, so the same depth reaches less of the part from them than from a
/// face's normal.
///
/// With its tools ([`ToolReach::of_tools`]) the reach is tool-aware: a narrow feature is
/// reached only as deep as a tool that fits it cuts. A surface sample's *gap* is the
/// free distance in front of it (the ray from the sample along its outward normal to the
/// part's surface: a hole's diameter on its wall, a slot's width on its sides, unbounded
/// on a floor open above); of the tools narrower than the gap the deepest sets how deep
/// below the stock's top the sample is reached ([`ToolReach::depth_within`]). A 6 mm bolt
/// hole beside a tall boss is thus reached from above only as deep as the 5 mm end mill's
/// holder allows, however deep the 12 mm end mill reaches beside it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolReach {
    /// The stock's box, in the part's frame.
    pub stock: Aabb,
    /// The deepest a tool cuts below the stock's top (part units).
    pub depth: Real,
    /// With tools: how near a tool must come to a sample to reach it (part units; say the
    /// simulation's half voxel), so that the thin skin a round tool leaves in a concave
    /// corner or a bowl narrower than it counts as reached. Default 0.
    pub slack: Real,
    /// The tools by width, by ascending radius and depth (the first `len`); none: every
    /// sample is reached to `depth`.
    tools: [ReachTool; REACH_TOOLS],
    len: usize,
}

/// Most tools a [`ToolReach`] tells apart.
pub const REACH_TOOLS: usize = 16;

/// One tool of a tool-aware [`ToolReach`]: its cutting radius and how deep below the
/// stock's top it cuts with its holder clear (`Tool::envelope`'s length in the toolpath
/// crate), part units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ReachTool {
    /// Cutting radius.
    pub radius: Real,
    /// Depth below the stock's top.
    pub depth: Real,
}

impl ToolReach {
    /// A reach of `depth` for every sample, whatever the width of the feature it lies in.
    pub fn new(stock: Aabb, depth: Real) -> Self {
        Self { stock, depth, slack: 0.0, tools: [ReachTool::default(); REACH_TOOLS], len: 0 }
    }

    /// The tool-aware reach of `tools` (see the type's docs): the tools that matter are
    /// kept, those reaching deeper than every narrower one (a tool no wider that reaches
    /// as deep fits wherever a wider one does); past [`REACH_TOOLS`] of them the
    /// narrowest `REACH_TOOLS - 1` and the deepest are kept (the dropped ones' widths get
    /// a narrower tool's depth: less reach, never more). `depth` is the deepest tool's.
    /// Tools without a positive, finite radius and depth are left out; `None` where none
    /// is left.
    pub fn of_tools(stock: Aabb, tools: &[ReachTool]) -> Option<Self> {
        let mut sorted: Vec<ReachTool> = tools
            .iter()
            .copied()
            .filter(|t| t.radius > 0.0 && t.depth > 0.0 && (t.radius + t.depth).is_finite())
            .collect();
        sorted.sort_by(|a, b| a.radius.total_cmp(&b.radius).then(b.depth.total_cmp(&a.depth)));
        let mut front: Vec<ReachTool> = Vec::new();
        for t in sorted {
            if front.last().is_none_or(|l| t.depth > l.depth) {
                front.push(t);
            }
        }
        if front.len() > REACH_TOOLS {
            let last = front[front.len() - 1];
            front.truncate(REACH_TOOLS - 1);
            front.push(last);
        }
        let deepest = front.last()?.depth;
        let mut reach = Self::new(stock, deepest);
        reach.tools[..front.len()].copy_from_slice(&front);
        reach.len = front.len();
        Some(reach)
    }

    /// This reach with [`slack`](Self::slack) `slack`.
    pub fn with_slack(self, slack: Real) -> Self {
        Self { slack, ..self }
    }

    /// The tools that matter, by ascending radius and depth (empty for [`ToolReach::new`]).
    pub fn tools(&self) -> &[ReachTool] {
        &self.tools[..self.len]
    }

    /// How deep below the stock's top a sample whose gap is `width` wide is reached: the
    /// depth of the deepest tool whose diameter is less than `width`, `-inf` where none
    /// is (nothing fits); [`depth`](Self::depth) without tools.
    pub fn depth_within(&self, width: Real) -> Real {
        if self.len == 0 {
            return self.depth;
        }
        self.tools()
            .iter()
            .take_while(|t| 2.0 * t.radius < width)
            .last()
            .map_or(Real::NEG_INFINITY, |t| t.depth)
    }

    /// The narrowest tool that reaches `depth` below the stock's top: its radius, `None`
    /// where none does or there are no tools.
    pub fn narrowest_reaching(&self, depth: Real) -> Option<Real> {
        self.tools().iter().find(|t| t.depth >= depth).map(|t| t.radius)
    }

    /// The stock's top along unit axis `v` (`v . x` of its highest corner).
    pub fn top(&self, v: &Vector3) -> Real {
        self.stock.corners().iter().map(|c| v.dot(&c.coords)).fold(Real::NEG_INFINITY, Real::max)
    }

    /// The lowest height along unit axis `v` (`v . x`) the tools reach: the stock's top
    /// along `v` less the depth (the deepest tool's, whatever the width).
    pub fn floor(&self, v: &Vector3) -> Real {
        self.top(v) - self.depth
    }
}

/// The free distance in front of each sample: along the ray from `p + eps n` along the
/// outward normal `n` to the part's surface (plus `eps`), `inf` where the ray leaves within
/// `2 diag` (past the part's bounding box) without meeting it. In parallel over samples.
pub fn sample_gaps(
    index: &MeshIndex,
    points: &[Point3],
    normals: &[Vector3],
    eps: Real,
    diag: Real,
) -> Vec<Real> {
    points
        .par_iter()
        .zip(normals.par_iter())
        .map(|(p, n)| {
            index.cast_ray(&(p + n * eps), n, 2.0 * diag).map_or(Real::INFINITY, |hit| hit.distance + eps)
        })
        .collect()
}

/// The radius of the largest ball tangent to the surface at `p` (outward normal `n`, the
/// ball on the free side) that holds no part, at most `cap`: the shrinking ball (the ball
/// through `p` and the part's point nearest to its centre, tangent at `p`, until that
/// point is no nearer than the radius, within `eps`); 0 where it shrinks below `eps`. With
/// it, the unit direction from the last point that shrank the ball to `p` (zero where none
/// did).
pub fn ball_clearance(index: &MeshIndex, p: &Point3, n: &Vector3, cap: Real, eps: Real) -> (Real, Vector3) {
    let mut rho = cap;
    let mut away = Vector3::zeros();
    for _ in 0..16 {
        if rho.is_nan() || rho <= eps {
            return (0.0, away);
        }
        let q = index.closest_point(&(p + n * rho));
        if q.distance >= rho - eps {
            return (rho, away);
        }
        let d = q.point - p;
        away = (-d).try_normalize(1e-12).unwrap_or(away);
        let along = 2.0 * n.dot(&d);
        let next = if along > 0.0 { d.norm_squared() / along } else { 0.0 };
        // The ball through `p` and `q` tangent at `p` is smaller; guard against no progress.
        rho = if next < rho { next } else { q.distance.min(rho) * 0.5 };
    }
    (rho, away)
}
