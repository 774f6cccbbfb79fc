//! Built-in command terms.

use glam::{EulerRot, Quat, Vec3};
use orbit_core::math::{Pose, quat_wxyz, rotation_distance, to_wxyz};
use orbit_core::parallel::MIN_ENVS_PER_TASK;
use orbit_core::scene::{Geometry, Marker, MarkerShape};
use rayon::prelude::*;
use serde::Deserialize;

use crate::base_env::EnvRngs;
use crate::error::EnvError;
use crate::scene::Scene;
use crate::term::*;

/// Parameters of `uniform_pose` (Isaac Lab's `UniformPoseCommandCfg`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UniformPoseParams {
    /// The articulation whose frame the command is for.
    #[serde(default = "super::robot")]
    pub asset: String,
    /// The link or frame that should reach the pose (e.g. `tcp`).
    pub body_name: String,
    /// Sampling ranges, in the articulation's root frame.
    pub ranges: PoseRanges,
    /// Flip quaternions to `w ≥ 0` (Isaac Lab's `make_quat_unique`).
    #[serde(default)]
    pub make_quat_unique: bool,
}

impl Default for UniformPoseParams {
    fn default() -> Self {
        Self {
            asset: super::robot(),
            body_name: String::new(),
            ranges: PoseRanges::default(),
            make_quat_unique: false,
        }
    }
}

/// Uniform ranges `(low, high)` of a pose: position (m) and extrinsic x-y-z Euler angles (rad).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseRanges {
    /// x range.
    pub pos_x: (f32, f32),
    /// y range.
    pub pos_y: (f32, f32),
    /// z range.
    pub pos_z: (f32, f32),
    /// Rotation about x.
    pub roll: (f32, f32),
    /// Rotation about y.
    pub pitch: (f32, f32),
    /// Rotation about z.
    pub yaw: (f32, f32),
}

/// Length of each axis of the target-pose marker (m).
const MARKER_AXIS_LENGTH: f32 = 0.1;

/// A target pose of a body in the articulation's root frame: position uniform in a box, then
/// `q = R_z(yaw)·R_y(pitch)·R_x(roll)` with uniform angles. Command `(x, y, z, qw, qx, qy, qz)`.
struct UniformPose {
    robot: usize,
    frame: (usize, Pose),
    p: UniformPoseParams,
    command: Vec<f32>,
    /// `position_error` (m) and `orientation_error` (rad) of the body against the command.
    metrics: [(&'static str, Vec<f32>); 2],
}

/// A pose command `(x, y, z, qw, qx, qy, qz)` (one env's row) as a pose in its own frame.
pub fn command_pose(command: &[f32]) -> Pose {
    Pose::new(
        Vec3::new(command[0], command[1], command[2]),
        quat_wxyz([command[3], command[4], command[5], command[6]]),
    )
}

/// The command of env `e` as a world (env-frame) pose, given the articulation's root pose.
pub fn command_pose_in_world(root: &Pose, command: &[f32]) -> Pose {
    root.mul_pose(&command_pose(command))
}

impl CommandTerm for UniformPose {
    fn dim(&self) -> usize {
        7
    }

    fn command(&self) -> &[f32] {
        &self.command
    }

    fn update_metrics(&mut self, scene: &Scene) {
        let a = scene.backend.articulation(self.robot);
        let [(_, distance), (_, angle)] = &mut self.metrics;
        let frame = &self.frame;
        distance
            .par_iter_mut()
            .with_min_len(MIN_ENVS_PER_TASK)
            .zip(angle.par_iter_mut())
            .zip(self.command.par_chunks(7))
            .enumerate()
            .for_each(|(e, ((d, rho), c))| {
                let target = command_pose_in_world(&a.link_pose(e, 0), c);
                let body = a.frame_pose(e, frame.0, &frame.1);
                *d = (body.pos - target.pos).length();
                *rho = rotation_distance(body.rot, target.rot);
            });
    }

    fn metrics(&self) -> &[(&'static str, Vec<f32>)] {
        &self.metrics
    }

    /// A frame triad at the target: x red, y green, z blue (Isaac Lab's pose marker).
    fn debug_markers(&self, scene: &Scene, env: usize, out: &mut Vec<Marker>) {
        let root = scene.backend.articulation(self.robot).link_pose(env, 0);
        let target = command_pose_in_world(&root, &self.command[env * 7..(env + 1) * 7]);
        let axis = Geometry::Capsule {
            radius: 0.006,
            half_length: 0.5 * MARKER_AXIS_LENGTH,
        };
        let half_pi = std::f32::consts::FRAC_PI_2;
        for (rot, color) in [
            (Quat::from_rotation_y(half_pi), [0.9, 0.15, 0.15]),
            (Quat::from_rotation_x(-half_pi), [0.15, 0.8, 0.2]),
            (Quat::IDENTITY, [0.2, 0.3, 0.95]),
        ] {
            // The capsule runs along its local z; move it so that it starts at the origin.
            let local = Pose::new(rot * Vec3::Z * (0.5 * MARKER_AXIS_LENGTH), rot);
            out.push(Marker {
                shape: MarkerShape::Geometry(axis),
                pose: target.mul_pose(&local),
                color,
                opacity: 1.0,
            });
        }
    }

    fn resample(&mut self, _scene: &Scene, env_ids: &[usize], rng: &mut EnvRngs) {
        let r = &self.p.ranges;
        for &e in env_ids {
            let g = rng.get(e);
            let mut draw = |(lo, hi): (f32, f32)| g.uniform_range(lo, hi);
            let pos = [draw(r.pos_x), draw(r.pos_y), draw(r.pos_z)];
            let (roll, pitch, yaw) = (draw(r.roll), draw(r.pitch), draw(r.yaw));
            let mut q = Quat::from_euler(EulerRot::ZYX, yaw, pitch, roll);
            if self.p.make_quat_unique && q.w < 0.0 {
                q = -q;
            }
            let row = &mut self.command[e * 7..(e + 1) * 7];
            row[..3].copy_from_slice(&pos);
            row[3..].copy_from_slice(&to_wxyz(q));
        }
    }
}

fn build_uniform_pose(ctx: &TermContext<'_>) -> Result<Box<dyn CommandTerm>, EnvError> {
    let p: UniformPoseParams = ctx.params()?;
    let f = |s: &str| format!("{}.params.{s}", ctx.field);
    let robot = ctx.scene.articulation(&f("asset"), &p.asset)?;
    let frame = ctx.scene.frame(&f("body_name"), robot, &p.body_name)?;
    let r = &p.ranges;
    for (name, (lo, hi)) in [
        ("pos_x", r.pos_x),
        ("pos_y", r.pos_y),
        ("pos_z", r.pos_z),
        ("roll", r.roll),
        ("pitch", r.pitch),
        ("yaw", r.yaw),
    ] {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(ctx.error(format!(
                "params.ranges.{name}: expected finite (low, high) with low <= high, got ({lo}, {hi})"
            )));
        }
    }
    let n = ctx.scene.num_envs();
    Ok(Box::new(UniformPose {
        robot,
        frame,
        p,
        command: vec![0.0; n * 7],
        metrics: [
            ("position_error", vec![0.0; n]),
            ("orientation_error", vec![0.0; n]),
        ],
    }))
}

inventory::submit! { CommandTermDef { name: "uniform_pose", build: build_uniform_pose } }
