//! Reading the state back: the host mirror's refresh after a dispatch, of every env or only of
//! the envs that a republish changed (see `gather.rs`), and what each dispatch makes stale.

use glam::Vec4;

use super::WgpuBackend;

/// The part of the host mirror that the dispatches since it was last current have changed.
pub(super) enum Stale {
    /// Every env (a step ran, or a republish of all envs).
    All,
    /// Only these envs were republished (after a state write or a mass change); every other
    /// row is current.
    Envs(Vec<u32>),
}

impl WgpuBackend {
    /// The published state, read back first if a dispatch ran since it was last read.
    pub(super) fn state_f32(&self) -> &[f32] {
        bytemuck::cast_slice(self.state.get(|dst| self.read_back(dst)))
    }

    /// The host copy of the state for host-side writes (current first, so that rows written
    /// back in the same span as the written envs hold the GPU's values).
    pub(super) fn state_f32_mut(&mut self) -> &mut [f32] {
        self.state_f32();
        bytemuck::cast_slice_mut(self.state.get_mut())
    }

    /// Waits for `slice` of a readback buffer to be mapped (after the submission that fills it).
    /// The views cannot return errors: a GPU lost while reading back is a panic.
    pub(super) fn map_read(&self, slice: &wgpu::BufferSlice<'_>) {
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.gpu
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .unwrap_or_else(|e| panic!("the GPU did not finish the physics step: {e}"));
    }

    /// Copies the last dispatch's published state into `dst`. The copy into the readback
    /// buffer is queued here, when the state is looked at, not with every step: at 65 536
    /// envs it is tens of megabytes over the bus, as long as a quarter of the step's kernel.
    fn read_back(&self, dst: &mut [Vec4]) {
        match &self.stale {
            Stale::All => self.read_back_all(dst),
            Stale::Envs(ids) => self.read_back_rows(ids, dst),
        }
    }

    /// Copies the rows of `env_ids` (all that changed since `dst` was current) into `dst`.
    fn read_back_rows(&self, env_ids: &[u32], dst: &mut [Vec4]) {
        if env_ids.is_empty() {
            return;
        }
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit gather"),
            });
        let bytes = self
            .gather
            .encode(&self.gpu, &mut encoder, env_ids, &self.staging);
        self.gpu.queue.submit([encoder.finish()]);
        let slice = self.staging.slice(..bytes.max(4));
        self.map_read(&slice);
        {
            let view = slice
                .get_mapped_range()
                .unwrap_or_else(|e| panic!("reading the reset envs' state back failed: {e}"));
            self.gather.scatter(
                env_ids,
                bytemuck::cast_slice(&view),
                bytemuck::cast_slice_mut(dst),
            );
        }
        self.staging.unmap();
    }

    /// Copies the whole published state into `dst`.
    fn read_back_all(&self, dst: &mut [Vec4]) {
        let bytes = (self.buffers.state_len * 4) as u64;
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("orbit readback"),
            });
        encoder.copy_buffer_to_buffer(&self.state_buf, 0, &self.staging, 0, bytes);
        self.gpu.queue.submit([encoder.finish()]);
        let slice = self.staging.slice(..bytes);
        self.map_read(&slice);
        {
            let view = slice
                .get_mapped_range()
                .unwrap_or_else(|e| panic!("reading the physics state back failed: {e}"));
            let len = self.buffers.state_len;
            let state: &mut [f32] = bytemuck::cast_slice_mut(dst);
            // Tens of megabytes at 65 536 envs: copied on every core.
            orbit_core::parallel::copy(bytemuck::cast_slice(&view), &mut state[..len]);
        }
        self.staging.unmap();
    }

    /// Records what a dispatch makes stale: the envs `marked` if it republished only those,
    /// else every env.
    pub(super) fn mark_stale(&mut self, marked: Option<&[usize]>) {
        let previous = std::mem::replace(&mut self.stale, Stale::All);
        let ids = marked.map(|ids| ids.iter().map(|&e| e as u32));
        let stale = match (ids, previous) {
            (Some(ids), _) if self.state.is_current() => Stale::Envs(ids.collect()),
            (Some(ids), Stale::Envs(mut earlier)) => {
                earlier.extend(ids);
                Stale::Envs(earlier)
            }
            _ => Stale::All,
        };
        self.stale = match stale {
            Stale::Envs(ids) if self.gather.worthwhile(ids.len()) => Stale::Envs(ids),
            _ => Stale::All,
        };
        self.state.invalidate();
    }
}

#[cfg(test)]
mod tests {
    use glam::{Vec3, Vec4};
    use orbit_core::physics::{BodyRef, PhysicsBackend, SimCfg};
    use orbit_core::scene::{RootState, SceneDesc};

    use super::Stale;
    use crate::backend::WgpuBackend;
    use crate::gpu::gpu_available_for_tests;

    /// The box-pushing scene on `n` envs after one env step under fixed efforts, synchronised;
    /// None without a GPU.
    fn stepped_box_pushing(n: usize) -> Option<(SceneDesc, WgpuBackend)> {
        if !gpu_available_for_tests() {
            return None;
        }
        let scene = orbit_assets::box_pushing_scene(&[]).expect("bundled scene");
        let mut b = WgpuBackend::new(&scene, n, &SimCfg::default()).expect("backend");
        let efforts: Vec<f32> = (0..n * 7).map(|i| ((i % 13) as f32 - 6.0) * 0.5).collect();
        b.set_joint_efforts(0, &efforts).unwrap();
        b.step_n(10).unwrap();
        b.sync();
        Some((scene, b))
    }

    /// Asserts that the host mirror (refreshed as a reader would) holds, bit for bit, what a
    /// read of the whole state gives.
    fn assert_mirror_is_whole_state(b: &mut WgpuBackend) {
        let mirror: Vec<u32> = b.state_f32().iter().map(|x| x.to_bits()).collect();
        let mut whole = vec![Vec4::ZERO; b.buffers.state_len.div_ceil(4)];
        b.read_back_all(&mut whole);
        let whole: Vec<u32> = bytemuck::cast_slice::<Vec4, f32>(&whole)
            .iter()
            .map(|x| x.to_bits())
            .collect();
        assert_eq!(mirror, whole);
    }

    /// After a reset of a few envs the host mirror reads back only their rows; it must then
    /// hold exactly what a read of the whole state gives, in every section.
    #[test]
    fn reading_back_the_reset_rows_gives_the_whole_state() {
        let Some((_, mut b)) = stepped_box_pushing(64) else {
            return;
        };
        let ids = [3, 17, 40, 41, 63];
        let pos: Vec<f32> = (0..ids.len() * 7).map(|i| 0.01 * i as f32).collect();
        b.write_joint_state(0, &ids, &pos, &vec![0.1; ids.len() * 7])
            .unwrap();
        let mut root = RootState::default();
        root.pose.pos = Vec3::new(0.4, 0.1, 0.3);
        b.write_root_state(0, &ids[1..3], &[root; 2]).unwrap();
        // The root write read the joint write's rows back before changing two of them, and
        // republished only those two.
        assert!(
            matches!(&b.stale, Stale::Envs(e) if e[..] == [17, 40]),
            "only the envs of the last write are stale"
        );
        assert_mirror_is_whole_state(&mut b);
        assert_eq!(b.articulation(0).joint_pos[17 * 7 + 3], pos[7 + 3]);
        assert_eq!(b.rigid_object(0).pos[40], root.pose.pos);
    }

    /// A mass change republishes its env at once (the bias forces follow the new mass) and
    /// leaves the host mirror exactly what a read of the whole state gives.
    #[test]
    fn a_mass_change_republishes_its_env() {
        let n = 16;
        let Some((scene, mut b)) = stepped_box_pushing(n) else {
            return;
        };
        let links = &scene.articulations[0].model.links;
        let link = links.iter().rposition(|l| l.inertial.mass > 0.0).unwrap();
        let hand = BodyRef::Link {
            articulation: 0,
            link,
        };
        let before = b.articulation(0).bias_forces.to_vec();
        b.set_masses(hand, &[5], &[3.0 * links[link].inertial.mass])
            .unwrap();
        let after = b.articulation(0).bias_forces.to_vec();
        for e in 0..n {
            let moved = before[e * 7..e * 7 + 7] != after[e * 7..e * 7 + 7];
            assert_eq!(moved, e == 5, "env {e}'s bias forces");
        }
        assert_mirror_is_whole_state(&mut b);
    }
}
