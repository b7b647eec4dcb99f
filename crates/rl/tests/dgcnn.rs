//! The DGCNN point-cloud encoder: shapes of the output, invariances, the neighbour graph,
//! degenerate clouds, pretraining, and its weights as bytes.

use s2g_rl::{Backend, DgcnnConfig, DgcnnEncoder, Encoder, FitOptions, RlError, knn_graph};

/// SplitMix64, so the test clouds do not depend on the crate's internals.
struct Rng(u64);

impl Rng {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn below(&mut self, n: usize) -> usize {
        ((self.next_f32() * n as f32) as usize).min(n - 1)
    }
}

fn small_config(seed: u64) -> DgcnnConfig {
    DgcnnConfig { k: 8, edge_widths: vec![16, 16], embedding: 32, seed, ..DgcnnConfig::default() }
}

fn encoder(seed: u64) -> DgcnnEncoder {
    DgcnnEncoder::new(small_config(seed)).unwrap()
}

/// `n` points uniform in the cube `[-0.5, 0.5]^3`.
fn random_cloud(n: usize, seed: u64) -> Vec<[f32; 3]> {
    let mut rng = Rng(seed);
    (0..n).map(|_| [rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5]).collect()
}

/// `n` points uniform on the sphere of radius `r` about `centre`.
fn sphere_cloud(n: usize, r: f32, centre: [f32; 3], seed: u64) -> Vec<[f32; 3]> {
    let mut rng = Rng(seed);
    (0..n)
        .map(|_| {
            let z = 2.0 * rng.next_f32() - 1.0;
            let phi = std::f32::consts::TAU * rng.next_f32();
            let s = (1.0 - z * z).max(0.0).sqrt();
            [centre[0] + r * s * phi.cos(), centre[1] + r * s * phi.sin(), centre[2] + r * z]
        })
        .collect()
}

/// The cloud in a shuffled order.
fn shuffled(cloud: &[[f32; 3]], seed: u64) -> Vec<[f32; 3]> {
    let mut out = cloud.to_vec();
    let mut rng = Rng(seed);
    for i in (1..out.len()).rev() {
        out.swap(i, rng.below(i + 1));
    }
    out
}

#[test]
fn output_has_dim_values_and_is_finite() {
    let enc = encoder(1);
    assert_eq!(enc.dim(), 64);
    assert_eq!(Encoder::dim(&enc), 64);
    for n in [0, 1, 2, 5, 9, 64, 200] {
        let f = enc.encode(&random_cloud(n, n as u64));
        assert_eq!(f.len(), 64, "{n} points");
        assert!(f.iter().all(|v| v.is_finite()), "{n} points: {f:?}");
    }
    // ReLU before both poolings: no feature is negative, and a real cloud has some non-zero.
    let f = enc.encode(&random_cloud(100, 3));
    assert!(f.iter().all(|&v| v >= 0.0));
    assert!(f.iter().any(|&v| v > 0.0));
}

#[test]
fn features_are_invariant_under_permutation() {
    let enc = encoder(2);
    // A random cloud, and a 4x4x4 grid where equal distances make ties in every neighbour
    // list (the tie-breaking must not depend on the order of the points).
    let grid: Vec<[f32; 3]> = (0..64)
        .map(|i| [(i % 4) as f32 * 0.25, ((i / 4) % 4) as f32 * 0.25, (i / 16) as f32 * 0.25])
        .collect();
    for (name, cloud) in [("random", random_cloud(200, 5)), ("grid", grid)] {
        let base = enc.encode(&cloud);
        let mut reversed = cloud.clone();
        reversed.reverse();
        for (how, other) in [("reversed", reversed), ("shuffled", shuffled(&cloud, 9))] {
            let f = enc.encode(&other);
            assert_eq!(f[..32], base[..32], "{name} {how}: max pooling differs");
            for (i, (a, b)) in f[32..].iter().zip(&base[32..]).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-5 * (1.0 + b.abs()),
                    "{name} {how}: mean feature {i}: {a} vs {b}"
                );
            }
        }
    }
}

#[test]
fn same_seed_same_features_other_seed_other_features() {
    let cloud = random_cloud(128, 11);
    let a = encoder(7).encode(&cloud);
    let b = encoder(7).encode(&cloud);
    assert_eq!(a, b, "two encoders from seed 7");
    assert_eq!(a, encoder(7).encode(&cloud), "a third encode");
    let c = encoder(8).encode(&cloud);
    assert_ne!(a, c, "seeds 7 and 8");
    // Different clouds give different features.
    assert_ne!(a, encoder(7).encode(&random_cloud(128, 12)));
    assert_eq!(encoder(3).to_bytes().unwrap(), encoder(3).to_bytes().unwrap(), "same seed, same bytes");
}

#[test]
fn batch_encoding_equals_one_by_one() {
    let enc = encoder(3);
    let clouds =
        [random_cloud(50, 1), Vec::new(), random_cloud(3, 2), random_cloud(120, 3), random_cloud(1, 4)];
    let refs: Vec<&[[f32; 3]]> = clouds.iter().map(Vec::as_slice).collect();
    let batch = enc.encode_batch(&refs).unwrap();
    assert_eq!(batch.len(), clouds.len());
    for (i, (c, f)) in clouds.iter().zip(&batch).enumerate() {
        let single = enc.try_encode(c).unwrap();
        assert_eq!(f.len(), single.len());
        for (j, (a, b)) in f.iter().zip(&single).enumerate() {
            assert!((a - b).abs() <= 1e-6 * (1.0 + b.abs()), "cloud {i} feature {j}: batch {a} vs alone {b}");
        }
    }
    assert!(enc.encode_batch(&[]).unwrap().is_empty());
}

/// Squared distance in f64, the brute-force reference.
fn dist(f: &[f32], dim: usize, i: usize, j: usize) -> f64 {
    (0..dim).map(|c| f64::from(f[i * dim + c] - f[j * dim + c]).powi(2)).sum()
}

#[test]
fn knn_agrees_with_brute_force() {
    // The encoder's distances are `|a|^2 + |b|^2 - 2 a.b` in f32: a neighbour may be up to
    // this much farther (squared) than the exact k-th nearest.
    const TOL: f64 = 2e-5;
    for (n, dim, k) in [(150, 3, 10), (100, 16, 20), (40, 5, 39), (4, 3, 10), (2, 3, 1)] {
        let mut rng = Rng((n * dim + k) as u64);
        let f: Vec<f32> = (0..n * dim).map(|_| rng.next_f32()).collect();
        let graph = knn_graph(&f, dim, k).unwrap();
        assert_eq!(graph.len(), n);
        let k_eff = k.min(n - 1);
        for (i, nb) in graph.iter().enumerate() {
            let case = format!("n {n} dim {dim} k {k} point {i}");
            assert_eq!(nb.len(), k_eff, "{case}");
            assert!(!nb.contains(&i), "{case}: contains itself");
            let mut sorted = nb.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), k_eff, "{case}: duplicates in {nb:?}");
            let mut all: Vec<f64> = (0..n).filter(|&j| j != i).map(|j| dist(&f, dim, i, j)).collect();
            all.sort_by(f64::total_cmp);
            let kth = all[k_eff - 1];
            for w in nb.windows(2) {
                assert!(dist(&f, dim, i, w[0]) <= dist(&f, dim, i, w[1]) + TOL, "{case}: not nearest first");
            }
            for &j in nb {
                assert!(dist(&f, dim, i, j) <= kth + TOL, "{case}: {j} is farther than the k-th nearest");
            }
        }
    }
    assert_eq!(knn_graph(&[0.1, 0.2, 0.3], 3, 5).unwrap(), vec![Vec::<usize>::new()]);
    assert!(knn_graph(&[], 3, 5).unwrap().is_empty());
    // Equal distances: ties go to the neighbour with the smaller values.
    let line = [0.0, 1.0, -1.0, 2.0];
    assert_eq!(knn_graph(&line, 1, 1).unwrap()[0], vec![2], "of the points at distance 1, -1 comes first");
}

#[test]
fn degenerate_clouds_do_not_panic() {
    let enc = encoder(4);
    let zeros = vec![0.0; enc.dim()];
    assert_eq!(enc.encode(&[]), zeros, "empty cloud");
    let nan = [f32::NAN, 0.0, 0.0];
    let inf = [0.0, f32::INFINITY, 0.0];
    assert_eq!(enc.encode(&[nan, inf, [f32::NEG_INFINITY; 3]]), zeros, "only non-finite points");
    let one = enc.encode(&[[0.1, 0.2, 0.3]]);
    assert!(one.iter().all(|v| v.is_finite()), "one point: {one:?}");
    // One point: max and mean pooling of a single embedding are equal.
    assert_eq!(one[..32], one[32..]);
    let same = enc.encode(&[[0.2, 0.2, 0.2]; 30]);
    assert!(same.iter().all(|v| v.is_finite()), "30 copies of one point");
    // Non-finite points are dropped: the rest encodes as if they were never there.
    let cloud = random_cloud(40, 6);
    let mut dirty = cloud.clone();
    dirty.insert(3, nan);
    dirty.insert(20, inf);
    dirty.push([0.0, 0.0, f32::NAN]);
    assert_eq!(enc.encode(&dirty), enc.encode(&cloud), "NaN and inf points not dropped");
    for n in 2..=9 {
        let f = enc.try_encode(&random_cloud(n, 100 + n as u64)).unwrap();
        assert!(f.iter().all(|v| v.is_finite()), "{n} points, k = 8");
    }
}

#[test]
fn bad_configs_are_refused() {
    let base = small_config(0);
    assert!(base.validate().is_ok());
    assert!(DgcnnConfig::default().validate().is_ok());
    let cases = [
        ("k", DgcnnConfig { k: 0, ..base.clone() }),
        ("edge_widths", DgcnnConfig { edge_widths: vec![], ..base.clone() }),
        ("edge_widths", DgcnnConfig { edge_widths: vec![16, 0], ..base.clone() }),
        ("embedding", DgcnnConfig { embedding: 0, ..base.clone() }),
        ("embedding", DgcnnConfig { embedding: usize::MAX, ..base.clone() }),
    ];
    for (field, config) in cases {
        match DgcnnEncoder::new(config.clone()) {
            Err(RlError::InvalidConfig { field: f, .. }) => assert_eq!(f, field, "{config:?}"),
            other => panic!("{config:?}: expected InvalidConfig({field}), got {other:?}"),
        }
    }
}

/// `n` spheres with radii uniform in `0.1..0.5`, 128 points each, centres within 0.05 of the
/// origin; returns the clouds and their radii.
fn spheres(n: usize, seed: u64) -> (Vec<Vec<[f32; 3]>>, Vec<Vec<f32>>) {
    let mut rng = Rng(seed);
    (0..n)
        .map(|i| {
            let r = 0.1 + 0.4 * rng.next_f32();
            let c = [0.1 * rng.next_f32() - 0.05, 0.1 * rng.next_f32() - 0.05, 0.1 * rng.next_f32() - 0.05];
            (sphere_cloud(128, r, c, seed * 1000 + i as u64), vec![r])
        })
        .unzip()
}

fn correlation(a: &[f32], b: &[f32]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) =
        (a.iter().map(|&v| f64::from(v)).sum::<f64>() / n, b.iter().map(|&v| f64::from(v)).sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (dx, dy) = (f64::from(x) - ma, f64::from(y) - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    sab / (saa * sbb).sqrt()
}

#[test]
fn fit_learns_the_radius_of_a_sphere() {
    let (clouds, radii) = spheres(48, 1);
    let (test_clouds, test_radii) = spheres(16, 2);
    let mut enc = encoder(5);
    let before = enc.encode(&test_clouds[0]);
    let options = FitOptions { epochs: 20, learning_rate: 3e-3, batch_size: 8, ..FitOptions::default() };
    let report = enc.fit(&clouds, &radii, &options).unwrap();
    let losses = &report.epoch_losses;
    assert_eq!(losses.len(), 20);
    let (first, last) = (losses[0], *losses.last().unwrap());
    assert!(last < 0.3 * first, "loss fell only from {first} to {last}: {losses:?}");
    assert_ne!(enc.encode(&test_clouds[0]), before, "fit did not keep the trained encoder");

    assert_eq!((report.head.input_dim(), report.head.output_dim()), (enc.dim(), 1));
    let predicted: Vec<f32> =
        test_clouds.iter().map(|c| report.head.predict(&enc.encode(c)).unwrap()[0]).collect();
    let truth: Vec<f32> = test_radii.iter().map(|r| r[0]).collect();
    let rho = correlation(&predicted, &truth);
    assert!(rho > 0.9, "held-out correlation {rho}: predicted {predicted:?}, true {truth:?}");
    let mae = predicted.iter().zip(&truth).map(|(p, t)| (p - t).abs()).sum::<f32>() / truth.len() as f32;
    assert!(mae < 0.03, "held-out mean absolute error {mae} (radii span 0.4)");
    assert!(matches!(report.head.predict(&[0.0; 3]), Err(RlError::StateDim { .. })));
}

#[test]
fn fit_is_deterministic_and_refuses_bad_input() {
    let (clouds, radii) = spheres(8, 3);
    let options = FitOptions { epochs: 3, batch_size: 4, head_hidden: vec![], ..FitOptions::default() };
    let run = || {
        let mut enc = encoder(6);
        let report = enc.fit(&clouds, &radii, &options).unwrap();
        (report, enc.encode(&clouds[0]))
    };
    let (a, fa) = run();
    let (b, fb) = run();
    assert_eq!(a, b, "two fits from the same seeds");
    assert_eq!(fa, fb);

    let mut enc = encoder(6);
    let untouched = enc.encode(&clouds[0]);
    let nan_target = {
        let mut t = radii.clone();
        t[2] = vec![f32::NAN];
        t
    };
    let ragged = {
        let mut t = radii.clone();
        t[1] = vec![0.1, 0.2];
        t
    };
    type Case<'a> = (&'a str, &'a [Vec<[f32; 3]>], &'a [Vec<f32>], FitOptions);
    let cases: [Case<'_>; 6] = [
        ("no clouds", &[], &[], options.clone()),
        ("fewer targets", &clouds, &radii[..7], options.clone()),
        ("NaN target", &clouds, &nan_target, options.clone()),
        ("ragged targets", &clouds, &ragged, options.clone()),
        ("zero epochs", &clouds, &radii, FitOptions { epochs: 0, ..options.clone() }),
        ("bad learning rate", &clouds, &radii, FitOptions { learning_rate: f64::NAN, ..options.clone() }),
    ];
    for (name, c, t, o) in cases {
        let r = enc.fit(c, t, &o);
        assert!(
            matches!(r, Err(RlError::InvalidArgument(_) | RlError::InvalidConfig { .. })),
            "{name}: {r:?}"
        );
    }
    assert_eq!(enc.encode(&clouds[0]), untouched, "a refused fit changed the encoder");
}

#[test]
fn bytes_round_trip_and_junk_is_refused() {
    let (clouds, radii) = spheres(8, 4);
    let mut enc = encoder(9);
    enc.fit(&clouds, &radii, &FitOptions { epochs: 2, batch_size: 4, ..FitOptions::default() }).unwrap();
    let bytes = enc.to_bytes().unwrap();
    let loaded = DgcnnEncoder::from_bytes(&bytes, Backend::default()).unwrap();
    assert_eq!(loaded.config(), enc.config());
    let cloud = random_cloud(100, 21);
    assert_eq!(loaded.encode(&cloud), enc.encode(&cloud), "loaded encoder differs");
    // A fresh encoder of the same seed is untrained: the bytes carried the trained weights.
    assert_ne!(encoder(9).encode(&cloud), enc.encode(&cloud));
    assert_eq!(loaded.to_bytes().unwrap(), bytes, "saving the loaded encoder");

    // Header: magic 8, version 4, k, seed, embedding, layer count, 2 widths, payload length.
    let header = 12 + 8 * 7;
    let mut huge_width = bytes.clone();
    huge_width[12 + 8 * 4..12 + 8 * 5].copy_from_slice(&(1u64 << 16).to_le_bytes());
    let mut other_width = bytes.clone();
    other_width[12 + 8 * 4] = 17;
    let mut huge_len = bytes.clone();
    huge_len[header - 8..header].copy_from_slice(&u64::MAX.to_le_bytes());
    let mut garbled = bytes.clone();
    for b in &mut garbled[header..header + 20] {
        *b ^= 0xA5;
    }
    let mut cases: Vec<(String, Vec<u8>)> = vec![
        ("empty".into(), Vec::new()),
        ("bad magic".into(), [b"S2GRLDQN".as_slice(), &bytes[8..]].concat()),
        ("trailing bytes".into(), [bytes.as_slice(), &[0u8; 3]].concat()),
        ("huge width".into(), huge_width),
        ("width 16 -> 17".into(), other_width),
        ("huge payload length".into(), huge_len),
        ("garbled payload".into(), garbled),
        ("random junk".into(), (0..500u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect()),
    ];
    for cut in (0..header).chain([header + 1, bytes.len() / 2, bytes.len() - 1]) {
        cases.push((format!("truncated to {cut} bytes"), bytes[..cut].to_vec()));
    }
    for (name, data) in cases {
        let r = DgcnnEncoder::from_bytes(&data, Backend::default());
        assert!(matches!(r, Err(RlError::Checkpoint { .. })), "{name}: got {r:?}");
    }
}
