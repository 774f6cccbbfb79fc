//! Fancy Gym's box-pushing reward terms (`box_pushing_env.py`), each returning the per-step
//! quantity that the config weights: distances and angles are positive, penalties come from
//! negative weights.

use glam::Quat;
use orbit_core::math::{Pose, rotation_distance};
use orbit_core::parallel::fill_rows;
use orbit_managers::mdp::command_pose;
use orbit_managers::term::{RewardTerm, RewardTermDef, TermContext};
use orbit_managers::{EnvError, EnvView};
use serde::Deserialize;

/// Scene names the box-pushing terms refer to.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxPushingParams {
    /// The robot articulation.
    #[serde(default = "robot")]
    pub robot: String,
    /// The pushed object.
    #[serde(default = "box_name")]
    pub object: String,
    /// The target command.
    #[serde(default = "target")]
    pub command: String,
    /// Frame at the rod tip.
    #[serde(default = "rod_tip")]
    pub rod_tip: String,
    /// Frame whose orientation is the rod's.
    #[serde(default = "push_rod")]
    pub rod: String,
    /// Action term whose processed values are the commanded torques `u`.
    #[serde(default = "arm")]
    pub action: String,
    /// Count the term only at the last step of an episode (Fancy Gym's sparse variants).
    #[serde(default)]
    pub only_at_end: bool,
}

fn robot() -> String {
    "robot".into()
}
fn box_name() -> String {
    "box".into()
}
fn target() -> String {
    "target".into()
}
fn rod_tip() -> String {
    "rod_tip".into()
}
fn push_rod() -> String {
    "push_rod".into()
}
fn arm() -> String {
    "arm".into()
}

impl Default for BoxPushingParams {
    fn default() -> Self {
        Self {
            robot: robot(),
            object: box_name(),
            command: target(),
            rod_tip: rod_tip(),
            rod: push_rod(),
            action: arm(),
            only_at_end: false,
        }
    }
}

/// Resolved scene indices shared by the terms.
#[derive(Clone)]
pub(crate) struct Refs {
    robot: usize,
    pub(crate) object: usize,
    pub(crate) command: String,
    rod_tip: (usize, Pose),
    rod: (usize, Pose),
    action: String,
    only_at_end: bool,
}

impl Refs {
    /// Reads the term's [`BoxPushingParams`] and looks its names up in the scene.
    pub(crate) fn resolve(ctx: &TermContext<'_>) -> Result<Self, EnvError> {
        let p: BoxPushingParams = ctx.params()?;
        let f = |s: &str| format!("{}.params.{s}", ctx.field);
        let robot = ctx.scene.articulation(&f("robot"), &p.robot)?;
        if !ctx
            .command_dims
            .iter()
            .any(|(n, d)| *n == p.command && *d == 7)
        {
            return Err(ctx.error(format!(
                "params.command: no 7-d pose command named `{}`; commands: {:?}",
                p.command, ctx.command_dims
            )));
        }
        if !ctx.action_terms.iter().any(|(n, _)| *n == p.action) {
            return Err(ctx.error(format!(
                "params.action: no action term named `{}`; action terms: {:?}",
                p.action, ctx.action_terms
            )));
        }
        Ok(Self {
            robot,
            object: ctx.scene.rigid_object(&f("object"), &p.object)?,
            command: p.command,
            rod_tip: ctx.scene.frame(&f("rod_tip"), robot, &p.rod_tip)?,
            rod: ctx.scene.frame(&f("rod"), robot, &p.rod)?,
            action: p.action,
            only_at_end: p.only_at_end,
        })
    }
}

/// Target pose of env `e` from the 7-wide pose command rows `cmd`.
pub(crate) fn target_pose(cmd: &[f32], e: usize) -> Pose {
    command_pose(&cmd[e * 7..(e + 1) * 7])
}

/// The quantity a box-pushing reward term computes.
#[derive(Clone, Copy)]
enum Quantity {
    /// `clip(‖p_box − p_rodtip‖, 0.05, 100)`.
    RodTipDistance,
    /// `‖p_box − p_target‖`.
    GoalDistance,
    /// `rotdist(q_box, q_target) / π`.
    GoalRotation,
    /// `rotdist(q_rod, (0,1,0,0)) / π` when above π/4, else 0.
    RodInclination,
    /// `Σ u²` of the action term's processed values.
    Energy,
    /// `‖q̇‖` of the arm.
    JointSpeed,
    /// TemporalSpatialSparse's final bonus: if `d < 0.1`,
    /// `300 + clip(−1050 d, −100, 0) + clip(−150 ρ/π, −100, 0)`, else 0.
    SpatialBonus,
}

struct BoxPushingTerm {
    refs: Refs,
    quantity: Quantity,
}

impl RewardTerm for BoxPushingTerm {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        // The batched views are looked up once, not per env.
        let objects = env.scene.backend.rigid_object(self.refs.object);
        let arm = env.scene.backend.articulation(self.refs.robot);
        let (cmd, _) = env
            .commands
            .command(&self.refs.command)
            .expect("checked when the term was built");
        let processed = env.actions.processed(&self.refs.action);
        let down = Quat::from_xyzw(1.0, 0.0, 0.0, 0.0);
        let n = out.len();
        let refs = &self.refs;
        let quantity = self.quantity;
        // Envs are independent: computed in parallel, each by the same operations.
        fill_rows(out, 1, |e, o| {
            if refs.only_at_end && env.episode_length[e] < env.max_episode_length {
                o[0] = 0.0;
                return;
            }
            let frame = |(link, offset): (usize, Pose)| arm.frame_pose(e, link, &offset);
            o[0] = match quantity {
                Quantity::RodTipDistance => {
                    let tip = frame(refs.rod_tip).pos;
                    (objects.pos[e] - tip).length().clamp(0.05, 100.0)
                }
                Quantity::GoalDistance => (objects.pos[e] - target_pose(cmd, e).pos).length(),
                Quantity::GoalRotation => {
                    rotation_distance(objects.quat[e], target_pose(cmd, e).rot)
                        / std::f32::consts::PI
                }
                Quantity::RodInclination => {
                    let phi = rotation_distance(frame(refs.rod).rot, down);
                    if phi > std::f32::consts::FRAC_PI_4 {
                        phi / std::f32::consts::PI
                    } else {
                        0.0
                    }
                }
                Quantity::Energy => processed.map_or(0.0, |u| {
                    let d = u.len() / n;
                    u[e * d..(e + 1) * d].iter().map(|x| x * x).sum()
                }),
                Quantity::JointSpeed => {
                    let d = arm.joint_vel.len() / n;
                    arm.joint_vel[e * d..(e + 1) * d]
                        .iter()
                        .map(|x| x * x)
                        .sum::<f32>()
                        .sqrt()
                }
                Quantity::SpatialBonus => {
                    let target = target_pose(cmd, e);
                    let d = (objects.pos[e] - target.pos).length();
                    let rho = rotation_distance(objects.quat[e], target.rot) / std::f32::consts::PI;
                    if d < 0.1 {
                        300.0 + (-1050.0 * d).clamp(-100.0, 0.0) + (-150.0 * rho).clamp(-100.0, 0.0)
                    } else {
                        0.0
                    }
                }
            };
        });
    }
}

fn term(ctx: &TermContext<'_>, quantity: Quantity) -> Result<Box<dyn RewardTerm>, EnvError> {
    Ok(Box::new(BoxPushingTerm {
        refs: Refs::resolve(ctx)?,
        quantity,
    }))
}

inventory::submit! { RewardTermDef { name: "rod_tip_box_distance", build: |c| term(c, Quantity::RodTipDistance) } }
inventory::submit! { RewardTermDef { name: "box_goal_distance", build: |c| term(c, Quantity::GoalDistance) } }
inventory::submit! { RewardTermDef { name: "box_goal_rotation", build: |c| term(c, Quantity::GoalRotation) } }
inventory::submit! { RewardTermDef { name: "rod_inclination", build: |c| term(c, Quantity::RodInclination) } }
inventory::submit! { RewardTermDef { name: "action_energy", build: |c| term(c, Quantity::Energy) } }
inventory::submit! { RewardTermDef { name: "arm_joint_speed", build: |c| term(c, Quantity::JointSpeed) } }
inventory::submit! { RewardTermDef { name: "spatial_sparse_bonus", build: |c| term(c, Quantity::SpatialBonus) } }

/// Parameters of `joint_limit_violation`: Fancy Gym's limits (`box_pushing_utils.py`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointLimitParams {
    /// The robot articulation.
    #[serde(default = "robot")]
    pub robot: String,
    /// Lower position limits.
    pub q_min: Vec<f32>,
    /// Upper position limits.
    pub q_max: Vec<f32>,
    /// Speed limits.
    pub qd_max: Vec<f32>,
}

impl Default for JointLimitParams {
    fn default() -> Self {
        Self {
            robot: robot(),
            q_min: Vec::new(),
            q_max: Vec::new(),
            qd_max: Vec::new(),
        }
    }
}

/// Fancy Gym's joint-limit penalty magnitude:
/// `|Σ_{q > q_max}(q − q_max)| + |Σ_{q < q_min}(q_min − q)| + |Σ_{|q̇| > q̇_max}(|q̇| − q̇_max)|`.
struct JointLimitViolation {
    robot: usize,
    p: JointLimitParams,
}

impl RewardTerm for JointLimitViolation {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let v = env.scene.backend.articulation(self.robot);
        let (n, p) = (self.p.q_min.len(), &self.p);
        fill_rows(out, 1, |e, o| {
            let (q, qd) = (
                &v.joint_pos[e * n..(e + 1) * n],
                &v.joint_vel[e * n..(e + 1) * n],
            );
            let above: f32 = (0..n).map(|i| (q[i] - p.q_max[i]).max(0.0)).sum();
            let below: f32 = (0..n).map(|i| (p.q_min[i] - q[i]).max(0.0)).sum();
            let fast: f32 = (0..n).map(|i| (qd[i].abs() - p.qd_max[i]).max(0.0)).sum();
            o[0] = above + below + fast;
        });
    }
}

inventory::submit! { RewardTermDef { name: "joint_limit_violation", build: |c| {
    let p: JointLimitParams = c.params()?;
    let robot = c.scene.articulation(&format!("{}.params.robot", c.field), &p.robot)?;
    let dofs = c.scene.backend.layout().articulations[robot].num_dofs();
    if p.q_min.len() != dofs || p.q_max.len() != dofs || p.qd_max.len() != dofs {
        return Err(c.error(format!("q_min, q_max and qd_max need {dofs} values each")));
    }
    Ok(Box::new(JointLimitViolation { robot, p }))
} } }
