//! Conventions for loops that run over envs on every core.
//!
//! Per-env work (a reward term, an observation's noise, an action sample) reads and writes only
//! its env's rows and draws only from its env's random stream, so running envs in parallel gives
//! the same bits as running them in order, on any number of threads. Sums across envs are the
//! exception: they go through fixed-size blocks added in block order.

/// Envs per parallel task (rayon's `with_min_len`): smaller tasks would cost more in scheduling
/// than the per-env work they carry, and a small batch stays on one thread.
pub const MIN_ENVS_PER_TASK: usize = 512;

/// Runs `f` on a pool of its own with `threads` threads: every parallel loop inside it splits
/// over that many. For checking that a result does not depend on the number of threads.
pub fn on_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool of that size can be built")
        .install(f)
}
