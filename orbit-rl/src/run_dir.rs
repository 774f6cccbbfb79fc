//! Run directories and checkpoint lookup, as Isaac Lab lays them out (`logs/rsl_rl/...`):
//! `logs/<experiment>/<YYYY-MM-DD_HH-MM-SS>[_<run_name>]/model_<it>.{bpk,adam.bpk,json}`.

use std::path::{Path, PathBuf};

use regex::Regex;

use crate::RlError;

/// The folder of a run directory that holds the run's resolved configs.
pub const PARAMS_DIR: &str = "params";

/// The resolved env config in [`PARAMS_DIR`].
pub const ENV_CONFIG_FILE: &str = "env.ron";

/// The `params/` directory of the run that wrote the checkpoint `base` (`<run>/model_<it>`).
pub fn checkpoint_params_dir(base: &Path) -> PathBuf {
    base.with_file_name(PARAMS_DIR)
}

/// The resolved env config of the run that wrote the checkpoint `base` (`<run>/model_<it>`).
pub fn checkpoint_env_config(base: &Path) -> PathBuf {
    checkpoint_params_dir(base).join(ENV_CONFIG_FILE)
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

/// Creates a new run directory named as [`new_run_dir`] says and returns it. A directory that
/// exists is never reused: a run started in the same second as another gets the next free
/// suffix (`…_2`, `…_3`), and the directory is created atomically, so two processes cannot
/// both take one name.
pub fn create_run_dir(
    log_root: &Path,
    experiment: &str,
    run_name: &str,
) -> Result<PathBuf, RlError> {
    let first = new_run_dir(log_root, experiment, run_name);
    let parent = first.parent().unwrap_or(log_root);
    std::fs::create_dir_all(parent).map_err(RlError::io(parent))?;
    for n in 1u32.. {
        let dir = match n {
            1 => first.clone(),
            n => PathBuf::from(format!("{}_{n}", first.display())),
        };
        match std::fs::create_dir(&dir) {
            Ok(()) => return Ok(dir),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(RlError::Io {
                    path: dir,
                    source: e,
                });
            }
        }
    }
    unreachable!("some suffix is free")
}

/// Finds a checkpoint like RSL-RL's `get_checkpoint_path`: among the run directories of
/// `experiment_dir` whose names start with a match of `load_run`, the last in alphabetical
/// (= chronological) order that holds a checkpoint named by `checkpoint` (a regex matching the
/// whole name `model_<it>`, so `model_1` is not `model_199`); in it, the one with the highest
/// iteration. Newer matching runs without such a checkpoint (failed or interrupted runs) are
/// skipped with a warning. Returns the checkpoint's path without extension.
pub fn resolve_checkpoint(
    experiment_dir: &Path,
    load_run: &str,
    checkpoint: &str,
) -> Result<PathBuf, RlError> {
    let pattern = |flag: &str, p: &str, end: &str| {
        Regex::new(&format!("^(?:{p}){end}")).map_err(|e| {
            RlError::checkpoint(
                experiment_dir,
                format!("{flag} `{p}` is not a valid regular expression: {e}"),
            )
        })
    };
    let run_re = pattern("--load-run", load_run, "")?;
    let ckpt_re = pattern("--checkpoint", checkpoint, "$")?;
    if !experiment_dir.is_dir() {
        return Err(RlError::checkpoint(
            experiment_dir,
            "no runs here yet (the directory does not exist): train the task first, or pass \
             --log-root with the directory that holds its runs, or --checkpoint with a \
             checkpoint's path",
        ));
    }
    let list = |dir: &Path| -> Result<Vec<String>, RlError> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .map_err(RlError::io(dir))?
            .filter_map(|e| e.ok().and_then(|e| e.file_name().into_string().ok()))
            .collect();
        names.sort();
        Ok(names)
    };
    let runs: Vec<String> = list(experiment_dir)?
        .into_iter()
        .filter(|n| run_re.is_match(n) && experiment_dir.join(n).is_dir())
        .collect();
    if runs.is_empty() {
        return Err(RlError::checkpoint(
            experiment_dir,
            format!("no run directory matches `{load_run}`"),
        ));
    }
    let mut skipped = Vec::new();
    for run in runs.iter().rev() {
        let run_dir = experiment_dir.join(run);
        let mut checkpoints: Vec<String> = list(&run_dir)?
            .into_iter()
            .filter_map(|n| n.strip_suffix(".json").map(str::to_string))
            .filter(|n| n.starts_with("model_") && ckpt_re.is_match(n))
            .collect();
        // Left-pad to 15 characters so `model_50` sorts before `model_100`.
        checkpoints.sort_by_key(|n| format!("{n:0>15}"));
        if let Some(last) = checkpoints.pop() {
            if !skipped.is_empty() {
                tracing::warn!(
                    "skipped newer run directories without a checkpoint matching `{checkpoint}`: {}",
                    skipped.join(", ")
                );
            }
            return Ok(run_dir.join(last));
        }
        skipped.push(run.clone());
    }
    Err(RlError::checkpoint(
        experiment_dir,
        format!(
            "no run directory matching `{load_run}` holds a checkpoint matching `{checkpoint}` \
             (looked in {})",
            runs.join(", ")
        ),
    ))
}

/// The checkpoint that `--checkpoint` names, one meaning in `train --resume` and `play`: the
/// path of a checkpoint file (`…/model_49`, with or without an extension such as `.json` or
/// `.bpk`), or else a pattern of checkpoint names (`model_49`, `model_.*`) looked up with
/// [`resolve_checkpoint`] among the runs of `experiment_dir` that `load_run` matches. `None`
/// is the newest run's last checkpoint. Returns the checkpoint's path without extension.
pub fn find_checkpoint(
    experiment_dir: &Path,
    load_run: &str,
    checkpoint: Option<&str>,
) -> Result<PathBuf, RlError> {
    let Some(given) = checkpoint else {
        return resolve_checkpoint(experiment_dir, load_run, "model_.*");
    };
    let path = Path::new(given);
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or(given);
    let stem = [".adam.bpk", ".bpk", ".json"]
        .iter()
        .find_map(|ext| name.strip_suffix(ext))
        .unwrap_or(name);
    let base = path.with_file_name(stem);
    if base.with_extension("json").is_file() {
        return Ok(base);
    }
    if path.parent().is_some_and(|p| !p.as_os_str().is_empty()) {
        return Err(RlError::checkpoint(
            base.with_extension("json"),
            "no checkpoint at this path (a path names `<run>/model_<it>`, with or without \
             an extension; a bare name is looked up in the newest run)",
        ));
    }
    resolve_checkpoint(experiment_dir, load_run, given)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A path names that checkpoint, with any of its extensions or none, whatever the run
    /// pattern; a bare name is a pattern within the runs; a path to nothing is an error.
    #[test]
    fn checkpoint_is_a_path_or_a_name_pattern() {
        let root = std::env::temp_dir().join(format!("orbit-rl-find-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let (old, new) = (
            root.join("2026-01-01_00-00-00"),
            root.join("2026-01-02_00-00-00"),
        );
        for (run, it) in [(&old, 5), (&new, 7), (&new, 9)] {
            std::fs::create_dir_all(run).unwrap();
            std::fs::write(run.join(format!("model_{it}.json")), "{}").unwrap();
        }
        for given in ["model_5", "model_5.json", "model_5.bpk", "model_5.adam.bpk"] {
            let path = old.join(given);
            let got = find_checkpoint(&root, "2026-01-02", Some(path.to_str().unwrap())).unwrap();
            assert_eq!(got, old.join("model_5"), "{given}");
        }
        assert_eq!(
            find_checkpoint(&root, ".*", None).unwrap(),
            new.join("model_9")
        );
        let got = find_checkpoint(&root, ".*", Some("model_7")).unwrap();
        assert_eq!(got, new.join("model_7"));
        for (load_run, checkpoint, flag) in [
            ("(", "model_.*", "--load-run `(`"),
            (".*", "[", "--checkpoint `[`"),
        ] {
            let err = resolve_checkpoint(&root, load_run, checkpoint).unwrap_err();
            assert!(err.to_string().contains(flag), "{err}");
        }
        let err = find_checkpoint(&root.join("nothing"), ".*", None).unwrap_err();
        assert!(err.to_string().contains("no runs here yet"), "{err}");
        let missing = old.join("model_6");
        let err = find_checkpoint(&root, ".*", Some(missing.to_str().unwrap())).unwrap_err();
        assert!(
            err.to_string().contains("no checkpoint at this path"),
            "{err}"
        );
        std::fs::remove_dir_all(&root).unwrap();
    }

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

    /// `model_1` names model_1, not model_149 or model_10; a newer run without a checkpoint
    /// (failed, interrupted, zero iterations) is skipped; no checkpoint anywhere is an error.
    #[test]
    fn checkpoint_names_match_whole_and_empty_runs_are_skipped() {
        let root = std::env::temp_dir().join(format!("orbit-rl-run-skip-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let run = root.join("2026-01-01_00-00-00");
        std::fs::create_dir_all(&run).unwrap();
        for it in [1, 10, 149] {
            std::fs::write(run.join(format!("model_{it}.json")), "{}").unwrap();
        }
        std::fs::create_dir_all(root.join("2026-01-02_00-00-00/params")).unwrap();
        let got = resolve_checkpoint(&root, ".*", "model_1").unwrap();
        assert_eq!(got, run.join("model_1"));
        let got = resolve_checkpoint(&root, ".*", "model_1.*").unwrap();
        assert_eq!(got, run.join("model_149"));
        let err = resolve_checkpoint(&root, ".*", "model_2").unwrap_err();
        assert!(err.to_string().contains("holds a checkpoint"), "{err}");
        std::fs::remove_dir_all(&root).unwrap();
    }

    /// Runs created in the same second get distinct directories, and none is reused.
    #[test]
    fn run_directories_are_never_reused() {
        let root = std::env::temp_dir().join(format!("orbit-rl-run-new-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dirs: Vec<PathBuf> = (0..3)
            .map(|_| create_run_dir(&root, "exp", "a").unwrap())
            .collect();
        assert!(dirs.iter().all(|d| d.is_dir()));
        assert!(dirs[0] != dirs[1] && dirs[1] != dirs[2] && dirs[0] != dirs[2]);
        let entries = std::fs::read_dir(root.join("exp")).unwrap().count();
        assert_eq!(entries, 3);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
