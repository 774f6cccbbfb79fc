//! Ctrl-C and SIGTERM during training: the first asks the runner to stop with a checkpoint and
//! is acknowledged at once; the second only repeats that the checkpoint is coming (it may be
//! being written); the third ends the process without one.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Signals within this time of the last counted one count as the same request: a wrapper such
/// as `timeout` sends its signal to the command and again to its process group.
const SIGNAL_GRACE: Duration = Duration::from_secs(1);

/// The exit code of a run ended by a signal (128 + SIGINT, as shells report Ctrl-C).
const ABORT_EXIT_CODE: i32 = 130;

/// A flag that the first SIGINT (Ctrl-C) or SIGTERM sets; pass it to
/// [`train_with`](crate::train::train_with) to stop training with a checkpoint. Each signal is
/// acknowledged on standard error as it arrives; the third (each more than a second after the
/// one before) ends the process at once with exit code 130.
pub fn stop_on_signals() -> std::io::Result<Arc<AtomicBool>> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let stop = Arc::new(AtomicBool::new(false));
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
    let flag = Arc::clone(&stop);
    // A thread of its own, not the handler: it may print, and the runner may be deep in an
    // update that does not look at the flag for seconds.
    std::thread::Builder::new()
        .name("stop-signals".into())
        .spawn(move || {
            let mut requests = StopRequests::default();
            for _ in signals.forever() {
                match requests.on_signal(Instant::now()) {
                    Response::Stop => {
                        flag.store(true, Ordering::SeqCst);
                        eprintln!(
                            "\nstopping: a checkpoint will be written after the current step or \
                             update (press Ctrl-C twice more to abort without one)"
                        );
                    }
                    Response::StillStopping => eprintln!(
                        "\nstill stopping: waiting for the checkpoint (press Ctrl-C once more to \
                         abort without it)"
                    ),
                    Response::Same => {}
                    Response::Abort => {
                        eprintln!("\naborted: no checkpoint of the unfinished iterations");
                        std::process::exit(ABORT_EXIT_CODE)
                    }
                }
            }
        })?;
    Ok(stop)
}

/// What a stop signal asks for.
#[derive(Debug, PartialEq, Eq)]
enum Response {
    /// The first: stop with a checkpoint.
    Stop,
    /// Within [`SIGNAL_GRACE`] of the last counted one: nothing new.
    Same,
    /// The second: the stop (and its checkpoint) is under way.
    StillStopping,
    /// The third: end without waiting.
    Abort,
}

/// The stop signals counted so far.
#[derive(Debug, Default)]
struct StopRequests {
    count: u32,
    last: Option<Instant>,
}

impl StopRequests {
    fn on_signal(&mut self, now: Instant) -> Response {
        if self
            .last
            .is_some_and(|last| now.saturating_duration_since(last) <= SIGNAL_GRACE)
        {
            return Response::Same;
        }
        self.last = Some(now);
        self.count += 1;
        match self.count {
            1 => Response::Stop,
            2 => Response::StillStopping,
            _ => Response::Abort,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first signal requests the stop; a repeat within a second (a wrapper's second
    /// delivery) is the same request; the second counted one waits for the checkpoint, and
    /// only the third aborts.
    #[test]
    fn only_a_third_signal_aborts() {
        let mut r = StopRequests::default();
        let t0 = Instant::now();
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        assert_eq!(r.on_signal(at(0)), Response::Stop);
        assert_eq!(r.on_signal(at(100)), Response::Same);
        assert_eq!(r.on_signal(at(1_500)), Response::StillStopping);
        assert_eq!(r.on_signal(at(2_000)), Response::Same);
        assert_eq!(r.on_signal(at(2_600)), Response::Abort);
    }
}
