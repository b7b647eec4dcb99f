//! The Q-network: a multilayer perceptron of Burn `Linear` layers with ReLU between them.

use burn::module::{Module, Param};
use burn::nn::Linear;
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};

use crate::rng::SplitMix64;

/// `state_dim -> hidden[0] -> ... -> num_actions`, ReLU after every hidden layer, none after
/// the output (Q-values are unbounded).
#[derive(Module, Debug)]
pub(crate) struct QNetwork {
    layers: Vec<Linear>,
}

impl QNetwork {
    /// A network with weights drawn from `rng` on `device`.
    ///
    /// Weights and biases are `U(-1/sqrt(fan_in), 1/sqrt(fan_in))`, the default of Burn's
    /// and PyTorch's `Linear`. They are drawn here from our own generator rather than by
    /// Burn's initialisers because Burn initialises parameters lazily from a backend-wide
    /// random state (`Device::seed` "may be applied globally"), which concurrent agents, or
    /// tests running in parallel, would share.
    pub(crate) fn new(widths: &[usize], rng: &mut SplitMix64, device: &Device) -> Self {
        let layers = widths.windows(2).map(|w| linear(w[0], w[1], rng, device)).collect();
        Self { layers }
    }

    /// Q-values for a batch of states.
    ///
    /// - `states`: `[batch, state_dim]`
    /// - output: `[batch, num_actions]`
    pub(crate) fn forward(&self, states: Tensor<2>) -> Tensor<2> {
        let last = self.layers.len() - 1;
        let mut x = states;
        for (i, layer) in self.layers.iter().enumerate() {
            x = layer.forward(x);
            if i < last {
                x = relu(x);
            }
        }
        x
    }
}

/// A `d_in -> d_out` layer with weights and biases `U(-1/sqrt(d_in), 1/sqrt(d_in))` drawn
/// from `rng` (see [`QNetwork::new`] for why not Burn's initialisers).
pub(crate) fn linear(d_in: usize, d_out: usize, rng: &mut SplitMix64, device: &Device) -> Linear {
    let bound = 1.0 / (d_in as f64).sqrt();
    let mut uniform =
        |n: usize| -> Vec<f32> { (0..n).map(|_| ((2.0 * rng.next_f64() - 1.0) * bound) as f32).collect() };
    // Burn's row layout stores the weight as [d_input, d_output] (`O = IW + b`).
    let weight = uniform(d_in * d_out);
    let bias = uniform(d_out);
    Linear {
        weight: Param::from_data(TensorData::new(weight, [d_in, d_out]), device),
        bias: Some(Param::from_data(TensorData::new(bias, [d_out]), device)),
    }
}
