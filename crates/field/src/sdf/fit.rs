//! The training of [`NeuralSdf`] (§6.2 of seed 002): the surface and general sample pools,
//! the batches, the four losses and the Adam loop with a decaying learning rate.

use std::time::Instant;

use burn::optim::AdamConfig;
use burn::tensor::{Device, Tensor, TensorData};
use s2g_geom::{Normalization, Point3, Real, SplitMix64, SurfaceSamples, Vector3};

use super::{NeuralSdf, SdfLossWeights, SdfOptions, SdfReport};
use crate::error::{FieldError, Result};
use crate::siren::Siren;
use crate::train::descend;

/// Refuses no samples, normals of a different count, and non-finite points or normals.
fn check_samples(samples: &SurfaceSamples) -> Result<()> {
    let n_surf = samples.len();
    if n_surf == 0 {
        return Err(FieldError::InvalidArgument("no surface samples".into()));
    }
    if samples.normals.len() != n_surf {
        return Err(FieldError::InvalidArgument(format!(
            "{} surface points but {} normals",
            n_surf,
            samples.normals.len()
        )));
    }
    if let Some(i) = samples.points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(FieldError::NonFinite { what: "surface point", index: i });
    }
    if let Some(i) = samples.normals.iter().position(|n| !(n.iter().all(|c| c.is_finite()))) {
        return Err(FieldError::NonFinite { what: "surface normal", index: i });
    }
    Ok(())
}

/// The training data in the unit cube: the surface pool (points, unit normals) and the
/// general pool (points with their true distances).
struct SdfPools {
    surf_pts: Vec<[f32; 3]>,
    surf_nrm: Vec<[f32; 3]>,
    gen_pts: Vec<[f32; 3]>,
    gen_dist: Vec<f32>,
}

impl SdfPools {
    /// Builds the pools from checked `samples`, drawing the general points from `rng`
    /// within the padded box `[-half, half]^3`.
    fn new(
        samples: &SurfaceSamples,
        truth: &dyn Fn(&[Point3]) -> Vec<Real>,
        normalization: Normalization,
        options: &SdfOptions,
        half: f64,
        rng: &mut SplitMix64,
    ) -> Result<Self> {
        let n_surf = samples.len();
        // Surface pool in the unit cube, normals unit length (zero normals stay zero and add
        // a constant to the normal loss).
        let surf_pts: Vec<[f32; 3]> =
            samples.points.iter().map(|p| to_f32(&normalization.to_unit(p).coords)).collect();
        let surf_nrm: Vec<[f32; 3]> = samples
            .normals
            .iter()
            .map(|n| to_f32(&n.try_normalize(0.0).unwrap_or_else(Vector3::zeros)))
            .collect();

        // General pool: near-surface and uniform points with their true distances, computed
        // in the shape's units and scaled to the unit cube.
        let n_gen = options.general_samples;
        let n_near = ((n_gen as f64) * options.near_fraction).round() as usize;
        let mut gen_unit = Vec::with_capacity(n_gen);
        for i in 0..n_gen {
            let u = if i < n_near {
                let p = &surf_pts[rng.below(n_surf)];
                let s = options.near_sigma;
                Vector3::new(
                    p[0] as f64 + s * rng.normal(),
                    p[1] as f64 + s * rng.normal(),
                    p[2] as f64 + s * rng.normal(),
                )
                .map(|c| c.clamp(-half, half))
            } else {
                Vector3::new(rng.uniform(-half, half), rng.uniform(-half, half), rng.uniform(-half, half))
            };
            gen_unit.push(u);
        }
        let world: Vec<Point3> =
            gen_unit.iter().map(|u| normalization.from_unit(&Point3::from(*u))).collect();
        let dist = truth(&world);
        if dist.len() != n_gen {
            return Err(FieldError::InvalidArgument(
                "the reference gave the wrong number of distances".into(),
            ));
        }
        if let Some(i) = dist.iter().position(|d| !d.is_finite()) {
            return Err(FieldError::NonFinite { what: "reference distance", index: i });
        }
        let gen_pts: Vec<[f32; 3]> = gen_unit.iter().map(to_f32).collect();
        let gen_dist: Vec<f32> = dist.iter().map(|&d| normalization.length_to_unit(d) as f32).collect();
        Ok(Self { surf_pts, surf_nrm, gen_pts, gen_dist })
    }
}

/// One batch: `bs` surface points then `bs` general points (`pts`, `[2 bs, 3]` row-major),
/// the surface points' normals and the general points' true distances.
#[derive(Default)]
struct SdfBatch {
    pts: Vec<f32>,
    nrm: Vec<f32>,
    dst: Vec<f32>,
}

/// The losses of §6.2 on `batch` (`bs` points of each kind): the weighted sum (Eq. 46) to
/// descend, and the four unweighted losses (Eq. 42-45) as one `[4]` tensor.
fn sdf_losses(
    net: &Siren,
    batch: &SdfBatch,
    bs: usize,
    w: &SdfLossWeights,
    device: &Device,
) -> (Tensor<1>, Tensor<1>) {
    let n = 2 * bs;
    let x = Tensor::<2>::from_data(TensorData::new(batch.pts.clone(), [n, 3]), device);
    let normals = Tensor::<2>::from_data(TensorData::new(batch.nrm.clone(), [bs, 3]), device);
    let target = Tensor::<2>::from_data(TensorData::new(batch.dst.clone(), [bs, 1]), device);

    let out = net.forward_gradient(x);
    let grad_norm = out.gradient.clone().square().sum_dim(1).add_scalar(1e-12).sqrt(); // [n, 1]
    let f_surf = out.value.clone().narrow(0, 0, bs);
    let f_gen = out.value.narrow(0, bs, bs);
    let g_surf = out.gradient.narrow(0, 0, bs);
    // Eq. (42): |f| on the surface.
    let l_surface = f_surf.abs().mean();
    // Eq. (43): 1 - cos(∇f, n) on the surface.
    let cos = (g_surf * normals).sum_dim(1) / grad_norm.clone().narrow(0, 0, bs);
    let l_normal = cos.neg().add_scalar(1.0).mean();
    // Eq. (44): |f - d| at general points.
    let l_general = (f_gen - target).abs().mean();
    // Eq. (45): Eikonal, (|∇f| - 1)^2 at general points.
    let l_eikonal = grad_norm.narrow(0, bs, bs).sub_scalar(1.0).square().mean();
    let parts = Tensor::cat(vec![l_surface, l_normal, l_general, l_eikonal], 0);
    let weights = Tensor::<1>::from_data(
        TensorData::new(vec![w.surface as f32, w.normal as f32, w.general as f32, w.eikonal as f32], [4]),
        device,
    );
    // Eq. (46): the weighted sum.
    ((parts.clone() * weights).sum(), parts)
}

/// The shared training: checks the data, builds the pools and runs Adam, an epoch being a
/// shuffled pass over the surface pool, each batch paired with as many general points
/// (shuffled passes of their own), the learning rate decaying geometrically per step.
pub(super) fn fit_with(
    samples: &SurfaceSamples,
    truth: &dyn Fn(&[Point3]) -> Vec<Real>,
    normalization: Normalization,
    options: &SdfOptions,
) -> Result<(NeuralSdf, SdfReport)> {
    check_samples(samples)?;
    let n_surf = samples.len();
    let half = 0.5 + options.padding;
    let mut rng = SplitMix64::new(options.seed, 0x5344_4650);
    let pools = SdfPools::new(samples, truth, normalization, options, half, &mut rng)?;
    let n_gen = options.general_samples;

    let device = options.backend.device().autodiff();
    let mut net = Siren::new(&options.network, &device)?;
    let mut optimizer = AdamConfig::new().init();

    let batch = options.batch_size.min(n_surf);
    let steps_per_epoch = n_surf.div_ceil(batch);
    let steps = options.epochs.saturating_mul(steps_per_epoch);
    let decay = options.final_learning_rate_fraction.powf(1.0 / (steps.max(2) - 1) as f64);
    let w = options.weights;

    let mut surf_order: Vec<usize> = (0..n_surf).collect();
    let mut gen_order: Vec<usize> = (0..n_gen).collect();
    let mut gen_cursor = n_gen; // Forces a shuffle before the first use.
    let mut b = SdfBatch {
        pts: Vec::with_capacity(2 * batch * 3),
        nrm: Vec::with_capacity(batch * 3),
        dst: Vec::with_capacity(batch),
    };
    let mut report =
        SdfReport { steps: 0, final_losses: [f32::NAN; 4], final_loss: f32::NAN, train_seconds: 0.0 };
    let start = Instant::now();
    let mut lr = options.learning_rate;
    for _ in 0..options.epochs {
        shuffle(&mut surf_order, &mut rng);
        for chunk in surf_order.chunks(batch) {
            let bs = chunk.len();
            b.pts.clear();
            b.nrm.clear();
            b.dst.clear();
            for &i in chunk {
                b.pts.extend_from_slice(&pools.surf_pts[i]);
                b.nrm.extend_from_slice(&pools.surf_nrm[i]);
            }
            for _ in 0..bs {
                if gen_cursor == n_gen {
                    shuffle(&mut gen_order, &mut rng);
                    gen_cursor = 0;
                }
                let j = gen_order[gen_cursor];
                gen_cursor += 1;
                b.pts.extend_from_slice(&pools.gen_pts[j]);
                b.dst.push(pools.gen_dist[j]);
            }
            let (loss, parts) = sdf_losses(&net, &b, bs, &w, &device);
            let values = crate::backend::host_values(parts.inner())?;
            let total = (values[0] as f64 * w.surface
                + values[1] as f64 * w.normal
                + values[2] as f64 * w.general
                + values[3] as f64 * w.eikonal) as f32;
            if !total.is_finite() {
                return Err(FieldError::Diverged { loss: total, step: report.steps });
            }
            net = descend(&mut optimizer, net, loss, lr);
            lr *= decay;
            report.steps += 1;
            report.final_losses = [values[0], values[1], values[2], values[3]];
            report.final_loss = total;
        }
    }
    report.train_seconds = start.elapsed().as_secs_f64();
    let host = net.to_f64()?;
    Ok((NeuralSdf { net: host, normalization, half_extent: half }, report))
}

fn to_f32(v: &Vector3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Fisher-Yates with our generator.
fn shuffle(v: &mut [usize], rng: &mut SplitMix64) {
    for i in (1..v.len()).rev() {
        let j = rng.below(i + 1);
        v.swap(i, j);
    }
}
