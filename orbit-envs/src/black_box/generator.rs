//! The movement primitive of a black-box env, ready to generate trajectories.

use orbit_mp::{MpError, ProDmp, ProMp};

/// A movement primitive ready to generate.
pub(super) enum Generator {
    ProMp(ProMp),
    ProDmp(ProDmp),
}

impl Generator {
    pub(super) fn num_params(&self) -> usize {
        match self {
            Generator::ProMp(p) => p.num_params(),
            Generator::ProDmp(p) => p.num_params(),
        }
    }

    /// Samples per plan.
    pub(super) fn num_steps(&self) -> usize {
        match self {
            Generator::ProMp(p) => p.cfg().num_steps,
            Generator::ProDmp(p) => p.cfg().num_steps,
        }
    }

    /// Trajectories from `t0` (a ProMP only starts at 0; checked on construction).
    pub(super) fn generate(
        &self,
        t0: f64,
        params: &[f32],
        q0: &[f32],
        v0: &[f32],
        pos: &mut [f32],
        vel: &mut [f32],
    ) -> Result<(), MpError> {
        match self {
            Generator::ProMp(p) => p.trajectories(params, q0, pos, vel),
            Generator::ProDmp(p) => p.trajectories(t0, params, q0, v0, pos, vel),
        }
    }
}
