//! Runs a registered task with uniform random actions in [-1, 1]:
//!
//! ```text
//! cargo run --release --example random_agent -- --task BoxPushing-Torque-Franka-v0 --num-envs 16
//! ```

use clap::Parser;

fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(orbit::agent::run(&orbit::agent::AgentArgs::parse(), false))
}
