//! Mesh I/O and checks: every bundled mesh loads, every STL edge case loads or fails
//! with a typed error naming the file and the defect, save/load round trips, glTF
//! node transforms, PLY variants, 3MF packages, content sniffing, and the mesh report.

use std::path::{Path, PathBuf};

use s2g_geom::{
    Aabb, GeomError, LoadOptions, Mesh, MeshFormat, Point3, Real, Similarity3, Vector3, drop_degenerate,
    load_mesh, load_mesh_with, merge_vertices, read_mesh, read_stl, remove_unused_vertices, report,
    save_mesh,
};

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data")
}

fn edge_dir() -> PathBuf {
    data_dir().join("meshes/stl_edge_cases/stl-models")
}

/// The closed, outward box `[min, max]`.
fn box_mesh(min: Point3, max: Point3) -> Mesh {
    Mesh::cuboid(&Aabb::new(min, max)).unwrap()
}

fn soup(mesh: &Mesh) -> Mesh {
    Mesh::from_soup(&mesh.triangle_points().collect::<Vec<_>>()).unwrap()
}

fn rel_close(a: Real, b: Real, tol: Real) -> bool {
    (a - b).abs() <= tol * a.abs().max(b.abs()).max(1e-300)
}

fn files_under(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files_under(&p, out);
        } else {
            out.push(p);
        }
    }
}

mod bundled {
    use super::*;

    #[test]
    fn every_bundled_mesh_loads_and_the_closed_ones_check_out() {
        let mut files = Vec::new();
        files_under(&data_dir().join("meshes"), &mut files);
        files_under(&data_dir().join("fdm/models"), &mut files);
        let meshes: Vec<_> = files
            .into_iter()
            .filter(|p| !p.starts_with(edge_dir()))
            .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("stl" | "obj")))
            .collect();
        assert!(meshes.len() >= 13, "expected the bundled meshes, found {meshes:?}");
        for p in &meshes {
            let m = load_mesh(p).unwrap_or_else(|e| panic!("{} failed to load: {e}", p.display()));
            assert!(!m.is_empty(), "{} loaded empty", p.display());
            let r = report(&m);
            let name = p.file_name().unwrap().to_string_lossy();
            if name.contains("teapot") {
                // Documented in tests/data/README.md: three open shells.
                assert!(!r.closed && r.boundary_edges > 0, "{name}: teapot should be open: {r:?}");
            } else {
                assert!(r.closed && r.consistently_oriented && r.volume > 0.0, "{name}: {r:?}");
                assert_eq!(r.bodies, 1, "{name}: {r:?}");
            }
        }
    }

    #[test]
    fn known_volumes_and_boxes() {
        // Volumes from tests/data/README.md (computed there by trimesh).
        for (file, volume, min, max) in [
            ("fdm/models/cube10.stl", 1000.0, [0.0; 3], [10.0; 3]),
            ("fdm/models/dogbone_iso527_1A.stl", 9600.62, [0.0; 3], [170.0, 20.0, 4.0]),
            ("meshes/openscad/openscad_Basics_LetterBlock.stl", 11323.5, [-15.0, -15.0, 0.0], [15.0; 3]),
            ("meshes/openscad/openscad_Old_example002.stl", 12241.7, [-15.0, -15.0, -20.0], [15.0; 3]),
            ("meshes/openscad/openscad_Old_example004.stl", 2284.39, [-15.0; 3], [15.0; 3]),
        ] {
            let m = load_mesh(data_dir().join(file)).unwrap();
            let r = report(&m);
            assert!(rel_close(r.volume, volume, 1e-5), "{file}: volume {} vs {volume}", r.volume);
            let b = r.bbox.unwrap();
            for a in 0..3 {
                assert!(
                    (b.min[a] - min[a]).abs() < 1e-9 && (b.max[a] - max[a]).abs() < 1e-9,
                    "{file}: {b:?}"
                );
            }
        }
    }

    #[test]
    fn bunny_stl_and_obj_agree() {
        let stl = load_mesh(data_dir().join("meshes/classic/stanford_bunny.stl")).unwrap();
        let obj = load_mesh(data_dir().join("meshes/classic/stanford_bunny.obj")).unwrap();
        assert_eq!(stl.triangles().len(), 3674);
        assert_eq!(obj.triangles().len(), 3674);
        assert_eq!(stl.vertices().len(), 1839, "STL welding should recover the shared vertices");
        let (rs, ro) = (report(&stl), report(&obj));
        assert!(rs.closed && ro.closed && rs.manifold && rs.consistently_oriented);
        // The STL stores f32, the OBJ six decimals: volumes agree to ~1e-6.
        assert!(rel_close(rs.volume, ro.volume, 1e-5), "{} vs {}", rs.volume, ro.volume);
        assert!(rs.volume > 190.0 && rs.volume < 200.0, "bunny volume {}", rs.volume);
        // The assets/ copy is the same file.
        let asset =
            load_mesh(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/stanford_bunny.stl")).unwrap();
        assert_eq!(asset, stl);
    }
}

mod stl_edge_cases {
    use super::*;

    enum Want {
        /// Loads with this many triangles, this volume (None: open) and bbox.
        Ok(usize, Option<Real>, [Real; 3], [Real; 3]),
        /// Fails; the message contains this text, and the error has this line.
        Err(&'static str, Option<u64>),
    }
    use Want::*;

    const UNIT: [Real; 3] = [1.0; 3];
    const ZERO: [Real; 3] = [0.0; 3];
    const TET: Option<Real> = Some(1.0 / 6.0);

    fn table() -> Vec<(&'static str, Want)> {
        vec![
            ("broken/empty.stl", Err("empty file", None)),
            ("broken/fourVertices.ascii.stl", Err("facet has 4 vertices", Some(2))),
            ("broken/incorrectFaceCounter.bin.stl", Err("face counter says 66", None)),
            ("broken/missingEndsolid.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("broken/missingFace.ascii.stl", Ok(3, None, ZERO, UNIT)),
            ("broken/missingNormal.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("broken/notANumberNormal.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("broken/quad.ascii.stl", Err("facet has 4 vertices", Some(2))),
            ("broken/singleFace.ascii.stl", Ok(1, None, ZERO, [1.0, 1.0, 0.0])),
            ("broken/solidNameMismatch.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("broken/twoVertices.ascii.stl", Err("facet has 2 vertices", Some(2))),
            ("broken/wrongHeader.bin.stl", Ok(12, Some(1e6), [-50.0; 3], [50.0; 3])),
            ("broken/wrongNormal.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("broken/wrongNormals.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("misc/faceless.ascii.stl", Err("no triangles", None)),
            ("misc/multiWordName.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("misc/multiWordName.bin.stl", Err("49 stray bytes", None)),
            ("misc/namelessSolid.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("polytopes/cube.ascii.stl", Ok(12, Some(8.0), [-1.0; 3], UNIT)),
            ("polytopes/cube.bin.stl", Ok(12, Some(8.0), [-1.0; 3], UNIT)),
            ("polytopes/cubeLarge.ascii.stl", Ok(12, Some(1e6), ZERO, [100.0; 3])),
            ("polytopes/tetrahedron.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("polytopes/tetrahedron.bin.stl", Ok(4, TET, ZERO, UNIT)),
            ("polytopes/tetrahedron.min.ascii.stl", Ok(4, TET, ZERO, UNIT)),
            ("polytopes/tetrahedronIrregular.ascii.stl", Ok(4, Some(1.0), ZERO, [3.0, 2.0, 1.0])),
            ("polytopes/tetrahedronIrregular.bin.stl", Ok(4, Some(1.0), ZERO, [3.0, 2.0, 1.0])),
            ("polytopes/tetrahedronMinusZero.bin.stl", Ok(4, TET, ZERO, UNIT)),
            ("polytopes/triangle.ascii.stl", Ok(1, None, ZERO, [1.0, 0.0, 1.0])),
            ("polytopes/triangle.bin.stl", Ok(1, None, ZERO, [1.0, 0.0, 1.0])),
            ("polytopes/unitCube.ascii.stl", Ok(12, Some(1.0), ZERO, UNIT)),
            ("polytopes/unitCube.binary.stl", Ok(12, Some(1.0), ZERO, UNIT)),
        ]
    }

    #[test]
    fn every_edge_case_loads_or_names_file_and_defect() {
        let table = table();
        let mut files = Vec::new();
        files_under(&edge_dir(), &mut files);
        assert_eq!(files.len(), table.len(), "the table must cover every file: {files:?}");
        for file in files {
            let rel = file.strip_prefix(edge_dir()).unwrap().to_string_lossy().replace('\\', "/");
            let want =
                &table.iter().find(|(n, _)| *n == rel).unwrap_or_else(|| panic!("{rel} not in table")).1;
            match (load_mesh(&file), want) {
                (Result::Ok(m), Ok(tris, vol, min, max)) => {
                    assert_eq!(m.triangles().len(), *tris, "{rel}");
                    let r = report(&m);
                    match vol {
                        Some(v) => {
                            assert!(r.closed && r.consistently_oriented, "{rel}: {r:?}");
                            assert!(rel_close(r.volume, *v, 1e-9), "{rel}: volume {} vs {v}", r.volume);
                        }
                        None => assert!(!r.closed, "{rel} should be open"),
                    }
                    let b = m.bbox().unwrap();
                    assert_eq!(b.min, Point3::from(*min), "{rel}");
                    assert_eq!(b.max, Point3::from(*max), "{rel}");
                }
                (Result::Err(e), Err(text, line)) => {
                    let msg = e.to_string();
                    assert!(msg.contains(text), "{rel}: error '{msg}' lacks '{text}'");
                    assert!(msg.contains(file.file_name().unwrap().to_str().unwrap()), "{rel}: '{msg}'");
                    match e {
                        GeomError::Parse { path, line: l, .. } => {
                            assert_eq!(path, file, "{rel}");
                            assert_eq!(l, *line, "{rel}: line of the defect");
                        }
                        other => panic!("{rel}: expected a parse error, got {other:?}"),
                    }
                }
                (Result::Ok(m), Err(..)) => panic!("{rel}: expected an error, loaded {m:?}"),
                (Result::Err(e), Ok(..)) => panic!("{rel}: expected a mesh, got {e}"),
            }
        }
    }

    #[test]
    fn a_wrong_face_counter_is_read_when_tolerated() {
        let opts = LoadOptions { tolerate_stl_face_count: true, ..LoadOptions::default() };
        let m = load_mesh_with(edge_dir().join("broken/incorrectFaceCounter.bin.stl"), &opts).unwrap();
        assert_eq!(m.triangles().len(), 4);
        assert!(rel_close(m.signed_volume(), 1.0 / 6.0, 1e-9));
    }

    #[test]
    fn faceless_solid_is_an_empty_mesh_when_allowed() {
        let opts = LoadOptions { allow_empty: true, ..LoadOptions::default() };
        let m = load_mesh_with(edge_dir().join("misc/faceless.ascii.stl"), &opts).unwrap();
        assert!(m.is_empty());
    }
}

mod ascii_stl {
    use super::*;

    const TET: &str = "solid t\nfacet normal 0 0 0\nouter loop\nvertex 1 0 0\nvertex 0 1 0\nvertex 0 0 1\nendloop\n\
        endfacet\nfacet normal 0 -1 0\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0 1\nendloop\nendfacet\n\
        facet\nouter loop\nvertex 0 0 0\nvertex 0 0 1\nvertex 0 1 0\nendloop\nendfacet\nfacet normal nan nan nan\n\
        outer loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid t\n";

    fn parse(text: &str) -> s2g_geom::Result<Mesh> {
        read_stl(text.as_bytes(), Path::new("mem.stl"))
    }

    fn line_of(e: GeomError) -> Option<u64> {
        match e {
            GeomError::Parse { line, .. } => line,
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    #[test]
    fn line_endings_do_not_matter() {
        let lf = parse(TET).unwrap();
        assert!(rel_close(lf.signed_volume(), 1.0 / 6.0, 1e-12));
        for ending in ["\r\n", "\r"] {
            let m = parse(&TET.replace('\n', ending)).unwrap();
            assert_eq!(m, lf, "ending {ending:?}");
        }
        // Uppercase keywords, tabs and a multi-word name.
        let m = parse(&TET.replace("solid t", "SOLID my part  v2").replace("vertex", "\tVERTEX")).unwrap();
        assert_eq!(m, lf);
    }

    #[test]
    fn defects_name_their_line_with_any_line_ending() {
        // Line 5 of TET is "vertex 0 1 0"; make its y coordinate garbage.
        let bad = TET.replacen("vertex 0 1 0", "vertex 0 oops 0", 1);
        for ending in ["\n", "\r\n", "\r"] {
            let e = parse(&bad.replace('\n', ending)).unwrap_err();
            assert!(e.to_string().contains("oops"), "{e}");
            assert_eq!(line_of(e), Some(5), "ending {ending:?}");
        }
        let e = parse(&TET.replacen("vertex 0 1 0", "vertex 0 inf 0", 1)).unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        let e = parse(&TET.replacen("endfacet", "endfacett", 1)).unwrap_err();
        assert_eq!(line_of(e), Some(8));
    }

    #[test]
    fn truncation_inside_a_facet_is_an_error_but_missing_endsolid_is_not() {
        let cut = &TET[..TET.find("endloop").unwrap()];
        let e = parse(cut).unwrap_err();
        assert!(e.to_string().contains("ends inside the facet"), "{e}");
        assert_eq!(line_of(e), Some(2));
        let no_end = TET.replace("endsolid t\n", "");
        assert_eq!(parse(&no_end).unwrap().triangles().len(), 4);
    }

    #[test]
    fn several_solids_are_merged() {
        let two = format!("{TET}{}", TET.replace("0 0 0", "5 5 5"));
        let m = parse(&two).unwrap();
        assert_eq!(m.triangles().len(), 8);
    }
}

mod round_trips {
    use super::*;

    /// The bunny rotated and shifted, so coordinates are not round decimals.
    pub(super) fn sample_mesh() -> Mesh {
        let m = load_mesh(data_dir().join("meshes/classic/stanford_bunny.stl")).unwrap();
        let t = Similarity3::new(Vector3::new(0.1, -7.3, 1e3), Vector3::new(0.3, 0.2, -0.1), 1.7);
        m.transformed(&t)
    }

    #[test]
    fn save_and_load_each_format() {
        let dir = tempfile::tempdir().unwrap();
        let m = sample_mesh();
        for (ext, exact) in [("ply", true), ("obj", true), ("stl", false)] {
            let path = dir.path().join(format!("out.{ext}"));
            save_mesh(&path, &m).unwrap();
            let back = load_mesh(&path).unwrap();
            assert_eq!(back.triangles().len(), m.triangles().len(), "{ext}");
            if ext == "ply" {
                assert_eq!(back, m, "PLY round trip must be exact");
            } else if exact {
                // tobj renumbers vertices in order of first use: compare triangle corners.
                assert_eq!(back.vertices().len(), m.vertices().len(), "{ext}");
                for (t, (a, b)) in m.triangle_points().zip(back.triangle_points()).enumerate() {
                    assert_eq!(a, b, "{ext}: triangle {t} must round-trip exactly");
                }
            } else {
                // STL stores f32: each corner within half an f32 ulp of the original.
                for (t, (a, b)) in m.triangle_points().zip(back.triangle_points()).enumerate() {
                    for k in 0..3 {
                        for c in 0..3 {
                            let tol = a[k][c].abs() * f32::EPSILON as f64;
                            assert!((a[k][c] - b[k][c]).abs() <= tol, "{ext}: triangle {t} corner {k}");
                        }
                    }
                }
                assert_eq!(back.vertices().len(), m.vertices().len(), "STL welding restores sharing");
            }
        }
        // Nothing but the three outputs is left behind (no temporary files).
        let mut names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, ["out.obj", "out.ply", "out.stl"]);
    }

    #[test]
    fn saving_reports_bad_paths() {
        let m = box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0));
        let dir = tempfile::tempdir().unwrap();
        let e = save_mesh(dir.path().join("x.xyz"), &m).unwrap_err();
        assert!(matches!(e, GeomError::UnsupportedFormat { .. }), "{e:?}");
        let e = save_mesh(dir.path().join("missing/dir/x.stl"), &m).unwrap_err();
        assert!(matches!(e, GeomError::Io { .. }), "{e:?}");
        let e = save_mesh(dir.path().join("x.glb"), &m).unwrap_err();
        assert!(matches!(e, GeomError::UnsupportedFormat { .. }), "{e:?}");
    }

    #[test]
    fn content_wins_over_a_lying_extension() {
        let dir = tempfile::tempdir().unwrap();
        let m = box_mesh(Point3::origin(), Point3::new(1.0, 2.0, 3.0));
        // Binary STL named .obj, PLY named .stl, OBJ named .txt.
        let stl = dir.path().join("a.stl");
        save_mesh(&stl, &m).unwrap();
        std::fs::rename(&stl, dir.path().join("a.obj")).unwrap();
        let ply = dir.path().join("b.ply");
        save_mesh(&ply, &m).unwrap();
        std::fs::rename(&ply, dir.path().join("b.stl")).unwrap();
        let obj = dir.path().join("c.obj");
        save_mesh(&obj, &m).unwrap();
        std::fs::rename(&obj, dir.path().join("c.txt")).unwrap();
        for name in ["a.obj", "b.stl", "c.txt"] {
            let back = load_mesh(dir.path().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(rel_close(back.signed_volume(), 6.0, 1e-12), "{name}");
        }
        assert_eq!(
            MeshFormat::sniff(&std::fs::read(dir.path().join("b.stl")).unwrap()),
            Some(MeshFormat::Ply)
        );
        let e = read_mesh(b"hello world", Path::new("x.dat"), &LoadOptions::default()).unwrap_err();
        assert!(matches!(e, GeomError::UnsupportedFormat { .. }), "{e:?}");
    }

    #[test]
    fn an_explicit_binary_header_starting_with_solid_is_binary() {
        let m = box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0));
        let mut bytes = Vec::new();
        s2g_geom::write_stl(&mut bytes, &m).unwrap();
        bytes[..12].copy_from_slice(b"solid cube  ");
        let back = read_stl(&bytes, Path::new("x.stl")).unwrap();
        assert_eq!(back.triangles().len(), 12);
        assert!(rel_close(back.signed_volume(), 1.0, 1e-12));
        // With a trailing stray byte the size no longer decides; the binary defect is reported.
        bytes.push(0);
        let e = read_stl(&bytes, Path::new("x.stl")).unwrap_err();
        assert!(e.to_string().contains("1 stray bytes"), "{e}");
        let opts = LoadOptions { tolerate_stl_face_count: true, ..LoadOptions::default() };
        let back = s2g_geom::read_stl_with(&bytes, Path::new("x.stl"), &opts).unwrap();
        assert_eq!(back.triangles().len(), 12);
    }
}

mod ply {
    use super::*;

    const ASCII: &str = "ply\r\nformat ascii 1.0\r\ncomment unit cube as quads\r\nelement vertex 8\r\n\
        property float x\r\nproperty float y\r\nproperty float z\r\nproperty uchar red\r\n\
        element face 6\r\nproperty list uchar int vertex_indices\r\nproperty int flags\r\n\
        element edge 0\r\nproperty int vertex1\r\nend_header\r\n\
        0 0 0 1\r\n1 0 0 2\r\n0 1 0 3\r\n1 1 0 4\r\n0 0 1 5\r\n1 0 1 6\r\n0 1 1 7\r\n1 1 1 8\r\n\
        4 0 2 3 1 9\r\n4 4 5 7 6 9\r\n4 0 1 5 4 9\r\n4 2 6 7 3 9\r\n4 0 4 6 2 9\r\n4 1 3 7 5 9\r\n";

    fn parse(bytes: &[u8]) -> s2g_geom::Result<Mesh> {
        s2g_geom::read_ply(bytes, Path::new("mem.ply"))
    }

    #[test]
    fn ascii_quads_are_fan_triangulated() {
        let m = parse(ASCII.as_bytes()).unwrap();
        assert_eq!(m.triangles().len(), 12);
        let r = report(&m);
        assert!(r.closed && r.consistently_oriented && rel_close(r.volume, 1.0, 1e-12), "{r:?}");
    }

    /// The same cube in binary with the given byte order.
    fn binary(big: bool) -> Vec<u8> {
        let m = parse(ASCII.as_bytes()).unwrap();
        let fmt = if big { "binary_big_endian" } else { "binary_little_endian" };
        let mut out = format!(
            "ply\nformat {fmt} 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n\
             element face 12\nproperty list uchar uint vertex_indices\nend_header\n"
        )
        .into_bytes();
        let put = |out: &mut Vec<u8>, b: [u8; 4]| {
            if big { out.extend(b.iter().rev()) } else { out.extend(b) }
        };
        for p in m.vertices() {
            for a in 0..3 {
                put(&mut out, (p[a] as f32).to_le_bytes());
            }
        }
        for t in m.triangles() {
            out.push(3);
            for &i in t {
                put(&mut out, i.to_le_bytes());
            }
        }
        out
    }

    #[test]
    fn binary_both_endians() {
        let reference = parse(ASCII.as_bytes()).unwrap();
        for big in [false, true] {
            let m = parse(&binary(big)).unwrap();
            assert_eq!(m, reference, "big endian: {big}");
        }
    }

    #[test]
    fn defects_are_typed_errors() {
        let full = binary(false);
        let e = parse(&full[..full.len() - 3]).unwrap_err();
        assert!(e.to_string().contains("ends"), "{e}");
        let e = parse(ASCII.replace("4 0 2 3 1 9", "4 0 2 3 99 9").as_bytes()).unwrap_err();
        assert!(e.to_string().contains("99"), "{e}");
        let e = parse(ASCII.replace("0 1 0 3", "0 x 0 3").as_bytes()).unwrap_err();
        assert_eq!(e.to_string(), "mem.ply:17: 'x' is not a number");
        let e = parse(ASCII.replace("end_header", "end_headr").as_bytes()).unwrap_err();
        assert!(matches!(e, GeomError::Parse { line: Some(_), .. }), "{e:?}");
        let e = parse(ASCII.replace("element vertex 8", "element vertex 800000000").as_bytes()).unwrap_err();
        assert!(e.to_string().contains("more than the file can hold"), "{e}");
        let e = parse(ASCII.replace("4 0 2 3 1 9", "2 0 2 9").as_bytes()).unwrap_err();
        assert!(e.to_string().contains("face 0 has 2 vertices"), "{e}");
    }
}

mod gltf {
    use super::*;

    /// A unit cube's positions (f32) and triangle indices (u16) as one little-endian buffer.
    fn cube_buffer() -> (Vec<u8>, usize, usize) {
        let m = box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0));
        let mut buf = Vec::new();
        for p in m.vertices() {
            for a in 0..3 {
                buf.extend((p[a] as f32).to_le_bytes());
            }
        }
        let pos_len = buf.len();
        for t in m.triangles() {
            for &i in t {
                buf.extend((i as u16).to_le_bytes());
            }
        }
        let idx_len = buf.len() - pos_len;
        while !buf.len().is_multiple_of(4) {
            buf.push(0);
        }
        (buf, pos_len, idx_len)
    }

    /// glTF JSON: a parent node translated by (10, 0, 0) holding a child scaled by
    /// (2, 3, 4) and rotated a quarter turn about +Z, which holds the cube; plus a
    /// second root with a mirroring matrix (scale -1 in x) translated by (0, 0, -5).
    fn json(uri: Option<&str>, buf_len: usize, pos_len: usize, idx_len: usize) -> String {
        let uri = uri.map(|u| format!("\"uri\": \"{u}\", ")).unwrap_or_default();
        let s = std::f64::consts::FRAC_1_SQRT_2;
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 2]}}],
  "nodes": [
    {{"translation": [10, 0, 0], "children": [1]}},
    {{"scale": [2, 3, 4], "rotation": [0, 0, {s}, {s}], "mesh": 0}},
    {{"matrix": [-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,-5,1], "mesh": 0}}
  ],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
  "buffers": [{{{uri}"byteLength": {buf_len}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": {pos_len}}},
    {{"buffer": 0, "byteOffset": {pos_len}, "byteLength": {idx_len}}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3", "min": [0,0,0], "max": [1,1,1]}},
    {{"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}}
  ]
}}"#
        )
    }

    fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
        let mut j = json.as_bytes().to_vec();
        while !j.len().is_multiple_of(4) {
            j.push(b' ');
        }
        let total = 12 + 8 + j.len() + 8 + bin.len();
        let mut out = Vec::new();
        out.extend(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend((total as u32).to_le_bytes());
        out.extend((j.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(j);
        out.extend((bin.len() as u32).to_le_bytes());
        out.extend(b"BIN\0");
        out.extend(bin);
        out
    }

    fn base64(bytes: &[u8]) -> String {
        const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in bytes.chunks(3) {
            let n = c.iter().enumerate().fold(0u32, |n, (i, &b)| n | (b as u32) << (16 - 8 * i));
            for i in 0..4 {
                if i <= c.len() {
                    s.push(A[(n >> (18 - 6 * i)) as usize & 63] as char);
                } else {
                    s.push('=');
                }
            }
        }
        s
    }

    fn check(m: &Mesh, what: &str) {
        assert_eq!(m.triangles().len(), 24, "{what}");
        let r = report(m);
        assert_eq!(r.bodies, 2, "{what}");
        // Child cube: scaled to 2 x 3 x 4, then a quarter turn about Z maps x -> y and
        // y -> -x, then the parent moves it by +10 in x: [7, 10] x [0, 2] x [0, 4].
        // Mirrored cube: [-1, 0] x [0, 1] x [-5, -4]. Both volumes stay positive.
        let b = m.bbox().unwrap();
        let (min, max) = (Point3::new(-1.0, 0.0, -5.0), Point3::new(10.0, 2.0, 4.0));
        assert!((b.min - min).norm() < 1e-6 && (b.max - max).norm() < 1e-6, "{what}: {b:?}");
        assert!(rel_close(r.volume, 24.0 + 1.0, 1e-6), "{what}: volume {}", r.volume);
        assert!(r.consistently_oriented && r.closed, "{what}: {r:?}");
        let child: Vec<_> = m.vertices().iter().filter(|p| p.x > 5.0).collect();
        let cb = s2g_geom::Aabb::from_points(child).unwrap();
        assert!((cb.min - Point3::new(7.0, 0.0, 0.0)).norm() < 1e-6, "{what}: {cb:?}");
        assert!((cb.max - Point3::new(10.0, 2.0, 4.0)).norm() < 1e-6, "{what}: {cb:?}");
    }

    #[test]
    fn gltf_with_external_bin_glb_and_data_uri() {
        let dir = tempfile::tempdir().unwrap();
        let (buf, pos_len, idx_len) = cube_buffer();
        // External file with a space in its name (percent-encoded in the URI).
        std::fs::write(dir.path().join("cube data.bin"), &buf).unwrap();
        let path = dir.path().join("scene.gltf");
        std::fs::write(&path, json(Some("cube%20data.bin"), buf.len(), pos_len, idx_len)).unwrap();
        check(&load_mesh(&path).unwrap(), "external .bin");

        let path = dir.path().join("scene.glb");
        std::fs::write(&path, glb(&json(None, buf.len(), pos_len, idx_len), &buf)).unwrap();
        check(&load_mesh(&path).unwrap(), "GLB");

        let uri = format!("data:application/octet-stream;base64,{}", base64(&buf));
        let path = dir.path().join("inline.gltf");
        std::fs::write(&path, json(Some(&uri), buf.len(), pos_len, idx_len)).unwrap();
        check(&load_mesh(&path).unwrap(), "data URI");

        // A GLB named .gltf is still read (the magic decides).
        let path = dir.path().join("lying.gltf");
        std::fs::write(&path, glb(&json(None, buf.len(), pos_len, idx_len), &buf)).unwrap();
        check(&load_mesh(&path).unwrap(), "GLB named .gltf");
    }

    #[test]
    fn strips_and_fans_are_triangulated_facing_the_same_way() {
        // A unit square in z = 0 as a 4-vertex strip (0,1,2,3 zig-zag) and as a fan;
        // points and lines primitives are skipped.
        let strip: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
        let fan: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let mut buf = Vec::new();
        for p in strip.iter().chain(fan.iter()) {
            for c in p {
                buf.extend(c.to_le_bytes());
            }
        }
        let uri = format!("data:application/octet-stream;base64,{}", base64(&buf));
        let text = format!(
            r#"{{"asset": {{"version": "2.0"}},
  "meshes": [{{"primitives": [
    {{"attributes": {{"POSITION": 0}}, "mode": 5}},
    {{"attributes": {{"POSITION": 1}}, "mode": 6}},
    {{"attributes": {{"POSITION": 1}}, "mode": 1}}]}}],
  "buffers": [{{"uri": "{uri}", "byteLength": 96}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 96, "byteStride": 12}}],
  "accessors": [
    {{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
    {{"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}}]
}}"#
        );
        // No scene and no nodes: every mesh is taken untransformed.
        let m = s2g_geom::read_gltf(text.as_bytes(), Path::new("mem.gltf")).unwrap();
        assert_eq!(m.triangles().len(), 4);
        assert!(rel_close(m.area(), 2.0, 1e-12));
        for t in 0..4 {
            let n = m.face_normal(t).unwrap();
            assert!((n - Vector3::z()).norm() < 1e-12, "triangle {t} normal {n:?}");
        }
    }

    #[test]
    fn broken_gltf_files_are_typed_errors() {
        let dir = tempfile::tempdir().unwrap();
        let (buf, pos_len, idx_len) = cube_buffer();
        let path = dir.path().join("missing.gltf");
        std::fs::write(&path, json(Some("nowhere.bin"), buf.len(), pos_len, idx_len)).unwrap();
        assert!(matches!(load_mesh(&path), Err(GeomError::Io { .. })));
        // Buffer shorter than declared.
        let path = dir.path().join("short.glb");
        std::fs::write(&path, glb(&json(None, buf.len(), pos_len, idx_len), &buf[..buf.len() - 8])).unwrap();
        assert!(matches!(load_mesh(&path), Err(GeomError::Parse { .. })));
        // Truncated JSON.
        let text = json(None, buf.len(), pos_len, idx_len);
        let path = dir.path().join("cut.gltf");
        std::fs::write(&path, &text[..text.len() / 2]).unwrap();
        let e = load_mesh(&path).unwrap_err();
        assert!(e.to_string().contains("cut.gltf"), "{e}");
        // An accessor that reaches past its view.
        let path = dir.path().join("overrun.glb");
        let bad = json(None, buf.len(), pos_len, idx_len).replace("\"count\": 8", "\"count\": 9");
        std::fs::write(&path, glb(&bad, &buf)).unwrap();
        assert!(matches!(load_mesh(&path), Err(GeomError::Parse { .. })));
    }
}

mod never_panics {
    use super::*;

    /// Truncations and byte corruptions of real files in every format never panic.
    #[test]
    fn mutated_files_give_results_or_errors() {
        let dir = tempfile::tempdir().unwrap();
        let m = box_mesh(Point3::origin(), Point3::new(1.0, 2.0, 3.0));
        let mut inputs: Vec<(String, Vec<u8>)> = Vec::new();
        for ext in ["stl", "obj", "ply", "3mf"] {
            let p = dir.path().join(format!("m.{ext}"));
            save_mesh(&p, &m).unwrap();
            inputs.push((format!("m.{ext}"), std::fs::read(&p).unwrap()));
        }
        for f in ["polytopes/cube.ascii.stl", "broken/fourVertices.ascii.stl", "polytopes/cube.bin.stl"] {
            inputs.push((format!("x{}.stl", inputs.len()), std::fs::read(edge_dir().join(f)).unwrap()));
        }
        inputs.push(("q.ply".into(), super::ply_ascii().into_bytes()));
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for (name, bytes) in &inputs {
            for k in 0..300 {
                let mut b = bytes.clone();
                if k % 3 == 0 {
                    b.truncate((next() as usize) % (b.len() + 1));
                } else {
                    for _ in 0..1 + k % 4 {
                        let i = (next() as usize) % b.len();
                        b[i] = next() as u8;
                    }
                }
                // Either outcome is fine; a panic fails the test.
                let _ = read_mesh(&b, Path::new(name), &LoadOptions::default());
            }
        }
    }
}

mod threemf {
    use super::*;
    use std::io::Write;

    /// A ZIP package with the given (name, content) entries, stored or deflated.
    fn package(entries: &[(&str, &str)]) -> Vec<u8> {
        let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        for (i, (name, text)) in entries.iter().enumerate() {
            let method =
                if i % 2 == 0 { zip::CompressionMethod::Deflated } else { zip::CompressionMethod::Stored };
            let opts = zip::write::SimpleFileOptions::DEFAULT.compression_method(method);
            zip.start_file(*name, opts).unwrap();
            zip.write_all(text.as_bytes()).unwrap();
        }
        zip.finish().unwrap().into_inner()
    }

    const RELS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
<Relationship Id="r" Target="/3D/Model.model" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>"#;

    /// A unit cube as a 3MF mesh object with the given id and type.
    fn cube_object(id: u32, ty: &str) -> String {
        let m = box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0));
        let mut s = format!("<object id=\"{id}\" type=\"{ty}\"><mesh><vertices>\n");
        for p in m.vertices() {
            s += &format!("<vertex x=\"{}\" y=\"{}\" z=\"{}\" />\n", p.x, p.y, p.z);
        }
        s += "</vertices>\n<triangles>\n";
        for t in m.triangles() {
            s += &format!("<triangle v1=\"{}\" v2=\"{}\" v3=\"{}\" pid=\"1\" p1=\"0\"/>\n", t[0], t[1], t[2]);
        }
        s + "</triangles></mesh></object>\n"
    }

    fn model(unit: &str, body: &str) -> String {
        format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- a comment <object> -->\n\
             <model unit=\"{unit}\" xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\" \
             xmlns:p=\"http://schemas.microsoft.com/3dmanufacturing/production/2015/06\">\n{body}</model>\n"
        )
    }

    #[test]
    fn round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let m = super::round_trips::sample_mesh();
        let path = dir.path().join("out.3mf");
        save_mesh(&path, &m).unwrap();
        let back = load_mesh(&path).unwrap();
        assert_eq!(back.vertices().len(), m.vertices().len());
        assert_eq!(back.triangles().len(), m.triangles().len());
        assert_eq!(back.signed_volume(), m.signed_volume());
        assert_eq!(back, m, "3MF round trip must be exact");
        // Detection by content: a 3MF under another extension still loads.
        std::fs::rename(&path, dir.path().join("out.stl")).unwrap();
        assert_eq!(load_mesh(dir.path().join("out.stl")).unwrap(), m);
        // Triangles that repeat a vertex are not written (the spec forbids them).
        let mut t = box_mesh(Point3::origin(), Point3::new(1.0, 2.0, 3.0)).triangles().to_vec();
        t.push([0, 0, 1]);
        let degenerate =
            Mesh::new(box_mesh(Point3::origin(), Point3::new(1.0, 2.0, 3.0)).vertices().to_vec(), t).unwrap();
        save_mesh(dir.path().join("d.3mf"), &degenerate).unwrap();
        let back = load_mesh(dir.path().join("d.3mf")).unwrap();
        assert_eq!(back.triangles().len(), 12);
        assert!(rel_close(back.signed_volume(), 6.0, 1e-12));
    }

    #[test]
    fn bytes_are_deterministic_and_the_package_is_opc() {
        let dir = tempfile::tempdir().unwrap();
        let m = super::round_trips::sample_mesh();
        let (a, b) = (dir.path().join("a.3mf"), dir.path().join("b.3mf"));
        save_mesh(&a, &m).unwrap();
        save_mesh(&b, &m).unwrap();
        let bytes = std::fs::read(&a).unwrap();
        assert!(bytes == std::fs::read(&b).unwrap(), "the same mesh must give the same bytes");
        let mut zip = zip::ZipArchive::new(std::io::Cursor::new(&bytes)).unwrap();
        let names: Vec<String> = zip.file_names().map(|n| n.unwrap().into_owned()).collect();
        assert_eq!(names, ["[Content_Types].xml", "_rels/.rels", "3D/3dmodel.model"]);
        for i in 0..zip.len() {
            let f = zip.by_index(i).unwrap();
            // A fixed timestamp, not the clock: 1980-01-01 00:00:00.
            assert_eq!(f.last_modified(), Some(zip::DateTime::default()), "{:?}", f.name());
            assert_eq!(f.compression(), zip::CompressionMethod::Deflated, "{:?}", f.name());
        }
        let mut text = String::new();
        std::io::Read::read_to_string(&mut zip.by_name("3D/3dmodel.model").unwrap(), &mut text).unwrap();
        assert!(text.contains("unit=\"millimeter\""), "{}", &text[..300]);
        assert_eq!(text.matches("<object ").count(), 1);
        assert!(text.contains("<object id=\"1\" type=\"model\">"));
        assert_eq!(text.matches("<vertex ").count(), m.vertices().len());
        assert_eq!(text.matches("<triangle ").count(), m.triangles().len());
        let mut rels = String::new();
        std::io::Read::read_to_string(&mut zip.by_name("_rels/.rels").unwrap(), &mut rels).unwrap();
        assert!(rels.contains("Target=\"/3D/3dmodel.model\""), "{rels}");
    }

    #[test]
    fn build_items_components_units_and_types() {
        // Object 1: a unit cube; 2: a support (skipped); 3: two copies of 1, one moved
        // by 2 in x; the build places 3 scaled by 2 and 1 moved by 10 in z, in cm.
        let body = format!(
            "<resources>\n{}{}<object id=\"3\" type=\"model\"><components>\n\
             <component objectid=\"1\"/>\n\
             <component objectid=\"1\" transform=\"1 0 0 0 1 0 0 0 1 2 0 0\"/>\n\
             </components></object>\n</resources>\n<build>\n\
             <item objectid=\"3\" transform=\"2 0 0 0 2 0 0 0 2 0 0 0\"/>\n\
             <item objectid=\"1\" transform='1 0 0 0 1 0 0 0 1 0 0 10'/>\n\
             <item objectid=\"2\"/>\n</build>\n",
            cube_object(1, "model"),
            cube_object(2, "support"),
        );
        let bytes = package(&[
            ("_rels/.rels", RELS),
            ("[Content_Types].xml", "<Types/>"),
            ("3D/Model.model", &model("centimeter", &body)),
        ]);
        let m = read_mesh(&bytes, Path::new("parts.3mf"), &LoadOptions::default()).unwrap();
        assert_eq!(m.triangles().len(), 36);
        // Two cubes of 20 mm and one of 10 mm.
        assert!(rel_close(m.signed_volume(), 2.0 * 8000.0 + 1000.0, 1e-12), "{}", m.signed_volume());
        let bb = m.bbox().unwrap();
        assert!(rel_close(bb.max.x, 60.0, 1e-12) && rel_close(bb.max.z, 110.0, 1e-12), "{bb:?}");
    }

    #[test]
    fn corrupt_packages_give_typed_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let m = box_mesh(Point3::origin(), Point3::new(1.0, 2.0, 3.0));
        let good = dir.path().join("good.3mf");
        save_mesh(&good, &m).unwrap();
        let bytes = std::fs::read(&good).unwrap();
        let bad_index = model(
            "millimeter",
            "<resources><object id=\"1\"><mesh><vertices>\n<vertex x=\"0\" y=\"0\" z=\"0\"/>\n</vertices>\n\
             <triangles>\n<triangle v1=\"0\" v2=\"1\" v3=\"7\"/>\n</triangles></mesh></object></resources>\
             <build><item objectid=\"1\"/></build>",
        );
        let mut cases: Vec<(&str, Vec<u8>, &str)> = vec![
            ("truncated.3mf", bytes[..bytes.len() / 2].to_vec(), "ZIP"),
            ("text.3mf", b"solid? no, just text".to_vec(), "ZIP"),
            ("nomodel.3mf", package(&[("readme.txt", "hello")]), "no model part 3D/3dmodel.model"),
            (
                "index.3mf",
                package(&[("_rels/.rels", RELS), ("3D/Model.model", &bad_index)]),
                "refers to vertex 1",
            ),
            (
                "unit.3mf",
                package(&[("3D/3dmodel.model", &model("furlong", "<build/>"))]),
                "3D/3dmodel.model:3: unknown unit",
            ),
            (
                "nobuild.3mf",
                package(&[("3D/3dmodel.model", &model("inch", "<resources/>"))]),
                "no <build> items",
            ),
            (
                "missing.3mf",
                package(&[("3D/3dmodel.model", &model("inch", "<build><item objectid=\"4\"/></build>"))]),
                "no object with id 4",
            ),
            (
                "cycle.3mf",
                package(&[(
                    "3D/3dmodel.model",
                    &model(
                        "inch",
                        "<resources><object id=\"1\"><components><component objectid=\"1\"/></components>\
                         </object></resources><build><item objectid=\"1\"/></build>",
                    ),
                )]),
                "nest too deep",
            ),
            (
                "unclosed.3mf",
                package(&[("3D/3dmodel.model", "<model unit=\"micron\"><build><item objectid=\"1")]),
                "not closed",
            ),
        ];
        // A "billion laughs" of components: each level places the next one twice.
        let mut laughs = cube_object(1, "model");
        for id in 2..=40 {
            laughs += &format!(
                "<object id=\"{id}\"><components><component objectid=\"{0}\"/><component objectid=\"{0}\"/>\
                 </components></object>\n",
                id - 1
            );
        }
        let laughs = model(
            "millimeter",
            &format!("<resources>{laughs}</resources><build><item objectid=\"40\"/></build>"),
        );
        cases.push(("laughs.3mf", package(&[("3D/3dmodel.model", &laughs)]), "object instances"));
        for (name, b, needle) in cases {
            let path = dir.path().join(name);
            std::fs::write(&path, &b).unwrap();
            let e = load_mesh(&path).unwrap_err();
            assert!(matches!(&e, GeomError::Parse { path: p, .. } if *p == path), "{name}: {e:?}");
            let msg = e.to_string();
            assert!(msg.starts_with(&path.display().to_string()), "{name}: {msg}");
            assert!(msg.contains(needle), "{name}: {msg:?} should contain {needle:?}");
        }
        // The line of the bad triangle is named.
        let e = read_mesh(
            &package(&[("_rels/.rels", RELS), ("3D/Model.model", &bad_index)]),
            Path::new("i.3mf"),
            &LoadOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("3D/Model.model:8: object 1: triangle 0 refers to vertex 1"), "{e}");
    }
}

fn ply_ascii() -> String {
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\n\
     element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"
        .into()
}

mod checks {
    use super::*;

    #[test]
    fn merging_restores_sharing_deterministically() {
        let cube = box_mesh(Point3::new(-1.0, -1.0, -1.0), Point3::new(1.0, 1.0, 1.0));
        let s = soup(&cube);
        assert_eq!(s.vertices().len(), 36);
        let merged = merge_vertices(&s, 0.0);
        assert_eq!(merged.vertices().len(), 8);
        assert!(report(&merged).closed);
        // Jitter below the tolerance merges; the result is the same on every run.
        let jittered: Vec<[Point3; 3]> = s
            .triangle_points()
            .enumerate()
            .map(|(t, tri)| tri.map(|p| p + Vector3::repeat(1e-7 * ((t % 5) as Real - 2.0))))
            .collect();
        let j = Mesh::from_soup(&jittered).unwrap();
        let a = merge_vertices(&j, 1e-5);
        assert_eq!(a.vertices().len(), 8);
        assert_eq!(a, merge_vertices(&j, 1e-5));
        assert!(merge_vertices(&j, 1e-9).vertices().len() > 8, "a tiny tolerance keeps jittered copies");
        // The report merges within 1e-9 of the diagonal only: 1e-7 jitter leaves it open.
        assert!(!report(&j).closed);
    }

    #[test]
    fn degenerate_faces_are_dropped() {
        let cube = box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0));
        let (mut v, mut t) = cube.into_parts();
        v.push(Point3::new(0.5, 0.5, 0.5));
        t.push([0, 0, 1]); // repeated index
        t.push([0, 1, 8]); // non-zero area: kept
        t.push([0, 7, 7]);
        v.push(Point3::new(2.0, 2.0, 2.0));
        t.push([0, 7, 9]); // collinear: zero area
        let m = Mesh::new(v, t).unwrap();
        assert_eq!(report(&m).degenerate_faces, 3);
        let d = drop_degenerate(&m, 1e-12);
        assert_eq!(d.triangles().len(), 13);
        assert_eq!(remove_unused_vertices(&d).vertices().len(), 9);
    }

    #[test]
    fn cuboids_are_closed_outward_boxes_and_bad_boxes_are_errors() {
        let b = Aabb::new(Point3::new(-1.0, 2.0, 0.5), Point3::new(3.0, 2.5, 4.0));
        assert_eq!((b.corner(0), b.corner(7)), (b.min, b.max));
        assert_eq!(b.corner(6), Point3::new(-1.0, 2.5, 4.0));
        let m = Mesh::cuboid(&b).unwrap();
        assert_eq!(m.vertices(), &b.corners()[..]);
        let r = report(&m);
        assert!(r.closed && r.manifold && r.consistently_oriented, "{r:?}");
        assert!(rel_close(r.volume, 4.0 * 0.5 * 3.5, 1e-12), "{}", r.volume);
        // Every face points away from the centre.
        for t in 0..m.triangles().len() {
            let [p, q, s] = m.triangle(t);
            let centroid = Point3::from((p.coords + q.coords + s.coords) / 3.0);
            assert!(m.face_normal(t).unwrap().dot(&(centroid - b.center())) > 0.0, "face {t}");
        }
        // Flat on an axis: valid, no volume; inside out or not finite: an error.
        let flat = Mesh::cuboid(&Aabb::new(b.min, Point3::new(3.0, 2.5, 0.5))).unwrap();
        assert_eq!(flat.signed_volume(), 0.0);
        for bad in [Aabb::new(b.max, b.min), Aabb::new(b.min, Point3::new(f64::NAN, 0.0, 0.0)), Aabb::empty()]
        {
            assert!(matches!(Mesh::cuboid(&bad), Err(GeomError::InvalidArgument(_))), "{bad:?}");
        }
    }

    #[test]
    fn report_on_known_shapes() {
        let cube = box_mesh(Point3::new(-1.0, -1.0, -1.0), Point3::new(1.0, 1.0, 1.0));
        let r = report(&cube);
        assert!(r.closed && r.manifold && r.consistently_oriented, "{r:?}");
        assert_eq!((r.triangles, r.vertices, r.edges, r.bodies, r.euler_characteristic), (12, 8, 18, 1, 2));
        assert!(rel_close(r.volume, 8.0, 1e-12) && rel_close(r.area, 24.0, 1e-12));

        // Two disjoint cubes: two bodies, volumes add.
        let mut two = cube.clone();
        two.append(&box_mesh(Point3::new(5.0, 0.0, 0.0), Point3::new(6.0, 1.0, 1.0)));
        let r = report(&two);
        assert_eq!(r.bodies, 2);
        assert!(rel_close(r.volume, 9.0, 1e-12) && r.closed);

        // One face flipped: closed but not consistently oriented.
        let (v, mut t) = cube.clone().into_parts();
        t[0] = [t[0][0], t[0][2], t[0][1]];
        let r = report(&Mesh::new(v.clone(), t).unwrap());
        assert!(r.closed && !r.consistently_oriented, "{r:?}");

        // A face removed: open with a 3-edge boundary.
        let (_, mut t) = cube.clone().into_parts();
        t.pop();
        let r = report(&Mesh::new(v.clone(), t).unwrap());
        assert!(!r.closed && r.manifold && r.consistently_oriented && r.boundary_edges == 3, "{r:?}");

        // Two cubes touching at one corner: closed, one body, but a bow-tie vertex.
        let mut bow = box_mesh(Point3::origin(), Point3::new(1.0, 1.0, 1.0));
        bow.append(&box_mesh(Point3::new(1.0, 1.0, 1.0), Point3::new(2.0, 2.0, 2.0)));
        let r = report(&bow);
        assert!(r.closed && !r.manifold && r.non_manifold_vertices == 1 && r.bodies == 1, "{r:?}");

        // A fin on an edge: three faces on one edge.
        let (mut v, mut t) = cube.clone().into_parts();
        v.push(Point3::new(0.0, -3.0, -3.0));
        t.push([0, 1, 8]);
        let r = report(&Mesh::new(v, t).unwrap());
        assert!(r.non_manifold_edges == 1 && !r.closed && !r.manifold, "{r:?}");

        // Flipped inside out: negative volume, still consistent.
        let r = report(&cube.flipped());
        assert!(r.volume < 0.0 && r.consistently_oriented);
    }

    #[test]
    fn report_is_invariant_under_rigid_motion() {
        let m = load_mesh(data_dir().join("meshes/classic/gearwheel_40t.bin.stl")).unwrap();
        let r0 = report(&m);
        for (i, t) in [
            Similarity3::new(Vector3::new(100.0, -50.0, 3.0), Vector3::new(0.4, -1.1, 2.0), 1.0),
            Similarity3::new(Vector3::new(-1e4, 0.0, 0.0), Vector3::new(0.0, 3.0, 0.0), 2.0),
        ]
        .iter()
        .enumerate()
        {
            let r = report(&m.transformed(t));
            let s3 = t.scaling().powi(3);
            assert!(
                rel_close(r.volume, r0.volume * s3, 1e-9),
                "transform {i}: {} vs {}",
                r.volume,
                r0.volume
            );
            assert!(rel_close(r.area, r0.area * t.scaling().powi(2), 1e-9), "transform {i}");
            assert_eq!(
                (r.closed, r.manifold, r.consistently_oriented, r.bodies, r.edges),
                (r0.closed, r0.manifold, r0.consistently_oriented, r0.bodies, r0.edges),
                "transform {i}"
            );
        }
    }
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    fn coord() -> impl Strategy<Value = Real> {
        prop_oneof![-1e6..1e6f64, -1.0..1.0f64, Just(0.0), Just(-0.0)]
    }

    fn soup_strategy() -> impl Strategy<Value = Mesh> {
        proptest::collection::vec(proptest::array::uniform3(proptest::array::uniform3(coord())), 1..40)
            .prop_map(|tris| {
                let tris: Vec<[Point3; 3]> = tris.iter().map(|t| t.map(Point3::from)).collect();
                Mesh::from_soup(&tris).unwrap()
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

        /// PLY and OBJ round trips are exact and STL is within f32 rounding, for any
        /// finite coordinates.
        #[test]
        fn writers_and_readers_agree(m in soup_strategy()) {
            let mut ply = Vec::new();
            s2g_geom::write_ply(&mut ply, &m).unwrap();
            prop_assert_eq!(&s2g_geom::read_ply(&ply, Path::new("p.ply")).unwrap(), &m);

            let mut obj = Vec::new();
            s2g_geom::write_obj(&mut obj, &m).unwrap();
            let back = s2g_geom::read_obj(&obj, Path::new("p.obj")).unwrap();
            for (a, b) in m.triangle_points().zip(back.triangle_points()) {
                prop_assert_eq!(a, b);
            }

            let mut stl = Vec::new();
            s2g_geom::write_stl(&mut stl, &m).unwrap();
            let opts = LoadOptions { weld_stl: false, ..LoadOptions::default() };
            let back = s2g_geom::read_stl_with(&stl, Path::new("p.stl"), &opts).unwrap();
            prop_assert_eq!(back.triangles().len(), m.triangles().len());
            for (a, b) in m.vertices().iter().zip(back.vertices()) {
                for c in 0..3 {
                    prop_assert_eq!(b[c], a[c] as f32 as f64);
                }
            }
        }
    }
}
