//! The action space of seed 000 §3.5 and the policies that choose in it.
//!
//! An [`Action`] is one setup's machining parameters: tool radius, layer height and
//! clearing strategy (contour always runs). A [`Policy`] picks one action per setup
//! from what it knows of the setup; the learned DQN policy plugs in here too.

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// A clearing strategy of the toolpath registry ([`s2g_toolpath::strategies`]) as the
/// policy's action vocabulary: its place in the registry, so the action space's strategies
/// are the registry's, in its order (seed 000 §3.3.2-3.3.4 names the first three). A
/// strategy added to the registry is an action the policies can choose with no change here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StrategyKind(u8);

impl StrategyKind {
    /// Parallel back-and-forth passes (`zigzag`).
    pub const ZIGZAG: StrategyKind = StrategyKind(0);
    /// Rings offset inward from the boundary (`periphery`).
    pub const PERIPHERY: StrategyKind = StrategyKind(1);
    /// One continuous spiral (`spiral`).
    pub const SPIRAL: StrategyKind = StrategyKind(2);

    /// Every strategy of the registry, in its order.
    pub fn all() -> Vec<StrategyKind> {
        (0..s2g_toolpath::strategies().len().min(256)).map(|i| StrategyKind(i as u8)).collect()
    }

    /// The registry's name of the strategy (`zigzag`, `periphery`, `spiral`, ...).
    pub fn name(self) -> &'static str {
        s2g_toolpath::strategies().names().nth(self.0 as usize).unwrap_or("zigzag")
    }

    /// The strategy the registry knows by `name` (any case).
    pub fn from_name(name: &str) -> Option<Self> {
        let i = s2g_toolpath::strategies().names().position(|n| n.eq_ignore_ascii_case(name))?;
        u8::try_from(i).ok().map(StrategyKind)
    }
}

/// One setup's machining parameters, in the units of the part being planned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Action {
    /// Tool radius.
    pub tool_radius: f64,
    /// Layer height (depth of cut per layer).
    pub layer_height: f64,
    /// Clearing strategy run after the contour of each layer.
    pub strategy: StrategyKind,
}

/// A discrete action space: every combination of its radii, layer heights and strategies.
#[derive(Debug, Clone, PartialEq)]
pub struct ActionSpace {
    /// Tool radii, ascending.
    pub radii: Vec<f64>,
    /// Layer heights, ascending.
    pub layer_heights: Vec<f64>,
    /// Clearing strategies.
    pub strategies: Vec<StrategyKind>,
}

impl ActionSpace {
    /// The paper's space in normalised units (the part's max extent is 1): tool radius
    /// 0.001-0.01 and layer height 1/512-1/64 (seed 000 §3.5), all three strategies.
    pub fn paper() -> Self {
        Self {
            radii: vec![0.001, 0.0025, 0.005, 0.01],
            layer_heights: vec![1.0 / 512.0, 1.0 / 256.0, 1.0 / 128.0, 1.0 / 64.0],
            strategies: StrategyKind::all(),
        }
    }

    /// The paper's space as its own 256³ grid sees it, on a grid of `resolution`³: every
    /// length multiplied by [`paper_space_scale`](Self::paper_space_scale)`(resolution)`.
    /// On 64³ the radii are 0.256-2.56 voxels and the layers 0.5-4, where the paper's
    /// space gives 0.06-0.64 and 0.13-1: no tool of it is resolved there.
    pub fn paper_at_resolution(resolution: usize) -> Self {
        Self::paper().scaled(Self::paper_space_scale(resolution))
    }

    /// `256 / resolution` (1 for a resolution of 0): the factor of
    /// [`paper_at_resolution`](Self::paper_at_resolution), the value of
    /// `MillOptions::paper_space_scale` (`--space grid`) that gives it.
    pub fn paper_space_scale(resolution: usize) -> f64 {
        if resolution == 0 { 1.0 } else { 256.0 / resolution as f64 }
    }

    /// A shop tool library in millimetres: end mills of 1-12 mm diameter and depths of
    /// cut of 0.25-2 mm.
    pub fn shop() -> Self {
        Self {
            radii: vec![0.5, 1.0, 1.5, 3.0, 6.0],
            layer_heights: vec![0.25, 0.5, 1.0, 2.0],
            strategies: StrategyKind::all(),
        }
    }

    /// The space with every length multiplied by `k` (e.g. normalised units to mm).
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            radii: self.radii.iter().map(|r| r * k).collect(),
            layer_heights: self.layer_heights.iter().map(|h| h * k).collect(),
            strategies: self.strategies.clone(),
        }
    }

    /// Number of actions.
    pub fn len(&self) -> usize {
        self.radii.len() * self.layer_heights.len() * self.strategies.len()
    }

    /// Whether the space has no action.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The action with index `i` (radius slowest, strategy fastest); `None` out of range.
    pub fn action(&self, i: usize) -> Option<Action> {
        if i >= self.len() {
            return None;
        }
        let ns = self.strategies.len();
        let nh = self.layer_heights.len();
        Some(Action {
            tool_radius: self.radii[i / (ns * nh)],
            layer_height: self.layer_heights[(i / ns) % nh],
            strategy: self.strategies[i % ns],
        })
    }

    /// The index of an action of this space (exact match), if any.
    pub fn index_of(&self, a: &Action) -> Option<usize> {
        let r = self.radii.iter().position(|&r| r == a.tool_radius)?;
        let h = self.layer_heights.iter().position(|&h| h == a.layer_height)?;
        let s = self.strategies.iter().position(|&s| s == a.strategy)?;
        Some((r * self.layer_heights.len() + h) * self.strategies.len() + s)
    }
}

/// What a policy may look at when it chooses a setup's action.
#[derive(Debug, Clone, Copy)]
pub struct SetupContext<'a> {
    /// Index of the setup in machining order.
    pub index: usize,
    /// Number of setups of the part.
    pub setups: usize,
    /// The action space to choose from.
    pub space: &'a ActionSpace,
    /// Geometric features of the setup (see [`SetupFeatures`]).
    pub features: &'a SetupFeatures,
    /// The run's finishing choice when the setup is finished whole after roughing
    /// ([`MillOptions::finish`](crate::MillOptions::finish)); `None` when it is roughed
    /// only, or its finisher takes only its few sculpted faces (the roughing leaves the
    /// rest as without finishing). A roughing that a finisher follows whole need not
    /// leave a fine staircase.
    pub finishing: Option<FinishChoice>,
}

/// The finishing strategies a policy chooses among (the toolpath crate's
/// [`FinishingStrategy`](s2g_toolpath::finish::FinishingStrategy) implementations).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FinishStrategyKind {
    /// Parallel (raster) passes over the drop-cutter surface.
    Parallel,
    /// Constant-Z contours of the cutter-location surface.
    Waterline,
    /// Waterline on steep regions, parallel on shallow ones.
    SteepShallow,
    /// Parallel passes in two directions, each where it spaces the surface tighter.
    Crossed,
}

impl FinishStrategyKind {
    /// Every kind, in order.
    pub const ALL: [FinishStrategyKind; 4] =
        [Self::Parallel, Self::Waterline, Self::SteepShallow, Self::Crossed];

    /// The name the CLI takes (`parallel`, `waterline`, `steep-shallow`, `crossed`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Parallel => "parallel",
            Self::Waterline => "waterline",
            Self::SteepShallow => "steep-shallow",
            Self::Crossed => "crossed",
        }
    }

    /// The kind named `name` (any case).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name().eq_ignore_ascii_case(name))
    }

    /// The toolpath crate's strategy of this kind, with its default options.
    pub fn strategy(self) -> Box<dyn s2g_toolpath::finish::FinishingStrategy> {
        use s2g_toolpath::finish::{Crossed, Parallel, SteepShallow, Waterline};
        match self {
            Self::Parallel => Box::new(Parallel::default()),
            Self::Waterline => Box::new(Waterline::default()),
            Self::SteepShallow => Box::new(SteepShallow::default()),
            Self::Crossed => Box::new(Crossed::default()),
        }
    }
}

/// How a setup is finished after roughing: the choices a policy may make (the learning
/// work can choose them later; today the run's options give them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinishChoice {
    /// Tool number of the finishing tool in the library; `None` (default): the pipeline's
    /// rule (the largest ball end mill no wider than the roughing tool that reaches the
    /// setup's depth; where none reaches, the one that reaches deepest).
    pub tool: Option<u32>,
    /// Scallop height allowed between passes, in part units (mm). Default 0.01.
    pub scallop: f64,
    /// Finishing strategy. Default [`FinishStrategyKind::Crossed`]: on the bunny at
    /// 100 mm it keeps the scallop on steep walls, which a single raster leaves up to
    /// 0.3 mm apart (99 % of the finished surface within 0.015 mm, against 0.041 mm with
    /// parallel), in 60 % of steep-and-shallow's time.
    pub strategy: FinishStrategyKind,
}

impl Default for FinishChoice {
    fn default() -> Self {
        Self { tool: None, scallop: 0.01, strategy: FinishStrategyKind::Crossed }
    }
}

/// Cheap geometric facts about one setup's manufacturable shape, for the heuristic
/// policy and as the learned policy's encoder input.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SetupFeatures {
    /// For each radius of the action space, the fraction of the setup's visible surface
    /// samples that a ball of that radius can touch (1 = the radius loses nothing).
    pub reach_by_radius: Vec<f64>,
    /// For each radius of the action space, the fraction of the setup's visible surface
    /// samples that a ball of that radius reaches to within half a voxel of the simulation
    /// grid ([`voxel`](Self::voxel); or 2 % of the radius, as `reach_by_radius`, if that is
    /// more): the material it leaves at the others is thinner than the simulated part can
    /// show. Empty when not computed (features read from an older
    /// outcome file).
    #[serde(default)]
    pub reach_at_resolution: Vec<f64>,
    /// Depth of the setup (extent along the tool axis), part units.
    pub depth: f64,
    /// Fraction of the stock volume this setup still has to remove.
    pub removal_fraction: f64,
    /// Edge length of the simulation's voxels, part units: detail finer than this is
    /// not seen by the score.
    pub voxel: f64,
    /// Fraction of the part's surface samples visible from the setup's tool axis.
    pub visible_fraction: f64,
    /// Where the visible surface lies along the tool axis: a histogram of
    /// [`DEPTH_BINS`](Self::DEPTH_BINS) bins from the stock's top (bin 0) to its bottom,
    /// summing to 1 (all zero when nothing is visible). Deep pockets need long tools and
    /// many layers; a shallow face needs few.
    pub depth_histogram: Vec<f64>,
    /// The visible surface samples in the setup frame (tool axis +Z), divided by the
    /// stock's largest extent, at most [`MAX_POINTS`](Self::MAX_POINTS): the point
    /// cloud a learned shape encoder reads.
    pub points: Vec<[f32; 3]>,
}

impl SetupFeatures {
    /// Bins of [`depth_histogram`](Self::depth_histogram).
    pub const DEPTH_BINS: usize = 8;
    /// Most points kept in [`points`](Self::points).
    pub const MAX_POINTS: usize = 1024;
}

/// Chooses an action for each setup.
pub trait Policy {
    /// The action for the setup described by `ctx`.
    fn choose(&mut self, ctx: &SetupContext<'_>) -> Action;

    /// A short name for reports (`fixed`, `random`, `heuristic`, ...).
    fn name(&self) -> String;

    /// The finishing choice for the setup described by `ctx`, given the run's
    /// `default` (provided: `default` unchanged).
    fn finish(&mut self, ctx: &SetupContext<'_>, default: FinishChoice) -> FinishChoice {
        let _ = ctx;
        default
    }
}

/// Always the same action.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixedPolicy(pub Action);

impl Policy for FixedPolicy {
    fn choose(&mut self, _: &SetupContext<'_>) -> Action {
        self.0
    }
    fn name(&self) -> String {
        format!("fixed:{},{},{}", self.0.tool_radius, self.0.layer_height, self.0.strategy.name())
    }
}

/// Uniformly random actions from a seeded generator (the paper's "Random" row of Table 3).
#[derive(Debug)]
pub struct RandomPolicy {
    rng: StdRng,
}

impl RandomPolicy {
    /// A random policy with the given seed.
    pub fn new(seed: u64) -> Self {
        Self { rng: StdRng::seed_from_u64(seed) }
    }
}

impl Policy for RandomPolicy {
    fn choose(&mut self, ctx: &SetupContext<'_>) -> Action {
        let i = self.rng.random_range(0..ctx.space.len().max(1));
        ctx.space.action(i).unwrap_or(Action {
            tool_radius: 0.0,
            layer_height: 0.0,
            strategy: StrategyKind::ZIGZAG,
        })
    }
    fn name(&self) -> String {
        "random".into()
    }
}

/// A geometric heuristic: the largest tool that still reaches (almost) every visible
/// surface point of the setup to within half a voxel of the simulation grid
/// ([`SetupFeatures::reach_at_resolution`]: material thinner than that is not seen by the
/// score, and a larger tool cuts the same shape in less time), the finest layer height not below the simulation's voxel
/// size (finer layers change nothing the score can see), and zigzag clearing (the
/// shortest paths on open stock).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeuristicPolicy {
    /// A radius is acceptable when it reaches at least this fraction of what the
    /// smallest radius reaches. Default 0.985.
    pub reach_ratio: f64,
}

impl Default for HeuristicPolicy {
    fn default() -> Self {
        Self { reach_ratio: 0.985 }
    }
}

impl Policy for HeuristicPolicy {
    fn choose(&mut self, ctx: &SetupContext<'_>) -> Action {
        let space = ctx.space;
        let f = ctx.features;
        let reach =
            if f.reach_at_resolution.is_empty() { &f.reach_by_radius } else { &f.reach_at_resolution };
        let best = reach.first().copied().unwrap_or(1.0);
        let radius_index = (0..space.radii.len())
            .rev()
            .find(|&i| reach.get(i).is_some_and(|&r| r >= self.reach_ratio * best))
            .unwrap_or(0);
        // A finisher follows: the roughing's staircase is its to remove, so the roughing
        // takes the deepest layers of the space; else the finest the grid can see.
        let layer_height = space
            .layer_heights
            .iter()
            .copied()
            .find(|&h| ctx.finishing.is_none() && h >= ctx.features.voxel * (1.0 - 1e-9))
            .or_else(|| space.layer_heights.last().copied())
            .unwrap_or(ctx.features.voxel);
        Action {
            tool_radius: space.radii.get(radius_index).copied().unwrap_or(0.0),
            layer_height,
            strategy: space.strategies.first().copied().unwrap_or(StrategyKind::ZIGZAG),
        }
    }
    fn name(&self) -> String {
        "heuristic".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The policy's strategies are the toolpath registry's, by name and in its order, so
    /// every action's strategy plans (the pipeline looks the name up there).
    #[test]
    fn strategy_kinds_are_the_registry_s_strategies_in_order() {
        let names: Vec<&str> = StrategyKind::all().iter().map(|s| s.name()).collect();
        assert_eq!(names, s2g_toolpath::strategies().names().collect::<Vec<_>>());
        assert_eq!(names[..3], ["zigzag", "periphery", "spiral"]);
        let consts = [StrategyKind::ZIGZAG, StrategyKind::PERIPHERY, StrategyKind::SPIRAL];
        assert_eq!(consts.map(|s| s.name()), ["zigzag", "periphery", "spiral"]);
        assert_eq!(StrategyKind::from_name("Spiral"), Some(StrategyKind::SPIRAL));
        assert_eq!(StrategyKind::from_name("trochoidal"), None);
        for s in StrategyKind::all() {
            assert_eq!(
                s2g_toolpath::strategies().get(s.name()).map(|c| c.name().to_owned()),
                Ok(s.name().into())
            );
        }
    }

    #[test]
    fn action_indices_round_trip() {
        for space in [ActionSpace::paper(), ActionSpace::shop()] {
            for i in 0..space.len() {
                let a = space.action(i).unwrap();
                assert_eq!(space.index_of(&a), Some(i), "action {i} of {space:?}");
            }
            assert_eq!(space.action(space.len()), None);
        }
    }

    #[test]
    fn heuristic_takes_the_largest_radius_that_keeps_reach() {
        let space = ActionSpace::paper();
        let features = SetupFeatures {
            reach_by_radius: vec![0.99, 0.989, 0.95, 0.90],
            voxel: 1.0 / 256.0,
            ..Default::default()
        };
        let ctx = SetupContext { index: 0, setups: 1, space: &space, features: &features, finishing: None };
        let a = HeuristicPolicy::default().choose(&ctx);
        assert_eq!(a.tool_radius, 0.0025, "0.95 / 0.99 is below the 0.985 ratio");
        assert_eq!(a.layer_height, 1.0 / 256.0);

        // Reach to within half a voxel, where known, decides instead.
        let radius = |reach_at_resolution: Vec<f64>| {
            let f = SetupFeatures { reach_at_resolution, ..features.clone() };
            HeuristicPolicy::default()
                .choose(&SetupContext { index: 0, setups: 1, space: &space, features: &f, finishing: None })
                .tool_radius
        };
        assert_eq!(radius(vec![0.995, 0.995, 0.99, 0.985]), 0.01, "0.985 / 0.995 keeps the ratio");
        assert_eq!(radius(vec![0.995, 0.99, 0.97, 0.9]), 0.0025);
    }

    #[test]
    fn random_policy_is_reproducible() {
        let space = ActionSpace::paper();
        let f = SetupFeatures::default();
        let ctx = SetupContext { index: 0, setups: 1, space: &space, features: &f, finishing: None };
        let mut a = RandomPolicy::new(7);
        let mut b = RandomPolicy::new(7);
        for _ in 0..20 {
            assert_eq!(a.choose(&ctx), b.choose(&ctx));
        }
    }
}
