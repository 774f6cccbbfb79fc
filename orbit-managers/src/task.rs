//! The task registry: a table of task ids and their config files (env, training agent,
//! black-box wrapper), as Isaac Lab's `gym.register(id, kwargs={"env_cfg_entry_point": …,
//! "rsl_rl_cfg_entry_point": …})`.
//!
//! A task crate bundles its `config/` files and registers its table:
//!
//! ```ignore
//! inventory::submit! {
//!     orbit_managers::TaskTable {
//!         root: "reach",
//!         files: orbit_managers::config_files!("env/reach.ron", "agents/ppo.ron"),
//!         tasks: &[orbit_managers::TaskDef {
//!             id: "Reach-Franka-v0",
//!             description: "…",
//!             env: "env/reach.ron",
//!             agent: Some("agents/ppo.ron"),
//!             black_box: None,
//!             cpu_agent: None,
//!         }],
//!     }
//! }
//! ```
//!
//! The files are compiled in and named `<bundled>/<root>/<path>`; their `#include`s resolve
//! relative to the including file, in memory, as they do on disk.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use orbit_core::config::{Bundled, Node};

use crate::error::EnvError;
use crate::rl_env::ManagerBasedRlEnv;

/// One row of a task table; paths are relative to the table's `config/` directory.
pub struct TaskDef {
    /// Task id.
    pub id: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// The env config (for a black-box task, the step-based env it wraps).
    pub env: &'static str,
    /// The training config of `train` (RSL-RL's PPO, or BBRL-PPO for a black-box task).
    pub agent: Option<&'static str>,
    /// The black-box wrapper config: set for episodic tasks, one movement primitive per
    /// episode (Fancy Gym's `fancy_ProMP/…` ids).
    pub black_box: Option<&'static str>,
    /// A training config sized for physics on the CPU (Mesa's lavapipe or rapier), which
    /// `train` uses instead of `agent` when the run's physics is on the CPU.
    pub cpu_agent: Option<&'static str>,
}

impl TaskDef {
    /// This task with a training config for physics on the CPU.
    pub const fn with_cpu_agent(self, cpu_agent: &'static str) -> Self {
        Self {
            cpu_agent: Some(cpu_agent),
            ..self
        }
    }
}

/// A crate's bundled config files and its tasks:
/// `inventory::submit! { TaskTable { root, files, tasks } }`.
pub struct TaskTable {
    /// The directory name of the crate's files under the bundled root (`box_pushing`).
    pub root: &'static str,
    /// `(path under config/, text)` of every file, from [`config_files!`](crate::config_files).
    pub files: &'static [(&'static str, &'static str)],
    /// The registered tasks.
    pub tasks: &'static [TaskDef],
}

inventory::collect!(TaskTable);

/// `(path, text)` pairs of files in the calling crate's `config/` directory, compiled in.
#[macro_export]
macro_rules! config_files {
    ($($file:literal),* $(,)?) => {
        &[$(($file, include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/config/", $file)))),*]
    };
}

/// A registered task with its files' full names (`<bundled>/box_pushing/env/torque.ron`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Task {
    /// Task id.
    pub id: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// The env config.
    pub env: PathBuf,
    /// The training config, if the task is trainable.
    pub agent: Option<PathBuf>,
    /// The black-box wrapper config of an episodic task.
    pub black_box: Option<PathBuf>,
    /// The training config for physics on the CPU, if the task has one.
    pub cpu_agent: Option<PathBuf>,
}

impl Task {
    /// Whether the task is episodic (a movement primitive per episode).
    pub fn is_black_box(&self) -> bool {
        self.black_box.is_some()
    }

    fn new(root: &str, def: &'static TaskDef) -> Self {
        let full = |path: &str| Bundled::full_path(&format!("{root}/{path}"));
        Self {
            id: def.id,
            description: def.description,
            env: full(def.env),
            agent: def.agent.map(full),
            black_box: def.black_box.map(full),
            cpu_agent: def.cpu_agent.map(full),
        }
    }
}

/// All registered tasks, sorted by id.
pub fn tasks() -> Vec<Task> {
    let mut v: Vec<Task> = inventory::iter::<TaskTable>
        .into_iter()
        .flat_map(|t| t.tasks.iter().map(|d| Task::new(t.root, d)))
        .collect();
    v.sort_by_key(|t| t.id);
    v
}

/// The task registered as `id`, or an error listing the registered ids.
pub fn task(id: &str) -> Result<Task, EnvError> {
    tasks()
        .into_iter()
        .find(|t| t.id == id)
        .ok_or_else(|| EnvError::InvalidTerm {
            field: "task".into(),
            message: format!(
                "no task `{id}`; registered tasks: {:?}",
                tasks().iter().map(|t| t.id).collect::<Vec<_>>()
            ),
        })
}

/// Every bundled config file of every task crate (for loading, including, exporting).
pub fn bundled_configs() -> &'static Bundled {
    static BUNDLED: OnceLock<Bundled> = OnceLock::new();
    BUNDLED.get_or_init(|| {
        Bundled::new(inventory::iter::<TaskTable>.into_iter().flat_map(|t| {
            t.files
                .iter()
                .map(move |(path, text)| (format!("{}/{path}", t.root), *text))
        }))
    })
}

/// Loads a config file (on disk, or bundled when its path starts with `<bundled>`) with its
/// includes and `overrides` applied.
pub fn load_config(path: &Path, overrides: &[String]) -> Result<Node, EnvError> {
    Ok(orbit_core::config::load_document_with(
        bundled_configs(),
        path,
        overrides,
    )?)
}

/// An env config document as the env is built from it: includes merged, `overrides` applied,
/// the scene composed from its asset configs. Its [`Node::to_ron`] is a self-contained file
/// that rebuilds the same env.
pub fn load_env_config(path: &Path, overrides: &[String]) -> Result<Node, EnvError> {
    let doc = load_config(path, overrides)?;
    Ok(orbit_assets::compose_env_scene(&doc)?)
}

/// Builds the env of a registered task with config overrides (`key.path=value`); for a
/// black-box task, the step-based env it wraps.
pub fn make(id: &str, overrides: &[String]) -> Result<ManagerBasedRlEnv, EnvError> {
    make_from_file(&task(id)?.env, overrides)
}

/// Builds the env of a config file (on disk or bundled) with overrides.
pub fn make_from_file(path: &Path, overrides: &[String]) -> Result<ManagerBasedRlEnv, EnvError> {
    // `from_document` composes the scene itself.
    ManagerBasedRlEnv::from_document(&load_config(path, overrides)?)
}

/// Writes the config files of task `id` (env, agent, black-box, and every file they include)
/// under `dir`, keeping their relative layout so the includes still resolve; returns the
/// written paths. Existing files are not overwritten.
pub fn export_task_configs(id: &str, dir: &Path) -> Result<Vec<PathBuf>, EnvError> {
    let task = task(id)?;
    let mut files: Vec<PathBuf> = Vec::new();
    for top in [
        Some(&task.env),
        task.agent.as_ref(),
        task.black_box.as_ref(),
    ]
    .into_iter()
    .flatten()
    {
        for dep in orbit_core::config::dependencies(bundled_configs(), top)? {
            if !files.contains(&dep) {
                files.push(dep);
            }
        }
    }
    let io = |path: &Path, e: std::io::Error| EnvError::InvalidTerm {
        field: "export".into(),
        message: format!("cannot write `{}`: {e}", path.display()),
    };
    // Every target is checked before anything is written, so a refusal leaves no partial copy.
    let mut targets = Vec::with_capacity(files.len());
    for file in &files {
        let relative = file
            .strip_prefix(orbit_core::config::BUNDLED_ROOT)
            .unwrap_or(file);
        let target = dir.join(relative);
        if target.exists() {
            return Err(EnvError::InvalidTerm {
                field: "export".into(),
                message: format!(
                    "`{}` exists; export into an empty directory (nothing was written)",
                    target.display()
                ),
            });
        }
        targets.push(target);
    }
    for (file, target) in files.iter().zip(&targets) {
        let text = bundled_configs().get(file).unwrap_or_default();
        if let Some(parent) = target.parent() {
            std::fs::create_dir_all(parent).map_err(|e| io(parent, e))?;
        }
        std::fs::write(target, text).map_err(|e| io(target, e))?;
    }
    Ok(targets)
}
