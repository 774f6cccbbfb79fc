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
