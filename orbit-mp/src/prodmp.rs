//! ProDMP trajectories (MP_PyTorch 0.1.3's `ProDMP` as Fancy Gym configures it; Li et al. 2023).
//!
//! A ProDMP is a DMP `y'' = α(β(g − y) − y') + x(s)·Σ_j B_j(s)·w_j` (β = α/4, derivatives in
//! scaled time `s = t/τ`) solved in closed form: the forced part is a linear combination of
//! position basis functions `Φ_j` (and `Φ_g` for the goal), tabulated once on a scaled-time
//! grid, and the two homogeneous solutions `y1 = e^{−αs/2}`, `y2 = s·y1` make the trajectory
//! start exactly at a given position and velocity. That boundary condition is what lets a
//! plan start from the previous plan's desired state (replanning).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{ExpDecayPhase, MpError, ZeroPaddedRbf, check_number};

/// A ProDMP's settings (Fancy Gym's box pushing: α 10, α_x 3, τ 1.5 s, 5 basis, bandwidth
/// factor 2; the replanning variant factor 3, auto-scaled basis, weight and goal scale 0.3,
/// no learned goal).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProDmpCfg {
    /// Degrees of freedom (joints) of a trajectory. In a black-box config, 0 (the default)
    /// means the env's action dimension.
    #[serde(default)]
    pub num_dof: usize,
    /// Weighted basis functions per dof.
    pub num_basis: usize,
    /// DMP stiffness α (β = α/4: critically damped).
    #[serde(default = "ten")]
    pub alpha: f64,
    /// Phase decay rate α_x.
    #[serde(default = "three")]
    pub alpha_phase: f64,
    /// Time constant τ (s).
    pub tau: f64,
    /// Phase delay (s).
    #[serde(default)]
    pub delay: f64,
    /// `h_j = factor / Δ_j²` (Δ_j the spacing of the centres in phase).
    pub basis_bandwidth_factor: f64,
    /// Scale of every weight.
    #[serde(default = "unit")]
    pub weights_scale: f64,
    /// Scale of the goal parameter.
    #[serde(default = "unit")]
    pub goal_scale: f64,
    /// Normalise every basis column by its maximum over the grid before scaling, so a unit
    /// weight moves the trajectory by about one unit.
    #[serde(default)]
    pub auto_scale_basis: bool,
    /// The goal is not a parameter (`num_basis` parameters per dof instead of `num_basis + 1`);
    /// it is 0, or the start position with `relative_goal`.
    #[serde(default)]
    pub disable_goal: bool,
    /// The goal (parameter, or 0 with `disable_goal`) is added to the start position.
    #[serde(default)]
    pub relative_goal: bool,
    /// Time between samples (s). In a black-box config, 0 (the default) means the env's step.
    #[serde(default)]
    pub dt: f64,
    /// Samples per trajectory. In a black-box config, 0 (the default) means the env's episode
    /// length in steps.
    #[serde(default)]
    pub num_steps: usize,
    /// Spacing (s) of the grid the basis is tabulated on.
    #[serde(default = "pre_compute_dt")]
    pub pre_compute_dt: f64,
    /// The grid covers scaled time `[0, factor]`.
    #[serde(default = "five")]
    pub pre_compute_length_factor: f64,
}

fn ten() -> f64 {
    10.0
}

fn three() -> f64 {
    3.0
}

fn five() -> f64 {
    5.0
}

fn unit() -> f64 {
    1.0
}

fn pre_compute_dt() -> f64 {
    0.01
}

/// The two homogeneous DMP solutions and their scaled-time derivatives at one `s`.
#[derive(Clone, Copy, Debug)]
struct Homogeneous {
    y1: f64,
    y2: f64,
    dy1: f64,
    dy2: f64,
}

/// A ProDMP with its basis tabulated on a scaled-time grid.
#[derive(Clone, Debug)]
pub struct ProDmp {
    cfg: ProDmpCfg,
    phase: ExpDecayPhase,
    basis: ZeroPaddedRbf,
    /// Grid spacing in scaled time, `pre_compute_dt / τ`.
    scaled_dt: f64,
    /// `[grid]` homogeneous solutions.
    homogeneous: Vec<Homogeneous>,
    /// `[grid × (num_basis + 1)]` position basis `Φ` (weights, then the goal).
    phi: Vec<f64>,
    /// `[grid × (num_basis + 1)]` velocity basis `Φ̇` (scaled time).
    dphi: Vec<f64>,
    /// Per column: the parameter scale (auto-scaling folded in).
    scale: Vec<f64>,
}

impl ProDmp {
    /// Checks `cfg` and tabulates the basis.
    pub fn new(cfg: ProDmpCfg) -> Result<Self, MpError> {
        if cfg.num_dof == 0 {
            return Err(MpError::InvalidConfig {
                field: "num_dof",
                message: "at least one degree of freedom is needed".into(),
            });
        }
        if cfg.num_basis == 0 {
            return Err(MpError::InvalidConfig {
                field: "num_basis",
                message: "at least one basis function is needed".into(),
            });
        }
        if cfg.num_steps == 0 {
            return Err(MpError::InvalidConfig {
                field: "num_steps",
                message: "at least one sample is needed".into(),
            });
        }
        for (field, v) in [
            ("alpha", cfg.alpha),
            ("alpha_phase", cfg.alpha_phase),
            ("tau", cfg.tau),
            ("basis_bandwidth_factor", cfg.basis_bandwidth_factor),
            ("dt", cfg.dt),
            ("pre_compute_dt", cfg.pre_compute_dt),
            ("pre_compute_length_factor", cfg.pre_compute_length_factor),
        ] {
            check_number(field, v, true)?;
        }
        for (field, v) in [
            ("delay", cfg.delay),
            ("weights_scale", cfg.weights_scale),
            ("goal_scale", cfg.goal_scale),
        ] {
            check_number(field, v, false)?;
        }
        let phase = ExpDecayPhase {
            tau: cfg.tau,
            delay: cfg.delay,
            alpha_phase: cfg.alpha_phase,
        };
        // Centres evenly spaced in time over [delay, delay + τ], mapped to phase.
        let nb = cfg.num_basis;
        let centres = (0..nb)
            .map(|j| {
                let frac = if nb == 1 {
                    0.0
                } else {
                    j as f64 / (nb - 1) as f64
                };
                phase.phase(cfg.delay + frac * cfg.tau)
            })
            .collect();
        let basis = ZeroPaddedRbf::with_centres(centres, 0, nb, cfg.basis_bandwidth_factor);
        let scaled_dt = cfg.pre_compute_dt / cfg.tau;
        let intervals = (cfg.pre_compute_length_factor / scaled_dt).round() as usize;
        if intervals < 1 {
            return Err(MpError::InvalidConfig {
                field: "pre_compute_length_factor",
                message: format!(
                    "the grid must span at least one step of {scaled_dt} in scaled time"
                ),
            });
        }
        let m = intervals + 1;
        let a = cfg.alpha;
        let cols = nb + 1;
        let mut homogeneous = Vec::with_capacity(m);
        let (mut phi, mut dphi) = (vec![0.0; m * cols], vec![0.0; m * cols]);
        // Running cumulative trapezoids of s·e^{αs/2}·x·B_j (p1) and e^{αs/2}·x·B_j (p2).
        let (mut p1, mut p2) = (vec![0.0; nb], vec![0.0; nb]);
        let (mut f1_prev, mut f2_prev) = (vec![0.0; nb], vec![0.0; nb]);
        let mut b = vec![0.0; nb];
        for i in 0..m {
            let s = i as f64 * scaled_dt;
            let y1 = (-a * s / 2.0).exp();
            let y2 = s * y1;
            let h = Homogeneous {
                y1,
                y2,
                dy1: -a / 2.0 * y1,
                dy2: -a / 2.0 * y2 + y1,
            };
            homogeneous.push(h);
            let grow = (a * s / 2.0).exp();
            let x = phase.phase(s * cfg.tau);
            basis.row(x, &mut b);
            for j in 0..nb {
                let f2 = grow * x * b[j];
                let f1 = s * f2;
                if i > 0 {
                    p1[j] += 0.5 * (f1_prev[j] + f1) * scaled_dt;
                    p2[j] += 0.5 * (f2_prev[j] + f2) * scaled_dt;
                }
                f1_prev[j] = f1;
                f2_prev[j] = f2;
                phi[i * cols + j] = p2[j] * h.y2 - p1[j] * h.y1;
                dphi[i * cols + j] = p2[j] * h.dy2 - p1[j] * h.dy1;
            }
            // The goal's forcing α²/4 integrated in closed form.
            let q1 = (a * s / 2.0 - 1.0) * grow + 1.0;
            let q2 = a / 2.0 * (grow - 1.0);
            phi[i * cols + nb] = q2 * h.y2 - q1 * h.y1;
            dphi[i * cols + nb] = q2 * h.dy2 - q1 * h.dy1;
        }
        let mut scale: Vec<f64> = (0..cols)
            .map(|j| {
                if j < nb {
                    cfg.weights_scale
                } else {
                    cfg.goal_scale
                }
            })
            .collect();
        if cfg.auto_scale_basis {
            for (j, sc) in scale.iter_mut().enumerate() {
                let max = (0..m).map(|i| phi[i * cols + j]).fold(f64::MIN, f64::max);
                *sc /= max;
            }
        }
        Ok(Self {
            cfg,
            phase,
            basis,
            scaled_dt,
            homogeneous,
            phi,
            dphi,
            scale,
        })
    }

    /// The config.
    pub fn cfg(&self) -> &ProDmpCfg {
        &self.cfg
    }

    /// The RBF basis (centres in phase, widths).
    pub fn basis(&self) -> &ZeroPaddedRbf {
        &self.basis
    }

    /// The phase.
    pub fn phase(&self) -> &ExpDecayPhase {
        &self.phase
    }

    /// Parameters per dof: the weights, then the goal unless `disable_goal`.
    pub fn params_per_dof(&self) -> usize {
        self.cfg.num_basis + usize::from(!self.cfg.disable_goal)
    }

    /// Parameters per env, dof-major (`index = dof·params_per_dof + k`).
    pub fn num_params(&self) -> usize {
        self.cfg.num_dof * self.params_per_dof()
    }

    /// The per-column parameter scales (weights, then the goal), auto-scaling included.
    pub fn column_scales(&self) -> &[f64] {
        &self.scale
    }

    /// The last scaled time the grid covers.
    pub fn grid_end(&self) -> f64 {
        (self.homogeneous.len() - 1) as f64 * self.scaled_dt
    }

    /// Linear interpolation on the grid at scaled time `s`: `(row i, weight of row i + 1)`.
    fn locate(&self, s: f64) -> (usize, f64) {
        let index = s / self.scaled_dt;
        let i = (index.floor().max(0.0) as usize).min(self.homogeneous.len() - 2);
        (i, index - i as f64)
    }

    fn homogeneous_at(&self, s: f64) -> Homogeneous {
        let (i, f) = self.locate(s);
        let (a, b) = (self.homogeneous[i], self.homogeneous[i + 1]);
        let lerp = |u: f64, v: f64| u + f * (v - u);
        Homogeneous {
            y1: lerp(a.y1, b.y1),
            y2: lerp(a.y2, b.y2),
            dy1: lerp(a.dy1, b.dy1),
            dy2: lerp(a.dy2, b.dy2),
        }
    }

    /// `Φ` and `Φ̇` (all columns) at scaled time `s`, written into `phi` and `dphi`.
    fn basis_at(&self, s: f64, phi: &mut [f64], dphi: &mut [f64]) {
        let (i, f) = self.locate(s);
        let cols = self.cfg.num_basis + 1;
        for j in 0..cols {
            let (a, b) = (i * cols + j, (i + 1) * cols + j);
            phi[j] = self.phi[a] + f * (self.phi[b] - self.phi[a]);
            dphi[j] = self.dphi[a] + f * (self.dphi[b] - self.dphi[a]);
        }
    }

    /// The sample times `t0 + k·dt`, `k = 1..=num_steps`.
    pub fn times(&self, t0: f64) -> impl Iterator<Item = f64> + '_ {
        (1..=self.cfg.num_steps).map(move |k| t0 + k as f64 * self.cfg.dt)
    }

    /// Trajectories of `n` envs starting at time `t0` from position `q0` and velocity `v0`
    /// (`[n × num_dof]` each; the trajectory meets both exactly at `t0`): `params`
    /// `[n × num_params]` → `pos` and `vel` `[n × num_steps × num_dof]` sampled at
    /// `t0 + k·dt`, `k = 1..=num_steps`, velocities analytic. Nothing is written if an input
    /// is invalid.
    pub fn trajectories(
        &self,
        t0: f64,
        params: &[f32],
        q0: &[f32],
        v0: &[f32],
        pos: &mut [f32],
        vel: &mut [f32],
    ) -> Result<(), MpError> {
        let (dof, steps) = (self.cfg.num_dof, self.cfg.num_steps);
        let n = q0.len() / dof;
        crate::check_inputs(
            n,
            &[
                ("params", params, self.num_params()),
                ("q0", q0, dof),
                ("v0", v0, dof),
            ],
            &[
                ("pos", pos.len(), steps * dof),
                ("vel", vel.len(), steps * dof),
            ],
        )?;
        check_number("t0", t0, false)?;
        let t_end = t0 + steps as f64 * self.cfg.dt;
        if self.phase.scaled_time(t_end) > self.grid_end() + 1e-9 {
            return Err(MpError::InvalidConfig {
                field: "pre_compute_length_factor",
                message: format!(
                    "the trajectory ends at scaled time {:.3}, beyond the tabulated {:.3}; \
                     raise the factor",
                    self.phase.scaled_time(t_end),
                    self.grid_end()
                ),
            });
        }
        // Per sample: ξ1, ξ2 (and their derivatives) and the rows H, Ḣ (weight columns scaled,
        // the goal column not); shared by every env.
        let cols = self.cfg.num_basis + 1;
        let s0 = self.phase.scaled_time(t0);
        let h0 = self.homogeneous_at(s0);
        let det = h0.y1 * h0.dy2 - h0.y2 * h0.dy1;
        let (mut phi0, mut dphi0) = (vec![0.0; cols], vec![0.0; cols]);
        self.basis_at(s0, &mut phi0, &mut dphi0);
        let mut xi = vec![[0.0f64; 4]; steps];
        let mut rows = vec![0.0; steps * cols];
        let mut drows = vec![0.0; steps * cols];
        let (mut phi, mut dphi) = (vec![0.0; cols], vec![0.0; cols]);
        for (k, t) in self.times(t0).enumerate() {
            let s = self.phase.scaled_time(t);
            let h = self.homogeneous_at(s);
            self.basis_at(s, &mut phi, &mut dphi);
            let xi1 = (h0.dy2 * h.y1 - h0.dy1 * h.y2) / det;
            let xi2 = (h0.y1 * h.y2 - h0.y2 * h.y1) / det;
            let xi3 = (h0.dy1 * h.y2 - h0.dy2 * h.y1) / det;
            let xi4 = (h0.y2 * h.y1 - h0.y1 * h.y2) / det;
            let dxi1 = (h0.dy2 * h.dy1 - h0.dy1 * h.dy2) / det;
            let dxi2 = (h0.y1 * h.dy2 - h0.y2 * h.dy1) / det;
            let dxi3 = (h0.dy1 * h.dy2 - h0.dy2 * h.dy1) / det;
            let dxi4 = (h0.y2 * h.dy1 - h0.y1 * h.dy2) / det;
            xi[k] = [xi1, xi2, dxi1, dxi2];
            for j in 0..cols {
                let sc = if j < self.cfg.num_basis {
                    self.scale[j]
                } else {
                    1.0
                };
                rows[k * cols + j] = (xi3 * phi0[j] + xi4 * dphi0[j] + phi[j]) * sc;
                drows[k * cols + j] = (dxi3 * phi0[j] + dxi4 * dphi0[j] + dphi[j]) * sc;
            }
        }
        let (nb, ppd, tau) = (self.cfg.num_basis, self.params_per_dof(), self.cfg.tau);
        let (disable_goal, relative_goal) = (self.cfg.disable_goal, self.cfg.relative_goal);
        let goal_scale = self.scale[nb];
        let per_env = steps * dof;
        pos.par_chunks_mut(per_env)
            .zip(vel.par_chunks_mut(per_env))
            .enumerate()
            .for_each(|(e, (pos, vel))| {
                for d in 0..dof {
                    let theta = &params[(e * dof + d) * ppd..(e * dof + d + 1) * ppd];
                    let q = f64::from(q0[e * dof + d]);
                    let v = f64::from(v0[e * dof + d]) * tau;
                    // The goal: the scaled parameter (or 0), plus the start if relative.
                    let mut goal = if disable_goal {
                        0.0
                    } else {
                        goal_scale * f64::from(theta[nb])
                    };
                    if relative_goal {
                        goal += q;
                    }
                    for k in 0..steps {
                        let (row, drow) = (
                            &rows[k * cols..(k + 1) * cols],
                            &drows[k * cols..(k + 1) * cols],
                        );
                        let [xi1, xi2, dxi1, dxi2] = xi[k];
                        let mut y = xi1 * q + xi2 * v;
                        let mut dy = dxi1 * q + dxi2 * v;
                        for j in 0..nb {
                            let w = f64::from(theta[j]);
                            y += row[j] * w;
                            dy += drow[j] * w;
                        }
                        y += row[nb] * goal;
                        dy += drow[nb] * goal;
                        pos[k * dof + d] = y as f32;
                        vel[k * dof + d] = (dy / tau) as f32;
                    }
                }
            });
        Ok(())
    }
}
