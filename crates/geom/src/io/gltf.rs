//! glTF 2.0, JSON (`.gltf`) or binary (`.glb`), through the `gltf` crate's document
//! model. Buffers are resolved here (the crate's `import` feature is off): the GLB
//! binary chunk, `data:` URIs in base64, and external files relative to the glTF
//! file. Accessors are read by our own bounds-checked code (strides, sparse
//! accessors, normalised integer positions).
//!
//! Every primitive of mode triangles, triangle strip or triangle fan under the nodes
//! of the default scene (or the first scene; without scenes, every root node; without
//! nodes, every mesh untransformed) is placed by its node's world transform (the
//! matrix or TRS of each node composed down the hierarchy), and all are merged into
//! one mesh. A transform with a negative determinant mirrors, so its triangles'
//! winding is reversed to keep them facing outwards. Points and lines are skipped.

use std::path::Path;

use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use nalgebra::{Matrix4, Vector4};

use super::{checked_mesh, parse_error};
use crate::error::{GeomError, Result};
use crate::math::Point3;
use crate::mesh::Mesh;

/// Parses a glTF (JSON) or GLB file; `path` locates external buffers and names the
/// file in errors.
pub fn read_gltf(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let err = |msg: String| parse_error(path, None, msg);
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| err(format!("invalid glTF: {e}")))?;
    let doc = &gltf.document;

    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for buffer in doc.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                err(format!("buffer {} refers to a GLB binary chunk, but there is none", buffer.index()))
            })?,
            gltf::buffer::Source::Uri(uri) => resolve_uri(uri, path, buffer.index())?,
        };
        if data.len() < buffer.length() {
            return Err(err(format!(
                "buffer {} declares {} bytes but only {} are available",
                buffer.index(),
                buffer.length(),
                data.len()
            )));
        }
        buffers.push(data);
    }

    let mut out = Builder { vertices: Vec::new(), triangles: Vec::new() };
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let roots: Vec<gltf::Node<'_>> = match scene {
        Some(ref s) => s.nodes().collect(),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    if roots.is_empty() && scene.is_none() {
        for mesh in doc.meshes() {
            add_mesh(&mut out, &mesh, &Matrix4::identity(), &buffers, path)?;
        }
    }
    // Depth-first with an explicit stack; a node cycle (invalid glTF) would never end,
    // so the depth is bounded by the number of nodes.
    let max_depth = doc.nodes().len();
    let mut stack: Vec<(gltf::Node<'_>, Matrix4<f64>, usize)> =
        roots.into_iter().rev().map(|n| (n, Matrix4::identity(), 0)).collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > max_depth {
            return Err(err("the node hierarchy has a cycle".into()));
        }
        let m = node.transform().matrix();
        let local = Matrix4::from_fn(|r, c| m[c][r] as f64);
        let world = parent * local;
        if let Some(mesh) = node.mesh() {
            add_mesh(&mut out, &mesh, &world, &buffers, path)?;
        }
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world, depth + 1));
        }
    }
    checked_mesh(path, out.vertices, out.triangles)
}

struct Builder {
    vertices: Vec<Point3>,
    triangles: Vec<[u32; 3]>,
}

fn add_mesh(
    out: &mut Builder,
    mesh: &gltf::Mesh<'_>,
    world: &Matrix4<f64>,
    buffers: &[Vec<u8>],
    path: &Path,
) -> Result<()> {
    let mirrored = world.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
    for prim in mesh.primitives() {
        let mode = prim.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            continue;
        }
        let what = format!("mesh {} primitive {}", mesh.index(), prim.index());
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            return Err(parse_error(path, None, format!("{what} has no POSITION attribute")));
        };
        if pos_acc.dimensions() != Dimensions::Vec3 {
            return Err(parse_error(path, None, format!("{what}: POSITION is not VEC3")));
        }
        let pos = read_accessor(&pos_acc, 3, buffers, path)?;
        let n_pos = pos.len() / 3;
        let indices: Vec<u32> = match prim.indices() {
            Some(acc) => {
                if acc.dimensions() != Dimensions::Scalar
                    || !matches!(acc.data_type(), DataType::U8 | DataType::U16 | DataType::U32)
                {
                    return Err(parse_error(path, None, format!("{what}: indices must be unsigned scalars")));
                }
                read_accessor(&acc, 1, buffers, path)?.into_iter().map(|v| v as u32).collect()
            }
            None => (0..n_pos as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n_pos) {
            return Err(parse_error(
                path,
                None,
                format!("{what}: index {bad} is out of range ({n_pos} positions)"),
            ));
        }
        let base = out.vertices.len() as u32;
        for p in pos.chunks_exact(3) {
            let q = world * Vector4::new(p[0], p[1], p[2], 1.0);
            let w = if q.w != 0.0 { q.w } else { 1.0 };
            out.vertices.push(Point3::new(q.x / w, q.y / w, q.z / w));
        }
        let mut push = |a: u32, b: u32, c: u32| {
            let t = if mirrored { [a, c, b] } else { [a, b, c] };
            out.triangles.push(t.map(|i| base + i));
        };
        match mode {
            Mode::Triangles => {
                for t in indices.chunks_exact(3) {
                    push(t[0], t[1], t[2]);
                }
            }
            Mode::TriangleStrip => {
                for (i, w) in indices.windows(3).enumerate() {
                    // Repeated indices stitch strips together: not real triangles.
                    if w[0] == w[1] || w[1] == w[2] || w[0] == w[2] {
                        continue;
                    }
                    if i % 2 == 0 { push(w[0], w[1], w[2]) } else { push(w[1], w[0], w[2]) }
                }
            }
            Mode::TriangleFan => {
                if let Some((&first, rest)) = indices.split_first() {
                    for w in rest.windows(2) {
                        push(first, w[0], w[1]);
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// The most elements of an accessor without a buffer view (2^26).
const MAX_SPARSE_BASE: usize = 1 << 26;

/// Reads an accessor as f64 values, `comps` per element, honouring byte stride,
/// sparse substitution and the normalised flag; every read is bounds-checked.
fn read_accessor(
    acc: &gltf::Accessor<'_>,
    comps: usize,
    buffers: &[Vec<u8>],
    path: &Path,
) -> Result<Vec<f64>> {
    let what = format!("accessor {}", acc.index());
    let err = |msg: String| parse_error(path, None, format!("{what}: {msg}"));
    let ty = acc.data_type();
    let csize = ty.size();
    let elem = csize * comps;
    let count = acc.count();
    let normalized = acc.normalized();
    let decode = |b: &[u8]| -> f64 {
        let v = match ty {
            DataType::I8 => b[0] as i8 as f64,
            DataType::U8 => b[0] as f64,
            DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        };
        // Normalised integers map to [0, 1] or [-1, 1] (glTF 2.0 §3.11).
        if normalized {
            match ty {
                DataType::I8 => (v / 127.0).max(-1.0),
                DataType::U8 => v / 255.0,
                DataType::I16 => (v / 32767.0).max(-1.0),
                DataType::U16 => v / 65535.0,
                _ => v,
            }
        } else {
            v
        }
    };
    let view_bytes = |view: &gltf::buffer::View<'_>| -> Result<&[u8]> {
        let buf = buffers
            .get(view.buffer().index())
            .ok_or_else(|| err(format!("buffer {} is missing", view.buffer().index())))?;
        let end = view.offset().checked_add(view.length()).filter(|&e| e <= buf.len());
        end.map(|e| &buf[view.offset()..e])
            .ok_or_else(|| err(format!("buffer view {} lies outside its buffer", view.index())))
    };
    // Reads `n` elements of `elem` bytes each from `bytes` at `offset` with `stride`.
    let read_elems =
        |bytes: &[u8], offset: usize, stride: usize, n: usize, out: &mut Vec<f64>| -> Result<()> {
            if n > 0 {
                let last = (n - 1)
                    .checked_mul(stride)
                    .and_then(|x| x.checked_add(offset))
                    .and_then(|x| x.checked_add(elem));
                if last.is_none_or(|l| l > bytes.len()) {
                    return Err(err(format!("{n} elements do not fit in their buffer view")));
                }
            }
            out.reserve(n * comps);
            for i in 0..n {
                let o = offset + i * stride;
                for c in 0..comps {
                    out.push(decode(&bytes[o + c * csize..o + (c + 1) * csize]));
                }
            }
            Ok(())
        };
    let mut values = Vec::new();
    match acc.view() {
        Some(view) => {
            let stride = view.stride().unwrap_or(elem);
            if stride < elem {
                return Err(err(format!("byte stride {stride} is smaller than an element ({elem} bytes)")));
            }
            read_elems(view_bytes(&view)?, acc.offset(), stride, count, &mut values)?;
        }
        None => {
            // Only a sparse accessor may lack a view (its base is zeros); bound the
            // allocation so a hostile count cannot exhaust memory.
            if count > MAX_SPARSE_BASE {
                return Err(err(format!("{count} elements without a buffer view is too many")));
            }
            values.resize(count * comps, 0.0);
        }
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        let iv = sparse.indices();
        let isize = match iv.index_type() {
            gltf::accessor::sparse::IndexType::U8 => 1,
            gltf::accessor::sparse::IndexType::U16 => 2,
            gltf::accessor::sparse::IndexType::U32 => 4,
        };
        let ibytes = view_bytes(&iv.view())?;
        let ioff = iv.offset();
        if n > 0 && n.checked_mul(isize).and_then(|b| b.checked_add(ioff)).is_none_or(|e| e > ibytes.len()) {
            return Err(err("sparse indices do not fit in their buffer view".into()));
        }
        let vv = sparse.values();
        let mut subst = Vec::new();
        read_elems(view_bytes(&vv.view())?, vv.offset(), elem, n, &mut subst)?;
        for k in 0..n {
            let b = &ibytes[ioff + k * isize..ioff + (k + 1) * isize];
            let idx = match isize {
                1 => b[0] as usize,
                2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
            };
            if idx >= count {
                return Err(err(format!("sparse index {idx} is out of range ({count} elements)")));
            }
            values[idx * comps..(idx + 1) * comps].copy_from_slice(&subst[k * comps..(k + 1) * comps]);
        }
    }
    Ok(values)
}

/// The bytes of a buffer URI: a base64 `data:` URI or a file relative to the glTF file.
fn resolve_uri(uri: &str, gltf_path: &Path, index: usize) -> Result<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(parse_error(
                gltf_path,
                None,
                format!("buffer {index}: only base64 data URIs are supported"),
            ));
        };
        return decode_base64(payload).ok_or_else(|| {
            parse_error(gltf_path, None, format!("buffer {index}: invalid base64 in data URI"))
        });
    }
    if uri.contains("://") {
        return Err(parse_error(
            gltf_path,
            None,
            format!("buffer {index}: remote URI '{uri}' is not fetched"),
        ));
    }
    let rel = percent_decode(uri);
    let file = gltf_path.parent().unwrap_or(Path::new("")).join(rel);
    std::fs::read(&file).map_err(|source| GeomError::Io { path: file, source })
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let Some(v) =
                std::str::from_utf8(&b[i + 1..i + 3]).ok().and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (RFC 4648, `+` and `/`), padding optional, whitespace ignored.
fn decode_base64(s: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    let mut acc = 0u32;
    let mut bits = 0;
    for c in s.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' => break,
            c if c.is_ascii_whitespace() => continue,
            _ => return None,
        };
        acc = (acc << 6) | v as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_known_strings() {
        assert_eq!(decode_base64("TWFu").as_deref(), Some(&b"Man"[..]));
        assert_eq!(decode_base64("TWE=").as_deref(), Some(&b"Ma"[..]));
        assert_eq!(decode_base64("TQ==").as_deref(), Some(&b"M"[..]));
        assert_eq!(decode_base64("").as_deref(), Some(&b""[..]));
        assert!(decode_base64("T*Q=").is_none());
    }

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("my%20file.bin"), "my file.bin");
        assert_eq!(percent_decode("a%2"), "a%2");
    }
}
