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

/// An unknown task is named as unknown by `train` and `play`, with the trainable tasks
/// (black-box ones included, those without a training config left out).
#[test]
fn an_unknown_task_lists_the_trainable_tasks() {
    let args = TrainArgs::parse_from(["train", "--task", "Foo-v0"]);
    let message = train(&args, false).err().expect("an error").to_string();
    assert!(message.starts_with("unknown task `Foo-v0`"), "{message}");
    assert!(message.contains("BoxPushing-ProMP-Franka-v0"), "{message}");
    assert!(!message.contains("TemporalSpatialSparse"), "{message}");
    let args = PlayArgs::parse_from(["play", "--task", "Foo-v0"]);
    let message = play(&args).unwrap_err().to_string();
    assert!(message.starts_with("unknown task `Foo-v0`"), "{message}");
}

/// `random_agent --set` takes overrides with or without `train`'s `env.` prefix, alike.
#[test]
fn agent_overrides_take_the_env_prefix() {
    for set in ["env.episode_length_s=0.04", "episode_length_s=0.04"] {
        let args = AgentArgs::parse_from([
            "random_agent",
            "--num-envs",
            "1",
            "--steps",
            "2",
            "--set",
            set,
        ]);
        run(&args, false).unwrap_or_else(|e| panic!("{set}: {e}"));
    }
}

/// `bb.` overrides on a step-based task are an error, not silently ignored.
#[test]
fn black_box_overrides_on_a_step_based_task_are_errors() {
    let root = std::env::temp_dir().join(format!("orbit-cli-bb-{}", std::process::id()));
    let args = TrainArgs::parse_from([
        "train",
        "--task",
        "Reach-Franka-v0",
        "--log-root",
        root.to_str().unwrap(),
        "bb.context=None",
    ]);
    let message = train(&args, false).err().expect("an error").to_string();
    assert!(
        message.contains("bb.context=None") && message.contains("step-based"),
        "{message}"
    );
    assert!(!root.exists(), "no run directory");
    let args = PlayArgs::parse_from(["play", "--task", "Reach-Franka-v0", "bb.context=None"]);
    let message = play(&args).unwrap_err().to_string();
    assert!(message.contains("step-based"), "{message}");
}
