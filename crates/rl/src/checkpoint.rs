//! Saving and loading an agent's Q-network.
//!
//! File layout (little-endian): the 8-byte magic `S2GRLDQN`, a `u32` format version, then
//! `u64` state dimension, `u64` action count, `u64` hidden-layer count and one `u64` per
//! hidden width, then a `u64` payload length and the payload: the online network's
//! parameters as a Burn `ModuleRecord` in Burn's burnpack format. The header lets
//! [`Dqn::load`] rebuild the network's shape before Burn applies (and shape-checks) the
//! parameters.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use burn::module::{Module, ModuleMapper, Param, ParamId};
use burn::store::ModuleRecord;
use burn::tensor::Bytes;
use burn::tensor::Tensor;

use crate::{Dqn, DqnConfig, RlError};

const MAGIC: &[u8; 8] = b"S2GRLDQN";
const VERSION: u32 = 1;
/// Far more hidden layers than any real network; refusing more keeps a corrupt header from
/// asking for a huge allocation.
const MAX_LAYERS: u64 = 1024;

/// `module`'s parameters as the bytes of a Burn `ModuleRecord` (burnpack format), the same
/// bytes for the same weights. Burn gives every parameter a random id, and the record
/// stores it; here the parameters are numbered 1, 2, ... in the order the module visits
/// them instead. (A module loaded from these bytes gets those ids: two such modules must
/// not share one optimiser.)
pub fn record_bytes<M: Module>(module: M) -> Result<Vec<u8>, RlError> {
    struct Renumber(u64);
    impl ModuleMapper for Renumber {
        fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
            let (_, value, mapper) = param.consume();
            self.0 += 1;
            Param::from_mapped_value(ParamId::from(self.0), value, mapper)
        }
    }
    let bytes = module.map(&mut Renumber(0)).into_record().into_bytes();
    bytes.map(|b| b.to_vec()).map_err(|e| RlError::Backend(e.to_string()))
}

impl Dqn {
    /// Write the online Q-network and its shape to `path`, atomically: the bytes go to a
    /// temporary file in the same directory, which is synced and then renamed over `path`,
    /// so a reader never sees a half-written checkpoint.
    ///
    /// Only the network is saved: the replay buffer, the optimiser's moments, the target
    /// network and the counters are training state, not the policy.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), RlError> {
        write_atomic(path.as_ref(), &self.to_bytes()?)
    }

    /// The checkpoint [`save`](Self::save) writes, as bytes (to embed in a larger file).
    pub fn to_bytes(&self) -> Result<Vec<u8>, RlError> {
        let payload = record_bytes(self.online().clone())?;
        let hidden = &self.config().hidden;
        let mut buf = Vec::with_capacity(payload.len() + 8 * (hidden.len() + 6));
        buf.extend_from_slice(MAGIC);
        buf.extend_from_slice(&VERSION.to_le_bytes());
        for v in [self.state_dim(), self.num_actions(), hidden.len()] {
            buf.extend_from_slice(&(v as u64).to_le_bytes());
        }
        for &w in hidden {
            buf.extend_from_slice(&(w as u64).to_le_bytes());
        }
        buf.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        buf.extend_from_slice(&payload);
        Ok(buf)
    }

    /// Build an agent from `config` with the network saved at `path` by [`Dqn::save`].
    ///
    /// The agent's state dimension and action count come from the file; `config.hidden`
    /// must equal the saved widths ([`RlError::Checkpoint`] otherwise). The loaded agent
    /// starts with an empty buffer, fresh optimiser and counters, and its target network
    /// equal to the loaded one; the Q-values are bit-identical to the saved agent's.
    pub fn load(path: impl AsRef<Path>, config: DqnConfig) -> Result<Self, RlError> {
        let path = path.as_ref();
        let bytes = fs::read(path).map_err(|source| RlError::Io { path: path.to_path_buf(), source })?;
        Self::decode(&bytes, config, path)
    }

    /// [`load`](Self::load) from bytes made by [`to_bytes`](Self::to_bytes); errors name
    /// the path `<memory>`.
    pub fn from_bytes(bytes: &[u8], config: DqnConfig) -> Result<Self, RlError> {
        Self::decode(bytes, config, Path::new("<memory>"))
    }

    fn decode(bytes: &[u8], config: DqnConfig, path: &Path) -> Result<Self, RlError> {
        let bad = |reason: String| RlError::Checkpoint { path: path.to_path_buf(), reason };
        let mut reader = Reader::new(bytes);
        if reader.take(8) != Some(MAGIC.as_slice()) {
            return Err(bad("not an s2g-rl checkpoint (bad magic)".into()));
        }
        let version = reader
            .take(4)
            .map(|b| u32::from_le_bytes(b.try_into().unwrap_or_default()))
            .ok_or_else(|| bad("truncated header".into()))?;
        if version != VERSION {
            return Err(bad(format!("format version {version}, this build reads {VERSION}")));
        }
        let mut next = || reader.u64().ok_or_else(|| bad("truncated header".into()));
        let state_dim = next()?;
        let num_actions = next()?;
        let layers = next()?;
        if layers > MAX_LAYERS {
            return Err(bad(format!("{layers} hidden layers")));
        }
        let hidden = (0..layers).map(|_| next()).collect::<Result<Vec<u64>, _>>()?;
        let payload_len = next()?;
        let to_usize = |v: u64| usize::try_from(v).map_err(|_| bad(format!("size {v} overflows usize")));
        let (state_dim, num_actions) = (to_usize(state_dim)?, to_usize(num_actions)?);
        let hidden = hidden.into_iter().map(to_usize).collect::<Result<Vec<_>, _>>()?;
        if hidden != config.hidden {
            return Err(bad(format!(
                "saved hidden layers {hidden:?} differ from the config's {:?}",
                config.hidden
            )));
        }
        let payload = reader.take(to_usize(payload_len)?).ok_or_else(|| bad("truncated payload".into()))?;
        if reader.pos != bytes.len() {
            return Err(bad("trailing bytes after the payload".into()));
        }
        let mut agent = Dqn::new(config, state_dim, num_actions)?;
        let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(payload.to_vec()))
            .map_err(|e| bad(e.to_string()))?;
        let online = agent.online().clone().try_load_record(record).map_err(|e| bad(e.to_string()))?;
        agent.set_online(online);
        Ok(agent)
    }
}

/// A cursor over the bytes of a checkpoint (the Q-network's, the DGCNN encoder's).
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, pos: 0 }
    }

    pub(crate) fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let out = self.bytes.get(self.pos..end)?;
        self.pos = end;
        Some(out)
    }

    /// Bytes not read yet.
    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    pub(crate) fn u64(&mut self) -> Option<u64> {
        self.take(8).map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()))
    }
}

/// Write `bytes` to a temporary sibling of `path`, sync it, and rename it over `path`.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RlError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let io = |p: &Path| {
        let p = p.to_path_buf();
        move |source| RlError::Io { path: p, source }
    };
    let file_name = path.file_name().ok_or_else(|| RlError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "path has no file name"),
    })?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(file_name);
    tmp_name.push(format!(".{}-{}.tmp", std::process::id(), COUNTER.fetch_add(1, Ordering::Relaxed)));
    let tmp: PathBuf = path.with_file_name(tmp_name);
    let result = (|| {
        let mut file = fs::File::create(&tmp).map_err(io(&tmp))?;
        file.write_all(bytes).map_err(io(&tmp))?;
        file.sync_all().map_err(io(&tmp))?;
        drop(file);
        fs::rename(&tmp, path).map_err(io(path))
    })();
    if result.is_err() {
        // Best effort: the temporary file is ours and useless once the write failed.
        let _ = fs::remove_file(&tmp);
    }
    result
}
