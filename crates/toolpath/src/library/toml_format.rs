//! The TOML form of a [`ToolLibrary`] (documented in `assets/tools/default.toml`).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use s2g_gcode::{Coolant, MachineProfile};
use s2g_geom::{Ball, BullNose, Cutter, CutterShape, Flat, Holder, Neck, TSlot};

use super::{CuttingData, LibraryError, LibraryTool, Material, ToolLibrary};

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LibraryToml {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    machine: Option<MachineToml>,
    #[serde(default, rename = "material")]
    materials: Vec<MaterialToml>,
    #[serde(default, rename = "tool")]
    tools: Vec<ToolToml>,
}

/// A [`MachineProfile`]: every field optional, defaults as documented there.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MachineToml {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    max_feed: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    rapid: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    accel: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    junction_deviation: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    spindle_rpm: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    tool_change_s: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    lookahead: Option<usize>,
}

impl MachineToml {
    fn profile(self) -> MachineProfile {
        let d = MachineProfile::default();
        MachineProfile {
            name: self.name.unwrap_or(d.name),
            max_feed: self.max_feed.unwrap_or(d.max_feed),
            rapid: self.rapid.unwrap_or(d.rapid),
            accel: self.accel.unwrap_or(d.accel),
            junction_deviation: self.junction_deviation.unwrap_or(d.junction_deviation),
            spindle_rpm: self.spindle_rpm.unwrap_or(d.spindle_rpm),
            tool_change_s: self.tool_change_s.unwrap_or(d.tool_change_s),
            lookahead: self.lookahead.unwrap_or(d.lookahead),
        }
    }

    fn from_profile(m: &MachineProfile) -> Self {
        Self {
            name: Some(m.name.clone()),
            max_feed: Some(m.max_feed),
            rapid: Some(m.rapid),
            accel: Some(m.accel),
            junction_deviation: Some(m.junction_deviation),
            spindle_rpm: Some(m.spindle_rpm),
            tool_change_s: Some(m.tool_change_s),
            lookahead: Some(m.lookahead),
        }
    }
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialToml {
    name: String,
    #[serde(default)]
    description: String,
    coolant: CoolantToml,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    fallback: Option<CuttingToml>,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum CoolantToml {
    Flood,
    Mist,
    None,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ToolToml {
    number: u32,
    name: String,
    shape: ShapeToml,
    diameter: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    corner_radius: f64,
    flutes: u32,
    flute_length: f64,
    stickout: f64,
    shank_diameter: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    holder: Option<HolderToml>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    neck: Option<NeckToml>,
    #[serde(default)]
    cutting: BTreeMap<String, CuttingToml>,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum ShapeToml {
    Flat,
    Ball,
    Bull,
    Tslot,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct HolderToml {
    diameter: f64,
    length: f64,
}

/// A long-reach end mill's relieved neck: its diameter and the tip to its top.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct NeckToml {
    diameter: f64,
    reach: f64,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CuttingToml {
    vc: f64,
    fz: f64,
    ap: f64,
    ae: f64,
    #[serde(default = "default_plunge")]
    plunge: f64,
}

fn default_plunge() -> f64 {
    0.3
}

impl From<CuttingToml> for CuttingData {
    fn from(c: CuttingToml) -> Self {
        Self {
            surface_speed: c.vc,
            chip_load: c.fz,
            max_axial_depth: c.ap,
            max_radial_depth: c.ae,
            plunge_ratio: c.plunge,
        }
    }
}

impl From<CuttingData> for CuttingToml {
    fn from(c: CuttingData) -> Self {
        Self {
            vc: c.surface_speed,
            fz: c.chip_load,
            ap: c.max_axial_depth,
            ae: c.max_radial_depth,
            plunge: c.plunge_ratio,
        }
    }
}

/// 1-based line and column of byte `offset` in `text`.
pub(super) fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.rfind('\n').map_or(before.len(), |nl| before.len() - nl - 1) + 1;
    (line, column)
}

pub(super) fn parse(text: &str, path: &Path) -> Result<ToolLibrary, LibraryError> {
    let raw: LibraryToml = toml::from_str(text).map_err(|e| {
        let (line, column) = e.span().map_or((1, 1), |s| line_column(text, s.start));
        LibraryError::Parse { path: path.to_path_buf(), line, column, message: e.message().to_string() }
    })?;
    let materials = raw
        .materials
        .into_iter()
        .map(|m| Material {
            name: m.name,
            description: m.description,
            coolant: match m.coolant {
                CoolantToml::Flood => Coolant::Flood,
                CoolantToml::Mist => Coolant::Mist,
                CoolantToml::None => Coolant::Off,
            },
            fallback: m.fallback.map(CuttingData::from),
        })
        .collect();
    let mut tools: Vec<LibraryTool> = raw
        .tools
        .into_iter()
        .map(|t| {
            let shape = match t.shape {
                ShapeToml::Flat => CutterShape::Flat(Flat),
                ShapeToml::Ball => CutterShape::Ball(Ball),
                ShapeToml::Bull => CutterShape::BullNose(BullNose { corner_radius: t.corner_radius }),
                ShapeToml::Tslot => CutterShape::TSlot(TSlot),
            };
            LibraryTool {
                number: t.number,
                name: t.name,
                cutter: Cutter {
                    shape,
                    radius: 0.5 * t.diameter,
                    flute_length: t.flute_length,
                    shank_radius: 0.5 * t.shank_diameter,
                    stickout: t.stickout,
                    holder: t.holder.map(|h| Holder { radius: 0.5 * h.diameter, length: h.length }),
                    neck: t.neck.map(|n| Neck { radius: 0.5 * n.diameter, reach: n.reach }),
                },
                flutes: t.flutes,
                cutting: t.cutting.into_iter().map(|(k, v)| (k, v.into())).collect(),
            }
        })
        .collect();
    tools.sort_by_key(|t| t.number);
    let machine = raw.machine.map(MachineToml::profile);
    let lib = ToolLibrary { machine, materials, tools };
    lib.validate(path)?;
    Ok(lib)
}

pub(super) fn write(lib: &ToolLibrary) -> String {
    let raw = LibraryToml {
        machine: lib.machine.as_ref().map(MachineToml::from_profile),
        materials: lib
            .materials
            .iter()
            .map(|m| MaterialToml {
                name: m.name.clone(),
                description: m.description.clone(),
                coolant: match m.coolant {
                    Coolant::Flood => CoolantToml::Flood,
                    Coolant::Mist => CoolantToml::Mist,
                    Coolant::Off => CoolantToml::None,
                },
                fallback: m.fallback.map(CuttingToml::from),
            })
            .collect(),
        tools: lib
            .tools
            .iter()
            .map(|t| {
                let c = &t.cutter;
                let (shape, corner_radius) = match c.shape {
                    CutterShape::Flat(_) => (ShapeToml::Flat, 0.0),
                    CutterShape::Ball(_) => (ShapeToml::Ball, 0.0),
                    CutterShape::BullNose(b) => (ShapeToml::Bull, b.corner_radius),
                    CutterShape::TSlot(_) => (ShapeToml::Tslot, 0.0),
                };
                ToolToml {
                    number: t.number,
                    name: t.name.clone(),
                    shape,
                    diameter: c.diameter(),
                    corner_radius,
                    flutes: t.flutes,
                    flute_length: c.flute_length,
                    stickout: c.stickout,
                    shank_diameter: 2.0 * c.shank_radius,
                    holder: c.holder.map(|h| HolderToml { diameter: 2.0 * h.radius, length: h.length }),
                    neck: c.neck.map(|n| NeckToml { diameter: 2.0 * n.radius, reach: n.reach }),
                    cutting: t.cutting.iter().map(|(k, v)| (k.clone(), (*v).into())).collect(),
                }
            })
            .collect(),
    };
    let mut out = String::from("# Shape2Gcode tool library (format: assets/tools/default.toml).\n");
    // Serialising plain structs of numbers, strings and maps cannot fail.
    out.push_str(&toml::to_string(&raw).unwrap_or_default());
    out
}
