//! §3.2 geometric quantities: against analytic fields (sphere distance, paraboloid) and,
//! on a random network, against finite differences of the host normal field.

use burn::tensor::{Tensor, TensorData};
use s2g_field::{Backend, LayerGeometry, Siren, SirenConfig};

fn vec2(t: Tensor<2>) -> Vec<f32> {
    t.into_data().try_to_vec::<f32>().unwrap()
}

/// Gradient and Hessian of `G = |x|` at `points`: `x/r`, `(I - n nᵀ)/r`.
fn sphere_field(points: &[[f64; 3]]) -> (Tensor<2>, Tensor<3>) {
    let device = Backend::default().device();
    let mut g = Vec::new();
    let mut h = Vec::new();
    for p in points {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        let n = p.map(|c| c / r);
        g.extend(n.map(|c| c as f32));
        for i in 0..3 {
            for j in 0..3 {
                h.push((((i == j) as u8 as f64 - n[i] * n[j]) / r) as f32);
            }
        }
    }
    let k = points.len();
    (
        Tensor::<2>::from_data(TensorData::new(g, [k, 3]), &device),
        Tensor::<3>::from_data(TensorData::new(h, [k, 3, 3]), &device),
    )
}

#[test]
fn sphere_distance_level_sets_have_curvature_one_over_r() {
    let points = [[3.0, 0.0, 0.0], [0.0, -0.5, 0.0], [1.0, 2.0, -2.0], [0.1, 0.2, 0.3]];
    let (g, h) = sphere_field(&points);
    let geo = LayerGeometry::new(g, h);
    let mean = vec2(geo.mean_curvature.clone());
    let gauss = vec2(geo.gaussian_curvature.clone());
    let spacing = vec2(geo.spacing.clone());
    let normal = vec2(geo.normal.clone());
    let (k1, k2) = geo.principal_curvatures();
    let (k1, k2) = (vec2(k1), vec2(k2));
    let kmax = vec2(geo.max_abs_curvature());
    for (i, p) in points.iter().enumerate() {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        let tol = 1e-4 / r;
        assert!((mean[i] as f64 - 1.0 / r).abs() < tol, "H at {p:?}: {} vs {}", mean[i], 1.0 / r);
        assert!((gauss[i] as f64 - 1.0 / (r * r)).abs() < tol / r, "K at {p:?}: {}", gauss[i]);
        assert!((spacing[i] - 1.0).abs() < 1e-5);
        for a in 0..3 {
            assert!((normal[3 * i + a] as f64 - p[a] / r).abs() < 1e-5);
        }
        // Umbilic: both principal curvatures 1/r (the discriminant guard adds ~1e-6).
        for k in [k1[i], k2[i], kmax[i]] {
            assert!((k as f64 - 1.0 / r).abs() < 1e-3 / r + 2e-6, "κ at {p:?}: {k}");
        }
    }
}

#[test]
fn paraboloid_and_cylinder_curvatures() {
    let device = Backend::default().device();
    // G = z - a (x² + y²) at the origin (H = -2a, K = 4a²), scaled by 3 (curvature is
    // invariant to the field's scale), and G = |(x, y)| - a cylinder of radius 2 at
    // (2, 0, 5): H = 1/(2·2), K = 0, κ = (1/2, 0).
    let a = 0.7f32;
    let g = Tensor::<2>::from_data(TensorData::new(vec![0.0f32, 0.0, 3.0, 1.0, 0.0, 0.0], [2, 3]), &device);
    let h = Tensor::<3>::from_data(
        TensorData::new(
            vec![
                -6.0 * a,
                0.0,
                0.0,
                0.0,
                -6.0 * a,
                0.0,
                0.0,
                0.0,
                0.0, // paraboloid
                0.0,
                0.0,
                0.0,
                0.0,
                0.5,
                0.0,
                0.0,
                0.0,
                0.0, // cylinder: (I - n nᵀ - e_z e_zᵀ)/r
            ],
            [2, 3, 3],
        ),
        &device,
    );
    let geo = LayerGeometry::new(g, h);
    let mean = vec2(geo.mean_curvature.clone());
    let gauss = vec2(geo.gaussian_curvature.clone());
    assert!((mean[0] + 2.0 * a).abs() < 1e-5, "paraboloid H {}", mean[0]);
    assert!((gauss[0] - 4.0 * a * a).abs() < 1e-5, "paraboloid K {}", gauss[0]);
    assert!((mean[1] - 0.25).abs() < 1e-6, "cylinder H {}", mean[1]);
    assert!(gauss[1].abs() < 1e-6, "cylinder K {}", gauss[1]);
    let (k1, k2) = geo.principal_curvatures();
    let (k1, k2) = (vec2(k1), vec2(k2));
    assert!((k1[1] - 0.5).abs() < 1e-5 && k2[1].abs() < 1e-5, "cylinder κ {} {}", k1[1], k2[1]);
    assert!((vec2(geo.max_abs_curvature())[0] - 2.0 * a).abs() < 1e-3);
}

/// On a random SIREN, `H = ½ ∇·n` with `n` from the host gradient, by central differences.
#[test]
fn network_mean_curvature_is_half_the_divergence_of_the_normal() {
    let device = Backend::default().device();
    let cfg = SirenConfig { sine_layers: 2, width: 24, first_omega: 3.0, seed: 5, ..SirenConfig::default() };
    let net = Siren::new(&cfg, &device).unwrap();
    let host = net.to_f64().unwrap();
    let pts = [[0.1f64, -0.2, 0.3], [-0.4, 0.25, 0.05], [0.3, 0.3, -0.3]];
    let flat: Vec<f32> = pts.iter().flat_map(|p| p.map(|c| c as f32)).collect();
    let out = net.forward_hessian(Tensor::<2>::from_data(TensorData::new(flat, [3, 3]), &device));
    let geo = LayerGeometry::from_field(&out);
    let mean = vec2(geo.mean_curvature);
    let normal = |p: [f64; 3]| {
        let (_, g) = host.value_gradient(p);
        let n = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        g.map(|c| c / n)
    };
    let step = 1e-4;
    for (i, p) in pts.iter().enumerate() {
        let mut div = 0.0;
        for a in 0..3 {
            let (mut hi, mut lo) = (*p, *p);
            hi[a] += step;
            lo[a] -= step;
            div += (normal(hi)[a] - normal(lo)[a]) / (2.0 * step);
        }
        let expected = 0.5 * div;
        let err = (mean[i] as f64 - expected).abs();
        assert!(err < 1e-3 * (1.0 + expected.abs()), "point {p:?}: H {} vs ½ div n {expected}", mean[i]);
    }
}
