//! Movement primitives for episodic (black-box) RL, following MP_PyTorch 0.1.3 as Fancy Gym's
//! box pushing uses it (ProMP: Paraschos et al. 2013; ProDMP: Li et al. 2023): a linear phase, a
//! zero-padded normalised RBF basis and ProMP trajectories, and ProDMP with its exponential phase,
//! generated for all envs at once.

mod basis;
mod error;
mod phase;
mod prodmp;
mod promp;

pub use basis::ZeroPaddedRbf;
pub use error::MpError;
pub use phase::{ExpDecayPhase, LinearPhase};
pub use prodmp::{ProDmp, ProDmpCfg};
pub use promp::{ProMp, ProMpCfg};

/// Checks a config number: finite, and above zero if `positive`.
pub(crate) fn check_number(field: &'static str, v: f64, positive: bool) -> Result<(), MpError> {
    if v.is_finite() && (!positive || v > 0.0) {
        Ok(())
    } else {
        let what = if positive { "positive" } else { "finite" };
        Err(MpError::InvalidConfig {
            field,
            message: format!("expected a {what} number, got {v}"),
        })
    }
}

/// Checks the inputs of a batched trajectory call for `n` envs: each input `(name, values,
/// width)` must hold `n × width` finite values, each output `(name, len, width)` `n × width`.
pub(crate) fn check_inputs(
    n: usize,
    inputs: &[(&'static str, &[f32], usize)],
    outputs: &[(&'static str, usize, usize)],
) -> Result<(), MpError> {
    let lengths = inputs
        .iter()
        .map(|&(name, v, w)| (name, v.len(), w))
        .chain(outputs.iter().copied());
    for (name, got, width) in lengths {
        if got != n * width {
            return Err(MpError::Length {
                name,
                expected: n * width,
                got,
            });
        }
    }
    for &(name, values, width) in inputs {
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(MpError::NonFinite {
                name,
                env: i / width,
                value: values[i],
            });
        }
    }
    Ok(())
}
