//! The path field's geometry (§3.2, Eq. 3, 4, 7 of seed 002): against analytic fields
//! (straight lines, circles, latitude circles on spheres) and, on random networks, against
//! finite differences of the host tangent field.

use burn::tensor::{Tensor, TensorData};
use s2g_field::{Backend, PathGeometry, Siren, SirenConfig, geodesic_curvature};

type Derivs = ([f64; 3], [[f64; 3]; 3]);

fn vec2(t: Tensor<2>) -> Vec<f32> {
    t.into_data().try_to_vec::<f32>().unwrap()
}

/// Gradient `[n, 3]` and Hessian `[n, 3, 3]` tensors of an analytic field at `points`.
fn tensors(points: &[[f64; 3]], f: impl Fn([f64; 3]) -> Derivs) -> (Tensor<2>, Tensor<3>) {
    let device = Backend::default().device();
    let (mut g, mut h) = (Vec::new(), Vec::new());
    for &p in points {
        let (gp, hp) = f(p);
        g.extend(gp.map(|c| c as f32));
        h.extend(hp.iter().flatten().map(|&c| c as f32));
    }
    let k = points.len();
    (
        Tensor::<2>::from_data(TensorData::new(g, [k, 3]), &device),
        Tensor::<3>::from_data(TensorData::new(h, [k, 3, 3]), &device),
    )
}

/// `G = z`.
fn planar(_: [f64; 3]) -> Derivs {
    ([0.0, 0.0, 1.0], [[0.0; 3]; 3])
}

/// `s · sqrt(x² + y²)`: gradient `s r̂`, Hessian `s (I - r̂ r̂ᵀ)/r` in the xy-plane.
fn radial(s: f64) -> impl Fn([f64; 3]) -> Derivs {
    move |p| {
        let r = p[0].hypot(p[1]);
        let e = [p[0] / r, p[1] / r, 0.0];
        let h = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                if i < 2 && j < 2 { s * ((i == j) as u8 as f64 - e[i] * e[j]) / r } else { 0.0 }
            })
        });
        (e.map(|c| s * c), h)
    }
}

/// `|x|`: gradient `x/R`, Hessian `(I - n nᵀ)/R`.
fn sphere(p: [f64; 3]) -> Derivs {
    let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    let n = p.map(|c| c / r);
    (n, std::array::from_fn(|i| std::array::from_fn(|j| ((i == j) as u8 as f64 - n[i] * n[j]) / r)))
}

fn geometry(
    points: &[[f64; 3]],
    g: impl Fn([f64; 3]) -> Derivs,
    p: impl Fn([f64; 3]) -> Derivs,
) -> PathGeometry {
    let (gg, gh) = tensors(points, g);
    let (pg, ph) = tensors(points, p);
    let mut geo = PathGeometry::new(gg.clone(), pg.clone());
    geo.geodesic_curvature = Some(geodesic_curvature(gg, gh, pg, ph));
    geo
}

const POINTS: [[f64; 3]; 4] = [[0.5, 0.0, 0.0], [-0.3, 0.4, 0.2], [0.1, -2.0, -1.0], [0.05, 0.05, 3.0]];

#[test]
fn planar_layers_and_planar_path_field_give_straight_paths() {
    // G = z, P = 2x + 5z: paths along +y (ẑ × x̂), spacing 2 (the z part is across the
    // layers, not within them), no turning.
    let p = |_: [f64; 3]| ([2.0, 0.0, 5.0], [[0.0; 3]; 3]);
    let geo = geometry(&POINTS, planar, p);
    let t = vec2(geo.tangent);
    let s = vec2(geo.spacing);
    let gs = vec2(geo.projected_gradient);
    let k = vec2(geo.geodesic_curvature.unwrap());
    for i in 0..POINTS.len() {
        assert_eq!(&t[3 * i..3 * i + 3], &[0.0, 1.0, 0.0], "tangent at {i}");
        assert!((gs[3 * i] - 2.0).abs() < 1e-6 && gs[3 * i + 2].abs() < 1e-6, "∇_s P at {i}");
        assert!((s[i] - 2.0).abs() < 1e-6, "spacing at {i}: {}", s[i]);
        assert!(k[i].abs() < 1e-6, "κ_g at {i}: {}", k[i]);
    }
}

#[test]
fn radial_path_field_on_planar_layers_gives_circles_of_curvature_one_over_r() {
    for sign in [1.0, -1.0] {
        let geo = geometry(&POINTS, planar, radial(sign));
        let t = vec2(geo.tangent);
        let s = vec2(geo.spacing);
        let k = vec2(geo.geodesic_curvature.unwrap());
        for (i, q) in POINTS.iter().enumerate() {
            let r = q[0].hypot(q[1]);
            // Counter-clockwise about +z for P = r (t = θ̂, κ_g = +1/r), clockwise for -r.
            let theta = [-q[1] / r, q[0] / r, 0.0];
            for a in 0..3 {
                assert!((t[3 * i + a] as f64 - sign * theta[a]).abs() < 1e-5, "t at {q:?}");
            }
            assert!((s[i] - 1.0).abs() < 1e-5, "spacing at {q:?}: {}", s[i]);
            let want = sign / r;
            assert!((k[i] as f64 - want).abs() < 1e-4 * want.abs(), "κ_g at {q:?}: {} vs {want}", k[i]);
        }
    }
}

#[test]
fn height_path_field_on_spherical_layers_gives_latitude_circles() {
    // G = |x|, P = z: the paths are latitude circles of radius ρ on spheres of radius R,
    // geodesic curvature z/(R ρ) in magnitude (0 on the equator); the paths run clockwise
    // about the outward normal where z > 0, so κ_g = -z/(R ρ). Spacing |∇_s z| = ρ/R.
    let points = [[1.0, 0.0, 0.0], [0.6, 0.0, 0.8], [-1.0, 2.0, 2.0], [0.3, -0.4, -1.2]];
    let geo = geometry(&points, sphere, |_| ([0.0, 0.0, 1.0], [[0.0; 3]; 3]));
    let s = vec2(geo.spacing);
    let k = vec2(geo.geodesic_curvature.unwrap());
    let t = vec2(geo.tangent);
    for (i, p) in points.iter().enumerate() {
        let rho = p[0].hypot(p[1]);
        let r = (rho * rho + p[2] * p[2]).sqrt();
        assert!((s[i] as f64 - rho / r).abs() < 1e-5, "spacing at {p:?}: {}", s[i]);
        let want = -p[2] / (r * rho);
        assert!((k[i] as f64 - want).abs() < 1e-4 * (1.0 + want.abs()), "κ_g at {p:?}: {} vs {want}", k[i]);
        // Horizontal and tangent to the sphere.
        let dot: f64 = (0..3).map(|a| t[3 * i + a] as f64 * p[a]).sum();
        assert!(t[3 * i + 2].abs() < 1e-6 && dot.abs() < 1e-5, "t at {p:?}");
    }
}

/// The host tangent `n × ∇P / |n × ∇P|` in `f64`.
fn host_tangent(g: &s2g_field::SirenF64, p: &s2g_field::SirenF64, x: [f64; 3]) -> [f64; 3] {
    let (_, a) = g.value_gradient(x);
    let (_, b) = p.value_gradient(x);
    let u = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let l = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    u.map(|c| c / l)
}

#[test]
fn geodesic_curvature_of_networks_matches_finite_differences() {
    // Two random networks with curved level sets: κ_g from the forward-propagated
    // derivatives against (dt/ds) · (n × t) by central differences of the host tangent.
    let device = Backend::default().device();
    let cfg = |seed| SirenConfig { sine_layers: 2, width: 24, first_omega: 2.0, hidden_omega: 30.0, seed };
    let g = Siren::new(&cfg(1), &device).unwrap();
    let p = Siren::new(&cfg(2), &device).unwrap();
    let (gh, ph) = (g.to_f64().unwrap(), p.to_f64().unwrap());
    let pts: Vec<[f64; 3]> = (0..12)
        .map(|i| {
            let s = i as f64;
            [0.7 * (1.3 * s).sin(), 0.6 * (0.7 * s + 1.0).cos(), 0.5 * (2.1 * s).sin()]
        })
        .collect();
    let x = Tensor::<2>::from_data(
        TensorData::new(pts.iter().flatten().map(|&c| c as f32).collect::<Vec<_>>(), [pts.len(), 3]),
        &device,
    );
    let geo = PathGeometry::from_fields(&g.forward_hessian(x.clone()), &p.forward_hessian(x));
    let k = vec2(geo.geodesic_curvature.unwrap());
    let t_tensor = vec2(geo.tangent);
    let mut checked = 0;
    for (i, &x) in pts.iter().enumerate() {
        let t = host_tangent(&gh, &ph, x);
        let (_, a) = gh.value_gradient(x);
        let la = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let n = a.map(|c| c / la);
        let side = [n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0]];
        let h = 1e-4;
        let tp = host_tangent(&gh, &ph, std::array::from_fn(|k| x[k] + h * t[k]));
        let tm = host_tangent(&gh, &ph, std::array::from_fn(|k| x[k] - h * t[k]));
        let fd: f64 = (0..3).map(|k| (tp[k] - tm[k]) / (2.0 * h) * side[k]).sum();
        for a in 0..3 {
            assert!((t_tensor[3 * i + a] as f64 - t[a]).abs() < 1e-4, "t at {x:?}");
        }
        assert!((k[i] as f64 - fd).abs() < 2e-3 * (1.0 + fd.abs()), "κ_g at {x:?}: {} vs fd {fd}", k[i]);
        if fd.abs() > 0.05 {
            checked += 1;
        }
    }
    // The networks' paths do curve: the comparison is not between zeros.
    assert!(checked >= 6, "only {checked} points with |κ_g| > 0.05");
}

/// `n` points in the annulus `0.15 <= r <= 0.45`, `|z| <= 0.3` (a deterministic
/// low-discrepancy sequence), with the circular direction field `θ̂` there.
fn annulus(n: usize) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let frac = |x: f64| x - x.floor();
    let mut points = Vec::with_capacity(n);
    let mut dirs = Vec::with_capacity(n);
    for i in 0..n {
        let k = i as f64 + 0.5;
        let r = (0.15f64.powi(2) + frac(k * 0.618_033_988_7) * (0.45f64.powi(2) - 0.15f64.powi(2))).sqrt();
        let a = std::f64::consts::TAU * frac(k * 0.754_877_666_2);
        let z = 0.6 * frac(k * 0.569_840_290_9) - 0.3;
        points.push([r * a.cos(), r * a.sin(), z]);
        dirs.push([-a.sin(), a.cos(), 0.0]);
    }
    (points, dirs)
}

/// A planar layer field `G ≈ z`, fitted once per call (well under a second).
fn planar_layer() -> s2g_field::SirenF64 {
    let opts = s2g_field::LayerOptions {
        network: SirenConfig { sine_layers: 2, width: 32, first_omega: 3.0, hidden_omega: 30.0, seed: 0 },
        pretrain_steps: 200,
        ..Default::default()
    };
    s2g_field::pretrain_planar(&opts).unwrap().to_f64().unwrap()
}

#[test]
fn path_field_learns_contour_parallel_circles() {
    // Planar layers, paths prescribed along θ̂ in an annulus (contour-parallel to a round
    // boundary) with unit spacing: P should become ±r, whose paths are circles with
    // κ_g = ±1/r.
    let layer = planar_layer();
    let (points, dirs) = annulus(600);
    let options = s2g_field::PathOptions { steps: 250, ..Default::default() };
    let device = Backend::default().device();
    let before_net = Siren::new(&options.network, &device).unwrap().to_f64().unwrap();
    let before = s2g_field::path_stats(&layer, &before_net, &points, &dirs, Backend::default()).unwrap();
    let (net, report) = s2g_field::optimize_path(&layer, &points, &dirs, &options).unwrap();
    let after =
        s2g_field::path_stats(&layer, &net.to_f64().unwrap(), &points, &dirs, Backend::default()).unwrap();
    println!("before {before:?}\nafter {after:?}\n{report:?}");
    assert!(report.totals[1] < 0.05 * report.totals[0], "total loss {:?}", report.totals);
    // Eq. 28 from |∇_s P| ≈ 0 to ≈ 1; the non-normalised Eq. 20 starts small (the random
    // P is nearly flat) and ends as sin² of the angle to θ̂ (|∇G × ∇P| ≈ 1): under 1°.
    assert!(report.final_losses[0] < 0.02 * report.initial_losses[0], "spacing {report:?}");
    assert!(report.final_losses[1] < 3e-4, "alignment {report:?}");
    assert!(before.mean_angle_deg > 30.0, "random P already aligned: {before:?}");
    assert!(after.mean_angle_deg < 5.0, "mean angle to θ̂ {after:?}");
    assert!((after.spacing_mean - 1.0).abs() < 0.05 && after.spacing_cv < 0.1, "spacing {after:?}");
    // Circles of radius 0.15..0.45: mean 1/r about 3.3.
    let mean_inv_r = points.iter().map(|p| 1.0 / p[0].hypot(p[1])).sum::<f64>() / points.len() as f64;
    assert!(
        (after.mean_abs_curvature / mean_inv_r - 1.0).abs() < 0.1,
        "mean |κ_g| {} vs mean 1/r {mean_inv_r}",
        after.mean_abs_curvature
    );
}

#[test]
fn curvature_loss_straightens_the_paths() {
    // Spacing only (no direction prescribed) leaves P's paths as they come out of the
    // random start; adding Eq. 25 (κ̄ = 0) straightens them.
    let layer = planar_layer();
    let (points, _) = annulus(400);
    let none = vec![[0.0; 3]; points.len()];
    let run = |curvature: f64| {
        let options = s2g_field::PathOptions {
            steps: 120,
            weights: s2g_field::PathWeights { curvature, ..Default::default() },
            ..Default::default()
        };
        let (net, report) = s2g_field::optimize_path(&layer, &points, &none, &options).unwrap();
        let stats = s2g_field::path_stats(&layer, &net.to_f64().unwrap(), &points, &none, Backend::default())
            .unwrap();
        (stats, report)
    };
    let (free, free_report) = run(0.0);
    let (straight, report) = run(0.3);
    println!("free {free:?}\nstraight {straight:?}\n{report:?}");
    assert_eq!(free_report.final_losses[3], 0.0);
    assert!(report.final_losses[3] < 0.5 * report.initial_losses[3], "Eq. 25 {report:?}");
    assert!(straight.mean_angle_deg.is_nan());
    assert!(straight.mean_abs_curvature < 0.5 * free.mean_abs_curvature, "{straight:?} vs {free:?}");
    assert!((straight.spacing_mean - 1.0).abs() < 0.1, "{straight:?}");
}

#[test]
fn path_optimisation_is_deterministic_and_refuses_bad_input() {
    use s2g_field::{FieldError, PathOptions, optimize_path};
    let layer = planar_layer();
    let (points, dirs) = annulus(64);
    let options = PathOptions { steps: 5, batch_size: 32, ..Default::default() };
    let (_, a) = optimize_path(&layer, &points, &dirs, &options).unwrap();
    let (_, b) = optimize_path(&layer, &points, &dirs, &options).unwrap();
    assert_eq!((a.initial_losses, a.final_losses), (b.initial_losses, b.final_losses));
    let err = |p: &[[f64; 3]], d: &[[f64; 3]], o: &PathOptions| optimize_path(&layer, p, d, o).unwrap_err();
    assert!(matches!(err(&[], &[], &options), FieldError::InvalidArgument(_)));
    assert!(matches!(err(&points, &dirs[1..], &options), FieldError::InvalidArgument(_)));
    let mut bad = points.clone();
    bad[3][1] = f64::NAN;
    assert!(matches!(err(&bad, &dirs, &options), FieldError::NonFinite { index: 3, .. }));
    let mut bad_dirs = dirs.clone();
    bad_dirs[7][0] = f64::INFINITY;
    assert!(matches!(
        err(&points, &bad_dirs, &options),
        FieldError::NonFinite { what: "direction", index: 7 }
    ));
    for o in [
        PathOptions { steps: 0, ..options.clone() },
        PathOptions { target_spacing: 0.0, ..options.clone() },
        PathOptions { learning_rate: f64::NAN, ..options.clone() },
        PathOptions {
            weights: s2g_field::PathWeights { alignment: -1.0, ..Default::default() },
            ..options.clone()
        },
    ] {
        assert!(matches!(err(&points, &dirs, &o), FieldError::InvalidConfig { .. }), "{o:?}");
    }
    let t = Tensor::<2>::zeros([2, 1], &Backend::default().device());
    assert!(s2g_field::path_curvature_loss(t.clone(), t.clone(), 0.0, 0.0).is_err());
    assert!(s2g_field::path_curvature_loss(t.clone(), t, -1.0, 0.1).is_err());
}
