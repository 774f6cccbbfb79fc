//! Run directories and checkpoint lookup, as Isaac Lab lays them out (`logs/rsl_rl/...`):
//! `logs/<experiment>/<YYYY-MM-DD_HH-MM-SS>[_<run_name>]/model_<it>.{bpk,adam.bpk,json}`.

use std::path::{Path, PathBuf};

use regex::Regex;

use crate::RlError;

/// The folder of a run directory that holds the run's resolved configs.
pub const PARAMS_DIR: &str = "params";

/// The resolved env config in [`PARAMS_DIR`].
pub const ENV_CONFIG_FILE: &str = "env.ron";

/// The resolved env config of the run that wrote the checkpoint `base` (`<run>/model_<it>`).
pub fn checkpoint_env_config(base: &Path) -> PathBuf {
    base.with_file_name(PARAMS_DIR).join(ENV_CONFIG_FILE)
}

/// The directory of a new run under `log_root/<experiment>/`, named by the local time.
pub fn new_run_dir(log_root: &Path, experiment: &str, run_name: &str) -> PathBuf {
    let stamp = chrono::Local::now().format("%Y-%m-%d_%H-%M-%S").to_string();
    let name = if run_name.is_empty() {
        stamp
    } else {
        format!("{stamp}_{run_name}")
    };
    log_root.join(experiment).join(name)
}

/// Finds a checkpoint like RSL-RL's `get_checkpoint_path`: among the run directories of
/// `experiment_dir` whose names start with a match of `load_run`, the last in alphabetical
/// (= chronological) order; inside it, among the checkpoints whose name (`model_<it>`) starts
/// with a match of `checkpoint`, the one with the highest iteration. Returns the checkpoint's
/// path without extension.
pub fn resolve_checkpoint(
    experiment_dir: &Path,
    load_run: &str,
    checkpoint: &str,
) -> Result<PathBuf, RlError> {
    let pattern = |p: &str| {
        Regex::new(&format!("^(?:{p})"))
            .map_err(|e| RlError::checkpoint(experiment_dir, format!("invalid pattern `{p}`: {e}")))
    };
    let (run_re, ckpt_re) = (pattern(load_run)?, pattern(checkpoint)?);
    let list = |dir: &Path| -> Result<Vec<String>, RlError> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .map_err(RlError::io(dir))?
            .filter_map(|e| e.ok().and_then(|e| e.file_name().into_string().ok()))
            .collect();
        names.sort();
        Ok(names)
    };
    let run = list(experiment_dir)?
        .into_iter()
        .rfind(|n| run_re.is_match(n) && experiment_dir.join(n).is_dir())
        .ok_or_else(|| {
            RlError::checkpoint(
                experiment_dir,
                format!("no run directory matches `{load_run}`"),
            )
        })?;
    let run_dir = experiment_dir.join(run);
    let mut checkpoints: Vec<String> = list(&run_dir)?
        .into_iter()
        .filter_map(|n| n.strip_suffix(".json").map(str::to_string))
        .filter(|n| n.starts_with("model_") && ckpt_re.is_match(n))
        .collect();
    // Left-pad to 15 characters so `model_50` sorts before `model_100`.
    checkpoints.sort_by_key(|n| format!("{n:0>15}"));
    let last = checkpoints.pop().ok_or_else(|| {
        RlError::checkpoint(&run_dir, format!("no checkpoint matches `{checkpoint}`"))
    })?;
    Ok(run_dir.join(last))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The latest run and the highest iteration win; patterns filter both.
    #[test]
    fn resolves_latest_run_and_iteration() {
        let root = std::env::temp_dir().join(format!("orbit-rl-run-dir-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        for (run, its) in [
            ("2026-01-01_00-00-00", &[0, 50][..]),
            ("2026-01-02_00-00-00", &[0, 50, 100, 149]),
        ] {
            std::fs::create_dir_all(root.join(run)).unwrap();
            for it in its {
                std::fs::write(root.join(run).join(format!("model_{it}.json")), "{}").unwrap();
            }
        }
        let got = resolve_checkpoint(&root, ".*", "model_.*").unwrap();
        assert_eq!(got, root.join("2026-01-02_00-00-00/model_149"));
        let got = resolve_checkpoint(&root, "2026-01-01", "model_.*").unwrap();
        assert_eq!(got, root.join("2026-01-01_00-00-00/model_50"));
        let got = resolve_checkpoint(&root, ".*", "model_100").unwrap();
        assert_eq!(got, root.join("2026-01-02_00-00-00/model_100"));
        let err = resolve_checkpoint(&root, "1999", "model_.*").unwrap_err();
        assert!(
            err.to_string().contains("no run directory matches `1999`"),
            "{err}"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}
