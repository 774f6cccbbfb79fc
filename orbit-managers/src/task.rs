//! The task registry: task ids (`BoxPushing-Torque-Franka-v0`) mapped to their RON configs.

use crate::error::EnvError;
use crate::rl_env::ManagerBasedRlEnv;

/// A registered task:
/// `inventory::submit! { TaskDef { id, description, file_name, config, overrides } }`.
pub struct TaskDef {
    /// Task id.
    pub id: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// File name used in error messages.
    pub file_name: &'static str,
    /// The env config (RON text).
    pub config: &'static str,
    /// Overrides that turn the config into this variant (applied before the user's).
    pub overrides: &'static [&'static str],
}

inventory::collect!(TaskDef);

/// A training config of a registered task for one learning library (Isaac Lab's
/// `rsl_rl_cfg_entry_point`): `inventory::submit! { AgentCfgDef { task, library, file_name,
/// config } }`.
pub struct AgentCfgDef {
    /// Task id the config trains.
    pub task: &'static str,
    /// Learning library / workflow, e.g. `"rsl_rl"` (step-based PPO).
    pub library: &'static str,
    /// File name used in error messages.
    pub file_name: &'static str,
    /// The config (RON text).
    pub config: &'static str,
}

inventory::collect!(AgentCfgDef);

/// The training config registered for `task` and `library`, if any.
pub fn agent_cfg(task: &str, library: &str) -> Option<&'static AgentCfgDef> {
    inventory::iter::<AgentCfgDef>
        .into_iter()
        .find(|a| a.task == task && a.library == library)
}

/// All registered tasks, sorted by id.
pub fn tasks() -> Vec<&'static TaskDef> {
    let mut v: Vec<&TaskDef> = inventory::iter::<TaskDef>.into_iter().collect();
    v.sort_by_key(|t| t.id);
    v
}

/// Builds the env of a registered task with config overrides (`key.path=value`).
pub fn make(id: &str, overrides: &[String]) -> Result<ManagerBasedRlEnv, EnvError> {
    let task = tasks()
        .into_iter()
        .find(|t| t.id == id)
        .ok_or_else(|| EnvError::InvalidTerm {
            field: "task".into(),
            message: format!(
                "no task `{id}`; registered tasks: {:?}",
                tasks().iter().map(|t| t.id).collect::<Vec<_>>()
            ),
        })?;
    let all: Vec<String> = task
        .overrides
        .iter()
        .map(|s| s.to_string())
        .chain(overrides.iter().cloned())
        .collect();
    ManagerBasedRlEnv::from_ron(task.config, task.file_name, &all)
}
