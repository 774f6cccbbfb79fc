//! Fancy Gym's offline IK (`calculateOfflineIK` in `box_pushing_utils.py`) and the reset event
//! that places the arm with the rod tip inside the box: resolved-rate IK with a weighted
//! pseudo-inverse, a null-space posture task with joint-limit avoidance and an adaptive step.

use glam::{Quat, Vec3};
use nalgebra::{Matrix6, SMatrix, Vector6};
use orbit_core::kinematics::ArticulationKinematics;
use orbit_core::math::Pose;
use orbit_managers::term::{EventTerm, EventTermDef, TermContext};
use orbit_managers::{EnvError, EnvRngs, Scene};
use serde::Deserialize;

/// Task gains `Kp` (3 position, 3 orientation).
const KP: [f64; 6] = [
    33.9403713446798,
    30.9403713446798,
    33.9403713446798,
    27.69370238555632,
    33.98706171459314,
    30.9185531893281,
];
/// Null-space gains before the factor 5.
const KN: [f64; 7] = [
    7.675519770796831,
    2.676935478437176,
    8.539040163444975,
    1.270446361314313,
    8.87752182480855,
    2.186782233762969,
    4.414432577659688,
];
/// Null-space posture target.
const Q_NULL: [f64; 7] = [
    3.57795216e-09,
    0.17453292,
    3.3050096e-08,
    -0.87266463,
    -1.14096181e-07,
    1.22173047,
    0.785398126,
];

/// The result of one IK solve.
#[derive(Clone, Copy, Debug)]
pub struct IkSolution {
    /// Joint positions.
    pub q: [f32; 7],
    /// Accepted iterations.
    pub iterations: usize,
    /// Final error `‖e_p‖² + ‖c − d‖²`.
    pub error: f64,
}

/// Fancy Gym's IK on our kinematics model.
pub struct OfflineIk {
    kin: ArticulationKinematics,
    root: Pose,
    tcp: (usize, Pose),
    q_min: [f64; 7],
    q_max: [f64; 7],
    jac: Vec<(Vec3, Vec3)>,
}

impl OfflineIk {
    /// IK for the `tcp` frame `(link, offset)` of a 7-dof model rooted at `root`, with the limits
    /// used by the environment code.
    pub fn new(
        kin: ArticulationKinematics,
        root: Pose,
        tcp: (usize, Pose),
        q_min: [f64; 7],
        q_max: [f64; 7],
    ) -> Self {
        Self {
            kin,
            root,
            tcp,
            q_min,
            q_max,
            jac: vec![(Vec3::ZERO, Vec3::ZERO); 7],
        }
    }

    fn tcp_pose(&mut self, q: &[f64; 7]) -> Pose {
        let qf = q.map(|v| v as f32);
        let poses = self.kin.forward(&self.root, &qf);
        poses[self.tcp.0].mul_pose(&self.tcp.1)
    }

    /// Solves for the tcp at `p_des` with orientation `d` starting from `q_start`.
    pub fn solve(&mut self, p_des: Vec3, d: Quat, q_start: [f32; 7]) -> IkSolution {
        let mut q = q_start.map(f64::from);
        let mut qd = [0.0f64; 7];
        let mut dt = 1e-3;
        let mut prev = f64::INFINITY;
        let mut iterations = 0;
        let d = [
            f64::from(d.w),
            f64::from(d.x),
            f64::from(d.y),
            f64::from(d.z),
        ];
        loop {
            let q_old = q;
            for i in 0..7 {
                q[i] = (q[i] + dt * qd[i]).clamp(self.q_min[i], self.q_max[i]);
            }
            let pose = self.tcp_pose(&q);
            let dp = p_des - pose.pos;
            let e_p = [dp.x, dp.y, dp.z].map(|v| f64::from(v).clamp(-0.1, 0.1));
            let mut c = [
                f64::from(pose.rot.w),
                f64::from(pose.rot.x),
                f64::from(pose.rot.y),
                f64::from(pose.rot.z),
            ];
            let dist =
                |a: &[f64; 4], s: f64| (0..4).map(|k| (a[k] - s * d[k]).powi(2)).sum::<f64>();
            if dist(&c, 1.0) > dist(&c, -1.0) {
                c = c.map(|v| -v);
            }
            // e_o = c_w d_v − d_w c_v − d_v × c_v
            let (cv, dv) = ([c[1], c[2], c[3]], [d[1], d[2], d[3]]);
            let cross = [
                dv[1] * cv[2] - dv[2] * cv[1],
                dv[2] * cv[0] - dv[0] * cv[2],
                dv[0] * cv[1] - dv[1] * cv[0],
            ];
            let e_o: [f64; 3] =
                std::array::from_fn(|k| (c[0] * dv[k] - d[0] * cv[k] - cross[k]).clamp(-0.5, 0.5));
            let error = e_p.iter().map(|v| v * v).sum::<f64>() + dist(&c, 1.0);
            if error > prev {
                q = q_old;
                dt *= 0.7;
                continue;
            }
            dt *= 1.025;
            if error < 1e-5 || iterations > 1000 {
                return IkSolution {
                    q: q.map(|v| v as f32),
                    iterations,
                    error,
                };
            }
            prev = error;
            self.kin.point_jacobian(self.tcp.0, pose.pos, &mut self.jac);
            let j = SMatrix::<f64, 6, 7>::from_fn(|r, col| {
                let (lin, ang) = self.jac[col];
                f64::from(if r < 3 { lin[r] } else { ang[r - 3] })
            });
            let mut q_null =
                nalgebra::SVector::<f64, 7>::from_fn(|i, _| 5.0 * KN[i] * (Q_NULL[i] - q[i]));
            for i in 0..7 {
                if q[i] > self.q_max[i] - 0.1 {
                    q_null[i] += 20.0 * (self.q_max[i] - 0.1 - q[i]);
                }
                if q[i] < self.q_min[i] + 0.1 {
                    q_null[i] += 20.0 * (self.q_min[i] + 0.1 - q[i]);
                }
            }
            let e = Vector6::from_fn(|r, _| KP[r] * if r < 3 { e_p[r] } else { e_o[r - 3] });
            let a: Matrix6<f64> = j * j.transpose() + Matrix6::identity() * 1e-6;
            let Some(chol) = a.cholesky() else {
                return IkSolution {
                    q: q.map(|v| v as f32),
                    iterations,
                    error,
                };
            };
            let y = chol.solve(&(e - j * q_null));
            let v = j.transpose() * y + q_null;
            qd = std::array::from_fn(|i| v[i]);
            iterations += 1;
        }
    }
}

/// Parameters of `reset_arm_by_ik`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmIkParams {
    /// The robot articulation.
    pub robot: String,
    /// The box (the tcp goes above its reset position).
    pub object: String,
    /// The controlled frame.
    pub frame: String,
    /// Desired tcp position relative to the box origin.
    pub offset: (f32, f32, f32),
    /// Desired tcp orientation `(w, x, y, z)`.
    pub orientation: (f32, f32, f32, f32),
    /// IK start configuration.
    pub q_start: [f32; 7],
    /// Joint limits used by the IK clamp (Fancy Gym's official Franka limits).
    pub q_min: [f64; 7],
    /// Upper joint limits.
    pub q_max: [f64; 7],
}

impl Default for ArmIkParams {
    fn default() -> Self {
        Self {
            robot: "robot".into(),
            object: "box".into(),
            frame: "tcp".into(),
            offset: (0.0, 0.0, 0.15),
            orientation: (0.0, 1.0, 0.0, 0.0),
            q_start: [0.0, 0.0, 0.0, -1.5, 0.0, 1.5, 0.0],
            q_min: [
                -2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973,
            ],
            q_max: [2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973],
        }
    }
}

/// `reset_arm_by_ik`: places the arm so the tcp is at the box position + `offset` with the given
/// orientation (Fancy Gym's reset; run it after the events that place the box).
struct ArmIk {
    ik: OfflineIk,
    robot: usize,
    object: usize,
    p: ArmIkParams,
}

impl EventTerm for ArmIk {
    fn apply(
        &mut self,
        scene: &mut Scene,
        env_ids: &[usize],
        _rng: &mut EnvRngs,
    ) -> Result<(), EnvError> {
        let boxes = scene.backend.rigid_object(self.object).pos.to_vec();
        let (w, x, y, z) = self.p.orientation;
        let d = Quat::from_xyzw(x, y, z, w).normalize();
        let dofs = 7;
        let mut pos = Vec::with_capacity(env_ids.len() * dofs);
        for &e in env_ids {
            let target = boxes[e] + Vec3::new(self.p.offset.0, self.p.offset.1, self.p.offset.2);
            let sol = self.ik.solve(target, d, self.p.q_start);
            pos.extend_from_slice(&sol.q);
        }
        let vel = vec![0.0; pos.len()];
        scene
            .backend
            .write_joint_state(self.robot, env_ids, &pos, &vel)?;
        Ok(())
    }
}

fn build(ctx: &TermContext<'_>) -> Result<Box<dyn EventTerm>, EnvError> {
    let p: ArmIkParams = ctx.params()?;
    let f = |s: &str| format!("{}.params.{s}", ctx.field);
    let robot = ctx.scene.articulation(&f("robot"), &p.robot)?;
    let object = ctx.scene.rigid_object(&f("object"), &p.object)?;
    let tcp = ctx.scene.frame(&f("frame"), robot, &p.frame)?;
    let desc = &ctx.scene.desc.articulations[robot];
    if desc.num_dofs() != 7 {
        return Err(ctx.error(format!(
            "the IK reset needs a 7-dof arm, `{}` has {}",
            p.robot,
            desc.num_dofs()
        )));
    }
    let ik = OfflineIk::new(
        ArticulationKinematics::new(&desc.model),
        desc.root_pose,
        tcp,
        p.q_min,
        p.q_max,
    );
    Ok(Box::new(ArmIk {
        ik,
        robot,
        object,
        p,
    }))
}

inventory::submit! { EventTermDef { name: "reset_arm_by_ik", build } }
