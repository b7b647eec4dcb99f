//! Extrusion spines (seed 004, §2.1-2.2): the continuous extrusion paths of an
//! FDM program, each with its layer, feature type and per-segment volume.
//!
//! # Rules
//!
//! * [`SpineRule::PaperFlags`] is the paper's rule. §2.1 flags each G-code line:
//!   1 for `G1`, 2 for `G0`, 3 for a `LAYER` comment. Table 1 keeps the segment
//!   from line *i* to line *i + 1* exactly when line *i + 1* has flag 1 (pairs
//!   3-1, 1-1, 2-1: scenario A) and closes the open spine otherwise (1-2, 2-2,
//!   2-3, 1-3, 3-2: scenario B). So every `G1`/`G2`/`G3` that moves is treated as
//!   extruding (a `G1` that does not move, such as a retraction, adds nothing and
//!   breaks nothing), every `G0` and layer change ends a spine. Segment volumes are
//!   still the moves' E increments (zero on travels, negative on wipes).
//! * [`SpineRule::ExtrusionIncrement`] (default) extrudes on a move iff its E
//!   increment exceeds [`SpineOptions::min_extrusion`] and it moves in XY.
//!   PrusaSlicer and Slic3r travel with `G1` moves that carry no E word, which the
//!   paper's rule counts as printed (so its spines jump across travels); this rule
//!   does not. Retractions (negative E) and `G92 E0` resets are resolved by the
//!   parser into per-move increments.
//!
//! Under both rules a spine also breaks on a layer change and a feature-type
//! change (`;TYPE:`); under the increment rule also on every non-extruding move,
//! retractions included.
//!
//! # Layers
//!
//! When the program carries layer markers (`;LAYER:n`, `;LAYER_CHANGE`, `;Z:`),
//! a marker starts a new layer only once something was extruded since the
//! previous one (so `;LAYER_CHANGE` followed by `;Z:` is one layer, and a purge
//! line printed before the first marker belongs to layer 0). Without markers
//! (Slic3r), a new layer starts whenever an extruding move's Z differs from the
//! previous extruding move's Z by more than [`SpineOptions::layer_z_tolerance`].

use std::convert::Infallible;
use std::f64::consts::PI;

use nalgebra::Point3;

use crate::arc::ArcSpec;
use crate::motion::{Marker, Motion, MotionSink};

/// Which moves count as extruding; see the [module docs](self).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum SpineRule {
    /// Seed 004 Table 1: every feed move (`G1`) extrudes, `G0` and layer changes break.
    PaperFlags,
    /// Extruding iff E increases by more than [`SpineOptions::min_extrusion`] on a move with XY length.
    #[default]
    ExtrusionIncrement,
}

/// Options of [`SpineBuilder`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpineOptions {
    /// Extrusion rule. Default [`SpineRule::ExtrusionIncrement`].
    pub rule: SpineRule,
    /// Filament diameter in mm, for volumes. Default 1.75.
    pub filament_diameter: f64,
    /// Smallest E increment (mm of filament) that counts as extrusion. Default 1e-9.
    pub min_extrusion: f64,
    /// Z change (mm) between extruding moves that starts a layer when the program has no markers. Default 1e-3.
    pub layer_z_tolerance: f64,
    /// Smallest XY length (mm) of an extruding move. Default 1e-9.
    pub min_xy_length: f64,
    /// Chordal tolerance (mm) for arcs in spines. Default 0.01.
    pub arc_tolerance: f64,
}

impl Default for SpineOptions {
    fn default() -> Self {
        SpineOptions {
            rule: SpineRule::ExtrusionIncrement,
            filament_diameter: 1.75,
            min_extrusion: 1e-9,
            layer_z_tolerance: 1e-3,
            min_xy_length: 1e-9,
            arc_tolerance: 0.01,
        }
    }
}

/// One continuous extrusion path.
#[derive(Debug, Clone, PartialEq)]
pub struct Spine {
    /// Path points (at least two).
    pub points: Vec<Point3<f64>>,
    /// Zero-based layer index.
    pub layer: usize,
    /// The slicer's feature type (`;TYPE:` value) in force, if any.
    pub kind: Option<String>,
    /// Extruded filament volume (mm^3) per segment: `E * pi * (d / 2)^2`; `points.len() - 1` entries.
    pub volumes: Vec<f64>,
}

impl Spine {
    /// Total extruded volume (mm^3).
    pub fn volume(&self) -> f64 {
        self.volumes.iter().sum()
    }

    /// Path length (mm).
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| (w[1] - w[0]).norm()).sum()
    }
}

/// A [`MotionSink`] that collects [`Spine`]s from an FDM program.
#[derive(Debug, Clone)]
pub struct SpineBuilder {
    opts: SpineOptions,
    area: f64,
    pos: Option<Point3<f64>>,
    open: Option<Spine>,
    /// Closed spines with their marker layer and Z layer.
    done: Vec<(Spine, usize, usize)>,
    open_layers: (usize, usize),
    kind: Option<String>,
    markers_seen: bool,
    marker_layer: usize,
    extruded_since_marker: bool,
    z_layer: Option<usize>,
    last_z: f64,
}

impl Default for SpineBuilder {
    fn default() -> Self {
        SpineBuilder::new(SpineOptions::default())
    }
}

impl SpineBuilder {
    /// A builder with `opts`.
    pub fn new(opts: SpineOptions) -> Self {
        let r = opts.filament_diameter * 0.5;
        SpineBuilder {
            opts,
            area: if r.is_finite() && r > 0.0 { PI * r * r } else { 0.0 },
            pos: None,
            open: None,
            done: Vec::new(),
            open_layers: (0, 0),
            kind: None,
            markers_seen: false,
            marker_layer: 0,
            extruded_since_marker: false,
            z_layer: None,
            last_z: f64::NAN,
        }
    }

    fn close(&mut self) {
        if let Some(s) = self.open.take()
            && s.points.len() >= 2
        {
            self.done.push((s, self.open_layers.0, self.open_layers.1));
        }
    }

    /// Adds a segment to `to` with filament `e` (mm) when extruding, or breaks.
    fn segment(&mut self, to: Point3<f64>, e: f64, extruding: bool) {
        let Some(from) = self.pos else {
            self.pos = Some(to);
            return;
        };
        self.pos = Some(to);
        if !extruding {
            self.close();
            return;
        }
        // Z-based layer count (used when the program has no markers), driven by
        // moves that really push filament so that travels counted as printed by
        // the paper's rule (z-hops) do not start layers.
        let zl = if e > self.opts.min_extrusion {
            let z = from.z.max(to.z);
            let zl = match self.z_layer {
                None => 0,
                Some(l) if (z - self.last_z).abs() > self.opts.layer_z_tolerance => l + 1,
                Some(l) => l,
            };
            self.last_z = z;
            zl
        } else {
            self.z_layer.unwrap_or(0)
        };
        if !self.markers_seen && self.z_layer.is_some_and(|l| l != zl) && self.open.is_some() {
            self.close();
        }
        self.z_layer = Some(zl);
        self.extruded_since_marker = true;
        let layers = (self.marker_layer, zl);
        if self.open.is_none() {
            self.open =
                Some(Spine { points: vec![from], layer: 0, kind: self.kind.clone(), volumes: Vec::new() });
            self.open_layers = layers;
        }
        if let Some(s) = self.open.as_mut() {
            s.points.push(to);
            s.volumes.push(e * self.area);
        }
    }

    fn is_extruding(&self, from: Option<Point3<f64>>, to: Point3<f64>, extrude: Option<f64>) -> bool {
        let e = extrude.unwrap_or(0.0);
        let xy = from.map_or(0.0, |f| (to.x - f.x).hypot(to.y - f.y));
        match self.opts.rule {
            SpineRule::PaperFlags => from.is_some_and(|f| f != to),
            SpineRule::ExtrusionIncrement => e > self.opts.min_extrusion && xy > self.opts.min_xy_length,
        }
    }

    /// Number of layers holding spines so far.
    pub fn layer_count(&self) -> usize {
        let mut s = self.clone();
        s.close();
        s.into_spines().iter().map(|s| s.layer + 1).max().unwrap_or(0)
    }

    /// Closes the open spine and returns every spine in program order, with
    /// layers assigned (markers when the program had any, Z changes otherwise).
    pub fn into_spines(mut self) -> Vec<Spine> {
        self.close();
        let markers = self.markers_seen;
        self.done
            .into_iter()
            .map(|(mut s, ml, zl)| {
                s.layer = if markers { ml } else { zl };
                s
            })
            .collect()
    }
}

impl MotionSink for SpineBuilder {
    type Error = Infallible;

    fn motion(&mut self, motion: &Motion<'_>) -> Result<(), Infallible> {
        match motion {
            Motion::Rapid { to } => self.segment(*to, 0.0, false),
            Motion::Linear { to, extrude, .. } => {
                if self.opts.rule == SpineRule::PaperFlags && self.pos == Some(*to) {
                    // A G1 that does not move (retract, unretract, feed change) adds
                    // no point and, being flag 1, does not break the spine.
                    return Ok(());
                }
                let ext = self.is_extruding(self.pos, *to, *extrude);
                self.segment(*to, extrude.unwrap_or(0.0), ext);
            }
            Motion::Arc { to, extrude, .. } => {
                let Some(start) = self.pos else {
                    self.pos = Some(*to);
                    return Ok(());
                };
                let ext = self.is_extruding(Some(start), *to, *extrude)
                    || (self.opts.rule == SpineRule::ExtrusionIncrement
                        && extrude.unwrap_or(0.0) > self.opts.min_extrusion);
                let Some(spec) = ArcSpec::from_motion(start, motion) else { return Ok(()) };
                let mut pts = Vec::new();
                if spec.linearize(self.opts.arc_tolerance, |p| pts.push(p)).is_err() {
                    // Degenerate arc or tolerance: fall back to its chord.
                    pts.clear();
                    pts.push(*to);
                }
                let n = pts.len() as f64;
                let e = extrude.unwrap_or(0.0) / n;
                for p in pts {
                    self.segment(p, e, ext);
                }
            }
            Motion::Marker(Marker::Layer { .. }) => {
                self.close();
                if self.markers_seen && self.extruded_since_marker {
                    self.marker_layer += 1;
                }
                self.markers_seen = true;
                self.extruded_since_marker = false;
            }
            Motion::Marker(Marker::Type(t)) => {
                self.close();
                self.kind = Some(t.to_string());
            }
            Motion::Setup { .. } => {
                self.close();
                self.pos = None;
            }
            _ => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::borrow::Cow;

    fn lin(x: f64, y: f64, z: f64, e: Option<f64>) -> Motion<'static> {
        Motion::Linear { to: Point3::new(x, y, z), feed: 1200.0, extrude: e }
    }

    #[test]
    fn rules_differ_on_g1_travel() {
        let prog = [
            Motion::Rapid { to: Point3::new(0.0, 0.0, 0.2) },
            lin(10.0, 0.0, 0.2, Some(0.5)),
            lin(10.0, 10.0, 0.2, Some(0.5)),
            lin(0.0, 10.0, 0.2, None), // travel as G1 without E (PrusaSlicer)
            lin(0.0, 20.0, 0.2, Some(0.5)),
            lin(0.0, 20.0, 0.2, Some(-2.0)), // retraction
            Motion::Marker(Marker::Type(Cow::Borrowed("Infill"))),
            lin(5.0, 20.0, 0.2, Some(0.25)),
        ];
        let run = |rule| {
            let mut b = SpineBuilder::new(SpineOptions { rule, ..Default::default() });
            for m in &prog {
                let _ = b.motion(m);
            }
            b.into_spines()
        };
        let inc = run(SpineRule::ExtrusionIncrement);
        assert_eq!(inc.len(), 3, "{inc:?}");
        assert_eq!(inc[0].points.len(), 3);
        assert_eq!(inc[2].kind.as_deref(), Some("Infill"));
        let area = PI * 0.875 * 0.875;
        assert!((inc[0].volume() - area).abs() < 1e-12);
        let paper = run(SpineRule::PaperFlags);
        // The G1 travel joins the first two spines; the retraction does not move so it adds nothing.
        assert_eq!(paper.len(), 2, "{paper:?}");
        assert_eq!(paper[0].points.len(), 5);
    }

    #[test]
    fn z_layers_without_markers_and_merged_markers() {
        let mut b = SpineBuilder::default();
        for (i, z) in [0.2, 0.4, 0.6].into_iter().enumerate() {
            let _ = b.motion(&Motion::Rapid { to: Point3::new(0.0, 0.0, z) });
            let _ = b.motion(&lin(1.0 + i as f64, 0.0, z, Some(0.1)));
        }
        assert_eq!(b.layer_count(), 3);
        let mut m = SpineBuilder::default();
        for z in [0.2, 0.4] {
            let _ = m.motion(&Motion::Marker(Marker::Layer { index: None, z: None }));
            let _ = m.motion(&Motion::Marker(Marker::Layer { index: None, z: Some(z) }));
            let _ = m.motion(&Motion::Rapid { to: Point3::new(0.0, 0.0, z) });
            let _ = m.motion(&lin(1.0, 0.0, z, Some(0.1)));
        }
        let s = m.into_spines();
        assert_eq!(s.iter().map(|s| s.layer).collect::<Vec<_>>(), [0, 1]);
    }
}
