//! One environment: a rapier world holding the scene's articulations (as reduced-coordinate
//! multibodies), free rigid objects and static fixtures.

// Dof loops index several parallel per-dof arrays at once; an index reads clearest there.
#![allow(clippy::needless_range_loop)]

use glam::{Quat, Vec3};
use orbit_core::kinematics::ArticulationKinematics;
use orbit_core::math::Pose as OrbitPose;
use orbit_core::physics::{BodyRef, PhysicsError, SimCfg};
use orbit_core::scene::{Inertial, JointDrive, RootState, SceneDesc};
use rapier3d::prelude::*;

use crate::DEFAULT_SOLVER_ITERATIONS;
use crate::build::{add_body, build_articulation, mass_props, to_rapier_pose};
use crate::hooks::ContactHooks;

/// Most degrees of freedom of one articulation (size of the stack buffer used for state writes).
pub(crate) const MAX_DOFS: usize = 64;

/// Per-env handles and scratch of one articulation.
pub(crate) struct EnvArticulation {
    /// Rigid body of each link.
    pub links: Vec<RigidBodyHandle>,
    /// Multibody index.
    pub multibody: MultibodyIndex,
    /// Multibody link id of each dof.
    pub dof_mb_link: Vec<usize>,
    /// Spatial axis (0..6) of each dof in its joint's coordinates.
    pub dof_axis: Vec<usize>,
    /// Link index owning each dof.
    pub dof_link: Vec<usize>,
    /// Kinematics and dynamics of this env's copy (per-env masses).
    pub kin: ArticulationKinematics,
    /// Root pose: the fixed base's, or a floating base's as of the last look.
    pub root: OrbitPose,
    /// Whether the root is welded to the world (else the multibody's first six dofs are a
    /// free joint: the root's centre-of-mass velocity and its angular velocity, world axes).
    pub fixed_base: bool,
    /// A floating root link's centre of mass in its frame: the origin of its rigid body (zero
    /// for a fixed base).
    pub root_com: Vec3,
    /// This env's published state.
    pub out: ArticulationRow,
    /// Passive joint damping of each dof (the drive's damping is added while it is active).
    pub joint_damping: Vec<f32>,
    /// Passive spring of each dof: stiffness and rest position.
    pub springs: Vec<(f32, f32)>,
    /// Explicit effort applied to each dof in the current step.
    pub effort: Vec<f32>,
}

/// One env's published state of one articulation.
pub(crate) struct ArticulationRow {
    pub q: Vec<f32>,
    pub qd: Vec<f32>,
    pub bias: Vec<f32>,
    pub applied: Vec<f32>,
    pub link_pos: Vec<Vec3>,
    pub link_quat: Vec<Quat>,
    pub link_lin_vel: Vec<Vec3>,
    pub link_ang_vel: Vec<Vec3>,
}

impl ArticulationRow {
    pub(crate) fn new(n_dofs: usize, n_links: usize) -> Self {
        Self {
            q: vec![0.0; n_dofs],
            qd: vec![0.0; n_dofs],
            bias: vec![0.0; n_dofs],
            applied: vec![0.0; n_dofs],
            link_pos: vec![Vec3::ZERO; n_links],
            link_quat: vec![Quat::IDENTITY; n_links],
            link_lin_vel: vec![Vec3::ZERO; n_links],
            link_ang_vel: vec![Vec3::ZERO; n_links],
        }
    }
}

/// One environment's physics world.
pub(crate) struct EnvWorld {
    pub world: PhysicsWorld,
    pub arts: Vec<EnvArticulation>,
    pub objects: Vec<RigidBodyHandle>,
}

impl EnvWorld {
    /// Builds one env of the scene.
    pub fn build(scene: &SceneDesc, sim: &SimCfg) -> Result<Self, PhysicsError> {
        let mut world = PhysicsWorld::new();
        world.gravity = sim.gravity;
        world.integration_parameters.dt = sim.dt;
        world.integration_parameters.num_solver_iterations =
            sim.iterations_or(DEFAULT_SOLVER_ITERATIONS);
        for s in &scene.static_objects {
            add_body(&mut world, &s.body, &s.pose, false);
        }
        let objects = scene
            .rigid_objects
            .iter()
            .map(|o| add_body(&mut world, &o.body, &o.default_root_state.pose, true))
            .collect();
        let arts = scene
            .articulations
            .iter()
            .enumerate()
            .map(|(i, a)| build_articulation(&mut world, a, i))
            .collect::<Result<Vec<_>, _>>()?;
        let mut env = Self {
            world,
            arts,
            objects,
        };
        for (o, desc) in scene.rigid_objects.iter().enumerate() {
            env.write_root_state(o, &desc.default_root_state);
        }
        for (a, desc) in scene.articulations.iter().enumerate() {
            if !desc.fixed_base {
                env.write_articulation_root_state(a, &desc.default_root_state());
            }
            env.write_joint_state(a, &desc.default_joint_pos, &desc.default_joint_vel);
        }
        Ok(env)
    }

    /// Refreshes the published state of articulation `a` from the simulation: joint state,
    /// link poses and velocities (from the joint state), bias forces and the applied-effort
    /// estimate `clip(k (q* − q) + d (q̇* − q̇) + τ_ff)`.
    pub fn publish(
        &mut self,
        a: usize,
        gravity: Vec3,
        drives: &[JointDrive],
        input: &ArticulationInputs<'_>,
    ) {
        let root = self.read_articulation_root_state(a);
        let art = &mut self.arts[a];
        art.root = root.pose;
        let mb = self
            .world
            .multibody_joints
            .get_multibody(art.multibody)
            .expect("multibody exists");
        let out = &mut art.out;
        joint_state(mb, &art.dof_mb_link, &art.dof_axis, &mut out.q, &mut out.qd);
        for d in 0..out.q.len() {
            let dr = &drives[d];
            // `out.bias` still holds the step's starting state (recomputed below).
            let tau = dr.stiffness * (input.pos_target[d] - out.q[d])
                + dr.damping * (input.vel_target[d] - out.qd[d])
                + input.effort(d, &out.bias);
            out.applied[d] = tau.clamp(-dr.effort_limit, dr.effort_limit);
        }
        art.kin.bias_forces(
            &art.root,
            root.ang_vel,
            &out.q,
            &out.qd,
            gravity,
            &mut out.bias,
        );
        // `bias_forces` ran forward kinematics on the current state.
        art.kin.link_velocities(
            root.lin_vel,
            root.ang_vel,
            &out.qd,
            &mut out.link_lin_vel,
            &mut out.link_ang_vel,
        );
        let poses = art.kin.forward(&art.root, &out.q);
        for (l, p) in poses.iter().enumerate() {
            out.link_pos[l] = p.pos;
            out.link_quat[l] = p.rot;
        }
    }

    /// Overwrites joint positions and velocities of articulation `a`.
    pub fn write_joint_state(&mut self, a: usize, q: &[f32], qd: &[f32]) {
        let art = &self.arts[a];
        let mb = self
            .world
            .multibody_joints
            .get_multibody_mut(art.multibody)
            .expect("multibody exists");
        let mut disp = [0.0f32; MAX_DOFS];
        let n = mb.ndofs();
        for d in 0..q.len() {
            let link = mb.link(art.dof_mb_link[d]).expect("link exists");
            disp[link.assembly_id()] = q[d] - link.joint().coords()[art.dof_axis[d]];
        }
        mb.apply_displacements(&disp[..n]);
        for d in 0..q.len() {
            let id = mb
                .link(art.dof_mb_link[d])
                .expect("link exists")
                .assembly_id();
            mb.generalized_velocity_mut()[id] = qd[d];
        }
        mb.forward_kinematics(&self.world.bodies, false);
        mb.update_rigid_bodies(&mut self.world.bodies, true);
        self.sync_link_velocities(a);
    }

    /// Gives the link bodies of articulation `a` the velocities of its multibody's joint and
    /// root state (after the multibody's link poses were updated).
    fn sync_link_velocities(&mut self, a: usize) {
        let root = self.read_articulation_root_state(a);
        let (mut q, mut qd) = ([0.0f32; MAX_DOFS], [0.0f32; MAX_DOFS]);
        let art = &mut self.arts[a];
        let n = art.dof_link.len();
        let mb = self
            .world
            .multibody_joints
            .get_multibody(art.multibody)
            .expect("multibody exists");
        joint_state(
            mb,
            &art.dof_mb_link,
            &art.dof_axis,
            &mut q[..n],
            &mut qd[..n],
        );
        let (q, qd) = (&q[..n], &qd[..n]);
        art.root = root.pose;
        art.kin.forward(&art.root, q);
        let out = &mut art.out;
        art.kin.link_velocities(
            root.lin_vel,
            root.ang_vel,
            qd,
            &mut out.link_lin_vel,
            &mut out.link_ang_vel,
        );
        let first = usize::from(art.fixed_base);
        for (l, &h) in art.links.iter().enumerate().skip(first) {
            let rb = &mut self.world.bodies[h];
            let origin = art.kin.frame_pose(l, &OrbitPose::IDENTITY).pos;
            let com = rb.center_of_mass();
            rb.set_linvel(
                out.link_lin_vel[l] + out.link_ang_vel[l].cross(com - origin),
                true,
            );
            rb.set_angvel(out.link_ang_vel[l], true);
        }
    }

    /// The root link's state of articulation `a` (velocity of the link origin; at rest for a
    /// fixed base).
    pub fn read_articulation_root_state(&self, a: usize) -> RootState {
        let art = &self.arts[a];
        if art.fixed_base {
            return RootState {
                pose: art.root,
                lin_vel: Vec3::ZERO,
                ang_vel: Vec3::ZERO,
            };
        }
        let mb = self
            .world
            .multibody_joints
            .get_multibody(art.multibody)
            .expect("multibody exists");
        let p = mb.root().local_to_world();
        let com = p.rotation * art.root_com;
        let pose = OrbitPose::new(p.translation - com, p.rotation);
        let v = mb.generalized_velocity();
        let (v_com, w) = (Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]));
        RootState {
            pose,
            lin_vel: v_com - w.cross(com),
            ang_vel: w,
        }
    }

    /// Overwrites the root state of floating-base articulation `a` (velocity of the root link's
    /// origin); the joint state is kept.
    pub fn write_articulation_root_state(&mut self, a: usize, s: &RootState) {
        let art = &self.arts[a];
        debug_assert!(
            !art.fixed_base,
            "the backend refuses root writes to a fixed base"
        );
        let root = art.links[0];
        let com = s.pose.rot * art.root_com;
        let body = OrbitPose::new(s.pose.pos + com, s.pose.rot);
        self.world.bodies[root].set_position(to_rapier_pose(&body), true);
        let mb = self
            .world
            .multibody_joints
            .get_multibody_mut(art.multibody)
            .expect("multibody exists");
        mb.forward_kinematics(&self.world.bodies, true);
        mb.update_rigid_bodies(&mut self.world.bodies, true);
        let v_com = s.lin_vel + s.ang_vel.cross(com);
        let mut v = mb.generalized_velocity_mut();
        for i in 0..3 {
            v[i] = v_com[i];
            v[3 + i] = s.ang_vel[i];
        }
        self.sync_link_velocities(a);
    }

    /// Overwrites the root state of rigid object `o` (velocities of the body origin).
    pub fn write_root_state(&mut self, o: usize, s: &RootState) {
        let rb = &mut self.world.bodies[self.objects[o]];
        rb.set_position(to_rapier_pose(&s.pose), true);
        let com = s.pose.transform_point(rb.local_center_of_mass());
        rb.set_linvel(s.lin_vel + s.ang_vel.cross(com - s.pose.pos), true);
        rb.set_angvel(s.ang_vel, true);
        rb.reset_forces(false);
        rb.reset_torques(false);
    }

    /// Root state of rigid object `o` (velocity of the body origin).
    pub fn read_root_state(&self, o: usize) -> RootState {
        let rb = &self.world.bodies[self.objects[o]];
        let p = rb.position();
        let pose = OrbitPose::new(p.translation, p.rotation);
        RootState {
            pose,
            lin_vel: rb.velocity_at_point(pose.pos),
            ang_vel: rb.angvel(),
        }
    }

    /// Advances the world one step (after [`apply_inputs`](Self::apply_inputs)).
    pub fn step_world(&mut self, drives: &[&[JointDrive]]) {
        self.world.step_with_events(&ContactHooks, &());
        for (a, drive) in drives.iter().enumerate() {
            self.clamp_velocities(a, drive);
        }
    }

    /// Sets the motors' targets and applies the joint efforts of articulation `a`.
    pub fn apply_inputs(
        &mut self,
        a: usize,
        drives: &[JointDrive],
        input: &ArticulationInputs<'_>,
    ) {
        let art = &mut self.arts[a];
        let mb = self
            .world
            .multibody_joints
            .get_multibody_mut(art.multibody)
            .expect("multibody exists");
        // Implicit PD: while the drive effort stays within its limit, it is a joint spring of
        // stiffness k at rest position q* plus damping d, both integrated implicitly by the
        // multibody (`M + h d + h² k` on the diagonal), and the explicit effort d q̇* completes
        // d (q̇* − q̇⁺). A drive that would exceed its limit is replaced by the saturated effort.
        for d in 0..drives.len() {
            let drive = &drives[d];
            let id = mb
                .link(art.dof_mb_link[d])
                .expect("link exists")
                .assembly_id();
            let mut effort = input.effort(d, &art.out.bias);
            let (mut k, mut q_rest, mut damping) = (0.0, 0.0, art.joint_damping[d]);
            let (spring, spring_ref) = art.springs[d];
            let driven = drive.stiffness > 0.0 || drive.damping > 0.0;
            // The joint position, read only where a drive or a spring needs it.
            let q = if driven || spring != 0.0 {
                mb.link(art.dof_mb_link[d])
                    .expect("link exists")
                    .joint()
                    .coords()[art.dof_axis[d]]
            } else {
                0.0
            };
            if driven {
                let v = mb.generalized_velocity()[id];
                let pd = drive.stiffness * (input.pos_target[d] - q)
                    + drive.damping * (input.vel_target[d] - v);
                if (pd + effort).abs() <= drive.effort_limit {
                    (k, q_rest) = (drive.stiffness, input.pos_target[d]);
                    damping += drive.damping;
                    effort += drive.damping * input.vel_target[d];
                } else {
                    effort += pd;
                }
            }
            // A passive spring (MuJoCo's joint `stiffness`) is explicit and no actuator's part.
            art.effort[d] =
                effort.clamp(-drive.effort_limit, drive.effort_limit) - spring * (q - spring_ref);
            mb.damping_mut()[id] = damping;
            let link = mb.link_mut(art.dof_mb_link[d]).expect("link exists");
            link.joint.set_spring(art.dof_axis[d], k, q_rest);
        }
        for &h in &art.links {
            let rb = &mut self.world.bodies[h];
            rb.reset_torques(false);
            rb.reset_forces(false);
        }
        let model = art.kin.model();
        for d in 0..drives.len() {
            let tau = art.effort[d];
            if tau == 0.0 {
                continue;
            }
            let child = art.dof_link[d];
            let parent = model.links[child].parent.expect("dof link has a parent");
            let (ch, ph) = (art.links[child], art.links[parent]);
            let child_rb = &self.world.bodies[ch];
            let axis_local = model.links[child].joint.as_ref().expect("joint").axis;
            let axis = child_rb.rotation() * axis_local;
            if art.dof_axis[d] == 3 {
                self.world.bodies[ch].add_torque(axis * tau, true);
                self.world.bodies[ph].add_torque(-axis * tau, true);
            } else {
                // Equal and opposite forces along one line of action: the parent also gets the
                // moment that keeps the pair's net wrench zero.
                let f = axis * tau;
                let c_child = self.world.bodies[ch].center_of_mass();
                let c_parent = self.world.bodies[ph].center_of_mass();
                self.world.bodies[ch].add_force(f, true);
                let prb = &mut self.world.bodies[ph];
                prb.add_force(-f, true);
                prb.add_torque((c_child - c_parent).cross(f), true);
            }
        }
    }

    fn clamp_velocities(&mut self, a: usize, drives: &[JointDrive]) {
        if drives.iter().all(|d| d.velocity_limit.is_infinite()) {
            return;
        }
        let art = &self.arts[a];
        let mb = self
            .world
            .multibody_joints
            .get_multibody_mut(art.multibody)
            .expect("multibody exists");
        for (d, drive) in drives.iter().enumerate() {
            let id = mb
                .link(art.dof_mb_link[d])
                .expect("link exists")
                .assembly_id();
            let v = &mut mb.generalized_velocity_mut()[id];
            *v = v.clamp(-drive.velocity_limit, drive.velocity_limit);
        }
    }

    /// Sets the mass of a body, scaling its inertia; updates the kinematics copy for links.
    pub fn set_mass(&mut self, body: BodyRef, inertial: &Inertial, mass: f32) -> Inertial {
        let scale = if inertial.mass > 0.0 {
            mass / inertial.mass
        } else {
            0.0
        };
        let new = Inertial {
            mass,
            com: inertial.com,
            inertia: inertial.inertia * scale,
        };
        self.set_inertial(body, &new);
        new
    }

    /// The rigid body of `body` (an index already checked by the backend).
    pub fn body(&self, body: BodyRef) -> RigidBodyHandle {
        match body {
            BodyRef::Link { articulation, link } => self.arts[articulation].links[link],
            BodyRef::RigidObject(o) => self.objects[o],
        }
    }

    /// Gives a body the mass properties `inertial` (a link's also in the kinematics that
    /// computes the bias forces).
    pub fn set_inertial(&mut self, body: BodyRef, inertial: &Inertial) {
        let mut in_body = *inertial;
        if let BodyRef::Link { articulation, link } = body {
            let art = &mut self.arts[articulation];
            art.kin.set_inertial(link, *inertial);
            if link == 0 {
                in_body.com -= art.root_com;
            }
        }
        let handle = self.body(body);
        let rb = &mut self.world.bodies[handle];
        rb.set_additional_mass_properties(mass_props(&in_body), true);
        rb.recompute_mass_properties_from_colliders(&self.world.colliders);
    }

    /// Sets the friction of every collider of a body.
    pub fn set_friction(&mut self, handle: RigidBodyHandle, friction: f32) {
        let colliders: Vec<ColliderHandle> = self.world.bodies[handle].colliders().to_vec();
        for c in colliders {
            let col = &mut self.world.colliders[c];
            col.set_friction(friction);
            let mut data = col.user_data;
            data = (data & !0xFFFF_FFFF) | u128::from(friction.to_bits());
            col.user_data = data;
        }
    }
}

/// The joint positions and velocities of a multibody's dofs (each dof's multibody link and
/// the axis of its joint's coordinates).
fn joint_state(
    mb: &Multibody,
    dof_mb_link: &[usize],
    dof_axis: &[usize],
    q: &mut [f32],
    qd: &mut [f32],
) {
    let vel = mb.generalized_velocity();
    for d in 0..q.len() {
        let link = mb.link(dof_mb_link[d]).expect("link exists");
        q[d] = link.joint().coords()[dof_axis[d]];
        qd[d] = vel[link.assembly_id()];
    }
}

/// Per-env input rows of one articulation.
pub(crate) struct ArticulationInputs<'a> {
    pub pos_target: &'a [f32],
    pub vel_target: &'a [f32],
    pub effort: &'a [f32],
    /// Dofs whose effort input gets the bias forces of the step's starting state added.
    pub compensate: &'a [bool],
}

impl ArticulationInputs<'_> {
    /// The effort input of dof `d`, with the bias compensation if enabled.
    fn effort(&self, d: usize, bias: &[f32]) -> f32 {
        self.effort[d] + if self.compensate[d] { bias[d] } else { 0.0 }
    }
}
