//! Trains a registered task with PPO (Isaac Lab's `rsl_rl/train.py`):
//!
//! ```text
//! cargo run --release --example train                                   # box pushing, CPU
//! cargo run --release --example train -- --task Reach-Franka-v0 --num-envs 256 --max-iterations 100
//! cargo run --release --example train -- --backend wgpu --num-envs 4096  # on a GPU
//! cargo run --release --example train -- --resume agent.max_iterations=500
//! ```
//!
//! Writes `logs/<experiment>/<timestamp>/`: resolved configs (`params/`), checkpoints
//! (`model_<it>.*`), `scalars.csv` and `training_curves.png`; with `--video`, GIFs in `videos/train/`.
//! Ctrl-C (or SIGTERM) stops at the next env step with a checkpoint that `--resume` continues
//! from; a second Ctrl-C waits for it, a third exits at once (each more than a second after the
//! one before).

use clap::Parser;

fn main() -> std::process::ExitCode {
    orbit::init_logging();
    let args = orbit::train::TrainArgs::parse();
    let run = orbit::signals::stop_on_signals()
        .map_err(Into::into)
        .and_then(|stop| orbit::train::train_with(&args, true, Some(stop)));
    orbit::exit_code(run)
}
