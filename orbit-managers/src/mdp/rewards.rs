//! Reward terms: action rate, joint speed, joint limits, alive and terminated, joint targets.
use super::*;

/// `action_rate_l2`: `Σ (a − a_prev)²`.
struct ActionRate;

impl RewardTerm for ActionRate {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let d = env.action_dim;
        orbit_core::parallel::fill_rows(out, 1, |e, o| {
            o[0] = (0..d)
                .map(|i| (env.action[e * d + i] - env.prev_action[e * d + i]).powi(2))
                .sum();
        });
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
        self.0.sum_per_env(v, out, |_, qd| qd * qd);
    }
}

inventory::submit! { RewardTermDef { name: "joint_vel_l2", build: |c| Ok(Box::new(JointVelL2(JointSel::resolve(c, &c.params()?)?))) } }

/// `joint_pos_limits`: `Σ max(q_min − q, 0) + max(q − q_max, 0)` over the selected joints, with
/// the model's position limits (unlimited joints contribute nothing).
struct JointPosLimits {
    sel: JointSel,
    /// `(lower, upper)` per selected joint.
    limits: Vec<(f32, f32)>,
}

impl RewardTerm for JointPosLimits {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let q = env
            .scene
            .backend
            .articulation(self.sel.articulation)
            .joint_pos;
        let limits = &self.limits;
        self.sel.sum_per_env(q, out, |k, q| {
            (limits[k].0 - q).max(0.0) + (q - limits[k].1).max(0.0)
        });
    }
}

inventory::submit! { RewardTermDef { name: "joint_pos_limits", build: |c| {
    let sel = JointSel::resolve(c, &c.params()?)?;
    let limits = joint_limits(&c.scene.desc.articulations[sel.articulation].model, &sel.dofs);
    Ok(Box::new(JointPosLimits { sel, limits }))
} } }

/// Parameters of `joint_vel_limits`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointVelLimitsParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes (full match).
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
    /// Fraction of each joint's velocity limit beyond which the penalty starts.
    pub soft_ratio: f32,
}

impl Default for JointVelLimitsParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
            soft_ratio: 1.0,
        }
    }
}

/// `joint_vel_limits`: `Σ clamp(|q̇| − soft_ratio · q̇_max, 0, 1)` over the selected joints (Isaac
/// Lab's term, whose clamp bounds each joint's share). `q̇_max` is the asset's joint velocity
/// limit, else the actuator's.
struct JointVelLimits {
    sel: JointSel,
    /// `soft_ratio · q̇_max` per selected joint.
    soft_limits: Vec<f32>,
}

impl RewardTerm for JointVelLimits {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let v = env
            .scene
            .backend
            .articulation(self.sel.articulation)
            .joint_vel;
        let limits = &self.soft_limits;
        self.sel
            .sum_per_env(v, out, |k, qd| (qd.abs() - limits[k]).clamp(0.0, 1.0));
    }
}

inventory::submit! { RewardTermDef { name: "joint_vel_limits", build: |c| {
    let p: JointVelLimitsParams = c.params()?;
    if !(p.soft_ratio.is_finite() && p.soft_ratio > 0.0) {
        return Err(c.error(format!("params.soft_ratio must be positive, got {}", p.soft_ratio)));
    }
    let sel = JointSel::resolve(c, &JointsParams { asset: p.asset, joint_names: p.joint_names })?;
    let desc = &c.scene.desc.articulations[sel.articulation];
    let dof_links = desc.model.dof_links();
    let mut soft_limits = Vec::with_capacity(sel.dofs.len());
    for &j in &sel.dofs {
        let joint = desc.model.links[dof_links[j]].joint.as_ref().expect("dof link has a joint");
        let limit = joint.velocity_limit.unwrap_or(desc.drives[j].velocity_limit);
        if !limit.is_finite() {
            return Err(c.error(format!(
                "joint `{}` has no velocity limit (neither in the asset nor in its actuator's `velocity_limit`)",
                joint.name
            )));
        }
        soft_limits.push(p.soft_ratio * limit);
    }
    Ok(Box::new(JointVelLimits { sel, soft_limits }))
} } }

/// `is_alive`: 1 for an env whose episode no termination term ended this step (a time-out
/// counts as alive), as Isaac Lab's.
struct IsAlive;

impl RewardTerm for IsAlive {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        for (e, o) in out.iter_mut().enumerate() {
            *o = if terminated(env, e) { 0.0 } else { 1.0 };
        }
    }
}

inventory::submit! { RewardTermDef { name: "is_alive", build: |_| Ok(Box::new(IsAlive)) } }

/// `is_terminated`: 1 for an env whose episode a termination term (not a time-out) ended this
/// step, as Isaac Lab's.
struct IsTerminated;

impl RewardTerm for IsTerminated {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        for (e, o) in out.iter_mut().enumerate() {
            *o = if terminated(env, e) { 1.0 } else { 0.0 };
        }
    }
}

inventory::submit! { RewardTermDef { name: "is_terminated", build: |_| Ok(Box::new(IsTerminated)) } }

/// Whether env `e`'s episode was terminated (not timed out) this step.
fn terminated(env: &EnvView<'_>, e: usize) -> bool {
    env.terminated.get(e).copied().unwrap_or(false)
}

/// Parameters of `joint_pos_target_l2`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointTargetParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes (full match).
    #[serde(default = "all_joints")]
    pub joint_names: Vec<String>,
    /// The target position (rad or m).
    pub target: f32,
}

impl Default for JointTargetParams {
    /// No target: the term's builder asks for one.
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: all_joints(),
            target: f32::NAN,
        }
    }
}

/// `joint_pos_target_l2`: `Σ (wrap(q) − target)²` over the selected joints, each position
/// wrapped to `(−π, π]` first (Isaac Lab's, for continuous joints such as a cart-pole's).
struct JointPosTargetL2 {
    sel: JointSel,
    target: f32,
}

impl RewardTerm for JointPosTargetL2 {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let q = env
            .scene
            .backend
            .articulation(self.sel.articulation)
            .joint_pos;
        let target = self.target;
        self.sel
            .sum_per_env(q, out, |_, q| (wrap_to_pi(q) - target).powi(2));
    }
}

/// `a` wrapped to `(−π, π]`.
fn wrap_to_pi(a: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w == -PI { PI } else { w }
}

inventory::submit! { RewardTermDef { name: "joint_pos_target_l2", build: |c| {
    let p: JointTargetParams = c.params()?;
    if !p.target.is_finite() {
        return Err(c.error(format!(
            "params.target (the joint position to reach) must be given and finite, got {}",
            p.target
        )));
    }
    let sel = JointSel::resolve(c, &JointsParams { asset: p.asset, joint_names: p.joint_names })?;
    Ok(Box::new(JointPosTargetL2 { sel, target: p.target }))
} } }

/// `joint_vel_l1`: `Σ |q̇|` over the selected joints.
struct JointVelL1(JointSel);

impl RewardTerm for JointVelL1 {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let v = env
            .scene
            .backend
            .articulation(self.0.articulation)
            .joint_vel;
        self.0.sum_per_env(v, out, |_, qd| qd.abs());
    }
}

inventory::submit! { RewardTermDef { name: "joint_vel_l1", build: |c| Ok(Box::new(JointVelL1(JointSel::resolve(c, &c.params()?)?))) } }

#[cfg(test)]
mod tests {
    use super::wrap_to_pi;
    use std::f32::consts::PI;

    /// Angles wrap into (−π, π] and keep their value modulo 2π.
    #[test]
    fn angles_wrap_into_one_turn() {
        for (a, w) in [
            (0.0, 0.0),
            (PI, PI),
            (-PI, PI),
            (3.0 * PI / 2.0, -PI / 2.0),
            (-7.0, -7.0 + 2.0 * PI),
        ] {
            assert!((wrap_to_pi(a) - w).abs() < 1e-5, "{a} -> {}", wrap_to_pi(a));
        }
    }
}
