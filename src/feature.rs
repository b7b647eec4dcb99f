//! Feature jobs (seed 001): a TOML description of a block, its tools and its machining
//! features, turned into a complete numbered CNC program with
//! [`s2g_toolpath::features`] and the `s2g-gcode` writers, and checked in `s2g-voxsim`.
//!
//! # Job file
//! ```toml
//! units = "mm"          # or "inch" (lengths in inches, feeds in inch/min); default mm
//! allowance = 0.4       # finishing allowance S on pocket and slot walls; default 0
//!
//! [block]               # X in [0, length], Y in [0, width], Z in [-height, 0]
//! length = 75.0
//! width = 60.0
//! height = 15.0
//!
//! [[tools]]
//! number = 1
//! diameter = 10.0
//! rpm = 1200
//! feed = 90             # mm/min
//! plunge_feed = 90      # optional; default feed
//!
//! [[features]]
//! type = "pocket"       # x, y: lower-left corner
//! name = "pocket"
//! x = 12.5
//! y = 12.5
//! length = 50.0
//! width = 35.0
//! corner_radius = 5.0
//! depth = 5.0
//! tool = 1
//! finish_tool = 1       # optional
//!
//! # type = "slot":  start = [x, y], end = [x, y], width, depth, through = false, tool, finish_tool
//! # type = "hole":  x, y, diameter, depth, tool,
//! #                 cycle = "auto" | "drill" | "dwell" | "peck" | "helical", dwell = s, peck = mm
//!
//! [options]             # optional, see FeatureOptions: max_depth_ratio, max_stepover_ratio,
//!                       # clearance, r_plane, overrun, optional_stop, coolant, comments
//! ```
//! Unknown keys are errors (a misspelt key would otherwise be silently ignored).

use std::path::Path;

use s2g_gcode::{Dialect, GcodeWriter, WriteError, WriterOptions};
use s2g_geom::{Aabb, GridSpec, Point3, VoxelGrid};
use s2g_toolpath::Tool;
use s2g_toolpath::features::{
    Block, Feature, FeatureJob, FeatureKind, FeatureOptions, FeaturePlan, HoleMethod, plan_features,
};
use s2g_voxsim::{Cutter, SimError, SimOptions, ToolTable};
use serde::Deserialize;

/// Errors of feature jobs.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FeatureError {
    /// The job file could not be read.
    #[error("{path}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The job text is not valid TOML or does not match the job schema (with line and column).
    #[error("{path}: {message}")]
    Parse {
        /// The file (`<string>` for text).
        path: String,
        /// The TOML error, with its position.
        message: String,
    },
    /// The job is impossible (names the feature when one is at fault).
    #[error(transparent)]
    Job(#[from] s2g_toolpath::features::FeatureError),
    /// The G-code writer failed.
    #[error("writing the program")]
    Write(#[from] WriteError),
    /// The voxel check's options are impossible.
    #[error("voxel check: {0}")]
    Check(String),
    /// The voxel check's simulation failed.
    #[error("voxel check")]
    Simulation(#[source] SimError),
}

/// A parsed job: what to machine and how.
#[derive(Debug, Clone, PartialEq)]
pub struct JobSpec {
    /// Block, allowance, tools and features (millimetres).
    pub job: FeatureJob,
    /// Rule bounds and program options.
    pub options: FeatureOptions,
}

/// A generated feature program.
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureProgram {
    /// The job it was made from.
    pub spec: JobSpec,
    /// Motions and per-feature summaries (depth of cut, cuts, step-over, passes, extents).
    pub plan: FeaturePlan,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct JobToml {
    #[serde(default)]
    units: Option<String>,
    #[serde(default)]
    allowance: Option<f64>,
    #[serde(default)]
    name: Option<String>,
    block: BlockToml,
    tools: Vec<ToolToml>,
    features: Vec<FeatureToml>,
    #[serde(default)]
    options: Option<OptionsToml>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct BlockToml {
    length: f64,
    width: f64,
    height: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToolToml {
    number: u32,
    diameter: f64,
    rpm: f64,
    feed: f64,
    #[serde(default)]
    plunge_feed: Option<f64>,
    #[serde(default)]
    name: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OptionsToml {
    max_depth_ratio: Option<f64>,
    max_stepover_ratio: Option<f64>,
    clearance: Option<f64>,
    r_plane: Option<f64>,
    overrun: Option<f64>,
    optional_stop: Option<bool>,
    coolant: Option<bool>,
    comments: Option<bool>,
    default_dwell: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum FeatureToml {
    Pocket {
        name: String,
        x: f64,
        y: f64,
        length: f64,
        width: f64,
        corner_radius: f64,
        depth: f64,
        tool: u32,
        #[serde(default)]
        finish_tool: Option<u32>,
    },
    Slot {
        name: String,
        start: [f64; 2],
        end: [f64; 2],
        width: f64,
        depth: f64,
        #[serde(default)]
        through: bool,
        tool: u32,
        #[serde(default)]
        finish_tool: Option<u32>,
    },
    Hole {
        name: String,
        x: f64,
        y: f64,
        diameter: f64,
        depth: f64,
        tool: u32,
        #[serde(default)]
        cycle: Option<String>,
        #[serde(default)]
        dwell: Option<f64>,
        #[serde(default)]
        peck: Option<f64>,
    },
}

/// Parses a job from TOML text; `path` names it in errors.
pub fn parse_job(text: &str, path: &str) -> Result<JobSpec, FeatureError> {
    let parse = |message: String| FeatureError::Parse { path: path.to_owned(), message };
    let raw: JobToml = toml::from_str(text).map_err(|e| {
        // toml's message is "position, snippet, detail" on lines: keep the position and the detail.
        let msg = e.to_string();
        let lines: Vec<&str> = msg.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
        match (lines.first(), lines.last()) {
            (Some(a), Some(b)) if lines.len() > 1 => parse(format!("{a}: {b}")),
            _ => parse(msg.trim().to_owned()),
        }
    })?;
    let _ = raw.name;
    let k = match raw.units.as_deref().unwrap_or("mm") {
        "mm" => 1.0,
        "inch" | "in" => 25.4,
        other => return Err(parse(format!("units must be \"mm\" or \"inch\", got \"{other}\""))),
    };
    let tools = raw
        .tools
        .iter()
        .map(|t| {
            let _ = &t.name;
            Tool {
                number: t.number,
                spindle_rpm: t.rpm,
                feed: t.feed * k,
                plunge_feed: t.plunge_feed.unwrap_or(t.feed) * k,
                ..Tool::flat(0.5 * (t.diameter * k))
            }
        })
        .collect();
    let mut features = Vec::with_capacity(raw.features.len());
    for f in raw.features {
        features.push(match f {
            FeatureToml::Pocket { name, x, y, length, width, corner_radius, depth, tool, finish_tool } => Feature {
                name,
                kind: FeatureKind::Pocket {
                    x: x * k,
                    y: y * k,
                    length: length * k,
                    width: width * k,
                    corner_radius: corner_radius * k,
                },
                depth: depth * k,
                tool,
                finish_tool,
            },
            FeatureToml::Slot { name, start, end, width, depth, through, tool, finish_tool } => Feature {
                name,
                kind: FeatureKind::Slot {
                    start: start.map(|v| v * k),
                    end: end.map(|v| v * k),
                    width: width * k,
                    through,
                },
                depth: depth * k,
                tool,
                finish_tool,
            },
            FeatureToml::Hole { name, x, y, diameter, depth, tool, cycle, dwell, peck } => {
                let method = match cycle.as_deref().unwrap_or("auto") {
                    "auto" => HoleMethod::Auto,
                    "drill" | "g81" => HoleMethod::Drill,
                    "dwell" | "g82" => HoleMethod::Dwell(dwell),
                    "peck" | "g83" => HoleMethod::Peck(peck.map(|p| p * k)),
                    "helical" => HoleMethod::Helical,
                    other => {
                        return Err(parse(format!(
                            "feature '{name}': cycle must be auto, drill, dwell, peck or helical, got \"{other}\""
                        )));
                    }
                };
                Feature {
                    name,
                    kind: FeatureKind::Hole { x: x * k, y: y * k, diameter: diameter * k, method },
                    depth: depth * k,
                    tool,
                    finish_tool: None,
                }
            }
        });
    }
    let mut options = FeatureOptions::default();
    if let Some(o) = raw.options {
        let set = |dst: &mut f64, v: Option<f64>, scale: f64| {
            if let Some(v) = v {
                *dst = v * scale;
            }
        };
        set(&mut options.max_depth_ratio, o.max_depth_ratio, 1.0);
        set(&mut options.max_stepover_ratio, o.max_stepover_ratio, 1.0);
        set(&mut options.clearance, o.clearance, k);
        set(&mut options.r_plane, o.r_plane, k);
        set(&mut options.overrun, o.overrun, k);
        set(&mut options.default_dwell, o.default_dwell, 1.0);
        options.optional_stop = o.optional_stop.unwrap_or(options.optional_stop);
        options.coolant = o.coolant.unwrap_or(options.coolant);
        options.comments = o.comments.unwrap_or(options.comments);
    }
    let job = FeatureJob {
        block: Block {
            length: raw.block.length * k,
            width: raw.block.width * k,
            height: raw.block.height * k,
        },
        allowance: raw.allowance.unwrap_or(0.0) * k,
        tools,
        features,
    };
    Ok(JobSpec { job, options })
}

/// Reads and parses a job file.
pub fn load_job(path: impl AsRef<Path>) -> Result<JobSpec, FeatureError> {
    let path = path.as_ref();
    let name = path.display().to_string();
    let text =
        std::fs::read_to_string(path).map_err(|source| FeatureError::Io { path: name.clone(), source })?;
    parse_job(&text, &name)
}

/// Validates the job and builds its program (rules, motions, summaries).
pub fn feature_program(spec: &JobSpec) -> Result<FeatureProgram, FeatureError> {
    let plan = plan_features(&spec.job, &spec.options)?;
    Ok(FeatureProgram { spec: spec.clone(), plan })
}

/// Writer options of feature programs: numbered blocks (`N10`, `N20`, ...), tool length
/// offsets (`G43 H<n>`) after tool changes, four decimals.
pub fn feature_writer_options() -> WriterOptions {
    WriterOptions { line_numbers: true, line_number_step: 10, tool_length_offset: true, ..Default::default() }
}

/// Per-feature result of [`FeatureProgram::voxel_check`].
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureResidual {
    /// Feature name.
    pub name: String,
    /// Voxels whose centre lies inside the feature at least one voxel from its walls and
    /// floor that the program left (should be 0).
    pub left_inside: u64,
    /// Z of the lowest removed voxel centre inside the feature's outline (one voxel in from
    /// its walls), or `None` when nothing was removed there.
    pub floor_z: Option<f64>,
    /// Largest distance (mm) from a removed voxel centre under the feature's outline to its
    /// volume: 0 when nothing was cut outside it.
    pub overcut: f64,
}

/// Result of [`FeatureProgram::voxel_check`].
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureCheck {
    /// Voxel edge (mm).
    pub voxel: f64,
    /// Voxels removed in total.
    pub removed_voxels: u64,
    /// Removed voxels outside every feature volume (gouges; should be 0).
    pub gouge_voxels: u64,
    /// Voxels removed by rapids (should be 0).
    pub rapid_collision_voxels: u64,
    /// Shank or holder collisions (voxels).
    pub holder_collision_voxels: u64,
    /// Per feature, in job order.
    pub features: Vec<FeatureResidual>,
}

impl FeatureProgram {
    /// The program as G-code text of `dialect` with [`feature_writer_options`].
    pub fn gcode(&self, dialect: Dialect) -> Result<String, FeatureError> {
        self.gcode_with(dialect, feature_writer_options())
    }

    /// The program as G-code text of `dialect` with `opts`.
    pub fn gcode_with(&self, dialect: Dialect, opts: WriterOptions) -> Result<String, FeatureError> {
        let mut w = GcodeWriter::new(Vec::new(), dialect, opts);
        self.plan.emit(&mut w)?;
        let bytes = w.into_inner();
        Ok(String::from_utf8_lossy(&bytes).into_owned())
    }

    /// Simulates `program` (G-code text of this job, e.g. from [`FeatureProgram::gcode`]) on
    /// the block in voxels of edge about `voxel` mm, every job tool its own cutter (flat, as
    /// the job file gives them) with flutes through the block, with the
    /// target "block minus feature volumes": gouges, rapid collisions and per-feature residuals.
    pub fn voxel_check(&self, program: &str, voxel: f64) -> Result<FeatureCheck, FeatureError> {
        let job = &self.spec.job;
        let b = job.block;
        if voxel.is_nan() || voxel <= 0.0 || voxel.is_infinite() {
            return Err(FeatureError::Check(format!("voxel size must be positive, got {voxel}")));
        }
        let dims = [b.length, b.width, b.height].map(|e| ((e / voxel).round() as usize).max(1));
        if dims.iter().map(|&d| d as f64).product::<f64>() > 2e8 {
            return Err(FeatureError::Check(format!("{dims:?} voxels is too many: use a larger voxel")));
        }
        let bounds = Aabb::new(Point3::new(0.0, 0.0, -b.height), Point3::new(b.length, b.width, 0.0));
        let spec = GridSpec::new(&bounds, dims).map_err(|e| FeatureError::Simulation(e.into()))?;
        let h = spec.voxel.max();
        let stock = VoxelGrid::full(spec);
        let mut target = VoxelGrid::new(spec);
        target.set_where(|p| !job.removed(p));
        let flute = b.height + 10.0;
        // Each job tool's own cutter, with flutes through the block.
        let cutter = |t: &Tool| Cutter { flute_length: flute, stickout: 2.0 * flute, ..t.cutter };
        let first = job.tools.first().map_or(Cutter::flat(1.0, flute), cutter);
        let mut tools = ToolTable::single(first);
        for t in &job.tools {
            tools = tools.with(t.number, cutter(t));
        }
        let mut simulator = s2g_voxsim::Simulator::new(stock, tools, SimOptions::default())
            .and_then(|s| s.with_target(&target))
            .map_err(FeatureError::Simulation)?;
        let popts = s2g_gcode::ParseOptions { stop_at_first_error: true, ..Default::default() };
        s2g_gcode::parse_str(program, &popts, &mut simulator)
            .map_err(|e| FeatureError::Simulation(e.into()))?;
        let sim = simulator.into_simulation().map_err(FeatureError::Simulation)?;
        let report = sim.report();
        let residual = sim.residual();
        let mut features = Vec::with_capacity(job.features.len());
        for f in &job.features {
            let mut left = 0u64;
            let mut floor: Option<f64> = None;
            let mut overcut = 0.0f64;
            for k in 0..dims[2] {
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        let p = spec.center(i, j, k);
                        let od = f.outline_distance(p.x, p.y);
                        if od > 2.0 * h {
                            continue;
                        }
                        let kept = residual.get(i, j, k);
                        if !kept {
                            if od <= -h {
                                floor = Some(floor.map_or(p.z, |z: f64| z.min(p.z)));
                            }
                            if !job.removed(&p) {
                                overcut = overcut.max(f.distance(&p));
                            }
                        } else if od <= -h && p.z >= -f.depth + h {
                            left += 1;
                        }
                    }
                }
            }
            features.push(FeatureResidual {
                name: f.name.clone(),
                left_inside: left,
                floor_z: floor,
                overcut,
            });
        }
        Ok(FeatureCheck {
            voxel: h,
            removed_voxels: report.removed_voxels,
            gouge_voxels: report.gouge_voxels,
            rapid_collision_voxels: report.rapid_collision_voxels,
            holder_collision_voxels: report.holder_collision_voxels,
            features,
        })
    }
}
