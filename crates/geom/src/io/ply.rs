//! PLY: ASCII, binary little endian and binary big endian, read with a small reader of
//! our own. The `vertex` element's `x`, `y`, `z` and the `face` element's
//! `vertex_indices` (or `vertex_index`) list are used; other elements and properties
//! are skipped. Polygons are fan-triangulated. Writing is binary little endian with
//! f64 coordinates, so a save/load round trip is exact.

use std::io::Write;
use std::path::Path;

use super::{checked_mesh, parse_error};
use crate::error::{GeomError, Result};
use crate::math::Point3;
use crate::mesh::Mesh;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }
}

#[derive(Debug, Clone)]
enum Prop {
    Scalar(Ty, String),
    List(Ty, Ty, String),
}

impl Prop {
    fn name(&self) -> &str {
        match self {
            Prop::Scalar(_, n) | Prop::List(_, _, n) => n,
        }
    }
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// Reads values of one element instance after another, ASCII or binary.
enum Body<'a> {
    Ascii { words: std::str::SplitAsciiWhitespace<'a>, lines: LineTracker<'a> },
    Binary { bytes: &'a [u8], pos: usize, big: bool },
}

/// For ASCII bodies: maps a word back to its line for error messages.
struct LineTracker<'a> {
    text: &'a str,
    first_line: u64,
}

impl LineTracker<'_> {
    fn line_of(&self, word: &str) -> u64 {
        let offset = (word.as_ptr() as usize).saturating_sub(self.text.as_ptr() as usize);
        let offset = offset.min(self.text.len());
        self.first_line + self.text.as_bytes()[..offset].iter().filter(|&&c| c == b'\n').count() as u64
    }
}

impl Body<'_> {
    /// Reads one value; `Err(message, line)` on a defect.
    fn read(&mut self, ty: Ty) -> std::result::Result<f64, (String, Option<u64>)> {
        match self {
            Body::Ascii { words, lines } => {
                let w = words
                    .next()
                    .ok_or_else(|| ("the file ends before all elements are read".into(), None))?;
                let v: f64 =
                    w.parse().map_err(|_| (format!("'{w}' is not a number"), Some(lines.line_of(w))))?;
                if ty.is_integer() && v.fract() != 0.0 {
                    return Err((format!("'{w}' should be an integer"), Some(lines.line_of(w))));
                }
                Ok(v)
            }
            Body::Binary { bytes, pos, big } => {
                let n = ty.size();
                let Some(b) = bytes.get(*pos..*pos + n) else {
                    return Err((
                        format!("the file ends at byte {} before all elements are read", bytes.len()),
                        None,
                    ));
                };
                *pos += n;
                let mut a = [0u8; 8];
                a[..n].copy_from_slice(b);
                if *big {
                    a[..n].reverse();
                }
                Ok(match ty {
                    Ty::I8 => a[0] as i8 as f64,
                    Ty::U8 => a[0] as f64,
                    Ty::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
                    Ty::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
                    Ty::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Ty::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Ty::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Ty::F64 => f64::from_le_bytes(a),
                })
            }
        }
    }

    fn remaining_hint(&self) -> usize {
        match self {
            Body::Ascii { lines, .. } => lines.text.len(),
            Body::Binary { bytes, pos, .. } => bytes.len().saturating_sub(*pos),
        }
    }
}

/// Reads the header: ASCII lines up to and including `end_header`. Returns the encoding,
/// the elements, where the body starts and the header's last line number.
fn read_header(bytes: &[u8], path: &Path) -> Result<(Encoding, Vec<Element>, usize, u64)> {
    let err = |line: Option<u64>, msg: String| parse_error(path, line, msg);
    // The header is ASCII lines up to and including `end_header`.
    let mut pos = 0usize;
    let mut line_no = 0u64;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(rel) = bytes[pos..].iter().position(|&c| c == b'\n') else {
            return Err(err(Some(line_no + 1), "the header has no 'end_header' line".into()));
        };
        let raw = &bytes[pos..pos + rel];
        pos += rel + 1;
        line_no += 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| err(Some(line_no), "the header is not text".into()))?
            .trim_end_matches('\r');
        let mut words = line.split_ascii_whitespace();
        let Some(first) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        if line_no == 1 {
            if first != "ply" {
                return Err(err(Some(1), "not a PLY file (the first line is not 'ply')".into()));
            }
            continue;
        }
        match first {
            "format" => {
                encoding = Some(match rest.first().copied() {
                    Some("ascii") => Encoding::Ascii,
                    Some("binary_little_endian") => Encoding::Little,
                    Some("binary_big_endian") => Encoding::Big,
                    other => {
                        return Err(err(
                            Some(line_no),
                            format!("unknown PLY format {:?}", other.unwrap_or("")),
                        ));
                    }
                });
            }
            "comment" | "obj_info" => {}
            "element" => {
                let (Some(name), Some(count)) = (rest.first(), rest.get(1)) else {
                    return Err(err(Some(line_no), "an element needs a name and a count".into()));
                };
                let count = count
                    .parse::<usize>()
                    .map_err(|_| err(Some(line_no), format!("element count '{count}' is not a number")))?;
                elements.push(Element { name: (*name).to_string(), count, props: Vec::new() });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(err(Some(line_no), "a property before any element".into()));
                };
                let ty = |s: &str| {
                    Ty::parse(s).ok_or_else(|| err(Some(line_no), format!("unknown property type '{s}'")))
                };
                let prop = match rest.as_slice() {
                    ["list", count_ty, item_ty, name] => {
                        let count_ty = ty(count_ty)?;
                        if !count_ty.is_integer() {
                            return Err(err(Some(line_no), "a list count must have an integer type".into()));
                        }
                        Prop::List(count_ty, ty(item_ty)?, (*name).to_string())
                    }
                    [t, name] => Prop::Scalar(ty(t)?, (*name).to_string()),
                    _ => return Err(err(Some(line_no), format!("malformed property line '{line}'"))),
                };
                element.props.push(prop);
            }
            "end_header" => break,
            other => return Err(err(Some(line_no), format!("unknown header keyword '{other}'"))),
        }
    }
    let encoding = encoding.ok_or_else(|| err(None, "the header has no 'format' line".into()))?;
    Ok((encoding, elements, pos, line_no))
}

/// Parses a PLY file (see the module docs).
pub fn read_ply(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let err = |line: Option<u64>, msg: String| parse_error(path, line, msg);
    if !bytes.starts_with(b"ply") {
        return Err(err(Some(1), "not a PLY file (it does not start with 'ply')".into()));
    }
    let (encoding, elements, pos, line_no) = read_header(bytes, path)?;
    let body_bytes = &bytes[pos..];
    let mut body = match encoding {
        Encoding::Ascii => {
            let text = std::str::from_utf8(body_bytes)
                .map_err(|_| err(None, "the ASCII body is not text".into()))?;
            Body::Ascii {
                words: text.split_ascii_whitespace(),
                lines: LineTracker { text, first_line: line_no + 1 },
            }
        }
        Encoding::Little | Encoding::Big => {
            Body::Binary { bytes: body_bytes, pos: 0, big: encoding == Encoding::Big }
        }
    };

    let mut vertices: Vec<Point3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut vertex_count = None;
    let to_err = |(msg, line): (String, Option<u64>)| err(line, msg);
    let mut polygon: Vec<f64> = Vec::new();
    for element in &elements {
        let is_vertex = element.name == "vertex";
        let is_face = element.name == "face";
        let xyz = ["x", "y", "z"].map(|n| element.props.iter().position(|p| p.name() == n));
        let index_list =
            element.props.iter().position(|p| p.name() == "vertex_indices" || p.name() == "vertex_index");
        if is_vertex && xyz.iter().any(Option::is_none) {
            return Err(err(None, "the vertex element lacks an x, y or z property".into()));
        }
        // Every instance takes at least one byte (or character), which bounds honest counts.
        if element.count > body.remaining_hint() && !element.props.is_empty() {
            return Err(err(
                None,
                format!(
                    "element '{}' claims {} instances, more than the file can hold",
                    element.name, element.count
                ),
            ));
        }
        if element.props.is_empty() {
            // Nothing to read, however many instances are claimed.
            continue;
        }
        if is_vertex {
            vertices.reserve(element.count);
            vertex_count = Some(element.count);
        }
        for instance in 0..element.count {
            let mut p = [0.0f64; 3];
            for (k, prop) in element.props.iter().enumerate() {
                match prop {
                    Prop::Scalar(ty, _) => {
                        let v = body.read(*ty).map_err(to_err)?;
                        if is_vertex {
                            for a in 0..3 {
                                if xyz[a] == Some(k) {
                                    p[a] = v;
                                }
                            }
                        }
                    }
                    Prop::List(count_ty, item_ty, _) => {
                        let n = body.read(*count_ty).map_err(to_err)?;
                        if !(0.0..=1e6).contains(&n) {
                            return Err(err(
                                None,
                                format!("{} {instance} has a list of {n} items", element.name),
                            ));
                        }
                        polygon.clear();
                        for _ in 0..n as usize {
                            polygon.push(body.read(*item_ty).map_err(to_err)?);
                        }
                        if is_face && index_list == Some(k) {
                            if polygon.len() < 3 {
                                return Err(err(
                                    None,
                                    format!(
                                        "face {instance} has {} vertices, at least 3 needed",
                                        polygon.len()
                                    ),
                                ));
                            }
                            let idx = |v: f64| {
                                if v >= 0.0 && v <= u32::MAX as f64 && v.fract() == 0.0 {
                                    Ok(v as u32)
                                } else {
                                    Err(err(
                                        None,
                                        format!("face {instance} has the invalid vertex index {v}"),
                                    ))
                                }
                            };
                            let a = idx(polygon[0])?;
                            for w in polygon[1..].windows(2) {
                                triangles.push([a, idx(w[0])?, idx(w[1])?]);
                            }
                        }
                    }
                }
            }
            if is_vertex {
                vertices.push(Point3::from(p));
            }
        }
    }
    if vertex_count.is_none() && !triangles.is_empty() {
        return Err(GeomError::Parse {
            path: path.to_path_buf(),
            line: None,
            message: "faces but no vertex element".into(),
        });
    }
    checked_mesh(path, vertices, triangles)
}

/// Writes binary little-endian PLY: `vertex` with double `x y z`, `face` with a
/// `uchar`-counted `int` list `vertex_indices`.
pub fn write_ply(w: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\ncomment written by s2g-geom\nelement vertex {}\n\
         property double x\nproperty double y\nproperty double z\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        mesh.vertices().len(),
        mesh.triangles().len()
    )?;
    for p in mesh.vertices() {
        for a in 0..3 {
            w.write_all(&p[a].to_le_bytes())?;
        }
    }
    for t in mesh.triangles() {
        w.write_all(&[3u8])?;
        for &i in t {
            let i = i32::try_from(i).map_err(|_| {
                std::io::Error::new(std::io::ErrorKind::InvalidInput, "vertex index too large for PLY")
            })?;
            w.write_all(&i.to_le_bytes())?;
        }
    }
    Ok(())
}
