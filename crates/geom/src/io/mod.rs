//! Mesh files: STL (ASCII and binary), OBJ, glTF/GLB, PLY and 3MF in; binary STL, OBJ,
//! binary PLY and 3MF out.
//!
//! The format comes from the file extension, checked against the content: a file
//! whose bytes clearly say another format (GLB, PLY or ZIP magic, glTF JSON, a binary STL
//! whose size matches its triangle count, an ASCII STL `solid ... facet`) is read as
//! what it is. Loading never panics on malformed input; it returns
//! [`GeomError::Parse`] naming the file, the line where the format has lines, and the
//! defect.

mod gltf;
mod obj;
mod ply;
mod step;
mod stl;
mod threemf;

use std::path::Path;

pub use self::gltf::read_gltf;
pub use self::obj::{read_obj, write_obj};
pub use self::ply::{read_ply, write_ply};
pub use self::step::{save_step, write_step};
pub use self::stl::{read_stl, read_stl_with, write_stl};
pub use self::threemf::{read_3mf, write_3mf};

use crate::atomic::write_atomic;
use crate::error::{GeomError, Result};
use crate::mesh::Mesh;

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MeshFormat {
    /// STL, ASCII or binary (told apart by content).
    Stl,
    /// Wavefront OBJ.
    Obj,
    /// glTF 2.0, JSON (`.gltf`) or binary (`.glb`), told apart by content.
    Gltf,
    /// PLY, ASCII or binary little/big endian.
    Ply,
    /// 3MF (core specification): a ZIP package holding an XML model.
    ThreeMf,
    /// Faceted STEP (ISO 10303-21, AP214): written, not read.
    Step,
}

impl MeshFormat {
    /// The format a file extension names (case-insensitive), if any.
    pub fn from_extension(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "stl" => Self::Stl,
            "obj" => Self::Obj,
            "gltf" | "glb" => Self::Gltf,
            "ply" => Self::Ply,
            "3mf" => Self::ThreeMf,
            "step" | "stp" => Self::Step,
            _ => return None,
        })
    }

    /// The format the content clearly is, from magic bytes and structure; `None` when
    /// the bytes do not decide.
    pub fn sniff(bytes: &[u8]) -> Option<Self> {
        if bytes.starts_with(b"glTF") {
            return Some(Self::Gltf);
        }
        if bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r") {
            return Some(Self::Ply);
        }
        // A ZIP archive: the only one among our formats.
        if bytes.starts_with(b"PK\x03\x04") {
            return Some(Self::ThreeMf);
        }
        if stl::binary_size_matches(bytes) {
            return Some(Self::Stl);
        }
        let text = skip_bom_and_space(bytes);
        if text.starts_with(b"{") && contains(&bytes[..bytes.len().min(4096)], b"\"asset\"") {
            return Some(Self::Gltf);
        }
        if starts_with_ignore_case(text, b"solid") && contains(bytes, b"facet") {
            return Some(Self::Stl);
        }
        None
    }
}

/// How to load a mesh file.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadOptions {
    /// Read the file as this format, skipping detection. Default `None`: from the
    /// extension, overridden by content sniffing where the two disagree.
    pub format: Option<MeshFormat>,
    /// A binary STL whose face counter disagrees with its size is an error by default
    /// (`false`): a larger counter means a truncated file and a smaller one usually
    /// corrupted bytes. With `true` the reader takes as many whole triangles as both
    /// the counter and the data allow.
    pub tolerate_stl_face_count: bool,
    /// Weld bitwise-identical vertex positions of formats that store a triangle soup
    /// (STL), so the mesh shares vertices between faces. Default `true`.
    pub weld_stl: bool,
    /// Accept a file that holds no triangles (giving an empty mesh). Default `false`:
    /// such a file is a [`GeomError::Parse`] error, since no later step can use it.
    pub allow_empty: bool,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self { format: None, tolerate_stl_face_count: false, weld_stl: true, allow_empty: false }
    }
}

/// Loads a mesh with default [`LoadOptions`].
pub fn load_mesh(path: impl AsRef<Path>) -> Result<Mesh> {
    load_mesh_with(path, &LoadOptions::default())
}

/// Loads a mesh (STL, OBJ, glTF/GLB, PLY or 3MF); see the module docs for format detection.
pub fn load_mesh_with(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Mesh> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| GeomError::Io { path: path.to_path_buf(), source })?;
    read_mesh(&bytes, path, options)
}

/// Parses a mesh from the bytes of a file; `path` names the file in errors, gives the
/// extension for format detection and the directory that external glTF buffers are
/// resolved against.
pub fn read_mesh(bytes: &[u8], path: &Path, options: &LoadOptions) -> Result<Mesh> {
    if bytes.is_empty() {
        return Err(parse_error(path, None, "empty file (0 bytes)"));
    }
    let format = match options.format {
        Some(f) => f,
        None => detect_format(bytes, path)?,
    };
    let mesh = match format {
        MeshFormat::Stl => read_stl_with(bytes, path, options)?,
        MeshFormat::Obj => read_obj(bytes, path)?,
        MeshFormat::Gltf => read_gltf(bytes, path)?,
        MeshFormat::Ply => read_ply(bytes, path)?,
        MeshFormat::ThreeMf => read_3mf(bytes, path)?,
        MeshFormat::Step => {
            return Err(GeomError::UnsupportedFormat {
                path: path.to_path_buf(),
                reason: "STEP is written, not read; read STL, OBJ, glTF/GLB, PLY or 3MF".into(),
            });
        }
    };
    if mesh.is_empty() && !options.allow_empty {
        return Err(parse_error(path, None, "the file holds no triangles"));
    }
    Ok(mesh)
}

/// The format of a file: its extension, unless the content clearly says otherwise.
pub fn detect_format(bytes: &[u8], path: &Path) -> Result<MeshFormat> {
    let by_ext = MeshFormat::from_extension(path);
    let sniffed = MeshFormat::sniff(bytes);
    match (by_ext, sniffed) {
        (Some(e), Some(s)) if e != s => Ok(s),
        (Some(e), _) => Ok(e),
        (None, Some(s)) => Ok(s),
        (None, None) => {
            if looks_like_obj(bytes) {
                Ok(MeshFormat::Obj)
            } else {
                Err(GeomError::UnsupportedFormat {
                    path: path.to_path_buf(),
                    reason: "unknown extension and content (expected STL, OBJ, glTF/GLB, PLY or 3MF)".into(),
                })
            }
        }
    }
}

/// Saves a mesh by extension: `.stl` binary STL (f32 coordinates), `.obj` OBJ
/// (shortest exact decimal of every f64), `.ply` binary little-endian PLY (f64
/// coordinates, exact), `.3mf` 3MF in millimetres (shortest exact decimals, one
/// object, deterministic bytes), `.step`/`.stp` faceted STEP (AP214, one faceted B-rep
/// per closed component, voids as `BREP_WITH_VOIDS`, named after the file's stem). The
/// file is written atomically.
pub fn save_mesh(path: impl AsRef<Path>, mesh: &Mesh) -> Result<()> {
    let path = path.as_ref();
    let format = MeshFormat::from_extension(path).ok_or_else(|| GeomError::UnsupportedFormat {
        path: path.to_path_buf(),
        reason: "saving needs a .stl, .obj, .ply, .3mf or .step extension".into(),
    })?;
    save_mesh_as(path, mesh, format)
}

/// Saves a mesh in the given format, atomically (glTF is not written).
pub fn save_mesh_as(path: impl AsRef<Path>, mesh: &Mesh, format: MeshFormat) -> Result<()> {
    let path = path.as_ref();
    match format {
        MeshFormat::Stl => write_atomic(path, |w| write_stl(w, mesh)),
        MeshFormat::Obj => write_atomic(path, |w| write_obj(w, mesh)),
        MeshFormat::Ply => write_atomic(path, |w| write_ply(w, mesh)),
        MeshFormat::ThreeMf => write_atomic(path, |w| write_3mf(w, mesh)),
        MeshFormat::Step => save_step(path, mesh),
        MeshFormat::Gltf => Err(GeomError::UnsupportedFormat {
            path: path.to_path_buf(),
            reason: "glTF is read but not written; save as .stl, .obj, .ply, .3mf or .step".into(),
        }),
    }
}

/// A [`GeomError::Parse`] for `path`.
pub(crate) fn parse_error(path: &Path, line: Option<u64>, message: impl Into<String>) -> GeomError {
    GeomError::Parse { path: path.to_path_buf(), line, message: message.into() }
}

/// Builds a checked mesh, turning a bad index or coordinate into a parse error for `path`.
pub(crate) fn checked_mesh(
    path: &Path,
    vertices: Vec<crate::Point3>,
    triangles: Vec<[u32; 3]>,
) -> Result<Mesh> {
    Mesh::new(vertices, triangles).map_err(|e| match e {
        GeomError::NonFinite { vertex } => {
            parse_error(path, None, format!("vertex {vertex} has a NaN or infinite coordinate"))
        }
        GeomError::BadIndex { triangle, vertex, vertices } => parse_error(
            path,
            None,
            format!("face {triangle} refers to vertex {vertex}, but there are only {vertices} vertices"),
        ),
        other => other,
    })
}

fn skip_bom_and_space(bytes: &[u8]) -> &[u8] {
    let b = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let start = b.iter().position(|c| !c.is_ascii_whitespace()).unwrap_or(b.len());
    &b[start..]
}

fn starts_with_ignore_case(bytes: &[u8], prefix: &[u8]) -> bool {
    bytes.len() >= prefix.len() && bytes[..prefix.len()].eq_ignore_ascii_case(prefix)
}

fn contains(haystack: &[u8], needle: &[u8]) -> bool {
    !needle.is_empty() && haystack.windows(needle.len()).any(|w| w == needle)
}

/// Text whose lines include OBJ vertex records.
fn looks_like_obj(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(1 << 16)];
    std::str::from_utf8(head).is_ok_and(|s| s.lines().any(|l| l.trim_start().starts_with("v ")))
        || head.is_ascii() && contains(head, b"\nv ")
}
