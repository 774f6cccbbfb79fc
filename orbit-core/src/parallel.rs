//! Conventions for loops that run over envs on every core.
//!
//! Per-env work (a reward term, an observation's noise, an action sample) reads and writes only
//! its env's rows and draws only from its env's random stream, so running envs in parallel gives
//! the same bits as running them in order, on any number of threads. Sums across envs are the
//! exception: they go through fixed-size blocks added in block order.

/// Envs per parallel task (rayon's `with_min_len`) for per-env arithmetic (a reward term, an
/// observation's noise, an action sample): smaller tasks would cost more in scheduling than the
/// per-env work they carry, and a small batch stays on one thread.
pub const MIN_ENVS_PER_TASK: usize = 512;

/// Envs per parallel task for loops that only copy or scale a few values per env. Waking the
/// pool's threads costs about 0.1 ms on an H100 GPU machine's host, more than such a loop over
/// 4 096 envs takes on one thread, so only batches of tens of thousands of envs split.
pub const MIN_ENVS_PER_COPY_TASK: usize = 1 << 14;

/// Runs `f` on a pool of its own with `threads` threads: every parallel loop inside it splits
/// over that many. For checking that a result does not depend on the number of threads.
pub fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool of that size can be built")
        .install(f)
}

/// Fills `out`, `dim` values per env, with `row(env, values)` for every env; envs run in
/// parallel in tasks of at least [`MIN_ENVS_PER_TASK`]. The loop of a per-env term (a
/// reward, an observation) that reads only its env's state.
pub fn fill_rows(out: &mut [f32], dim: usize, row: impl Fn(usize, &mut [f32]) + Sync + Send) {
    use rayon::prelude::*;
    if dim == 0 {
        return;
    }
    out.par_chunks_mut(dim)
        .enumerate()
        .with_min_len(MIN_ENVS_PER_TASK)
        .for_each(|(e, values)| row(e, values));
}

/// Values per parallel task for element-wise scans of a batch (well under a nanosecond each):
/// 4 096 envs' observations are scanned on one thread.
const MIN_VALUES_PER_TASK: usize = 1 << 18;

/// Copies `src` into `dst` (of the same length) on every core for large batches.
pub fn copy(src: &[f32], dst: &mut [f32]) {
    use rayon::prelude::*;
    assert_eq!(
        src.len(),
        dst.len(),
        "copy between batches of different sizes"
    );
    dst.par_chunks_mut(MIN_VALUES_PER_TASK)
        .zip(src.par_chunks(MIN_VALUES_PER_TASK))
        .for_each(|(d, s)| d.copy_from_slice(s));
}

/// A copy of `src` in a new vector, written on every core for large batches (straight into
/// the new allocation: no zeroing pass first).
pub fn to_vec(src: &[f32]) -> Vec<f32> {
    use rayon::prelude::*;
    src.par_iter()
        .with_min_len(MIN_VALUES_PER_TASK)
        .copied()
        .collect()
}

/// Values per block of [`first_beyond`]: a whole block is checked without branching, so that
/// the check vectorises, and only a block found to hold a bad value is searched for it.
const SCAN_BLOCK: usize = 1 << 12;

/// The index of the first value that is NaN or infinite, scanned on every core; the same
/// index a sequential scan finds.
pub fn first_non_finite(values: &[f32]) -> Option<usize> {
    first_beyond(values, f32::MAX)
}

/// The index of the first value whose magnitude exceeds `limit` (≥ 0) or that is NaN, scanned
/// on every core; the same index a sequential scan finds.
pub fn first_beyond(values: &[f32], limit: f32) -> Option<usize> {
    use rayon::prelude::*;
    let limit = limit.abs().to_bits();
    let block = values
        .par_chunks(SCAN_BLOCK)
        .with_min_len(MIN_VALUES_PER_TASK / SCAN_BLOCK)
        .position_first(|b| max_magnitude_bits(b) > limit)?;
    let start = block * SCAN_BLOCK;
    let end = (start + SCAN_BLOCK).min(values.len());
    values[start..end]
        .iter()
        .position(|v| magnitude_bits(*v) > limit)
        .map(|i| start + i)
}

/// The bits of `|v|`: for non-negative floats the integer order is the numeric order, with
/// infinity above every finite value and NaN above infinity.
fn magnitude_bits(v: f32) -> u32 {
    v.to_bits() & 0x7fff_ffff
}

/// The largest [`magnitude_bits`] of `values`, without an early exit so that the compiler
/// vectorises it.
fn max_magnitude_bits(values: &[f32]) -> u32 {
    values.iter().fold(0, |max, v| max.max(magnitude_bits(*v)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A copy split over threads holds every value in its place.
    #[test]
    fn to_vec_copies_in_order_on_any_number_of_threads() {
        let src: Vec<f32> = (0..3 * MIN_VALUES_PER_TASK + 5).map(|i| i as f32).collect();
        for threads in [1, 3] {
            assert_eq!(
                on_threads(threads, || to_vec(&src)),
                src,
                "{threads} threads"
            );
        }
    }

    #[test]
    fn first_non_finite_is_the_first_on_any_number_of_threads() {
        let mut values = vec![1.0f32; 5 * MIN_VALUES_PER_TASK + 3];
        assert_eq!(first_non_finite(&values), None);
        values[4 * MIN_VALUES_PER_TASK + 1] = f32::INFINITY;
        values[3 * MIN_VALUES_PER_TASK + 7] = f32::NAN;
        for threads in [1, 3] {
            let found = on_threads(threads, || first_non_finite(&values));
            assert_eq!(
                found,
                Some(3 * MIN_VALUES_PER_TASK + 7),
                "{threads} threads"
            );
        }
    }

    /// The extremes of the finite range pass; either infinity and NaN of any sign are found,
    /// also in the last, partial block.
    #[test]
    fn first_non_finite_finds_every_kind_of_bad_value() {
        let mut values = vec![0.5f32; 3 * SCAN_BLOCK + 5];
        let last = values.len() - 1;
        values[..4].copy_from_slice(&[f32::MAX, f32::MIN, f32::MIN_POSITIVE / 2.0, -0.0]);
        assert_eq!(first_non_finite(&values), None);
        for bad in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN, -f32::NAN] {
            values[last] = bad;
            assert_eq!(first_non_finite(&values), Some(last), "{bad}");
        }
    }

    /// Values at the limit pass; the first beyond it (either sign) or NaN is found.
    #[test]
    fn first_beyond_compares_magnitudes() {
        let mut values = vec![-2.0f32, 2.0, 1.5, -1.0];
        assert_eq!(first_beyond(&values, 2.0), None);
        assert_eq!(first_beyond(&values, 1.9), Some(0));
        values[0] = 0.0;
        assert_eq!(first_beyond(&values, 1.9), Some(1));
        values[1] = 0.0;
        values[3] = f32::NAN;
        assert_eq!(first_beyond(&values, 1.9), Some(3));
    }
}
