//! Ctrl-C and SIGTERM during training: the first asks the runner to stop with a checkpoint, a
//! later one ends the process.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// Signals within this time of the first one count as the same request: a wrapper such as
/// `timeout` sends its signal to the command and again to its process group.
const SIGNAL_GRACE: std::time::Duration = std::time::Duration::from_secs(1);

/// A flag that the first SIGINT (Ctrl-C) or SIGTERM sets; a later one (more than a second
/// after it) ends the process at once with exit code 130. Pass it to
/// [`train_with`](crate::train::train_with) to stop training with a checkpoint.
pub fn stop_on_signals() -> std::io::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    // Nanoseconds after `origin` of the first signal (0: none yet).
    let first = Arc::new(std::sync::atomic::AtomicU64::new(0));
    let origin = std::time::Instant::now();
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        let (stop, first) = (Arc::clone(&stop), Arc::clone(&first));
        let handler = move || {
            let now = (origin.elapsed().as_nanos() as u64).max(1);
            if on_signal(&first, &stop, now) {
                signal_hook::low_level::exit(130)
            }
        };
        // SAFETY: the handler only reads the monotonic clock (clock_gettime), uses atomics and
        // calls `_exit`, all async-signal-safe; it allocates and locks nothing.
        unsafe { signal_hook::low_level::register(signal, handler) }?;
    }
    Ok(stop)
}

/// What a stop signal at `now` (nanoseconds, > 0) does: the first sets `stop` and is recorded
/// in `first`; one within [`SIGNAL_GRACE`] of it does nothing; a later one asks for an exit
/// (returns true). Only atomics: it runs in a signal handler.
fn on_signal(first: &std::sync::atomic::AtomicU64, stop: &AtomicBool, now: u64) -> bool {
    use std::sync::atomic::Ordering::SeqCst;
    match first.compare_exchange(0, now, SeqCst, SeqCst) {
        Ok(_) => {
            stop.store(true, SeqCst);
            false
        }
        Err(at) => now.saturating_sub(at) > SIGNAL_GRACE.as_nanos() as u64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first signal requests the stop; a repeat within a second (a wrapper's second
    /// delivery) is the same request; one after that aborts.
    #[test]
    fn a_second_signal_aborts_only_after_the_grace_time() {
        let (first, stop) = (std::sync::atomic::AtomicU64::new(0), AtomicBool::new(false));
        let second = 1_000_000_000u64;
        assert!(!on_signal(&first, &stop, 5 * second));
        assert!(stop.load(std::sync::atomic::Ordering::SeqCst));
        assert!(!on_signal(&first, &stop, 5 * second + second / 10));
        assert!(on_signal(&first, &stop, 6 * second + second / 10));
    }
}
