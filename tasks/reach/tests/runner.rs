//! Runner contracts on the reach task: same seed ⇒ identical logs; checkpoints restore the
//! policy exactly; the run directory holds what Isaac Lab's does.

use orbit_envs::RlVecEnv;
use orbit_managers::make;
use orbit_physics_rapier as _;
use orbit_rl::burn::tensor::Device;
use orbit_rl::{IterationLog, OnPolicyRunner, Policy, RunnerCfg, VecEnv};
use orbit_task_reach::TASK_ID;

fn runner(
    seed: u64,
    log_dir: Option<std::path::PathBuf>,
    agent_overrides: &[&str],
) -> OnPolicyRunner<RlVecEnv> {
    runner_on(seed, log_dir, agent_overrides, &[])
}

/// [`runner`] on an env with extra env overrides.
fn runner_on(
    seed: u64,
    log_dir: Option<std::path::PathBuf>,
    agent_overrides: &[&str],
    env_overrides: &[&str],
) -> OnPolicyRunner<RlVecEnv> {
    let mut o = vec![
        "num_envs=8".to_string(),
        format!("seed={seed}"),
        "episode_length_s=0.5".into(),
    ];
    o.extend(env_overrides.iter().map(|s| s.to_string()));
    let env = RlVecEnv::new(make(TASK_ID, &o).unwrap_or_else(|e| panic!("{e}"))).unwrap();
    let agent = orbit_managers::task(TASK_ID).unwrap().agent.unwrap();
    let mut o = vec![
        format!("seed={seed}"),
        "num_steps_per_env=8".into(),
        "save_interval=2".into(),
        "empirical_normalization=true".into(),
    ];
    o.extend(agent_overrides.iter().map(|s| s.to_string()));
    let cfg = RunnerCfg::load(&agent, &o).unwrap();
    OnPolicyRunner::new(env, cfg, log_dir, Device::flex()).unwrap()
}

/// The parts of a log that do not depend on the wall clock.
fn timeless(h: &IterationLog) -> IterationLog {
    IterationLog {
        wall_time: 0.0,
        fps: 0.0,
        collection_time: 0.0,
        env_time: 0.0,
        physics_time: 0.0,
        env_phase_times: Default::default(),
        policy_time: 0.0,
        learning_time: 0.0,
        ..h.clone()
    }
}

/// Every phase of the env's step is logged, and the phases, all measured inside the env's
/// `step`, add up to no more than the time spent there.
#[test]
fn env_phases_add_up_to_the_env_time() {
    let mut r = runner(3, None, &[]);
    r.learn(2).unwrap();
    for h in &r.history {
        let names: Vec<&str> = h.env_phase_times.keys().map(String::as_str).collect();
        assert_eq!(
            names,
            [
                "actions",
                "commands",
                "events",
                "observations",
                "resets",
                "rewards",
                "terminations"
            ]
        );
        let phases: f64 = h.physics_time + h.env_phase_times.values().sum::<f64>();
        assert!(h.physics_time > 0.0 && h.env_phase_times["observations"] > 0.0);
        assert!(
            phases <= h.env_time,
            "phases {phases} s, env {} s",
            h.env_time
        );
    }
}

#[test]
fn same_seed_gives_identical_logs() {
    let runs: Vec<Vec<IterationLog>> = [7, 7, 8]
        .iter()
        .map(|&seed| {
            let mut r = runner(seed, None, &[]);
            r.learn(3).unwrap();
            r.history.iter().map(timeless).collect()
        })
        .collect();
    assert_eq!(runs[0], runs[1]);
    assert!(
        runs[0]
            .iter()
            .all(|h| h.losses.value.is_finite() && h.mean_return.is_some())
    );
    assert_ne!(runs[0], runs[2], "a different seed must change the run");
}

#[test]
fn checkpoints_restore_the_policy_and_the_run_directory_is_complete() {
    let dir = std::env::temp_dir().join(format!("orbit-reach-ckpt-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let value_norm = ["algorithm.normalize_value=true"];
    let mut r = runner(3, Some(dir.clone()), &value_norm);
    r.learn(4).unwrap();
    for f in [
        "model_1.bpk",
        "model_1.adam.bpk",
        "model_1.json",
        "model_3.bpk",
        "model_3.json",
        "scalars.csv",
    ] {
        assert!(dir.join(f).is_file(), "missing {f}");
    }
    let csv = std::fs::read_to_string(dir.join("scalars.csv")).unwrap();
    assert!(csv.starts_with("iteration,env_steps,wall_time,tag,value\n"));
    assert!(
        csv.lines()
            .any(|l| l.starts_with("3,256,") && l.contains(",Loss/surrogate,")),
        "{csv}"
    );
    // The loaded policy (weights + normaliser) acts exactly as the trained one.
    let obs = r.env.observations().to_vec();
    let loaded = Policy::load(&dir.join("model_3"), Device::flex()).unwrap();
    assert_eq!(loaded.act(&obs), r.inference_policy().act(&obs));
    // Resuming restores the iteration count, learning rate and normalisers (observations and
    // returns).
    let mut resumed = runner(3, None, &value_norm);
    resumed.load_checkpoint(&dir.join("model_3")).unwrap();
    assert_eq!(resumed.iteration, 4);
    assert_eq!(resumed.alg.learning_rate(), r.alg.learning_rate());
    let returns = r
        .alg
        .value_normalizer
        .as_ref()
        .expect("value normalisation is on");
    assert!(returns.count > 0);
    assert_eq!(resumed.alg.value_normalizer.as_ref(), Some(returns));
    assert_eq!(
        resumed.inference_policy().act(&obs),
        r.inference_policy().act(&obs)
    );
    // An env whose observation gained a term refuses the checkpoint, naming both sizes and
    // the run's env config, and keeps its own state.
    let wider = ["observations.policy.terms.extra=(func: \"joint_vel\")"];
    let mut other = runner_on(3, None, &value_norm, &wider);
    let err = other
        .load_checkpoint(&dir.join("model_3"))
        .unwrap_err()
        .to_string();
    let (n, m) = (r.env.num_obs(), other.env.num_obs());
    assert!(m > n, "{m} vs {n}");
    assert!(
        err.contains(&format!("({n}, {n}, ")) && err.contains(&format!("({m}, {m}, ")),
        "{err}"
    );
    assert!(
        err.contains(&dir.join("params").join("env.ron").display().to_string()),
        "{err}"
    );
    assert_eq!(other.iteration, 0);
    std::fs::remove_dir_all(&dir).unwrap();
}
