//! Environment configs (Isaac Lab `ManagerBasedEnvCfg` and `ManagerBasedRLEnvCfg`), read from
//! RON. Terms are given by
//! name in ordered maps (`{"joint_pos": (func: "joint_pos_rel"), ...}`); their `params` stay
//! untyped here and are deserialised by each term into its own parameter type.

use std::marker::PhantomData;

use orbit_core::physics::SimCfg;
use orbit_core::scene::{SceneCfg, ViewerCfg};
use serde::de::{Deserializer, IgnoredAny, MapAccess, Visitor};
use serde::{Deserialize, Serialize};

/// Terms in config order (a RON map whose order is kept: it is the concatenation order).
#[derive(Clone, Debug, PartialEq)]
pub struct Terms<T>(pub Vec<(String, T)>);

impl<T> Default for Terms<T> {
    fn default() -> Self {
        Self(Vec::new())
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Terms<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
            type Value = Terms<T>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a map of term names to term configs")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
                let mut out = Vec::new();
                while let Some((k, v)) = map.next_entry::<String, T>()? {
                    out.push((k, v));
                }
                Ok(Terms(out))
            }
        }
        d.deserialize_map(V(PhantomData))
    }
}

/// A term that is a function called with typed parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FuncTermCfg {
    /// Registered term name.
    pub func: String,
    /// Parameters (deserialised by the term).
    #[serde(default)]
    pub params: IgnoredAny,
}

/// A reward term: `value = func(env) * weight * step_dt`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RewardTermCfg {
    /// Registered term name.
    pub func: String,
    /// Parameters.
    #[serde(default)]
    pub params: IgnoredAny,
    /// Weight (0 disables the term).
    pub weight: f32,
}

/// A termination term; `time_out` terms mark truncations rather than terminations.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TerminationTermCfg {
    /// Registered term name.
    pub func: String,
    /// Parameters.
    #[serde(default)]
    pub params: IgnoredAny,
    /// Whether this term is a time-out (truncation).
    #[serde(default)]
    pub time_out: bool,
}

/// Uniform or Gaussian observation noise.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum NoiseCfg {
    /// Adds `U(n_min, n_max)`.
    Uniform {
        /// Lower bound.
        n_min: f32,
        /// Upper bound.
        n_max: f32,
    },
    /// Adds `mean + std · N(0, 1)`.
    Gaussian {
        /// Mean.
        mean: f32,
        /// Standard deviation.
        std: f32,
    },
}

/// An observation term: `func`, then noise, then clip, then scale (Isaac Lab's order).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationTermCfg {
    /// Registered term name.
    pub func: String,
    /// Parameters.
    #[serde(default)]
    pub params: IgnoredAny,
    /// Noise (only applied if the group enables corruption).
    #[serde(default)]
    pub noise: Option<NoiseCfg>,
    /// Clip range.
    #[serde(default)]
    pub clip: Option<(f32, f32)>,
    /// Scale factor.
    #[serde(default)]
    pub scale: Option<f32>,
    /// Number of past values kept and returned oldest to newest (0 = only the current one).
    /// After a reset the first value fills every slot.
    #[serde(default)]
    pub history_length: usize,
}

/// An observation group (`policy`, `critic`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationGroupCfg {
    /// Whether noise terms are applied.
    #[serde(default)]
    pub enable_corruption: bool,
    /// The terms, concatenated in order.
    pub terms: Terms<ObservationTermCfg>,
}

/// An event term (`mode`: `Startup`, `Reset` or `Interval`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventTermCfg {
    /// Registered term name.
    pub func: String,
    /// Parameters.
    #[serde(default)]
    pub params: IgnoredAny,
    /// When the event fires.
    pub mode: EventMode,
    /// For interval events: seconds between firings, drawn uniformly per env.
    #[serde(default)]
    pub interval_range_s: Option<(f32, f32)>,
}

/// When an event term fires.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum EventMode {
    /// Once, after the managers are built.
    Startup,
    /// For every env that resets.
    Reset,
    /// Every `interval_range_s` seconds per env.
    Interval,
}

/// A command term with its resampling time range.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandTermCfg {
    /// Registered term name.
    pub func: String,
    /// Parameters.
    #[serde(default)]
    pub params: IgnoredAny,
    /// Seconds until resampling, drawn uniformly.
    pub resampling_time_range: (f32, f32),
}

/// A manager-based environment config (Isaac Lab `ManagerBasedEnvCfg`): scene, physics,
/// actions, observations, events and (optionally, for observation terms that read them)
/// commands. [`RlEnvCfg`] adds the episode, rewards, terminations and curriculum.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvCfg {
    /// Base seed of every per-env random stream.
    #[serde(default)]
    pub seed: u64,
    /// Number of environments.
    pub num_envs: usize,
    /// Physics steps per env step.
    pub decimation: usize,
    /// Physics settings, including the backend name.
    #[serde(default)]
    pub sim: SimCfg,
    /// The scene: its entities by name, each from a registered asset config
    /// (`"robot": (asset: "franka_panda_rod", …)`, see `orbit_assets::compose_scene`) or
    /// given whole.
    pub scene: SceneCfg,
    /// Action terms (concatenated in order).
    pub actions: Terms<FuncTermCfg>,
    /// Observation groups.
    pub observations: Terms<ObservationGroupCfg>,
    /// Event terms.
    #[serde(default)]
    pub events: Terms<EventTermCfg>,
    /// Command terms.
    #[serde(default)]
    pub commands: Terms<CommandTermCfg>,
    /// The camera of rendered frames and videos (`--video`).
    #[serde(default)]
    pub viewer: ViewerCfg,
}

/// A manager-based RL environment config (Isaac Lab `ManagerBasedRLEnvCfg`): the fields of
/// [`EnvCfg`] plus the episode length, rewards, terminations and curriculum.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RlEnvCfg {
    /// Base seed of every per-env random stream.
    #[serde(default)]
    pub seed: u64,
    /// Number of environments.
    pub num_envs: usize,
    /// Physics steps per env step.
    pub decimation: usize,
    /// Episode length in seconds (`max_episode_length = ceil(T / (dt · decimation) − 1e-4)`, the
    /// small margin absorbing float rounding so 2 s at 20 ms is exactly 100 steps).
    pub episode_length_s: f32,
    /// Physics settings, including the backend name.
    #[serde(default)]
    pub sim: SimCfg,
    /// The scene: its entities by name, each from a registered asset config
    /// (`"robot": (asset: "franka_panda_rod", …)`, see `orbit_assets::compose_scene`) or
    /// given whole.
    pub scene: SceneCfg,
    /// Action terms (concatenated in order).
    pub actions: Terms<FuncTermCfg>,
    /// Observation groups.
    pub observations: Terms<ObservationGroupCfg>,
    /// Reward terms.
    #[serde(default)]
    pub rewards: Terms<RewardTermCfg>,
    /// Termination terms.
    #[serde(default)]
    pub terminations: Terms<TerminationTermCfg>,
    /// Event terms.
    #[serde(default)]
    pub events: Terms<EventTermCfg>,
    /// Command terms.
    #[serde(default)]
    pub commands: Terms<CommandTermCfg>,
    /// Curriculum terms (run when envs reset).
    #[serde(default)]
    pub curriculum: Terms<FuncTermCfg>,
    /// The camera of rendered frames and videos (`--video`).
    #[serde(default)]
    pub viewer: ViewerCfg,
}

impl RlEnvCfg {
    /// The base-environment part of this config.
    pub fn base(&self) -> EnvCfg {
        EnvCfg {
            seed: self.seed,
            num_envs: self.num_envs,
            decimation: self.decimation,
            sim: self.sim.clone(),
            scene: self.scene.clone(),
            actions: self.actions.clone(),
            observations: self.observations.clone(),
            events: self.events.clone(),
            commands: self.commands.clone(),
            viewer: self.viewer.clone(),
        }
    }
}
