//! `train --ranks K`: K threads of one process train as data-parallel ranks.

mod common;

use clap::Parser;
use orbit::train::{RankCount, TrainArgs, resolve, thread_ranks, train};

/// Reach with 8 envs and 8 steps per iteration on rapier, two iterations, logging under
/// `root`.
fn reach_args(root: &std::path::Path, extra: &[&str]) -> TrainArgs {
    let mut args = vec!["--backend", "rapier", "--max-iterations", "2"];
    args.extend_from_slice(extra);
    common::reach_args(root, &args)
}

/// Two thread ranks make one run: they share its envs, and its one run directory (rank 0's)
/// logs every rank's env steps and keeps the run's env count in `params/env.ron`.
#[test]
fn two_thread_ranks_make_one_run() {
    let root = std::env::temp_dir().join(format!("orbit-thread-ranks-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let runner = train(&reach_args(&root, &["--ranks", "2"]), false).unwrap();
    assert_eq!(runner.env.num_envs(), 4, "rank 0 steps half the 8 envs");
    let last = runner.history.last().unwrap();
    assert_eq!(last.env_steps, 8 * 8 * 2, "8 envs × 8 steps × 2 iterations");
    let runs: Vec<_> = std::fs::read_dir(root.join("franka_reach"))
        .unwrap()
        .collect();
    assert_eq!(runs.len(), 1, "one run directory");
    let params = runs[0].as_ref().unwrap().path().join("params/env.ron");
    let env = std::fs::read_to_string(params).unwrap();
    assert!(env.contains("num_envs: 8"), "{env}");
    let _ = std::fs::remove_dir_all(&root);
}

/// Ranks that cannot share the envs evenly are refused before anything starts.
#[test]
fn ranks_must_share_the_envs_evenly() {
    let root = std::env::temp_dir().join(format!("orbit-uneven-ranks-{}", std::process::id()));
    let message = train(&reach_args(&root, &["--ranks", "3"]), false)
        .err()
        .expect("an error")
        .to_string();
    assert!(
        message.contains("--ranks") && message.contains("3 ranks cannot share 8 envs"),
        "{message}"
    );
    assert!(!root.exists());
}

/// `--ranks auto` splits a CPU run over the cores, at most 8 ranks of at least 64 envs that
/// share the envs evenly, and leaves small runs whole.
#[test]
fn auto_ranks_follow_the_cores_and_the_envs() {
    let auto = |envs: usize, cores: usize| {
        let envs_flag = envs.to_string();
        let args = TrainArgs::parse_from([
            "train",
            "--task",
            "Reach-Franka-v0",
            "--backend",
            "rapier",
            "--num-envs",
            &envs_flag,
        ]);
        let run = resolve(&args).unwrap();
        assert!(run.physics_on_cpu);
        thread_ranks(RankCount::Auto, &run, envs, cores).unwrap()
    };
    assert_eq!(auto(1024, 16), 8);
    assert_eq!(auto(1024, 2), 2);
    assert_eq!(auto(1000, 16), 8, "125 envs each");
    assert_eq!(auto(192, 16), 3, "64 envs each");
    assert_eq!(auto(100, 16), 1, "50 envs each would be too few");
    assert_eq!(auto(1024, 1), 1);
}

/// A failure on the ranks (here the physics blowing up) ends the run with the error, not
/// the process.
#[test]
fn a_rank_failure_is_the_runs_error() {
    let root = std::env::temp_dir().join(format!("orbit-rank-failure-{}", std::process::id()));
    let args = reach_args(&root, &["--ranks", "2", "env.sim.dt=1.0"]);
    let message = train(&args, false).err().expect("an error").to_string();
    assert!(message.contains("physics became unstable"), "{message}");
    let _ = std::fs::remove_dir_all(&root);
}

/// Threads and MPI ranks together are refused before anything starts.
#[test]
fn thread_ranks_and_mpi_ranks_exclude_each_other() {
    let root = std::env::temp_dir().join(format!("orbit-thread-mpi-{}", std::process::id()));
    let args = reach_args(&root, &["--ranks", "2", "--distributed"]);
    let message = train(&args, false).err().expect("an error").to_string();
    assert!(
        message.contains("--ranks") && message.contains("--distributed"),
        "{message}"
    );
    assert!(!root.exists());
    assert!(TrainArgs::try_parse_from(["train", "--ranks", "0"]).is_err());
}

/// Thread ranks on the GPU backend each open a device of their own and end cleanly: a device
/// left to the thread's exit would be destroyed in a thread-local destructor and abort the
/// process.
#[test]
fn thread_ranks_on_the_gpu_backend_end_cleanly() {
    if !orbit::physics_wgpu::gpu_available_for_tests() {
        return;
    }
    let root = std::env::temp_dir().join(format!("orbit-gpu-ranks-{}", std::process::id()));
    let args = TrainArgs::parse_from([
        "train",
        "--task",
        "Isaac-Cartpole-v0",
        "--backend",
        "wgpu",
        "--ranks",
        "2",
        "--num-envs",
        "8",
        "--max-iterations",
        "2",
        "--log-root",
        root.to_str().unwrap(),
    ]);
    let runner = std::thread::spawn(move || train(&args, false).map(|r| r.history.len()).ok())
        .join()
        .expect("the training thread ends");
    assert_eq!(runner, Some(2));
    let _ = std::fs::remove_dir_all(&root);
}
