//! Runs a registered task with zero actions (same flags as `random_agent`):
//!
//! ```text
//! cargo run --release --example zero_agent -- --task BoxPushing-JointPos-Franka-v0
//! ```

use clap::Parser;

fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(orbit::agent::run(&orbit::agent::AgentArgs::parse(), true))
}
