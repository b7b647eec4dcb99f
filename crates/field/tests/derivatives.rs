//! The forward-propagated input derivatives against finite differences and Burn's autodiff.
//!
//! The reference is `SirenF64`: the network's own f32 weights evaluated in f64. Its value
//! is checked against the tensor forward pass, its gradient against central differences of
//! its value and its Hessian against central differences of its gradient (all in f64,
//! relative error at most 1e-6). The tensor (f32) gradient and Hessian are then checked
//! against it with the documented f32 bound: the largest error over the batch at most 1e-4
//! of the largest magnitude of that quantity over the batch.

use burn::tensor::{Tensor, TensorData};
use s2g_field::{Backend, Siren, SirenConfig};

const F32_BOUND: f64 = 1e-4;
const F64_BOUND: f64 = 1e-6;

fn points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    // A small LCG is enough to spread test points; the network has its own seed.
    let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut next = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((s >> 11) as f64 / (1u64 << 53) as f64) * 1.2 - 0.6
    };
    (0..n).map(|_| [next(), next(), next()]).collect()
}

fn to_tensor(pts: &[[f64; 3]], device: &burn::tensor::Device) -> Tensor<2> {
    let flat: Vec<f32> = pts.iter().flat_map(|p| p.map(|c| c as f32)).collect();
    Tensor::<2>::from_data(TensorData::new(flat, [pts.len(), 3]), device)
}

fn read<const D: usize>(t: Tensor<D>) -> Vec<f64> {
    t.into_data().try_into_vec::<f32>().unwrap().into_iter().map(f64::from).collect()
}

/// Largest `|a - b|` over the largest `|b|` (plus a floor so zero vectors do not divide).
fn rel_error(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-12);
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

fn check(config: &SirenConfig) {
    let device = Backend::default().device();
    let net = Siren::new(config, &device).unwrap();
    let host = net.to_f64().unwrap();
    let pts = points(48, config.seed);
    let n = pts.len();
    let out = net.forward_hessian(to_tensor(&pts, &device));
    let (value, grad, hess) = (read(out.value), read(out.gradient), read(out.hessian));
    let cheap = net.forward_gradient(to_tensor(&pts, &device));
    let (value2, grad2) = (read(cheap.value), read(cheap.gradient));

    let h = 1e-5;
    let mut host_v = Vec::with_capacity(n);
    let mut host_g = Vec::with_capacity(3 * n);
    let mut host_h = Vec::with_capacity(9 * n);
    let mut fd_g = Vec::with_capacity(3 * n);
    let mut fd_h = Vec::with_capacity(9 * n);
    for p in &pts {
        let (v, g, hh) = host.value_gradient_hessian(*p);
        assert_eq!((v, g), host.value_gradient(*p), "the two host paths differ at {p:?}");
        assert_eq!(v, host.value(*p), "host value paths differ at {p:?}");
        host_v.push(v);
        host_g.extend(g);
        host_h.extend(hh.iter().flatten());
        for i in 0..3 {
            let (mut a, mut b) = (*p, *p);
            a[i] += h;
            b[i] -= h;
            fd_g.push((host.value(a) - host.value(b)) / (2.0 * h));
            let (ga, gb) = (host.value_gradient(a).1, host.value_gradient(b).1);
            // Row i of the Hessian: d(grad)/dx_i, symmetric so also column i.
            for j in 0..3 {
                fd_h.push((ga[j] - gb[j]) / (2.0 * h));
            }
        }
    }
    let e = rel_error(&host_g, &fd_g);
    assert!(e < F64_BOUND, "{config:?}: f64 gradient vs finite differences: relative error {e:e}");
    let e = rel_error(&host_h, &fd_h);
    assert!(e < F64_BOUND, "{config:?}: f64 Hessian vs finite differences: relative error {e:e}");

    let e = rel_error(&value, &host_v);
    assert!(e < F32_BOUND, "{config:?}: tensor value vs f64: relative error {e:e}");
    let e = rel_error(&grad, &host_g);
    assert!(e < F32_BOUND, "{config:?}: tensor gradient vs f64: relative error {e:e}");
    let e = rel_error(&hess, &host_h);
    assert!(e < F32_BOUND, "{config:?}: tensor Hessian vs f64: relative error {e:e}");
    // The cheap pass gives the same value and gradient as the full one.
    assert!(
        rel_error(&value2, &value) < 1e-6 && rel_error(&grad2, &grad) < 1e-6,
        "{config:?}: passes differ"
    );
    // The Hessian is symmetric.
    for k in 0..n {
        for i in 0..3 {
            for j in 0..3 {
                let (a, b) = (hess[9 * k + 3 * i + j], hess[9 * k + 3 * j + i]);
                assert!((a - b).abs() <= 1e-5 * (1.0 + a.abs()), "{config:?}: H not symmetric at point {k}");
            }
        }
    }
}

#[test]
fn tensor_derivatives_match_f64_finite_differences() {
    for config in [
        SirenConfig { sine_layers: 1, width: 8, seed: 1, ..SirenConfig::default() },
        SirenConfig { sine_layers: 3, width: 32, seed: 2, ..SirenConfig::default() },
        SirenConfig { sine_layers: 4, width: 24, first_omega: 60.0, hidden_omega: 10.0, seed: 3 },
    ] {
        check(&config);
    }
}

#[test]
fn tensor_gradient_matches_burn_autodiff() {
    let device = Backend::default().device().autodiff();
    let config = SirenConfig { sine_layers: 3, width: 32, seed: 9, ..SirenConfig::default() };
    let net = Siren::new(&config, &device).unwrap();
    let pts = points(32, 9);
    let x = to_tensor(&pts, &device).require_grad();
    let out = net.forward_gradient(x.clone());
    let grads = out.value.sum().backward();
    let auto = read(x.grad(&grads).expect("the input is tracked"));
    let ours = read(out.gradient);
    let e = rel_error(&ours, &auto);
    assert!(e < F32_BOUND, "forward-mode gradient vs autodiff: relative error {e:e}");
}

#[test]
fn initialisation_is_seeded_and_frequencies_matter() {
    let device = Backend::default().device();
    let config = SirenConfig { sine_layers: 2, width: 16, seed: 4, ..SirenConfig::default() };
    let a = Siren::new(&config, &device).unwrap().to_f64().unwrap();
    let b = Siren::new(&config, &device).unwrap().to_f64().unwrap();
    assert_eq!(a, b, "same seed, same network");
    let c = Siren::new(&SirenConfig { seed: 5, ..config.clone() }, &device).unwrap().to_f64().unwrap();
    assert_ne!(a, c, "another seed, another network");
    // A higher first-layer frequency gives a steeper field at initialisation (§7.5.1).
    let steep =
        Siren::new(&SirenConfig { first_omega: 90.0, ..config.clone() }, &device).unwrap().to_f64().unwrap();
    let mean_grad = |net: &s2g_field::SirenF64| {
        let pts = points(200, 11);
        pts.iter().map(|p| net.value_gradient(*p).1.iter().map(|g| g * g).sum::<f64>().sqrt()).sum::<f64>()
            / 200.0
    };
    assert!(mean_grad(&steep) > 2.0 * mean_grad(&a), "{} vs {}", mean_grad(&steep), mean_grad(&a));
    // The rebuilt Burn network is the same function.
    let rebuilt = a.to_siren(&device).to_f64().unwrap();
    assert_eq!(rebuilt, a);
}
