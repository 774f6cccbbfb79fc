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
