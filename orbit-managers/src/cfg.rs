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

/// A manager-based RL environment config (Isaac Lab `ManagerBasedRLEnvCfg`, which extends
/// `ManagerBasedEnvCfg`): the base env's config plus the episode length, rewards, terminations
/// and curriculum. In RON it is one flat struct: the base's fields and these side by side.
#[derive(Clone, Debug)]
pub struct RlEnvCfg {
    /// The base env's config (scene, physics, actions, observations, events, commands).
    pub base: EnvCfg,
    /// Episode length in seconds (`max_episode_length = ceil(T / (dt · decimation) − 1e-4)`, the
    /// small margin absorbing float rounding so 2 s at 20 ms is exactly 100 steps).
    pub episode_length_s: f32,
    /// Reward terms.
    pub rewards: Terms<RewardTermCfg>,
    /// Termination terms.
    pub terminations: Terms<TerminationTermCfg>,
    /// Curriculum terms (run when envs reset).
    pub curriculum: Terms<FuncTermCfg>,
}

/// Every field of an RL env config: [`EnvCfg`]'s, in declaration order, then those
/// [`RlEnvCfg`] adds.
#[rustfmt::skip]
const RL_ENV_FIELDS: &[&str] = &[
    "seed", "num_envs", "decimation", "sim", "scene", "actions", "observations", "events",
    "commands", "viewer",
    "episode_length_s", "rewards", "terminations", "curriculum",
];

/// The fields of [`EnvCfg`], in declaration order.
pub const ENV_FIELDS: &[&str] = RL_ENV_FIELDS.split_at(10).0;

/// The fields [`RlEnvCfg`] adds to [`EnvCfg`].
const RL_FIELDS: &[&str] = RL_ENV_FIELDS.split_at(10).1;

impl<'de> Deserialize<'de> for RlEnvCfg {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_struct("RlEnvCfg", RL_ENV_FIELDS, rl_de::RlEnvCfgVisitor)
    }
}

/// Reading one flat struct into [`RlEnvCfg`]: the base's fields go to [`EnvCfg`]'s own
/// deserialiser, the RL fields are taken out on the way, so unknown fields stay errors at
/// their line.
mod rl_de {
    use serde::de::{self, DeserializeSeed, IntoDeserializer, MapAccess, Visitor};

    use super::*;

    pub(super) struct RlEnvCfgVisitor;

    impl<'de> Visitor<'de> for RlEnvCfgVisitor {
        type Value = RlEnvCfg;

        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("an RL env config struct")
        }

        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<RlEnvCfg, A::Error> {
            let mut rl = RlFields::default();
            let split = SplitMap {
                map: &mut map,
                rl: &mut rl,
            };
            let base = EnvCfg::deserialize(de::value::MapAccessDeserializer::new(split))?;
            Ok(RlEnvCfg {
                base,
                episode_length_s: rl
                    .episode_length_s
                    .ok_or_else(|| de::Error::missing_field("episode_length_s"))?,
                rewards: rl.rewards.unwrap_or_default(),
                terminations: rl.terminations.unwrap_or_default(),
                curriculum: rl.curriculum.unwrap_or_default(),
            })
        }
    }

    #[derive(Default)]
    struct RlFields {
        episode_length_s: Option<f32>,
        rewards: Option<Terms<RewardTermCfg>>,
        terminations: Option<Terms<TerminationTermCfg>>,
        curriculum: Option<Terms<FuncTermCfg>>,
    }

    impl RlFields {
        /// Reads the value of the RL field `field` from `map`.
        fn read<'de, A: MapAccess<'de>>(
            &mut self,
            field: &str,
            map: &mut A,
        ) -> Result<(), A::Error> {
            fn once<T, E: de::Error>(slot: &mut Option<T>, v: T, f: &'static str) -> Result<(), E> {
                match slot.replace(v) {
                    None => Ok(()),
                    Some(_) => Err(E::duplicate_field(f)),
                }
            }
            match field {
                "episode_length_s" => once(
                    &mut self.episode_length_s,
                    map.next_value()?,
                    "episode_length_s",
                ),
                "rewards" => once(&mut self.rewards, map.next_value()?, "rewards"),
                "terminations" => once(&mut self.terminations, map.next_value()?, "terminations"),
                _ => once(&mut self.curriculum, map.next_value()?, "curriculum"),
            }
        }
    }

    /// A field name: an RL field, or a base field as the base's deserialiser reads it.
    enum Key<K> {
        Rl(&'static str),
        Base(K),
    }

    struct KeySeed<'s, K>(&'s mut Option<K>);

    impl<'de, K: DeserializeSeed<'de>> DeserializeSeed<'de> for KeySeed<'_, K> {
        type Value = Key<K::Value>;

        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
            let name = String::deserialize(d)?;
            if let Some(f) = RL_FIELDS.iter().find(|f| **f == name) {
                return Ok(Key::Rl(f));
            }
            if !ENV_FIELDS.contains(&name.as_str()) {
                return Err(de::Error::unknown_field(&name, RL_ENV_FIELDS));
            }
            let seed = self.0.take().expect("a base key is read once per call");
            seed.deserialize(name.into_deserializer()).map(Key::Base)
        }
    }

    /// The map of an RL env config as the base's deserialiser sees it: without the RL fields.
    struct SplitMap<'a, A> {
        map: &'a mut A,
        rl: &'a mut RlFields,
    }

    impl<'de, A: MapAccess<'de>> MapAccess<'de> for SplitMap<'_, A> {
        type Error = A::Error;

        fn next_key_seed<K: DeserializeSeed<'de>>(
            &mut self,
            seed: K,
        ) -> Result<Option<K::Value>, A::Error> {
            let mut seed = Some(seed);
            loop {
                match self.map.next_key_seed(KeySeed(&mut seed))? {
                    None => return Ok(None),
                    Some(Key::Base(key)) => return Ok(Some(key)),
                    Some(Key::Rl(field)) => self.rl.read(field, self.map)?,
                }
            }
        }

        fn next_value_seed<V: DeserializeSeed<'de>>(
            &mut self,
            seed: V,
        ) -> Result<V::Value, A::Error> {
            self.map.next_value_seed(seed)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = "scene: (), actions: {}, observations: {}";

    fn rl(text: &str) -> Result<RlEnvCfg, String> {
        let doc =
            orbit_core::config::parse_document(text, "t.ron", &[]).map_err(|e| e.to_string())?;
        orbit_core::config::from_node(&doc).map_err(|e| e.to_string())
    }

    /// One flat struct fills the base and the RL fields, in any order.
    #[test]
    fn an_rl_env_config_reads_its_base_and_its_own_fields() {
        let cfg = rl(&format!(
            "(episode_length_s: 2.5, num_envs: 3, decimation: 2, rewards: {{\"r\": (func: \"f\", weight: 0.5)}}, {SCENE})"
        ))
        .unwrap();
        assert_eq!(
            (cfg.base.num_envs, cfg.base.decimation, cfg.episode_length_s),
            (3, 2, 2.5)
        );
        assert_eq!(cfg.rewards.0.len(), 1);
        assert!(cfg.terminations.0.is_empty() && cfg.curriculum.0.is_empty());
    }

    /// An unknown field is an error at its line that lists every field; a missing or repeated
    /// RL field is an error too; the list of the base's fields is the base's own.
    #[test]
    fn unknown_missing_and_repeated_fields_are_errors() {
        let e = rl(&format!(
            "(num_envs: 1, decimation: 1,\n rewardz: {{}}, {SCENE})"
        ))
        .unwrap_err();
        assert!(e.starts_with("t.ron:2:"), "{e}");
        assert!(
            e.contains("unknown field `rewardz`") && e.contains("`episode_length_s`"),
            "{e}"
        );
        assert!(e.contains("`viewer`"), "{e}");
        let e = rl(&format!("(num_envs: 1, decimation: 1, {SCENE})")).unwrap_err();
        assert!(e.contains("missing field `episode_length_s`"), "{e}");
        let e = rl(&format!(
            "(episode_length_s: 1.0, num_envs: 1, decimation: 1, episode_length_s: 2.0, {SCENE})"
        ))
        .unwrap_err();
        assert!(e.contains("episode_length_s"), "{e}");
        let doc = orbit_core::config::parse_document("(zzz: 1)", "t.ron", &[]).unwrap();
        let e = orbit_core::config::from_node::<EnvCfg>(&doc)
            .unwrap_err()
            .to_string();
        let listed = ENV_FIELDS
            .iter()
            .map(|f| format!("`{f}`"))
            .collect::<Vec<_>>()
            .join(", ");
        assert!(e.contains(&listed), "{e}\n{listed}");
    }
}
