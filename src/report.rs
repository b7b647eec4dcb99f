//! The JSON report of a [`Milled`] run.

use serde_json::{Value, json};

use crate::gcode::Coolant;
use crate::pipeline::{Milled, Preset};

fn round(x: f64, decimals: i32) -> f64 {
    let s = 10f64.powi(decimals);
    let r = (x * s).round() / s;
    if r == 0.0 { 0.0 } else { r }
}

fn v3(v: &crate::geom::Vector3) -> Value {
    json!([round(v.x, 6), round(v.y, 6), round(v.z, 6)])
}

impl Milled {
    /// The run as JSON: metrics, safety counts, per-setup parameters, orientation
    /// coverage and rewards. With `timings`, also `stage_seconds` (wall times differ
    /// between runs; without them the report is byte-identical for the same input and seed).
    pub fn report_json(&self, timings: bool) -> Value {
        let sim = &self.simulation;
        let setups: Vec<Value> = self
            .setups
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let mut setup = json!({
                    "index": i + 1,
                    "tool_axis": v3(&s.setup.tool_axis().into_inner()),
                    "tool_radius": s.action.tool_radius,
                    "layer_height": s.action.layer_height,
                    "strategy": s.action.strategy.name(),
                    "layers": s.plan.layers,
                    "cutting_length": round(s.plan.cutting_length, 6),
                    "rapid_length": round(s.plan.rapid_length, 6),
                    "program_lines": s.lines,
                    "gouge_voxels": s.gouge_voxels,
                    "rapid_collision_lines": s.rapid_collision_lines,
                    "holder_collision_lines": s.holder_collision_lines,
                });
                if let Some(k) = s.rest_of {
                    setup["rest_of"] = json!(k);
                }
                if self.preset == Preset::Shop {
                    let t = &s.tool;
                    setup["tool"] = json!({
                        "number": t.number,
                        "diameter": round(t.diameter(), 6),
                        "flute_length": round(t.flute_length(), 6),
                        "spindle_rpm": round(t.spindle_rpm, 3),
                        "feed": round(t.feed, 3),
                        "plunge_feed": round(t.plunge_feed, 3),
                        "coolant": match t.coolant {
                            Coolant::Flood => "flood",
                            Coolant::Mist => "mist",
                            Coolant::Off => "none",
                        },
                    });
                    setup["machine_time_s"] = json!(s.machine_time_s.map(|t| round(t, 3)));
                }
                if let Some(f) = &s.finish {
                    self.finish_json(&mut setup, s, f);
                }
                setup
            })
            .collect();
        let o = &self.orientation;
        let mut report = json!({
            "preset": match self.preset { Preset::Paper => "paper", Preset::Shop => "shop" },
            "policy": self.policy,
            "iou": round(self.metrics.iou, 6),
            "f1": round(self.metrics.f1, 6),
            "chamfer_x1000": round(self.metrics.chamfer_x1000, 6),
            "normal_consistency": round(self.metrics.normal_consistency, 6),
            "machining_time_s": round(sim.machining_time_s, 3),
            "gouge_voxels": sim.gouge_voxels,
            "first_gouge_line": sim.first_gouge_line,
            // The IoU on the simulation grid (voxels of `MillOptions::resolution` along the
            // part's longest side; Eq. 11's R_f), beside `iou` on a 256^3 grid over the unit
            // cube, which cannot resolve a part a few millimetres thick and 200 mm long.
            "grid_iou": round(self.rewards.final_iou, 6),
            "rapid_collisions": self.rapid_collisions(),
            "holder_collisions": sim.holder_collisions.len(),
            "removed_volume": round(sim.removed_volume_mm3, 9),
            "removed_voxels": sim.removed_voxels,
            "rewards": {
                "preservation": round(self.rewards.preservation, 6),
                "final_iou": round(self.rewards.final_iou, 6),
                "mrr": round(self.rewards.mrr, 6),
                "total": round(self.rewards.total, 6),
            },
            "orientation": {
                "coverage": o.coverage.iter().map(|c| round(*c, 6)).collect::<Vec<_>>(),
                "upper_bound": round(o.upper_bound, 6),
                "six_axes": round(o.baselines.six_axes, 6),
                "random5": round(o.baselines.random5, 6),
                "random6": round(o.baselines.random6, 6),
                "plain_greedy": round(o.baselines.plain_greedy, 6),
            },
            "setups": setups,
        });
        self.stock_json(&mut report);
        if self.preset == Preset::Shop {
            // The shop's time is the machine's, acceleration included; the simulator's
            // length / feed stays beside it.
            let machine: Option<f64> = self.setups.iter().map(|s| s.machine_time_s).sum();
            if let Some(t) = machine {
                report["machining_time_s"] = json!(round(t, 3));
                report["feed_time_s"] = json!(round(sim.machining_time_s, 3));
            }
        }
        if let Some(d) = &self.surface_deviation {
            report["surface_deviation"] = json!({
                "max_mm": round(d.max, 6),
                "p99_mm": round(d.p99, 6),
                "mean_mm": round(d.mean, 6),
                "samples": d.samples,
            });
        }
        if timings {
            let t = &self.stage_seconds;
            report["stage_seconds"] = json!({
                "orientation": round(t.orientation, 4),
                "action_selection": round(t.action_selection, 4),
                "gcode_translation": round(t.gcode_translation, 4),
                "simulation": round(t.simulation, 4),
                "scoring": round(t.scoring, 4),
            });
            if self.setups.iter().any(|s| s.finish.is_some()) {
                report["stage_seconds"]["surface_deviation"] = json!(round(t.surface, 4));
            }
        }
        report
    }
}

impl Milled {
    /// A finished setup's fields: its roughing and finishing times, tools, scallop,
    /// finishing strategy and passes, and the finished surface's deviation.
    fn finish_json(
        &self,
        setup: &mut Value,
        s: &crate::pipeline::SetupProgram,
        f: &crate::pipeline::SetupFinish,
    ) {
        let d = &f.deviation;
        setup["roughing_time_s"] = json!(round(f.roughing_time_s, 3));
        setup["finishing_time_s"] = json!(round(f.finishing_time_s, 3));
        setup["tools"] = json!([s.tool.number, f.tool.number]);
        setup["scallop_mm"] = json!(round(f.choice.scallop, 6));
        setup["finish"] = json!({
            "strategy": f.choice.strategy.name(),
            "tool": {
                "number": f.tool.number,
                "shape": match f.tool.cutter.shape {
                    crate::geom::CutterShape::Ball(_) => "ball",
                    crate::geom::CutterShape::BullNose(_) => "bull",
                    crate::geom::CutterShape::Flat(_) => "flat",
                    crate::geom::CutterShape::TSlot(_) => "tslot",
                },
                "diameter": round(f.tool.diameter(), 6),
                "spindle_rpm": round(f.tool.spindle_rpm, 3),
                "feed": round(f.tool.feed, 3),
            },
            "passes": f.summary.passes,
            "links": f.summary.links,
            "retracts": f.summary.retracts,
            "guarded_points": f.summary.guarded_points,
            "cutting_length": round(f.summary.cutting_length, 6),
        });
        setup["surface_deviation"] = json!({
            "max_mm": round(d.max, 6),
            "mean_mm": round(d.mean, 6),
            "gouge_depth_mm": round(d.gouge_depth, 6),
            "columns": d.columns,
            "unpassed_columns": d.unpassed,
            "unpassed_area_mm2": round(d.unpassed_area, 6),
            "unpassed_max_mm": round(d.unpassed_max, 6),
            "gouged": f.gouged(),
        });
    }

    /// The stock, the datum and the stock-removal term in `report`, where the run names a
    /// stock or a datum or the term changed the setups (the paper's runs report none).
    fn stock_json(&self, report: &mut Value) {
        use crate::pipeline::{Datum, Stock};
        if let Some(s) = self.orientation.stock.filter(|s| s.changed) {
            report["orientation"]["stock_removal"] = json!({
                "material_samples": s.material,
                "part_samples": s.part,
                "left_by_visibility": s.left_by_visibility,
                "left": s.left,
                "unreachable": s.unreachable,
            });
        }
        if self.stock_option != Stock::Preset || self.datum.is_some() {
            let b = &self.stock;
            report["stock"] = json!({
                "kind": match self.stock_option {
                    Stock::Preset => "preset",
                    Stock::BoxSize(_) | Stock::BoxCorners { .. } => "box",
                    Stock::Cylinder { .. } => "cylinder",
                },
                "min": v3(&b.min.coords),
                "max": v3(&b.max.coords),
            });
        }
        if let Some(d) = self.datum {
            report["datum"] = json!({
                "kind": match d { Datum::TopCentre => "top-centre", Datum::Corner => "corner" },
                "work_offset": "G54",
                "origins": self.setups.iter().map(|s| v3(&s.setup.frame.translation.vector)).collect::<Vec<_>>(),
            });
        }
    }
}
