//! The allowed range of each number of an env config, checked when the env is built: a value
//! outside it is an error naming the file, line, field, value and range, where it would
//! otherwise hang a run (a million-step episode of a microsecond step) or quietly simulate
//! something else.

use std::fmt::Display;

use orbit_core::config::{ConfigError, Node, node_at};

use crate::EnvError;
use crate::cfg::{EnvCfg, NoiseCfg};

/// Most envs one env config may ask for (2²⁴): beyond any GPU's memory for the smallest scene.
pub const MAX_ENVS: usize = 1 << 24;
/// Most physics steps per env step.
pub const MAX_DECIMATION: usize = 1000;
/// The physics step's range in seconds: below a microsecond an episode needs billions of
/// steps; above a second no integrator in either backend stays stable.
pub const DT_RANGE: (f32, f32) = (1e-6, 1.0);
/// Most solver iterations per physics step (0 is the backend's default).
pub const MAX_SOLVER_ITERATIONS: usize = 1000;
/// Largest gravity component (m/s²): a hundred times the Earth's.
pub const MAX_GRAVITY: f32 = 1000.0;
/// Longest episode, command period or event interval (seconds, about 11.6 days).
pub const MAX_DURATION_S: f32 = 1e6;
/// Most past values an observation term keeps.
pub const MAX_HISTORY: usize = 1000;
/// Largest distance of an initial position or the env spacing from the origin (metres).
pub const MAX_POSITION_M: f32 = 1e4;

/// Checks an env config's numbers against their ranges (`doc` locates the errors).
pub(crate) fn check_env_cfg(doc: &Node, cfg: &EnvCfg) -> Result<(), EnvError> {
    let r = Ranges { doc };
    r.within("num_envs", cfg.num_envs, 1, MAX_ENVS, "envs")?;
    r.within(
        "decimation",
        cfg.decimation,
        1,
        MAX_DECIMATION,
        "physics steps per env step",
    )?;
    r.within("sim.dt", cfg.sim.dt, DT_RANGE.0, DT_RANGE.1, "seconds")?;
    r.within(
        "sim.solver_iterations",
        cfg.sim.solver_iterations,
        0,
        MAX_SOLVER_ITERATIONS,
        "iterations (0: the backend's default)",
    )?;
    for g in cfg.sim.gravity.to_array() {
        r.within("sim.gravity", g, -MAX_GRAVITY, MAX_GRAVITY, "m/s² per axis")?;
    }
    r.within(
        "scene.env_spacing",
        cfg.scene.env_spacing,
        0.0,
        MAX_POSITION_M,
        "metres",
    )?;
    let scene = &cfg.scene;
    let field = |kind: &str, i: usize| format!("scene.{kind}[{i}].init_state.pos");
    let roots = (scene.articulations.iter().enumerate())
        .map(|(i, a)| (field("articulations", i), a.init_state.pos))
        .chain(
            (scene.rigid_objects.iter().enumerate())
                .map(|(i, o)| (field("rigid_objects", i), o.init_state.pos)),
        );
    for (field, pos) in roots {
        for x in pos.to_array() {
            let m = MAX_POSITION_M;
            r.within(&field, x, -m, m, "metres per axis")?;
        }
    }
    for (group, g) in &cfg.observations.0 {
        for (name, t) in &g.terms.0 {
            let at = format!("observations[{group:?}].terms[{name:?}]");
            let field = format!("{at}.history_length");
            r.within(&field, t.history_length, 0, MAX_HISTORY, "past values")?;
            if let Some(scale) = t.scale {
                r.finite(&format!("{at}.scale"), scale)?;
            }
            if let Some((lo, hi)) = t.clip {
                r.ordered(
                    &format!("{at}.clip"),
                    lo,
                    hi,
                    f32::NEG_INFINITY,
                    f32::INFINITY,
                )?;
            }
            match t.noise {
                Some(NoiseCfg::Uniform { n_min, n_max }) => {
                    let field = format!("{at}.noise");
                    r.ordered(&field, n_min, n_max, f32::MIN, f32::MAX)?;
                }
                Some(NoiseCfg::Gaussian { mean, std }) => {
                    r.finite(&format!("{at}.noise.mean"), mean)?;
                    r.within(&format!("{at}.noise.std"), std, 0.0, f32::MAX, "")?;
                }
                None => {}
            }
        }
    }
    for (name, e) in &cfg.events.0 {
        if let Some((lo, hi)) = e.interval_range_s {
            let field = format!("events[{name:?}].interval_range_s");
            r.ordered(&field, lo, hi, f32::MIN_POSITIVE, MAX_DURATION_S)?;
        }
    }
    for (name, c) in &cfg.commands.0 {
        let (lo, hi) = c.resampling_time_range;
        let field = format!("commands[{name:?}].resampling_time_range");
        r.ordered(&field, lo, hi, f32::MIN_POSITIVE, MAX_DURATION_S)?;
    }
    Ok(())
}

/// Checks an episode's length against the env step (`step_dt` seconds): at least one step.
pub(crate) fn check_episode_length(
    doc: &Node,
    episode_length_s: f32,
    step_dt: f32,
) -> Result<(), EnvError> {
    let why = format!("seconds: at least one env step of {step_dt} s (sim.dt × decimation)");
    Ranges { doc }.within(
        "episode_length_s",
        episode_length_s,
        step_dt,
        MAX_DURATION_S,
        &why,
    )
}

/// Range checks located in one document.
struct Ranges<'a> {
    doc: &'a Node,
}

impl Ranges<'_> {
    /// An error at the node of `field` (the document's start for a default value).
    fn error(&self, field: &str, message: String) -> EnvError {
        let span = node_at(self.doc, field).map_or(&self.doc.span, |n| &n.span);
        EnvError::Config(ConfigError::invalid_at(span, field, message))
    }

    /// `lo <= value <= hi` (NaN fails), `unit` naming what is counted.
    fn within<T: PartialOrd + Display>(
        &self,
        field: &str,
        value: T,
        lo: T,
        hi: T,
        unit: &str,
    ) -> Result<(), EnvError> {
        if lo <= value && value <= hi {
            return Ok(());
        }
        let unit = if unit.is_empty() {
            String::new()
        } else {
            format!(" {unit}")
        };
        Err(self.error(
            field,
            format!("{value} is out of range: expected {lo} to {hi}{unit}"),
        ))
    }

    /// A finite number.
    fn finite(&self, field: &str, value: f32) -> Result<(), EnvError> {
        self.within(field, value, f32::MIN, f32::MAX, "(a finite number)")
    }

    /// A range `(lo, hi)` with `lo <= hi`, both within `[min, max]`.
    fn ordered(&self, field: &str, lo: f32, hi: f32, min: f32, max: f32) -> Result<(), EnvError> {
        if min <= lo && lo <= hi && hi <= max {
            return Ok(());
        }
        Err(self.error(
            field,
            format!("({lo}, {hi}) is out of range: expected (low, high) with {min} <= low <= high <= {max}"),
        ))
    }
}
