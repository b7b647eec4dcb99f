//! The multi-axis printing program, for either of two five-axis printers
//! ([`PrintProgramOptions::mount`], `s2g-gcode`'s [`RotaryMount`]):
//!
//! - **a tilting and rotating platform** (table-table A/C or B/C) under a vertical nozzle:
//!   the part is turned until the nozzle axis (the layer normal) points up, and X, Y, Z are
//!   the tip in the turned platform's frame;
//! - **a tilting head** (head-head A/C or B/C, same angle conventions) with tool-centre-point
//!   control over a still platform: X, Y, Z are the tip in the part frame and the angles
//!   turn the nozzle about it. Between two poses the tip runs straight in the part frame
//!   (on the platform machine it runs straight in the platform's frame, which turns).
//!
//! - **Extrusion**: `E = w · t · L / (π (d/2)²)` per move (bead width `w`, local layer
//!   thickness `t`, length `L`, filament diameter `d`), relative (`M83`).
//! - **Travel**: retract the filament, lift the nozzle along its axis by the first hop of
//!   [`PrintProgramOptions::hops`] whose whole way is clear (lift, traverse over to the
//!   next start lifted along its axis, lower), else straight up by the first such hop,
//!   else over everything (out to a sphere around the part's box, along it with the
//!   nozzle pointing away from the part, in to the start), else the way with the fewest
//!   colliding poses; unretract.
//! - **Collisions**: every pose the machine passes through (each block sampled as the
//!   simulator interpolates it: program point linear, rotation slerp, at most
//!   [`PrintProgramOptions::check_step`] of tip travel apart) is tested with the sampled
//!   nozzle and carriage ([`Tool`], the collision loss's test): a point below the
//!   platform, or inside the part on a layer already printed (`G(q) < g_k - ¼ Δg`), is a
//!   collision. The tip itself is tested on travel moves only (on an extruding move it
//!   sits on its own bead). Before a path is written, each of its points whose pose
//!   collides gets the clear axis nearest its own among axes on cones 5°, 10°, ..., 90°
//!   around it, about 5° apart on each (toward vertical first), keeping `+Z` above the
//!   platform's plane (the layer field's optimisation samples the nozzle only; the
//!   carriage above it is wider). With [`PrintProgramOptions::skip_unclear`] the segments
//!   along which a pose still collides (a point no axis clears, or the way between two
//!   clear poses) are left out and their length reported as unprintable; the rest of the
//!   path is printed in runs, each after its own travel.
//! - Moves are split so that no block turns a rotary axis by more than
//!   [`PrintProgramOptions::max_angle_step_deg`]; each rotary block is merged into the move
//!   after it, as in the milling program.

use s2g_gcode::{
    Dialect, ExtrusionMode, FooterRetract, GcodeWriter, Motion, MotionSink, RotaryAxes, RotaryMount,
    WriterOptions, rotary_frame,
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
    /// What the rotary axes turn: the platform ([`RotaryMount::Table`], the default) or
    /// the nozzle's head ([`RotaryMount::Head`], tool-centre-point control).
    pub mount: RotaryMount,
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
    /// Leave out the path segments along which a pose collides whatever the axis (no clear
    /// axis at a point, or the way between two clear poses colliding), counted in
    /// [`PrintProgram::unprintable_length`], instead of printing through them. Default
    /// `true`.
    pub skip_unclear: bool,
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
            neck: None,
        };
        Self {
            nozzle: Tool { cutter, axial_offset: 0.5, axial_step: 1.5, ring_points: 12 },
            rotary: RotaryAxes::AC,
            mount: RotaryMount::Table,
            filament_diameter: 1.75,
            feed: 1200.0,
            retract: 0.8,
            hops: vec![1.0, 3.0, 10.0, 30.0, 60.0],
            check_step: 1.0,
            max_angle_step_deg: 2.0,
            skip_unclear: true,
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
    /// Path points whose axis was turned off the layer normal to clear the nozzle.
    pub turned_axes: usize,
    /// Path points with no clear axis (kept on the layer normal).
    pub unclear_points: usize,
    /// Length of the path segments left out as unprintable (a pose along them collides
    /// whatever the axis), with [`PrintProgramOptions::skip_unclear`].
    pub unprintable_length: f64,
}

/// Angular step of the axes tried for a colliding point, degrees.
const AXIS_STEP_DEG: f64 = 5.0;

/// Unit directions around `+Z` (the third coordinate) in rings `step, 2 step, ..., 90°`
/// off it, about `step` apart on each ring, in order of the angle off `+Z` and, on a ring,
/// of the angle from `+X` (`0, +1, -1, +2, ...` steps): `+X` stands for "toward vertical".
fn cone(step_deg: f64) -> Vec<[f64; 3]> {
    let rings = (90.0 / step_deg).round() as usize;
    let mut out = Vec::new();
    for i in 1..=rings {
        let theta = (i as f64 * step_deg).to_radians();
        let n = ((360.0 * theta.sin() / step_deg).round() as usize).max(4);
        let (s, c) = theta.sin_cos();
        for k in 0..n {
            let j = k.div_ceil(2);
            let phi = std::f64::consts::TAU * j as f64 / n as f64 * if k % 2 == 1 { 1.0 } else { -1.0 };
            out.push([s * phi.cos(), s * phi.sin(), c]);
        }
    }
    out
}

/// The directions of `cone` turned onto the axis `a`: `+Z` onto `a`, `+X` onto the way
/// from `a` toward vertical (`+X` projected off `a` where `a` is vertical).
fn axis_candidates<'c>(a: &Vector3, cone: &'c [[f64; 3]]) -> impl Iterator<Item = Vector3> + 'c {
    let a = *a;
    let e1 = (Vector3::z() - a * a.z)
        .try_normalize(1e-6)
        .or_else(|| (Vector3::x() - a * a.x).try_normalize(1e-6))
        .unwrap_or_else(Vector3::y);
    let e2 = a.cross(&e1);
    cone.iter().map(move |q| (e1 * q[0] + e2 * q[1] + a * q[2]).normalize())
}

/// A travel's way (ending at its start) and its poses checked and colliding.
struct Travel {
    checked: usize,
    hits: usize,
    /// Whether it is not the first way tried.
    raised: bool,
    way: Vec<State>,
}

pub(crate) struct Emitter<'a> {
    opts: &'a PrintProgramOptions,
    lattice: &'a Lattice,
    platform: f64,
    local: Vec<[f64; 3]>,
    /// The farthest of `local` from the tip: how far what a tilting head turns reaches.
    head_reach: f64,
    /// [`cone`] of [`AXIS_STEP_DEG`].
    cone: Vec<[f64; 3]>,
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
        let local = opts.nozzle.points(0.0);
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
            head_reach: local.iter().map(|q| Vector3::from(*q).norm()).fold(0.0, f64::max),
            local,
            cone: cone(AXIS_STEP_DEG),
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
                turned_axes: 0,
                unclear_points: 0,
                unprintable_length: 0.0,
            },
        })
    }

    fn push(&mut self, m: Motion<'_>) -> Result<()> {
        self.writer.motion(&m).map_err(FieldError::Write)
    }

    fn frame(&self, s: &State) -> Isometry3 {
        match self.opts.rotary {
            RotaryAxes::AC => rotary_frame(self.opts.rotary, [s.tilt, 0.0, s.c]),
            RotaryAxes::BC => rotary_frame(self.opts.rotary, [0.0, s.tilt, s.c]),
        }
    }

    /// Where the program puts the tip of `s`: in the turned platform's frame, or, on a
    /// head machine, in the part's.
    fn program_point(&self, s: &State) -> Point3 {
        match self.opts.mount {
            RotaryMount::Table => self.frame(s).inverse() * s.tip,
            RotaryMount::Head => s.tip,
        }
    }

    /// The state with the tip at `tip` and the nozzle along `axis`, C unwrapped to the
    /// nearest turn of the current C (kept where the axis is vertical).
    fn state(&self, tip: Point3, axis: &Vector3) -> State {
        self.state_after(tip, axis, self.state.map_or(0.0, |s| s.c))
    }

    /// The pose with the tip at `tip` and the tool along `axis`, its C angle the turn of
    /// the axis's nearest `prev_c` (unchanged where the axis is vertical and C is free).
    fn state_after(&self, tip: Point3, axis: &Vector3, prev_c: f64) -> State {
        let (tilt, c) = tool_axis_angles(self.opts.rotary, axis);
        let c = if tilt.abs() < 1e-9 { prev_c } else { c + 360.0 * ((prev_c - c) / 360.0).round() };
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
    ///
    /// On the platform machine the program point runs straight while the platform turns
    /// (the tip's way in the part frame bends); on a head machine the tip runs straight in
    /// the part frame and the nozzle turns about it. Poses are at most
    /// [`PrintProgramOptions::check_step`] apart at the tip, and at the farthest point of
    /// what turns (the program point's distance from the rotary centre, or the carriage's
    /// top from the tip).
    fn block_poses(&self, a: &State, b: &State) -> Vec<(Point3, Vector3)> {
        let (fa, fb) = (self.frame(a), self.frame(b));
        let (pa, pb) = (self.program_point(a), self.program_point(b));
        let angle = fa.rotation.angle_to(&fb.rotation);
        let reach = match self.opts.mount {
            RotaryMount::Table => pa.coords.norm().max(pb.coords.norm()),
            RotaryMount::Head => self.head_reach,
        };
        let travel = (b.tip - a.tip).norm() + angle * reach;
        let n = ((travel / self.opts.check_step).ceil() as usize).clamp(1, 1 << 16);
        (1..=n)
            .map(|k| {
                let t = k as f64 / n as f64;
                let r = fa.rotation.slerp(&fb.rotation, t);
                let tip = match self.opts.mount {
                    RotaryMount::Table => r * (pa + (pb - pa) * t),
                    RotaryMount::Head => pa + (pb - pa) * t,
                };
                (tip, r * Vector3::z())
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
        match self.opts.mount {
            RotaryMount::Table => self.push(Motion::Setup { frame, rotary }),
            RotaryMount::Head => self.push(Motion::ToolAxis { axis: frame.rotation * Vector3::z(), rotary }),
        }
    }

    /// Moves to `states` in turn, split by angle; `extrude` gives the filament of a piece
    /// from its start and end tips (`None`: a rapid).
    fn go(&mut self, states: &[State], thickness: Option<(f64, f64)>) -> Result<()> {
        let Some(mut prev) = self.state else {
            // The first move: put the part in place, then rapid to the first point.
            let s = states[0];
            self.setup(&s)?;
            let to = self.program_point(&s);
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
                let to = self.program_point(piece);
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
    /// the clear axis nearest its own among [`axis_candidates`] (the axis kept where none
    /// is clear), how many points were turned, and which points stayed unclear.
    fn clear_axes(&self, path: &PrintPath) -> (PrintPath, usize, Vec<bool>) {
        let mut out = path.clone();
        let mut turned = 0;
        let mut unclear = vec![false; path.points.len()];
        for ((p, a), u) in out.points.iter().zip(out.axes.iter_mut()).zip(&mut unclear) {
            if !self.collides(p, a, false) {
                continue;
            }
            match axis_candidates(a, &self.cone).find(|b| b.z > 0.0 && !self.collides(p, b, false)) {
                Some(b) => {
                    *a = b;
                    turned += 1;
                }
                None => *u = true,
            }
        }
        (out, turned, unclear)
    }

    fn axis(&self, s: &State) -> Vector3 {
        self.frame(s).rotation * Vector3::z()
    }

    /// The way of a travel to `start` (module docs): the first way whose poses are all
    /// clear, else the one with the fewest colliding.
    fn travel_way(&self, start: &State) -> Travel {
        let Some(cur) = self.state else {
            let high = *self.opts.hops.last().unwrap_or(&0.0);
            let above = State { tip: start.tip + self.axis(start) * high, ..*start };
            let (checked, hits) = self.count_way(&above, &[*start], true);
            return Travel { checked, hits, raised: false, way: vec![above, *start] };
        };
        let mut best: Option<Travel> = None;
        // Lifts along the nozzle axes first, then straight up.
        let dirs = [(self.axis(&cur), self.axis(start)), (Vector3::z(), Vector3::z())];
        let tries = dirs.iter().flat_map(|d| self.opts.hops.iter().map(move |h| (*d, *h)));
        for (i, ((dc, ds), h)) in tries.enumerate() {
            let lift = State { tip: cur.tip + dc * h, ..cur };
            let above = State { tip: start.tip + ds * h, ..*start };
            let way = vec![lift, above, *start];
            let (checked, hits) = self.count_way(&cur, &way, true);
            if best.as_ref().is_none_or(|b| hits < b.hits) {
                best = Some(Travel { checked, hits, raised: i > 0, way });
            }
            if hits == 0 {
                break;
            }
        }
        if best.as_ref().is_some_and(|b| b.hits > 0) {
            // Over everything: out to a sphere around the whole part, along it, back in.
            let (up, (dc0, ds0)) = (Vector3::z(), dirs[0]);
            for (dc, ds) in [(dc0, ds0), (up, up), (dc0, up), (up, ds0)] {
                let way = self.sphere_way(&cur, start, &dc, &ds);
                let (checked, hits) = self.count_way(&cur, &way, true);
                if best.as_ref().is_none_or(|b| hits < b.hits) {
                    best = Some(Travel { checked, hits, raised: true, way });
                }
                if hits == 0 {
                    break;
                }
            }
        }
        best.unwrap_or(Travel { checked: 0, hits: 0, raised: false, way: vec![*start] })
    }

    /// The way over everything from `cur` to `start`: out along `dc` from `cur`'s tip to
    /// the sphere 2 mm outside the lattice's box, along a great circle of that sphere
    /// (every 10° at most) with the nozzle axis radial, so that nozzle and carriage point
    /// away from the part, in to the point of the sphere along `ds` from `start`, down to
    /// `start`. Directions on the sphere are kept at least 14° above its equator, so the
    /// way never passes under the part.
    fn sphere_way(&self, cur: &State, start: &State, dc: &Vector3, ds: &Vector3) -> Vec<State> {
        let (centre, r) = self.lattice.sphere();
        let radius = r + 2.0;
        // The lift `h >= 0` along unit `d` from `p` that reaches the sphere.
        let exit = |p: &Point3, d: &Vector3| {
            let o = p - centre;
            let b = o.dot(d);
            (-b + (b * b - o.norm_squared() + radius * radius).max(0.0).sqrt()).max(0.0)
        };
        let lift = State { tip: cur.tip + dc * exit(&cur.tip, dc), ..*cur };
        let above = State { tip: start.tip + ds * exit(&start.tip, ds), ..*start };
        let up = |p: &Point3| {
            let mut v = p - centre;
            v.z = v.z.max(0.25 * v.norm());
            v.try_normalize(1e-9).unwrap_or_else(Vector3::z)
        };
        let (u0, u1) = (up(&lift.tip), up(&above.tip));
        let n = (u0.angle(&u1).to_degrees() / 10.0).ceil().max(1.0) as usize;
        let (a0, a1) = (s2g_geom::UnitVector3::new_unchecked(u0), s2g_geom::UnitVector3::new_unchecked(u1));
        let mut way = vec![lift];
        let mut prev = lift;
        for k in 0..=n {
            let u = a0.try_slerp(&a1, k as f64 / n as f64, 1e-9).map_or(u1, |u| u.into_inner());
            prev = self.state_after(centre + u * radius, &u, prev.c);
            way.push(prev);
        }
        way.push(above);
        way.push(*start);
        way
    }

    /// Retract, go along `travel`'s way, unretract.
    fn travel(&mut self, travel: Travel) -> Result<()> {
        self.report.poses_checked += travel.checked;
        self.report.collisions += travel.hits;
        self.report.travel_collisions += travel.hits;
        self.report.raised_hops += (travel.raised && travel.hits == 0) as usize;
        let Some(cur) = self.state else { return self.go(&travel.way, None) };
        let here = self.program_point(&cur);
        if self.opts.retract > 0.0 {
            self.push(Motion::Linear { to: here, feed: self.opts.feed, extrude: Some(-self.opts.retract) })?;
            self.report.filament -= self.opts.retract;
        }
        self.go(&travel.way, None)?;
        if let Some(start) = travel.way.last().filter(|_| self.opts.retract > 0.0) {
            let to = self.program_point(start);
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
            let (path, turned, unclear) = self.clear_axes(path);
            self.report.turned_axes += turned;
            self.report.unclear_points += unclear.iter().filter(|u| **u).count();
            self.print_path(&path, &unclear)?;
        }
        Ok(())
    }

    /// Prints `path` (its axes cleared); with [`PrintProgramOptions::skip_unclear`], only
    /// its runs of segments along which no pose collides, each after its own travel.
    fn print_path(&mut self, path: &PrintPath, unclear: &[bool]) -> Result<()> {
        let states = self.path_states(path);
        // Per segment k (from point k to k + 1): its poses checked and colliding (those
        // after point k), and whether it is left out (a collision, or point k unclear).
        let ways: Vec<(usize, usize)> =
            states.windows(2).map(|w| self.count_way(&w[0], &w[1..], false)).collect();
        let skip: Vec<bool> =
            ways.iter().zip(unclear).map(|(w, u)| self.opts.skip_unclear && (w.1 > 0 || *u)).collect();
        let mut k = 0;
        while k < ways.len() {
            if skip[k] {
                self.report.unprintable_length += (states[k + 1].tip - states[k].tip).norm();
                k += 1;
                continue;
            }
            let mut first = k;
            while k < ways.len() && !skip[k] {
                k += 1;
            }
            // A run whose start pose collides with its tip (the lowering onto it would)
            // starts one segment later.
            while self.opts.skip_unclear && first < k && {
                let s = &states[first];
                self.collides(&s.tip, &self.axis(s), true)
            } {
                self.report.unprintable_length += (states[first + 1].tip - states[first].tip).norm();
                first += 1;
            }
            if first == k {
                continue;
            }
            let travel = self.travel_way(&states[first]);
            self.travel(travel)?;
            self.report.paths += 1;
            for j in first..k {
                self.report.poses_checked += ways[j].0;
                self.report.collisions += ways[j].1;
                self.go(&states[j + 1..j + 2], Some((path.thickness[j], path.thickness[j + 1])))?;
            }
        }
        Ok(())
    }

    /// Finishes the program: the footer, and each rotary block merged into its move.
    pub(crate) fn finish(mut self) -> Result<PrintProgram> {
        self.writer.finish().map_err(FieldError::Write)?;
        let raw = String::from_utf8_lossy(&self.writer.into_inner()).into_owned();
        self.report.text = merge_rotary_blocks(&raw, self.opts.rotary);
        Ok(self.report)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::print::LayerField;
    use s2g_geom::{Aabb, BoxShape};

    /// Bowl layers `G = z + x²/100`: a layer runs 3 mm lower 18 mm out than in the middle.
    struct Bowl;

    impl LayerField for Bowl {
        fn value_gradient(&self, p: &Point3) -> (f64, Vector3) {
            (p.z + 0.01 * p.x * p.x, Vector3::new(0.02 * p.x, 0.0, 1.0))
        }
    }

    /// A travel across a bowl layer from one rim to the other: a 1 mm hop (along the
    /// axes or straight up) runs through the middle, printed up to 3 mm above the rims;
    /// the way over the part's sphere is clear, every pose of it checked.
    #[test]
    fn a_travel_that_no_hop_clears_goes_over_the_part() {
        let part = BoxShape { min: Point3::new(-20.0, 0.0, 0.0), max: Point3::new(20.0, 10.0, 10.0) };
        let bounds = Aabb::new(part.min, part.max);
        let lattice = Lattice::new(&bounds, 0.5, &Bowl, &part).unwrap();
        let opts = PrintProgramOptions { hops: vec![1.0], ..PrintProgramOptions::default() };
        let mut e = Emitter::new(&opts, &lattice, 0.0, 0.5).unwrap();
        e.printed_below = 6.0;
        let level = 6.25;
        let on_layer = |x: f64| Point3::new(x, 5.0, level - 0.01 * x * x);
        let axis = |x: f64| Bowl.value_gradient(&on_layer(x)).1.normalize();
        let cur = e.state(on_layer(-18.0), &axis(-18.0));
        e.state = Some(cur);
        let start = e.state(on_layer(18.0), &axis(18.0));
        assert!(!e.collides(&cur.tip, &axis(-18.0), true) && !e.collides(&start.tip, &axis(18.0), true));
        // Every hop of the options collides on the way.
        for d in [(axis(-18.0), axis(18.0)), (Vector3::z(), Vector3::z())] {
            let way = [State { tip: cur.tip + d.0, ..cur }, State { tip: start.tip + d.1, ..start }, start];
            assert!(e.count_way(&cur, &way, true).1 > 0);
        }
        let travel = e.travel_way(&start);
        assert_eq!(travel.hits, 0);
        assert!(travel.raised && travel.way.len() > 4 && travel.checked > 50, "{}", travel.checked);
        // The way rises above the part's top and ends at the start.
        assert!(travel.way.iter().any(|s| s.tip.z > 12.0));
        assert!((travel.way.last().unwrap().tip - start.tip).norm() < 1e-12);
        assert_eq!(e.count_way(&cur, &travel.way, true), (travel.checked, 0));
    }
}
