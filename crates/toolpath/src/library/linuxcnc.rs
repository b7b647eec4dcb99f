//! LinuxCNC tool tables (`tool.tbl`): `T<n> P<pocket> [X Y Z A B C U V W offsets] D<diameter>
//! [I J Q lathe words] ;comment`, one tool a line.
//!
//! A table holds a number, a diameter and offsets, not a cutter: an imported tool is a flat
//! end mill (a ball end mill where its comment says "ball") with flutes 3 D long, a shank
//! of its diameter, a stick-out of 4 D, two flutes, no holder, and no cutting data of its
//! own (a material's fallback data applies). Lines with no positive `D` (probes, length
//! references) are left out.
//!
//! Written, a tool is its number, pocket, cutting diameter (what cutter compensation
//! needs) and zero length offset, its name the comment. The table has no column for a
//! long-reach end mill's neck (nor flute length, shank or holder): the library's name says
//! it ("2 mm long-reach flat end mill, neck 1.9 mm to 12 mm"), and a table read back
//! gives a plain end mill of that diameter. A T-slot cutter likewise: its disc's diameter,
//! the name saying the thickness and neck ("21 x 9 mm T-slot cutter, neck 10 mm to 30 mm").

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use s2g_geom::{Ball, Cutter, CutterShape, Flat};

use super::{LibraryError, LibraryTool, ToolLibrary};

pub(super) fn parse(text: &str, path: &Path) -> Result<ToolLibrary, LibraryError> {
    let mut tools = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let (words, comment) = match raw.find(';') {
            Some(at) => (&raw[..at], raw[at + 1..].trim()),
            None => (raw, ""),
        };
        let err = |column: usize, message: String| LibraryError::Parse {
            path: path.to_path_buf(),
            line: i + 1,
            column,
            message,
        };
        let (mut number, mut diameter) = (None, None);
        let mut rest = words;
        while let Some(start) = rest.find(|c: char| !c.is_whitespace()) {
            let column = words.len() - rest.len() + start + 1;
            let word = &rest[start..];
            let end = word.find(char::is_whitespace).unwrap_or(word.len());
            let (token, after) = word.split_at(end);
            rest = after;
            let mut chars = token.chars();
            let letter = chars.next().map(|c| c.to_ascii_uppercase()).unwrap_or(' ');
            let value: f64 = chars
                .as_str()
                .parse()
                .map_err(|_| err(column, format!("\"{token}\": not a letter and a number")))?;
            if !value.is_finite() {
                return Err(err(column, format!("\"{token}\": not finite")));
            }
            match letter {
                'T' => {
                    if !(value >= 1.0 && value.fract() == 0.0 && value <= u32::MAX as f64) {
                        return Err(err(
                            column,
                            format!("tool number must be a positive integer, got {token}"),
                        ));
                    }
                    number = Some(value as u32);
                }
                'D' => diameter = Some(value),
                'P' | 'X' | 'Y' | 'Z' | 'A' | 'B' | 'C' | 'U' | 'V' | 'W' | 'I' | 'J' | 'Q' => {}
                _ => return Err(err(column, format!("\"{token}\": no such tool table word"))),
            }
        }
        let Some(number) = number else {
            if words.trim().is_empty() {
                continue;
            }
            return Err(err(1, "a tool line needs a T word".into()));
        };
        let Some(d) = diameter.filter(|d| *d > 0.0) else { continue };
        let ball = comment.to_ascii_lowercase().contains("ball");
        let shape = if ball { CutterShape::Ball(Ball) } else { CutterShape::Flat(Flat) };
        let name = if comment.is_empty() { format!("T{number} D{d}") } else { comment.to_string() };
        tools.push(LibraryTool {
            number,
            name,
            cutter: Cutter {
                shape,
                radius: 0.5 * d,
                flute_length: 3.0 * d,
                shank_radius: 0.5 * d,
                stickout: 4.0 * d,
                holder: None,
                neck: None,
            },
            flutes: 2,
            cutting: BTreeMap::new(),
        });
    }
    tools.sort_by_key(|t| t.number);
    let lib = ToolLibrary { tools, ..ToolLibrary::default() };
    lib.validate(path)?;
    Ok(lib)
}

pub(super) fn write(lib: &ToolLibrary) -> String {
    let mut out = String::new();
    for t in &lib.tools {
        // A comment ends the line: keep the name on it.
        let name: String = t.name.chars().map(|c| if c == '\n' || c == '\r' { ' ' } else { c }).collect();
        let _ = writeln!(out, "T{0} P{0} D{1:.6} Z+0.000000 ;{2}", t.number, t.cutter.diameter(), name);
    }
    out
}
