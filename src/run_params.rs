//! A run's own configs (`<run>/params/`): `play` and `train --resume` rebuild the env and the
//! agent from the run that wrote the checkpoint, so that a run trained with overrides plays and
//! continues with them; `--registered-config` takes the task's configs instead.

use std::path::{Path, PathBuf};

use orbit_rl::run_dir::{ENV_CONFIG_FILE, PARAMS_DIR};

use crate::RunConfigs;
use crate::train::{AGENT_CONFIG_FILE, BLACK_BOX_CONFIG_FILE};

/// The file in a resumed run's `params/` that names the checkpoint it continued from.
pub const RESUMED_FROM_FILE: &str = "resumed_from.ron";

/// What the command line chose: the registered configs, or files for some of them (those
/// are kept).
#[derive(Clone, Copy, Debug, Default)]
pub struct GivenFiles {
    /// `--registered-config`: the task's configs, none of the run's.
    pub registered: bool,
    /// `--task-config`.
    pub env: bool,
    /// `--agent-config`.
    pub agent: bool,
    /// `--bb-config`.
    pub black_box: bool,
}

/// The `params/` directory of the run that wrote the checkpoint `base` (`<run>/model_<it>`).
pub fn params_dir(base: &Path) -> PathBuf {
    base.with_file_name(PARAMS_DIR)
}

/// Replaces each config of `configs` that was not given on the command line by the file of the
/// run that wrote `checkpoint`, where the run has one (none with `--registered-config`), and
/// returns a line that says which configs the env and agent are built from.
pub fn choose_configs(configs: &mut RunConfigs, checkpoint: &Path, given: GivenFiles) -> String {
    if given.registered {
        return "configs: the task's registered ones (--registered-config)".into();
    }
    let dir = params_dir(checkpoint);
    let mut used = Vec::new();
    let mut take = |name: &str, slot: &mut Option<PathBuf>, given: bool| {
        let file = dir.join(name);
        if !given && slot.is_some() && file.is_file() {
            *slot = Some(file);
            used.push(name.to_string());
        }
    };
    let mut env = Some(configs.env.clone());
    take(ENV_CONFIG_FILE, &mut env, given.env);
    configs.env = env.expect("kept or replaced");
    take(AGENT_CONFIG_FILE, &mut configs.agent, given.agent);
    take(
        BLACK_BOX_CONFIG_FILE,
        &mut configs.black_box,
        given.black_box,
    );
    if used.iter().any(|u| u == AGENT_CONFIG_FILE) {
        // The run's agent config is the one it trained with, CPU-sized or not.
        configs.cpu_agent = None;
    }
    if used.is_empty() {
        format!(
            "configs: the task's registered ones ({} holds none of the run's configs)",
            dir.display()
        )
    } else {
        format!(
            "configs: {} of the run ({}); --registered-config builds from the task's instead",
            used.join(", "),
            dir.display()
        )
    }
}

/// The text of a resumed run's [`RESUMED_FROM_FILE`]: the checkpoint it continued from.
pub fn resumed_from_text(checkpoint: &Path) -> String {
    let run = checkpoint.parent().unwrap_or(Path::new(""));
    format!(
        "(\n    run: {:?},\n    checkpoint: {:?},\n)\n",
        run.display().to_string(),
        checkpoint.display().to_string()
    )
}
