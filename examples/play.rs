//! Replays a trained policy with its mean actions (Isaac Lab's `rsl_rl/play.py`), printing each
//! episode's return and, at the end, the mean return and episode metrics (e.g. the success rate)
//! over all played episodes:
//!
//! ```text
//! cargo run --release --example play -- --task Reach-Franka-v0            # newest run
//! cargo run --release --example play -- --checkpoint logs/franka_reach/<run>/model_99
//! cargo run --release --example play -- --task Reach-Franka-v0 --video   # and a GIF of it
//! ```

use clap::Parser;

fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(orbit::play::play(&orbit::play::PlayArgs::parse()))
}
