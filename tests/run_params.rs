//! `train --resume` and `play` rebuild a run from its own `params/`: a run trained with an
//! override continues and plays with it, unless `--registered-config` asks for the task's.

use std::path::{Path, PathBuf};

use clap::Parser;

mod common;

use common::reach_args;
use orbit::play::{PlayArgs, play};
use orbit::train::train;

/// The `decimation` a run's `params/env.ron` holds.
fn decimation(run: &Path) -> usize {
    let doc = orbit::core::config::load_document(run.join("params/env.ron"), &[]).unwrap();
    let node = orbit::core::config::node_at(&doc, "decimation").unwrap();
    orbit::core::config::from_node(node).unwrap()
}

/// The run directories under `experiment`, oldest first.
fn runs(experiment: &Path) -> Vec<PathBuf> {
    let mut runs: Vec<PathBuf> = std::fs::read_dir(experiment)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    runs.sort();
    runs
}

#[test]
fn resume_and_play_use_the_runs_own_configs() {
    let root = std::env::temp_dir().join(format!("orbit-run-params-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let experiment = root.join("franka_reach");
    // Reach's own decimation is 2; the first run trains at 3.
    train(
        &reach_args(&root, &["--max-iterations", "1", "env.decimation=3"]),
        false,
    )
    .unwrap();
    let first = runs(&experiment).remove(0);
    assert_eq!(decimation(&first), 3);
    let assets = std::fs::read_to_string(first.join("params/assets.ron")).unwrap();
    assert!(
        assets.contains("loaded: \"<bundled>/franka_panda_rod.urdf\", sha256: Some(\""),
        "{assets}"
    );

    let resumed = reach_args(&root, &["--resume", "--max-iterations", "1"]);
    train(&resumed, false).unwrap();
    let second = runs(&experiment).remove(1);
    assert_eq!(
        decimation(&second),
        3,
        "the resumed run kept the run's decimation"
    );
    let parent = std::fs::read_to_string(second.join("params/resumed_from.ron")).unwrap();
    let checkpoint = first.join("model_0").display().to_string();
    assert!(
        parent.contains(&format!("checkpoint: {checkpoint:?}")),
        "{parent}"
    );

    let registered = ["--resume", "--registered-config", "--max-iterations", "1"];
    train(&reach_args(&root, &registered), false).unwrap();
    let third = runs(&experiment).remove(2);
    assert_eq!(
        decimation(&third),
        2,
        "--registered-config takes the task's"
    );

    // `play` of the first run builds its env at decimation 3: one episode of 8 envs.
    let play_args = PlayArgs::parse_from([
        "play",
        "--task",
        "Reach-Franka-v0",
        "--num-envs",
        "2",
        "--log-root",
        root.to_str().unwrap(),
        "--checkpoint",
        &checkpoint,
    ]);
    play(&play_args).unwrap();
    std::fs::remove_dir_all(&root).unwrap();
}
