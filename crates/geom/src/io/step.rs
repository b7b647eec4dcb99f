//! Faceted STEP export (ISO 10303-21, AP214 `AUTOMOTIVE_DESIGN` schema): each connected
//! component of positive volume becomes one `FACETED_BREP` (a `CLOSED_SHELL` of triangular
//! `FACE_SURFACE`s on `PLANE`s, bounded by `POLY_LOOP`s), all in one `FACETED_BREP_SHAPE_REPRESENTATION` in
//! millimetres. Components of negative volume (the surfaces of internal voids of a solid,
//! such as the closed cells of sparse infill) become the voids of a `BREP_WITH_VOIDS`: each
//! goes to the positive body with the smallest bounding box containing the void's box
//! (voids that fit no body are left out).

use std::io::Write;
use std::path::Path;

use crate::atomic::write_atomic;
use crate::mesh::Mesh;

/// Connected components of the triangles through shared vertices, numbered in order of
/// their first triangle.
fn components(mesh: &Mesh) -> (Vec<u32>, usize) {
    let n = mesh.vertices().len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for t in mesh.triangles() {
        for k in 1..3 {
            let (a, b) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
            if a != b {
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut label = vec![u32::MAX; n];
    let mut count = 0u32;
    let mut tri_label = Vec::with_capacity(mesh.triangles().len());
    for t in mesh.triangles() {
        let r = find(&mut parent, t[0]) as usize;
        if label[r] == u32::MAX {
            label[r] = count;
            count += 1;
        }
        tri_label.push(label[r]);
    }
    (tri_label, count as usize)
}

/// A STEP real: fixed point with a mandatory decimal point.
fn real(v: f64) -> String {
    let s = format!("{v:.9}");
    s.trim_end_matches('0').to_string()
}

/// Writes `mesh` as faceted STEP, one body per connected component of positive volume
/// (voids as in [`save_step`]); `name` goes in the header.
pub fn write_step(w: &mut impl Write, mesh: &Mesh, name: &str) -> std::io::Result<()> {
    let clean: String = name.chars().filter(|c| c.is_ascii_graphic() && *c != '\'' && *c != '\\').collect();
    writeln!(w, "ISO-10303-21;\nHEADER;")?;
    writeln!(w, "FILE_DESCRIPTION(('shape2gcode FDM reconstruction, faceted B-rep'),'2;1');")?;
    writeln!(w, "FILE_NAME('{clean}','1970-01-01T00:00:00',(''),(''),'shape2gcode','shape2gcode','');")?;
    writeln!(w, "FILE_SCHEMA(('AUTOMOTIVE_DESIGN {{ 1 0 10303 214 1 1 1 1 }}'));\nENDSEC;\nDATA;")?;
    writeln!(w, "#1=APPLICATION_CONTEXT('automotive design');")?;
    writeln!(w, "#2=APPLICATION_PROTOCOL_DEFINITION('international standard','automotive_design',2000,#1);")?;
    writeln!(w, "#3=PRODUCT_CONTEXT('',#1,'mechanical');")?;
    writeln!(w, "#4=PRODUCT_DEFINITION_CONTEXT('part definition',#1,'design');")?;
    writeln!(w, "#5=PRODUCT('{clean}','{clean}','',(#3));")?;
    writeln!(w, "#6=PRODUCT_RELATED_PRODUCT_CATEGORY('part',$,(#5));")?;
    writeln!(w, "#7=PRODUCT_DEFINITION_FORMATION('','',#5);")?;
    writeln!(w, "#8=PRODUCT_DEFINITION('design','',#7,#4);")?;
    writeln!(w, "#9=PRODUCT_DEFINITION_SHAPE('','',#8);")?;
    writeln!(w, "#10=(LENGTH_UNIT()NAMED_UNIT(*)SI_UNIT(.MILLI.,.METRE.));")?;
    writeln!(w, "#11=(NAMED_UNIT(*)PLANE_ANGLE_UNIT()SI_UNIT($,.RADIAN.));")?;
    writeln!(w, "#12=(NAMED_UNIT(*)SI_UNIT($,.STERADIAN.)SOLID_ANGLE_UNIT());")?;
    writeln!(
        w,
        "#13=UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-06),#10,'distance_accuracy_value','confusion accuracy');"
    )?;
    writeln!(
        w,
        "#14=(GEOMETRIC_REPRESENTATION_CONTEXT(3)GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#13))\
         GLOBAL_UNIT_ASSIGNED_CONTEXT((#10,#11,#12))REPRESENTATION_CONTEXT('',''));"
    )?;
    writeln!(
        w,
        "#15=CARTESIAN_POINT('',(0.,0.,0.));\n#16=DIRECTION('',(0.,0.,1.));\n#17=DIRECTION('',(1.,0.,0.));"
    )?;
    writeln!(w, "#18=AXIS2_PLACEMENT_3D('',#15,#16,#17);")?;
    let mut id: u64 = 19;
    let pt0 = id;
    for p in mesh.vertices() {
        writeln!(w, "#{id}=CARTESIAN_POINT('',({},{},{}));", real(p.x), real(p.y), real(p.z))?;
        id += 1;
    }
    let (label, n) = components(mesh);
    // Signed volume per component: voids (negative) are skipped.
    let mut vol = vec![0.0f64; n];
    let v = mesh.vertices();
    for (t, &l) in mesh.triangles().iter().zip(&label) {
        let [a, b, c] = t.map(|i| v[i as usize].coords);
        vol[l as usize] += a.dot(&b.cross(&c)) / 6.0;
    }
    // Each void goes to the positive body of smallest box that contains the void's box.
    let mut boxes = vec![crate::Aabb::empty(); n];
    for (t, &l) in mesh.triangles().iter().zip(&label) {
        for &i in t {
            boxes[l as usize].grow(&v[i as usize]);
        }
    }
    let size = |b: &crate::Aabb| b.extent().iter().product::<f64>();
    let inside =
        |a: &crate::Aabb, b: &crate::Aabb| (0..3).all(|k| b.min[k] <= a.min[k] && a.max[k] <= b.max[k]);
    let owner: Vec<Option<usize>> = (0..n)
        .map(|c| {
            if vol[c] > 0.0 {
                return Some(c);
            }
            (0..n)
                .filter(|&o| vol[o] > 0.0 && inside(&boxes[c], &boxes[o]))
                .min_by(|&x, &y| size(&boxes[x]).total_cmp(&size(&boxes[y])))
        })
        .collect();
    let mut faces: Vec<Vec<u64>> = vec![Vec::new(); n];
    for (t, &l) in mesh.triangles().iter().zip(&label) {
        if owner[l as usize].is_none() {
            continue;
        }
        // Void shells are written with normals out of the void (reversed), then oriented .F.
        let t = if vol[l as usize] > 0.0 { *t } else { [t[0], t[2], t[1]] };
        let [a, b, c] = t.map(|i| pt0 + i as u64);
        let [pa, pb, pc] = t.map(|i| v[i as usize]);
        let (e, f) = (pb - pa, pc - pa);
        let nrm = e.cross(&f);
        let (nrm, x) = if nrm.norm() > 0.0 && e.norm() > 0.0 {
            (nrm.normalize(), e.normalize())
        } else {
            (crate::Vector3::z(), crate::Vector3::x())
        };
        writeln!(w, "#{id}=POLY_LOOP('',(#{a},#{b},#{c}));")?;
        writeln!(w, "#{}=FACE_OUTER_BOUND('',#{id},.T.);", id + 1)?;
        writeln!(w, "#{}=DIRECTION('',({},{},{}));", id + 2, real(nrm.x), real(nrm.y), real(nrm.z))?;
        writeln!(w, "#{}=DIRECTION('',({},{},{}));", id + 3, real(x.x), real(x.y), real(x.z))?;
        writeln!(w, "#{}=AXIS2_PLACEMENT_3D('',#{a},#{},#{});", id + 4, id + 2, id + 3)?;
        writeln!(w, "#{}=PLANE('',#{});", id + 5, id + 4)?;
        writeln!(w, "#{}=FACE_SURFACE('',(#{}),#{},.T.);", id + 6, id + 1, id + 5)?;
        faces[l as usize].push(id + 6);
        id += 7;
    }
    let mut shells = vec![0u64; n];
    for (c, f) in faces.iter().enumerate() {
        if f.is_empty() {
            continue;
        }
        let list: Vec<String> = f.iter().map(|i| format!("#{i}")).collect();
        writeln!(w, "#{id}=CLOSED_SHELL('',({}));", list.join(","))?;
        shells[c] = id;
        id += 1;
    }
    let mut breps = Vec::new();
    for c in (0..n).filter(|&c| vol[c] > 0.0 && shells[c] != 0) {
        let voids: Vec<usize> =
            (0..n).filter(|&o| vol[o] <= 0.0 && owner[o] == Some(c) && shells[o] != 0).collect();
        if voids.is_empty() {
            writeln!(w, "#{id}=FACETED_BREP('',#{});", shells[c])?;
            breps.push(format!("#{id}"));
            id += 1;
        } else {
            let mut refs = Vec::new();
            for o in voids {
                writeln!(w, "#{id}=ORIENTED_CLOSED_SHELL('',*,#{},.F.);", shells[o])?;
                refs.push(format!("#{id}"));
                id += 1;
            }
            writeln!(w, "#{id}=BREP_WITH_VOIDS('',#{},({}));", shells[c], refs.join(","))?;
            breps.push(format!("#{id}"));
            id += 1;
        }
    }
    writeln!(
        w,
        "#{id}=FACETED_BREP_SHAPE_REPRESENTATION('{clean}',(#18{}{}),#14);",
        if breps.is_empty() { "" } else { "," },
        breps.join(",")
    )?;
    writeln!(w, "#{}=SHAPE_DEFINITION_REPRESENTATION(#9,#{id});", id + 1)?;
    writeln!(w, "ENDSEC;\nEND-ISO-10303-21;")
}

/// Saves `mesh` as faceted STEP (ISO 10303-21, AP214) atomically: each connected
/// component of positive volume is a `FACETED_BREP`; components of negative volume (void
/// surfaces) become voids (`BREP_WITH_VOIDS`) of the positive body with the smallest
/// bounding box containing theirs.
pub fn save_step(path: impl AsRef<Path>, mesh: &Mesh) -> crate::error::Result<()> {
    let path = path.as_ref();
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("part").to_string();
    write_atomic(path, |w| write_step(w, mesh, &name))
}
