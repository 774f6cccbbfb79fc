//! Requests that would do nothing are errors that name the flag, and leave nothing behind.

use std::path::Path;

use clap::Parser;
use orbit::agent::{AgentArgs, run};
use orbit::play::{PlayArgs, play};
use orbit::train::{TrainArgs, train};

/// The error message of `train` on the reach task with 4 envs, logging under `root`, with
/// `extra` tokens.
fn reach_train_error(root: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "train",
        "--task",
        "Reach-Franka-v0",
        "--num-envs",
        "4",
        "--log-root",
        root.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let args = TrainArgs::parse_from(args);
    train(&args, false).err().expect("an error").to_string()
}

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

    // No envs is blamed on `num_envs`, not on the minibatches it leaves without transitions.
    let args = TrainArgs::parse_from(["train", "--task", "Reach-Franka-v0", "--num-envs", "0"]);
    let message = train(&args, false).err().expect("an error").to_string();
    assert!(
        message.contains("field `num_envs`") && !message.contains("num_mini_batches"),
        "{message}"
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
    let message = reach_train_error(&root, &["bb.context=None"]);
    assert!(
        message.contains("bb.context=None") && message.contains("step-based"),
        "{message}"
    );
    assert!(!root.exists(), "no run directory");
    let args = PlayArgs::parse_from(["play", "--task", "Reach-Franka-v0", "bb.context=None"]);
    let message = play(&args).unwrap_err().to_string();
    assert!(message.contains("step-based"), "{message}");
}

/// A time step far too long for the arm's drives (a second, the longest `sim.dt` allowed)
/// blows the state up in the first step: `train`
/// reports it as a physics failure naming the joint, the env and what to change, not as a
/// diverging policy.
#[test]
fn a_physics_blow_up_is_a_physics_error() {
    let root = std::env::temp_dir().join(format!("orbit-blow-up-{}", std::process::id()));
    let message = reach_train_error(&root, &["--max-iterations", "1", "env.sim.dt=1.0"]);
    for part in [
        "physics became unstable in env step 1",
        "of articulation `robot`",
        "in env 0",
        "of 4 envs out of range",
        "Lower `sim.dt`",
    ] {
        assert!(message.contains(part), "`{part}` missing: {message}");
    }
    assert!(!message.contains("diverged"), "{message}");
    // The run failed in its first step: it leaves no run directory behind.
    let runs = std::fs::read_dir(root.join("franka_reach")).map_or(0, |d| d.count());
    assert_eq!(runs, 0, "a run directory was left behind");
    let _ = std::fs::remove_dir_all(&root);
}

/// An override error names the override as the user wrote it (not its place among the task's
/// own overrides), and more minibatches than an iteration collects transitions is refused
/// before a rollout; neither leaves a run directory behind.
#[test]
fn override_errors_name_the_override_and_minibatches_are_checked_first() {
    let root = std::env::temp_dir().join(format!("orbit-override-errors-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let run = |extra: &str| reach_train_error(&root, &[extra]);
    let message = run("env.sim.dtx=0.1");
    assert!(
        message.starts_with("override `sim.dtx=0.1`: sim.dtx: unknown field `dtx`"),
        "{message}"
    );
    let message = run("agent.algorithm.learning_rate=fast");
    assert!(
        message.starts_with("agent config: override `algorithm.learning_rate=fast`"),
        "{message}"
    );
    let message = run("agent.algorithm.num_mini_batches=1000");
    assert!(
        message.contains("field `algorithm.num_mini_batches`: 1000 minibatches")
            && message.contains("4 envs × 24 steps collect 96"),
        "{message}"
    );
    let runs = std::fs::read_dir(root.join("franka_reach")).map_or(0, |d| d.count());
    assert_eq!(runs, 0, "no run directory is left behind");
    let _ = std::fs::remove_dir_all(&root);
}

/// The binary of an example, which `cargo test --workspace` builds beside the tests.
fn example_binary(name: &str) -> std::path::PathBuf {
    let binary = std::env::current_exe()
        .unwrap()
        .parent()
        .and_then(Path::parent)
        .unwrap()
        .join("examples")
        .join(name);
    assert!(
        binary.exists(),
        "{} is missing: run the tests with `cargo test --workspace`, which builds the examples",
        binary.display()
    );
    binary
}

/// The examples' binaries (which `cargo test` builds beside the tests) print an error as its
/// message on one line, not as a debug struct, and exit with failure.
#[test]
fn examples_print_error_messages_not_debug_structs() {
    for (example, args, expected) in [
        ("zero_agent", &["--task", "Foo-v0"][..], "no task `Foo-v0`"),
        (
            "random_agent",
            &["--set", "sim.dt=-1.0"],
            "sim.dt: -1 is out of range: expected 0.000001 to 1 seconds",
        ),
        (
            "benchmark",
            &["--backend", "nope", "--num-envs", "1", "--steps", "1"],
            "unknown physics backend `nope`",
        ),
    ] {
        let out = std::process::Command::new(example_binary(example))
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{example}: {stderr}");
        assert!(
            stderr.starts_with("error: ") && stderr.contains(expected),
            "{example}: {stderr}"
        );
        assert!(
            !stderr.contains(" {\n") && !stderr.contains(": \""),
            "{example}: {stderr}"
        );
    }
}

/// `--num-envs 10000000` on the CPU backend fails at once with the memory it would need,
/// instead of allocating until the machine runs out.
#[test]
fn envs_beyond_the_memory_fail_fast() {
    let args = AgentArgs::parse_from([
        "zero_agent",
        "--num-envs",
        "10000000",
        "--steps",
        "1",
        "--backend",
        "rapier",
    ]);
    let message = run(&args, true).unwrap_err().to_string();
    assert!(
        message.contains("10000000 envs on the `rapier` backend need at least"),
        "{message}"
    );
}

/// Warnings show without `RUST_LOG` (here `play` skipping a newer run without a checkpoint),
/// and `list_tasks` says which tasks train and with which algorithm.
#[test]
fn examples_show_warnings_and_list_the_training_algorithm() {
    let root = std::env::temp_dir().join(format!("orbit-warnings-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let experiment = root.join("franka_reach");
    std::fs::create_dir_all(experiment.join("2026-01-01_00-00-00")).unwrap();
    std::fs::write(experiment.join("2026-01-01_00-00-00/model_0.json"), "{}").unwrap();
    std::fs::create_dir_all(experiment.join("2026-01-02_00-00-00/params")).unwrap();
    let out = std::process::Command::new(example_binary("play"))
        .args([
            "--task",
            "Reach-Franka-v0",
            "--log-root",
            root.to_str().unwrap(),
        ])
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("WARN") && stderr.contains("skipped newer run directories"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&root).unwrap();

    let out = std::process::Command::new(example_binary("list_tasks"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let training = |id: &str| {
        let line = stdout.lines().find(|l| l.starts_with(id)).unwrap();
        line.split_whitespace().nth(1).unwrap().to_string()
    };
    assert_eq!(training("BoxPushing-JointPos-Franka-v0 "), "PPO");
    assert_eq!(training("BoxPushing-ProMP-Franka-v0 "), "BBRL-PPO");
    assert_eq!(training("BoxPushing-Torque-TemporalSparse-Franka-v0 "), "-");
}

/// `--distributed` in a build without the `distributed` feature says how to build it, and
/// makes no run directory.
#[cfg(not(feature = "distributed"))]
#[test]
fn distributed_training_needs_its_feature() {
    let root = std::env::temp_dir().join(format!("orbit-cli-distributed-{}", std::process::id()));
    let message = reach_train_error(&root, &["--distributed"]);
    assert!(message.contains("--features distributed"), "{message}");
    assert!(message.contains("mpiexec"), "{message}");
    assert!(!root.exists());
}
