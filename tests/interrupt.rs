//! Ctrl-C during training: the first SIGINT stops the run with a checkpoint, and `--resume`
//! continues from it.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::reach_args;
use orbit::signals::stop_on_signals;
use orbit::train::{train, train_with};

/// The environment variable that makes [`train_until_signalled`] train (its log root).
const CHILD_LOG_ROOT: &str = "ORBIT_TEST_TRAIN_CHILD_LOG_ROOT";

/// The experiment directory of the reach task's runs.
const EXPERIMENT: &str = "franka_reach";

/// The child process of [`sigint_saves_a_checkpoint_that_resume_continues`]: trains until a
/// signal stops it and exits as the `train` example does. Without the environment variable
/// it returns at once.
#[test]
#[ignore = "run as a child process by sigint_saves_a_checkpoint_that_resume_continues"]
fn train_until_signalled() {
    let Ok(root) = std::env::var(CHILD_LOG_ROOT) else {
        return;
    };
    let args = reach_args(Path::new(&root), &["--max-iterations", "100000"]);
    let stop = stop_on_signals().unwrap();
    if let Err(e) = train_with(&args, true, Some(stop)) {
        eprintln!("error: {e}");
        std::process::exit(i32::from(orbit::failure_status(e.as_ref())));
    }
}

/// The number of iterations logged in the newest `scalars.csv` under `experiment_dir`.
fn logged_iterations(experiment_dir: &Path) -> usize {
    let Ok(runs) = std::fs::read_dir(experiment_dir) else {
        return 0;
    };
    runs.filter_map(|r| std::fs::read_to_string(r.ok()?.path().join("scalars.csv")).ok())
        .map(|csv| {
            let iterations = csv.lines().skip(1).filter_map(|l| l.split(',').next());
            iterations.collect::<std::collections::BTreeSet<_>>().len()
        })
        .max()
        .unwrap_or(0)
}

/// A training child sent SIGINT after two logged iterations (twice within a second, which is
/// one request) exits with 130 and names the checkpoint it saved; a `--resume` run starts from that checkpoint's iteration. Its
/// standard output, a pipe, shows a line per iteration.
#[test]
fn sigint_saves_a_checkpoint_that_resume_continues() {
    let root = std::env::temp_dir().join(format!("orbit-sigint-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "train_until_signalled",
            "--ignored",
            "--nocapture",
        ])
        .env(CHILD_LOG_ROOT, &root)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let experiment = root.join(EXPERIMENT);
    let start = Instant::now();
    while logged_iterations(&experiment) < 2 {
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "the child logged no two iterations in 300 s"
        );
        assert!(child.try_wait().unwrap().is_none(), "the child ended early");
        std::thread::sleep(Duration::from_millis(50));
    }
    // Twice, 100 ms apart, as `timeout` sends it (to the child, then to its process group):
    // one request, not an abort.
    // The child may have saved and exited before the second: only the first must arrive.
    for n in 0..2 {
        let sent = Command::new("kill")
            .args(["-INT", &child.id().to_string()])
            .stderr(Stdio::null())
            .status()
            .unwrap();
        assert!(sent.success() || n == 1);
        std::thread::sleep(Duration::from_millis(100));
    }
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("checkpoint saved"), "{stderr}");
    // The signal was acknowledged as it came, before the checkpoint was written.
    let acknowledged = stderr.find("a checkpoint will be written").expect(&stderr);
    assert!(
        acknowledged < stderr.find("checkpoint saved").unwrap(),
        "{stderr}"
    );
    // Standard output is a pipe: the first iteration's phases and a line per iteration.
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("iteration 1: collecting 8 steps × 8 envs"),
        "{stdout}"
    );
    for it in ["iteration 1/", "iteration 2/"] {
        assert!(
            stdout
                .lines()
                .any(|l| l.starts_with(it) && l.contains("steps/s")),
            "{stdout}"
        );
    }

    let base =
        orbit_rl::run_dir::resolve_checkpoint(&experiment, ".*", "model_.*").expect("a checkpoint");
    let saved = orbit_rl::runner::read_state(&base).unwrap().iteration;
    assert!(saved >= 2, "the checkpoint holds {saved} iterations");
    assert!(stderr.contains(&base.display().to_string()), "{stderr}");

    let resumed = train(
        &reach_args(&root, &["--resume", "--max-iterations", "1"]),
        false,
    )
    .unwrap();
    assert_eq!(resumed.history.len(), 1);
    assert_eq!(resumed.history[0].iteration, saved);
    std::fs::remove_dir_all(&root).unwrap();
}
