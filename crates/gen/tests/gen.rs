//! The generator's properties over many seeds: every part closed, 2-manifold,
//! outward-wound, of the volume its own formula gives, and the same bytes per seed.

use s2g_gen::{Feature, GenError, GenOptions, Kind, SHOP_PARTS, generate, shop_parts};
use s2g_geom::{Mesh, report, write_stl};

/// Checks one part: topology, volume against its formula, bounding box within size.
fn check(mesh: &Mesh, volume: f64, size: f64, what: &str) {
    let r = report(mesh);
    assert!(r.closed, "{what}: not closed ({} boundary edges)", r.boundary_edges);
    assert!(
        r.manifold,
        "{what}: not manifold ({} edges, {} vertices)",
        r.non_manifold_edges, r.non_manifold_vertices
    );
    assert!(r.consistently_oriented, "{what}: not consistently oriented");
    assert_eq!(r.degenerate_faces, 0, "{what}: degenerate faces");
    assert!(volume > 0.0, "{what}: volume {volume}");
    assert!(
        (r.volume - volume).abs() <= 1e-9 * volume,
        "{what}: mesh volume {} vs formula {volume}",
        r.volume
    );
    let b = r.bbox.expect("a non-empty mesh");
    let longest = b.extent().max();
    assert!(longest <= size * (1.0 + 1e-9), "{what}: longest side {longest} > {size}");
}

fn stl_bytes(mesh: &Mesh) -> Vec<u8> {
    let mut v = Vec::new();
    write_stl(&mut v, mesh).unwrap();
    v
}

#[test]
fn every_kind_is_a_closed_manifold_of_exact_volume() {
    for kind in [Kind::Prismatic, Kind::Turned, Kind::Freeform, Kind::Mix] {
        for (seed, size) in [(1u64, 100.0), (2, 37.5), (99, 250.0)] {
            let options = GenOptions { kind, size };
            for index in 0..60 {
                let part = generate(seed, index, &options)
                    .unwrap_or_else(|e| panic!("{kind} seed {seed} index {index}: {e}"));
                check(&part.mesh, part.volume, size, &format!("{kind} seed {seed} index {index}"));
            }
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_bytes_and_another_seed_other_parts() {
    let options = GenOptions::default();
    for index in 0..20 {
        let a = generate(5, index, &options).unwrap();
        let b = generate(5, index, &options).unwrap();
        assert_eq!(stl_bytes(&a.mesh), stl_bytes(&b.mesh), "index {index}");
        assert_eq!(a.features, b.features);
        assert_eq!(a.volume.to_bits(), b.volume.to_bits());
        let c = generate(6, index, &options).unwrap();
        assert_ne!(stl_bytes(&a.mesh), stl_bytes(&c.mesh), "index {index}: seeds 5 and 6 agree");
    }
}

#[test]
fn the_stl_of_a_prismatic_part_is_its_mesh_exactly() {
    // Grid coordinates are exact in f32: reading the STL back gives the same volume.
    let part = generate(3, 1, &GenOptions { kind: Kind::Prismatic, size: 100.0 }).unwrap();
    let back = s2g_geom::read_stl(&stl_bytes(&part.mesh), std::path::Path::new("part.stl")).unwrap();
    let r = report(&back);
    assert!(r.closed && r.manifold && r.consistently_oriented);
    assert!((r.volume - part.volume).abs() <= 1e-9 * part.volume, "{} vs {}", r.volume, part.volume);
}

#[test]
fn mix_follows_its_proportions() {
    let options = GenOptions { kind: Kind::Mix, size: 50.0 };
    let mut counts = [0usize; 3];
    let n = 400;
    for index in 0..n {
        let k = generate(11, index, &options).unwrap().kind;
        counts[[Kind::Prismatic, Kind::Turned, Kind::Freeform].iter().position(|&x| x == k).unwrap()] += 1;
    }
    // Binomial standard deviations are about 10 (half) and 9 (quarters): allow 4 of them.
    for (c, p) in counts.iter().zip(s2g_gen::MIX.map(|m| m.1)) {
        let expect = p * n as f64;
        assert!((*c as f64 - expect).abs() < 40.0, "{counts:?}");
    }
}

#[test]
fn shop_parts_are_the_five_in_millimetres() {
    let parts = shop_parts().unwrap();
    assert_eq!(parts.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), SHOP_PARTS);
    for p in &parts {
        check(&p.mesh, p.volume, 100.0, &p.name);
        let e = report(&p.mesh).bbox.unwrap().extent();
        assert!(e.max() >= 60.0 && e.max() <= 100.0, "{}: {e:?}", p.name);
    }
    // The pocketed plate is 100 x 70 x 15 with pockets.
    let plate = &parts[2];
    let e = plate.mesh.bbox().unwrap().extent();
    assert_eq!([e.x, e.y, e.z], [100.0, 70.0, 15.0]);
    assert!(plate.features.iter().filter(|f| matches!(f, Feature::Pocket { .. })).count() >= 2);
    assert_eq!(stl_bytes(&shop_parts().unwrap()[4].mesh), stl_bytes(&parts[4].mesh));
}

#[test]
fn exact_volumes_of_simple_shop_geometry() {
    // The T-slot block: box minus the T (neck 12 x 12, head 22 x 10) along 100 mm, minus
    // four 48-gon holes, with the 3 mm corners as 8-chord arcs. Both polygons are regular,
    // so the expected volume follows from their areas (to the grid's snapping).
    let block = &shop_parts().unwrap()[4];
    let chord = |r: f64, n: f64, sweep: f64| 0.5 * r * r * n * (sweep / n).sin();
    let corners = 4.0 * (3.0 * 3.0 - chord(3.0, 8.0, std::f64::consts::FRAC_PI_2));
    let hole = chord(4.25, 48.0, std::f64::consts::TAU);
    let expect = (100.0 * 60.0 - corners) * 40.0 - 100.0 * (12.0 * 12.0 + 22.0 * 10.0) - 4.0 * hole * 40.0;
    assert!((block.volume - expect).abs() < 1e-3 * expect / 1e3, "{} vs {expect}", block.volume);
}

#[test]
fn bad_options_are_typed_errors() {
    for size in [-1.0, 0.0, f64::NAN, f64::INFINITY, 0.5, 5000.0] {
        let e = generate(1, 0, &GenOptions { kind: Kind::Mix, size }).unwrap_err();
        assert!(matches!(e, GenError::InvalidOption { name: "size", .. }), "{size}: {e}");
    }
    assert!(matches!("cube".parse::<Kind>(), Err(GenError::UnknownKind(_))));
    assert_eq!("turned".parse::<Kind>().unwrap(), Kind::Turned);
    let e = generate(1, 5, &GenOptions { kind: Kind::Shop, size: 100.0 }).unwrap_err();
    assert!(matches!(e, GenError::InvalidOption { name: "index", .. }));
}
