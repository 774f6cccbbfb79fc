//! Terms of Isaac Lab's classic locomotion tasks (Ant, Humanoid): the base's heading and tilt
//! towards a target, and the rewards built on them (progress, upright and heading bonuses,
//! power and joint-limit penalties). The target is a point in each env's frame.
use std::collections::BTreeMap;

use super::*;
use orbit_core::parallel::fill_rows;

fn far_ahead() -> Vec3 {
    Vec3::new(1000.0, 0.0, 0.0)
}

/// Parameters naming an articulation and a target point.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Target in the env frame (m); Isaac Lab's tasks walk towards (1000, 0, 0).
    #[serde(default = "far_ahead")]
    pub target_pos: Vec3,
}

impl Default for TargetParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            target_pos: far_ahead(),
        }
    }
}

/// Roll and yaw of a base orientation (Isaac Lab's `euler_xyz_from_quat`: rotations about the
/// fixed x, y, then z axes), each in [−π, π].
pub fn roll_yaw(q: Quat) -> (f32, f32) {
    let roll = (2.0 * (q.w * q.x + q.y * q.z)).atan2(1.0 - 2.0 * (q.x * q.x + q.y * q.y));
    let yaw = (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z));
    (roll, yaw)
}

/// `a` wrapped into [−π, π].
fn wrap(a: f32) -> f32 {
    a.sin().atan2(a.cos())
}

/// Env `e`'s base: the root link's position and orientation.
fn base_pose(view: &orbit_core::physics::ArticulationView<'_>, e: usize) -> (Vec3, Quat) {
    let root = e * view.num_links;
    (view.link_pos[root], view.link_quat[root])
}

/// The horizontal vector from `pos` to `target`; its length is the progress terms' distance.
fn to_target(pos: Vec3, target: Vec3) -> Vec3 {
    (target - pos) * Vec3::new(1.0, 1.0, 0.0)
}

/// z of world up in base axes: the cosine of the base's tilt.
fn up_proj(rot: Quat) -> f32 {
    (rot.inverse() * Vec3::Z).z
}

/// Cosine between the base's x axis and the horizontal direction `to_target`.
fn heading_proj(rot: Quat, to_target: Vec3) -> f32 {
    (rot * Vec3::X).dot(to_target.normalize_or_zero())
}

/// Which quantity of the base's heading an observation term writes.
#[derive(Clone, Copy)]
enum HeadingObs {
    /// `[yaw, roll]` (2).
    YawRoll,
    /// Angle to the target (1).
    AngleToTarget,
    /// Up projection (1).
    UpProj,
    /// Heading projection (1).
    HeadingProj,
}

/// `base_yaw_roll` / `base_angle_to_target` / `base_up_proj` / `base_heading_proj`.
struct HeadingTerm {
    articulation: usize,
    target: Vec3,
    quantity: HeadingObs,
}

impl ObservationTerm for HeadingTerm {
    fn dim(&self) -> usize {
        match self.quantity {
            HeadingObs::YawRoll => 2,
            _ => 1,
        }
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let view = env.scene.backend.articulation(self.articulation);
        let (target, quantity) = (self.target, self.quantity);
        fill_rows(out, self.dim(), |e, row| {
            let (pos, rot) = base_pose(&view, e);
            match quantity {
                HeadingObs::YawRoll => {
                    let (roll, yaw) = roll_yaw(rot);
                    row.copy_from_slice(&[yaw, roll]);
                }
                HeadingObs::AngleToTarget => {
                    let d = to_target(pos, target);
                    row[0] = wrap(d.y.atan2(d.x) - roll_yaw(rot).1);
                }
                HeadingObs::UpProj => row[0] = up_proj(rot),
                HeadingObs::HeadingProj => row[0] = heading_proj(rot, to_target(pos, target)),
            }
        });
    }
}

fn heading_obs(
    ctx: &TermContext<'_>,
    quantity: HeadingObs,
) -> Result<Box<dyn ObservationTerm>, EnvError> {
    let p: TargetParams = ctx.params()?;
    let articulation = ctx.articulation(&p.asset)?;
    Ok(Box::new(HeadingTerm {
        articulation,
        target: p.target_pos,
        quantity,
    }))
}

inventory::submit! { ObservationTermDef { name: "base_yaw_roll", build: |c| heading_obs(c, HeadingObs::YawRoll) } }
inventory::submit! { ObservationTermDef { name: "base_angle_to_target", build: |c| heading_obs(c, HeadingObs::AngleToTarget) } }
inventory::submit! { ObservationTermDef { name: "base_up_proj", build: |c| heading_obs(c, HeadingObs::UpProj) } }
inventory::submit! { ObservationTermDef { name: "base_heading_proj", build: |c| heading_obs(c, HeadingObs::HeadingProj) } }

/// `progress_reward`: the speed at which the base approaches the target horizontally,
/// `(d_{t−1} − d_t) / step_dt` (Isaac Lab's potential `−d / step_dt`, differenced). A reset
/// restarts the difference from the base's new position. Evaluating the term again within a
/// step (an inspection) gives the same values.
struct Progress {
    articulation: usize,
    target: Vec3,
    step_dt: f32,
    /// The env step whose distances `now` holds.
    step: Option<u64>,
    /// Per env, the horizontal distance to the target before that step (or after a reset).
    before: Vec<f32>,
    /// Per env, the distance measured at that step (or after a reset).
    now: Vec<f32>,
}

impl Progress {
    /// Env `e`'s horizontal distance to the target.
    fn distance(&self, view: &orbit_core::physics::ArticulationView<'_>, e: usize) -> f32 {
        to_target(base_pose(view, e).0, self.target).length()
    }
}

impl RewardTerm for Progress {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        if self.step != Some(env.common_step_counter) {
            // A new step: the last step's distances become the ones to difference against.
            std::mem::swap(&mut self.before, &mut self.now);
            self.step = Some(env.common_step_counter);
        }
        let view = env.scene.backend.articulation(self.articulation);
        for (e, o) in out.iter_mut().enumerate() {
            self.now[e] = self.distance(&view, e);
            *o = (self.before[e] - self.now[e]) / self.step_dt;
        }
    }
    fn reset(&mut self, scene: &Scene, env_ids: &[usize]) {
        let view = scene.backend.articulation(self.articulation);
        for &e in env_ids {
            let d = self.distance(&view, e);
            (self.before[e], self.now[e]) = (d, d);
        }
    }
}

inventory::submit! { RewardTermDef { name: "progress_reward", build: |c| {
    let p: TargetParams = c.params()?;
    let articulation = c.articulation(&p.asset)?;
    let n = c.scene.num_envs();
    let mut term = Progress { articulation, target: p.target_pos, step_dt: c.step_dt, step: None, before: vec![0.0; n], now: vec![0.0; n] };
    term.reset(c.scene, &(0..n).collect::<Vec<_>>());
    Ok(Box::new(term))
} } }

/// Parameters of the heading bonuses.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BonusParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Target in the env frame (m).
    #[serde(default = "far_ahead")]
    pub target_pos: Vec3,
    /// Projection above which the bonus is full (required).
    pub threshold: Option<f32>,
}

impl Default for BonusParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            target_pos: far_ahead(),
            threshold: None,
        }
    }
}

/// `params.threshold`, required, inside `range` (described by `range_text`).
fn threshold(
    ctx: &TermContext<'_>,
    value: Option<f32>,
    range: impl Fn(f32) -> bool,
    range_text: &str,
) -> Result<f32, EnvError> {
    match value {
        None => Err(ctx.error(format!(
            "params.threshold is required: a value in {range_text}"
        ))),
        Some(t) if range(t) => Ok(t),
        Some(t) => Err(ctx.error(format!("params.threshold must be in {range_text}, got {t}"))),
    }
}

/// `upright_posture_bonus` (1 while the up projection exceeds the threshold) and
/// `move_to_target_bonus` (1 while the heading projection exceeds it, else the projection over
/// the threshold, negative when facing away).
struct Bonus {
    articulation: usize,
    target: Vec3,
    threshold: f32,
    upright: bool,
}

impl RewardTerm for Bonus {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let view = env.scene.backend.articulation(self.articulation);
        let (target, th, upright) = (self.target, self.threshold, self.upright);
        fill_rows(out, 1, |e, o| {
            let (pos, rot) = base_pose(&view, e);
            o[0] = if upright {
                if up_proj(rot) > th { 1.0 } else { 0.0 }
            } else {
                let h = heading_proj(rot, to_target(pos, target));
                if h > th { 1.0 } else { h / th }
            };
        });
    }
}

fn bonus(ctx: &TermContext<'_>, upright: bool) -> Result<Box<dyn RewardTerm>, EnvError> {
    let p: BonusParams = ctx.params()?;
    let threshold = threshold(ctx, p.threshold, |t| t > 0.0 && t <= 1.0, "(0, 1]")?;
    let articulation = ctx.articulation(&p.asset)?;
    Ok(Box::new(Bonus {
        articulation,
        target: p.target_pos,
        threshold,
        upright,
    }))
}

inventory::submit! { RewardTermDef { name: "upright_posture_bonus", build: |c| bonus(c, true) } }
inventory::submit! { RewardTermDef { name: "move_to_target_bonus", build: |c| bonus(c, false) } }

/// Parameters of `power_consumption`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Gear ratio per joint-name regex (full match); joints matched by none weigh 1. Weights
    /// are the gears over the largest.
    #[serde(default)]
    pub gear_ratio: BTreeMap<String, f32>,
}

impl Default for GearParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            gear_ratio: BTreeMap::new(),
        }
    }
}

/// Parameters of `joint_pos_limits_penalty_ratio`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsRatioParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Gear ratio per joint-name regex, as for `power_consumption`.
    #[serde(default)]
    pub gear_ratio: BTreeMap<String, f32>,
    /// The normalised position beyond which a joint is penalised (required).
    pub threshold: Option<f32>,
}

impl Default for LimitsRatioParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            gear_ratio: BTreeMap::new(),
            threshold: None,
        }
    }
}

/// Every joint's gear over the largest gear, from a regex map.
fn scaled_gears(
    ctx: &TermContext<'_>,
    articulation: usize,
    gear_ratio: &BTreeMap<String, f32>,
) -> Result<Vec<f32>, EnvError> {
    if let Some((pattern, gear)) = gear_ratio
        .iter()
        .find(|(_, g)| !(g.is_finite() && **g > 0.0))
    {
        return Err(ctx.error(format!(
            "params.gear_ratio[{pattern:?}] must be positive, got {gear}"
        )));
    }
    let gears: Vec<f32> = values_by_joint(ctx, "gear_ratio", articulation, gear_ratio)?
        .into_iter()
        .map(|g| g.unwrap_or(1.0))
        .collect();
    let max = gears.iter().copied().fold(0.0, f32::max);
    Ok(gears.into_iter().map(|g| g / max).collect())
}

/// `power_consumption`: `Σ_j |a_j q̇_j w_j|`, action `j` times joint `j`'s velocity and gear
/// weight (the task's actions drive the articulation's joints in order).
struct Power {
    articulation: usize,
    weights: Vec<f32>,
}

impl RewardTerm for Power {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let qd = env.scene.backend.articulation(self.articulation).joint_vel;
        let (n, w) = (self.weights.len(), &self.weights);
        fill_rows(out, 1, |e, o| {
            o[0] = (0..n)
                .map(|j| (env.action[e * n + j] * qd[e * n + j] * w[j]).abs())
                .sum();
        });
    }
}

inventory::submit! { RewardTermDef { name: "power_consumption", build: |c| {
    let p: GearParams = c.params()?;
    let articulation = c.articulation(&p.asset)?;
    let weights = scaled_gears(c, articulation, &p.gear_ratio)?;
    if c.action_dim != weights.len() {
        return Err(c.error(format!(
            "pairs action j with joint j, but the actions have {} values and `{}` {} joints",
            c.action_dim, p.asset, weights.len()
        )));
    }
    Ok(Box::new(Power { articulation, weights }))
} } }

/// `joint_pos_limits_penalty_ratio`: `Σ_j w_j (|u_j| − t) / (1 − t)` over the joints whose
/// normalised position `u_j` (−1 at the lower limit, 1 at the upper) exceeds `t` in size.
struct LimitsRatio {
    /// Every joint of the articulation.
    sel: JointSel,
    weights: Vec<f32>,
    limits: Vec<(f32, f32)>,
    threshold: f32,
}

impl RewardTerm for LimitsRatio {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let q = env
            .scene
            .backend
            .articulation(self.sel.articulation)
            .joint_pos;
        let (t, w, limits) = (self.threshold, &self.weights, &self.limits);
        self.sel.sum_per_env(q, out, |j, q| {
            let u = normalized(q, limits[j]).abs();
            if u > t {
                w[j] * (u - t) / (1.0 - t)
            } else {
                0.0
            }
        });
    }
}

inventory::submit! { RewardTermDef { name: "joint_pos_limits_penalty_ratio", build: |c| {
    let p: LimitsRatioParams = c.params()?;
    let threshold = threshold(c, p.threshold, |t| (0.0..1.0).contains(&t), "[0, 1)")?;
    let articulation = c.articulation(&p.asset)?;
    let weights = scaled_gears(c, articulation, &p.gear_ratio)?;
    let n = weights.len();
    let sel = JointSel { articulation, dofs: (0..n).collect(), num_dofs: n };
    let limits = finite_limits(c, sel.articulation, &sel.dofs)?;
    Ok(Box::new(LimitsRatio { sel, weights, limits, threshold }))
} } }

/// `q` normalised by its limits: −1 at the lower, 1 at the upper (Isaac Lab's
/// `scale_transform`).
fn normalized(q: f32, (lo, hi): (f32, f32)) -> f32 {
    2.0 * (q - 0.5 * (lo + hi)) / (hi - lo)
}

/// Position limits of `dofs`, each finite with lower below upper, else an error naming the
/// joint.
fn finite_limits(
    ctx: &TermContext<'_>,
    articulation: usize,
    dofs: &[usize],
) -> Result<Vec<(f32, f32)>, EnvError> {
    let model = &ctx.scene.desc.articulations[articulation].model;
    let limits = joint_limits(model, dofs);
    for (&j, &(lo, hi)) in dofs.iter().zip(&limits) {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            let name = &ctx.scene.backend.layout().articulations[articulation].joint_names[j];
            return Err(ctx.error(format!(
                "joint `{name}` has no finite position limits ({lo}, {hi}) to normalise by"
            )));
        }
    }
    Ok(limits)
}

/// `joint_pos_limit_normalized`: the selected joints' positions normalised by their limits.
struct JointPosNormalized {
    sel: JointSel,
    limits: Vec<(f32, f32)>,
}

impl ObservationTerm for JointPosNormalized {
    fn dim(&self) -> usize {
        self.sel.dofs.len()
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let q = env
            .scene
            .backend
            .articulation(self.sel.articulation)
            .joint_pos;
        let (n, dofs, limits) = (self.sel.num_dofs, &self.sel.dofs, &self.limits);
        fill_rows(out, dofs.len(), |e, row| {
            for (k, &j) in dofs.iter().enumerate() {
                row[k] = normalized(q[e * n + j], limits[k]);
            }
        });
    }
}

inventory::submit! { ObservationTermDef { name: "joint_pos_limit_normalized", build: |c| {
    let sel = JointSel::resolve(c, &c.params()?)?;
    let limits = finite_limits(c, sel.articulation, &sel.dofs)?;
    Ok(Box::new(JointPosNormalized { sel, limits }))
} } }

/// `action_l2`: `Σ a²` over the policy's actions.
struct ActionL2;

impl RewardTerm for ActionL2 {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let d = env.action_dim;
        fill_rows(out, 1, |e, o| {
            o[0] = env.action[e * d..(e + 1) * d].iter().map(|a| a * a).sum();
        });
    }
}

inventory::submit! { RewardTermDef { name: "action_l2", build: |_| Ok(Box::new(ActionL2)) } }

#[cfg(test)]
mod tests {
    use glam::Quat;

    use super::roll_yaw;

    /// A roll about x followed by a yaw about the fixed z axis reads back as both angles, to
    /// 1e-6 rad; a pitch alone changes neither.
    #[test]
    fn roll_and_yaw_of_fixed_axis_rotations() {
        let (roll, yaw) = roll_yaw(Quat::from_rotation_z(0.5) * Quat::from_rotation_x(0.2));
        assert!(
            (roll - 0.2).abs() < 1e-6 && (yaw - 0.5).abs() < 1e-6,
            "{roll} {yaw}"
        );
        let (roll, yaw) = roll_yaw(Quat::from_rotation_z(-3.0));
        assert!(
            roll.abs() < 1e-6 && (yaw + 3.0).abs() < 1e-6,
            "{roll} {yaw}"
        );
        let (roll, yaw) = roll_yaw(Quat::from_rotation_y(0.4));
        assert!(roll.abs() < 1e-6 && yaw.abs() < 1e-6, "{roll} {yaw}");
    }
}
