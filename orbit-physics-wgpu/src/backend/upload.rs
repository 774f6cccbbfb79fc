//! Host-side writes and their uploads: the initial state, root states written into the host
//! copy, state rows and the dirty ranges of the input buffer.

use orbit_core::scene::{RootState, SceneDesc};

use super::WgpuBackend;
use crate::layout;

impl WgpuBackend {
    /// Default joint state, the default root state of every floating base (its root link's
    /// rows) and rigid object, unit mass scales and the shapes' frictions.
    pub(super) fn init_state(&mut self, desc: &SceneDesc) {
        let n = self.buffers.num_envs;
        for (a, art) in desc.articulations.iter().enumerate() {
            let off = self.buffers.articulations[a].clone();
            let dofs = off.dofs;
            for e in 0..n {
                for i in 0..dofs {
                    let s = self.state_f32_mut();
                    s[off.joints + e * dofs + i] = art.default_joint_pos[i];
                    s[off.joints + off.joint_len + e * dofs + i] = art.default_joint_vel[i];
                    self.inputs[off.inputs + e * dofs + i] = art.default_joint_pos[i];
                    self.inputs[off.inputs + off.joint_len + e * dofs + i] =
                        art.default_joint_vel[i];
                }
            }
        }
        let all: Vec<usize> = (0..n).collect();
        for (a, art) in desc.articulations.iter().enumerate() {
            if !art.fixed_base {
                self.put_articulation_root_states(a, &all, &vec![art.default_root_state(); n]);
            }
        }
        for (o, obj) in desc.rigid_objects.iter().enumerate() {
            let states = vec![obj.default_root_state; n];
            self.put_root_states(o, &(0..n).collect::<Vec<_>>(), &states);
        }
        let bodies = self.scene.num_bodies();
        let shapes = self.scene.shapes.len();
        for e in 0..n {
            for b in 0..bodies {
                self.inputs[self.buffers.mass_scale + e * bodies + b] = 1.0;
            }
            for s in 0..shapes {
                self.inputs[self.buffers.friction + e * shapes + s] = self.scene.shapes[s].friction;
            }
        }
    }

    pub(super) fn put_root_states(&mut self, o: usize, env_ids: &[usize], states: &[RootState]) {
        let off = self.buffers.objects[o].clone();
        let rows = env_ids.iter().map(|&e| {
            [
                off.pos + e * 3,
                off.quat + e * 4,
                off.lin + e * 3,
                off.ang + e * 3,
            ]
        });
        put_rows(self.state_f32_mut(), rows, states);
    }

    /// Writes root states into the rows of articulation `a`'s root link (its first link), the
    /// state a floating base's kernel starts from.
    pub(super) fn put_articulation_root_states(
        &mut self,
        a: usize,
        env_ids: &[usize],
        states: &[RootState],
    ) {
        let off = self.buffers.articulations[a].clone();
        let links = off.links;
        let rows = env_ids.iter().map(|&e| {
            let k = e * links;
            [
                off.link_pos + 3 * k,
                off.link_quat + 4 * k,
                off.link_lin + 3 * k,
                off.link_ang + 3 * k,
            ]
        });
        put_rows(self.state_f32_mut(), rows, states);
    }

    pub(super) fn upload_state(&self) {
        self.gpu
            .queue
            .write_buffer(&self.state_buf, 0, bytemuck::cast_slice(self.state_f32()));
    }

    /// Uploads the rows of `env_ids` in each state section `(first float, floats per env)`:
    /// packed and put in place by the write kernel when the envs are few (at most a quarter)
    /// and far apart, else per section the span from the lowest to the highest env written.
    pub(super) fn upload_state_rows(&self, env_ids: &[usize], sections: &[(usize, usize)]) {
        if self
            .gather
            .write(&self.gpu, env_ids, sections, self.state_f32())
        {
            return;
        }
        for &(start, width) in sections {
            let Some(range) = layout::env_rows(start, width, env_ids) else {
                return;
            };
            self.gpu.queue.write_buffer(
                &self.state_buf,
                (range.start * 4) as u64,
                bytemuck::cast_slice(&self.state_f32()[range]),
            );
        }
    }

    /// Uploads the dirty ranges of `inputs`, overlapping ones merged.
    pub(super) fn upload_inputs(&mut self) {
        self.dirty.sort_unstable_by_key(|r| r.start);
        let mut ranges = self.dirty.drain(..);
        let Some(mut run) = ranges.next() else {
            return;
        };
        let upload = |r: std::ops::Range<usize>| {
            self.gpu.queue.write_buffer(
                &self.inputs_buf,
                (r.start * 4) as u64,
                bytemuck::cast_slice(&self.inputs[r]),
            );
        };
        for r in ranges {
            if r.start <= run.end {
                run.end = run.end.max(r.end);
            } else {
                upload(std::mem::replace(&mut run, r));
            }
        }
        upload(run);
    }

    /// Marks `len` inputs from `start` for the next upload.
    pub(super) fn mark(&mut self, start: usize, len: usize) {
        self.dirty.push(start..start + len);
    }

    /// Marks the rows of `env_ids` in the per-env input section at `section` (`per_env`
    /// values per env) for the next upload: the span from the lowest to the highest.
    pub(super) fn mark_env_rows(&mut self, section: usize, per_env: usize, env_ids: &[usize]) {
        self.dirty
            .extend(layout::env_rows(section, per_env, env_ids));
    }
}

/// Writes each root state at its row's `[position, quaternion, linear velocity, angular
/// velocity]` offsets (the quaternion normalised).
fn put_rows(s: &mut [f32], rows: impl Iterator<Item = [usize; 4]>, states: &[RootState]) {
    for ([pos, quat, lin, ang], st) in rows.zip(states) {
        s[pos..pos + 3].copy_from_slice(&st.pose.pos.to_array());
        s[quat..quat + 4].copy_from_slice(&st.pose.rot.normalize().to_array());
        s[lin..lin + 3].copy_from_slice(&st.lin_vel.to_array());
        s[ang..ang + 3].copy_from_slice(&st.ang_vel.to_array());
    }
}
