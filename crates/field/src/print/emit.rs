//! The multi-axis printing program: a printer whose nozzle stays vertical over a
//! tilting and rotating platform (table-table A/C or B/C, `s2g-gcode`'s kinematics), so the
//! part is turned until the nozzle axis (the layer normal) points up.
//!
//! - **Extrusion**: `E = w · t · L / (π (d/2)²)` per move (bead width `w`, local layer
//!   thickness `t`, length `L`, filament diameter `d`), relative (`M83`).
//! - **Travel**: retract the filament, lift the nozzle along its axis by the first hop of
//!   [`PrintProgramOptions::hops`] whose whole way is clear (lift, traverse over to the
//!   next start lifted along its axis, lower), traverse, unretract.
//! - **Collisions**: every pose the machine passes through (each block sampled as the
//!   simulator interpolates it: program point linear, rotation slerp, at most
//!   [`PrintProgramOptions::check_step`] of tip travel apart) is tested with the sampled
//!   nozzle and carriage ([`Tool`], the collision loss's test): a point below the
//!   platform, or inside the part on a layer already printed (`G(q) < g_k - ¼ Δg`), is a
//!   collision. The tip itself is tested on travel moves only (on an extruding move it
//!   sits on its own bead). Before a path is written, each of its points whose pose
//!   collides gets the first clear axis of: turned toward vertical by ¼, ½, ¾ or all of
//!   the way, then 15°, 30°, 45° off its own in eight directions (the layer field's
//!   optimisation samples the nozzle only; the carriage above it is wider).
//! - Moves are split so that no block turns a rotary axis by more than
//!   [`PrintProgramOptions::max_angle_step_deg`]; each rotary block is merged into the move
//!   after it, as in the milling program.

use s2g_gcode::{
    Dialect, ExtrusionMode, FooterRetract, GcodeWriter, Motion, MotionSink, RotaryAxes, WriterOptions,
    rotary_frame,
};
use s2g_geom::{Isometry3, Point3, Vector3};

use super::extract::{PrintLayer, PrintPath};
use super::lattice::Lattice;
use crate::error::{FieldError, Result};
use crate::program::{State, merge_rotary_blocks, tool_axis_angles};
use crate::tool::{Tool, place_tool};

/// How [`print_program`](super::print_program) writes the program. Lengths in mm.
#[derive(Debug, Clone, PartialEq)]
pub struct PrintProgramOptions {
    /// The nozzle and the carriage above it, sampled as points. Default: a nozzle of
    /// radius 2.5 up to 8 mm above the tip, then a carriage of radius 10 for 30 mm,
    /// sampled from 0.5 mm above the tip in rings 1.5 mm apart with 12 points.
    pub nozzle: Tool,
    /// The machine's rotary axes. Default [`RotaryAxes::AC`].
    pub rotary: RotaryAxes,
    /// Filament diameter. Default `1.75`.
    pub filament_diameter: f64,
    /// Printing feed, mm/min. Default `1200`.
    pub feed: f64,
    /// Filament retracted before each travel, mm. Default `0.8`.
    pub retract: f64,
    /// Lifts along the nozzle axis tried in turn for a travel, the first clear one taken.
    /// Default `[1, 3, 10, 30, 60]`.
    pub hops: Vec<f64>,
    /// Tip travel between checked poses. Default `1.0`.
    pub check_step: f64,
    /// Largest change of a rotary angle per block, degrees. Default `2.0`.
    pub max_angle_step_deg: f64,
}

impl Default for PrintProgramOptions {
    fn default() -> Self {
        let cutter = s2g_geom::Cutter {
            shape: s2g_geom::CutterShape::Flat(s2g_geom::Flat),
            radius: 2.5,
            flute_length: 8.0,
            shank_radius: 2.5,
            stickout: 8.0,
            holder: Some(s2g_geom::Holder { radius: 10.0, length: 30.0 }),
        };
        Self {
            nozzle: Tool { cutter, axial_offset: 0.5, axial_step: 1.5, ring_points: 12 },
            rotary: RotaryAxes::AC,
            filament_diameter: 1.75,
            feed: 1200.0,
            retract: 0.8,
            hops: vec![1.0, 3.0, 10.0, 30.0, 60.0],
            check_step: 1.0,
            max_angle_step_deg: 2.0,
        }
    }
}

impl PrintProgramOptions {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        self.nozzle.validate()?;
        FieldError::check_positive(&[
            ("program.filament_diameter", self.filament_diameter),
            ("program.feed", self.feed),
            ("program.check_step", self.check_step),
            ("program.max_angle_step_deg", self.max_angle_step_deg),
        ])?;
        FieldError::check_non_negative(&[("program.retract", self.retract)])?;
        if self.hops.is_empty() || !self.hops.iter().all(|h| h.is_finite() && *h >= 0.0) {
            return Err(FieldError::config("program.hops", "needs at least one finite hop >= 0"));
        }
        Ok(())
    }
}

/// What [`print_program`](super::print_program) wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct PrintProgram {
    /// The G-code text (Marlin words with A/C or B/C rotary words).
    pub text: String,
    /// Layers printed.
    pub layers: usize,
    /// Toolpaths printed.
    pub paths: usize,
    /// Length of the extruding moves.
    pub extruded_length: f64,
    /// Length of the travel moves (tip).
    pub travel_length: f64,
    /// Filament pushed, mm.
    pub filament: f64,
    /// Poses checked along the interpolated path.
    pub poses_checked: usize,
    /// Of them, poses in collision with printed material or the platform.
    pub collisions: usize,
    /// Of them, poses on travel moves (lift, traverse, lower).
    pub travel_collisions: usize,
    /// Travels that needed a higher hop than the first.
    pub raised_hops: usize,
    /// Motion blocks written.
    pub blocks: usize,
}

pub(crate) struct Emitter<'a> {
    opts: &'a PrintProgramOptions,
    lattice: &'a Lattice,
    platform: f64,
    local: Vec<[f64; 3]>,
    writer: GcodeWriter<Vec<u8>>,
    state: Option<State>,
    angles: Option<(f64, f64)>,
    /// The level below which material counts as printed.
    printed_below: f64,
    filament_area: f64,
    bead_width: f64,
    report: PrintProgram,
}

impl<'a> Emitter<'a> {
    pub(crate) fn new(
        opts: &'a PrintProgramOptions,
        lattice: &'a Lattice,
        platform: f64,
        bead_width: f64,
    ) -> Result<Self> {
        opts.validate()?;
        let wopts = WriterOptions {
            rotary: Some(opts.rotary),
            comments: false,
            retract: FooterRetract::None,
            extrusion: ExtrusionMode::Relative,
            ..WriterOptions::default()
        };
        Ok(Self {
            opts,
            lattice,
            platform,
            local: opts.nozzle.points(0.0),
            writer: GcodeWriter::new(Vec::new(), Dialect::Marlin, wopts),
            state: None,
            angles: None,
            printed_below: f64::NEG_INFINITY,
            bead_width,
            filament_area: std::f64::consts::PI * 0.25 * opts.filament_diameter * opts.filament_diameter,
            report: PrintProgram {
                text: String::new(),
                layers: 0,
                paths: 0,
                extruded_length: 0.0,
                travel_length: 0.0,
                filament: 0.0,
                poses_checked: 0,
                collisions: 0,
                travel_collisions: 0,
                raised_hops: 0,
                blocks: 0,
            },
        })
    }

    fn push(&mut self, m: Motion<'_>) -> Result<()> {
        self.writer.motion(&m).map_err(|e| FieldError::Program(e.to_string()))
    }

    fn frame(&self, s: &State) -> Isometry3 {
        match self.opts.rotary {
            RotaryAxes::AC => rotary_frame(self.opts.rotary, [s.tilt, 0.0, s.c]),
            RotaryAxes::BC => rotary_frame(self.opts.rotary, [0.0, s.tilt, s.c]),
        }
    }

    /// The state with the tip at `tip` and the nozzle along `axis`, C unwrapped to the
    /// nearest turn of the current C (kept where the axis is vertical).
    fn state(&self, tip: Point3, axis: &Vector3) -> State {
        let (tilt, c) = tool_axis_angles(self.opts.rotary, axis);
        let prev = self.state.map_or(0.0, |s| s.c);
        let c = if tilt.abs() < 1e-9 { prev } else { c + 360.0 * ((prev - c) / 360.0).round() };
        State { tip, tilt, c }
    }

    /// Whether the tool at `tip` along `axis` hits the platform or printed material.
    fn collides(&self, tip: &Point3, axis: &Vector3, with_tip: bool) -> bool {
        let hit = |q: &Point3| {
            q.z < self.platform - 1e-6
                || (self.lattice.sdf_at(q) < 0.0 && self.lattice.g_at(q) < self.printed_below)
        };
        (with_tip && hit(tip)) || place_tool(tip, axis, &self.local).any(|q| hit(&q))
    }

    /// The poses of one block from `a` to `b` as the machine interpolates it.
    fn block_poses(&self, a: &State, b: &State) -> Vec<(Point3, Vector3)> {
        let (fa, fb) = (self.frame(a), self.frame(b));
        let (pa, pb) = (fa.inverse() * a.tip, fb.inverse() * b.tip);
        let angle = fa.rotation.angle_to(&fb.rotation);
        let reach = pa.coords.norm().max(pb.coords.norm());
        let travel = (b.tip - a.tip).norm() + angle * reach;
        let n = ((travel / self.opts.check_step).ceil() as usize).clamp(1, 1 << 16);
        (1..=n)
            .map(|k| {
                let t = k as f64 / n as f64;
                let r = fa.rotation.slerp(&fb.rotation, t);
                (r * (pa + (pb - pa) * t), r * Vector3::z())
            })
            .collect()
    }

    /// Colliding poses along the moves through `states` (from the current state).
    fn count_way(&self, from: &State, states: &[State], with_tip: bool) -> (usize, usize) {
        let (mut checked, mut hits) = (0, 0);
        let mut prev = *from;
        for s in states {
            for piece in prev.pieces(s, self.opts.max_angle_step_deg) {
                for (tip, axis) in self.block_poses(&prev, &piece) {
                    checked += 1;
                    hits += self.collides(&tip, &axis, with_tip) as usize;
                }
                prev = piece;
            }
        }
        (checked, hits)
    }

    fn setup(&mut self, s: &State) -> Result<()> {
        if self.angles == Some((s.tilt, s.c)) {
            return Ok(());
        }
        self.angles = Some((s.tilt, s.c));
        let rotary = match self.opts.rotary {
            RotaryAxes::AC => [Some(s.tilt), None, Some(s.c)],
            RotaryAxes::BC => [None, Some(s.tilt), Some(s.c)],
        };
        let frame = self.frame(s);
        self.push(Motion::Setup { frame, rotary })
    }

    /// Moves to `states` in turn, split by angle; `extrude` gives the filament of a piece
    /// from its start and end tips (`None`: a rapid).
    fn go(&mut self, states: &[State], thickness: Option<(f64, f64)>) -> Result<()> {
        let Some(mut prev) = self.state else {
            // The first move: put the part in place, then rapid to the first point.
            let s = states[0];
            self.setup(&s)?;
            let to = self.frame(&s).inverse() * s.tip;
            self.report.blocks += 1;
            self.push(Motion::Rapid { to })?;
            self.state = Some(s);
            return self.go(&states[1..], thickness);
        };
        for s in states {
            let pieces = prev.pieces(s, self.opts.max_angle_step_deg);
            let n = pieces.len() as f64;
            for (k, piece) in pieces.iter().enumerate() {
                self.setup(piece)?;
                let to = self.frame(piece).inverse() * piece.tip;
                let len = (piece.tip - prev.tip).norm();
                self.report.blocks += 1;
                match thickness {
                    Some((ta, tb)) => {
                        let t = ta + (tb - ta) * (k as f64 + 0.5) / n;
                        let e = self.bead_width * t * len / self.filament_area;
                        self.report.extruded_length += len;
                        self.report.filament += e;
                        self.push(Motion::Linear { to, feed: self.opts.feed, extrude: Some(e) })?;
                    }
                    None => {
                        self.report.travel_length += len;
                        self.push(Motion::Rapid { to })?;
                    }
                }
                prev = *piece;
            }
        }
        self.state = Some(prev);
        Ok(())
    }
}

impl Emitter<'_> {
    /// The states along `path`, C unwrapped point to point from the current state.
    fn path_states(&mut self, path: &PrintPath) -> Vec<State> {
        let saved = self.state;
        let mut out = Vec::with_capacity(path.points.len());
        for (p, a) in path.points.iter().zip(&path.axes) {
            let s = self.state(*p, a);
            self.state = Some(s);
            out.push(s);
        }
        self.state = saved;
        out
    }

    /// `path` with each point whose nozzle or carriage would hit printed material given
    /// the first clear axis of: the axis turned toward vertical by ¼, ½, ¾ and the whole
    /// way, then axes 15°, 30° and 45° off it in eight directions (the axis kept where
    /// none is clear).
    fn clear_axes(&self, path: &PrintPath) -> PrintPath {
        let mut out = path.clone();
        for (p, a) in out.points.iter().zip(out.axes.iter_mut()) {
            if !self.collides(p, a, false) {
                continue;
            }
            let axis = *a;
            let toward = [0.25, 0.5, 0.75, 1.0].map(|f| {
                (axis * (1.0 - f) + Vector3::z() * f).try_normalize(1e-9).unwrap_or_else(Vector3::z)
            });
            let e1 = a
                .cross(&Vector3::x())
                .try_normalize(1e-6)
                .unwrap_or_else(|| a.cross(&Vector3::y()).normalize());
            let e2 = a.cross(&e1);
            let around = [15.0f64, 30.0, 45.0].into_iter().flat_map(|deg| {
                let (s, c) = deg.to_radians().sin_cos();
                (0..8).map(move |k| {
                    let phi = k as f64 * std::f64::consts::FRAC_PI_4;
                    (axis * c + (e1 * phi.cos() + e2 * phi.sin()) * s).normalize()
                })
            });
            if let Some(b) =
                toward.into_iter().chain(around).find(|b| b.z > 0.0 && !self.collides(p, b, false))
            {
                *a = b;
            }
        }
        out
    }

    fn axis(&self, s: &State) -> Vector3 {
        self.frame(s).rotation * Vector3::z()
    }

    /// Retract, travel to `start` over the first clear hop, unretract.
    fn travel(&mut self, start: State) -> Result<()> {
        let Some(cur) = self.state else {
            let high = *self.opts.hops.last().unwrap_or(&0.0);
            let above = State { tip: start.tip + self.axis(&start) * high, ..start };
            let (checked, hits) = self.count_way(&above, &[start], true);
            self.report.poses_checked += checked;
            self.report.collisions += hits;
            self.report.travel_collisions += hits;
            return self.go(&[above, start], None);
        };
        let here = self.frame(&cur).inverse() * cur.tip;
        if self.opts.retract > 0.0 {
            self.push(Motion::Linear { to: here, feed: self.opts.feed, extrude: Some(-self.opts.retract) })?;
            self.report.filament -= self.opts.retract;
        }
        let mut best: Option<(usize, usize, [State; 3])> = None;
        for (i, &h) in self.opts.hops.iter().enumerate() {
            let lift = State { tip: cur.tip + self.axis(&cur) * h, ..cur };
            let above = State { tip: start.tip + self.axis(&start) * h, ..start };
            let way = [lift, above, start];
            let (checked, hits) = self.count_way(&cur, &way, true);
            if best.as_ref().is_none_or(|b| hits < b.1) {
                best = Some((checked, hits, way));
                if i > 0 && hits == 0 {
                    self.report.raised_hops += 1;
                }
            }
            if hits == 0 {
                break;
            }
        }
        if let Some((checked, hits, way)) = best {
            self.report.poses_checked += checked;
            self.report.collisions += hits;
            self.report.travel_collisions += hits;
            self.go(&way, None)?;
        }
        if self.opts.retract > 0.0 {
            let to = self.frame(&start).inverse() * start.tip;
            self.push(Motion::Linear { to, feed: self.opts.feed, extrude: Some(self.opts.retract) })?;
            self.report.filament += self.opts.retract;
        }
        Ok(())
    }

    /// Prints one layer (level `level`, levels `step` apart) path by path.
    pub(crate) fn layer(&mut self, layer: &PrintLayer, step: f64) -> Result<()> {
        if layer.paths.is_empty() {
            return Ok(());
        }
        self.report.layers += 1;
        self.printed_below = layer.level - 0.25 * step;
        for path in &layer.paths {
            let path = &self.clear_axes(path);
            let states = self.path_states(path);
            self.travel(states[0])?;
            self.report.paths += 1;
            let mut prev = states[0];
            for (k, s) in states.iter().enumerate().skip(1) {
                let (checked, hits) = self.count_way(&prev, std::slice::from_ref(s), false);
                self.report.poses_checked += checked;
                self.report.collisions += hits;
                self.go(std::slice::from_ref(s), Some((path.thickness[k - 1], path.thickness[k])))?;
                prev = *s;
            }
        }
        Ok(())
    }

    /// Finishes the program: the footer, and each rotary block merged into its move.
    pub(crate) fn finish(mut self) -> Result<PrintProgram> {
        self.writer.finish().map_err(|e| FieldError::Program(e.to_string()))?;
        let raw = String::from_utf8_lossy(&self.writer.into_inner()).into_owned();
        self.report.text = merge_rotary_blocks(&raw, self.opts.rotary);
        Ok(self.report)
    }
}
