//! Terms and their registries. A term is a value built once from its config (typed parameters
//! deserialised from RON, scene names resolved) and then called once per step for all envs.
//! Crates register term builders by name with `inventory::submit!`.

use orbit_core::config::{Node, from_node};
use serde::de::DeserializeOwned;

use crate::base_env::EnvView;
use crate::error::EnvError;
use crate::scene::Scene;

/// What a term builder gets: its parameters, its config field path and the scene.
pub struct TermContext<'a> {
    /// Field path of the term in the config (for errors), e.g. `rewards.distance`.
    pub field: String,
    /// Where the term's config was written (the file of an include or an override too).
    pub at: Option<orbit_core::config::Span>,
    /// The term's `params` node, if given.
    pub params: Option<&'a Node>,
    /// The scene.
    pub scene: &'a Scene,
    /// Physics steps per env step.
    pub decimation: usize,
    /// Env step duration in seconds.
    pub step_dt: f32,
    /// Total action dimension (known to observation, reward and termination terms, which are
    /// built after the action manager; 0 for command, action and event terms).
    pub action_dim: usize,
    /// Action terms and their dimensions (same availability as `action_dim`).
    pub action_terms: Vec<(String, usize)>,
    /// Command terms and their dimensions (known to observation, reward and termination terms).
    pub command_dims: Vec<(String, usize)>,
}

impl TermContext<'_> {
    /// The articulation a term's `params.asset` names.
    pub fn articulation(&self, asset: &str) -> Result<usize, EnvError> {
        (self.scene).articulation(&format!("{}.params.asset", self.field), asset)
    }

    /// Deserialises the parameters (absent parameters give `P::default()`).
    pub fn params<P: DeserializeOwned + Default>(&self) -> Result<P, EnvError> {
        match self.params {
            None => Ok(P::default()),
            Some(node) => from_node(node).map_err(|e| EnvError::InvalidTerm {
                field: format!("{}.params", self.field),
                message: e.to_string(),
            }),
        }
    }

    /// An error about this term, naming the file, line and column of the term's config where
    /// they are known.
    pub fn error(&self, message: impl Into<String>) -> EnvError {
        match &self.at {
            Some(span) => EnvError::Config(orbit_core::config::ConfigError::invalid_at(
                span,
                self.field.clone(),
                message,
            )),
            None => EnvError::InvalidTerm {
                field: self.field.clone(),
                message: message.into(),
            },
        }
    }
}

/// An observation term: writes `num_envs × dim` values.
pub trait ObservationTerm: Send + Sync {
    /// Values per env.
    fn dim(&self) -> usize;
    /// Computes the term for all envs into `out` (row-major, `num_envs × dim`). The manager
    /// may run a step's terms concurrently, so a term depends only on `env` and itself.
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]);
}

/// A reward term: writes one value per env (before weight and `step_dt`).
pub trait RewardTerm: Send + Sync {
    /// Computes the term for all envs. The manager may run a step's terms concurrently, so a
    /// term depends only on `env` and itself.
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]);
    /// Restarts the listed envs' state after their reset events (Isaac Lab's
    /// `ManagerTermBase.reset`), for a term that keeps state across steps.
    fn reset(&mut self, _scene: &Scene, _env_ids: &[usize]) {}
}

/// A termination term: writes one flag per env.
pub trait TerminationTerm: Send + Sync {
    /// Computes the term for all envs.
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [bool]);
}

/// An action term: turns its slice of the policy action into backend inputs.
pub trait ActionTerm: Send + Sync {
    /// Action values per env.
    fn dim(&self) -> usize;
    /// Processes the raw actions (`num_envs × dim`), once per env step.
    fn process(&mut self, scene: &Scene, raw: &[f32]);
    /// Writes targets/efforts to the backend, before every physics step.
    fn apply(&mut self, scene: &mut Scene) -> Result<(), EnvError>;
    /// Whether `apply` writes the same inputs before every physics step of an env step (it
    /// reads no simulation state), so the env may apply once and let the backend run the
    /// `decimation` steps together (`PhysicsBackend::step_n`).
    fn substep_invariant(&self) -> bool {
        false
    }
    /// Clears per-env state of the listed envs.
    fn reset(&mut self, _env_ids: &[usize]) {}
    /// Processed actions, `num_envs × dim` (e.g. the commanded torques).
    fn processed(&self) -> &[f32];
    /// The raw action range of each action value beyond which the term's effect no longer
    /// changes in any state (its clip, or an effort limit divided by the scale); unbounded by
    /// default.
    fn bounds(&self) -> Vec<(f32, f32)> {
        vec![(f32::NEG_INFINITY, f32::INFINITY); self.dim()]
    }
    /// For a term that drives joints directly, how its raw actions map onto them (lets a
    /// tracking controller, such as the black-box wrapper's, turn desired joint values into
    /// actions); `None` for other terms.
    fn joint_map(&self) -> Option<JointActionMap<'_>> {
        None
    }
}

/// What a joint action term drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointActionKind {
    /// Joint position targets of the implicit PD drives.
    Position,
    /// Joint efforts (torques).
    Effort,
}

/// How a joint action term maps raw actions onto joints: for action `k`,
/// `processed = clip(raw) · scales[k] + offsets[k]` drives dof `dofs[k]` of `articulation`.
#[derive(Clone, Copy, Debug)]
pub struct JointActionMap<'a> {
    /// Position targets or efforts.
    pub kind: JointActionKind,
    /// Articulation index in the scene.
    pub articulation: usize,
    /// Dofs of the articulation, one per action value.
    pub dofs: &'a [usize],
    /// Scale of the raw action, per action value.
    pub scales: &'a [f32],
    /// Offset per action value.
    pub offsets: &'a [f32],
    /// Range the raw action is clipped to first, if any.
    pub clip: Option<(f32, f32)>,
}

/// An event term, applied to a set of envs.
pub trait EventTerm: Send + Sync {
    /// Applies the event to the listed envs; `rng` yields each env's random stream.
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        rng: &mut crate::base_env::EnvRngs,
    ) -> Result<(), EnvError>;
}

/// A command term: a per-env command vector resampled on reset and on a timer.
pub trait CommandTerm: Send + Sync {
    /// Command values per env.
    fn dim(&self) -> usize;
    /// The commands, `num_envs × dim`.
    fn command(&self) -> &[f32];
    /// Draws new commands for the listed envs.
    fn resample(&mut self, scene: &Scene, env_ids: &[usize], rng: &mut crate::base_env::EnvRngs);
    /// Recomputes the metrics on the current state (called after rewards, before resets, so
    /// the values logged for a finished episode describe its terminal state).
    fn update_metrics(&mut self, _scene: &Scene) {}
    /// Named per-env metrics, logged at reset as `Metrics/<term>/<name>` (mean over the
    /// resetting envs).
    fn metrics(&self) -> &[(&'static str, Vec<f32>)] {
        &[]
    }
    /// Appends what rendered frames should show of env `env`'s command (Isaac Lab's
    /// `debug_vis`), e.g. a ghost of the object at its target pose.
    fn debug_markers(
        &self,
        _scene: &Scene,
        _env: usize,
        _out: &mut Vec<orbit_core::scene::Marker>,
    ) {
    }
}

macro_rules! registry {
    ($(#[$m:meta])* $def:ident, $term:ident, $kind:literal, $list:ident, $build:ident) => {
        $(#[$m])*
        pub struct $def {
            /// Name used in configs.
            pub name: &'static str,
            /// Builds the term.
            pub build: fn(&TermContext<'_>) -> Result<Box<dyn $term>, EnvError>,
        }
        inventory::collect!($def);

        /// Registered names of this kind, sorted.
        pub fn $list() -> Vec<String> {
            let mut v: Vec<String> = inventory::iter::<$def>.into_iter().map(|d| d.name.to_string()).collect();
            v.sort();
            v
        }

        /// Builds the term registered under `name`.
        pub fn $build(name: &str, ctx: &TermContext<'_>) -> Result<Box<dyn $term>, EnvError> {
            let def = inventory::iter::<$def>
                .into_iter()
                .find(|d| d.name == name)
                .ok_or_else(|| EnvError::UnknownTerm {
                    field: format!("{}.func", ctx.field),
                    kind: $kind,
                    name: name.to_string(),
                    available: $list(),
                })?;
            (def.build)(ctx)
        }
    };
}

registry!(
    /// Registration of an observation term.
    ObservationTermDef, ObservationTerm, "observation", observation_terms, build_observation
);
registry!(
    /// Registration of a reward term.
    RewardTermDef, RewardTerm, "reward", reward_terms, build_reward
);
registry!(
    /// Registration of a termination term.
    TerminationTermDef, TerminationTerm, "termination", termination_terms, build_termination
);
registry!(
    /// Registration of an action term.
    ActionTermDef, ActionTerm, "action", action_terms, build_action
);
registry!(
    /// Registration of an event term.
    EventTermDef, EventTerm, "event", event_terms, build_event
);
registry!(
    /// Registration of a command term.
    CommandTermDef, CommandTerm, "command", command_terms, build_command
);

/// A curriculum term: runs when some envs reset and may change other managers (reward weights).
pub trait CurriculumTerm: Send + Sync {
    /// Updates the curriculum; returns a value to log as `Curriculum/<term>`, if any.
    fn compute(
        &mut self,
        env_ids: &[usize],
        common_step_counter: u64,
        rewards: &mut crate::managers::RewardManager,
    ) -> Result<Option<f32>, EnvError>;
}

registry!(
    /// Registration of a curriculum term.
    CurriculumTermDef, CurriculumTerm, "curriculum", curriculum_terms, build_curriculum
);
