//! The managers: each owns its terms (built from the config in order) and their buffers.
//!
//! One file per manager; this module holds what they share: the term contexts they build
//! their terms with and the [`Manager`] trait (Isaac Lab's `ManagerBase`: term names and a
//! reset that returns the episode log).

use std::collections::BTreeMap;

use orbit_core::config::{Node, node_at};

use crate::base_env::{EnvRngs, EnvView};
use crate::cfg::EnvCfg;
use crate::scene::Scene;
use crate::term::TermContext;

mod action;
mod command;
mod curriculum;
mod event;
mod observation;
mod reward;
mod termination;

pub use action::ActionManager;
pub use command::CommandManager;
pub use curriculum::CurriculumManager;
pub use event::EventManager;
pub use observation::{ObservationGroup, ObservationManager};
pub use reward::RewardManager;
pub use termination::TerminationManager;

/// What every manager offers (Isaac Lab's `ManagerBase`).
pub trait Manager {
    /// The names of its terms, in config order (an observation term as `<group>/<term>`).
    fn active_terms(&self) -> Vec<String>;

    /// Resets the listed envs' state and returns its episode statistics of those envs, e.g.
    /// `Episode Reward/<term>` (see [`crate::Extras::log`]); empty when it logs nothing.
    fn reset(&mut self, env_ids: &[usize], ctx: &mut ResetContext<'_>) -> BTreeMap<String, f32>;
}

/// What a manager's reset may use besides the env ids.
pub struct ResetContext<'a> {
    /// The scene (commands are resampled on it).
    pub scene: &'a Scene,
    /// The command streams (resampled commands and their timers draw from them).
    pub command_rngs: &'a mut EnvRngs,
    /// Episode duration in seconds, which reward episode sums are divided by when logged
    /// (infinite for a base env, whose episodes do not end).
    pub episode_length_s: f32,
}

/// Builds the context of the term at `section.name` (its `params` node looked up in `doc`).
pub(crate) fn context<'a>(
    doc: &'a Node,
    scene: &'a Scene,
    cfg: &EnvCfg,
    field: String,
) -> TermContext<'a> {
    let params = node_at(doc, &format!("{field}.params"));
    TermContext {
        at: node_at(doc, &field).map(|n| n.span.clone()),
        field,
        params,
        scene,
        decimation: cfg.decimation,
        step_dt: cfg.sim.dt * cfg.decimation as f32,
        action_dim: 0,
        action_terms: Vec::new(),
        command_dims: Vec::new(),
    }
}

/// A term context that also knows the action and command terms (for terms built after them).
pub(crate) fn context_after<'a>(
    doc: &'a Node,
    scene: &'a Scene,
    cfg: &EnvCfg,
    field: String,
    actions: &ActionManager,
    commands: &CommandManager,
) -> TermContext<'a> {
    let mut ctx = context(doc, scene, cfg, field);
    ctx.action_dim = actions.dim;
    ctx.action_terms = actions
        .terms
        .iter()
        .map(|(n, t)| (n.clone(), t.dim()))
        .collect();
    ctx.command_dims = commands
        .terms
        .iter()
        .map(|c| (c.name.clone(), c.term.dim()))
        .collect();
    ctx
}

/// Prepares for computing a manager's terms concurrently (each reads only the env's state and
/// writes only its own buffer, so their own loops over envs share the pool instead of
/// following one another). The backend's state is made current first, on this thread: a
/// backend that refreshes it lazily on first look (the GPU backend's host mirror, a parallel
/// copy behind a `OnceLock`) must not do so inside the pool, where a worker waiting for the
/// copy could pick up another term that waits for the same refresh.
fn before_concurrent_terms(env: &EnvView<'_>) {
    env.scene.backend.sync();
}

/// The mean over `env_ids` of per-env `values` (0 for no envs), as logged at reset.
fn mean_over(env_ids: &[usize], value: impl Fn(usize) -> f32) -> f32 {
    env_ids.iter().map(|&e| value(e)).sum::<f32>() / env_ids.len().max(1) as f32
}
