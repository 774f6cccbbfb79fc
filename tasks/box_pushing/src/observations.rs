//! Box-pushing observation terms (Isaac Lab keeps such task-specific terms in the task's `mdp`).

use glam::Mat3;
use orbit_core::parallel::fill_rows;
use orbit_managers::term::{ObservationTerm, ObservationTermDef, TermContext};
use orbit_managers::{EnvError, EnvView};

use crate::rewards::{Refs, target_pose};

/// `box_goal_error`: how far the box is from its target pose (9 values). First the position
/// error `p_target − p_box` in the env frame (3), the frame the rod tip is observed in; then
/// the rotation that takes the box onto the target, `q_box⁻¹ q_target`, as the first two columns
/// of its matrix (6). Unlike a quaternion, whose sign flips somewhere on every full turn, the
/// two columns change continuously with the box's yaw. Parameters: [`crate::BoxPushingParams`]
/// (`object`, `command`).
struct BoxGoalError {
    refs: Refs,
}

impl ObservationTerm for BoxGoalError {
    fn dim(&self) -> usize {
        9
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let objects = env.scene.backend.rigid_object(self.refs.object);
        let (cmd, _) = env
            .commands
            .command(&self.refs.command)
            .expect("checked when the term was built");
        fill_rows(out, 9, |e, row| {
            let target = target_pose(cmd, e);
            let rot = Mat3::from_quat(objects.quat[e].inverse() * target.rot);
            row[..3].copy_from_slice(&(target.pos - objects.pos[e]).to_array());
            row[3..6].copy_from_slice(&rot.x_axis.to_array());
            row[6..].copy_from_slice(&rot.y_axis.to_array());
        });
    }
}

inventory::submit! { ObservationTermDef { name: "box_goal_error", build: |c: &TermContext<'_>| -> Result<Box<dyn ObservationTerm>, EnvError> {
    Ok(Box::new(BoxGoalError { refs: Refs::resolve(c)? }))
} } }
