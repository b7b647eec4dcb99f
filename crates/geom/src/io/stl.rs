//! STL, ASCII and binary.
//!
//! Binary or ASCII is decided by content, not by the header: a file whose size is
//! exactly `84 + 50 n` for the face counter `n` stored at byte 80 is binary even when
//! its 80-byte header starts with `solid` (many exporters write that); otherwise a file
//! starting with `solid` is ASCII and anything else binary.
//!
//! ASCII: any line endings (LF, CRLF, CR), any whitespace, case-insensitive keywords,
//! nameless or multi-word solid names, several solids in one file (merged). Facet
//! normals are ignored (missing, NaN or wrong are all fine): the vertex winding
//! defines the orientation. A missing `endsolid` at the end of the file is accepted
//! (documented fallback: the end of the file closes the solid); a file that ends
//! inside a facet is an error. A facet with other than three vertices is an error
//! naming its line.
//!
//! Binary: a face counter that disagrees with the file size is an error unless
//! [`LoadOptions::tolerate_stl_face_count`] is set. A file that starts with `solid`,
//! fails to parse as ASCII and holds non-ASCII bytes is read as binary.

use std::io::Write;
use std::path::Path;

use super::{LoadOptions, checked_mesh, parse_error};
use crate::check::weld_exact;
use crate::error::Result;
use crate::math::Point3;
use crate::mesh::Mesh;

/// Whether `bytes` are a binary STL whose face counter matches its size exactly.
pub(crate) fn binary_size_matches(bytes: &[u8]) -> bool {
    bytes.len() >= 84 && 84 + 50 * face_counter(bytes) as u64 == bytes.len() as u64
}

fn face_counter(bytes: &[u8]) -> u32 {
    u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]])
}

/// Parses an STL file (ASCII or binary, see the module docs) with default options.
pub fn read_stl(bytes: &[u8], path_for_errors: &Path) -> Result<Mesh> {
    read_stl_with(bytes, path_for_errors, &LoadOptions::default())
}

/// Parses an STL file with the given options (`tolerate_stl_face_count`, `weld_stl`).
pub fn read_stl_with(bytes: &[u8], path: &Path, options: &LoadOptions) -> Result<Mesh> {
    if bytes.is_empty() {
        return Err(parse_error(path, None, "empty file (0 bytes)"));
    }
    let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let first = text.iter().position(|c| !c.is_ascii_whitespace()).unwrap_or(text.len());
    let says_solid = text.len() >= first + 5 && text[first..first + 5].eq_ignore_ascii_case(b"solid");
    let soup = if binary_size_matches(bytes) || !says_solid {
        read_binary(bytes, path, options)?
    } else {
        match read_ascii(text, path) {
            Ok(soup) if !soup.1.is_empty() || bytes.is_ascii() => soup,
            Err(e) if bytes.is_ascii() => return Err(e),
            // Not text after all: a binary STL whose header starts with "solid" but whose
            // size disagrees with its counter. Its binary defect is the better message.
            _ => read_binary(bytes, path, options)?,
        }
    };
    let mesh = checked_mesh(path, soup.0, soup.1)?;
    Ok(if options.weld_stl { weld_exact(&mesh) } else { mesh })
}

type Soup = (Vec<Point3>, Vec<[u32; 3]>);

fn soup_triangles(vertex_count: usize) -> Vec<[u32; 3]> {
    (0..(vertex_count / 3) as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect()
}

fn read_binary(bytes: &[u8], path: &Path, options: &LoadOptions) -> Result<Soup> {
    if bytes.len() < 84 {
        return Err(parse_error(
            path,
            None,
            format!(
                "{} bytes is too short for a binary STL (84-byte header and counter) and the file does \
                 not start with 'solid'",
                bytes.len()
            ),
        ));
    }
    let counter = face_counter(bytes) as u64;
    let available = (bytes.len() as u64 - 84) / 50;
    let leftover = (bytes.len() as u64 - 84) % 50;
    let n = if counter == available && leftover == 0 {
        counter
    } else if options.tolerate_stl_face_count {
        counter.min(available)
    } else {
        return Err(parse_error(
            path,
            None,
            format!(
                "binary STL face counter says {counter} triangles ({} bytes), but the file has {} bytes \
                 ({available} whole triangles{}); the file is truncated or corrupt",
                84 + 50 * counter,
                bytes.len(),
                if leftover > 0 { format!(" and {leftover} stray bytes") } else { String::new() }
            ),
        ));
    };
    let n = n as usize;
    let mut vertices = Vec::with_capacity(3 * n);
    for t in 0..n {
        let rec = &bytes[84 + 50 * t..84 + 50 * (t + 1)];
        for v in 0..3 {
            let off = 12 + 12 * v;
            let f = |i: usize| {
                let o = off + 4 * i;
                f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]]) as f64
            };
            let p = Point3::new(f(0), f(1), f(2));
            if !p.iter().all(|c| c.is_finite()) {
                return Err(parse_error(
                    path,
                    None,
                    format!(
                        "binary STL triangle {t} (byte {}) has a NaN or infinite coordinate",
                        84 + 50 * t
                    ),
                ));
            }
            vertices.push(p);
        }
    }
    let tris = soup_triangles(vertices.len());
    Ok((vertices, tris))
}

/// Whitespace-separated words with their 1-based line numbers; LF, CRLF and CR all
/// end a line.
struct Words<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: u64,
}

impl<'a> Words<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, pos: 0, line: 1 }
    }

    fn skip_space(&mut self) {
        while let Some(&c) = self.bytes.get(self.pos) {
            match c {
                b'\n' => self.line += 1,
                b'\r' => {
                    if self.bytes.get(self.pos + 1) != Some(&b'\n') {
                        self.line += 1;
                    }
                }
                c if c.is_ascii_whitespace() => {}
                _ => return,
            }
            self.pos += 1;
        }
    }

    /// The next word and its line.
    fn next_word(&mut self) -> Option<(&'a [u8], u64)> {
        self.skip_space();
        let start = self.pos;
        while self.bytes.get(self.pos).is_some_and(|c| !c.is_ascii_whitespace()) {
            self.pos += 1;
        }
        (self.pos > start).then(|| (&self.bytes[start..self.pos], self.line))
    }

    /// The next word without consuming it.
    fn peek(&mut self) -> Option<(&'a [u8], u64)> {
        let (pos, line) = (self.pos, self.line);
        let w = self.next_word();
        self.pos = pos;
        self.line = line;
        w
    }

    /// Skips the rest of the current line (a solid's name).
    fn skip_line(&mut self) {
        while let Some(&c) = self.bytes.get(self.pos) {
            if c == b'\n' || c == b'\r' {
                return;
            }
            self.pos += 1;
        }
    }
}

fn is(word: &[u8], keyword: &str) -> bool {
    word.eq_ignore_ascii_case(keyword.as_bytes())
}

fn show(word: &[u8]) -> String {
    let s = String::from_utf8_lossy(&word[..word.len().min(40)]).into_owned();
    if word.len() > 40 { format!("{s}...") } else { s }
}

fn read_ascii(text: &[u8], path: &Path) -> Result<Soup> {
    let mut words = Words::new(text);
    let mut vertices: Vec<Point3> = Vec::new();
    let err = |line: u64, msg: String| parse_error(path, Some(line), msg);
    // Top level: `solid NAME...` { facets } `endsolid NAME...`, repeated.
    while let Some((w, line)) = words.next_word() {
        if !is(w, "solid") {
            return Err(err(line, format!("expected 'solid', found '{}'", show(w))));
        }
        words.skip_line();
        loop {
            let Some((w, line)) = words.next_word() else {
                // Documented fallback: the end of the file closes a solid without `endsolid`.
                return Ok((vertices.clone(), soup_triangles(vertices.len())));
            };
            if is(w, "endsolid") {
                words.skip_line();
                break;
            }
            if !is(w, "facet") {
                return Err(err(line, format!("expected 'facet' or 'endsolid', found '{}'", show(w))));
            }
            let facet_line = line;
            let eof = |what: &str| {
                err(facet_line, format!("the file ends inside the facet that starts here (expected {what})"))
            };
            // Optional `normal nx ny nz`, ignored whatever it holds (NaN included).
            if words.peek().is_some_and(|(w, _)| is(w, "normal")) {
                words.next_word();
                for _ in 0..3 {
                    match words.peek() {
                        Some((w, _)) if !is(w, "outer") => {
                            words.next_word();
                        }
                        _ => break,
                    }
                }
            }
            for kw in ["outer", "loop"] {
                match words.next_word() {
                    Some((w, _)) if is(w, kw) => {}
                    Some((w, l)) => return Err(err(l, format!("expected '{kw}', found '{}'", show(w)))),
                    None => return Err(eof(kw)),
                }
            }
            let mut count = 0usize;
            loop {
                match words.next_word() {
                    Some((w, _)) if is(w, "vertex") => {
                        let mut p = [0.0f64; 3];
                        for c in &mut p {
                            match words.next_word() {
                                Some((w, l)) => {
                                    let v = std::str::from_utf8(w).ok().and_then(|s| s.parse::<f64>().ok());
                                    match v {
                                        Some(v) if v.is_finite() => *c = v,
                                        Some(_) => {
                                            return Err(err(
                                                l,
                                                format!("vertex coordinate '{}' is not finite", show(w)),
                                            ));
                                        }
                                        None => {
                                            return Err(err(
                                                l,
                                                format!("expected a vertex coordinate, found '{}'", show(w)),
                                            ));
                                        }
                                    }
                                }
                                None => return Err(eof("a vertex coordinate")),
                            }
                        }
                        count += 1;
                        if count <= 3 {
                            vertices.push(Point3::from(p));
                        }
                    }
                    Some((w, l)) if is(w, "endloop") => {
                        if count != 3 {
                            return Err(err(
                                facet_line,
                                format!("facet has {count} vertices, expected 3 (its loop ends at line {l})"),
                            ));
                        }
                        break;
                    }
                    Some((w, l)) => {
                        return Err(err(l, format!("expected 'vertex' or 'endloop', found '{}'", show(w))));
                    }
                    None => return Err(eof("'vertex' or 'endloop'")),
                }
            }
            match words.next_word() {
                Some((w, _)) if is(w, "endfacet") => {}
                Some((w, l)) => return Err(err(l, format!("expected 'endfacet', found '{}'", show(w)))),
                None => return Err(eof("'endfacet'")),
            }
        }
    }
    let tris = soup_triangles(vertices.len());
    Ok((vertices, tris))
}

/// Writes binary STL: an 80-byte header, the face count, then per triangle its unit
/// normal (zero for a degenerate one), three f32 corners and a zero attribute word.
/// Coordinates are rounded to f32, as the format stores them.
pub fn write_stl(w: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    let mut header = [b' '; 80];
    let tag = b"binary STL written by s2g-geom";
    header[..tag.len()].copy_from_slice(tag);
    w.write_all(&header)?;
    let n = u32::try_from(mesh.triangles().len())
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, "too many triangles for STL"))?;
    w.write_all(&n.to_le_bytes())?;
    let mut rec = [0u8; 50];
    for t in 0..mesh.triangles().len() {
        let normal = mesh.face_normal(t).unwrap_or_default();
        let corners = mesh.triangle(t);
        let values = std::iter::once(normal).chain(corners.iter().map(|p| p.coords));
        for (i, v) in values.enumerate() {
            for a in 0..3 {
                let o = 12 * i + 4 * a;
                rec[o..o + 4].copy_from_slice(&(v[a] as f32).to_le_bytes());
            }
        }
        w.write_all(&rec)?;
    }
    Ok(())
}
