//! ProMP trajectories (MP_PyTorch's `ProMP` as Fancy Gym calls it; Paraschos et al. 2013): per
//! dof, `y(t) = q_start + Σ_j b_j(x(t)) · s · w_j` over the learned basis functions, sampled at
//! `t_k = k·dt` for `k = 1..=num_steps`, with forward-difference velocities.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{LinearPhase, MpError, ZeroPaddedRbf, check_number};

/// A ProMP's settings (Fancy Gym's box pushing: 7 dof, 5 basis + 1 zero-start, bandwidth
/// factor 2, τ = 2 s, dt = 0.02 s, 100 steps).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProMpCfg {
    /// Degrees of freedom (joints) of a trajectory. In a black-box config, 0 (the default)
    /// means the env's action dimension.
    #[serde(default)]
    pub num_dof: usize,
    /// Weighted basis functions per dof.
    pub num_basis: usize,
    /// Unweighted basis functions before them, which hold the start near `q_start`.
    #[serde(default = "one")]
    pub num_basis_zero_start: usize,
    /// Unweighted basis functions after them.
    #[serde(default)]
    pub num_basis_zero_goal: usize,
    /// `h_j = factor / Δ_j²`.
    pub basis_bandwidth_factor: f64,
    /// Phase duration τ (s).
    pub tau: f64,
    /// Phase delay (s).
    #[serde(default)]
    pub delay: f64,
    /// Scale of every weight.
    #[serde(default = "unit")]
    pub weights_scale: f64,
    /// Time between samples (s). In a black-box config, 0 (the default) means the env's step.
    #[serde(default)]
    pub dt: f64,
    /// Samples per trajectory. In a black-box config, 0 (the default) means the env's episode
    /// length in steps.
    #[serde(default)]
    pub num_steps: usize,
}

fn one() -> usize {
    1
}

fn unit() -> f64 {
    1.0
}

/// A ProMP with its basis evaluated at every sample time.
#[derive(Clone, Debug)]
pub struct ProMp {
    cfg: ProMpCfg,
    basis: ZeroPaddedRbf,
    times: Vec<f64>,
    /// `[num_steps × len]`: all basis functions at every sample.
    rows: Vec<f64>,
    /// `[num_steps × num_basis]`: the learned functions times `weights_scale`.
    weighted: Vec<f64>,
}

impl ProMp {
    /// Checks `cfg` and tabulates the basis at the sample times.
    pub fn new(cfg: ProMpCfg) -> Result<Self, MpError> {
        if cfg.num_dof == 0 {
            return Err(MpError::InvalidConfig {
                field: "num_dof",
                message: "at least one degree of freedom is needed".into(),
            });
        }
        if cfg.num_steps < 2 {
            return Err(MpError::InvalidConfig {
                field: "num_steps",
                message: format!("velocities need at least 2 samples, got {}", cfg.num_steps),
            });
        }
        check_number("tau", cfg.tau, true)?;
        check_number("dt", cfg.dt, true)?;
        check_number("delay", cfg.delay, false)?;
        check_number("weights_scale", cfg.weights_scale, false)?;
        let basis = ZeroPaddedRbf::new(
            cfg.num_basis,
            cfg.num_basis_zero_start,
            cfg.num_basis_zero_goal,
            cfg.basis_bandwidth_factor,
        )?;
        let phase = LinearPhase {
            tau: cfg.tau,
            delay: cfg.delay,
        };
        // MP_PyTorch's `set_duration`: linspace(0, steps·dt, steps + 1), first sample dropped.
        let duration = cfg.num_steps as f64 * cfg.dt;
        let times: Vec<f64> = (1..=cfg.num_steps)
            .map(|k| k as f64 * duration / cfg.num_steps as f64)
            .collect();
        let n = basis.len();
        let mut rows = vec![0.0; cfg.num_steps * n];
        for (row, &t) in rows.chunks_exact_mut(n).zip(&times) {
            basis.row(phase.phase(t), row);
        }
        let weighted = rows
            .chunks_exact(n)
            .flat_map(|row| row[basis.learned()].iter().map(|b| b * cfg.weights_scale))
            .collect();
        Ok(Self {
            cfg,
            basis,
            times,
            rows,
            weighted,
        })
    }

    /// The config.
    pub fn cfg(&self) -> &ProMpCfg {
        &self.cfg
    }

    /// Parameters per env: `num_dof × num_basis`, dof-major (`index = dof·num_basis + k`).
    pub fn num_params(&self) -> usize {
        self.cfg.num_dof * self.cfg.num_basis
    }

    /// The sample times `t_1 … t_num_steps` (s).
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// The basis.
    pub fn basis(&self) -> &ZeroPaddedRbf {
        &self.basis
    }

    /// The normalised basis row (all functions, padded ones included) at sample `k`.
    pub fn basis_row(&self, k: usize) -> &[f64] {
        let n = self.basis.len();
        &self.rows[k * n..(k + 1) * n]
    }

    /// Trajectories of `n` envs: `params` `[n × num_params]`, `q_start` `[n × num_dof]` (the
    /// joint positions when the trajectory is generated) → `pos` and `vel`
    /// `[n × num_steps × num_dof]`. Velocities are forward differences, the last repeating the
    /// one before (MP_PyTorch). Nothing is written if an input is invalid.
    pub fn trajectories(
        &self,
        params: &[f32],
        q_start: &[f32],
        pos: &mut [f32],
        vel: &mut [f32],
    ) -> Result<(), MpError> {
        let (dof, nb, steps) = (self.cfg.num_dof, self.cfg.num_basis, self.cfg.num_steps);
        let n = q_start.len() / dof;
        crate::check_inputs(
            n,
            &[
                ("params", params, self.num_params()),
                ("q_start", q_start, dof),
            ],
            &[
                ("pos", pos.len(), steps * dof),
                ("vel", vel.len(), steps * dof),
            ],
        )?;
        let per_env = steps * dof;
        pos.par_chunks_mut(per_env)
            .zip(vel.par_chunks_mut(per_env))
            .enumerate()
            .for_each(|(e, (pos, vel))| {
                let w = &params[e * dof * nb..(e + 1) * dof * nb];
                for d in 0..dof {
                    let w = &w[d * nb..(d + 1) * nb];
                    let q0 = f64::from(q_start[e * dof + d]);
                    let mut prev = 0.0;
                    for k in 0..steps {
                        let b = &self.weighted[k * nb..(k + 1) * nb];
                        let y = q0 + b.iter().zip(w).map(|(b, &w)| b * f64::from(w)).sum::<f64>();
                        pos[k * dof + d] = y as f32;
                        if k > 0 {
                            let dt = self.times[k] - self.times[k - 1];
                            vel[(k - 1) * dof + d] = ((y - prev) / dt) as f32;
                        }
                        prev = y;
                    }
                    vel[(steps - 1) * dof + d] = vel[(steps - 2) * dof + d];
                }
            });
        Ok(())
    }
}
