//! Wavefront OBJ through `tobj`: polygons fan-triangulated, every object and group
//! merged into one mesh; materials, normals and texture coordinates are ignored.

use std::io::Write;
use std::path::Path;

use super::{checked_mesh, parse_error};
use crate::error::Result;
use crate::math::Point3;
use crate::mesh::Mesh;

/// Parses an OBJ file. Points and lines are skipped; faces are triangulated as fans.
pub fn read_obj(bytes: &[u8], path: &Path) -> Result<Mesh> {
    let options =
        tobj::LoadOptions { single_index: false, triangulate: true, ignore_points: true, ignore_lines: true };
    let mut reader = std::io::BufReader::new(bytes);
    // Materials are not needed; a missing .mtl must not fail the load.
    // tobj has a few internal unwraps; a panic there becomes a parse error.
    let loaded = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
        tobj::load_obj_buf(&mut reader, &options, |_| Err(tobj::LoadError::OpenFileFailed))
    }));
    let (models, _materials) = match loaded {
        Ok(Ok(m)) => m,
        Ok(Err(e)) => return Err(parse_error(path, None, format!("invalid OBJ: {e}"))),
        Err(_) => return Err(parse_error(path, None, "invalid OBJ (the OBJ reader gave up)")),
    };
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = vertices.len() as u64;
        vertices.extend(m.positions.chunks_exact(3).map(|c| Point3::new(c[0], c[1], c[2])));
        for t in m.indices.chunks_exact(3) {
            let idx = |i: u32| u32::try_from(base + i as u64).unwrap_or(u32::MAX);
            triangles.push([idx(t[0]), idx(t[1]), idx(t[2])]);
        }
    }
    checked_mesh(path, vertices, triangles)
}

/// Writes OBJ: `v x y z` lines with the shortest decimal that reads back to the same
/// f64 (so a save/load round trip is exact), then 1-based `f a b c` lines.
pub fn write_obj(w: &mut impl Write, mesh: &Mesh) -> std::io::Result<()> {
    writeln!(
        w,
        "# written by s2g-geom: {} vertices, {} triangles",
        mesh.vertices().len(),
        mesh.triangles().len()
    )?;
    for p in mesh.vertices() {
        writeln!(w, "v {:?} {:?} {:?}", p.x, p.y, p.z)?;
    }
    for t in mesh.triangles() {
        writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    Ok(())
}
