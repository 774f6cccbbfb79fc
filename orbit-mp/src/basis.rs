//! The zero-padded normalised RBF basis (MP_PyTorch's
//! `ZeroPaddingNormalizedRBFBasisGenerator`): `N = zero_start + learned + zero_goal` Gaussians
//! with centres evenly spaced over the phase [0, 1], widths `h_j = bandwidth_factor / Δ_j²`
//! (`Δ_j` the spacing to the next centre, the last one repeated), normalised to sum to 1 over
//! all `N`. The padded functions carry no weights: they pin the trajectory near its offset at
//! the start (and goal).

use crate::MpError;

/// The basis functions of one primitive.
#[derive(Clone, Debug, PartialEq)]
pub struct ZeroPaddedRbf {
    zero_start: usize,
    learned: usize,
    centres: Vec<f64>,
    widths: Vec<f64>,
}

impl ZeroPaddedRbf {
    /// `learned` weighted functions between `zero_start` and `zero_goal` padded ones.
    pub fn new(
        learned: usize,
        zero_start: usize,
        zero_goal: usize,
        bandwidth_factor: f64,
    ) -> Result<Self, MpError> {
        if learned == 0 {
            return Err(MpError::InvalidConfig {
                field: "num_basis",
                message: "at least one basis function is needed".into(),
            });
        }
        crate::check_number("basis_bandwidth_factor", bandwidth_factor, true)?;
        let n = zero_start + learned + zero_goal;
        let centres: Vec<f64> = if n == 1 {
            vec![0.0]
        } else {
            (0..n).map(|j| j as f64 / (n - 1) as f64).collect()
        };
        Ok(Self::with_centres(
            centres,
            zero_start,
            learned,
            bandwidth_factor,
        ))
    }

    /// A basis with the given centres (phase values; ProDMP maps times evenly spaced over
    /// τ through its exponential phase), the first `zero_start` of them unweighted.
    pub(crate) fn with_centres(
        centres: Vec<f64>,
        zero_start: usize,
        learned: usize,
        bandwidth_factor: f64,
    ) -> Self {
        let n = centres.len();
        let widths = (0..n)
            .map(|j| {
                let spacing = if n == 1 {
                    1.0
                } else if j + 1 < n {
                    centres[j + 1] - centres[j]
                } else {
                    centres[n - 1] - centres[n - 2]
                };
                bandwidth_factor / (spacing * spacing)
            })
            .collect();
        Self {
            zero_start,
            learned,
            centres,
            widths,
        }
    }

    /// All functions, padded ones included.
    pub fn len(&self) -> usize {
        self.centres.len()
    }

    /// Always false: a basis has at least one learned function.
    pub fn is_empty(&self) -> bool {
        self.centres.is_empty()
    }

    /// The weighted functions (columns `zero_start .. zero_start + learned` of a row).
    pub fn learned(&self) -> std::ops::Range<usize> {
        self.zero_start..self.zero_start + self.learned
    }

    /// Centres in phase.
    pub fn centres(&self) -> &[f64] {
        &self.centres
    }

    /// Widths `h_j`.
    pub fn widths(&self) -> &[f64] {
        &self.widths
    }

    /// Writes the normalised values of all functions at phase `x` into `out` (`len()` values).
    pub fn row(&self, x: f64, out: &mut [f64]) {
        for ((o, &c), &h) in out.iter_mut().zip(&self.centres).zip(&self.widths) {
            *o = (-0.5 * h * (x - c) * (x - c)).exp();
        }
        let sum: f64 = out.iter().sum();
        for o in out.iter_mut() {
            *o /= sum;
        }
    }
}
