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

use clap::Parser;

fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(orbit::train::train(&orbit::train::TrainArgs::parse(), true))
}
