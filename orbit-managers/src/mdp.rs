//! Built-in terms (Isaac Lab's generic `mdp` functions), registered by name.

use glam::{Quat, Vec3};
use serde::Deserialize;

use crate::env::{EnvRngs, EnvView};
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::*;

fn robot() -> String {
    "robot".into()
}
fn all_joints() -> Vec<String> {
    vec![".*".into()]
}

/// An articulation and a joint selection (Isaac Lab `SceneEntityCfg`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointsParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes (full match).
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
}

impl Default for JointsParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
        }
    }
}

/// Resolved articulation + dof indices.
pub struct JointSel {
    /// Articulation index.
    pub articulation: usize,
    /// Selected dofs.
    pub dofs: Vec<usize>,
    /// Dofs of the articulation.
    pub num_dofs: usize,
}

impl JointSel {
    /// Resolves a joint selection for a term.
    pub fn resolve(ctx: &TermContext<'_>, p: &JointsParams) -> Result<Self, EnvError> {
        let articulation = ctx
            .scene
            .articulation(&format!("{}.params.asset", ctx.field), &p.asset)?;
        let dofs = ctx.scene.joints(
            &format!("{}.params.joint_names", ctx.field),
            articulation,
            &p.joint_names,
        )?;
        let num_dofs = ctx.scene.backend.layout().articulations[articulation].num_dofs();
        Ok(Self {
            articulation,
            dofs,
            num_dofs,
        })
    }
}

impl JointSel {
    /// Writes the backend's bias forces of the selected joints (zero elsewhere) into `buf`
    /// (`num_envs × num_dofs`) and applies them as feed-forward efforts: gravity and Coriolis
    /// compensation beside position targets.
    pub fn apply_bias_feed_forward(
        &self,
        scene: &mut Scene,
        buf: &mut [f32],
    ) -> Result<(), EnvError> {
        let n = self.num_dofs;
        let bias = scene.backend.articulation(self.articulation).bias_forces;
        buf.fill(0.0);
        for e in 0..scene.num_envs() {
            for &j in &self.dofs {
                buf[e * n + j] = bias[e * n + j];
            }
        }
        scene.backend.set_joint_efforts(self.articulation, buf)?;
        Ok(())
    }
}

/// `joint_pos_rel` / `joint_vel_rel`: selected joint positions or velocities minus defaults.
struct JointRel {
    sel: JointSel,
    default: Vec<f32>,
    velocity: bool,
}

impl ObservationTerm for JointRel {
    fn dim(&self) -> usize {
        self.sel.dofs.len()
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let view = env.scene.backend.articulation(self.sel.articulation);
        let src = if self.velocity {
            view.joint_vel
        } else {
            view.joint_pos
        };
        let (n, d) = (self.sel.num_dofs, self.dim());
        for (e, row) in out.chunks_exact_mut(d).enumerate() {
            for (k, &j) in self.sel.dofs.iter().enumerate() {
                row[k] = src[e * n + j] - self.default[j];
            }
        }
    }
}

fn joint_rel(ctx: &TermContext<'_>, velocity: bool) -> Result<Box<dyn ObservationTerm>, EnvError> {
    let sel = JointSel::resolve(ctx, &ctx.params()?)?;
    let a = &ctx.scene.desc.articulations[sel.articulation];
    let default = if velocity {
        a.default_joint_vel.clone()
    } else {
        a.default_joint_pos.clone()
    };
    Ok(Box::new(JointRel {
        sel,
        default,
        velocity,
    }))
}

inventory::submit! { ObservationTermDef { name: "joint_pos_rel", build: |c| joint_rel(c, false) } }
inventory::submit! { ObservationTermDef { name: "joint_vel_rel", build: |c| joint_rel(c, true) } }

/// `joint_pos` / `joint_vel`: absolute joint state (a `JointRel` with zero defaults).
fn joint_abs(ctx: &TermContext<'_>, velocity: bool) -> Result<Box<dyn ObservationTerm>, EnvError> {
    let sel = JointSel::resolve(ctx, &ctx.params()?)?;
    let default = vec![0.0; sel.num_dofs];
    Ok(Box::new(JointRel {
        sel,
        default,
        velocity,
    }))
}

inventory::submit! { ObservationTermDef { name: "joint_pos", build: |c| joint_abs(c, false) } }
inventory::submit! { ObservationTermDef { name: "joint_vel", build: |c| joint_abs(c, true) } }

/// `last_action`: the policy action of the last step (zero after reset).
struct LastAction(usize);

impl ObservationTerm for LastAction {
    fn dim(&self) -> usize {
        self.0
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        out.copy_from_slice(env.action);
    }
}

/// Parameters naming a command term.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandParams {
    /// Command term name.
    pub command_name: String,
}

/// `generated_commands`: the command vector of a command term.
struct GeneratedCommands {
    name: String,
    dim: usize,
}

impl ObservationTerm for GeneratedCommands {
    fn dim(&self) -> usize {
        self.dim
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let (cmd, _) = env
            .commands
            .command(&self.name)
            .expect("resolved at construction");
        out.copy_from_slice(cmd);
    }
}

/// Parameters naming a rigid object.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectParams {
    /// Rigid-object name.
    pub asset: String,
}

impl Default for ObjectParams {
    fn default() -> Self {
        Self {
            asset: "object".into(),
        }
    }
}

/// `root_pos` / `root_quat`: a rigid object's position (env frame) or orientation `(w,x,y,z)`.
struct RootPose {
    object: usize,
    quat: bool,
}

impl ObservationTerm for RootPose {
    fn dim(&self) -> usize {
        if self.quat { 4 } else { 3 }
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let view = env.scene.backend.rigid_object(self.object);
        let d = self.dim();
        for (e, row) in out.chunks_exact_mut(d).enumerate() {
            if self.quat {
                row.copy_from_slice(&orbit_core::math::to_wxyz(view.quat[e]));
            } else {
                row.copy_from_slice(&view.pos[e].to_array());
            }
        }
    }
}

fn root_pose(ctx: &TermContext<'_>, quat: bool) -> Result<Box<dyn ObservationTerm>, EnvError> {
    let p: ObjectParams = ctx.params()?;
    let object = ctx
        .scene
        .rigid_object(&format!("{}.params.asset", ctx.field), &p.asset)?;
    Ok(Box::new(RootPose { object, quat }))
}

inventory::submit! { ObservationTermDef { name: "root_pos", build: |c| root_pose(c, false) } }
inventory::submit! { ObservationTermDef { name: "root_quat", build: |c| root_pose(c, true) } }

inventory::submit! { ObservationTermDef { name: "last_action", build: |c| Ok(Box::new(LastAction(c.action_dim))) } }

inventory::submit! { ObservationTermDef { name: "generated_commands", build: |c| {
    let p: CommandParams = c.params()?;
    let dim = c
        .command_dims
        .iter()
        .find(|(n, _)| *n == p.command_name)
        .map(|(_, d)| *d)
        .ok_or_else(|| c.error(format!(
            "no command term named `{}`; commands: {:?}",
            p.command_name,
            c.command_dims.iter().map(|(n, _)| n).collect::<Vec<_>>()
        )))?;
    Ok(Box::new(GeneratedCommands { name: p.command_name, dim }))
} } }

/// `action_rate_l2`: `Σ (a − a_prev)²`.
struct ActionRate;

impl RewardTerm for ActionRate {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let d = env.action_dim;
        for (e, o) in out.iter_mut().enumerate() {
            *o = (0..d)
                .map(|i| (env.action[e * d + i] - env.prev_action[e * d + i]).powi(2))
                .sum();
        }
    }
}

inventory::submit! { RewardTermDef { name: "action_rate_l2", build: |_| Ok(Box::new(ActionRate)) } }

/// `joint_vel_l2`: `Σ q̇²` over selected joints.
struct JointVelL2(JointSel);

impl RewardTerm for JointVelL2 {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let v = env
            .scene
            .backend
            .articulation(self.0.articulation)
            .joint_vel;
        for (e, o) in out.iter_mut().enumerate() {
            *o = self
                .0
                .dofs
                .iter()
                .map(|&j| v[e * self.0.num_dofs + j].powi(2))
                .sum();
        }
    }
}

inventory::submit! { RewardTermDef { name: "joint_vel_l2", build: |c| Ok(Box::new(JointVelL2(JointSel::resolve(c, &c.params()?)?))) } }

/// `time_out`: the episode has lasted `max_episode_length` steps.
struct TimeOut;

impl TerminationTerm for TimeOut {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [bool]) {
        for (o, &l) in out.iter_mut().zip(env.episode_length) {
            *o = l >= env.max_episode_length;
        }
    }
}

inventory::submit! { TerminationTermDef { name: "time_out", build: |_| Ok(Box::new(TimeOut)) } }

/// `reset_scene_to_default`: default joint state of every articulation and default root state
/// of every rigid object.
struct ResetSceneToDefault;

impl EventTerm for ResetSceneToDefault {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        _rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        for a in 0..scene.desc.articulations.len() {
            let desc = &scene.desc.articulations[a];
            let pos = desc.default_joint_pos.repeat(env_ids.len());
            let vel = desc.default_joint_vel.repeat(env_ids.len());
            scene.backend.write_joint_state(a, env_ids, &pos, &vel)?;
        }
        for o in 0..scene.desc.rigid_objects.len() {
            let states = vec![scene.desc.rigid_objects[o].default_root_state; env_ids.len()];
            scene.backend.write_root_state(o, env_ids, &states)?;
        }
        Ok(())
    }
}

inventory::submit! { EventTermDef { name: "reset_scene_to_default", build: |_| Ok(Box::new(ResetSceneToDefault)) } }

/// Parameters of `reset_root_state_uniform`: offsets added to the default root state.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetRootParams {
    /// Rigid-object name.
    pub asset: String,
    /// Position offset ranges `(x, y, z)` as `((lo, hi), (lo, hi), (lo, hi))`.
    #[serde(default)]
    pub pos_range: [(f32, f32); 3],
    /// Yaw offset range (rad).
    #[serde(default)]
    pub yaw_range: (f32, f32),
    /// Linear velocity offset ranges `(x, y, z)` added to the default velocity (m/s).
    #[serde(default)]
    pub lin_vel_range: [(f32, f32); 3],
}

/// `reset_root_state_uniform`: default root state plus uniform position, yaw and linear
/// velocity offsets.
struct ResetRootUniform {
    object: usize,
    p: ResetRootParams,
}

impl EventTerm for ResetRootUniform {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        let default = scene.desc.rigid_objects[self.object].default_root_state;
        let states: Vec<_> = env_ids
            .iter()
            .map(|&e| {
                let r = rng.get(e);
                let mut s = default;
                let off = Vec3::new(
                    r.uniform_range(self.p.pos_range[0].0, self.p.pos_range[0].1),
                    r.uniform_range(self.p.pos_range[1].0, self.p.pos_range[1].1),
                    r.uniform_range(self.p.pos_range[2].0, self.p.pos_range[2].1),
                );
                let yaw = r.uniform_range(self.p.yaw_range.0, self.p.yaw_range.1);
                let [vx, vy, vz] = self.p.lin_vel_range;
                s.lin_vel += Vec3::new(
                    r.uniform_range(vx.0, vx.1),
                    r.uniform_range(vy.0, vy.1),
                    r.uniform_range(vz.0, vz.1),
                );
                s.pose.pos += off;
                s.pose.rot = (Quat::from_rotation_z(yaw) * s.pose.rot).normalize();
                s
            })
            .collect();
        scene
            .backend
            .write_root_state(self.object, env_ids, &states)?;
        Ok(())
    }
}

inventory::submit! { EventTermDef { name: "reset_root_state_uniform", build: |c| {
    let p: ResetRootParams = c.params()?;
    let object = c.scene.rigid_object(&format!("{}.params.asset", c.field), &p.asset)?;
    Ok(Box::new(ResetRootUniform { object, p }))
} } }

/// Parameters of joint actions: `processed = raw · scale + offset`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointActionParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes.
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
    /// Scale.
    #[serde(default = "one")]
    pub scale: f32,
    /// Offset.
    #[serde(default)]
    pub offset: f32,
    /// Position actions: use the default joint positions as offset.
    #[serde(default)]
    pub use_default_offset: bool,
    /// Raw actions are clipped to this range first (Fancy Gym clips to `[-1, 1]`).
    #[serde(default)]
    pub clip: Option<(f32, f32)>,
    /// Add the backend's bias forces (gravity + Coriolis compensation) as effort: on top of the
    /// processed torque for effort actions (Fancy Gym's torque controller), as a feed-forward
    /// effort beside the targets for position actions.
    #[serde(default)]
    pub compensate_bias: bool,
    /// Effort actions: clip the final effort per joint (Fancy Gym's `q_torque_max`).
    #[serde(default)]
    pub effort_clip: Option<Vec<f32>>,
}

fn one() -> f32 {
    1.0
}

impl Default for JointActionParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
            scale: 1.0,
            offset: 0.0,
            use_default_offset: false,
            clip: None,
            compensate_bias: false,
            effort_clip: None,
        }
    }
}

#[derive(Clone, Copy, PartialEq)]
enum JointActionKind {
    Position,
    Effort,
}

/// `joint_position` and `joint_effort` actions.
struct JointAction {
    kind: JointActionKind,
    sel: JointSel,
    p: JointActionParams,
    offsets: Vec<f32>,
    processed: Vec<f32>,
    /// Full `num_envs × num_dofs` target/effort buffer.
    full: Vec<f32>,
    /// Feed-forward bias efforts of position actions.
    feed_forward: Vec<f32>,
}

impl ActionTerm for JointAction {
    fn dim(&self) -> usize {
        self.sel.dofs.len()
    }

    fn process(&mut self, _scene: &Scene, raw: &[f32]) {
        let d = self.dim();
        for (i, (out, &a)) in self.processed.iter_mut().zip(raw).enumerate() {
            let a = match self.p.clip {
                Some((lo, hi)) => a.clamp(lo, hi),
                None => a,
            };
            *out = a * self.p.scale + self.offsets[i % d];
        }
    }

    fn apply(&mut self, scene: &mut Scene) -> Result<(), EnvError> {
        let (n, d) = (self.sel.num_dofs, self.dim());
        let view = scene.backend.articulation(self.sel.articulation);
        for e in 0..scene.num_envs() {
            for (k, &j) in self.sel.dofs.iter().enumerate() {
                let mut v = self.processed[e * d + k];
                if self.kind == JointActionKind::Effort {
                    if self.p.compensate_bias {
                        v += view.bias_forces[e * n + j];
                    }
                    if let Some(lim) = &self.p.effort_clip {
                        v = v.clamp(-lim[k], lim[k]);
                    }
                }
                self.full[e * n + j] = v;
            }
        }
        match self.kind {
            JointActionKind::Position => {
                scene
                    .backend
                    .set_joint_position_targets(self.sel.articulation, &self.full)?;
                if self.p.compensate_bias {
                    self.sel
                        .apply_bias_feed_forward(scene, &mut self.feed_forward)?;
                }
            }
            JointActionKind::Effort => scene
                .backend
                .set_joint_efforts(self.sel.articulation, &self.full)?,
        }
        Ok(())
    }

    fn processed(&self) -> &[f32] {
        &self.processed
    }
}

fn joint_action(
    ctx: &TermContext<'_>,
    kind: JointActionKind,
) -> Result<Box<dyn ActionTerm>, EnvError> {
    let p: JointActionParams = ctx.params()?;
    let sel = JointSel::resolve(
        ctx,
        &JointsParams {
            asset: p.asset.clone(),
            joint_names: p.joint_names.clone(),
        },
    )?;
    let d = sel.dofs.len();
    if let Some(lim) = &p.effort_clip
        && lim.len() != d
    {
        return Err(ctx.error(format!(
            "effort_clip has {} values for {d} joints",
            lim.len()
        )));
    }
    let defaults = &ctx.scene.desc.articulations[sel.articulation].default_joint_pos;
    let offsets = sel
        .dofs
        .iter()
        .map(|&j| {
            if p.use_default_offset {
                defaults[j]
            } else {
                p.offset
            }
        })
        .collect();
    let n = ctx.scene.num_envs();
    // Joints outside the selection keep their default targets (position) or zero effort.
    let full = match kind {
        JointActionKind::Position => defaults.repeat(n),
        JointActionKind::Effort => vec![0.0; n * sel.num_dofs],
    };
    Ok(Box::new(JointAction {
        kind,
        feed_forward: vec![0.0; full.len()],
        full,
        processed: vec![0.0; n * d],
        sel,
        p,
        offsets,
    }))
}

inventory::submit! { ActionTermDef { name: "joint_position", build: |c| joint_action(c, JointActionKind::Position) } }
inventory::submit! { ActionTermDef { name: "joint_effort", build: |c| joint_action(c, JointActionKind::Effort) } }

/// Parameters of `reset_joints_by_offset` / `reset_joints_by_scale`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResetJointsParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes.
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
    /// Range added to (offset) or multiplied with (scale) the default positions.
    pub position_range: (f32, f32),
    /// Range added to or multiplied with the default velocities.
    #[serde(default)]
    pub velocity_range: (f32, f32),
}

impl Default for ResetJointsParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
            position_range: (0.0, 0.0),
            velocity_range: (0.0, 0.0),
        }
    }
}

/// `reset_joints_by_offset` / `_by_scale`: default joint state plus (or times) uniform noise,
/// positions clamped to the joint limits; unselected joints get their defaults.
struct ResetJoints {
    sel: JointSel,
    p: ResetJointsParams,
    scale: bool,
    limits: Vec<[f32; 2]>,
}

impl EventTerm for ResetJoints {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        let desc = &scene.desc.articulations[self.sel.articulation];
        let n = self.sel.num_dofs;
        let mut pos = desc.default_joint_pos.repeat(env_ids.len());
        let mut vel = desc.default_joint_vel.repeat(env_ids.len());
        for (i, &e) in env_ids.iter().enumerate() {
            let r = rng.get(e);
            for &j in &self.sel.dofs {
                let (dp, dv) = (
                    r.uniform_range(self.p.position_range.0, self.p.position_range.1),
                    r.uniform_range(self.p.velocity_range.0, self.p.velocity_range.1),
                );
                let (q, v) = (&mut pos[i * n + j], &mut vel[i * n + j]);
                if self.scale {
                    *q *= dp;
                    *v *= dv;
                } else {
                    *q += dp;
                    *v += dv;
                }
                *q = q.clamp(self.limits[j][0], self.limits[j][1]);
            }
        }
        scene
            .backend
            .write_joint_state(self.sel.articulation, env_ids, &pos, &vel)?;
        Ok(())
    }
}

fn reset_joints(ctx: &TermContext<'_>, scale: bool) -> Result<Box<dyn EventTerm>, EnvError> {
    let p: ResetJointsParams = ctx.params()?;
    for (name, (lo, hi)) in [
        ("position_range", p.position_range),
        ("velocity_range", p.velocity_range),
    ] {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(ctx.error(format!(
                "params.{name} must be a finite (lo, hi) with lo <= hi, got ({lo}, {hi})"
            )));
        }
    }
    let sel = JointSel::resolve(
        ctx,
        &JointsParams {
            asset: p.asset.clone(),
            joint_names: p.joint_names.clone(),
        },
    )?;
    let model = &ctx.scene.desc.articulations[sel.articulation].model;
    let limits = model
        .dof_links()
        .into_iter()
        .map(|l| {
            model.links[l]
                .joint
                .as_ref()
                .and_then(|j| j.limits)
                .unwrap_or([f32::MIN, f32::MAX])
        })
        .collect();
    Ok(Box::new(ResetJoints {
        sel,
        p,
        scale,
        limits,
    }))
}

inventory::submit! { EventTermDef { name: "reset_joints_by_offset", build: |c| reset_joints(c, false) } }
inventory::submit! { EventTermDef { name: "reset_joints_by_scale", build: |c| reset_joints(c, true) } }

/// Parameters of `object_position_in_robot_root_frame`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectInRobotParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub robot: String,
    /// Rigid-object name.
    pub object: String,
}

impl Default for ObjectInRobotParams {
    fn default() -> Self {
        Self {
            robot: robot(),
            object: "object".into(),
        }
    }
}

/// `object_position_in_robot_root_frame`: the object's position in the robot's root frame.
struct ObjectInRobot {
    robot: usize,
    object: usize,
}

impl ObservationTerm for ObjectInRobot {
    fn dim(&self) -> usize {
        3
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let robot = env.scene.backend.articulation(self.robot);
        let object = env.scene.backend.rigid_object(self.object);
        for (e, row) in out.chunks_exact_mut(3).enumerate() {
            let root = robot.link_pose(e, 0);
            row.copy_from_slice(&root.inverse().transform_point(object.pos[e]).to_array());
        }
    }
}

inventory::submit! { ObservationTermDef { name: "object_position_in_robot_root_frame", build: |c| {
    let p: ObjectInRobotParams = c.params()?;
    let robot = c.scene.articulation(&format!("{}.params.robot", c.field), &p.robot)?;
    let object = c.scene.rigid_object(&format!("{}.params.object", c.field), &p.object)?;
    Ok(Box::new(ObjectInRobot { robot, object }))
} } }

/// Parameters of `modify_reward_weight`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModifyRewardWeightParams {
    /// Reward term to change.
    pub term_name: String,
    /// Its new weight.
    pub weight: f32,
    /// Env steps (the common step counter) after which the weight applies.
    pub num_steps: u64,
}

/// `modify_reward_weight`: once the common step counter exceeds `num_steps`, sets the reward
/// term's weight (idempotent); logs the current weight.
struct ModifyRewardWeight(ModifyRewardWeightParams);

impl CurriculumTerm for ModifyRewardWeight {
    fn compute(
        &mut self,
        _env_ids: &[usize],
        common_step_counter: u64,
        rewards: &mut crate::managers::RewardManager,
    ) -> Result<Option<f32>, EnvError> {
        if common_step_counter > self.0.num_steps {
            rewards.set_weight(&self.0.term_name, self.0.weight)?;
        }
        Ok(rewards.weight(&self.0.term_name))
    }
}

inventory::submit! { CurriculumTermDef { name: "modify_reward_weight", build: |c| {
    Ok(Box::new(ModifyRewardWeight(c.params()?)))
} } }

/// Parameters of `randomize_rigid_body_material`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialParams {
    /// Rigid-object name.
    pub asset: String,
    /// Friction coefficients are drawn uniformly from this range per env.
    pub friction_range: (f32, f32),
}

/// `randomize_rigid_body_material`: a uniform friction coefficient per env for every shape of a
/// rigid object (shape priorities are kept, so a prioritised shape's new friction still wins).
struct RandomizeMaterial {
    object: usize,
    range: (f32, f32),
}

impl EventTerm for RandomizeMaterial {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        let values: Vec<f32> = env_ids
            .iter()
            .map(|&e| rng.get(e).uniform_range(self.range.0, self.range.1))
            .collect();
        scene.backend.set_friction(
            orbit_core::physics::BodyRef::RigidObject(self.object),
            env_ids,
            &values,
        )?;
        Ok(())
    }
}

inventory::submit! { EventTermDef { name: "randomize_rigid_body_material", build: |c| {
    let p: MaterialParams = c.params()?;
    let (lo, hi) = p.friction_range;
    if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi) {
        return Err(c.error(format!("params.friction_range must satisfy 0 <= lo <= hi, got ({lo}, {hi})")));
    }
    let object = c.scene.rigid_object(&format!("{}.params.asset", c.field), &p.asset)?;
    Ok(Box::new(RandomizeMaterial { object, range: p.friction_range }))
} } }
