//! Kinematics and inverse dynamics of an articulation model in reduced coordinates: forward
//! kinematics, frame Jacobians and the recursive Newton–Euler bias forces (gravity + Coriolis).
//! Backends use it for `bias_forces`; tests and the IK reset use it as ground truth.

use glam::{Mat3, Vec3};

use crate::math::{Pose, rotate_inertia};
use crate::scene::{ArticulationModel, JointKind};

/// Precomputed structure of a model plus reusable scratch space (no allocation per call).
#[derive(Clone, Debug)]
pub struct ArticulationKinematics {
    model: ArticulationModel,
    /// Dof index of each link's joint, if movable.
    link_dof: Vec<Option<usize>>,
    num_dofs: usize,
    poses: Vec<Pose>,
    axes: Vec<Vec3>,
    ang_vel: Vec<Vec3>,
    ang_acc: Vec<Vec3>,
    lin_acc: Vec<Vec3>,
    force: Vec<Vec3>,
    moment: Vec<Vec3>,
}

impl ArticulationKinematics {
    /// Prepares kinematics for a model (fixed joints may be present).
    pub fn new(model: &ArticulationModel) -> Self {
        let mut next = 0;
        let link_dof = model
            .links
            .iter()
            .map(|l| match &l.joint {
                Some(j) if j.kind != JointKind::Fixed => {
                    next += 1;
                    Some(next - 1)
                }
                _ => None,
            })
            .collect();
        let n = model.links.len();
        Self {
            model: model.clone(),
            link_dof,
            num_dofs: next,
            poses: vec![Pose::IDENTITY; n],
            axes: vec![Vec3::ZERO; n],
            ang_vel: vec![Vec3::ZERO; n],
            ang_acc: vec![Vec3::ZERO; n],
            lin_acc: vec![Vec3::ZERO; n],
            force: vec![Vec3::ZERO; n],
            moment: vec![Vec3::ZERO; n],
        }
    }

    /// The model.
    pub fn model(&self) -> &ArticulationModel {
        &self.model
    }

    /// Number of degrees of freedom.
    pub fn num_dofs(&self) -> usize {
        self.num_dofs
    }

    /// Dof index of each link's joint.
    pub fn link_dof(&self) -> &[Option<usize>] {
        &self.link_dof
    }

    /// Computes link poses for joint positions `q` with the root at `root`. Returns the poses
    /// (valid until the next call).
    pub fn forward(&mut self, root: &Pose, q: &[f32]) -> &[Pose] {
        assert_eq!(
            q.len(),
            self.num_dofs,
            "joint position vector has the wrong length"
        );
        for (i, link) in self.model.links.iter().enumerate() {
            let pose = match (link.parent, &link.joint) {
                (Some(p), Some(j)) => {
                    let qi = self.link_dof[i].map_or(0.0, |d| q[d]);
                    self.poses[p].mul_pose(&j.child_pose(qi))
                }
                _ => *root,
            };
            self.poses[i] = pose;
            self.axes[i] = link
                .joint
                .as_ref()
                .map_or(Vec3::ZERO, |j| pose.rot * j.axis);
        }
        &self.poses
    }

    /// Replaces the mass properties of one link (mass randomisation).
    pub fn set_inertial(&mut self, link: usize, inertial: crate::scene::Inertial) {
        self.model.links[link].inertial = inertial;
    }

    /// Link origin velocities `(linear, angular)` in world axes for joint velocities `qd` and
    /// the root link's origin moving at `root_lin_vel` and turning at `root_ang_vel` (zero for
    /// a fixed base), after [`forward`](Self::forward).
    pub fn link_velocities(
        &self,
        root_lin_vel: Vec3,
        root_ang_vel: Vec3,
        qd: &[f32],
        lin: &mut [Vec3],
        ang: &mut [Vec3],
    ) {
        for (i, link) in self.model.links.iter().enumerate() {
            let Some(p) = link.parent else {
                lin[i] = root_lin_vel;
                ang[i] = root_ang_vel;
                continue;
            };
            let r = self.poses[i].pos - self.poses[p].pos;
            let (mut v, mut w) = (lin[p] + ang[p].cross(r), ang[p]);
            if let (Some(d), Some(j)) = (self.link_dof[i], &link.joint) {
                match j.kind {
                    JointKind::Revolute => w += self.axes[i] * qd[d],
                    _ => v += self.axes[i] * qd[d],
                }
            }
            lin[i] = v;
            ang[i] = w;
        }
    }

    /// World axis of each link's joint after [`forward`](Self::forward).
    pub fn joint_axes(&self) -> &[Vec3] {
        &self.axes
    }

    /// World pose of a link-attached frame after [`forward`](Self::forward).
    pub fn frame_pose(&self, link: usize, offset: &Pose) -> Pose {
        self.poses[link].mul_pose(offset)
    }

    /// Geometric Jacobian (world frame) of a point attached to `link`, after
    /// [`forward`](Self::forward): `out[d] = (linear, angular)` column of dof `d`.
    pub fn point_jacobian(&self, link: usize, point: Vec3, out: &mut [(Vec3, Vec3)]) {
        assert_eq!(
            out.len(),
            self.num_dofs,
            "Jacobian buffer has the wrong length"
        );
        out.fill((Vec3::ZERO, Vec3::ZERO));
        let mut cur = Some(link);
        while let Some(i) = cur {
            if let (Some(d), Some(j)) = (self.link_dof[i], &self.model.links[i].joint) {
                let s = self.axes[i];
                out[d] = match j.kind {
                    JointKind::Revolute => (s.cross(point - self.poses[i].pos), s),
                    _ => (s, Vec3::ZERO),
                };
            }
            cur = self.model.links[i].parent;
        }
    }

    /// Generalized bias forces `c(q, q̇) + g(q)` of the joints: the joint efforts that produce
    /// zero joint acceleration while the root does not accelerate either (recursive
    /// Newton–Euler with the root accelerating at `−gravity` and turning at `root_ang_vel`, zero
    /// for a fixed base). For a floating base these are the joint rows of MuJoCo's `qfrc_bias`;
    /// the root's linear velocity does not enter them.
    pub fn bias_forces(
        &mut self,
        root: &Pose,
        root_ang_vel: Vec3,
        q: &[f32],
        qd: &[f32],
        gravity: Vec3,
        out: &mut [f32],
    ) {
        assert_eq!(
            qd.len(),
            self.num_dofs,
            "joint velocity vector has the wrong length"
        );
        assert_eq!(
            out.len(),
            self.num_dofs,
            "output vector has the wrong length"
        );
        self.forward(root, q);
        let links = &self.model.links;
        // Forward pass: velocities and accelerations of link origins (world frame).
        for (i, link) in links.iter().enumerate() {
            let Some(p) = link.parent else {
                self.ang_vel[i] = root_ang_vel;
                self.ang_acc[i] = Vec3::ZERO;
                self.lin_acc[i] = -gravity;
                continue;
            };
            let r = self.poses[i].pos - self.poses[p].pos;
            let (wp, ap) = (self.ang_vel[p], self.ang_acc[p]);
            let mut w = wp;
            let mut alpha = ap;
            let mut acc = self.lin_acc[p] + ap.cross(r) + wp.cross(wp.cross(r));
            if let (Some(d), Some(j)) = (self.link_dof[i], &link.joint) {
                let sq = self.axes[i] * qd[d];
                match j.kind {
                    JointKind::Revolute => {
                        w += sq;
                        alpha += wp.cross(sq);
                    }
                    _ => acc += 2.0 * wp.cross(sq),
                }
            }
            self.ang_vel[i] = w;
            self.ang_acc[i] = alpha;
            self.lin_acc[i] = acc;
        }
        // Backward pass: spatial forces about link origins.
        for i in (0..links.len()).rev() {
            let inertial = &links[i].inertial;
            let pose = self.poses[i];
            let c = pose.rot * inertial.com;
            let (w, alpha) = (self.ang_vel[i], self.ang_acc[i]);
            let a_com = self.lin_acc[i] + alpha.cross(c) + w.cross(w.cross(c));
            let f = a_com * inertial.mass;
            let iw: Mat3 = rotate_inertia(pose.rot, inertial.inertia);
            let n = iw * alpha + w.cross(iw * w) + c.cross(f);
            self.force[i] += f;
            self.moment[i] += n;
            if let Some(d) = self.link_dof[i] {
                let s = self.axes[i];
                out[d] = match links[i].joint.as_ref().map(|j| j.kind) {
                    Some(JointKind::Revolute) => s.dot(self.moment[i]),
                    _ => s.dot(self.force[i]),
                };
            }
            if let Some(p) = links[i].parent {
                let r = pose.pos - self.poses[p].pos;
                let (fi, ni) = (self.force[i], self.moment[i]);
                self.force[p] += fi;
                self.moment[p] += ni + r.cross(fi);
            }
            self.force[i] = Vec3::ZERO;
            self.moment[i] = Vec3::ZERO;
        }
    }
}
