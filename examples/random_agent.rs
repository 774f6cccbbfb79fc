//! Runs a registered task with uniform random actions in [-1, 1]:
//!
//! ```text
//! cargo run --release --example random_agent -- --task BoxPushing-Torque-Franka-v0 --num-envs 16
//! ```

use clap::Parser;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    orbit::agent::run(&orbit::agent::AgentArgs::parse(), false)
}
