//! Saving and loading a [`NeuralSdf`].
//!
//! File layout (little-endian): the 8-byte magic `S2GFLSDF`, a `u32` format version, then
//! `u64` sine-layer count, `u64` width, `f64` first-layer and hidden frequencies, `f64`
//! normalisation scale and three `f64` translation components, `f64` half extent of the
//! training box, then a `u64` payload length and the payload: the network's parameters as
//! a Burn `ModuleRecord` in Burn's burnpack format. The header lets [`NeuralSdf::load`]
//! rebuild the network's shape before Burn applies (and shape-checks) the parameters.

use std::path::Path;

use burn::module::{Module, ModuleMapper, Param, ParamId};
use burn::store::ModuleRecord;
use burn::tensor::Bytes;
use burn::tensor::Tensor;
use s2g_geom::{Normalization, Vector3, write_bytes_atomic};

use crate::backend::Backend;
use crate::error::{FieldError, Result};
use crate::sdf::NeuralSdf;
use crate::siren::{Siren, SirenConfig};

const MAGIC: &[u8; 8] = b"S2GFLSDF";
const VERSION: u32 = 1;

/// `module`'s parameters as burnpack bytes, the same bytes for the same weights: Burn's
/// random parameter ids are replaced by 1, 2, ... in visiting order, as
/// `s2g_rl::record_bytes` does for the Q-networks (this crate does not depend on s2g-rl).
fn record_bytes<M: Module>(module: M) -> Result<Bytes> {
    struct Renumber(u64);
    impl ModuleMapper for Renumber {
        fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
            let (_, value, mapper) = param.consume();
            self.0 += 1;
            Param::from_mapped_value(ParamId::from(self.0), value, mapper)
        }
    }
    module.map(&mut Renumber(0)).into_record().into_bytes().map_err(FieldError::backend)
}

impl NeuralSdf {
    /// The field as bytes (see the module docs for the layout).
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let device = Backend::default().device();
        let net = self.net.to_siren(&device);
        let (layers, width) = (net.sine_layers(), net.width());
        let payload = record_bytes(net)?;
        let mut buf = Vec::with_capacity(payload.len() + 96);
        buf.extend_from_slice(MAGIC);
        buf.extend_from_slice(&VERSION.to_le_bytes());
        for v in [layers, width] {
            buf.extend_from_slice(&(v as u64).to_le_bytes());
        }
        let n = &self.normalization;
        for v in [
            self.net.first_omega(),
            self.net.hidden_omega(),
            n.scale,
            n.translation.x,
            n.translation.y,
            n.translation.z,
            self.half_extent,
        ] {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        buf.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        buf.extend_from_slice(&payload);
        Ok(buf)
    }

    /// Writes the field to `path` atomically (a temporary sibling, synced, then renamed),
    /// so a reader never sees a half-written file.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let bytes = self.to_bytes()?;
        write_bytes_atomic(path, &bytes).map_err(FieldError::geom)
    }

    /// Reads a field written by [`NeuralSdf::save`]; it answers every query bit-identically
    /// to the saved one.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let bytes =
            std::fs::read(path).map_err(|source| FieldError::Io { path: path.to_path_buf(), source })?;
        Self::from_bytes(&bytes).map_err(|e| match e {
            FieldError::Checkpoint { reason, .. } => {
                FieldError::Checkpoint { path: path.to_path_buf(), reason }
            }
            e => e,
        })
    }

    /// Reads a field from bytes written by [`NeuralSdf::to_bytes`]. Errors are
    /// [`FieldError::Checkpoint`] with an empty path.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let bad = |reason: String| FieldError::Checkpoint { path: Default::default(), reason };
        let mut r = Reader { bytes, pos: 0 };
        if r.take(8) != Some(MAGIC.as_slice()) {
            return Err(bad("not an s2g-field SDF (bad magic)".into()));
        }
        let version = r.take(4).map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()));
        match version {
            Some(VERSION) => {}
            Some(v) => return Err(bad(format!("format version {v}, this build reads {VERSION}"))),
            None => return Err(bad("truncated header".into())),
        }
        let trunc = || bad("truncated header".into());
        let layers = r.u64().ok_or_else(trunc)?;
        let width = r.u64().ok_or_else(trunc)?;
        let mut f = [0.0f64; 7];
        for v in &mut f {
            *v = r.u64().map(f64::from_bits).ok_or_else(trunc)?;
        }
        let [first_omega, hidden_omega, scale, tx, ty, tz, half_extent] = f;
        let to_usize = |v: u64| usize::try_from(v).map_err(|_| bad(format!("size {v} overflows usize")));
        let config = SirenConfig {
            sine_layers: to_usize(layers)?,
            width: to_usize(width)?,
            first_omega,
            hidden_omega,
            seed: 0,
        };
        config.validate().map_err(|e| bad(format!("bad network header: {e}")))?;
        if !(f.iter().all(|v| v.is_finite()) && scale > 0.0 && half_extent > 0.0) {
            return Err(bad("bad normalisation in the header".into()));
        }
        let payload_len = r.u64().ok_or_else(trunc)?;
        let payload = r.take(to_usize(payload_len)?).ok_or_else(|| bad("truncated payload".into()))?;
        if r.pos != bytes.len() {
            return Err(bad("trailing bytes after the payload".into()));
        }
        let device = Backend::default().device();
        let net = Siren::new(&config, &device).map_err(|e| bad(e.to_string()))?;
        let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(payload.to_vec()))
            .map_err(|e| bad(e.to_string()))?;
        let net = net.try_load_record(record).map_err(|e| bad(e.to_string()))?;
        Ok(NeuralSdf {
            net: net.to_f64()?,
            normalization: Normalization { scale, translation: Vector3::new(tx, ty, tz) },
            half_extent,
        })
    }
}

/// A cursor over the file's bytes.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let out = self.bytes.get(self.pos..end)?;
        self.pos = end;
        Some(out)
    }

    fn u64(&mut self) -> Option<u64> {
        self.take(8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()))
    }
}
