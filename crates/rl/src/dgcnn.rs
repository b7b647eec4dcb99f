//! A DGCNN point-cloud encoder (Wang et al., "Dynamic Graph CNN for Learning on Point
//! Clouds", ACM TOG 2019), the shape encoder of the Shape2Gcode paper (§3.5, Appendix A.1:
//! a setup's sampled surface points become the feature vector `z_s` the DQN reads).
//!
//! The network and its guarantees are described on [`DgcnnEncoder`].

use std::ops::Range;
use std::path::Path;

use burn::module::Module;
use burn::nn::Linear;
use burn::optim::{AdamConfig, GradientsParams};
use burn::store::ModuleRecord;
use burn::tensor::activation::relu;
use burn::tensor::{Bytes, Device, Int, Tensor, TensorData};

use crate::RlError;
use crate::checkpoint::Reader;
use crate::config::Backend;
use crate::dqn::{backend_device, backend_err};
use crate::env::Encoder;
use crate::network::linear;
use crate::rng::SplitMix64;

/// Stream numbers of this module's generators, distinct from the DQN's so that an agent and
/// an encoder built from the same seed do not draw the same numbers.
const STREAM_INIT: u64 = 0xD6C0_0001;
const STREAM_HEAD: u64 = 0xD6C0_0002;
const STREAM_SHUFFLE: u64 = 0xD6C0_0003;

/// Largest layer width, embedding width and `k` a config may ask for: far above any real
/// network, low enough that a bad value is an error rather than a failed allocation.
const MAX_WIDTH: usize = 1 << 16;
/// Largest number of EdgeConv layers.
const MAX_LAYERS: usize = 64;

const MAGIC: &[u8; 8] = b"S2GDGCNN";
const VERSION: u32 = 1;

/// Hyper-parameters of a [`DgcnnEncoder`].
///
/// Every field is public and documented with its default; [`DgcnnConfig::validate`] (called
/// by [`DgcnnEncoder::new`]) refuses out-of-range values with [`RlError::InvalidConfig`].
#[derive(Debug, Clone, PartialEq)]
pub struct DgcnnConfig {
    /// Neighbours per point in every EdgeConv layer, the point itself not counted,
    /// `1..=65536`. Clouds with `k` points or fewer use all the other points. Default `20`,
    /// the paper's.
    pub k: usize,
    /// Output width of each EdgeConv layer, at least one layer, each `1..=65536`, at most 64
    /// layers. Default `vec![64, 64, 128, 256]`, the paper's DGCNN.
    pub edge_widths: Vec<usize>,
    /// Width of the shared per-point layer after the concatenation, `1..=65536`; the feature
    /// vector has twice as many values (max and mean pooling). Default `512`, which makes
    /// the features 1024 values long, the length of the Shape2Gcode paper's DGCNN features
    /// (Appendix A.1). Wang et al.'s classifier uses `1024` (2048 features), about 15% slower
    /// here; `256` is about 10% faster.
    pub embedding: usize,
    /// Seed of the weight initialisation. Default `0`.
    pub seed: u64,
    /// Backend that runs the network. Default [`Backend::default`].
    pub backend: Backend,
}

impl Default for DgcnnConfig {
    fn default() -> Self {
        Self {
            k: 20,
            edge_widths: vec![64, 64, 128, 256],
            embedding: 512,
            seed: 0,
            backend: Backend::default(),
        }
    }
}

impl DgcnnConfig {
    /// Check every field's range; the first bad field is named in the error.
    pub fn validate(&self) -> Result<(), RlError> {
        if !(1..=MAX_WIDTH).contains(&self.k) {
            return Err(RlError::config("k", format!("must be in 1..={MAX_WIDTH}, got {}", self.k)));
        }
        if self.edge_widths.is_empty() || self.edge_widths.len() > MAX_LAYERS {
            return Err(RlError::config(
                "edge_widths",
                format!("must have 1..={MAX_LAYERS} layers, got {}", self.edge_widths.len()),
            ));
        }
        if let Some((i, w)) = self.edge_widths.iter().enumerate().find(|(_, w)| !(1..=MAX_WIDTH).contains(*w))
        {
            return Err(RlError::config(
                "edge_widths",
                format!("layer {i} has width {w}, not in 1..={MAX_WIDTH}"),
            ));
        }
        if !(1..=MAX_WIDTH).contains(&self.embedding) {
            return Err(RlError::config(
                "embedding",
                format!("must be in 1..={MAX_WIDTH}, got {}", self.embedding),
            ));
        }
        Ok(())
    }

    /// Number of weights and biases of the network this config describes.
    fn parameter_count(&self) -> usize {
        // Saturating: only compared against a payload length, and never overflows on 64 bits.
        let mut c_in = 3usize;
        let mut total = 0usize;
        for &w in &self.edge_widths {
            total = total.saturating_add((2 * c_in + 1).saturating_mul(w));
            c_in = w;
        }
        let concat: usize = self.edge_widths.iter().sum();
        total.saturating_add((concat + 1).saturating_mul(self.embedding))
    }
}

/// Options of [`DgcnnEncoder::fit`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Hidden widths of the regression head on top of the features, ReLU after each; empty
    /// gives a linear head. Default `vec![64]`.
    pub head_hidden: Vec<usize>,
    /// Passes over the training clouds, `> 0`. Default `50`.
    pub epochs: usize,
    /// Adam learning rate, finite and `> 0`. Default `1e-3`.
    pub learning_rate: f64,
    /// Clouds per gradient update, `> 0`. Default `16`.
    pub batch_size: usize,
    /// Seed of the head's initialisation and of the shuffling of the clouds each epoch.
    /// Default `0`.
    pub seed: u64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self { head_hidden: vec![64], epochs: 50, learning_rate: 1e-3, batch_size: 16, seed: 0 }
    }
}

impl FitOptions {
    /// Check every field's range; the first bad field is named in the error.
    pub fn validate(&self) -> Result<(), RlError> {
        if let Some(i) = self.head_hidden.iter().position(|&w| !(1..=MAX_WIDTH).contains(&w)) {
            return Err(RlError::config(
                "head_hidden",
                format!("layer {i} has width outside 1..={MAX_WIDTH}"),
            ));
        }
        if self.epochs == 0 {
            return Err(RlError::config("epochs", "must be > 0"));
        }
        if !(self.learning_rate.is_finite() && self.learning_rate > 0.0) {
            return Err(RlError::config(
                "learning_rate",
                format!("must be finite and > 0, got {}", self.learning_rate),
            ));
        }
        if self.batch_size == 0 {
            return Err(RlError::config("batch_size", "must be > 0"));
        }
        Ok(())
    }
}

/// What [`DgcnnEncoder::fit`] returns: the loss curve and the trained head.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// Mean squared error of each epoch, averaged over the epoch's clouds as they were
    /// trained on, in units of the *standardised* targets (each target dimension shifted and
    /// scaled to mean 0 and variance 1 over the training set): `1.0` is what predicting the
    /// mean gives.
    pub epoch_losses: Vec<f32>,
    /// The regression head trained with the encoder, mapping the trained encoder's features
    /// to targets in their original units.
    pub head: RegressionHead,
}

/// The small MLP that [`DgcnnEncoder::fit`] trains on top of the features, copied to the
/// host: `features -> hidden... -> targets`, ReLU after every hidden layer.
#[derive(Debug, Clone, PartialEq)]
pub struct RegressionHead {
    /// `(weight [d_in * d_out, row-major d_in x d_out], bias [d_out], d_in, d_out)` per layer.
    layers: Vec<(Vec<f32>, Vec<f32>, usize, usize)>,
    target_mean: Vec<f32>,
    target_std: Vec<f32>,
}

impl RegressionHead {
    /// Length of the feature vectors it reads (the encoder's [`dim`](DgcnnEncoder::dim)).
    pub fn input_dim(&self) -> usize {
        self.layers.first().map_or(0, |l| l.2)
    }

    /// Length of the target vectors it predicts.
    pub fn output_dim(&self) -> usize {
        self.target_mean.len()
    }

    /// Predicted targets, in their original units, for the features of one cloud (from the
    /// encoder `fit` trained).
    ///
    /// Fails with [`RlError::StateDim`] for features of the wrong length and
    /// [`RlError::NonFiniteState`] for a NaN or an infinity among them.
    pub fn predict(&self, features: &[f32]) -> Result<Vec<f32>, RlError> {
        if features.len() != self.input_dim() {
            return Err(RlError::StateDim { expected: self.input_dim(), got: features.len() });
        }
        if let Some((index, &value)) = features.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(RlError::NonFiniteState { index, value });
        }
        let last = self.layers.len() - 1;
        let mut x = features.to_vec();
        for (l, (weight, bias, d_in, d_out)) in self.layers.iter().enumerate() {
            let mut y = bias.clone();
            for (i, &xi) in x.iter().enumerate().take(*d_in) {
                for (yo, &w) in y.iter_mut().zip(&weight[i * d_out..(i + 1) * d_out]) {
                    *yo += xi * w;
                }
            }
            if l < last {
                y.iter_mut().for_each(|v| *v = v.max(0.0));
            }
            x = y;
        }
        Ok(x.iter().zip(self.target_std.iter().zip(&self.target_mean)).map(|(v, (s, m))| v * s + m).collect())
    }
}

/// The network's parameters: one linear layer per EdgeConv (`weight [2 c_in, c_out]`, the
/// first `c_in` rows acting on `x_i`, the others on `x_j - x_i`) and the embedding layer.
#[derive(Module, Debug)]
struct DgcnnNet {
    edges: Vec<Linear>,
    embed: Linear,
}

/// The encoder and a regression head, trained together by [`DgcnnEncoder::fit`].
#[derive(Module, Debug)]
struct Pretrain {
    net: DgcnnNet,
    head: Vec<Linear>,
}

impl DgcnnNet {
    fn new(config: &DgcnnConfig, device: &Device) -> Self {
        let mut rng = SplitMix64::new(config.seed, STREAM_INIT);
        let mut c_in = 3;
        let mut edges = Vec::with_capacity(config.edge_widths.len());
        for &w in &config.edge_widths {
            edges.push(linear(2 * c_in, w, &mut rng, device));
            c_in = w;
        }
        let concat = config.edge_widths.iter().sum();
        let embed = linear(concat, config.embedding, &mut rng, device);
        Self { edges, embed }
    }
}

fn to_host<const D: usize>(t: Tensor<D>) -> Result<Vec<f32>, RlError> {
    t.try_into_data().map_err(backend_err)?.try_into_vec::<f32>().map_err(backend_err)
}

/// The finite points of a batch of clouds, one after the other.
struct Flat {
    /// `[points, 3]`, row-major.
    coords: Vec<f32>,
    /// The rows of each input cloud, in input order; empty for a cloud without finite points.
    segments: Vec<Range<usize>>,
}

impl Flat {
    fn new<'a>(clouds: impl IntoIterator<Item = &'a [[f32; 3]]>) -> Self {
        let mut coords = Vec::new();
        let mut segments = Vec::new();
        for cloud in clouds {
            let start = coords.len() / 3;
            for p in cloud.iter().filter(|p| p.iter().all(|v| v.is_finite())) {
                coords.extend_from_slice(p);
            }
            segments.push(start..coords.len() / 3);
        }
        Self { coords, segments }
    }

    fn points(&self) -> usize {
        self.coords.len() / 3
    }
}

/// Entries of the Gram matrix computed per matrix product: a cloud of `n` points is done in
/// blocks of `GRAM_FLOATS / n` rows, 16 MiB at a time rather than `4 n^2` bytes at once.
const GRAM_FLOATS: usize = 1 << 22;

/// The `min(k, n - 1)` nearest neighbours of every row of `features` (`n` rows of `dim`
/// values), nearest first, the row itself excluded. Returns local indices, `min(k, n - 1)`
/// per row.
///
/// Squared distances are `|a|^2 + |b|^2 - 2 a.b` (clamped at 0), the dot products from one
/// matrix product on `device`, after shifting every channel by the centre of its range (the
/// midpoint of its minimum and maximum: distances do not change, the cancellation in the
/// formula shrinks, and unlike the mean it does not depend on the order of the rows). Ties
/// are broken by the neighbours' values (lexicographic, `f32::total_cmp`) and then by index,
/// so the chosen neighbours depend only on the values.
fn knn_rows(features: &[f32], dim: usize, k: usize, device: &Device) -> Result<Vec<u32>, RlError> {
    let n = features.len().checked_div(dim).unwrap_or(0);
    let k_eff = k.min(n.saturating_sub(1));
    if k_eff == 0 {
        return Ok(Vec::new());
    }
    let rows = features.chunks_exact(dim);
    let mut lo = vec![f32::INFINITY; dim];
    let mut hi = vec![f32::NEG_INFINITY; dim];
    for r in rows.clone() {
        for (c, &v) in r.iter().enumerate() {
            lo[c] = lo[c].min(v);
            hi[c] = hi[c].max(v);
        }
    }
    let centre: Vec<f32> = lo.iter().zip(&hi).map(|(l, h)| 0.5 * l + 0.5 * h).collect();
    let centred: Vec<f32> = rows.flat_map(|r| r.iter().zip(&centre).map(|(v, c)| v - c)).collect();
    let sq: Vec<f32> = centred.chunks_exact(dim).map(|r| r.iter().map(|v| v * v).sum()).collect();
    let all = Tensor::<2>::from_data(TensorData::new(centred, [n, dim]), device);
    let all_t = all.clone().transpose();

    let row = |j: u32| &features[j as usize * dim..(j as usize + 1) * dim];
    let cmp = |a: &(f32, u32), b: &(f32, u32)| {
        a.0.total_cmp(&b.0)
            .then_with(|| {
                row(a.1)
                    .iter()
                    .zip(row(b.1))
                    .map(|(x, y)| x.total_cmp(y))
                    .find(|o| o.is_ne())
                    .unwrap_or(std::cmp::Ordering::Equal)
            })
            .then(a.1.cmp(&b.1))
    };
    let mut out = Vec::with_capacity(n * k_eff);
    let mut best: Vec<(f32, u32)> = Vec::with_capacity(k_eff + 1);
    let mut dist = vec![0.0f32; n];
    let block = (GRAM_FLOATS / n).clamp(1, n);
    for start in (0..n).step_by(block) {
        let end = (start + block).min(n);
        let gram = to_host(all.clone().slice([start..end, 0..dim]).matmul(all_t.clone()))?;
        for (i, g_row) in (start..end).zip(gram.chunks_exact(n)) {
            let sq_i = sq[i];
            for ((d, &g), &sq_j) in dist.iter_mut().zip(g_row).zip(&sq) {
                *d = ((sq_i + sq_j) - 2.0 * g).max(0.0);
            }
            best.clear();
            let mut worst = f32::INFINITY;
            for (j, &d) in dist.iter().enumerate() {
                // Most candidates are farther than the k-th best so far: one comparison.
                if d > worst || j == i {
                    continue;
                }
                let c = (d, j as u32);
                let at = best.partition_point(|b| cmp(b, &c).is_lt());
                if at < k_eff {
                    best.insert(at, c);
                    best.truncate(k_eff);
                    if best.len() == k_eff {
                        worst = best[k_eff - 1].0;
                    }
                }
            }
            out.extend(best.iter().map(|c| c.1));
        }
    }
    Ok(out)
}

/// The k-nearest-neighbour graph the encoder builds, for one cloud of `n` rows of `dim`
/// features (`features.len() = n * dim`, on the default backend): for each row, the indices
/// of its `min(k, n - 1)` nearest other rows by squared Euclidean distance, nearest first,
/// ties broken by the neighbours' values and then by index. A row of a one-row cloud has no
/// neighbours (the encoder then uses the point itself). Exposed for tests; not part of the
/// stable API.
#[doc(hidden)]
pub fn knn_graph(features: &[f32], dim: usize, k: usize) -> Result<Vec<Vec<usize>>, RlError> {
    if dim == 0 {
        return Ok(Vec::new());
    }
    let n = features.len() / dim;
    let flat = knn_rows(&features[..n * dim], dim, k, &backend_device(Backend::default()))?;
    let k_eff = k.min(n.saturating_sub(1));
    Ok((0..n).map(|i| flat[i * k_eff..(i + 1) * k_eff].iter().map(|&j| j as usize).collect()).collect())
}

/// The neighbours of every point of a batch as `kb` index vectors of all the batch's points
/// (global rows; vector `s` holds each point's `s`-th nearest neighbour), where `kb` is the
/// largest `min(k, n - 1)` over the batch's clouds (at least 1). Points with fewer
/// neighbours repeat their nearest one, and a point alone in its cloud is its own neighbour:
/// a repeated neighbour does not change a maximum.
fn batch_neighbours(
    features: &[f32],
    dim: usize,
    segments: &[Range<usize>],
    k: usize,
    device: &Device,
) -> Result<Vec<Vec<i64>>, RlError> {
    let kb = segments.iter().map(|s| k.min(s.len().saturating_sub(1))).max().unwrap_or(0).max(1);
    let total: usize = segments.iter().map(|s| s.len()).sum();
    let mut slots = vec![Vec::with_capacity(total); kb];
    for seg in segments.iter().filter(|s| !s.is_empty()) {
        let local = knn_rows(&features[seg.start * dim..seg.end * dim], dim, k, device)?;
        let k_eff = k.min(seg.len() - 1);
        for i in 0..seg.len() {
            let row = &local[i * k_eff..(i + 1) * k_eff];
            let fill = row.first().map_or(i, |&j| j as usize);
            for (s, slot) in slots.iter_mut().enumerate() {
                slot.push((seg.start + row.get(s).map_or(fill, |&j| j as usize)) as i64);
            }
        }
    }
    Ok(slots)
}

/// One EdgeConv layer on `p` points.
///
/// - `x`: `[p, c_in]`; `neighbours`: `kb` vectors of `p` row indices of `x`, see
///   [`batch_neighbours`]
/// - output: `[p, c_out]`, `ReLU((theta - phi) x_i + b + max_j phi x_j)` (see [`DgcnnEncoder`])
fn edge_conv(layer: &Linear, x: Tensor<2>, neighbours: &[Vec<i64>], p: usize, device: &Device) -> Tensor<2> {
    let w = layer.weight.val();
    let [two_c_in, c_out] = w.dims();
    let c_in = two_c_in / 2;
    let theta = w.clone().slice([0..c_in, 0..c_out]);
    let phi = w.slice([c_in..two_c_in, 0..c_out]);
    let y = x.matmul(Tensor::cat(vec![theta - phi.clone(), phi], 1));
    let centre = y.clone().slice([0..p, 0..c_out]);
    let neigh = y.slice([0..p, c_out..2 * c_out]);
    // A running maximum of one gathered `[p, c_out]` matrix per neighbour rank: about ten
    // times faster on Flex than gathering `[p * k, c_out]` and reducing the middle axis of
    // `[p, k, c_out]`.
    let gather = |slot: &Vec<i64>| {
        neigh.clone().select(0, Tensor::<1, Int>::from_data(TensorData::new(slot.clone(), [p]), device))
    };
    let mut best = gather(&neighbours[0]);
    for slot in &neighbours[1..] {
        best = best.max_pair(gather(slot));
    }
    let mut out = centre + best;
    if let Some(b) = &layer.bias {
        out = out + b.val().unsqueeze_dim::<2>(0);
    }
    relu(out)
}

impl DgcnnNet {
    fn embedding(&self) -> usize {
        self.embed.weight.dims()[1]
    }

    /// Features of every cloud of `flat`.
    ///
    /// - output: `[clouds, 2 * embedding]`, max pooling then mean pooling; zeros for a cloud
    ///   without points.
    fn forward(&self, k: usize, flat: &Flat, device: &Device) -> Result<Tensor<2>, RlError> {
        let p = flat.points();
        let e = self.embedding();
        if p == 0 {
            return Ok(Tensor::zeros([flat.segments.len(), 2 * e], device));
        }
        let mut host = flat.coords.clone();
        let mut dim = 3;
        let mut x = Tensor::<2>::from_data(TensorData::new(host.clone(), [p, 3]), device);
        let mut outs = Vec::with_capacity(self.edges.len());
        for (l, layer) in self.edges.iter().enumerate() {
            if l > 0 {
                host = to_host(x.clone())?;
            }
            let neighbours = batch_neighbours(&host, dim, &flat.segments, k, device)?;
            x = edge_conv(layer, x, &neighbours, p, device);
            dim = x.dims()[1];
            outs.push(x.clone());
        }
        let emb = relu(self.embed.forward(Tensor::cat(outs, 1)));
        let rows = flat
            .segments
            .iter()
            .map(|seg| {
                if seg.is_empty() {
                    return Tensor::zeros([1, 2 * e], device);
                }
                let part = if seg.len() == p { emb.clone() } else { emb.clone().slice([seg.clone(), 0..e]) };
                Tensor::cat(vec![part.clone().max_dim(0), part.mean_dim(0)], 1)
            })
            .collect();
        Ok(Tensor::cat(rows, 0))
    }
}

/// A DGCNN encoder of point clouds: a cloud of `[x, y, z]` points becomes `2 * embedding`
/// features, the global max pooling of a per-point embedding followed by its mean pooling.
///
/// - Deterministic: the weights come from [`DgcnnConfig::seed`] through this crate's own
///   generator, so the same seed and cloud give bit-identical features.
/// - Permutation invariant: reordering the points gives the same max-pooled half bit for
///   bit (ties in the neighbour graphs included) and the same mean-pooled half up to the
///   float summation order.
/// - Degenerate input never panics: points with a NaN or infinite coordinate are dropped;
///   a cloud with no points left encodes to zeros; a cloud of `n <= k` points uses its
///   `n - 1` other points as neighbours, and a single point is its own neighbour (edge
///   feature `[x_i, 0]`). Finite points are used as given; the encoder is meant for clouds
///   normalised into about the unit cube.
/// - Cost: `O(N^2 C)` for the neighbour graphs plus `O(N k C)` for the layers; the whole
///   batch of [`encode_batch`](Self::encode_batch) is held in memory at once. One cloud of
///   1024 points takes 70-100 ms with the default config on Flex (a 2-core CPU), of which
///   the neighbour graphs are about half.
///
/// # Network
///
/// - EdgeConv layers. For every point `i` and each of its `k` nearest neighbours `j` in the
///   layer's *input* feature space (xyz for the first layer, the previous layer's output for
///   the others: the graph is rebuilt per layer, which is what "dynamic" means), the edge
///   feature `[x_i, x_j - x_i]` goes through one shared linear layer and a ReLU, and the
///   layer's output at `i` is the maximum over the neighbours.
/// - The outputs of all EdgeConv layers are concatenated per point and mapped by a shared
///   linear layer and a ReLU to [`DgcnnConfig::embedding`] channels.
/// - Global max pooling and global mean pooling over the points, concatenated.
///
/// There is no batch normalisation (Wang et al. have it after every layer): the features of
/// a cloud must not depend on the other clouds of a batch, and without it the EdgeConv
/// maximum can be taken over points instead of edges. Writing the linear layer as
/// `theta x_i + phi (x_j - x_i) + b`, the term in `x_i` does not depend on `j` and ReLU is
/// monotone, so
/// `max_j ReLU(theta x_i + phi (x_j - x_i) + b) = ReLU((theta - phi) x_i + b + max_j phi x_j)`:
/// one matrix product over the `N` points per layer instead of one over the `N k` edges, then
/// a gather and a maximum; equal to the definition up to float rounding.
///
/// # Neighbours
///
/// Squared distances are `|a|^2 + |b|^2 - 2 a.b`, the dot products from one matrix product,
/// after shifting each channel by the midpoint of its range (distances are unchanged, the
/// cancellation shrinks). The `k` nearest other points are then chosen on the host, ties
/// broken by the neighbours' feature values (lexicographically) and only then by index, so
/// the graph depends on the points' values and not on their order. No gradient flows
/// through the choice of neighbours, as in Wang et al.'s implementation.
pub struct DgcnnEncoder {
    config: DgcnnConfig,
    /// The backend with autodiff, where the trainable network lives.
    train_device: Device,
    /// The same backend without autodiff, for encoding.
    infer_device: Device,
    net: DgcnnNet,
    /// `net.valid()`, kept so that encoding records no graph and converts nothing.
    infer: DgcnnNet,
}

impl std::fmt::Debug for DgcnnEncoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DgcnnEncoder").field("config", &self.config).finish_non_exhaustive()
    }
}

impl DgcnnEncoder {
    /// A fresh encoder with weights drawn from `config.seed`.
    ///
    /// Fails with [`RlError::InvalidConfig`] for a bad config.
    pub fn new(config: DgcnnConfig) -> Result<Self, RlError> {
        config.validate()?;
        let infer_device = backend_device(config.backend);
        let train_device = infer_device.clone().autodiff();
        let net = DgcnnNet::new(&config, &train_device);
        let infer = net.valid();
        Ok(Self { config, train_device, infer_device, net, infer })
    }

    /// The encoder's configuration.
    pub fn config(&self) -> &DgcnnConfig {
        &self.config
    }

    /// Length of every feature vector: `2 * embedding`.
    pub fn dim(&self) -> usize {
        2 * self.config.embedding
    }

    /// The features of one cloud (`dim()` values), or the backend's error.
    pub fn try_encode(&self, cloud: &[[f32; 3]]) -> Result<Vec<f32>, RlError> {
        Ok(self.encode_batch(&[cloud])?.pop().unwrap_or_else(|| vec![0.0; self.dim()]))
    }

    /// The features of several clouds at once (one matrix product per layer for the whole
    /// batch); each equals what [`try_encode`](Self::try_encode) gives for that cloud alone,
    /// up to float rounding. Clouds may have different sizes. On the CPU backends this is
    /// no faster per cloud than encoding one at a time.
    pub fn encode_batch(&self, clouds: &[&[[f32; 3]]]) -> Result<Vec<Vec<f32>>, RlError> {
        let flat = Flat::new(clouds.iter().copied());
        let features = to_host(self.infer.forward(self.config.k, &flat, &self.infer_device)?)?;
        Ok(features.chunks(self.dim()).map(<[f32]>::to_vec).collect())
    }

    /// Train the encoder together with a fresh regression head on the mean squared error
    /// between the head's prediction for `clouds[i]` and `targets[i]`, with Adam, and keep
    /// the trained encoder (pretraining on shape targets).
    ///
    /// The targets are standardised per dimension over the training set (the returned head
    /// undoes it); each epoch visits the clouds in an order shuffled from `options.seed`, in
    /// mini-batches of `options.batch_size`. Deterministic: the same encoder, data and
    /// options give the same losses and weights, bit for bit.
    ///
    /// Fails with [`RlError::InvalidConfig`] for bad options, [`RlError::InvalidArgument`]
    /// for no clouds, a different number of targets, targets of different or zero lengths
    /// or non-finite targets, and [`RlError::Diverged`] if the loss becomes non-finite; on
    /// any error the encoder is unchanged.
    pub fn fit(
        &mut self,
        clouds: &[Vec<[f32; 3]>],
        targets: &[Vec<f32>],
        options: &FitOptions,
    ) -> Result<FitReport, RlError> {
        options.validate()?;
        if clouds.is_empty() || clouds.len() != targets.len() {
            return Err(RlError::InvalidArgument(format!(
                "fit needs one target per cloud and at least one cloud, got {} clouds and {} targets",
                clouds.len(),
                targets.len()
            )));
        }
        let t_dim = targets[0].len();
        if t_dim == 0 || targets.iter().any(|t| t.len() != t_dim) {
            return Err(RlError::InvalidArgument("targets must all have the same length, > 0".into()));
        }
        if let Some(i) = targets.iter().position(|t| t.iter().any(|v| !v.is_finite())) {
            return Err(RlError::InvalidArgument(format!("target {i} is not finite")));
        }
        let n = clouds.len();
        let (target_mean, target_std) = standardisation(targets, t_dim);
        let scaled: Vec<f32> = targets
            .iter()
            .flat_map(|t| t.iter().zip(target_mean.iter().zip(&target_std)).map(|(v, (m, s))| (v - m) / s))
            .collect();

        let device = &self.train_device;
        let mut head_rng = SplitMix64::new(options.seed, STREAM_HEAD);
        let mut widths = vec![self.dim()];
        widths.extend_from_slice(&options.head_hidden);
        widths.push(t_dim);
        let head = widths.windows(2).map(|w| linear(w[0], w[1], &mut head_rng, device)).collect();
        let mut model = Pretrain { net: self.net.clone(), head };
        let mut optimizer = AdamConfig::new().init();
        let mut shuffle = SplitMix64::new(options.seed, STREAM_SHUFFLE);
        let mut order: Vec<usize> = (0..n).collect();
        let mut epoch_losses = Vec::with_capacity(options.epochs);
        let mut updates = 0u64;
        for _ in 0..options.epochs {
            for i in (1..n).rev() {
                order.swap(i, shuffle.below(i + 1));
            }
            let mut sum = 0.0f64;
            for batch in order.chunks(options.batch_size) {
                let flat = Flat::new(batch.iter().map(|&i| clouds[i].as_slice()));
                let features = model.net.forward(self.config.k, &flat, device)?;
                let mut pred = features;
                let last = model.head.len() - 1;
                for (l, layer) in model.head.iter().enumerate() {
                    pred = layer.forward(pred);
                    if l < last {
                        pred = relu(pred);
                    }
                }
                let t: Vec<f32> =
                    batch.iter().flat_map(|&i| scaled[i * t_dim..(i + 1) * t_dim].iter().copied()).collect();
                let t = Tensor::<2>::from_data(TensorData::new(t, [batch.len(), t_dim]), device);
                let loss = (pred - t).square().mean();
                let loss_value = to_host(loss.clone())?.first().copied().unwrap_or(f32::NAN);
                if !loss_value.is_finite() {
                    return Err(RlError::Diverged { loss: loss_value, updates });
                }
                let grads = GradientsParams::from_grads(loss.backward(), &model);
                model = optimizer.step(options.learning_rate, model, grads);
                updates += 1;
                sum += f64::from(loss_value) * batch.len() as f64;
            }
            epoch_losses.push((sum / n as f64) as f32);
        }
        let mut layers = Vec::with_capacity(model.head.len());
        for layer in &model.head {
            let [d_in, d_out] = layer.weight.dims();
            let bias = match &layer.bias {
                Some(b) => to_host(b.val())?,
                None => vec![0.0; d_out],
            };
            layers.push((to_host(layer.weight.val())?, bias, d_in, d_out));
        }
        self.net = model.net;
        self.infer = self.net.valid();
        Ok(FitReport { epoch_losses, head: RegressionHead { layers, target_mean, target_std } })
    }

    /// The encoder's weights and shape as bytes: the 8-byte magic `S2GDGCNN`, a `u32` format
    /// version, `u64` values `k`, `seed`, `embedding`, the EdgeConv layer count and one per
    /// layer width, a `u64` payload length and the payload, the weights as a Burn
    /// `ModuleRecord` in burnpack format (all little-endian, as in the DQN checkpoints).
    pub fn to_bytes(&self) -> Result<Vec<u8>, RlError> {
        let payload = crate::record_bytes(self.net.clone())?;
        let c = &self.config;
        let mut buf = Vec::with_capacity(payload.len() + 8 * (c.edge_widths.len() + 6));
        buf.extend_from_slice(MAGIC);
        buf.extend_from_slice(&VERSION.to_le_bytes());
        for v in [c.k as u64, c.seed, c.embedding as u64, c.edge_widths.len() as u64] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        for &w in &c.edge_widths {
            buf.extend_from_slice(&(w as u64).to_le_bytes());
        }
        buf.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        buf.extend_from_slice(&payload);
        Ok(buf)
    }

    /// An encoder with the shape and weights of bytes made by [`to_bytes`](Self::to_bytes),
    /// on `backend`; it encodes bit-identically to the saved one (on the same backend).
    ///
    /// Junk, truncated or inconsistent bytes give [`RlError::Checkpoint`] (path `<memory>`).
    pub fn from_bytes(bytes: &[u8], backend: Backend) -> Result<Self, RlError> {
        let bad = |reason: String| RlError::Checkpoint { path: Path::new("<memory>").to_path_buf(), reason };
        let mut r = Reader::new(bytes);
        if r.take(8) != Some(MAGIC.as_slice()) {
            return Err(bad("not an s2g-rl DGCNN encoder (bad magic)".into()));
        }
        let version = r
            .take(4)
            .and_then(|b| b.try_into().ok())
            .map(u32::from_le_bytes)
            .ok_or_else(|| bad("truncated header".into()))?;
        if version != VERSION {
            return Err(bad(format!("format version {version}, this build reads {VERSION}")));
        }
        let mut next = || r.u64().ok_or_else(|| bad("truncated header".into()));
        let small = |v: u64, what: &str| -> Result<usize, RlError> {
            usize::try_from(v)
                .ok()
                .filter(|&v| v <= MAX_WIDTH)
                .ok_or_else(|| bad(format!("{what} {v} out of range")))
        };
        let k = small(next()?, "k")?;
        let seed = next()?;
        let embedding = small(next()?, "embedding")?;
        let layers = usize::try_from(next()?)
            .ok()
            .filter(|&l| l <= MAX_LAYERS)
            .ok_or_else(|| bad("layer count".into()))?;
        let edge_widths =
            (0..layers).map(|_| next().and_then(|w| small(w, "width"))).collect::<Result<Vec<_>, _>>()?;
        let payload_len = next()?;
        let config = DgcnnConfig { k, edge_widths, embedding, seed, backend };
        config.validate().map_err(|e| bad(format!("bad shape in header: {e}")))?;
        let payload = usize::try_from(payload_len)
            .ok()
            .and_then(|n| r.take(n))
            .ok_or_else(|| bad("truncated payload".into()))?;
        if r.remaining() != 0 {
            return Err(bad("trailing bytes after the payload".into()));
        }
        // Every parameter takes 4 bytes of the payload: a header asking for more than the
        // payload holds is corrupt, refused before building (and allocating) the network.
        if config.parameter_count().saturating_mul(4) > payload.len() {
            return Err(bad(format!(
                "header describes {} parameters, the payload has {} bytes",
                config.parameter_count(),
                payload.len()
            )));
        }
        let mut encoder = Self::new(config)?;
        let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(payload.to_vec()))
            .map_err(|e| bad(e.to_string()))?;
        encoder.net = encoder.net.clone().try_load_record(record).map_err(|e| bad(e.to_string()))?;
        encoder.infer = encoder.net.valid();
        Ok(encoder)
    }
}

/// Per-dimension mean and standard deviation of the targets (a zero or tiny deviation is
/// replaced by 1, so constant targets stay constant).
fn standardisation(targets: &[Vec<f32>], t_dim: usize) -> (Vec<f32>, Vec<f32>) {
    let n = targets.len() as f64;
    let mut mean = vec![0.0f64; t_dim];
    for t in targets {
        mean.iter_mut().zip(t).for_each(|(m, &v)| *m += f64::from(v) / n);
    }
    let mut var = vec![0.0f64; t_dim];
    for t in targets {
        var.iter_mut().zip(t.iter().zip(&mean)).for_each(|(s, (&v, m))| *s += (f64::from(v) - m).powi(2) / n);
    }
    let std = var.iter().map(|&v| if v.sqrt() > 1e-12 { v.sqrt() as f32 } else { 1.0 }).collect();
    (mean.iter().map(|&m| m as f32).collect(), std)
}

impl Encoder for DgcnnEncoder {
    type Input = [[f32; 3]];

    fn dim(&self) -> usize {
        DgcnnEncoder::dim(self)
    }

    /// [`DgcnnEncoder::try_encode`], with zeros in the (not expected) case of a backend error.
    fn encode(&self, input: &[[f32; 3]]) -> Vec<f32> {
        self.try_encode(input).unwrap_or_else(|_| vec![0.0; DgcnnEncoder::dim(self)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-matrix-product EdgeConv equals the definition computed edge by edge.
    #[test]
    fn edge_conv_matches_the_definition() {
        let config = DgcnnConfig { k: 4, edge_widths: vec![5], embedding: 3, ..DgcnnConfig::default() };
        let device = backend_device(config.backend);
        let net = DgcnnNet::new(&config, &device);
        let mut rng = SplitMix64::new(11, 0);
        let (p, c_in) = (9, 3);
        let xs: Vec<f32> = (0..p * c_in).map(|_| rng.next_f64() as f32 - 0.5).collect();
        let slots = batch_neighbours(&xs, c_in, std::slice::from_ref(&(0..p)), config.k, &device).unwrap();
        assert_eq!(slots.len(), 4);
        let x = Tensor::<2>::from_data(TensorData::new(xs.clone(), [p, c_in]), &device);
        let got = to_host(edge_conv(&net.edges[0], x, &slots, p, &device)).unwrap();
        let w = to_host(net.edges[0].weight.val()).unwrap();
        let b = to_host(net.edges[0].bias.as_ref().unwrap().val()).unwrap();
        let c_out = 5;
        for i in 0..p {
            for o in 0..c_out {
                let mut best = f32::NEG_INFINITY;
                for slot in &slots {
                    let j = slot[i] as usize;
                    let mut v = b[o];
                    for c in 0..c_in {
                        v += xs[i * c_in + c] * w[c * c_out + o];
                        v += (xs[j * c_in + c] - xs[i * c_in + c]) * w[(c_in + c) * c_out + o];
                    }
                    best = best.max(v.max(0.0));
                }
                let g = got[i * c_out + o];
                assert!((g - best).abs() < 1e-5, "point {i} channel {o}: {g} vs {best}");
            }
        }
    }
}
