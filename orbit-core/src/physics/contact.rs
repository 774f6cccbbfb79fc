//! The wgpu backend's contact model: MuJoCo's soft constraints (`solref`, `solimp`,
//! `impratio`), solved as MuJoCo does, or rigid friction with Box2D's soft step (docs/physics.md).
//! The rapier backend keeps rapier's own contact model and ignores these values.

use serde::{Deserialize, Serialize};

use super::PhysicsError;

/// How contacts and joint limits resolve penetration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum ContactModel {
    /// MuJoCo's soft constraints with `solref`, `solimp` and `impratio` (the simulator of
    /// Fancy Gym's tasks). Default solver: 12 over-relaxed Gauss–Seidel sweeps.
    MuJoCo,
    /// Rigid rows (friction included) that push out of penetration like a spring of
    /// `frequency` (rad/s) and `damping_ratio`, with relaxation sweeps after the position update
    /// so that pushing out adds no velocity (Box2D's soft step; near-rigid contacts as PhysX
    /// gives the Orbit port). Default solver: 4 iterations, each a sweep before and one after
    /// the position update.
    SoftStep {
        /// Natural frequency of the push-out (rad/s).
        frequency: f32,
        /// Its damping ratio.
        damping_ratio: f32,
    },
}

/// Contact and joint-limit constraints. The defaults are MuJoCo's, which every contact of Fancy
/// Gym's box-pushing scene uses.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ContactCfg {
    /// The contact model; `solref`, `solimp` and `impratio` apply to `MuJoCo`.
    pub model: ContactModel,
    /// `(timeconst, dampratio)`: a penetration recovers like a mass-spring-damper of this time
    /// constant (s) and damping ratio. Smaller is stiffer; as in MuJoCo, a time constant under
    /// `2 · dt` counts as `2 · dt` (its stability limit).
    pub solref: (f32, f32),
    /// `(d0, dwidth, width, midpoint)`: the impedance rises from `d0` at contact to `dwidth`
    /// at `width` (m) of penetration, along a power-2 sigmoid with this midpoint. The share
    /// of the constraint force that the reference acceleration sets is the impedance; the rest
    /// lets the unconstrained motion through.
    pub solimp: (f32, f32, f32, f32),
    /// Friction rows are `impratio` times harder than the normal row (MuJoCo's elliptic cones).
    pub impratio: f32,
}

impl Default for ContactCfg {
    fn default() -> Self {
        Self {
            model: ContactModel::MuJoCo,
            solref: (0.02, 1.0),
            solimp: (0.9, 0.95, 0.001, 0.5),
            impratio: 3.0,
        }
    }
}

impl ContactCfg {
    /// The time constant in use at physics step `dt`: at least `2 · dt`.
    pub fn timeconst(&self, dt: f32) -> f32 {
        self.solref.0.max(2.0 * dt)
    }

    /// Reference-acceleration stiffness `K = 1 / (dwidth² · timeconst² · dampratio²)` (1/s²)
    /// at physics step `dt`.
    pub fn stiffness(&self, dt: f32) -> f32 {
        let (tc, ratio) = (self.timeconst(dt), self.solref.1);
        1.0 / (self.solimp.1 * self.solimp.1 * tc * tc * ratio * ratio)
    }

    /// Reference-acceleration damping `B = 2 / (dwidth · timeconst)` (1/s) at physics step
    /// `dt`. Below the slip speed `μ g / B` friction acts as a damper of this rate.
    pub fn damping(&self, dt: f32) -> f32 {
        2.0 / (self.solimp.1 * self.timeconst(dt))
    }

    /// Checks the values are usable.
    pub fn validate(&self) -> Result<(), PhysicsError> {
        let bad = |what: String| Err(PhysicsError::InvalidInput(what));
        let (tc, ratio) = self.solref;
        if !(tc.is_finite() && tc > 0.0) {
            return bad(format!(
                "sim.contact.solref: the time constant must be a positive number of seconds, got {tc}"
            ));
        }
        if !(ratio.is_finite() && ratio > 0.0) {
            return bad(format!(
                "sim.contact.solref: the damping ratio must be positive, got {ratio}"
            ));
        }
        let (d0, dwidth, width, mid) = self.solimp;
        let impedance = |d: f32| d > 0.0 && d < 1.0;
        if !(impedance(d0) && impedance(dwidth)) {
            return bad(format!(
                "sim.contact.solimp: d0 and dwidth must lie in (0, 1), got ({d0}, {dwidth})"
            ));
        }
        if !(width.is_finite() && width > 0.0 && mid > 0.0 && mid < 1.0) {
            return bad(format!(
                "sim.contact.solimp: width must be positive and the midpoint in (0, 1), got ({width}, {mid})"
            ));
        }
        if !(self.impratio.is_finite() && self.impratio > 0.0) {
            return bad(format!(
                "sim.contact.impratio must be positive, got {}",
                self.impratio
            ));
        }
        if let ContactModel::SoftStep {
            frequency,
            damping_ratio,
        } = self.model
            && !(frequency.is_finite()
                && frequency > 0.0
                && damping_ratio.is_finite()
                && damping_ratio > 0.0)
        {
            return bad(format!(
                "sim.contact.model: SoftStep needs a positive frequency and damping ratio, got ({frequency}, {damping_ratio})"
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::ContactCfg;

    /// MuJoCo's defaults give K = 1 / (0.95² · 0.02²) and B = 2 / (0.95 · 0.02); a time
    /// constant under 2 dt counts as 2 dt.
    #[test]
    fn reference_coefficients() {
        let c = ContactCfg::default();
        assert!((c.stiffness(0.002) - 2770.083).abs() < 0.01);
        assert!((c.damping(0.002) - 105.263_16).abs() < 1e-3);
        let fast = ContactCfg {
            solref: (0.001, 1.0),
            ..Default::default()
        };
        let limit = ContactCfg {
            solref: (0.004, 1.0),
            ..Default::default()
        };
        assert_eq!(fast.stiffness(0.002), limit.stiffness(0.002));
        assert_eq!(fast.damping(0.002), limit.damping(0.002));
    }

    #[test]
    fn rejects_values_mujoco_would_not_use() {
        assert!(ContactCfg::default().validate().is_ok());
        let negative = ContactCfg {
            solref: (-0.02, 1.0),
            ..Default::default()
        };
        let err = negative.validate().unwrap_err().to_string();
        assert!(err.contains("sim.contact.solref"), "{err}");
        let impedance = ContactCfg {
            solimp: (0.9, 1.2, 0.001, 0.5),
            ..Default::default()
        };
        let err = impedance.validate().unwrap_err().to_string();
        assert!(err.contains("dwidth"), "{err}");
    }
}
