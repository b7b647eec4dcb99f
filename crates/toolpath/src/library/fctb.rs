//! FreeCAD tool bits (`.fctb`, FreeCAD's Path/CAM workbench, format version 2): a JSON
//! object naming a shape template and its dimensions as quantities (`"6.000 mm"`).
//!
//! Read: the `endmill`, `ballend` and `bullnose` shapes (`Diameter`, `CuttingEdgeHeight`,
//! `Length`, `ShankDiameter`, `FlatRadius` for the bull nose, `Flutes` where given, else
//! 2), in mm or inches. Other shapes (chamfer, v-bit, drill, probe, dovetail, slitting
//! saw, thread mill) are refused with an error naming the shape. A bit has no number (a
//! FreeCAD library binds numbers to bits): it reads as tool 1, without cutting data (a
//! material's fallback applies).

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::Value;

use s2g_geom::{Ball, BullNose, Cutter, CutterShape, Flat};

use super::toml_format::line_column;
use super::{LibraryError, LibraryTool};

/// Reads one FreeCAD tool bit; `path` names the source in errors.
pub fn read_fctb(text: &str, path: &Path) -> Result<LibraryTool, LibraryError> {
    let parse = |line: usize, column: usize, message: String| LibraryError::Parse {
        path: path.to_path_buf(),
        line,
        column,
        message,
    };
    let json: Value = serde_json::from_str(text).map_err(|e| parse(e.line(), e.column(), e.to_string()))?;
    // Errors about a key point at its first mention in the text.
    let at = |key: &str| text.find(&format!("\"{key}\"")).map_or((1, 1), |offset| line_column(text, offset));
    let invalid = |key: &str, message: String| {
        let (line, column) = at(key);
        parse(line, column, message)
    };
    let shape_name =
        json.get("shape").and_then(Value::as_str).ok_or_else(|| invalid("shape", "no \"shape\"".into()))?;
    let stem = shape_name.trim_end_matches(".fcstd").to_ascii_lowercase();
    let params = json
        .get("parameter")
        .and_then(Value::as_object)
        .ok_or_else(|| invalid("parameter", "no \"parameter\" object".into()))?;
    let length = |key: &str| -> Result<Option<f64>, LibraryError> {
        match params.get(key) {
            None => Ok(None),
            Some(v) => quantity_mm(v).map(Some).map_err(|m| invalid(key, format!("{key}: {m}"))),
        }
    };
    let need =
        |key: &str| length(key)?.ok_or_else(|| invalid("parameter", format!("no \"{key}\" parameter")));
    let diameter = need("Diameter")?;
    let shape = match stem.as_str() {
        "endmill" => CutterShape::Flat(Flat),
        "ballend" => CutterShape::Ball(Ball),
        "bullnose" => {
            let flat = need("FlatRadius")?;
            CutterShape::BullNose(BullNose { corner_radius: 0.5 * diameter - flat })
        }
        other => {
            return Err(invalid(
                "shape",
                format!("tool shape \"{other}\" is not supported (endmill, ballend and bullnose are)"),
            ));
        }
    };
    let flute_length = need("CuttingEdgeHeight")?;
    let stickout = length("Length")?.unwrap_or(flute_length).max(flute_length);
    let shank = length("ShankDiameter")?.unwrap_or(diameter);
    let flutes = match params.get("Flutes").or_else(|| json.get("attribute").and_then(|a| a.get("Flutes"))) {
        None => 2,
        Some(v) => {
            let n = v.as_f64().or_else(|| v.as_str().and_then(|s| s.trim().parse().ok()));
            match n {
                Some(n) if n >= 1.0 && n.fract() == 0.0 && n <= 64.0 => n as u32,
                _ => return Err(invalid("Flutes", format!("Flutes must be a whole number 1-64, got {v}"))),
            }
        }
    };
    let name = json.get("name").and_then(Value::as_str).unwrap_or(shape_name).to_string();
    let tool = LibraryTool {
        number: 1,
        name,
        cutter: Cutter {
            shape,
            radius: 0.5 * diameter,
            flute_length,
            shank_radius: 0.5 * shank,
            stickout,
            holder: None,
            neck: None,
        },
        flutes,
        cutting: BTreeMap::new(),
    };
    tool.cutter.validate().map_err(|e| LibraryError::Invalid {
        path: path.to_path_buf(),
        message: format!("{}: {e}", tool.name),
    })?;
    Ok(tool)
}

/// A FreeCAD length quantity in mm: `"6.000 mm"`, `"0.25 in"`, `"0.25\""` or a bare number
/// (mm).
fn quantity_mm(v: &Value) -> Result<f64, String> {
    let (value, scale) = match v {
        Value::Number(n) => (n.as_f64().unwrap_or(f64::NAN), 1.0),
        Value::String(s) => {
            let s = s.trim();
            let split = s
                .find(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'e' | 'E')))
                .unwrap_or(s.len());
            let (num, unit) = s.split_at(split);
            let scale = match unit.trim() {
                "" | "mm" => 1.0,
                "cm" => 10.0,
                "m" => 1000.0,
                "in" | "\"" | "inch" => 25.4,
                other => return Err(format!("unknown length unit \"{other}\" in \"{s}\"")),
            };
            (num.parse::<f64>().map_err(|_| format!("\"{s}\" is not a length"))?, scale)
        }
        other => return Err(format!("{other} is not a length")),
    };
    if value.is_finite() && value >= 0.0 {
        Ok(value * scale)
    } else {
        Err(format!("{v} is not a finite, non-negative length"))
    }
}
