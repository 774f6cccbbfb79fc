//! The CPU physics backend: one [rapier3d](https://rapier.rs) world per env, stepped in
//! parallel with rayon. Articulations are rapier multibodies (reduced coordinates); free objects
//! are rigid bodies; fixtures are fixed bodies.
//!
//! Physical model (see `docs/physics.md`):
//! - implicit PD drives are the multibody's implicit joint springs and damping
//!   (`M + h d + h² k` on the mass-matrix diagonal, solved directly), switched to the saturated
//!   effort when the drive would exceed its effort limit;
//! - joint efforts are equal and opposite torques on a joint's two links, which the multibody
//!   maps to exactly the generalized force on that joint;
//! - velocity limits clamp the joint speed after each step (PhysX's max joint velocity);
//! - bias forces are computed by recursive Newton–Euler on the same model.

mod build;
mod env_world;
mod hooks;

use glam::{Quat, Vec3};
use orbit_core::math::Pose;
use orbit_core::physics::{
    ArticulationView, BackendProbe, BackendRegistration, BodyRef, DeviceKind, PhysicsBackend,
    PhysicsError, RigidObjectView, SceneLayout, SimCfg, check_batch, check_dof_ids, check_env_ids,
    check_floating_base, check_root_states, check_values,
};
use orbit_core::scene::{Inertial, JointDrive, RootState, SceneDesc};
use rayon::prelude::*;

use env_world::{ArticulationInputs, EnvWorld};

/// Name under which this backend is registered.
pub const BACKEND_NAME: &str = "rapier";
/// Velocity-solver iterations when `sim.solver_iterations` is 0 (the default).
pub const DEFAULT_SOLVER_ITERATIONS: usize = 4;

inventory::submit! {
    BackendRegistration {
        name: BACKEND_NAME,
        description: "CPU: one rapier3d world per env, stepped in parallel with rayon",
        build: |scene, num_envs, sim| Ok(Box::new(RapierBackend::new(scene, num_envs, sim)?)),
        probe: || BackendProbe {
            kind: DeviceKind::Cpu,
            detail: format!(
                "rapier on {} CPU threads",
                std::thread::available_parallelism().map_or(1, |n| n.get())
            ),
        },
    }
}

/// A lower estimate of one env's memory: its rapier world holds every body's rigid body,
/// colliders, contact pairs and solver data, about 12 KiB per body on the box-pushing scene
/// (177 KiB per env measured for 14 bodies); 10 KiB per body keeps the estimate below that.
fn bytes_per_env(scene: &SceneDesc) -> usize {
    let links: usize = scene
        .articulations
        .iter()
        .map(|a| a.model.links.len())
        .sum();
    let bodies = links + scene.rigid_objects.len() + scene.static_objects.len();
    bodies * 10 * 1024
}

/// Batched buffers of one articulation (all envs).
struct ArticulationBuffers {
    dofs: usize,
    links: usize,
    drives: Vec<JointDrive>,
    /// Per-env inertials of each link (mass randomisation).
    inertials: Vec<Inertial>,
    pos_target: Vec<f32>,
    vel_target: Vec<f32>,
    effort: Vec<f32>,
    /// Per dof: add the bias forces to the effort input every step.
    compensate: Vec<bool>,
    joint_pos: Vec<f32>,
    joint_vel: Vec<f32>,
    bias: Vec<f32>,
    applied: Vec<f32>,
    link_pos: Vec<Vec3>,
    link_quat: Vec<Quat>,
    link_lin_vel: Vec<Vec3>,
    link_ang_vel: Vec<Vec3>,
}

/// Batched buffers of one rigid object.
struct ObjectBuffers {
    inertials: Vec<Inertial>,
    pos: Vec<Vec3>,
    quat: Vec<Quat>,
    lin_vel: Vec<Vec3>,
    ang_vel: Vec<Vec3>,
}

/// The rapier CPU backend.
pub struct RapierBackend {
    layout: SceneLayout,
    sim: SimCfg,
    /// The scene, from which an env's world is built anew when its state is written.
    scene: SceneDesc,
    envs: Vec<EnvWorld>,
    /// Per env: its world has not been stepped since it was built, so it holds no contacts.
    unstepped: Vec<bool>,
    /// Per env: the frictions set on its bodies, reapplied when its world is built anew.
    frictions: Vec<Vec<(BodyRef, f32)>>,
    arts: Vec<ArticulationBuffers>,
    objects: Vec<ObjectBuffers>,
    pool: rayon::ThreadPool,
}

/// The part of an env's state that a write replaces (the rest is carried into a new world).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Written {
    Articulation(usize),
    ArticulationRoot(usize),
    Object(usize),
}

impl RapierBackend {
    /// Builds `num_envs` copies of `scene`.
    pub fn new(scene: &SceneDesc, num_envs: usize, sim: &SimCfg) -> Result<Self, PhysicsError> {
        sim.validate()?;
        if num_envs == 0 {
            return Err(PhysicsError::InvalidInput(
                "num_envs must be at least 1".into(),
            ));
        }
        // Held until the worlds are built: data-parallel ranks building beside this count it.
        let _reservation =
            orbit_core::physics::check_host_memory(BACKEND_NAME, num_envs, bytes_per_env(scene))?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(sim.num_threads)
            .build()
            .map_err(|e| PhysicsError::InvalidInput(format!("cannot start worker threads: {e}")))?;
        let envs = pool.install(|| {
            (0..num_envs)
                .into_par_iter()
                .map(|_| EnvWorld::build(scene, sim))
                .collect::<Result<Vec<_>, _>>()
        })?;
        let arts = scene
            .articulations
            .iter()
            .map(|a| {
                let (dofs, links) = (a.num_dofs(), a.model.links.len());
                let tile = |v: &[f32]| v.repeat(num_envs);
                ArticulationBuffers {
                    dofs,
                    links,
                    drives: a.drives.clone(),
                    inertials: a
                        .model
                        .links
                        .iter()
                        .map(|l| l.inertial)
                        .collect::<Vec<_>>()
                        .repeat(num_envs),
                    pos_target: tile(&a.default_joint_pos),
                    vel_target: vec![0.0; num_envs * dofs],
                    effort: vec![0.0; num_envs * dofs],
                    compensate: vec![false; dofs],
                    joint_pos: vec![0.0; num_envs * dofs],
                    joint_vel: vec![0.0; num_envs * dofs],
                    bias: vec![0.0; num_envs * dofs],
                    applied: vec![0.0; num_envs * dofs],
                    link_pos: vec![Vec3::ZERO; num_envs * links],
                    link_quat: vec![Quat::IDENTITY; num_envs * links],
                    link_lin_vel: vec![Vec3::ZERO; num_envs * links],
                    link_ang_vel: vec![Vec3::ZERO; num_envs * links],
                }
            })
            .collect();
        let objects = scene
            .rigid_objects
            .iter()
            .map(|o| ObjectBuffers {
                inertials: vec![o.body.inertial; num_envs],
                pos: vec![Vec3::ZERO; num_envs],
                quat: vec![Quat::IDENTITY; num_envs],
                lin_vel: vec![Vec3::ZERO; num_envs],
                ang_vel: vec![Vec3::ZERO; num_envs],
            })
            .collect();
        let mut backend = Self {
            layout: SceneLayout::from_desc(scene),
            sim: sim.clone(),
            scene: scene.clone(),
            envs,
            unstepped: vec![true; num_envs],
            frictions: vec![Vec::new(); num_envs],
            arts,
            objects,
            pool,
        };
        let all: Vec<usize> = (0..num_envs).collect();
        backend.publish(&all);
        Ok(backend)
    }

    /// Builds the worlds of the listed envs anew before a write of `written`, so that the
    /// write starts a fresh history: rapier keeps each contact pair's impulses from step to step
    /// to warm-start its solver, and a reset env must not start its episode with the last
    /// one's. Everything else carries over: the published state (all but `written`), masses and
    /// frictions. An env not stepped since its world was built is left as it is.
    fn renew(&mut self, env_ids: &[usize], written: Written) -> Result<(), PhysicsError> {
        let stale: Vec<usize> = env_ids
            .iter()
            .copied()
            .filter(|&e| !self.unstepped[e])
            .collect();
        if stale.is_empty() {
            return Ok(());
        }
        let this = &*self;
        let worlds = self.pool.install(|| {
            stale
                .par_iter()
                .map(|&e| this.rebuilt(e, written))
                .collect::<Result<Vec<_>, _>>()
        })?;
        for (e, world) in stale.into_iter().zip(worlds) {
            self.envs[e] = world;
            self.unstepped[e] = true;
        }
        Ok(())
    }

    /// A new world for env `e` in its published state (but for `written`), with its masses and
    /// frictions.
    fn rebuilt(&self, e: usize, written: Written) -> Result<EnvWorld, PhysicsError> {
        let mut env = EnvWorld::build(&self.scene, &self.sim)?;
        for (a, b) in self.arts.iter().enumerate() {
            let links = &self.scene.articulations[a].model.links;
            for (l, link) in links.iter().enumerate() {
                let inertial = b.inertials[e * b.links + l];
                if inertial != link.inertial {
                    let body = BodyRef::Link {
                        articulation: a,
                        link: l,
                    };
                    env.set_inertial(body, &inertial);
                }
            }
            let r = e * b.dofs..(e + 1) * b.dofs;
            // The applied-effort estimate of the next publish adds the last bias forces.
            env.arts[a].out.bias.copy_from_slice(&b.bias[r.clone()]);
            // The root first: a joint-state write gives the links velocities on top of it.
            if !self.layout.articulations[a].fixed_base && written != Written::ArticulationRoot(a) {
                let root = e * b.links;
                let origin = b.link_pos[root];
                let state = RootState {
                    pose: Pose::new(origin, b.link_quat[root]),
                    lin_vel: b.link_lin_vel[root],
                    ang_vel: b.link_ang_vel[root],
                };
                env.write_articulation_root_state(a, &state);
            }
            if written != Written::Articulation(a) {
                env.write_joint_state(a, &b.joint_pos[r.clone()], &b.joint_vel[r]);
            }
        }
        for (o, b) in self.objects.iter().enumerate() {
            if b.inertials[e] != self.scene.rigid_objects[o].body.inertial {
                env.set_inertial(BodyRef::RigidObject(o), &b.inertials[e]);
            }
            if written != Written::Object(o) {
                let state = RootState {
                    pose: Pose::new(b.pos[e], b.quat[e]),
                    lin_vel: b.lin_vel[e],
                    ang_vel: b.ang_vel[e],
                };
                env.write_root_state(o, &state);
            }
        }
        for &(body, friction) in &self.frictions[e] {
            env.set_friction(env.body(body), friction);
        }
        Ok(env)
    }

    /// Input rows of env `e` for every articulation (no allocation: fixed-size array).
    fn inputs_of<'a>(
        arts: &'a [ArticulationBuffers],
        e: usize,
    ) -> impl Iterator<Item = ArticulationInputs<'a>> {
        arts.iter().map(move |b| {
            let r = e * b.dofs..(e + 1) * b.dofs;
            ArticulationInputs {
                pos_target: &b.pos_target[r.clone()],
                vel_target: &b.vel_target[r.clone()],
                effort: &b.effort[r],
                compensate: &b.compensate,
            }
        })
    }

    /// Refreshes the published state of the listed envs (in parallel), then gathers rows.
    fn publish(&mut self, env_ids: &[usize]) {
        let gravity = self.sim.gravity;
        let arts = &self.arts;
        let envs = &mut self.envs;
        let refresh = |e: usize, env: &mut EnvWorld| {
            for (a, input) in Self::inputs_of(arts, e).enumerate() {
                env.publish(a, gravity, &arts[a].drives, &input);
            }
        };
        if env_ids.len() == envs.len() {
            self.pool.install(|| {
                envs.par_iter_mut()
                    .enumerate()
                    .for_each(|(e, env)| refresh(e, env))
            });
        } else {
            for &e in env_ids {
                refresh(e, &mut envs[e]);
            }
        }
        self.gather(env_ids);
    }

    /// Copies the env rows into the batched buffers.
    fn gather(&mut self, env_ids: &[usize]) {
        for &e in env_ids {
            let env = &self.envs[e];
            for (a, b) in self.arts.iter_mut().enumerate() {
                let row = &env.arts[a].out;
                let (d, l) = (e * b.dofs..(e + 1) * b.dofs, e * b.links..(e + 1) * b.links);
                b.joint_pos[d.clone()].copy_from_slice(&row.q);
                b.joint_vel[d.clone()].copy_from_slice(&row.qd);
                b.bias[d.clone()].copy_from_slice(&row.bias);
                b.applied[d].copy_from_slice(&row.applied);
                b.link_pos[l.clone()].copy_from_slice(&row.link_pos);
                b.link_quat[l.clone()].copy_from_slice(&row.link_quat);
                b.link_lin_vel[l.clone()].copy_from_slice(&row.link_lin_vel);
                b.link_ang_vel[l].copy_from_slice(&row.link_ang_vel);
            }
            for (o, b) in self.objects.iter_mut().enumerate() {
                let s = env.read_root_state(o);
                b.pos[e] = s.pose.pos;
                b.quat[e] = s.pose.rot;
                b.lin_vel[e] = s.lin_vel;
                b.ang_vel[e] = s.ang_vel;
            }
        }
    }

    fn check_articulation(&self, a: usize) -> Result<&ArticulationBuffers, PhysicsError> {
        self.arts.get(a).ok_or_else(|| {
            PhysicsError::InvalidInput(format!(
                "articulation index {a} is out of range ({} articulations)",
                self.arts.len()
            ))
        })
    }

    fn set_inputs(
        &mut self,
        a: usize,
        what: &str,
        values: &[f32],
        field: fn(&mut ArticulationBuffers) -> &mut Vec<f32>,
    ) -> Result<(), PhysicsError> {
        let dofs = self.check_articulation(a)?.dofs;
        check_batch(what, values, self.envs.len(), dofs)?;
        field(&mut self.arts[a]).copy_from_slice(values);
        Ok(())
    }

    /// The rigid body and current inertial of a body in env `e`.
    fn body_handle(&self, body: BodyRef) -> Result<(), PhysicsError> {
        match body {
            BodyRef::Link { articulation, link } => {
                let b = self.check_articulation(articulation)?;
                if link >= b.links {
                    return Err(PhysicsError::InvalidInput(format!(
                        "link index {link} is out of range ({} links)",
                        b.links
                    )));
                }
            }
            BodyRef::RigidObject(o) if o >= self.objects.len() => {
                return Err(PhysicsError::InvalidInput(format!(
                    "rigid object index {o} is out of range ({} objects)",
                    self.objects.len()
                )));
            }
            BodyRef::RigidObject(_) => {}
        }
        Ok(())
    }
}

impl PhysicsBackend for RapierBackend {
    fn name(&self) -> &'static str {
        BACKEND_NAME
    }

    fn num_envs(&self) -> usize {
        self.envs.len()
    }

    fn layout(&self) -> &SceneLayout {
        &self.layout
    }

    fn dt(&self) -> f32 {
        self.sim.dt
    }

    fn step(&mut self) -> Result<(), PhysicsError> {
        let arts = &self.arts;
        let gravity = self.sim.gravity;
        self.pool.install(|| {
            self.envs.par_iter_mut().enumerate().for_each(|(e, env)| {
                // At most a handful of articulations per scene: a fixed array avoids allocation.
                let mut drives: [&[JointDrive]; 8] = [&[]; 8];
                for (a, b) in arts.iter().enumerate() {
                    drives[a] = &b.drives;
                }
                for (a, input) in Self::inputs_of(arts, e).enumerate() {
                    env.apply_inputs(a, drives[a], &input);
                }
                env.step_world(&drives[..arts.len()]);
                for (a, input) in Self::inputs_of(arts, e).enumerate() {
                    env.publish(a, gravity, drives[a], &input);
                }
            })
        });
        let all = 0..self.envs.len();
        for e in all {
            self.gather(std::slice::from_ref(&e));
        }
        self.unstepped.fill(false);
        Ok(())
    }

    fn articulation(&self, a: usize) -> ArticulationView<'_> {
        let b = &self.arts[a];
        ArticulationView {
            num_links: b.links,
            joint_pos: &b.joint_pos,
            joint_vel: &b.joint_vel,
            bias_forces: &b.bias,
            applied_effort: &b.applied,
            link_pos: &b.link_pos,
            link_quat: &b.link_quat,
            link_lin_vel: &b.link_lin_vel,
            link_ang_vel: &b.link_ang_vel,
        }
    }

    fn rigid_object(&self, o: usize) -> RigidObjectView<'_> {
        let b = &self.objects[o];
        RigidObjectView {
            pos: &b.pos,
            quat: &b.quat,
            lin_vel: &b.lin_vel,
            ang_vel: &b.ang_vel,
        }
    }

    fn set_joint_position_targets(
        &mut self,
        a: usize,
        targets: &[f32],
    ) -> Result<(), PhysicsError> {
        self.set_inputs(a, "joint position targets", targets, |b| &mut b.pos_target)
    }

    fn set_joint_velocity_targets(
        &mut self,
        a: usize,
        targets: &[f32],
    ) -> Result<(), PhysicsError> {
        self.set_inputs(a, "joint velocity targets", targets, |b| &mut b.vel_target)
    }

    fn set_joint_efforts(&mut self, a: usize, efforts: &[f32]) -> Result<(), PhysicsError> {
        self.set_inputs(a, "joint efforts", efforts, |b| &mut b.effort)
    }

    fn set_bias_compensation(
        &mut self,
        a: usize,
        dofs: &[usize],
        enabled: bool,
    ) -> Result<(), PhysicsError> {
        check_dof_ids(dofs, self.check_articulation(a)?.dofs)?;
        for &d in dofs {
            self.arts[a].compensate[d] = enabled;
        }
        Ok(())
    }

    fn write_joint_state(
        &mut self,
        a: usize,
        env_ids: &[usize],
        pos: &[f32],
        vel: &[f32],
    ) -> Result<(), PhysicsError> {
        let dofs = self.check_articulation(a)?.dofs;
        check_env_ids(env_ids, self.envs.len())?;
        check_batch("joint positions", pos, env_ids.len(), dofs)?;
        check_batch("joint velocities", vel, env_ids.len(), dofs)?;
        self.renew(env_ids, Written::Articulation(a))?;
        for (i, &e) in env_ids.iter().enumerate() {
            let r = i * dofs..(i + 1) * dofs;
            self.envs[e].write_joint_state(a, &pos[r.clone()], &vel[r]);
        }
        self.publish(env_ids);
        Ok(())
    }

    fn write_articulation_root_state(
        &mut self,
        a: usize,
        env_ids: &[usize],
        states: &[RootState],
    ) -> Result<(), PhysicsError> {
        self.check_articulation(a)?;
        check_floating_base(&self.layout, a)?;
        check_env_ids(env_ids, self.envs.len())?;
        check_root_states(states, env_ids.len())?;
        self.renew(env_ids, Written::ArticulationRoot(a))?;
        for (&e, s) in env_ids.iter().zip(states) {
            self.envs[e].write_articulation_root_state(a, s);
        }
        self.publish(env_ids);
        Ok(())
    }

    fn write_root_state(
        &mut self,
        o: usize,
        env_ids: &[usize],
        states: &[RootState],
    ) -> Result<(), PhysicsError> {
        self.body_handle(BodyRef::RigidObject(o))?;
        check_env_ids(env_ids, self.envs.len())?;
        check_root_states(states, env_ids.len())?;
        self.renew(env_ids, Written::Object(o))?;
        for (&e, s) in env_ids.iter().zip(states) {
            self.envs[e].write_root_state(o, s);
        }
        self.publish(env_ids);
        Ok(())
    }

    fn set_masses(
        &mut self,
        body: BodyRef,
        env_ids: &[usize],
        masses: &[f32],
    ) -> Result<(), PhysicsError> {
        self.body_handle(body)?;
        check_env_ids(env_ids, self.envs.len())?;
        check_values("masses", masses, env_ids.len(), "> 0", |m| m > 0.0)?;
        for (&e, &m) in env_ids.iter().zip(masses) {
            let slot = match body {
                BodyRef::Link { articulation, link } => {
                    let b = &mut self.arts[articulation];
                    &mut b.inertials[e * b.links + link]
                }
                BodyRef::RigidObject(o) => &mut self.objects[o].inertials[e],
            };
            *slot = self.envs[e].set_mass(body, slot, m);
        }
        Ok(())
    }

    fn set_friction(
        &mut self,
        body: BodyRef,
        env_ids: &[usize],
        friction: &[f32],
    ) -> Result<(), PhysicsError> {
        self.body_handle(body)?;
        check_env_ids(env_ids, self.envs.len())?;
        check_values("friction", friction, env_ids.len(), ">= 0", |f| f >= 0.0)?;
        for (&e, &f) in env_ids.iter().zip(friction) {
            let env = &mut self.envs[e];
            env.set_friction(env.body(body), f);
            let set = &mut self.frictions[e];
            match set.iter_mut().find(|(b, _)| *b == body) {
                Some(entry) => entry.1 = f,
                None => set.push((body, f)),
            }
        }
        Ok(())
    }
}
