//! Differential inverse kinematics (Isaac Lab's `DifferentialIKController` and
//! `DifferentialInverseKinematicsAction`): a task-space command on a robot frame becomes joint
//! position targets `q + Δq` every physics step, with `Δq` from the frame Jacobian by damped least
//! squares, pseudo-inverse, SVD with a singular-value floor, or Jacobian transpose.

use glam::{Quat, Vec3};
use nalgebra::{DMatrix, DVector};
use orbit_core::kinematics::ArticulationKinematics;
use orbit_core::math::Pose;
use serde::Deserialize;

use crate::error::EnvError;
use crate::mdp::JointSel;
use crate::scene::Scene;
use crate::term::{ActionTerm, ActionTermDef, TermContext};

/// How `Δq` is computed from the Jacobian `J` and the task error `e`.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum IkMethod {
    /// Damped least squares `Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e`.
    Dls {
        /// Damping λ (Isaac Lab default 0.01).
        lambda_val: f32,
    },
    /// Moore–Penrose pseudo-inverse `Δq = k J⁺ e`.
    Pinv {
        /// Gain (default 1).
        k_val: f32,
    },
    /// SVD pseudo-inverse ignoring singular values below `min_singular_value`.
    Svd {
        /// Gain.
        k_val: f32,
        /// Singular values below this are treated as zero.
        min_singular_value: f32,
    },
    /// Jacobian transpose `Δq = k Jᵀ e`.
    Trans {
        /// Gain.
        k_val: f32,
    },
}

/// `Δq` for task error `e` (length = rows of `j`).
pub fn solve_ik(method: IkMethod, j: &DMatrix<f64>, e: &DVector<f64>) -> DVector<f64> {
    match method {
        IkMethod::Dls { lambda_val } => {
            let l2 = f64::from(lambda_val).powi(2);
            let jjt = j * j.transpose() + DMatrix::identity(j.nrows(), j.nrows()) * l2;
            match jjt.cholesky() {
                Some(c) => j.transpose() * c.solve(e),
                None => DVector::zeros(j.ncols()),
            }
        }
        IkMethod::Pinv { k_val } => match j.clone().pseudo_inverse(1e-12) {
            Ok(p) => p * e * f64::from(k_val),
            Err(_) => DVector::zeros(j.ncols()),
        },
        IkMethod::Svd {
            k_val,
            min_singular_value,
        } => {
            let svd = j.clone().svd(true, true);
            let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
                return DVector::zeros(j.ncols());
            };
            let ut_e = u.transpose() * e;
            let scaled = DVector::from_iterator(
                ut_e.len(),
                ut_e.iter().zip(svd.singular_values.iter()).map(|(x, s)| {
                    if *s > f64::from(min_singular_value) {
                        x / s
                    } else {
                        0.0
                    }
                }),
            );
            vt.transpose() * scaled * f64::from(k_val)
        }
        IkMethod::Trans { k_val } => j.transpose() * e * f64::from(k_val),
    }
}

/// Command dimensions: position (3) or pose (7 absolute, 6 relative).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum IkCommand {
    /// Position only; the orientation is held at its value when the command was set.
    Position,
    /// Position and orientation.
    Pose,
}

/// Parameters of `differential_ik`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffIkParams {
    /// Articulation name.
    #[serde(default = "robot")]
    pub asset: String,
    /// Joint-name regexes of the joints IK may move.
    pub joint_names: Vec<String>,
    /// Controlled link or frame (e.g. `tcp`).
    pub body_name: String,
    /// Offset of the controlled point from that frame.
    #[serde(default)]
    pub body_offset: Pose,
    /// Scale of the raw action.
    #[serde(default = "one")]
    pub scale: f32,
    /// Command type.
    pub command_type: IkCommand,
    /// Relative (delta) commands instead of absolute targets.
    #[serde(default)]
    pub use_relative_mode: bool,
    /// IK method and its parameters.
    pub ik_method: IkMethod,
    /// Also apply the bias forces (gravity compensation) as feed-forward effort.
    #[serde(default)]
    pub compensate_bias: bool,
}

fn robot() -> String {
    "robot".into()
}
fn one() -> f32 {
    1.0
}

impl Default for DiffIkParams {
    fn default() -> Self {
        Self {
            asset: robot(),
            joint_names: vec![],
            body_name: String::new(),
            body_offset: Pose::IDENTITY,
            scale: 1.0,
            command_type: IkCommand::Pose,
            use_relative_mode: false,
            ik_method: IkMethod::Dls { lambda_val: 0.01 },
            compensate_bias: false,
        }
    }
}

/// The differential-IK action term.
struct DiffIkAction {
    p: DiffIkParams,
    sel: JointSel,
    frame: (usize, Pose),
    root: Pose,
    kin: ArticulationKinematics,
    processed: Vec<f32>,
    /// Desired pose per env (env frame), set once per env step.
    desired: Vec<Pose>,
    targets: Vec<f32>,
    /// Bias compensation has been handed to the backend (on the first `apply`).
    compensation_enabled: bool,
    jac: Vec<(Vec3, Vec3)>,
    q: Vec<f32>,
}

impl DiffIkAction {
    fn dim_of(p: &DiffIkParams) -> usize {
        match (p.command_type, p.use_relative_mode) {
            (IkCommand::Position, _) => 3,
            (IkCommand::Pose, false) => 7,
            (IkCommand::Pose, true) => 6,
        }
    }

    /// Current pose of the controlled point in env `e` (updates the kinematics).
    fn current_pose(&mut self, scene: &Scene, e: usize) -> Pose {
        let n = self.sel.num_dofs;
        let view = scene.backend.articulation(self.sel.articulation);
        self.q.copy_from_slice(&view.joint_pos[e * n..(e + 1) * n]);
        let poses = self.kin.forward(&self.root, &self.q);
        poses[self.frame.0]
            .mul_pose(&self.frame.1)
            .mul_pose(&self.p.body_offset)
    }
}

impl ActionTerm for DiffIkAction {
    fn dim(&self) -> usize {
        Self::dim_of(&self.p)
    }

    fn process(&mut self, scene: &Scene, raw: &[f32]) {
        let d = self.dim();
        for (o, r) in self.processed.iter_mut().zip(raw) {
            *o = r * self.p.scale;
        }
        for e in 0..scene.num_envs() {
            let cur = self.current_pose(scene, e);
            let c = &self.processed[e * d..(e + 1) * d];
            let v = Vec3::new(c[0], c[1], c[2]);
            self.desired[e] = match (self.p.command_type, self.p.use_relative_mode) {
                (IkCommand::Position, false) => Pose::new(v, cur.rot),
                (IkCommand::Position, true) => Pose::new(cur.pos + v, cur.rot),
                (IkCommand::Pose, false) => {
                    let q = Quat::from_xyzw(c[4], c[5], c[6], c[3]);
                    let rot = if q.length() > 1e-6 {
                        q.normalize()
                    } else {
                        cur.rot
                    };
                    Pose::new(v, rot)
                }
                (IkCommand::Pose, true) => {
                    let r = Vec3::new(c[3], c[4], c[5]);
                    let dq = if r.length() > 1e-6 {
                        Quat::from_scaled_axis(r)
                    } else {
                        Quat::IDENTITY
                    };
                    Pose::new(cur.pos + v, (dq * cur.rot).normalize())
                }
            };
        }
    }

    fn apply(&mut self, scene: &mut Scene) -> Result<(), EnvError> {
        let n = self.sel.num_dofs;
        let rows = if self.p.command_type == IkCommand::Position {
            3
        } else {
            6
        };
        let cols = self.sel.dofs.len();
        for e in 0..scene.num_envs() {
            let cur = self.current_pose(scene, e);
            self.kin
                .point_jacobian(self.frame.0, cur.pos, &mut self.jac);
            let mut j = DMatrix::<f64>::zeros(rows, cols);
            for (c, &dof) in self.sel.dofs.iter().enumerate() {
                let (lin, ang) = self.jac[dof];
                for r in 0..3 {
                    j[(r, c)] = f64::from(lin[r]);
                    if rows == 6 {
                        j[(r + 3, c)] = f64::from(ang[r]);
                    }
                }
            }
            let des = self.desired[e];
            let dp = des.pos - cur.pos;
            let mut err = DVector::<f64>::zeros(rows);
            for r in 0..3 {
                err[r] = f64::from(dp[r]);
            }
            if rows == 6 {
                let mut dq = des.rot * cur.rot.conjugate();
                if dq.w < 0.0 {
                    dq = -dq;
                }
                let axis_angle = dq.to_scaled_axis();
                for r in 0..3 {
                    err[r + 3] = f64::from(axis_angle[r]);
                }
            }
            let delta = solve_ik(self.p.ik_method, &j, &err);
            let row = &mut self.targets[e * n..(e + 1) * n];
            row.copy_from_slice(&self.q);
            for (c, &dof) in self.sel.dofs.iter().enumerate() {
                row[dof] = self.q[dof] + delta[c] as f32;
            }
        }
        let art = self.sel.articulation;
        scene
            .backend
            .set_joint_position_targets(art, &self.targets)?;
        if self.p.compensate_bias && !self.compensation_enabled {
            self.sel.enable_bias_compensation(scene)?;
            self.compensation_enabled = true;
        }
        Ok(())
    }

    fn processed(&self) -> &[f32] {
        &self.processed
    }
}

fn build(ctx: &TermContext<'_>) -> Result<Box<dyn ActionTerm>, EnvError> {
    let p: DiffIkParams = ctx.params()?;
    let sel = JointSel::resolve(
        ctx,
        &crate::mdp::JointsParams {
            asset: p.asset.clone(),
            joint_names: p.joint_names.clone(),
        },
    )?;
    let frame = ctx.scene.frame(
        &format!("{}.params.body_name", ctx.field),
        sel.articulation,
        &p.body_name,
    )?;
    let desc = &ctx.scene.desc.articulations[sel.articulation];
    let n = ctx.scene.num_envs();
    let d = DiffIkAction::dim_of(&p);
    let dofs = sel.num_dofs;
    Ok(Box::new(DiffIkAction {
        frame,
        root: desc.root_pose,
        kin: ArticulationKinematics::new(&desc.model),
        processed: vec![0.0; n * d],
        desired: vec![Pose::IDENTITY; n],
        targets: desc.default_joint_pos.repeat(n),
        compensation_enabled: false,
        jac: vec![(Vec3::ZERO, Vec3::ZERO); dofs],
        q: vec![0.0; dofs],
        sel,
        p,
    }))
}

inventory::submit! { ActionTermDef { name: "differential_ik", build } }

#[cfg(test)]
mod tests {
    use super::*;

    /// A redundant 3×4 Jacobian with a reachable error: dls, pinv and svd produce `Δq` with
    /// `J Δq ≈ e` (dls within its damping), and transpose gives exactly `k Jᵀ e`.
    #[test]
    fn solvers_reach_a_reachable_error() {
        let j = DMatrix::from_row_slice(
            3,
            4,
            &[1.0, 0.5, 0.0, 0.2, 0.0, 1.0, 0.3, 0.0, 0.2, 0.0, 1.0, 0.5],
        );
        let e = DVector::from_vec(vec![0.01, -0.02, 0.015]);
        for (m, tol) in [
            (IkMethod::Pinv { k_val: 1.0 }, 1e-9),
            (
                IkMethod::Svd {
                    k_val: 1.0,
                    min_singular_value: 1e-5,
                },
                1e-9,
            ),
            (IkMethod::Dls { lambda_val: 0.01 }, 2e-4 * e.norm()),
        ] {
            let dq = solve_ik(m, &j, &e);
            assert!(
                (&j * &dq - &e).norm() < tol,
                "{m:?}: residual {}",
                (&j * &dq - &e).norm()
            );
        }
        let dq = solve_ik(IkMethod::Trans { k_val: 2.0 }, &j, &e);
        assert!((dq - j.transpose() * &e * 2.0).norm() < 1e-15);
        // The pseudo-inverse gives the minimum-norm solution: it lies in the row space of J,
        // so projecting it onto that space leaves it unchanged.
        let dq = solve_ik(IkMethod::Pinv { k_val: 1.0 }, &j, &e);
        let jt = j.transpose();
        let projected = &jt * (&j * &jt).try_inverse().unwrap() * &j * &dq;
        assert!((projected - &dq).norm() < 1e-12);
    }

    /// A singular direction (zero column) is ignored by the SVD floor instead of blowing up.
    #[test]
    fn svd_floor_ignores_singular_directions() {
        let j = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, 1e-9]);
        let e = DVector::from_vec(vec![0.1, 0.1]);
        let dq = solve_ik(
            IkMethod::Svd {
                k_val: 1.0,
                min_singular_value: 1e-5,
            },
            &j,
            &e,
        );
        assert!((dq[0] - 0.1).abs() < 1e-12 && dq[1].abs() < 1e-12, "{dq:?}");
    }
}
