//! [`print_mesh`]: a part from its mesh to a scored multi-axis print, with planar slicing
//! of the same part beside it.

use std::time::Instant;

use s2g_geom::Mesh;

use super::{
    LayerField, NeuralLayers, PlanarLayers, PlanarSupport, PrintPathOptions, PrintPlan, PrintProgram,
    PrintProgramOptions, PrintScore, ScoreOptions, SpacingStats, bead_spacing, extract_print, planar_support,
    print_program, read_beads, score_print,
};
use crate::additive::{PrintOptions, PrintProblem, optimize_print_layers, pretrain_planar_print};
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
}

/// Options of [`print_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct PrintMeshOptions {
    /// The layers. Default [`PrintObjective::SupportFree`].
    pub objective: PrintObjective,
    /// The optimisation of Eq. 37. Default [`PrintOptions::default`] with 200 pretraining
    /// and 200 Adam steps.
    pub optimisation: PrintOptions,
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
    part: &MeshSdf,
    mesh: &Mesh,
    options: &PrintMeshOptions,
    seconds: &mut StageSeconds,
) -> Result<(PrintPlan, PrintProgram, PrintScore)> {
    let bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
    let t = Instant::now();
    let plan = extract_print(field, part, &bbox, None, &options.paths)?;
    seconds.extract = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let program = print_program(&plan, bbox.min.z, &options.program)?;
    seconds.program = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let beads = read_beads(
        &program.text,
        options.program.rotary,
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
    let part = MeshSdf::new(mesh)?;
    let mut seconds = StageSeconds::default();
    let neural;
    let field: &dyn LayerField = match options.objective {
        PrintObjective::Planar => &PlanarLayers,
        PrintObjective::SupportFree => {
            progress(PrintStage::Optimise);
            let t = Instant::now();
            let o = &options.optimisation;
            let problem = PrintProblem::from_mesh(
                &part,
                mesh,
                options.train_nozzle,
                options.grid,
                options.surface_samples,
                o.seed,
            )?;
            let g = pretrain_planar_print(o)?;
            let (g, _) = optimize_print_layers(g, &problem, o)?;
            neural = NeuralLayers { field: g.to_f64()?, normalization: problem.normalization() };
            seconds.optimise = t.elapsed().as_secs_f64();
            &neural
        }
    };
    progress(PrintStage::Extract);
    let (plan, program, score) = print_field(field, &part, mesh, options, &mut seconds)?;
    let spacing = bead_spacing(&plan.layers, options.paths.bead_width);
    let planar = if options.planar_baseline && options.objective != PrintObjective::Planar {
        progress(PrintStage::Planar);
        let (_, p, s) = print_field(&PlanarLayers, &part, mesh, options, &mut StageSeconds::default())?;
        Some((p, s))
    } else {
        None
    };
    let bbox = mesh.bbox().ok_or(FieldError::EmptyMesh)?;
    let planar_support =
        planar_support(mesh, options.optimisation.constants.max_overhang_deg, bbox.min.z, options.voxel)?;
    Ok(PrintRun { plan, program, score, spacing, planar, planar_support, seconds })
}
