//! The black-box (episodic) wrapper: Fancy Gym's `BlackBoxWrapper` over a
//! [`ManagerBasedRlEnv`] (`fancy_gym/black_box/black_box_wrapper.py`, with its replanning).
//!
//! The policy picks the parameters of a movement primitive once per episode (or once per
//! replanning segment) from a *context*, a masked observation. One wrapper step turns every
//! env's parameters into a desired joint trajectory and runs it to the end of the segment with
//! a tracking controller, all envs in lockstep; the wrapper's reward is the sum of the step
//! rewards, and the episode statistics (success included) are those of the last step.
//!
//! ```text
//! params [n × P] ─ ProMP / ProDMP ─▶ desired q, q̇ [n × T × dof]
//!   for each env step k of the segment:
//!     action = controller(desired_k, measured q, q̇) ─ env.step ─▶ reward += r_k
//! ```

use std::collections::BTreeMap;

use orbit_core::config::Node;
use orbit_managers::ManagerBasedRlEnv;
use orbit_managers::term::JointActionKind;
use orbit_mp::{ProDmp, ProMp};

mod cfg;
mod generator;

pub use cfg::{BlackBoxCfg, ControllerCfg, ReplanCfg, TrajectoryCfg};
use generator::Generator;

use crate::{VecEnv, VecEnvError, VecEnvStep};

/// The controller with its per-action constants.
enum Controller {
    Pd {
        kp: Vec<f32>,
        kd: Vec<f32>,
        clip: (f32, f32),
    },
    /// `raw = (q_d − offset) / scale` per action value.
    JointPosition { scale: Vec<f32>, offset: Vec<f32> },
}

/// A [`ManagerBasedRlEnv`] driven by movement primitives, as a [`VecEnv`] whose actions are
/// primitive parameters and whose observations are contexts.
pub struct BlackBoxEnv {
    env: ManagerBasedRlEnv,
    generator: Generator,
    controller: Controller,
    /// Per action value: (articulation, dof) it drives.
    joints: Vec<(usize, usize)>,
    /// Observation indices of the context.
    context: Vec<usize>,
    replan: Option<ReplanCfg>,
    /// Plans made and env steps taken in the running episodes (all envs in lockstep).
    plans: u32,
    steps_done: u32,
    segments: u32,
    num_obs: usize,
    obs: Vec<f32>,
    /// The contexts the last finished episodes ended in, when kept.
    final_obs: Option<Vec<f32>>,
    q: Vec<f32>,
    qd: Vec<f32>,
    /// Conditioning state for the next plan (the last executed desired sample).
    q_cond: Vec<f32>,
    v_cond: Vec<f32>,
    desired_pos: Vec<f32>,
    desired_vel: Vec<f32>,
    action: Vec<f32>,
    rewards: Vec<f32>,
    dones: Vec<bool>,
    time_outs: Vec<bool>,
    log: BTreeMap<String, f32>,
    empty_log: BTreeMap<String, f32>,
}

fn invalid(file: &str, field: &str, message: impl Into<String>) -> VecEnvError {
    VecEnvError::InvalidConfig {
        file: file.to_string(),
        field: field.to_string(),
        message: message.into(),
    }
}

/// Fills a primitive's env-given sizes (0 = the env's) and checks given ones against the env.
fn fit_to_env(
    file: &str,
    field: &str,
    num_dof: &mut usize,
    dt: &mut f64,
    num_steps: &mut usize,
    env: &ManagerBasedRlEnv,
) -> Result<(), VecEnvError> {
    let (d, step_dt) = (env.action_dim(), f64::from(env.step_dt()));
    if *num_dof == 0 {
        *num_dof = d;
    } else if *num_dof != d {
        return Err(invalid(
            file,
            &format!("{field}.num_dof"),
            format!("the env has {d} action values; set it to {d} or leave it out"),
        ));
    }
    if *dt == 0.0 {
        *dt = step_dt;
    } else if (*dt - step_dt).abs() > 1e-6 * step_dt {
        return Err(invalid(
            file,
            &format!("{field}.dt"),
            format!("the env steps {step_dt} s; set it to that or leave it out"),
        ));
    }
    if *num_steps == 0 {
        *num_steps = env.max_episode_length() as usize;
    }
    Ok(())
}

impl BlackBoxEnv {
    /// Wraps and resets `env`. `file` names the config in errors.
    pub fn new(
        mut env: ManagerBasedRlEnv,
        cfg: BlackBoxCfg,
        file: &str,
    ) -> Result<Self, VecEnvError> {
        let (n, dof) = (env.num_envs(), env.action_dim());
        // Episodes must end together, by their time-out: the envs run in lockstep.
        if let Some((name, _)) = env.cfg.terminations.0.iter().find(|(_, t)| !t.time_out) {
            return Err(VecEnvError::Mismatch(format!(
                "termination `{name}` can end an episode before its time-out; the black-box \
                 wrapper runs every env's whole episode in lockstep, so only time-out \
                 terminations are supported"
            )));
        }
        // Which joint each action value drives, and how.
        let mut joints = Vec::with_capacity(dof);
        let (mut scale, mut offset) = (Vec::with_capacity(dof), Vec::with_capacity(dof));
        let position_controller = cfg.controller == ControllerCfg::JointPosition;
        for (name, map) in env.actions().joint_maps() {
            let map = map.ok_or_else(|| {
                VecEnvError::Mismatch(format!(
                    "action term `{name}` does not drive joints directly; the black-box \
                     wrapper needs `joint_position` or `joint_effort` actions"
                ))
            })?;
            if position_controller
                && (map.kind != JointActionKind::Position || map.scales.contains(&0.0))
            {
                return Err(invalid(
                    file,
                    "controller",
                    format!(
                        "JointPosition needs `joint_position` action terms with a non-zero \
                         scale; term `{name}` is not one (use Pd)"
                    ),
                ));
            }
            for ((&j, &o), &s) in map.dofs.iter().zip(map.offsets).zip(map.scales) {
                joints.push((map.articulation, j));
                scale.push(s);
                offset.push(o);
            }
        }
        let controller = match cfg.controller {
            ControllerCfg::Pd {
                p_gains,
                d_gains,
                clip,
            } => {
                for (field, g) in [("p_gains", &p_gains), ("d_gains", &d_gains)] {
                    if g.len() != dof || g.iter().any(|v| !v.is_finite()) {
                        return Err(invalid(
                            file,
                            &format!("controller.{field}"),
                            format!("expected {dof} finite gains, one per action value"),
                        ));
                    }
                }
                if !(clip.0.is_finite() && clip.1.is_finite()) || clip.0 >= clip.1 {
                    return Err(invalid(
                        file,
                        "controller.clip",
                        "expected a finite range (low, high) with low < high",
                    ));
                }
                Controller::Pd {
                    kp: p_gains,
                    kd: d_gains,
                    clip,
                }
            }
            ControllerCfg::JointPosition => Controller::JointPosition { scale, offset },
        };
        let generator = match cfg.trajectory {
            TrajectoryCfg::ProMp(mut c) => {
                if cfg.replanning.is_some() {
                    return Err(invalid(
                        file,
                        "replanning",
                        "replanning needs a ProDmp trajectory (a ProMP cannot start from a \
                         given state)",
                    ));
                }
                let f = "trajectory";
                fit_to_env(file, f, &mut c.num_dof, &mut c.dt, &mut c.num_steps, &env)?;
                Generator::ProMp(ProMp::new(c)?)
            }
            TrajectoryCfg::ProDmp(mut c) => {
                let f = "trajectory";
                fit_to_env(file, f, &mut c.num_dof, &mut c.dt, &mut c.num_steps, &env)?;
                Generator::ProDmp(ProDmp::new(c)?)
            }
        };
        let max_len = env.max_episode_length();
        let steps = generator.num_steps();
        let segments = match &cfg.replanning {
            None => 1,
            Some(r) => {
                if r.interval == 0 || r.max_plans == 0 {
                    return Err(invalid(
                        file,
                        "replanning",
                        "interval and max_plans must be at least 1",
                    ));
                }
                r.max_plans.min(max_len.div_ceil(r.interval))
            }
        };
        // Every segment must be covered by its plan's samples.
        let longest = match &cfg.replanning {
            None => max_len,
            Some(r) => max_len - (segments - 1) * r.interval,
        };
        if steps < longest as usize {
            return Err(invalid(
                file,
                "trajectory.num_steps",
                format!("a plan must cover {longest} env steps, it has {steps} samples"),
            ));
        }
        env.reset()?;
        let width = env.observation("policy").map(|(_, w)| w).ok_or_else(|| {
            VecEnvError::Mismatch("the env has no `policy` observation group".into())
        })?;
        let ranges = cfg.context.clone().unwrap_or_else(|| vec![(0, width)]);
        let mut context = Vec::new();
        for &(a, b) in &ranges {
            if a >= b || b > width {
                return Err(invalid(
                    file,
                    "context",
                    format!(
                        "range ({a}, {b}) is not a non-empty range within the {width} \
                         observation values"
                    ),
                ));
            }
            context.extend(a..b);
        }
        // With replanning, the context ends with the episode's progress (Fancy Gym's
        // `TimeAwareObservation`).
        let num_obs = context.len() + usize::from(cfg.replanning.is_some());
        let per_env = steps * dof;
        let mut wrapper = Self {
            generator,
            controller,
            joints,
            context,
            replan: cfg.replanning,
            plans: 0,
            steps_done: 0,
            segments,
            num_obs,
            obs: vec![0.0; n * num_obs],
            final_obs: None,
            q: vec![0.0; n * dof],
            qd: vec![0.0; n * dof],
            q_cond: vec![0.0; n * dof],
            v_cond: vec![0.0; n * dof],
            desired_pos: vec![0.0; n * per_env],
            desired_vel: vec![0.0; n * per_env],
            action: vec![0.0; n * dof],
            rewards: vec![0.0; n],
            dones: vec![false; n],
            time_outs: vec![false; n],
            log: BTreeMap::new(),
            empty_log: BTreeMap::new(),
            env,
        };
        wrapper.update_context();
        Ok(wrapper)
    }

    /// Parses a black-box config (RON with `key.path=value` overrides) and wraps `env`.
    pub fn from_ron(
        env: ManagerBasedRlEnv,
        text: &str,
        file_name: &str,
        overrides: &[String],
    ) -> Result<Self, VecEnvError> {
        let doc = orbit_core::config::parse_document(text, file_name, overrides)?;
        Self::from_document(env, &doc)
    }

    /// Loads a black-box config file (on disk, or bundled: `<bundled>/…`) with `overrides` and
    /// wraps `env`.
    pub fn load(
        env: ManagerBasedRlEnv,
        path: &std::path::Path,
        overrides: &[String],
    ) -> Result<Self, VecEnvError> {
        let doc = orbit_managers::load_config(path, overrides)?;
        Self::from_document(env, &doc)
    }

    /// Wraps `env` with the black-box config document `doc` (a loaded file, includes merged).
    pub fn from_document(env: ManagerBasedRlEnv, doc: &Node) -> Result<Self, VecEnvError> {
        let cfg: BlackBoxCfg = orbit_core::config::from_node(doc)?;
        Self::new(env, cfg, &doc.span.file.display().to_string())
    }

    /// The wrapped env.
    pub fn env(&self) -> &ManagerBasedRlEnv {
        &self.env
    }

    /// The desired joint positions of the last plan, `[num_envs × samples × dof]`.
    pub fn desired_positions(&self) -> &[f32] {
        &self.desired_pos
    }

    /// Segments (wrapper steps) per episode.
    pub fn segments(&self) -> u32 {
        self.segments
    }

    /// Reads the measured joint positions and velocities of the driven joints.
    fn read_joints(&mut self) {
        let dof = self.joints.len();
        for (k, &(art, j)) in self.joints.iter().enumerate() {
            let view = self.env.scene().backend.articulation(art);
            let nd = view.joint_pos.len() / self.env.num_envs();
            for e in 0..self.env.num_envs() {
                self.q[e * dof + k] = view.joint_pos[e * nd + j];
                self.qd[e * dof + k] = view.joint_vel[e * nd + j];
            }
        }
    }

    /// The context of every env from the env's current observation.
    fn update_context(&mut self) {
        let (obs, width) = self.env.observation("policy").expect("checked in new");
        let progress = self.steps_done as f32 / self.env.max_episode_length() as f32;
        let mut out = std::mem::take(&mut self.obs);
        self.write_contexts(obs, width, progress, &mut out);
        self.obs = out;
    }

    /// Each env's context from its `width`-wide row of `obs`, with `progress` when replanning.
    fn write_contexts(&self, obs: &[f32], width: usize, progress: f32, out: &mut [f32]) {
        for (e, out) in out.chunks_exact_mut(self.num_obs).enumerate() {
            let row = &obs[e * width..(e + 1) * width];
            for (o, &i) in out.iter_mut().zip(&self.context) {
                *o = row[i];
            }
            if self.replan.is_some() {
                out[self.context.len()] = progress;
            }
        }
    }

    /// The actions of sample `k` of the plan from the measured state.
    fn compute_actions(&mut self, k: usize) {
        let dof = self.joints.len();
        let samples = self.generator.num_steps();
        for e in 0..self.env.num_envs() {
            let base = (e * samples + k) * dof;
            let (qd_des, vd_des) = (
                &self.desired_pos[base..base + dof],
                &self.desired_vel[base..base + dof],
            );
            let a = &mut self.action[e * dof..(e + 1) * dof];
            match &self.controller {
                Controller::Pd { kp, kd, clip } => {
                    for i in 0..dof {
                        let u = kp[i] * (qd_des[i] - self.q[e * dof + i])
                            + kd[i] * (vd_des[i] - self.qd[e * dof + i]);
                        a[i] = u.clamp(clip.0, clip.1);
                    }
                }
                Controller::JointPosition { scale, offset } => {
                    for i in 0..dof {
                        a[i] = (qd_des[i] - offset[i]) / scale[i];
                    }
                }
            }
        }
    }
}

impl VecEnv for BlackBoxEnv {
    fn num_envs(&self) -> usize {
        self.env.num_envs()
    }

    fn num_actions(&self) -> usize {
        self.generator.num_params()
    }

    fn num_obs(&self) -> usize {
        self.num_obs
    }

    fn num_critic_obs(&self) -> usize {
        self.num_obs
    }

    fn max_episode_length(&self) -> u32 {
        self.segments
    }

    fn observations(&self) -> &[f32] {
        &self.obs
    }

    fn critic_observations(&self) -> &[f32] {
        &self.obs
    }

    fn keep_final_observations(&mut self, keep: bool) {
        self.env.keep_final_observations(keep);
        self.final_obs = keep.then(|| vec![0.0; self.obs.len()]);
    }

    fn final_observations(&self) -> Option<&[f32]> {
        self.final_obs.as_deref()
    }

    fn final_critic_observations(&self) -> Option<&[f32]> {
        self.final_obs.as_deref()
    }

    /// Runs one segment (the whole episode without replanning) of every env's trajectory.
    fn step(&mut self, params: &[f32]) -> Result<VecEnvStep<'_>, VecEnvError> {
        let (n, dof) = (self.env.num_envs(), self.joints.len());
        let max_len = self.env.max_episode_length();
        if let Some(e) = self
            .env
            .episode_length()
            .iter()
            .position(|&l| l != self.steps_done)
        {
            return Err(VecEnvError::Mismatch(format!(
                "env {e} is at step {} of its episode, the others at {}; black-box envs run \
                 in lockstep (do not step the wrapped env directly)",
                self.env.episode_length()[e],
                self.steps_done
            )));
        }
        self.read_joints();
        let conditioned =
            self.plans > 0 && self.replan.as_ref().is_some_and(|r| r.condition_on_desired);
        let (q0, v0) = if conditioned {
            (&self.q_cond, &self.v_cond)
        } else {
            (&self.q, &self.qd)
        };
        let t0 = f64::from(self.steps_done) * f64::from(self.env.step_dt());
        self.generator.generate(
            t0,
            params,
            q0,
            v0,
            &mut self.desired_pos,
            &mut self.desired_vel,
        )?;
        let last_segment = self.plans + 1 >= self.segments;
        let length = match &self.replan {
            Some(r) if !last_segment => r.interval,
            _ => max_len - self.steps_done,
        } as usize;
        self.rewards.fill(0.0);
        for k in 0..length {
            if k > 0 {
                self.read_joints();
            }
            self.compute_actions(k);
            let r = self.env.step(&self.action)?;
            for (sum, &x) in self.rewards.iter_mut().zip(r.reward) {
                *sum += x;
            }
            let episode_end = last_segment && k + 1 == length;
            let ended = |e: usize| r.terminated[e] || r.time_outs[e];
            if let Some(e) = (0..n).find(|&e| ended(e) != episode_end) {
                return Err(VecEnvError::Mismatch(format!(
                    "env {e} {} its episode at step {} of {max_len}; the black-box wrapper \
                     needs every episode to end by its time-out",
                    if episode_end { "did not end" } else { "ended" },
                    self.steps_done as usize + k + 1
                )));
            }
            if episode_end {
                self.log.clone_from(&r.extras.log);
                if let Some(mut out) = self.final_obs.take() {
                    let (obs, width) = self.env.final_observation("policy").expect("kept");
                    self.write_contexts(obs, width, 1.0, &mut out);
                    self.final_obs = Some(out);
                }
            }
        }
        // The next plan starts from the last executed desired sample.
        let samples = self.generator.num_steps();
        for e in 0..n {
            let src = (e * samples + length - 1) * dof;
            self.q_cond[e * dof..(e + 1) * dof].copy_from_slice(&self.desired_pos[src..src + dof]);
            self.v_cond[e * dof..(e + 1) * dof].copy_from_slice(&self.desired_vel[src..src + dof]);
        }
        self.plans += 1;
        self.steps_done += length as u32;
        if last_segment {
            self.plans = 0;
            self.steps_done = 0;
        }
        self.dones.fill(last_segment);
        // The episode really ends: nothing follows it to bootstrap from.
        self.time_outs.fill(false);
        self.update_context();
        Ok(VecEnvStep {
            rewards: &self.rewards,
            dones: &self.dones,
            terminated: &self.dones,
            time_outs: &self.time_outs,
            log: if last_segment {
                &self.log
            } else {
                &self.empty_log
            },
            interactions: length as u32,
        })
    }

    fn reset(&mut self) -> Result<(), VecEnvError> {
        self.env.reset()?;
        self.plans = 0;
        self.steps_done = 0;
        self.dones.fill(false);
        self.update_context();
        Ok(())
    }

    fn randomize_episode_lengths(&mut self, _seed: u64) -> Result<(), VecEnvError> {
        Err(VecEnvError::Mismatch(
            "black-box envs run their episodes in lockstep; set `init_at_random_ep_len: false` \
             in the runner config"
                .into(),
        ))
    }

    fn step_timings(&self) -> Option<orbit_managers::StepTimings> {
        Some(*self.env.timings())
    }
}
