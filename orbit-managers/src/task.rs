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

/// A registered black-box (episodic) task: a step-based task driven by movement primitives
/// (Fancy Gym's `fancy_ProMP/…` ids): `inventory::submit! { BlackBoxTaskDef { … } }`. The
/// config is the black-box wrapper's (`orbit_rl::BlackBoxCfg`).
pub struct BlackBoxTaskDef {
    /// Task id.
    pub id: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// The step-based task it wraps.
    pub env_task: &'static str,
    /// Overrides of the step-based task's config (applied before the user's).
    pub env_overrides: &'static [&'static str],
    /// File name used in error messages.
    pub file_name: &'static str,
    /// The black-box config (RON text).
    pub config: &'static str,
    /// Overrides that turn the black-box config into this variant (applied before the
    /// user's).
    pub overrides: &'static [&'static str],
}

impl BlackBoxTaskDef {
    /// The task's black-box overrides followed by `user`.
    pub fn overrides_with(&self, user: &[String]) -> Vec<String> {
        self.overrides
            .iter()
            .map(|s| s.to_string())
            .chain(user.iter().cloned())
            .collect()
    }
}

inventory::collect!(BlackBoxTaskDef);

/// All registered black-box tasks, sorted by id.
pub fn black_box_tasks() -> Vec<&'static BlackBoxTaskDef> {
    let mut v: Vec<&BlackBoxTaskDef> = inventory::iter::<BlackBoxTaskDef>.into_iter().collect();
    v.sort_by_key(|t| t.id);
    v
}

/// The black-box task `id`, if one is registered.
pub fn black_box_task(id: &str) -> Option<&'static BlackBoxTaskDef> {
    inventory::iter::<BlackBoxTaskDef>
        .into_iter()
        .find(|t| t.id == id)
}

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

/// The step-based task behind `id` (itself, or the task a black-box task wraps) and the
/// overrides that make its config `id`'s env, followed by `overrides`.
pub fn resolve_task(
    id: &str,
    overrides: &[String],
) -> Result<(&'static TaskDef, Vec<String>), EnvError> {
    let (env_id, bb_overrides): (&str, &[&str]) = match black_box_task(id) {
        Some(bb) => (bb.env_task, bb.env_overrides),
        None => (id, &[]),
    };
    let task = tasks()
        .into_iter()
        .find(|t| t.id == env_id)
        .ok_or_else(|| EnvError::InvalidTerm {
            field: "task".into(),
            message: format!(
                "no task `{env_id}`; registered tasks: {:?}",
                tasks()
                    .iter()
                    .map(|t| t.id)
                    .chain(black_box_tasks().iter().map(|t| t.id))
                    .collect::<Vec<_>>()
            ),
        })?;
    let all = task
        .overrides
        .iter()
        .chain(bb_overrides)
        .map(|s| s.to_string())
        .chain(overrides.iter().cloned())
        .collect();
    Ok((task, all))
}

/// Builds the env of a registered task with config overrides (`key.path=value`); for a
/// black-box task, the step-based env it wraps.
pub fn make(id: &str, overrides: &[String]) -> Result<ManagerBasedRlEnv, EnvError> {
    let (task, all) = resolve_task(id, overrides)?;
    ManagerBasedRlEnv::from_ron(task.config, task.file_name, &all)
}
