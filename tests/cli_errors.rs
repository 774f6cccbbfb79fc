//! Requests that would do nothing are errors that name the flag, and leave nothing behind.

use clap::Parser;
use orbit::agent::{AgentArgs, run};
use orbit::train::{PlayArgs, TrainArgs, play, train};

#[test]
fn zero_iterations_steps_or_episodes_are_errors() {
    let root = std::env::temp_dir().join(format!("orbit-cli-errors-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let args = TrainArgs::parse_from([
        "train",
        "--task",
        "Reach-Franka-v0",
        "--max-iterations",
        "0",
        "--log-root",
        root.to_str().unwrap(),
    ]);
    let message = train(&args, false).err().expect("an error").to_string();
    assert!(message.contains("max_iterations"), "{message}");
    assert!(
        !root.exists(),
        "no run directory is made for a run that cannot start"
    );

    let args = AgentArgs::parse_from(["random_agent", "--steps", "0"]);
    let message = run(&args, false).unwrap_err().to_string();
    assert!(message.contains("--steps"), "{message}");

    let args = PlayArgs::parse_from(["play", "--episodes", "0"]);
    let message = play(&args).unwrap_err().to_string();
    assert!(message.contains("--episodes"), "{message}");
}
