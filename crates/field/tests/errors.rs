//! Bad input is a typed error (or a documented NaN), never a panic.

use s2g_field::{
    Backend, FieldError, NeuralSdf, SdfOptions, Siren, SirenConfig, fit_sdf_opt, fit_sdf_samples, sdf_error,
    validation_points,
};
use s2g_geom::{Aabb, Mesh, Point3, SignedDistance, Sphere, SurfaceSamples, Vector3};

fn tiny() -> SdfOptions {
    SdfOptions {
        network: SirenConfig { sine_layers: 1, width: 8, ..SirenConfig::default() },
        epochs: 1,
        surface_samples: 64,
        general_samples: 64,
        batch_size: 64,
        ..SdfOptions::default()
    }
}

fn unit_sphere() -> (Sphere, SurfaceSamples, Aabb) {
    let s = Sphere { center: Point3::origin(), radius: 0.4 };
    let mut samples = SurfaceSamples::default();
    for i in 0..64 {
        let t = i as f64 * 0.7;
        let d = Vector3::new(t.cos(), t.sin(), (i as f64 / 32.0) - 1.0).normalize();
        samples.points.push(Point3::from(d * 0.4));
        samples.normals.push(d);
    }
    (s, samples, Aabb::new(Point3::new(-0.5, -0.5, -0.5), Point3::new(0.5, 0.5, 0.5)))
}

#[test]
fn bad_options_are_refused() {
    let (s, samples, bbox) = unit_sphere();
    let cases: Vec<(&str, SdfOptions)> = vec![
        ("epochs", SdfOptions { epochs: 0, ..tiny() }),
        ("batch_size", SdfOptions { batch_size: 0, ..tiny() }),
        ("general_samples", SdfOptions { general_samples: 0, ..tiny() }),
        ("learning_rate", SdfOptions { learning_rate: f64::NAN, ..tiny() }),
        ("near_fraction", SdfOptions { near_fraction: 1.5, ..tiny() }),
        ("padding", SdfOptions { padding: -1.0, ..tiny() }),
        ("first_omega", SdfOptions { network: SirenConfig { first_omega: 0.0, ..tiny().network }, ..tiny() }),
        (
            "hidden_omega",
            SdfOptions { network: SirenConfig { hidden_omega: f64::INFINITY, ..tiny().network }, ..tiny() },
        ),
        ("width", SdfOptions { network: SirenConfig { width: 0, ..tiny().network }, ..tiny() }),
        ("sine_layers", SdfOptions { network: SirenConfig { sine_layers: 0, ..tiny().network }, ..tiny() }),
    ];
    for (name, options) in cases {
        match fit_sdf_samples(&samples, &s, &bbox, &options) {
            Err(FieldError::InvalidConfig { field, .. }) => assert_eq!(field, name),
            other => panic!("{name}: expected InvalidConfig, got {other:?}"),
        }
    }
    assert!(matches!(
        Siren::new(&SirenConfig { width: 0, ..SirenConfig::default() }, &Backend::default().device()),
        Err(FieldError::InvalidConfig { field: "width", .. })
    ));
}

#[test]
fn bad_data_is_refused() {
    let (s, samples, bbox) = unit_sphere();
    let empty = Mesh::new(Vec::new(), Vec::new()).unwrap();
    assert!(matches!(fit_sdf_opt(&empty, &tiny()), Err(FieldError::EmptyMesh)));
    let flat = Mesh::from_soup(&[[Point3::origin(), Point3::new(1.0, 0.0, 0.0), Point3::new(2.0, 0.0, 0.0)]])
        .unwrap();
    assert!(matches!(fit_sdf_opt(&flat, &tiny()), Err(FieldError::EmptyMesh | FieldError::Geometry(_))));

    let mut nan = samples.clone();
    nan.points[5].y = f64::NAN;
    assert!(matches!(
        fit_sdf_samples(&nan, &s, &bbox, &tiny()),
        Err(FieldError::NonFinite { what: "surface point", index: 5 })
    ));
    let mut nan = samples.clone();
    nan.normals[7].z = f64::INFINITY;
    assert!(matches!(fit_sdf_samples(&nan, &s, &bbox, &tiny()), Err(FieldError::NonFinite { index: 7, .. })));
    let mut short = samples.clone();
    short.normals.pop();
    assert!(matches!(fit_sdf_samples(&short, &s, &bbox, &tiny()), Err(FieldError::InvalidArgument(_))));
    assert!(matches!(
        fit_sdf_samples(&SurfaceSamples::default(), &s, &bbox, &tiny()),
        Err(FieldError::InvalidArgument(_))
    ));
    let flat_box = Aabb::new(Point3::origin(), Point3::origin());
    assert!(matches!(fit_sdf_samples(&samples, &s, &flat_box, &tiny()), Err(FieldError::InvalidArgument(_))));

    // A reference field that answers NaN.
    struct Broken;
    impl SignedDistance for Broken {
        fn distance(&self, _: &Point3) -> f64 {
            f64::NAN
        }
    }
    assert!(matches!(
        fit_sdf_samples(&samples, &Broken, &bbox, &tiny()),
        Err(FieldError::NonFinite { what: "reference distance", .. })
    ));

    assert!(matches!(sdf_error(&s, &s, &[]), Err(FieldError::InvalidArgument(_))));
    assert!(matches!(
        sdf_error(&s, &s, &[Point3::new(f64::NAN, 0.0, 0.0)]),
        Err(FieldError::NonFinite { .. })
    ));
    assert!(validation_points(&SurfaceSamples::default(), 3, 0.1, &bbox, 0, 1).is_err());
    assert!(validation_points(&samples, 3, -0.1, &bbox, 0, 1).is_err());
}

#[test]
fn nan_queries_give_nan_and_bad_files_are_refused() {
    let (s, samples, bbox) = unit_sphere();
    let (sdf, _) = fit_sdf_samples(&samples, &s, &bbox, &tiny()).unwrap();
    assert!(sdf.distance(&Point3::new(f64::NAN, 0.0, 0.0)).is_nan());
    assert_eq!(sdf.gradient(&Point3::new(0.0, f64::INFINITY, 0.0)), Vector3::zeros());

    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.sdf");
    assert!(matches!(NeuralSdf::load(&missing), Err(FieldError::Io { .. })));
    let bytes = sdf.to_bytes().unwrap();
    for (name, bad) in [
        ("magic", [b"XXXXXXXX".as_slice(), &bytes[8..]].concat()),
        ("truncated header", bytes[..20].to_vec()),
        ("truncated payload", bytes[..bytes.len() - 3].to_vec()),
        ("trailing", [bytes.as_slice(), b"!"].concat()),
        ("zero width", {
            let mut b = bytes.clone();
            b[20..28].copy_from_slice(&0u64.to_le_bytes());
            b
        }),
        ("wide", {
            let mut b = bytes.clone();
            b[20..28].copy_from_slice(&9u64.to_le_bytes());
            b
        }),
    ] {
        let path = dir.path().join("bad.sdf");
        std::fs::write(&path, &bad).unwrap();
        match NeuralSdf::load(&path) {
            Err(FieldError::Checkpoint { path: p, .. }) => assert_eq!(p, path, "{name}"),
            other => panic!("{name}: expected Checkpoint, got {other:?}"),
        }
    }
    assert_eq!(NeuralSdf::from_bytes(&bytes).unwrap(), sdf);
}
