//! `train --video` and `play --video` end to end on the reach task (CPU): videos start every
//! `--video-interval` env steps with one frame per env step, and `play` keeps stepping past
//! its episodes until its video is complete.

use std::path::Path;

use clap::Parser;
use orbit::play::{PlayArgs, play};
use orbit::train::{TrainArgs, train};

/// Frames and per-frame delay (hundredths of a second) of a GIF.
fn gif_frames(path: &Path) -> Vec<u16> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut decoder = gif::DecodeOptions::new().read_info(file).unwrap();
    let mut delays = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        delays.push(frame.delay);
    }
    delays
}

#[test]
fn train_and_play_write_videos_at_the_requested_steps() {
    let root = std::env::temp_dir().join(format!("orbit-video-{}", std::process::id()));
    let root_arg = root.to_str().unwrap();
    // One iteration of 24 env steps: videos start at steps 0, 10 and 20 (the last one has
    // the 4 steps that remain when training ends).
    let args = TrainArgs::parse_from([
        "train",
        "--task",
        "Reach-Franka-v0",
        "--num-envs",
        "4",
        "--max-iterations",
        "1",
        "--log-root",
        root_arg,
        "--video",
        "--video-interval",
        "10",
        "--video-length",
        "5",
    ]);
    let runner = train(&args, false).unwrap_or_else(|e| panic!("{e}"));
    let run = runner.log_dir().unwrap().to_path_buf();
    drop(runner);
    // Reach steps at 30 Hz: a frame lasts 1/30 s, written as 3 hundredths.
    for (step, frames) in [(0, 5), (10, 5), (20, 4)] {
        let path = orbit::render::video_path(&run.join("videos/train"), step);
        assert_eq!(gif_frames(&path), vec![3; frames], "{}", path.display());
    }
    assert_eq!(
        std::fs::read_dir(run.join("videos/train")).unwrap().count(),
        3
    );

    // Episodes of 0.1 s (3 steps) end long before the 20-step video, which play completes.
    let args = PlayArgs::parse_from([
        "play",
        "--task",
        "Reach-Franka-v0",
        "--num-envs",
        "2",
        "--log-root",
        root_arg,
        "--video",
        "--video-length",
        "20",
        "env.episode_length_s=0.1",
    ]);
    play(&args).unwrap_or_else(|e| panic!("{e}"));
    let path = orbit::render::video_path(&run.join("videos/play"), 0);
    assert_eq!(gif_frames(&path).len(), 20);
    std::fs::remove_dir_all(&root).unwrap();
}
