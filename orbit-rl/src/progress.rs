//! Training progress for a person: a bar on a terminal (iterations, FPS, mean return, success
//! rate, ETA), a line per iteration where standard output is a file or a pipe (as RSL-RL
//! prints), and what the first iteration is doing while kernels compile.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

use crate::runner::IterationLog;

/// How a run shows its progress: a bar on standard error when that is a terminal, and lines on
/// standard output when that is not one (both with `train > log`).
pub struct Progress {
    bar: Option<ProgressBar>,
    lines: bool,
    start: Instant,
    first: u64,
    total: u64,
}

impl Progress {
    /// Progress over `iterations` iterations, the first of which is `first` (a resumed run's).
    pub fn new(first: usize, iterations: usize) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = ProgressBar::new(iterations as u64);
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:30} {pos}/{len} it  {msg}  [{elapsed_precise} < {eta_precise}]",
                )
                .expect("the template is valid"),
            );
            // Ticks keep the elapsed time moving through a long first iteration.
            bar.enable_steady_tick(Duration::from_secs(1));
            bar
        });
        Self {
            bar,
            lines: !std::io::stdout().is_terminal(),
            start: Instant::now(),
            first: first as u64,
            total: iterations as u64,
        }
    }

    /// Says what the run is doing before its first iteration ends (collecting while the
    /// physics kernels compile, the learner's first update).
    pub fn phase(&self, what: &str) {
        if let Some(bar) = &self.bar {
            bar.set_message(what.to_string());
        }
        if self.lines {
            println!("[{:>7.1} s] {what}", self.start.elapsed().as_secs_f64());
        }
    }

    /// Shows one finished iteration.
    pub fn update(&self, log: &IterationLog) {
        let text = summary(log);
        if let Some(bar) = &self.bar {
            bar.set_message(text.clone());
            bar.inc(1);
        }
        if self.lines {
            let done = log.iteration as u64 + 1 - self.first;
            let elapsed = self.start.elapsed().as_secs_f64();
            let eta = elapsed / done as f64 * (self.total.saturating_sub(done)) as f64;
            println!(
                "iteration {}/{}  {text}  env steps {}  elapsed {}  eta {}",
                log.iteration + 1,
                self.first + self.total,
                log.env_steps,
                clock(elapsed),
                clock(eta)
            );
        }
    }

    /// Ends the bar (after the last iteration, or when training stops early).
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.abandon();
        }
    }
}

/// The iteration's rate, mean return, success rate and learning rate.
fn summary(log: &IterationLog) -> String {
    let opt =
        |x: Option<f32>, digits: usize| x.map_or("–".to_string(), |v| format!("{v:.digits$}"));
    format!(
        "{:.0} steps/s  return {}  success {}  lr {:.1e}",
        log.fps,
        opt(log.mean_return, 2),
        opt(log.success_rate, 3),
        log.learning_rate
    )
}

/// `h:mm:ss` of `seconds`.
fn clock(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::clock;

    #[test]
    fn clock_reads_hours_minutes_seconds() {
        assert_eq!(clock(0.4), "0:00:00");
        assert_eq!(clock(3725.0), "1:02:05");
    }
}
