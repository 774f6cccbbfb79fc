//! Running observation normalisation (RSL-RL's `EmpiricalNormalization`).

use serde::{Deserialize, Serialize};

/// Columns whose statistics one pass over the rows accumulates (on the stack).
const COLUMN_BLOCK: usize = 64;

/// Normalises each observation dimension by running statistics: `(x − μ) / (σ + ε)` with
/// `ε = 0.01`. In training, every batch of rows updates the statistics with the batch mean and
/// the biased batch variance, until `until` rows have been seen; then they are frozen.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct EmpiricalNormalizer {
    /// Running mean per dimension.
    pub mean: Vec<f32>,
    /// Running (biased) variance per dimension.
    pub var: Vec<f32>,
    /// Rows seen.
    pub count: u64,
    /// Rows after which the statistics stop changing.
    pub until: u64,
    /// Added to the standard deviation.
    pub eps: f32,
}

impl EmpiricalNormalizer {
    /// Statistics of a `dim`-dimensional input: mean 0, variance 1, frozen after `until` rows.
    pub fn new(dim: usize, until: u64) -> Self {
        Self {
            mean: vec![0.0; dim],
            var: vec![1.0; dim],
            count: 0,
            until,
            eps: 1e-2,
        }
    }

    /// Input dimension.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Folds a batch of rows (`x.len() = rows · dim`) into the statistics, unless frozen.
    /// Sums run in `f64` in row order, so the result does not depend on threads.
    pub fn update(&mut self, x: &[f32]) {
        let d = self.dim();
        let n = x.len() / d;
        if n == 0 || self.count >= self.until {
            return;
        }
        self.count += n as u64;
        let rate = n as f64 / self.count as f64;
        // Columns in blocks of COLUMN_BLOCK, each block in two row-order passes (sums, then
        // squared deviations): the rows are read contiguously, and each column's sums keep
        // the row order.
        for first in (0..d).step_by(COLUMN_BLOCK) {
            let width = COLUMN_BLOCK.min(d - first);
            let mut sum = [0.0f64; COLUMN_BLOCK];
            for row in x.chunks_exact(d) {
                for (s, &v) in sum.iter_mut().zip(&row[first..first + width]) {
                    *s += f64::from(v);
                }
            }
            let batch_mean = sum.map(|s| s / n as f64);
            let mut sq = [0.0f64; COLUMN_BLOCK];
            for row in x.chunks_exact(d) {
                for ((q, &v), &m) in sq
                    .iter_mut()
                    .zip(&row[first..first + width])
                    .zip(&batch_mean)
                {
                    *q += (f64::from(v) - m).powi(2);
                }
            }
            for k in 0..width {
                let j = first + k;
                let batch_var = sq[k] / n as f64;
                let (mean, var) = (f64::from(self.mean[j]), f64::from(self.var[j]));
                let delta = batch_mean[k] - mean;
                let new_mean = mean + rate * delta;
                let new_var = var + rate * (batch_var - var + delta * (batch_mean[k] - new_mean));
                self.mean[j] = new_mean as f32;
                self.var[j] = new_var as f32;
            }
        }
    }

    /// Normalises rows in place.
    pub fn normalize(&self, x: &mut [f32]) {
        let d = self.dim();
        for row in x.chunks_exact_mut(d) {
            for ((v, &m), &var) in row.iter_mut().zip(&self.mean).zip(&self.var) {
                *v = (*v - m) / (var.sqrt() + self.eps);
            }
        }
    }

    /// Inverts [`normalize`](Self::normalize) in place: `x·(σ + ε) + μ`.
    pub fn denormalize(&self, x: &mut [f32]) {
        let d = self.dim();
        for row in x.chunks_exact_mut(d) {
            for ((v, &m), &var) in row.iter_mut().zip(&self.mean).zip(&self.var) {
                *v = *v * (var.sqrt() + self.eps) + m;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// After two batches the statistics equal those of the concatenated data (the parallel
    /// variance formula is exact), and normalising gives `(x − μ)/(σ + 0.01)`.
    #[test]
    fn batches_combine_exactly() {
        let a = [1.0f32, 10.0, 3.0, 14.0];
        let b = [5.0f32, 30.0, 7.0, 34.0, 9.0, 38.0];
        let mut n = EmpiricalNormalizer::new(2, u64::MAX);
        n.update(&a);
        n.update(&b);
        // Column 0: 1, 3, 5, 7, 9 → mean 5, biased variance 8; column 1: mean 25.2.
        assert!((n.mean[0] - 5.0).abs() < 1e-6 && (n.var[0] - 8.0).abs() < 1e-5);
        let c1 = [10.0f32, 14.0, 30.0, 34.0, 38.0];
        let m1 = c1.iter().sum::<f32>() / 5.0;
        let v1 = c1.iter().map(|v| (v - m1).powi(2)).sum::<f32>() / 5.0;
        assert!((n.mean[1] - m1).abs() < 1e-5 && (n.var[1] - v1).abs() < 1e-3);
        let mut x = [5.0f32 + 8f32.sqrt(), m1];
        n.normalize(&mut x);
        assert!((x[0] - 8f32.sqrt() / (8f32.sqrt() + 0.01)).abs() < 1e-6 && x[1].abs() < 1e-6);
        assert_eq!(n.count, 5);
        n.denormalize(&mut x);
        assert!((x[0] - (5.0 + 8f32.sqrt())).abs() < 1e-5 && (x[1] - m1).abs() < 1e-5);
    }

    /// Past `until` rows, updates leave the statistics unchanged.
    #[test]
    fn freezes_after_until() {
        let mut n = EmpiricalNormalizer::new(1, 2);
        n.update(&[1.0, 3.0]);
        let frozen = n.clone();
        n.update(&[100.0]);
        assert_eq!(n, frozen);
    }
}
