//! Conventions for loops that run over envs on every core.
//!
//! Per-env work (a reward term, an observation's noise, an action sample) reads and writes only
//! its env's rows and draws only from its env's random stream, so running envs in parallel gives
//! the same bits as running them in order, on any number of threads. Sums across envs are the
//! exception: they go through fixed-size blocks added in block order.

/// Envs per parallel task (rayon's `with_min_len`): smaller tasks would cost more in scheduling
/// than the per-env work they carry, and a small batch stays on one thread.
pub const MIN_ENVS_PER_TASK: usize = 512;
