//! `s2g-toolpath`: layer toolpaths per setup (seed 000 §3.3), built exactly on 2-D regions.
//!
//! Planning happens in the setup frame, where the tool approaches from +Z
//! ([`s2g_geom::Setup`]). For each layer, from the stock top down to the lowest reachable
//! level:
//!
//! 1. the **keep-out** region is the XY projection of the part above the layer (the
//!    cross-section of its visibility closure), computed exactly and incrementally from
//!    the part's triangles with `i_overlay` booleans;
//! 2. it is grown by the radius of the tool's planning [`Envelope`] (+ finishing
//!    allowance) with round joins; the tool centre stays out of it, so the tool body never
//!    cuts the part. The envelope is the cutter's enclosing cylinder, which holds flat, ball
//!    and bull-nose ends alike (safe; shape-aware planning plugs in at [`Tool::envelope`]);
//! 3. the **contour** follows that grown region's boundary (always run, §3.3.1), climb or
//!    conventional;
//! 4. a [`ClearingStrategy`] ([`PlanOptions::strategy`]) fills the rest of the stock
//!    outline: [`Zigzag`] (§3.3.2), [`Periphery`] (§3.3.3), [`Spiral`] (§3.3.4), or any
//!    strategy of the caller's;
//! 5. passes are linked at feed when the link is short and inside the free region,
//!    otherwise through the clearance plane (Eq. 4) and back in by helix, ramp or plunge.
//!
//! With a [`RemainingMaterial`], areas without material are skipped (rest machining).
//! Motions stream into any [`s2g_gcode::MotionSink`] through [`plan_setup`].
//! Machining features (pockets, slots, holes on a block; seed 001) live in [`features`].
//!
//! ```
//! use s2g_gcode::MotionRecorder;
//! use s2g_geom::{Mesh, Point3, Setup};
//! use s2g_toolpath::{plan_setup, PlanOptions, Tool};
//!
//! // A 1 x 1 x 0.5 box.
//! let v = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
//! let c = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.),
//!          v(0., 0., 0.5), v(1., 0., 0.5), v(1., 1., 0.5), v(0., 1., 0.5)];
//! let t = vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
//!              [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]];
//! let part = Mesh::new(c.to_vec(), t).unwrap();
//! let opts = PlanOptions { layer_height: 0.125, stock_margin: 0.1, ..Default::default() };
//! let mut rec = MotionRecorder::default();
//! let summary = plan_setup(&part, &Setup::top(), &Tool::flat(0.05), &opts, &mut rec).unwrap();
//! assert_eq!(summary.layers, 5); // 0.6 (stock top) down to 0 in steps of at most 0.125
//! assert!(summary.cutting_length > 0.0);
//! ```
//!
//! # Tools
//!
//! A [`Tool`] is a physical cutter, [`s2g_geom::Cutter`] (the workspace's one cutter
//! vocabulary, which the simulator cuts with too), plus its cutting data (feeds, spindle
//! speed, tool number). [`Tool::flat`] has unlimited flutes (`f64::INFINITY` flute length
//! and stick-out); [`Tool::new`] takes any cutter.
//!
//! # Clearing strategies
//!
//! The planner takes any [`ClearingStrategy`] object in [`PlanOptions::strategy`] and
//! hands it a [`ClearingContext`] per layer (tool radius, step-over, start point, arc step,
//! climb or conventional). [`strategies()`] is the one registry of the built-in ones by
//! name, in a fixed order (`zigzag`, `periphery`, `spiral`), for the policy and the CLI.
//!
//! **To add a clearing strategy to this crate**: write `src/<name>.rs` with a type that
//! implements [`ClearingStrategy`] and `Default`, and add its `<name>::<Type>,` line to the
//! `builtin_strategies!` list in `src/lib.rs` (that line declares the module, re-exports
//! the type and registers its default value in [`strategies()`]). From outside the crate, a
//! strategy plugs in directly, or by name through a clone of the registry:
//!
//! ```
//! use std::sync::Arc;
//! use s2g_gcode::MotionRecorder;
//! use s2g_geom::{Mesh, Point3, Setup};
//! use s2g_toolpath::{
//!     ClearingContext, ClearingStrategy, PlanOptions, Polyline2, Region2, Tool, plan_setup,
//!     strategies,
//! };
//!
//! /// Runs the region's boundary loops only (a finishing-style pass), for illustration.
//! #[derive(Debug)]
//! struct Outline;
//!
//! impl ClearingStrategy for Outline {
//!     fn name(&self) -> &str {
//!         "outline"
//!     }
//!
//!     fn clear(&self, region: &Region2, ctx: &ClearingContext) -> Vec<Polyline2> {
//!         let mut loops = region.loops();
//!         if !ctx.climb {
//!             loops.iter_mut().for_each(Polyline2::reverse);
//!         }
//!         loops
//!     }
//! }
//!
//! let mut registry = strategies().clone();
//! assert!(registry.register(Arc::new(Outline)).is_none());
//! assert_eq!(registry.names().collect::<Vec<_>>(), ["zigzag", "periphery", "spiral", "outline"]);
//!
//! // A 1 x 1 x 0.25 box, planned with the new strategy.
//! let v = |x: f64, y: f64, z: f64| Point3::new(x, y, z);
//! let c = [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.),
//!          v(0., 0., 0.25), v(1., 0., 0.25), v(1., 1., 0.25), v(0., 1., 0.25)];
//! let t = vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
//!              [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]];
//! let part = Mesh::new(c.to_vec(), t).unwrap();
//! let strategy = registry.get("outline").unwrap();
//! let opts = PlanOptions { layer_height: 0.125, stock_margin: 0.1, strategy, ..Default::default() };
//! let mut rec = MotionRecorder::default();
//! let summary = plan_setup(&part, &Setup::top(), &Tool::flat(0.05), &opts, &mut rec).unwrap();
//! assert!(summary.cutting_length > 0.0);
//! assert!(registry.get("trochoidal").is_err());
//! ```

// `!(x > 0.0)` is deliberate throughout: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod baseline;
mod clear;
mod error;
pub mod features;
pub mod finish;
mod floors;
mod layer;
pub mod library;
mod link;
mod options;
mod plan;
mod region;
mod registry;
mod rest;
mod rings;
mod slice;
mod strategy;
mod tool;
pub mod undercut;

pub use crate::error::ToolpathError;
pub use crate::layer::LayerPlan;
pub use crate::options::{DEFAULT_ARC_STEP, PlanOptions, RampOptions};
pub use crate::plan::{
    PlanProgress, PlanSummary, SetupSlices, plan_layers, plan_setup, plan_setup_rest, plan_setup_watched,
    slice_setup,
};
pub use crate::region::{Point2, Polyline2, Region2, RegionIndex, Vector2, point_segment_distance};
pub use crate::registry::{StrategyRegistry, UnknownStrategy};
pub use crate::rest::{RemainingMaterial, VoxelMaterial};
pub use crate::slice::region_signed_distance;
pub use crate::strategy::{ClearingContext, ClearingStrategy};
pub use crate::tool::{Envelope, Tool};

/// Declares the built-in clearing strategies, one `module::Type` a line, in the order of
/// the registry: each line declares the module (the file `src/<module>.rs`), re-exports its
/// type and registers the type's `Default` value in [`strategies()`].
macro_rules! builtin_strategies {
    ($($module:ident :: $ty:ident),+ $(,)?) => {
        $(mod $module;)+
        pub use crate::{$($module::$ty),+};

        /// The built-in clearing strategies by name: `zigzag` ([`Zigzag`] along X),
        /// `periphery` ([`Periphery`]) and `spiral` ([`Spiral`]), in this order. Clone it
        /// to [`register`](StrategyRegistry::register) more.
        pub fn strategies() -> &'static StrategyRegistry {
            static BUILTIN: std::sync::OnceLock<StrategyRegistry> = std::sync::OnceLock::new();
            BUILTIN.get_or_init(|| {
                StrategyRegistry::from_strategies([
                    $(std::sync::Arc::new($ty::default()) as std::sync::Arc<dyn ClearingStrategy>),+
                ])
            })
        }
    };
}

builtin_strategies! {
    zigzag::Zigzag,
    periphery::Periphery,
    spiral::Spiral,
}
