//! Which Burn CPU backend runs the networks.

use burn::tensor::{Device, Tensor};

use crate::error::{FieldError, Result};

/// Which Burn CPU backend trains and evaluates the networks (tensor paths only; the
/// per-point queries of [`SirenF64`](crate::SirenF64) and [`NeuralSdf`](crate::NeuralSdf)
/// run on the host without Burn).
///
/// The variants present depend on this crate's cargo features (`flex`, the default, and
/// `ndarray`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Backend {
    /// Burn's pure-Rust Flex CPU backend (feature `flex`, on by default).
    #[cfg(feature = "flex")]
    Flex,
    /// Burn's NdArray CPU backend (feature `ndarray`; deprecated by Burn 0.22 in favour of
    /// Flex).
    #[cfg(feature = "ndarray")]
    NdArray,
}

impl Default for Backend {
    /// Flex when the `flex` feature is on, otherwise NdArray.
    fn default() -> Self {
        #[cfg(feature = "flex")]
        {
            Backend::Flex
        }
        #[cfg(not(feature = "flex"))]
        {
            Backend::NdArray
        }
    }
}

impl Backend {
    /// The backend's device, without autodiff.
    pub fn device(self) -> Device {
        match self {
            #[cfg(feature = "flex")]
            Backend::Flex => Device::flex(),
            // Burn 0.22 deprecates NdArray in favour of Flex; it is kept, behind its own
            // feature, as the backend the design named and as a cross-check of Flex.
            #[cfg(feature = "ndarray")]
            #[allow(deprecated)]
            Backend::NdArray => Device::ndarray(),
        }
    }
}

/// A tensor's values on the host, in row-major order.
pub(crate) fn host_values<const D: usize>(t: Tensor<D>) -> Result<Vec<f32>> {
    t.try_into_data().map_err(FieldError::backend)?.try_into_vec::<f32>().map_err(FieldError::backend)
}

/// The values of one step's losses on the host, in order, or [`FieldError::Diverged`] at
/// `step` with the first that is not finite (the check every optimisation loop makes
/// before its update).
pub(crate) fn finite_losses(losses: Vec<Tensor<1>>, step: usize) -> Result<Vec<f32>> {
    let values = host_values(Tensor::cat(losses, 0).inner())?;
    match values.iter().find(|v| !v.is_finite()) {
        Some(&loss) => Err(FieldError::Diverged { loss, step }),
        None => Ok(values),
    }
}
