//! Observation terms: joint state, actions, commands, object poses and velocities, frame
//! positions.
use super::*;
use orbit_core::parallel::fill_rows;

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
        let (dofs, default) = (&self.sel.dofs, &self.default);
        fill_rows(out, d, |e, row| {
            for (k, &j) in dofs.iter().enumerate() {
                row[k] = src[e * n + j] - default[j];
            }
        });
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
/// Which root-state quantity of a rigid object a [`RootState`] term reads.
#[derive(Clone, Copy)]
enum RootQuantity {
    /// Position in the env frame (3).
    Pos,
    /// Orientation `(w, x, y, z)` (4).
    Quat,
    /// Linear velocity of the body origin, world (= env) axes (3).
    LinVel,
    /// Angular velocity, world (= env) axes (3).
    AngVel,
}

/// `root_pos` / `root_quat` / `root_lin_vel` / `root_ang_vel`: one root-state quantity of a
/// rigid object.
struct RootState {
    object: usize,
    quantity: RootQuantity,
}

impl ObservationTerm for RootState {
    fn dim(&self) -> usize {
        match self.quantity {
            RootQuantity::Quat => 4,
            _ => 3,
        }
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let view = env.scene.backend.rigid_object(self.object);
        let quantity = self.quantity;
        fill_rows(out, self.dim(), |e, row| match quantity {
            RootQuantity::Pos => row.copy_from_slice(&view.pos[e].to_array()),
            RootQuantity::Quat => row.copy_from_slice(&orbit_core::math::to_wxyz(view.quat[e])),
            RootQuantity::LinVel => row.copy_from_slice(&view.lin_vel[e].to_array()),
            RootQuantity::AngVel => row.copy_from_slice(&view.ang_vel[e].to_array()),
        });
    }
}

fn root_state(
    ctx: &TermContext<'_>,
    quantity: RootQuantity,
) -> Result<Box<dyn ObservationTerm>, EnvError> {
    let p: ObjectParams = ctx.params()?;
    let object = ctx
        .scene
        .rigid_object(&format!("{}.params.asset", ctx.field), &p.asset)?;
    Ok(Box::new(RootState { object, quantity }))
}

inventory::submit! { ObservationTermDef { name: "root_pos", build: |c| root_state(c, RootQuantity::Pos) } }
inventory::submit! { ObservationTermDef { name: "root_quat", build: |c| root_state(c, RootQuantity::Quat) } }
inventory::submit! { ObservationTermDef { name: "root_lin_vel", build: |c| root_state(c, RootQuantity::LinVel) } }
inventory::submit! { ObservationTermDef { name: "root_ang_vel", build: |c| root_state(c, RootQuantity::AngVel) } }

/// Parameters of `frame_pos`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FrameParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// A link of the articulation, or a frame rigidly attached to one (e.g. a tool tip).
    pub frame: String,
}

impl Default for FrameParams {
    /// No frame: the term's error then lists the articulation's links.
    fn default() -> Self {
        Self {
            asset: robot(),
            frame: String::new(),
        }
    }
}

/// `frame_pos`: the position of an articulation's link or frame in the env frame (3), Isaac
/// Lab's end-effector position observation.
struct FramePos {
    articulation: usize,
    link: usize,
    offset: orbit_core::math::Pose,
}

impl ObservationTerm for FramePos {
    fn dim(&self) -> usize {
        3
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        let view = env.scene.backend.articulation(self.articulation);
        let (link, offset) = (self.link, &self.offset);
        fill_rows(out, 3, |e, row| {
            row.copy_from_slice(&view.frame_pose(e, link, offset).pos.to_array());
        });
    }
}

inventory::submit! { ObservationTermDef { name: "frame_pos", build: |c| {
    let p: FrameParams = c.params()?;
    let articulation = c.scene.articulation(&format!("{}.params.asset", c.field), &p.asset)?;
    let (link, offset) = c.scene.frame(&format!("{}.params.frame", c.field), articulation, &p.frame)?;
    Ok(Box::new(FramePos { articulation, link, offset }))
} } }

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
        fill_rows(out, 3, |e, row| {
            let root = robot.link_pose(e, 0);
            row.copy_from_slice(&root.inverse().transform_point(object.pos[e]).to_array());
        });
    }
}

inventory::submit! { ObservationTermDef { name: "object_position_in_robot_root_frame", build: |c| {
    let p: ObjectInRobotParams = c.params()?;
    let robot = c.scene.articulation(&format!("{}.params.robot", c.field), &p.robot)?;
    let object = c.scene.rigid_object(&format!("{}.params.object", c.field), &p.object)?;
    Ok(Box::new(ObjectInRobot { robot, object }))
} } }
