//! Multi-axis printing end to end (step 4 of seed 002's pipeline, closed with seed 004):
//! layers as iso-surfaces of a layer field and toolpaths on them ([`extract_print`]), a
//! collision-checked program for a printer with a tilting and rotating platform
//! ([`print_program`]), and the print rebuilt from the program text and scored against
//! the part ([`read_beads`], [`score_print`]). [`print_mesh`] runs it all for a mesh,
//! with planar slicing of the same part beside it.
//!
//! The layer field is anything that gives a value and a gradient in the part's units
//! ([`LayerField`]): an optimised SIREN ([`NeuralLayers`]) or planar layers
//! ([`PlanarLayers`], the baseline). Layers are printed in increasing `G`; the tip of
//! layer `k` runs on `G = g_k`, the bead below it.

mod emit;
mod extract;
mod lattice;
mod offsets;
mod order;
mod parts;
mod rebuild;
mod run;
mod spacing;
mod support;

use s2g_geom::{Aabb, Mesh, Normalization, Point3, SignedDistance, SweepOptions, Vector3, sweep_profile};

use crate::error::{FieldError, Result};
use crate::siren::SirenF64;

pub use emit::{PrintProgram, PrintProgramOptions};
pub use extract::{PathKind, PrintLayer, PrintPath, PrintPathOptions};
pub use parts::{PRINT_PARTS, arch_mesh, bracket_mesh, overhang_arch_mesh, print_part};
pub use rebuild::{
    Bead, PrintScore, ScoreOptions, deposit, overhang_fraction, overhang_misses, read_beads, score_print,
};
pub use run::{
    AlignDirection, PrintMeshOptions, PrintObjective, PrintRun, PrintStage, StageSeconds, print_mesh,
};
pub use spacing::{SpacingStats, bead_spacing};
pub use support::{PlanarSupport, planar_support};

/// A scalar field whose level sets are layers, in the part's units.
///
/// Required: [`LayerField::value_gradient`].
pub trait LayerField: Sync {
    /// The value at `p` and its gradient (per unit of the part's length).
    fn value_gradient(&self, p: &Point3) -> (f64, Vector3);
}

/// Planar layers: `G = z` (the baseline of planar slicing).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlanarLayers;

impl LayerField for PlanarLayers {
    fn value_gradient(&self, p: &Point3) -> (f64, Vector3) {
        (p.z, Vector3::z())
    }
}

/// A SIREN layer (or path) field on the unit cube of a [`Normalization`].
#[derive(Debug, Clone)]
pub struct NeuralLayers {
    /// The field on unit-cube coordinates.
    pub field: SirenF64,
    /// The part's units to the unit cube.
    pub normalization: Normalization,
}

impl LayerField for NeuralLayers {
    fn value_gradient(&self, p: &Point3) -> (f64, Vector3) {
        let u = self.normalization.to_unit(p);
        let (v, g) = self.field.value_gradient([u.x, u.y, u.z]);
        (v, Vector3::new(g[0], g[1], g[2]) * self.normalization.scale)
    }
}

/// Layers and their ordered toolpaths, with what the program's checks need.
#[derive(Debug, Clone)]
pub struct PrintPlan {
    /// Layers in print order (increasing level).
    pub layers: Vec<PrintLayer>,
    /// Spacing of the levels, in units of `G`.
    pub level_step: f64,
    /// The bead width the paths were spaced for.
    pub bead_width: f64,
    lattice: lattice::Lattice,
}

impl PrintPlan {
    /// The layers' surfaces inside the part as one mesh.
    pub fn layers_mesh(&self) -> Result<Mesh> {
        let mut vertices = Vec::new();
        let mut triangles = Vec::new();
        for l in &self.layers {
            let base = vertices.len() as u32;
            vertices.extend_from_slice(l.surface.vertices());
            triangles.extend(l.surface.triangles().iter().map(|t| t.map(|i| i + base)));
        }
        Mesh::new(vertices, triangles).map_err(FieldError::geom)
    }

    /// The toolpaths as one mesh of thin square tubes of half-width `radius`.
    pub fn paths_mesh(&self, radius: f64) -> Result<Mesh> {
        FieldError::check_positive(&[("radius", radius)])?;
        let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
        let square = [[-radius, -radius], [radius, -radius], [radius, radius], [-radius, radius]];
        for path in self.layers.iter().flat_map(|l| &l.paths) {
            let profile = |_: Option<usize>, _: Option<usize>, ring: &mut Vec<[f64; 2]>| ring.extend(square);
            sweep_profile(&path.points, &SweepOptions::default(), profile, &mut vertices, &mut triangles);
        }
        Mesh::new(vertices, triangles).map_err(FieldError::geom)
    }
}

/// Extracts the layers of `field` over `part` (whose box is `bounds`) and their toolpaths
/// (iso-curves of `path_field` when given, contours and zig-zag infill otherwise), in
/// print order; see [`PrintPathOptions`].
///
/// Errors: [`FieldError::InvalidConfig`] for bad options; [`FieldError::InvalidArgument`]
/// for a degenerate box, a lattice too fine or a field constant over the part;
/// [`FieldError::NonFinite`]; [`FieldError::Geometry`].
pub fn extract_print(
    field: &dyn LayerField,
    part: &dyn SignedDistance,
    bounds: &Aabb,
    path_field: Option<&dyn LayerField>,
    opts: &PrintPathOptions,
) -> Result<PrintPlan> {
    opts.validate()?;
    let lattice = lattice::Lattice::new(bounds, opts.lattice, field, part)?;
    let (mut layers, level_step) = extract::extract(&lattice, field, part, path_field, opts)?;
    let mut at = Point3::new(bounds.min.x, bounds.min.y, bounds.min.z);
    for layer in &mut layers {
        let (paths, end) = order::order_paths(std::mem::take(&mut layer.paths), at, 2.0 * opts.bead_width);
        layer.paths = paths;
        at = end;
    }
    Ok(PrintPlan { layers, level_step, bead_width: opts.bead_width, lattice })
}

/// Writes the program of `plan` for a platform at `z = platform`; see
/// [`PrintProgramOptions`].
///
/// Errors: [`FieldError::InvalidConfig`] for bad options, [`FieldError::Write`] if the
/// writer fails.
pub fn print_program(plan: &PrintPlan, platform: f64, opts: &PrintProgramOptions) -> Result<PrintProgram> {
    let mut e = emit::Emitter::new(opts, &plan.lattice, platform, plan.bead_width)?;
    for layer in &plan.layers {
        e.layer(layer, plan.level_step)?;
    }
    e.finish()
}
