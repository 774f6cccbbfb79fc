//! `scalars.csv` round trip: what the runner writes, `read_scalars` reads back unchanged (the
//! wall time is written to the millisecond, so the test uses whole milliseconds).

use std::collections::BTreeMap;

use orbit_rl::IterationLog;
use orbit_rl::logger::{ScalarLog, merge_segments, read_scalars, resumed_history};
use orbit_rl::ppo::LossStats;

fn log(iteration: usize, success: Option<f32>) -> IterationLog {
    IterationLog {
        iteration,
        env_steps: 409_600 * (iteration as u64 + 1),
        wall_time: 2.125 * (iteration as f64 + 1.0),
        mean_return: Some(-251.37 + iteration as f32),
        mean_episode_length: Some(1.0),
        success_rate: success,
        losses: LossStats {
            value: 7.5e4,
            surrogate: -0.143,
            entropy: 49.646,
        },
        learning_rate: 1e-4,
        mean_noise_std: 0.99946,
        fps: 192_753.123_456,
        collection_time: 1.712_345,
        env_time: 0.25,
        physics_time: 0.125,
        env_phase_times: BTreeMap::from([
            ("observations".to_string(), 0.031_25),
            ("resets".to_string(), 0.003_906_25),
        ]),
        policy_time: 0.062_5,
        learning_time: 0.412_5,
        episode: BTreeMap::from([
            ("Metrics/target/success".to_string(), 0.25),
            ("reward_sum".to_string(), -3.5),
        ]),
    }
}

#[test]
fn scalars_read_back_as_written() {
    let dir = std::env::temp_dir().join(format!("orbit-scalars-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let written = vec![log(0, None), log(1, Some(0.5))];
    {
        let mut out = ScalarLog::create(&dir).unwrap();
        for l in &written {
            out.write(l).unwrap();
        }
    }
    let read = read_scalars(&dir.join("scalars.csv")).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(read, written);
}

#[test]
fn a_malformed_row_names_its_line() {
    let path = std::env::temp_dir().join(format!("orbit-bad-scalars-{}.csv", std::process::id()));
    std::fs::write(
        &path,
        "iteration,env_steps,wall_time,tag,value\n0,1,0.5,Loss/x\n",
    )
    .unwrap();
    let e = read_scalars(&path).unwrap_err().to_string();
    std::fs::remove_file(&path).unwrap();
    assert!(e.contains("line 2") && e.contains("five fields"), "{e}");
}

#[test]
fn resumed_segments_merge_with_redone_iterations_replaced() {
    // Iterations 0-4 in the first directory; the run resumed from the checkpoint after
    // iteration 2 and logged 3-5 again in a second one (with other returns).
    let mut redone: Vec<IterationLog> = (3..6).map(|i| log(i, Some(0.5))).collect();
    for l in &mut redone {
        l.mean_return = Some(7.0);
    }
    let merged = merge_segments(vec![(0..5).map(|i| log(i, None)).collect(), redone]);
    let iterations: Vec<usize> = merged.iter().map(|l| l.iteration).collect();
    assert_eq!(iterations, [0, 1, 2, 3, 4, 5]);
    let returns: Vec<f32> = merged.iter().map(|l| l.mean_return.unwrap()).collect();
    assert_eq!(returns, [-251.37, -250.37, -249.37, 7.0, 7.0, 7.0]);
}

#[test]
fn a_resumed_run_plots_the_earlier_run_before_its_own_iterations() {
    let dir = std::env::temp_dir().join(format!("orbit-resumed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    {
        let mut out = ScalarLog::create(&dir).unwrap();
        for i in 0..5 {
            out.write(&log(i, None)).unwrap();
        }
    }
    // Resumed from the checkpoint of iteration 2: iterations 3-5 are this run's.
    let own: Vec<IterationLog> = (3..6).map(|i| log(i, Some(0.5))).collect();
    let history = resumed_history(&dir.join("model_2"), &own);
    let iterations: Vec<usize> = history.iter().map(|l| l.iteration).collect();
    assert_eq!(iterations, [0, 1, 2, 3, 4, 5]);
    assert_eq!(history[3..], own[..]);
    // Without the earlier run's scalars, only this run's iterations.
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(resumed_history(&dir.join("model_2"), &own), own);
}

/// A kill while a row is written leaves a last line without its newline: reading (for
/// `plot_run`, and for a resumed run's curves) drops it and keeps every whole row, even when
/// the cut row would parse (a value cut to fewer digits).
#[test]
fn a_cut_last_line_is_dropped() {
    let dir = std::env::temp_dir().join(format!("orbit-cut-scalars-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let written = vec![log(0, None), log(1, Some(0.5))];
    {
        let mut out = ScalarLog::create(&dir).unwrap();
        for l in &written {
            out.write(l).unwrap();
        }
    }
    let path = dir.join("scalars.csv");
    for cut in [
        "2,1228800,6.375,Loss/val",
        "2,1228800,6.375,Loss/value_function,7",
    ] {
        let whole = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, format!("{whole}{cut}")).unwrap();
        assert_eq!(read_scalars(&path).unwrap(), written, "{cut}");
        std::fs::write(&path, whole).unwrap();
    }
    std::fs::write(
        &path,
        format!("{}2,1", std::fs::read_to_string(&path).unwrap()),
    )
    .unwrap();
    let own = vec![log(2, Some(0.75))];
    let history = resumed_history(&dir.join("model_1"), &own);
    std::fs::remove_dir_all(&dir).unwrap();
    let iterations: Vec<usize> = history.iter().map(|l| l.iteration).collect();
    assert_eq!(iterations, [0, 1, 2]);
}
