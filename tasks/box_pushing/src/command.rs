//! The target-pose command: Fancy Gym's `sample_context` with its minimum-distance rule.

use orbit_core::math::rotation_distance;
use orbit_core::parallel::MIN_ENVS_PER_TASK;
use orbit_core::scene::{Marker, MarkerShape};
use orbit_managers::mdp::command_pose;
use orbit_managers::term::{CommandTerm, CommandTermDef, TermContext};
use orbit_managers::{EnvError, EnvRngs, Scene};
use rayon::prelude::*;
use serde::Deserialize;

/// Parameters of `box_target_pose`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetPoseParams {
    /// Rigid object whose pose the target is compared against.
    pub object: String,
    /// Lower corner of the target position box (env frame).
    pub pos_low: (f32, f32, f32),
    /// Upper corner of the target position box.
    pub pos_high: (f32, f32, f32),
    /// Minimum xy distance between the target and the object's position at reset.
    pub min_distance: f32,
    /// A fixed target `(x, y, z, qw, qx, qy, qz)` instead of sampling (for tests and evaluation).
    #[serde(default)]
    pub fixed: Option<[f32; 7]>,
}

impl Default for TargetPoseParams {
    fn default() -> Self {
        Self {
            object: "box".into(),
            pos_low: (0.3, -0.45, -0.01),
            pos_high: (0.6, 0.45, -0.01),
            min_distance: 0.3,
            fixed: None,
        }
    }
}

/// Samples targets like Fancy Gym: position uniform in the box, `θ ~ U(0, 2π)` and the
/// quaternion `(sin θ/2, 0, 0, cos θ/2)` (Fancy Gym's `rot_to_quat`, a uniform yaw), redrawn
/// until the xy distance to the object is at least `min_distance`.
struct TargetPose {
    object: usize,
    p: TargetPoseParams,
    command: Vec<f32>,
    /// `position_error` (m), `orientation_error` (rad), `success` (1 if both are within
    /// Fancy Gym's 0.05 m / 0.5 rad).
    metrics: [(&'static str, Vec<f32>); 3],
}

/// Fancy Gym's success threshold on the box's distance to the target (m).
pub const SUCCESS_DISTANCE: f32 = 0.05;
/// Fancy Gym's success threshold on the orientation error (rad).
pub const SUCCESS_ANGLE: f32 = 0.5;

/// Colour of the target marker (a translucent ghost of the box) in rendered frames.
const TARGET_COLOR: [f32; 3] = [0.2, 0.85, 0.3];

/// Draws at most this many candidates per resample (Fancy Gym loops without bound; with the
/// default ranges the acceptance rate is above 0.5, so the cap is never reached in practice).
const MAX_DRAWS: usize = 1000;

impl CommandTerm for TargetPose {
    fn dim(&self) -> usize {
        7
    }

    fn command(&self) -> &[f32] {
        &self.command
    }

    fn update_metrics(&mut self, scene: &Scene) {
        let objects = scene.backend.rigid_object(self.object);
        let [(_, distance), (_, angle), (_, success)] = &mut self.metrics;
        // Envs are independent: computed in parallel, each by the same operations.
        distance
            .par_iter_mut()
            .with_min_len(MIN_ENVS_PER_TASK)
            .zip(angle.par_iter_mut())
            .zip(success.par_iter_mut())
            .zip(self.command.par_chunks(7))
            .enumerate()
            .for_each(|(e, (((d, rho), ok), c))| {
                let target = command_pose(c);
                *d = (objects.pos[e] - target.pos).length();
                *rho = rotation_distance(objects.quat[e], target.rot);
                *ok = f32::from(u8::from(*d <= SUCCESS_DISTANCE && *rho <= SUCCESS_ANGLE));
            });
    }

    fn metrics(&self) -> &[(&'static str, Vec<f32>)] {
        &self.metrics
    }

    fn debug_markers(&self, _scene: &Scene, env: usize, out: &mut Vec<Marker>) {
        out.push(Marker {
            shape: MarkerShape::RigidObject(self.object),
            pose: command_pose(&self.command[env * 7..(env + 1) * 7]),
            color: TARGET_COLOR,
            opacity: 0.45,
        });
    }

    fn resample(&mut self, scene: &Scene, env_ids: &[usize], rng: &mut EnvRngs) {
        let objects = scene.backend.rigid_object(self.object);
        for &e in env_ids {
            let row = &mut self.command[e * 7..(e + 1) * 7];
            if let Some(fixed) = self.p.fixed {
                row.copy_from_slice(&fixed);
                continue;
            }
            let start = objects.pos[e];
            let r = rng.get(e);
            for _ in 0..MAX_DRAWS {
                let (lo, hi) = (self.p.pos_low, self.p.pos_high);
                let pos = [
                    r.uniform_range(lo.0, hi.0),
                    r.uniform_range(lo.1, hi.1),
                    r.uniform_range(lo.2, hi.2),
                ];
                let theta = r.uniform_range(0.0, std::f32::consts::TAU);
                row[..3].copy_from_slice(&pos);
                row[3..].copy_from_slice(&[(theta / 2.0).sin(), 0.0, 0.0, (theta / 2.0).cos()]);
                if glam::Vec2::new(pos[0] - start.x, pos[1] - start.y).length()
                    >= self.p.min_distance
                {
                    break;
                }
            }
        }
    }
}

fn build(ctx: &TermContext<'_>) -> Result<Box<dyn CommandTerm>, EnvError> {
    let p: TargetPoseParams = ctx.params()?;
    let object = ctx
        .scene
        .rigid_object(&format!("{}.params.object", ctx.field), &p.object)?;
    if let Some(f) = p.fixed {
        let q = glam::Vec4::new(f[3], f[4], f[5], f[6]);
        if !(q.length() - 1.0).abs().lt(&1e-3) {
            return Err(ctx.error(format!(
                "fixed target quaternion {:?} is not unit length",
                &f[3..]
            )));
        }
    }
    let n = ctx.scene.num_envs();
    Ok(Box::new(TargetPose {
        object,
        p,
        command: vec![0.0; n * 7],
        metrics: [
            ("position_error", vec![0.0; n]),
            ("orientation_error", vec![0.0; n]),
            ("success", vec![0.0; n]),
        ],
    }))
}

inventory::submit! { CommandTermDef { name: "box_target_pose", build } }
