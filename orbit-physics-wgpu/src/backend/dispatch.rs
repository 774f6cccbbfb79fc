//! Dispatches of the step kernel: steps, republishes of a few envs or all, the fresh flags that
//! state writes set, and the wait for the previous submission.

use orbit_core::physics::PhysicsError;

use super::{WgpuBackend, err};
use crate::layout::{self, FRESH, NOT_FRESH, REPUBLISH};

impl WgpuBackend {
    /// Waits for the submission `index` (the dispatch before the one just submitted, see
    /// `dispatch`), if any.
    fn wait_for(&self, index: Option<wgpu::SubmissionIndex>) -> Result<(), PhysicsError> {
        if let Some(index) = index {
            self.gpu
                .device
                .poll(wgpu::PollType::Wait {
                    submission_index: Some(index),
                    timeout: None,
                })
                .map_err(|e| err(format!("the GPU did not finish the step: {e}")))?;
        }
        Ok(())
    }

    /// Runs `substeps` substeps (0: only recompute what is published, for the envs `marked` if
    /// given, which [`republish`](Self::republish) flagged with [`REPUBLISH`]; else for all).
    /// The host mirror reads the published state back when it is next looked at.
    pub(super) fn dispatch(
        &mut self,
        substeps: u32,
        marked: Option<&[usize]>,
    ) -> Result<(), PhysicsError> {
        let marked = marked.filter(|_| substeps == 0);
        self.upload_inputs();
        // Steps (not republishes) are timed.
        let timer = self.timer.as_ref().filter(|_| substeps > 0);
        let gpu = self.gpu.clone();
        let queue = &gpu.queue;
        queue.write_buffer(
            &self.params_buf,
            0,
            bytemuck::cast_slice(&[substeps, u32::from(marked.is_some()), 0, 0]),
        );
        let device = &gpu.device;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("orbit step"),
        });
        {
            let timestamp_writes = timer.map(|t| wgpu::ComputePassTimestampWrites {
                query_set: &t.queries,
                beginning_of_pass_write_index: Some(0),
                end_of_pass_write_index: Some(1),
            });
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("orbit step"),
                timestamp_writes,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(self.groups, 1, 1);
        }
        if let Some(t) = timer {
            encoder.resolve_query_set(&t.queries, 0..2, &t.resolved, 0);
            encoder.copy_buffer_to_buffer(&t.resolved, 0, &self.timestamps, 0, 16);
        }
        // Submit this step, then wait for the one before it: the GPU always has the next
        // step queued, and at most two are in flight.
        let submitted = queue.submit([encoder.finish()]);
        if timer.is_some() {
            self.timed = true;
        }
        self.mark_stale(marked);
        let previous = self.pending.replace(submitted);
        // Fresh flags last until a step has consumed them (its first substep skips the warm
        // start); a republish leaves them set. The submitted step consumes them whether or
        // not the wait below succeeds.
        if substeps > 0 {
            let fresh = self.buffers.fresh;
            let rows = layout::env_rows(fresh, 1, &self.fresh_envs);
            for e in self.fresh_envs.drain(..) {
                self.inputs[fresh + e] = NOT_FRESH;
            }
            self.dirty.extend(rows);
        }
        self.wait_for(previous)
    }

    /// Marks every env fresh and republishes (after construction).
    pub(super) fn refresh_all(&mut self) -> Result<(), PhysicsError> {
        let (fresh, n) = (self.buffers.fresh, self.buffers.num_envs);
        self.inputs[fresh..fresh + n].fill(FRESH);
        self.mark(fresh, n);
        self.fresh_envs = (0..n).collect();
        self.dispatch(0, None)
    }

    /// After a state write to `sections` (see [`upload_state_rows`](Self::upload_state_rows)):
    /// upload those rows, flag the envs fresh (the next step's first substep runs them without
    /// warm starts) and republish the envs of this write.
    pub(super) fn after_write(
        &mut self,
        env_ids: &[usize],
        sections: &[(usize, usize)],
    ) -> Result<(), PhysicsError> {
        let fresh = self.buffers.fresh;
        for &e in env_ids {
            if self.inputs[fresh + e] == NOT_FRESH {
                self.inputs[fresh + e] = FRESH;
                self.fresh_envs.push(e);
            }
        }
        self.upload_state_rows(env_ids, sections);
        self.republish(env_ids)
    }

    /// Republishes `env_ids` only, so that only their rows are read back and every other env's
    /// state stays as it was, envs written earlier in the same step included (a republish
    /// normalises quaternions and moves velocities to the centre of mass and back, which can
    /// move the last bits of a state it republishes again). Their fresh flags carry
    /// [`REPUBLISH`] for the dispatch and are restored after it, also when it fails.
    pub(super) fn republish(&mut self, env_ids: &[usize]) -> Result<(), PhysicsError> {
        if env_ids.is_empty() {
            return Ok(());
        }
        let fresh = self.buffers.fresh;
        for &e in env_ids {
            self.inputs[fresh + e] += REPUBLISH;
        }
        self.mark_env_rows(fresh, 1, env_ids);
        let published = self.dispatch(0, Some(env_ids));
        for &e in env_ids {
            self.inputs[fresh + e] -= REPUBLISH;
        }
        self.mark_env_rows(fresh, 1, env_ids);
        published
    }
}
