//! [`PhysicsBackend`] for [`WgpuBackend`], with the checks of its arguments.

use glam::{Quat, Vec3};
use orbit_core::physics::{
    ArticulationView, BodyRef, PhysicsBackend, PhysicsError, RigidObjectView, SceneLayout,
    check_batch, check_dof_ids, check_env_ids, check_floating_base, check_root_states,
    check_values,
};
use orbit_core::scene::RootState;

use super::WgpuBackend;
use crate::BACKEND_NAME;
use crate::compile::ArticulationBlock;
use crate::layout;

impl WgpuBackend {
    fn check_articulation(&self, a: usize) -> Result<layout::ArticulationOffsets, PhysicsError> {
        self.buffers.articulations.get(a).cloned().ok_or_else(|| {
            PhysicsError::InvalidInput(format!(
                "articulation index {a} out of range ({} articulations)",
                self.buffers.articulations.len()
            ))
        })
    }

    /// Copies a full `num_envs × dofs` input batch into input quantity `k`.
    fn set_inputs(
        &mut self,
        a: usize,
        k: usize,
        what: &str,
        values: &[f32],
    ) -> Result<(), PhysicsError> {
        let off = self.check_articulation(a)?;
        check_batch(what, values, self.buffers.num_envs, off.dofs)?;
        let start = off.inputs + k * off.joint_len;
        self.inputs[start..start + values.len()].copy_from_slice(values);
        self.mark(start, values.len());
        Ok(())
    }

    /// Global body index of a body reference, checked.
    fn body_index(&self, body: BodyRef) -> Result<usize, PhysicsError> {
        match body {
            BodyRef::Link { articulation, link } => {
                let &ArticulationBlock { link0, links, .. } =
                    self.scene.articulations.get(articulation).ok_or_else(|| {
                        PhysicsError::InvalidInput(format!(
                            "articulation index {articulation} out of range"
                        ))
                    })?;
                if link >= links {
                    return Err(PhysicsError::InvalidInput(format!(
                        "link index {link} out of range ({links} links)"
                    )));
                }
                Ok(link0 + link)
            }
            BodyRef::RigidObject(o) => {
                if o >= self.scene.objects.len() {
                    return Err(PhysicsError::InvalidInput(format!(
                        "rigid object index {o} out of range"
                    )));
                }
                Ok(self.scene.links.len() + o)
            }
        }
    }
}

impl PhysicsBackend for WgpuBackend {
    fn name(&self) -> &'static str {
        BACKEND_NAME
    }

    fn num_envs(&self) -> usize {
        self.buffers.num_envs
    }

    fn layout(&self) -> &SceneLayout {
        &self.layout
    }

    fn dt(&self) -> f32 {
        self.sim.dt
    }

    fn sync(&self) {
        self.state_f32();
    }

    fn last_kernel_time(&self) -> Option<std::time::Duration> {
        self.kernel_time()
    }

    fn device_memory_bytes(&self) -> usize {
        // State, inputs, warm starts, the readback copy, the layout table and the gather's.
        let b = &self.buffers;
        4 * (2 * b.state_len + b.inputs_len + b.warm_len + self.lay_len)
            + self.gather.device_memory_bytes()
    }

    fn step(&mut self) -> Result<(), PhysicsError> {
        self.dispatch(1, None)
    }

    fn step_n(&mut self, n: usize) -> Result<(), PhysicsError> {
        if n == 0 {
            return Ok(());
        }
        let n = u32::try_from(n)
            .map_err(|_| PhysicsError::InvalidInput(format!("{n} steps in one call")))?;
        self.dispatch(n, None)
    }

    fn articulation(&self, a: usize) -> ArticulationView<'_> {
        let off = &self.buffers.articulations[a];
        let n = self.buffers.num_envs;
        let s = self.state_f32();
        let (d, l) = (n * off.dofs, n * off.links);
        let j = |k: usize| &s[off.joints + k * off.joint_len..off.joints + k * off.joint_len + d];
        ArticulationView {
            num_links: off.links,
            joint_pos: j(0),
            joint_vel: j(1),
            bias_forces: j(2),
            applied_effort: j(3),
            link_pos: bytemuck::cast_slice(&s[off.link_pos..off.link_pos + 3 * l]),
            link_quat: bytemuck::cast_slice(&s[off.link_quat..off.link_quat + 4 * l]),
            link_lin_vel: bytemuck::cast_slice(&s[off.link_lin..off.link_lin + 3 * l]),
            link_ang_vel: bytemuck::cast_slice(&s[off.link_ang..off.link_ang + 3 * l]),
        }
    }

    fn rigid_object(&self, o: usize) -> RigidObjectView<'_> {
        let off = &self.buffers.objects[o];
        let n = self.buffers.num_envs;
        let s = self.state_f32();
        RigidObjectView {
            pos: bytemuck::cast_slice::<f32, Vec3>(&s[off.pos..off.pos + 3 * n]),
            quat: bytemuck::cast_slice::<f32, Quat>(&s[off.quat..off.quat + 4 * n]),
            lin_vel: bytemuck::cast_slice(&s[off.lin..off.lin + 3 * n]),
            ang_vel: bytemuck::cast_slice(&s[off.ang..off.ang + 3 * n]),
        }
    }

    fn set_joint_position_targets(
        &mut self,
        a: usize,
        targets: &[f32],
    ) -> Result<(), PhysicsError> {
        self.set_inputs(a, 0, "joint position targets", targets)
    }

    fn set_joint_velocity_targets(
        &mut self,
        a: usize,
        targets: &[f32],
    ) -> Result<(), PhysicsError> {
        self.set_inputs(a, 1, "joint velocity targets", targets)
    }

    fn set_joint_efforts(&mut self, a: usize, efforts: &[f32]) -> Result<(), PhysicsError> {
        self.set_inputs(a, 2, "joint efforts", efforts)
    }

    fn set_bias_compensation(
        &mut self,
        a: usize,
        dofs: &[usize],
        enabled: bool,
    ) -> Result<(), PhysicsError> {
        check_dof_ids(dofs, self.check_articulation(a)?.dofs)?;
        let first = self.scene.articulations[a].joint_dof0();
        for &d in dofs {
            self.inputs[self.buffers.compensate + first + d] = if enabled { 1.0 } else { 0.0 };
        }
        self.mark(self.buffers.compensate, self.scene.dofs.len());
        Ok(())
    }

    fn write_joint_state(
        &mut self,
        a: usize,
        env_ids: &[usize],
        pos: &[f32],
        vel: &[f32],
    ) -> Result<(), PhysicsError> {
        let off = self.check_articulation(a)?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        let dofs = off.dofs;
        check_batch("joint positions", pos, env_ids.len(), dofs)?;
        check_batch("joint velocities", vel, env_ids.len(), dofs)?;
        let s = self.state_f32_mut();
        for (i, &e) in env_ids.iter().enumerate() {
            let row = off.joints + e * dofs;
            s[row..row + dofs].copy_from_slice(&pos[i * dofs..(i + 1) * dofs]);
            let row = row + off.joint_len;
            s[row..row + dofs].copy_from_slice(&vel[i * dofs..(i + 1) * dofs]);
        }
        let sections = [off.joint_section(0), off.joint_section(1)];
        self.after_write(env_ids, &sections)
    }

    fn write_articulation_root_state(
        &mut self,
        a: usize,
        env_ids: &[usize],
        states: &[RootState],
    ) -> Result<(), PhysicsError> {
        let off = self.check_articulation(a)?;
        check_floating_base(self.layout(), a)?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        check_root_states(states, env_ids.len())?;
        self.put_articulation_root_states(a, env_ids, states);
        // The whole link rows: the republish recomputes the other links from the root.
        self.after_write(env_ids, &off.link_sections())
    }

    fn write_root_state(
        &mut self,
        o: usize,
        env_ids: &[usize],
        states: &[RootState],
    ) -> Result<(), PhysicsError> {
        self.body_index(BodyRef::RigidObject(o))?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        check_root_states(states, env_ids.len())?;
        self.put_root_states(o, env_ids, states);
        let sections = self.buffers.objects[o].sections();
        self.after_write(env_ids, &sections)
    }

    fn set_masses(
        &mut self,
        body: BodyRef,
        env_ids: &[usize],
        masses: &[f32],
    ) -> Result<(), PhysicsError> {
        let b = self.body_index(body)?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        check_values("masses", masses, env_ids.len(), "> 0", |m| m > 0.0)?;
        let default = self.default_masses[b];
        if default <= 0.0 {
            return Err(PhysicsError::InvalidInput(format!(
                "body {body:?} has no mass to scale"
            )));
        }
        let bodies = self.scene.num_bodies();
        for (&e, &m) in env_ids.iter().zip(masses) {
            self.inputs[self.buffers.mass_scale + e * bodies + b] = m / default;
        }
        self.mark_env_rows(self.buffers.mass_scale, bodies, env_ids);
        // Bias forces depend on the masses: republish the envs whose masses changed.
        self.republish(env_ids)
    }

    fn set_friction(
        &mut self,
        body: BodyRef,
        env_ids: &[usize],
        friction: &[f32],
    ) -> Result<(), PhysicsError> {
        let b = self.body_index(body)?;
        check_env_ids(env_ids, self.buffers.num_envs)?;
        check_values("friction", friction, env_ids.len(), ">= 0", |f| f >= 0.0)?;
        let shapes = self.scene.shapes.len();
        for (s, shape) in self.scene.shapes.iter().enumerate() {
            if shape.body == Some(b) {
                for (&e, &f) in env_ids.iter().zip(friction) {
                    self.inputs[self.buffers.friction + e * shapes + s] = f;
                }
            }
        }
        self.mark_env_rows(self.buffers.friction, shapes, env_ids);
        Ok(())
    }
}
