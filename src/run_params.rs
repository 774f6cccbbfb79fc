//! A run's own configs (`<run>/params/`): `play` and `train --resume` rebuild the env and the
//! agent from the run that wrote the checkpoint, so that a run trained with overrides plays and
//! continues with them; `--registered-config` takes the task's configs instead.

use std::path::{Path, PathBuf};

use orbit_rl::run_dir::{ENV_CONFIG_FILE, checkpoint_params_dir};

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

/// Replaces each config of `configs` that was not given on the command line by the file of the
/// run that wrote `checkpoint`, where the run has one (none with `--registered-config`), and
/// returns a line that says which configs the env and agent are built from.
pub fn choose_configs(configs: &mut RunConfigs, checkpoint: &Path, given: GivenFiles) -> String {
    if given.registered {
        return "configs: the task's registered ones (--registered-config)".into();
    }
    let dir = checkpoint_params_dir(checkpoint);
    let mut used = Vec::new();
    // The run's file `name`, where `wanted` and the run has it.
    let mut from_run = |name: &str, wanted: bool| -> Option<PathBuf> {
        let file = dir.join(name);
        (wanted && file.is_file()).then(|| {
            used.push(name.to_string());
            file
        })
    };
    if let Some(file) = from_run(ENV_CONFIG_FILE, !given.env) {
        configs.env = file;
    }
    if let Some(file) = from_run(AGENT_CONFIG_FILE, !given.agent && configs.agent.is_some()) {
        configs.agent = Some(file);
        // The run's agent config is the one it trained with, CPU-sized or not.
        configs.cpu_agent = None;
    }
    let black_box = !given.black_box && configs.black_box.is_some();
    if let Some(file) = from_run(BLACK_BOX_CONFIG_FILE, black_box) {
        configs.black_box = Some(file);
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
