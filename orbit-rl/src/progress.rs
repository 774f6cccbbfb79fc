//! The training progress bar: iterations, FPS, mean return, success rate, ETA.

use indicatif::{ProgressBar, ProgressStyle};

use crate::runner::IterationLog;

/// A bar over `iterations` iterations.
pub fn bar(iterations: u64) -> ProgressBar {
    let bar = ProgressBar::new(iterations);
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:30} {pos}/{len} it  {msg}  [{elapsed_precise} < {eta_precise}]",
        )
        .expect("the template is valid"),
    );
    bar
}

/// Shows one finished iteration.
pub fn update(bar: &ProgressBar, log: &IterationLog) {
    let opt =
        |x: Option<f32>, digits: usize| x.map_or("–".to_string(), |v| format!("{v:.digits$}"));
    bar.set_message(format!(
        "{:.0} steps/s  return {}  success {}  lr {:.1e}",
        log.fps,
        opt(log.mean_return, 2),
        opt(log.success_rate, 3),
        log.learning_rate
    ));
    bar.inc(1);
}
