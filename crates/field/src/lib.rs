//! `s2g-field`: SIREN implicit neural fields in [Burn](https://burn.dev) on the CPU, with
//! exact input derivatives, and neural signed distance fields of meshes (seed 002,
//! "implicit multi-axis manufacturing").
//!
//! # Design
//!
//! - [`Siren`] is the network: sine layers with Sitzmann's initialisation, a first-layer
//!   frequency `ω0` and a hidden frequency `ω` ([`SirenConfig`], §7.5.1 of seed 002,
//!   [`omega_for_scale`]). Its forward passes propagate the Jacobian and the Hessian through
//!   the layers as tensor operations ([`Siren::forward_gradient`],
//!   [`Siren::forward_hessian`]), so losses on gradients and curvatures need only Burn's
//!   first-order autodiff. Burn 0.22 cannot differentiate a loss built from `x.grad(..)`.
//! - [`SirenF64`] holds the same weights and evaluates value, gradient and Hessian point by
//!   point on the host in `f64`, without Burn: fast single queries, and the reference the
//!   tests check the tensor derivatives against (by finite differences in `f64`).
//! - [`NeuralSdf`] (§6.2) is a trained SIREN for a mesh's signed distance: Adam on the
//!   surface-value, surface-normal, general-point-value and Eikonal losses
//!   ([`fit_sdf_opt`], [`SdfOptions`]); it implements [`s2g_geom::SignedDistance`] with the
//!   network's exact gradient, and saves to a file with Burn's record format
//!   ([`NeuralSdf::save`], atomic). [`sdf_error`] and [`validation_points`] measure it.
//! - Milling (§4.2, §5.4, §7.4): a layer field optimised from planar layers by Eq. 40 so that the tool along
//!   the layer normal is clear of the part ([`optimize_layers`], [`count_collisions`]), a simultaneous
//!   five-axis program from its layers and normals written by `s2g-gcode` ([`mill_program`]), simulated in
//!   `s2g-voxsim` for gouges ([`simulate_program`]); [`mill_mesh`] runs it all.
//! - Toolpaths (§3.2, §4.3-4.5, §7.3-7.4): a path field `P` whose iso-curves on each layer are the
//!   toolpaths: tangent, spacing and geodesic curvature ([`PathGeometry`]), the path losses and their
//!   optimisation on a fixed layer field ([`optimize_path`], [`path_stats`]), and contour-parallel
//!   milling toolpaths ([`fit_contour_paths`], [`mill_program_with_paths`]).
//! - Printing (§4.1, §4.6, §5.1, §7.1): a layer field optimised from planar layers by the
//!   support- and collision-free total loss (Eq. 37: support-free Eq. 30, base Eq. 31, the
//!   nozzle sampled as points against printed material Eq. 13 and the platform Eq. 36, and
//!   the layer regularisers) so that the build direction (the layer normal) keeps every
//!   overhang within the self-supporting angle ([`optimize_print_layers`],
//!   [`overhang_stats`], [`print_collisions`]); [`bent_arm_mesh`] is a part planar layers
//!   cannot print without support.
//! - Direction alignment (§5.2-5.3, §7.2-7.3): a printing problem with a prescribed
//!   direction field ([`AlignProblem`], e.g. [`bent_arm_axis`], the stress direction of a
//!   bent cantilever). DAC (Eq. 38): layers that contain the directions (Eq. 21), with the
//!   layer regularisers and the nozzle's collisions with printed layers and the platform,
//!   Table 1's DAC weights ([`optimize_dac_layers`], [`DacWeights`], [`alignment_stats`]).
//!   TGC (Eq. 39): the layer field and a path field optimised together by one Adam
//!   ([`LayerPathFields`], [`optimize_tgc`]) so that the layers contain the directions
//!   and the toolpaths follow them, evenly spaced, their geodesic curvature weighted up
//!   from 0.001 to 1 (Table 1's TGC row, [`TgcWeights`]).
//! - Reproducible: seeds drive geom's [`SplitMix64`](s2g_geom::SplitMix64) for weights, samples and
//!   batches, and the CPU backends run single-threaded, so the same options give the same field.
//! - Bad input (NaN points, empty meshes, zero epochs, bad frequencies) is a [`FieldError`], never a panic.
//!
//! # Example
//!
//! ```
//! use burn::tensor::{Tensor, TensorData};
//! use s2g_field::{Backend, Siren, SirenConfig};
//!
//! let device = Backend::default().device();
//! let net = Siren::new(&SirenConfig { width: 16, sine_layers: 2, ..SirenConfig::default() }, &device)?;
//! let x = Tensor::<2>::from_data(TensorData::new(vec![0.1f32, -0.2, 0.3], [1, 3]), &device);
//! let out = net.forward_hessian(x);
//! assert_eq!(out.hessian.dims(), [1, 3, 3]);
//! // The host copy agrees with the tensor forward pass.
//! let host = net.to_f64()?;
//! let v: f32 = out.value.into_scalar();
//! assert!((host.value([0.1, -0.2, 0.3]) - v as f64).abs() < 1e-5);
//! # Ok::<(), s2g_field::FieldError>(())
//! ```

#[cfg(not(any(feature = "flex", feature = "ndarray")))]
compile_error!("s2g-field needs a Burn backend: enable the `flex` (default) or `ndarray` feature");

mod additive;
mod aligned;
mod backend;
mod checkpoint;
mod error;
mod eval;
mod layer;
mod mesh_sdf;
mod milling;
mod path;
mod print;
mod program;
mod sdf;
mod siren;
mod tool;
mod train;

pub use additive::{
    OverhangStats, PrintCollisionCount, PrintConstants, PrintLosses, PrintOptions, PrintProblem, PrintReport,
    PrintSamples, PrintWeights, base_loss, bent_arm_mesh, first_layers_loss, optimize_print_layers,
    overhang_angle, overhang_angles, overhang_stats, pretrain_planar_print, print_collisions, print_losses,
    support_free_loss,
};
pub use aligned::{
    AlignProblem, AlignmentStats, DacLosses, DacOptions, DacReport, DacWeights, LayerPathFields,
    TgcConstants, TgcLosses, TgcOptions, TgcReport, TgcWeights, alignment_stats, bent_arm_axis, dac_losses,
    init_tgc_fields, layer_alignment, optimize_dac_layers, optimize_tgc, pretrain_planar_dac, tgc_losses,
};
pub use backend::Backend;
pub use error::{FieldError, Result};
pub use eval::{SdfError, sdf_error, validation_points};
pub use layer::{
    GRAD_EPS, LayerGeometry, gaussian_curvature, gradient_norm, hessian_times_gradient, layer_normal,
    max_abs_curvature, mean_curvature, principal_curvatures,
};
pub use mesh_sdf::MeshSdf;
pub use milling::{
    CollisionCount, LayerOptions, LayerReport, MillingLosses, MillingProblem, MillingWeights,
    colliding_poses, count_collisions, cup_mesh, milling_losses, optimize_layers, pretrain_planar,
};
pub use path::{
    DirectionLosses, PathGeometry, PathOptions, PathReport, PathStats, PathWeights, contour_directions,
    direction_losses, fit_contour_paths, geodesic_curvature, optimize_path, path_curvature_loss,
    path_spacing, path_spacing_loss, path_stats, path_tangent, projected_path_gradient,
};
pub use print::{
    AlignDirection, Bead, LayerField, NeuralLayers, PRINT_PARTS, PathKind, PlanarLayers, PlanarSupport,
    PrintLayer, PrintMeshOptions, PrintObjective, PrintPath, PrintPathOptions, PrintPlan, PrintProgram,
    PrintProgramOptions, PrintRun, PrintScore, PrintStage, ScoreOptions, SpacingStats, StageSeconds,
    arch_mesh, bead_spacing, bracket_mesh, deposit, extract_print, overhang_arch_mesh, overhang_fraction,
    overhang_misses, planar_support, print_mesh, print_part, print_program, read_beads, score_print,
};
pub use program::{
    ContourPaths, MillOptions, MillProgram, MillReport, ProgramOptions, ProgramSimulation, layer_mesh,
    mill_mesh, mill_program, mill_program_with_paths, simulate_program,
};
pub use sdf::{NeuralSdf, SdfLossWeights, SdfOptions, SdfReport, fit_sdf, fit_sdf_opt, fit_sdf_samples};
pub use siren::{FieldGradient, FieldHessian, Siren, SirenConfig, SirenF64, omega_for_scale};
pub use tool::Tool;
pub use train::LossConstants;
