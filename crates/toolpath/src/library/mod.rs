//! [`ToolLibrary`]: the cutters in a shop's drawer with their cutting data per material,
//! read from a documented TOML file (the shipped default is `assets/tools/default.toml`),
//! from a LinuxCNC tool table or from FreeCAD tool bits, and written back as TOML or as a
//! LinuxCNC tool table.
//!
//! Feeds and speeds come from the cutting data the way a machinist's chart gives them:
//! spindle speed `n = 1000 vc / (π D)` (rpm, from the surface speed `vc` in m/min and the
//! diameter `D` in mm) within the machine's spindle range, and feed `vf = fz z n` (mm/min,
//! from the chip load `fz` per tooth and the flute count `z`) capped by the machine's
//! largest feed ([`LibraryTool::cutting`]). Radial chip thinning is not applied: the feed
//! is the one for a slot, conservative for lighter radial engagement.

mod fctb;
mod linuxcnc;
mod toml_format;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use s2g_gcode::{Coolant, MachineProfile};
use s2g_geom::Cutter;

use crate::Tool;

pub use self::fctb::read_fctb;

/// Everything reading or using a tool library can fail with.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LibraryError {
    /// The file could not be read or written.
    #[error("{path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        #[source]
        source: std::io::Error,
    },
    /// The file is not a library of this format: what is wrong, where.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Parse {
        /// The file (`<memory>` for text).
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A tool or material that cannot exist; the message names it and the field.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file (`<memory>` for text).
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The library has no cutting data for this tool in this material.
    #[error("tool T{tool} ({name}) has no cutting data for material \"{material}\" (it has: {known})")]
    NoCuttingData {
        /// Tool number.
        tool: u32,
        /// Tool name.
        name: String,
        /// The material asked for.
        material: String,
        /// The materials it has data for.
        known: String,
    },
    /// The material is not in the library.
    #[error("unknown material \"{material}\"; the library has: {known}")]
    UnknownMaterial {
        /// The material asked for.
        material: String,
        /// The library's materials.
        known: String,
    },
}

/// Cutting data of one tool in one material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CuttingData {
    /// Surface speed `vc`, m/min.
    pub surface_speed: f64,
    /// Chip load per tooth `fz`, mm.
    pub chip_load: f64,
    /// Largest axial depth of cut `ap`, in tool diameters.
    pub max_axial_depth: f64,
    /// Largest radial depth of cut (stepover) `ae`, in tool diameters.
    pub max_radial_depth: f64,
    /// Plunge and ramp feed as a fraction of the cutting feed.
    pub plunge_ratio: f64,
}

/// A workpiece material: its name (the key of the tools' cutting data) and coolant.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name, e.g. `aluminium-6061`.
    pub name: String,
    /// What a human reads.
    pub description: String,
    /// Coolant to run with: flood (M8), mist (M7) or none ([`Coolant::Off`]).
    pub coolant: Coolant,
    /// Cutting data for tools that have none of their own for this material (imported
    /// tool tables carry none): surface speed (m/min), and chip load as a fraction of the
    /// diameter (`fz = fz_per_diameter D`), with the depth limits and plunge ratio of
    /// [`CuttingData`]. `None`: such tools cannot cut this material.
    pub fallback: Option<CuttingData>,
}

/// One cutter of a library: its number in the machine's magazine, a name, the cutter and
/// its cutting data per material.
#[derive(Debug, Clone, PartialEq)]
pub struct LibraryTool {
    /// Tool number (the T word and the H word of its length offset).
    pub number: u32,
    /// Name, e.g. `6 mm flat end mill, 3 flutes`.
    pub name: String,
    /// The cutter: end shape, radius, flute length, shank, stick-out, holder.
    pub cutter: Cutter,
    /// Number of flutes (teeth).
    pub flutes: u32,
    /// Cutting data per material name.
    pub cutting: BTreeMap<String, CuttingData>,
}

/// What a tool runs at in one material on one machine ([`LibraryTool::cutting`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cutting {
    /// Spindle speed, rpm (within the machine's range).
    pub spindle_rpm: f64,
    /// Cutting feed, mm/min (within the machine's largest feed).
    pub feed: f64,
    /// Plunge and ramp feed, mm/min.
    pub plunge_feed: f64,
    /// Largest axial depth of cut, mm.
    pub max_axial_depth: f64,
    /// Largest radial depth of cut (stepover), mm.
    pub max_radial_depth: f64,
    /// Coolant of the material.
    pub coolant: Coolant,
}

/// A tool library: the machine it is for, tools, and the materials their cutting data
/// refer to.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ToolLibrary {
    /// The machine these tools are fitted to (its `[machine]` table; every field optional,
    /// defaults of [`MachineProfile::default`]). `None`: the file names none.
    pub machine: Option<MachineProfile>,
    /// Materials, by name.
    pub materials: Vec<Material>,
    /// Tools, in ascending number.
    pub tools: Vec<LibraryTool>,
}

impl LibraryTool {
    /// The cutting data of this tool in `material`: its own, or the material's fallback
    /// scaled to its diameter.
    pub fn cutting_data(&self, material: &Material) -> Result<CuttingData, LibraryError> {
        if let Some(c) = self.cutting.get(&material.name) {
            return Ok(*c);
        }
        match material.fallback {
            Some(f) => Ok(CuttingData { chip_load: f.chip_load * self.cutter.diameter(), ..f }),
            None => Err(LibraryError::NoCuttingData {
                tool: self.number,
                name: self.name.clone(),
                material: material.name.clone(),
                known: self.cutting.keys().cloned().collect::<Vec<_>>().join(", "),
            }),
        }
    }

    /// Spindle speed, feeds and depth limits of this tool in `material` on `machine`:
    /// `n = 1000 vc / (π D)` rounded to whole rpm, within the spindle range, `vf = fz z n` capped by the
    /// machine's largest feed, the plunge feed that fraction of it.
    pub fn cutting(&self, material: &Material, machine: &MachineProfile) -> Result<Cutting, LibraryError> {
        let c = self.cutting_data(material)?;
        let d = self.cutter.diameter();
        // A spindle is set in whole revolutions per minute.
        let rpm = machine.clamp_rpm((1000.0 * c.surface_speed / (std::f64::consts::PI * d)).round());
        let feed = (c.chip_load * self.flutes as f64 * rpm).min(machine.max_feed);
        Ok(Cutting {
            spindle_rpm: rpm,
            feed,
            plunge_feed: feed * c.plunge_ratio,
            max_axial_depth: c.max_axial_depth * d,
            max_radial_depth: c.max_radial_depth * d,
            coolant: material.coolant,
        })
    }

    /// The planner's [`Tool`]: this cutter at its cutting data in `material` on `machine`.
    pub fn tool(&self, material: &Material, machine: &MachineProfile) -> Result<Tool, LibraryError> {
        let c = self.cutting(material, machine)?;
        Ok(Tool {
            cutter: self.cutter,
            feed: c.feed,
            plunge_feed: c.plunge_feed,
            spindle_rpm: c.spindle_rpm,
            number: self.number,
            coolant: c.coolant,
        })
    }
}

impl ToolLibrary {
    /// Reads a library: TOML (`.toml`, the format of `assets/tools/default.toml`), a
    /// LinuxCNC tool table (`.tbl`) or a FreeCAD tool bit (`.fctb`), by extension.
    pub fn load(path: &Path) -> Result<Self, LibraryError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| LibraryError::Io { path: path.to_path_buf(), source })?;
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("tbl") => Self::from_linuxcnc_table(&text, path),
            Some("fctb") => read_fctb(&text, path).map(|tool| Self { tools: vec![tool], ..Self::default() }),
            _ => Self::from_toml(&text, path),
        }
    }

    /// Parses the TOML format; `path` names the source in errors.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, LibraryError> {
        toml_format::parse(text, path)
    }

    /// The library as TOML, in the format [`from_toml`](Self::from_toml) reads back to
    /// the same value.
    pub fn to_toml(&self) -> String {
        toml_format::write(self)
    }

    /// Reads a LinuxCNC tool table (see [`to_linuxcnc_table`](Self::to_linuxcnc_table)).
    pub fn from_linuxcnc_table(text: &str, path: &Path) -> Result<Self, LibraryError> {
        linuxcnc::parse(text, path)
    }

    /// The library as a LinuxCNC tool table: one line a tool, `T<n> P<n> D<diameter>
    /// Z+0.000000 ;<name>`, so a program written with this library runs in `rs274 -t` and
    /// on a machine with the same numbers (tool length offsets are measured at the
    /// machine: Z is 0 here).
    pub fn to_linuxcnc_table(&self) -> String {
        linuxcnc::write(self)
    }

    /// The material called `name`.
    pub fn material(&self, name: &str) -> Result<&Material, LibraryError> {
        self.materials.iter().find(|m| m.name == name).ok_or_else(|| LibraryError::UnknownMaterial {
            material: name.to_string(),
            known: self.materials.iter().map(|m| m.name.as_str()).collect::<Vec<_>>().join(", "),
        })
    }

    /// The tool numbered `number`.
    pub fn tool(&self, number: u32) -> Option<&LibraryTool> {
        self.tools.iter().find(|t| t.number == number)
    }

    /// Adds `other`'s machine, materials and tools; a machine, or a tool or material of
    /// the same number or name, replaces this library's.
    pub fn merge(&mut self, other: ToolLibrary) {
        if other.machine.is_some() {
            self.machine = other.machine;
        }
        for m in other.materials {
            self.materials.retain(|x| x.name != m.name);
            self.materials.push(m);
        }
        for t in other.tools {
            self.tools.retain(|x| x.number != t.number);
            self.tools.push(t);
        }
        self.tools.sort_by_key(|t| t.number);
    }

    /// Checks every tool and material; the message names the tool or material and field.
    pub fn validate(&self, path: &Path) -> Result<(), LibraryError> {
        let bad = |message: String| Err(LibraryError::Invalid { path: path.to_path_buf(), message });
        if let Some(m) = &self.machine
            && let Err(e) = m.validate()
        {
            return bad(format!("machine: {e}"));
        }
        let mut numbers = std::collections::BTreeSet::new();
        for t in &self.tools {
            if t.number == 0 {
                return bad(format!(
                    "tool \"{}\": number must be at least 1 (T0 is the empty spindle)",
                    t.name
                ));
            }
            if !numbers.insert(t.number) {
                return bad(format!("tool T{}: the number is used twice", t.number));
            }
            if let Err(e) = t.cutter.validate() {
                return bad(format!("tool T{} ({}): {e}", t.number, t.name));
            }
            if t.flutes == 0 {
                return bad(format!("tool T{} ({}): flutes must be at least 1", t.number, t.name));
            }
            for (m, c) in &t.cutting {
                if let Err(e) = check_cutting(c) {
                    return bad(format!("tool T{} ({}), material {m}: {e}", t.number, t.name));
                }
            }
        }
        let mut names = std::collections::BTreeSet::new();
        for m in &self.materials {
            if m.name.is_empty() || !names.insert(m.name.as_str()) {
                return bad(format!("material \"{}\": names must be unique and not empty", m.name));
            }
            if let Some(c) = &m.fallback
                && let Err(e) = check_cutting(c)
            {
                return bad(format!("material {}: {e}", m.name));
            }
        }
        Ok(())
    }
}

fn check_cutting(c: &CuttingData) -> Result<(), String> {
    for (name, v) in [
        ("vc", c.surface_speed),
        ("fz", c.chip_load),
        ("ap", c.max_axial_depth),
        ("ae", c.max_radial_depth),
        ("plunge", c.plunge_ratio),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("{name} must be positive and finite, got {v}"));
        }
    }
    if c.max_radial_depth > 1.0 {
        return Err(format!("ae must be at most 1 diameter, got {}", c.max_radial_depth));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
