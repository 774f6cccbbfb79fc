//! Isaac Lab's reach reward terms: distance, fine-grained distance and orientation error of a
//! body against a pose command.

use orbit_core::math::{Pose, rotation_distance};
use orbit_managers::mdp::command_pose_in_world;
use orbit_managers::term::{RewardTerm, RewardTermDef, TermContext};
use orbit_managers::{EnvError, EnvView};
use serde::Deserialize;

/// Parameters shared by the pose-tracking terms.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseTrackingParams {
    /// The articulation.
    #[serde(default = "robot")]
    pub asset: String,
    /// Link or frame that tracks the command.
    pub body_name: String,
    /// A 7-d pose command in the articulation's root frame.
    pub command_name: String,
    /// Distance scale of `position_command_error_tanh` (m).
    #[serde(default)]
    pub std: Option<f32>,
}

fn robot() -> String {
    "robot".into()
}

impl Default for PoseTrackingParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            body_name: String::new(),
            command_name: String::new(),
            std: None,
        }
    }
}

/// Which quantity a pose-tracking term reports.
#[derive(Clone, Copy)]
enum Quantity {
    /// `‖p_body − p_cmd‖`.
    Distance,
    /// `1 − tanh(‖p_body − p_cmd‖ / std)`.
    DistanceTanh(f32),
    /// Angle of `q_body · q_cmd⁻¹` (rad).
    Orientation,
}

struct PoseTracking {
    robot: usize,
    frame: (usize, Pose),
    command: String,
    quantity: Quantity,
}

impl RewardTerm for PoseTracking {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let a = env.scene.backend.articulation(self.robot);
        let (cmd, _) = env
            .commands
            .command(&self.command)
            .expect("checked at build");
        for (e, o) in out.iter_mut().enumerate() {
            let target = command_pose_in_world(&a.link_pose(e, 0), &cmd[e * 7..(e + 1) * 7]);
            let body = a.frame_pose(e, self.frame.0, &self.frame.1);
            let d = (body.pos - target.pos).length();
            *o = match self.quantity {
                Quantity::Distance => d,
                Quantity::DistanceTanh(std) => 1.0 - (d / std).tanh(),
                Quantity::Orientation => rotation_distance(body.rot, target.rot),
            };
        }
    }
}

fn build(
    ctx: &TermContext<'_>,
    tanh: bool,
    orientation: bool,
) -> Result<Box<dyn RewardTerm>, EnvError> {
    let p: PoseTrackingParams = ctx.params()?;
    let f = |s: &str| format!("{}.params.{s}", ctx.field);
    let robot = ctx.scene.articulation(&f("asset"), &p.asset)?;
    let frame = ctx.scene.frame(&f("body_name"), robot, &p.body_name)?;
    if !ctx
        .command_dims
        .iter()
        .any(|(n, d)| *n == p.command_name && *d == 7)
    {
        return Err(ctx.error(format!(
            "params.command_name: no 7-d pose command named `{}`; commands: {:?}",
            p.command_name, ctx.command_dims
        )));
    }
    let quantity = match (tanh, orientation, p.std) {
        (true, _, Some(std)) if std > 0.0 => Quantity::DistanceTanh(std),
        (true, _, std) => {
            return Err(ctx.error(format!(
                "params.std: expected a positive distance scale, got {std:?}"
            )));
        }
        (false, true, _) => Quantity::Orientation,
        (false, false, _) => Quantity::Distance,
    };
    Ok(Box::new(PoseTracking {
        robot,
        frame,
        command: p.command_name,
        quantity,
    }))
}

inventory::submit! { RewardTermDef { name: "position_command_error", build: |c| build(c, false, false) } }
inventory::submit! { RewardTermDef { name: "position_command_error_tanh", build: |c| build(c, true, false) } }
inventory::submit! { RewardTermDef { name: "orientation_command_error", build: |c| build(c, false, true) } }
