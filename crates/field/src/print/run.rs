//! [`print_mesh`]: a part from its mesh to a scored multi-axis print, with planar slicing
//! of the same part beside it.

use std::time::Instant;

use s2g_geom::{Mesh, Vector3};

use super::{
    LayerField, NeuralLayers, PlanarLayers, PlanarSupport, PrintPathOptions, PrintPlan, PrintProgram,
    PrintProgramOptions, PrintScore, ScoreOptions, SpacingStats, bead_spacing, extract_print, planar_support,
    print_program, read_beads, score_print,
};
use crate::additive::{PrintOptions, PrintProblem, optimize_print_layers, pretrain_planar_print};
use crate::aligned::{
    AlignProblem, DacOptions, TgcOptions, bent_arm_axis, init_tgc_fields, optimize_dac_layers, optimize_tgc,
    pretrain_planar_dac,
};
use crate::error::{FieldError, Result};
use crate::mesh_sdf::MeshSdf;
use crate::tool::Tool;

/// Which layers to print.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum PrintObjective {
    /// Support- and collision-free layers (Eq. 37).
    SupportFree,
    /// Planar layers (the baseline).
    Planar,
    /// Layers aligned with [`PrintMeshOptions::direction`] (DAC, Eq. 38).
    Aligned,
    /// Layers and a path field co-optimised along [`PrintMeshOptions::direction`] (TGC,
    /// Eq. 39); the toolpaths are the path field's iso-curves.
    Coopt,
}

/// The direction field that aligned and co-optimised layers follow.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum AlignDirection {
    /// One direction everywhere (need not be unit).
    Constant(Vector3),
    /// The axis of [`bent_arm_mesh`](crate::bent_arm_mesh)'s arm ([`bent_arm_axis`]):
    /// its column height, bend radius and bend angle in degrees.
    BentArm {
        /// Column height.
        column: f64,
        /// Centreline radius of the bend.
        bend_radius: f64,
        /// Bend angle, degrees.
        bend_deg: f64,
    },
}

impl AlignDirection {
    fn at(&self, p: &s2g_geom::Point3) -> Vector3 {
        match *self {
            Self::Constant(d) => d,
            Self::BentArm { column, bend_radius, bend_deg } => {
                bent_arm_axis(p, column, bend_radius, bend_deg)
            }
        }
    }
}

/// Options of [`print_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct PrintMeshOptions {
    /// The layers. Default [`PrintObjective::SupportFree`].
    pub objective: PrintObjective,
    /// The optimisation of Eq. 37. Default [`PrintOptions::default`] with 200 pretraining
    /// and 200 Adam steps.
    pub optimisation: PrintOptions,
    /// The direction field of [`PrintObjective::Aligned`] and [`PrintObjective::Coopt`].
    /// Default: the bent arm's axis (column 12, bend 16 through 60°).
    pub direction: AlignDirection,
    /// The optimisation of Eq. 38. Default [`DacOptions::default`].
    pub dac: DacOptions,
    /// The co-optimisation of Eq. 39. Default [`TgcOptions::default`].
    pub tgc: TgcOptions,
    /// The nozzle the optimisation samples (Appendix B). Default: radius 2.5, 30 mm long,
    /// rings from 1 mm, 3 mm apart.
    pub train_nozzle: Tool,
    /// Pose grid of the optimisation, mm. Default `2.5`.
    pub grid: f64,
    /// Surface samples of the optimisation. Default `3000`.
    pub surface_samples: usize,
    /// Layers and toolpaths.
    pub paths: PrintPathOptions,
    /// The program.
    pub program: PrintProgramOptions,
    /// Voxel edge of the rebuilt print's score. Default `0.5`.
    pub voxel: f64,
    /// Also slice the part with planar layers and score that print. Default `true`.
    pub planar_baseline: bool,
}

impl Default for PrintMeshOptions {
    fn default() -> Self {
        Self {
            objective: PrintObjective::SupportFree,
            optimisation: PrintOptions { pretrain_steps: 200, steps: 200, ..PrintOptions::default() },
            direction: AlignDirection::BentArm { column: 12.0, bend_radius: 16.0, bend_deg: 60.0 },
            dac: DacOptions::default(),
            tgc: TgcOptions::default(),
            train_nozzle: Tool { axial_offset: 1.0, axial_step: 3.0, ..Tool::cylinder(2.5, 30.0) },
            grid: 2.5,
            surface_samples: 3000,
            paths: PrintPathOptions::default(),
            program: PrintProgramOptions::default(),
            voxel: 0.5,
            planar_baseline: true,
        }
    }
}

/// Wall-clock seconds per stage.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageSeconds {
    /// Optimising the layer field.
    pub optimise: f64,
    /// Extracting layers and toolpaths.
    pub extract: f64,
    /// Writing and checking the program.
    pub program: f64,
    /// Parsing it back, depositing and scoring.
    pub rebuild: f64,
}

/// A stage of [`print_mesh`], for progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrintStage {
    /// Optimising the layer field.
    Optimise,
    /// Extracting layers and toolpaths.
    Extract,
    /// Writing and checking the program.
    Program,
    /// Parsing it back, depositing and scoring.
    Rebuild,
    /// The planar baseline.
    Planar,
}

/// What [`print_mesh`] made and measured.
#[derive(Debug, Clone)]
pub struct PrintRun {
    /// Layers and toolpaths.
    pub plan: PrintPlan,
    /// The program.
    pub program: PrintProgram,
    /// The rebuilt print's score.
    pub score: PrintScore,
    /// Bead spacing on the extracted paths.
    pub spacing: SpacingStats,
    /// Planar slicing of the same part: its program's statistics and its score.
    pub planar: Option<(PrintProgram, PrintScore)>,
    /// The support a planar slicer would need under the part (at the self-supporting
    /// angle of the optimisation, on a grid of the score's voxel).
    pub planar_support: PlanarSupport,
    /// Seconds per stage (the planar baseline not included).
    pub seconds: StageSeconds,
}

/// Extraction, program, rebuild and score of one layer field.
fn print_field(
    field: &dyn LayerField,
    path_field: Option<&dyn LayerField>,
    part: &MeshSdf,
    mesh: &Mesh,
    options: &PrintMeshOptions,
    seconds: &mut StageSeconds,
) -> Result<(PrintPlan, PrintProgram, PrintScore)> {
    let bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
    let t = Instant::now();
    let plan = extract_print(field, part, &bbox, path_field, &options.paths)?;
    seconds.extract = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let program = print_program(&plan, bbox.min.z, &options.program)?;
    seconds.program = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let beads = read_beads(
        &program.text,
        options.program.rotary,
        options.program.mount,
        options.paths.bead_width,
        options.program.filament_diameter,
    )?;
    let score = score_print(
        &beads,
        mesh,
        &ScoreOptions {
            voxel: options.voxel,
            bead_width: options.paths.bead_width,
            max_overhang_deg: options.optimisation.constants.max_overhang_deg,
            platform: bbox.min.z,
        },
    )?;
    seconds.rebuild = t.elapsed().as_secs_f64();
    Ok((plan, program, score))
}

/// The optimised layer field of `objective` (not planar), and its path field for TGC.
fn optimise(
    objective: PrintObjective,
    part: &MeshSdf,
    mesh: &Mesh,
    options: &PrintMeshOptions,
) -> Result<(NeuralLayers, Option<NeuralLayers>)> {
    let o = &options.optimisation;
    let seed = match objective {
        PrintObjective::Aligned => options.dac.seed,
        PrintObjective::Coopt => options.tgc.seed,
        _ => o.seed,
    };
    let problem = PrintProblem::from_mesh(
        part,
        mesh,
        options.train_nozzle,
        options.grid,
        options.surface_samples,
        seed,
    )?;
    let normalization = problem.normalization();
    let neural = |g: crate::siren::SirenF64| NeuralLayers { field: g, normalization };
    match objective {
        PrintObjective::Aligned => {
            let problem = AlignProblem::from_field(problem, |p| options.direction.at(p))?;
            let g = pretrain_planar_dac(&options.dac)?;
            let (g, _) = optimize_dac_layers(g, &problem, &options.dac)?;
            Ok((neural(g.to_f64()?), None))
        }
        PrintObjective::Coopt => {
            let problem = AlignProblem::from_field(problem, |p| options.direction.at(p))?;
            let fields = init_tgc_fields(&options.tgc)?;
            let (fields, _) = optimize_tgc(fields, &problem, &options.tgc)?;
            Ok((neural(fields.layer.to_f64()?), Some(neural(fields.path.to_f64()?))))
        }
        _ => {
            let g = pretrain_planar_print(o)?;
            let (g, _) = optimize_print_layers(g, &problem, o)?;
            Ok((neural(g.to_f64()?), None))
        }
    }
}

/// Prints `mesh` standing on the platform `z = min z`: optimises the layer field for the
/// objective, extracts layers and toolpaths, writes and checks the program, reads it back
/// and scores the rebuilt print; then the same for planar layers when asked. `progress`
/// hears each stage as it starts.
///
/// Deterministic for fixed options.
///
/// Errors: those of the stages ([`optimize_print_layers`], [`extract_print`],
/// [`print_program`], [`read_beads`], [`score_print`]).
pub fn print_mesh(
    mesh: &Mesh,
    options: &PrintMeshOptions,
    progress: &mut dyn FnMut(PrintStage),
) -> Result<PrintRun> {
    // Checked before the optimisation, not after it: the score's grid over the part's
    // box alone already too fine is refused (the beads' box only adds to it).
    FieldError::check_positive(&[("score.voxel", options.voxel)])?;
    let bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
    super::rebuild::score_box(&bbox, options.paths.bead_width, options.voxel)?;
    let part = MeshSdf::new(mesh)?;
    let mut seconds = StageSeconds::default();
    let (field, path_field): (Box<dyn LayerField>, Option<NeuralLayers>) = match options.objective {
        PrintObjective::Planar => (Box::new(PlanarLayers), None),
        objective => {
            progress(PrintStage::Optimise);
            let t = Instant::now();
            let fields = optimise(objective, &part, mesh, options)?;
            seconds.optimise = t.elapsed().as_secs_f64();
            (Box::new(fields.0), fields.1)
        }
    };
    progress(PrintStage::Extract);
    let path_field = path_field.as_ref().map(|p| p as &dyn LayerField);
    let (plan, program, score) = print_field(field.as_ref(), path_field, &part, mesh, options, &mut seconds)?;
    let spacing = bead_spacing(&plan.layers, options.paths.bead_width);
    let planar = if options.planar_baseline && options.objective != PrintObjective::Planar {
        progress(PrintStage::Planar);
        let (_, p, s) = print_field(&PlanarLayers, None, &part, mesh, options, &mut StageSeconds::default())?;
        Some((p, s))
    } else {
        None
    };
    let planar_support =
        planar_support(mesh, options.optimisation.constants.max_overhang_deg, bbox.min.z, options.voxel)?;
    Ok(PrintRun { plan, program, score, spacing, planar, planar_support, seconds })
}
