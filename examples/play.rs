//! Replays a trained policy (Isaac Lab's `rsl_rl/play.py`), printing each episode's return:
//!
//! ```text
//! cargo run --release --example play -- --task Reach-Franka-v0            # newest run
//! cargo run --release --example play -- --checkpoint logs/franka_reach/<run>/model_99
//! ```

use clap::Parser;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    orbit::train::play(&orbit::train::PlayArgs::parse())
}
