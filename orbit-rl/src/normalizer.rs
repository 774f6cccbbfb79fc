//! Running observation normalisation (RSL-RL's `EmpiricalNormalization`).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::collective::Collective;

/// Rows per block of the parallel passes. Fixed (not derived from the number of threads), so
/// that the statistics' summation order, and with it every bit of the result, is too.
const ROW_BLOCK: usize = 2048;

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
    /// The first non-finite statistic, as `mean[k]` or `var[k]`.
    pub fn first_non_finite(&self) -> Option<String> {
        let at = |name: &str, v: &[f32]| {
            (v.iter().position(|x| !x.is_finite())).map(|k| format!("{name}[{k}] ({})", v[k]))
        };
        at("mean", &self.mean).or_else(|| at("var", &self.var))
    }

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
    /// Rows are summed in `f64` in fixed blocks of [`ROW_BLOCK`] rows whose partial sums are
    /// added in block order, so the result depends on neither the number of threads nor
    /// their timing.
    pub fn update(&mut self, x: &[f32]) {
        if !self.frozen() {
            let batch = self.batch_stats(x);
            self.fold(&batch);
        }
    }

    /// [`update`](Self::update) with every rank's batch when `ranks` is a data-parallel run's
    /// group (else this process's alone): each rank's batch statistics are gathered and folded
    /// in rank order, so every rank holds the same statistics.
    pub fn update_across(&mut self, ranks: Option<&dyn Collective>, x: &[f32]) {
        let Some(c) = ranks else {
            return self.update(x);
        };
        // Frozen on one rank is frozen on all: they hold the same count.
        if self.frozen() {
            return;
        }
        let batch = self.batch_stats(x);
        let mut flat = Vec::with_capacity(1 + 2 * self.dim());
        flat.push(batch.rows as f64);
        flat.extend(&batch.mean);
        flat.extend(&batch.var);
        let d = self.dim();
        for rank in crate::collective::gather_f64(c, &flat) {
            self.fold(&BatchStats {
                rows: rank[0] as u64,
                mean: rank[1..1 + d].to_vec(),
                var: rank[1 + d..].to_vec(),
            });
        }
    }

    /// Whether the statistics have stopped changing.
    fn frozen(&self) -> bool {
        self.count >= self.until
    }

    /// The mean and biased variance of a batch of rows.
    fn batch_stats(&self, x: &[f32]) -> BatchStats {
        let d = self.dim();
        let n = x.len() / d;
        if n == 0 {
            return BatchStats {
                rows: 0,
                mean: vec![0.0; d],
                var: vec![0.0; d],
            };
        }
        let mean: Vec<f64> = column_sums(x, d, None)
            .into_iter()
            .map(|s| s / n as f64)
            .collect();
        let var = column_sums(x, d, Some(&mean))
            .into_iter()
            .map(|s| s / n as f64)
            .collect();
        BatchStats {
            rows: n as u64,
            mean,
            var,
        }
    }

    /// Folds a batch's statistics into the running ones (the exact pooled mean and variance).
    fn fold(&mut self, batch: &BatchStats) {
        if batch.rows == 0 || self.frozen() {
            return;
        }
        self.count += batch.rows;
        let rate = batch.rows as f64 / self.count as f64;
        for j in 0..self.dim() {
            let (mean, var) = (f64::from(self.mean[j]), f64::from(self.var[j]));
            let delta = batch.mean[j] - mean;
            let new_mean = mean + rate * delta;
            let new_var = var + rate * (batch.var[j] - var + delta * (batch.mean[j] - new_mean));
            self.mean[j] = new_mean as f32;
            self.var[j] = new_var as f32;
        }
    }

    /// The per-column divisors `σ + ε`.
    fn divisors(&self) -> Vec<f32> {
        self.var.iter().map(|v| v.sqrt() + self.eps).collect()
    }

    /// Normalises rows in place (on every core for large batches; each value independently).
    pub fn normalize(&self, x: &mut [f32]) {
        let divisors = self.divisors();
        self.for_rows(x, |row| {
            for ((v, &m), &s) in row.iter_mut().zip(&self.mean).zip(&divisors) {
                *v = (*v - m) / s;
            }
        });
    }

    /// Writes the normalised rows of `x` to `out` (the same values [`normalize`](Self::normalize)
    /// gives in place, without a separate copy).
    pub fn normalize_into(&self, x: &[f32], out: &mut [f32]) {
        assert_eq!(
            x.len(),
            out.len(),
            "input and output batches differ in size"
        );
        let divisors = self.divisors();
        self.for_rows_into(x, out, |x, out| {
            for (((o, &v), &m), &s) in out.iter_mut().zip(x).zip(&self.mean).zip(&divisors) {
                *o = (v - m) / s;
            }
        });
    }

    /// Inverts [`normalize`](Self::normalize) in place: `x·(σ + ε) + μ`.
    pub fn denormalize(&self, x: &mut [f32]) {
        let divisors = self.divisors();
        self.for_rows(x, |row| {
            for ((v, &m), &s) in row.iter_mut().zip(&self.mean).zip(&divisors) {
                *v = *v * s + m;
            }
        });
    }

    /// Applies `f` to every row, blocks of [`ROW_BLOCK`] rows in parallel.
    fn for_rows(&self, x: &mut [f32], f: impl Fn(&mut [f32]) + Sync) {
        let d = self.dim();
        x.par_chunks_mut(ROW_BLOCK * d)
            .for_each(|block| block.chunks_exact_mut(d).for_each(&f));
    }

    /// Applies `f` to every row of `x` and the same row of `out`, blocks of [`ROW_BLOCK`] rows
    /// in parallel.
    fn for_rows_into(&self, x: &[f32], out: &mut [f32], f: impl Fn(&[f32], &mut [f32]) + Sync) {
        let d = self.dim();
        out.par_chunks_mut(ROW_BLOCK * d)
            .zip(x.par_chunks(ROW_BLOCK * d))
            .for_each(|(out, x)| {
                for (out, x) in out.chunks_exact_mut(d).zip(x.chunks_exact(d)) {
                    f(x, out);
                }
            });
    }
}

/// The rows, mean and biased variance per column of one batch.
struct BatchStats {
    rows: u64,
    mean: Vec<f64>,
    var: Vec<f64>,
}

/// Per-column sums over the rows of `x` (`d` columns) of the values, or with `center` of their
/// squared deviations from it. Each block of [`ROW_BLOCK`] rows is summed in row order (in
/// parallel over blocks), then the blocks' sums in block order, so the result is the same on
/// any number of threads.
fn column_sums(x: &[f32], d: usize, center: Option<&[f64]>) -> Vec<f64> {
    let partial: Vec<Vec<f64>> = x
        .par_chunks(ROW_BLOCK * d)
        .map(|block| {
            let mut sums = vec![0.0f64; d];
            let rows = block.chunks_exact(d);
            match center {
                None => rows.for_each(|row| {
                    for (s, &v) in sums.iter_mut().zip(row) {
                        *s += f64::from(v);
                    }
                }),
                Some(c) => rows.for_each(|row| {
                    for ((s, &v), &c) in sums.iter_mut().zip(row).zip(c) {
                        *s += (f64::from(v) - c).powi(2);
                    }
                }),
            }
            sums
        })
        .collect();
    partial.into_iter().fold(vec![0.0; d], |mut total, sums| {
        for (t, s) in total.iter_mut().zip(sums) {
            *t += s;
        }
        total
    })
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

    /// Normalising into a second buffer gives the bits of normalising in place, over several
    /// row blocks.
    #[test]
    fn normalize_into_matches_in_place() {
        let rows = 2 * ROW_BLOCK + 5;
        let x: Vec<f32> = (0..rows * 3)
            .map(|i| (i % 89) as f32 * 0.37 - 9.0)
            .collect();
        let mut n = EmpiricalNormalizer::new(3, u64::MAX);
        n.update(&x);
        let mut in_place = x.clone();
        n.normalize(&mut in_place);
        let mut out = vec![0.0; x.len()];
        n.normalize_into(&x, &mut out);
        assert_eq!(out, in_place);
        assert!(out.iter().any(|&v| v != 0.0));
    }

    /// The statistics of a batch spanning several row blocks are the same bits on one thread
    /// and on four, and match the two-pass mean and variance of the data.
    #[test]
    fn statistics_do_not_depend_on_threads() {
        let rows = 3 * ROW_BLOCK + 17;
        let x: Vec<f32> = (0..rows * 2)
            .map(|i| {
                if i % 2 == 0 {
                    (i % 97) as f32
                } else {
                    -0.5 * (i % 13) as f32
                }
            })
            .collect();
        let stats = |threads: usize| {
            let mut n = EmpiricalNormalizer::new(2, u64::MAX);
            orbit_core::parallel::on_threads(threads, || n.update(&x));
            n
        };
        let (one, four) = (stats(1), stats(4));
        assert_eq!(one, four);
        for j in 0..2 {
            let col: Vec<f64> = x.iter().skip(j).step_by(2).map(|&v| f64::from(v)).collect();
            let mean = col.iter().sum::<f64>() / rows as f64;
            let var = col.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / rows as f64;
            assert!((f64::from(one.mean[j]) - mean).abs() < 1e-5 * mean.abs().max(1.0));
            assert!((f64::from(one.var[j]) - var).abs() < 1e-5 * var);
        }
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
