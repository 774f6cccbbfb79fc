//! The linear phase `x(t) = clip((t − delay)/τ, 0, 1)` (MP_PyTorch's `LinearPhaseGenerator`).

/// A linear phase running from 0 at `delay` to 1 at `delay + tau`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearPhase {
    /// Duration of the phase (s).
    pub tau: f64,
    /// Time at which the phase starts (s).
    pub delay: f64,
}

impl LinearPhase {
    /// The phase at time `t`.
    pub fn phase(&self, t: f64) -> f64 {
        ((t - self.delay) / self.tau).clamp(0.0, 1.0)
    }
}

/// The exponentially decaying phase `x(t) = exp(−α_x·s(t))`, `s(t) = max((t − delay)/τ, 0)`
/// (MP_PyTorch's `ExpDecayPhaseGenerator`), which drives DMPs and ProDMPs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExpDecayPhase {
    /// Time constant τ (s): the scaled time `s` reaches 1 at `delay + tau`.
    pub tau: f64,
    /// Time at which the phase starts decaying (s).
    pub delay: f64,
    /// Decay rate α_x.
    pub alpha_phase: f64,
}

impl ExpDecayPhase {
    /// The scaled time `s(t)`.
    pub fn scaled_time(&self, t: f64) -> f64 {
        ((t - self.delay) / self.tau).max(0.0)
    }

    /// The phase at scaled time `s`.
    pub fn phase_at_scaled(&self, s: f64) -> f64 {
        (-self.alpha_phase * s).exp()
    }

    /// The phase at time `t`.
    pub fn phase(&self, t: f64) -> f64 {
        self.phase_at_scaled(self.scaled_time(t))
    }
}
