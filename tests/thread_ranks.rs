//! `train --ranks K`: K threads of one process train as data-parallel ranks.

mod common;

use clap::Parser;
use orbit::train::{TrainArgs, train};

/// Reach with 8 envs per rank and 8 steps per iteration on rapier, two iterations, logging
/// under `root`.
fn reach_args(root: &std::path::Path, extra: &[&str]) -> TrainArgs {
    let mut args = vec!["--backend", "rapier", "--max-iterations", "2"];
    args.extend_from_slice(extra);
    common::reach_args(root, &args)
}

/// Two thread ranks make one run: one run directory (rank 0's), whose log counts both ranks'
/// env steps.
#[test]
fn two_thread_ranks_make_one_run() {
    let root = std::env::temp_dir().join(format!("orbit-thread-ranks-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let runner = train(&reach_args(&root, &["--ranks", "2"]), false).unwrap();
    let last = runner.history.last().unwrap();
    assert_eq!(
        last.env_steps,
        2 * 8 * 8 * 2,
        "2 ranks × 8 envs × 8 steps × 2"
    );
    let runs = std::fs::read_dir(root.join("franka_reach"))
        .unwrap()
        .count();
    assert_eq!(runs, 1, "one run directory");
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
