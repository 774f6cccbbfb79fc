//! Helpers shared by the integration tests.

use std::path::Path;

use clap::Parser;
use orbit::train::TrainArgs;

/// `train` on a small reach run (8 envs, 8 steps per iteration) under `log_root`, with extra
/// flags.
pub fn reach_args(log_root: &Path, extra: &[&str]) -> TrainArgs {
    let mut args = vec![
        "train",
        "--task",
        "Reach-Franka-v0",
        "--num-envs",
        "8",
        "--log-root",
        log_root.to_str().unwrap(),
        "agent.num_steps_per_env=8",
    ];
    args.extend_from_slice(extra);
    TrainArgs::parse_from(args)
}
