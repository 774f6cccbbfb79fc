//! A runner's checkpoint on disk: `model_<it>.bpk` (the network), `model_<it>.adam.bpk` (Adam's
//! state) and `model_<it>.json` (everything else), written so that a failed write never
//! leaves a damaged checkpoint or touches an earlier one.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::RlError;
use crate::cfg::PolicyCfg;
use crate::normalizer::EmpiricalNormalizer;
use crate::ppo::Ppo;

/// The suffix of a checkpoint file while it is being written.
const PARTIAL_SUFFIX: &str = "partial";

/// Everything besides the weights that a checkpoint must restore (`model_<it>.json`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct CheckpointState {
    /// Iteration the checkpoint was taken after (a resumed run continues from it).
    pub iteration: usize,
    /// Learning rate at that point.
    pub learning_rate: f64,
    /// Transitions collected so far.
    pub env_steps: u64,
    /// Training wall-clock seconds so far.
    pub wall_time: f64,
    /// Actor input width.
    pub num_obs: usize,
    /// Critic input width.
    pub num_critic_obs: usize,
    /// Action width.
    pub num_actions: usize,
    /// The network's architecture.
    pub policy: PolicyCfg,
    /// Actor observation statistics, if normalisation is on.
    pub obs_normalizer: Option<EmpiricalNormalizer>,
    /// Critic observation statistics, if normalisation is on.
    pub critic_obs_normalizer: Option<EmpiricalNormalizer>,
    /// Return statistics the critic's output is scaled by, if `normalize_value` is on
    /// (absent in checkpoints written before the option existed).
    #[serde(default)]
    pub value_normalizer: Option<EmpiricalNormalizer>,
}

/// Reads a checkpoint's `model_<it>.json`.
pub fn read_state(base: &Path) -> Result<CheckpointState, RlError> {
    let path = base.with_extension("json");
    let text = std::fs::read_to_string(&path).map_err(RlError::io(&path))?;
    serde_json::from_str(&text).map_err(|e| RlError::checkpoint(path, e))
}

/// Writes the checkpoint `base` (`<run>/model_<it>`, no extension) of `alg` and `state`
/// atomically: each file goes to `<file>.partial` first and is renamed into place only when
/// all three are written, the `.json` that marks a checkpoint last. A failed write removes
/// the partial files and returns the error at once; earlier checkpoints are never touched,
/// and a checkpoint of the same name is either kept whole or replaced whole by readers'
/// lights (they look for the `.json`).
pub fn write_checkpoint(base: &Path, alg: &Ppo, state: &CheckpointState) -> Result<(), RlError> {
    let targets = [
        base.with_extension("bpk"),
        base.with_extension("adam.bpk"),
        base.with_extension("json"),
    ];
    let partial = targets.clone().map(|p| partial_path(&p));
    let written = (|| {
        alg.save_files(&partial[0], &partial[1])?;
        let text = serde_json::to_string_pretty(state).expect("plain data serialises");
        write_synced(&partial[2], text.as_bytes())?;
        for (from, to) in partial.iter().zip(&targets) {
            std::fs::rename(from, to).map_err(RlError::io(to))?;
        }
        Ok(())
    })();
    if written.is_err() {
        for p in &partial {
            let _ = std::fs::remove_file(p);
        }
    }
    written
}

/// `<file>.partial` beside `file`.
fn partial_path(file: &Path) -> PathBuf {
    let mut name = file.file_name().unwrap_or_default().to_os_string();
    name.push(".");
    name.push(PARTIAL_SUFFIX);
    file.with_file_name(name)
}

/// Writes `bytes` to `path` and waits until they are on disk (a full disk fails here, not
/// later).
fn write_synced(path: &Path, bytes: &[u8]) -> Result<(), RlError> {
    let mut file = std::fs::File::create(path).map_err(RlError::io(path))?;
    file.write_all(bytes).map_err(RlError::io(path))?;
    file.sync_all().map_err(RlError::io(path))
}
