//! The step and reset order of `ManagerBasedRlEnv` and `ManagerBasedEnv` as a contract (Isaac
//! Lab's `ManagerBasedRLEnv.step` and `_reset_idx`): probe terms of every kind append what they
//! see to a per-thread log, and the tests compare the log with Isaac Lab's order. The log is per
//! thread, so each manager has one probe term: managers compute several terms concurrently, and a
//! single term stays on the calling thread.

use std::cell::RefCell;

use orbit_managers::term::*;
use orbit_managers::{EnvError, EnvRngs, EnvView, ManagerBasedEnv, ManagerBasedRlEnv, Scene};
use orbit_physics_rapier as _;

thread_local! {
    static LOG: RefCell<Vec<String>> = const { RefCell::new(Vec::new()) };
}

fn log(entry: String) {
    LOG.with(|l| l.borrow_mut().push(entry));
}

fn take_log() -> Vec<String> {
    LOG.with(|l| std::mem::take(&mut *l.borrow_mut()))
}

struct ProbeAction(Vec<f32>);
impl ActionTerm for ProbeAction {
    fn dim(&self) -> usize {
        1
    }
    fn process(&mut self, _: &Scene, raw: &[f32]) {
        self.0.copy_from_slice(raw);
        log("process".into());
    }
    fn apply(&mut self, _: &mut Scene) -> Result<(), EnvError> {
        log("apply".into());
        Ok(())
    }
    fn processed(&self) -> &[f32] {
        &self.0
    }
}

struct ProbeObservation;
impl ObservationTerm for ProbeObservation {
    fn dim(&self) -> usize {
        1
    }
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        log(format!("observe {:?}", env.episode_length));
        for (o, &l) in out.iter_mut().zip(env.episode_length) {
            *o = l as f32;
        }
    }
}

struct ProbeReward;
impl RewardTerm for ProbeReward {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [f32]) {
        log(format!("rewards {:?}", env.episode_length));
        out.fill(1.0);
    }
}

/// Terminates env 1 when its episode reaches 2 steps.
struct ProbeTermination;
impl TerminationTerm for ProbeTermination {
    fn compute(&mut self, env: &EnvView<'_>, out: &mut [bool]) {
        log(format!("terminations {:?}", env.episode_length));
        out.fill(false);
        out[1] = env.episode_length[1] == 2;
    }
}

struct ProbeEvent(&'static str);
impl EventTerm for ProbeEvent {
    fn apply(&mut self, _: &mut Scene, env_ids: &[usize], _: &mut EnvRngs) -> Result<(), EnvError> {
        log(format!("{} {env_ids:?}", self.0));
        Ok(())
    }
}

struct ProbeCommand(Vec<f32>);
impl CommandTerm for ProbeCommand {
    fn dim(&self) -> usize {
        1
    }
    fn command(&self) -> &[f32] {
        &self.0
    }
    fn resample(&mut self, _: &Scene, env_ids: &[usize], _: &mut EnvRngs) {
        log(format!("resample {env_ids:?}"));
    }
    fn update_metrics(&mut self, _: &Scene) {
        log("metrics".into());
    }
}

struct ProbeCurriculum;
impl CurriculumTerm for ProbeCurriculum {
    fn compute(
        &mut self,
        env_ids: &[usize],
        _: u64,
        _: &mut orbit_managers::managers::RewardManager,
    ) -> Result<Option<f32>, EnvError> {
        log(format!("curriculum {env_ids:?}"));
        Ok(None)
    }
}

fn n(c: &TermContext<'_>) -> usize {
    c.scene.num_envs()
}

inventory::submit! { ActionTermDef { name: "probe_action", build: |c| {
    log("build action".into());
    Ok(Box::new(ProbeAction(vec![0.0; n(c)])))
} } }
inventory::submit! { ObservationTermDef { name: "probe_observation", build: |_| {
    log("build observation".into());
    Ok(Box::new(ProbeObservation))
} } }
inventory::submit! { RewardTermDef { name: "probe_reward", build: |_| {
    log("build reward".into());
    Ok(Box::new(ProbeReward))
} } }
inventory::submit! { TerminationTermDef { name: "probe_termination", build: |_| {
    log("build termination".into());
    Ok(Box::new(ProbeTermination))
} } }
inventory::submit! { EventTermDef { name: "probe_startup", build: |_| {
    log("build event".into());
    Ok(Box::new(ProbeEvent("startup")))
} } }
inventory::submit! { EventTermDef { name: "probe_reset", build: |_| Ok(Box::new(ProbeEvent("reset"))) } }
inventory::submit! { EventTermDef { name: "probe_interval", build: |_| Ok(Box::new(ProbeEvent("interval"))) } }
inventory::submit! { CommandTermDef { name: "probe_command", build: |c| {
    log("build command".into());
    Ok(Box::new(ProbeCommand(vec![0.0; n(c)])))
} } }
inventory::submit! { CurriculumTermDef { name: "probe_curriculum", build: |_| {
    log("build curriculum".into());
    Ok(Box::new(ProbeCurriculum))
} } }

/// Scene, physics (dt 10 ms × decimation 3 = 30 ms env steps), actions, observations, events
/// (the interval event fires every step) and commands (resampled only on reset).
const BASE: &str = r#"
    num_envs: 2,
    decimation: 3,
    sim: (dt: 0.01),
    scene: (env_spacing: 2.5, articulations: {"robot": (asset: "franka_panda_rod")}, rigid_objects: {"box": (asset: "push_box")}, static_objects: {"table": (asset: "lab_table"), "robot_mount": (asset: "franka_mount")}),
    actions: {"probe": (func: "probe_action")},
    observations: {"policy": (terms: {"probe": (func: "probe_observation")})},
    events: {
        "startup": (func: "probe_startup", mode: Startup),
        "reset": (func: "probe_reset", mode: Reset),
        "interval": (func: "probe_interval", mode: Interval, interval_range_s: Some((0.03, 0.03))),
    },
    commands: {"probe": (func: "probe_command", resampling_time_range: (1000.0, 1000.0))},
"#;

/// The RL additions: 4-step episodes (0.12 s), a reward of weight 2, the probe termination
/// and `time_out`, and a curriculum.
const RL: &str = r#"
    episode_length_s: 0.12,
    rewards: {"probe": (func: "probe_reward", weight: 2.0)},
    terminations: {
        "probe": (func: "probe_termination"),
        "time_out": (func: "time_out", time_out: true),
    },
    curriculum: {"probe": (func: "probe_curriculum")},
"#;

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

#[test]
fn rl_env_follows_isaac_labs_order() {
    take_log();
    let mut env =
        ManagerBasedRlEnv::from_ron(&format!("({BASE}{RL})"), "step_order.ron", &[]).unwrap();
    // Construction: command, action, observation, event, termination, reward, curriculum;
    // startup events once all managers exist.
    let build = strings(&[
        "build command",
        "build action",
        "build observation",
        "build event",
        "build termination",
        "build reward",
        "build curriculum",
        "startup [0, 1]",
    ]);
    assert_eq!(take_log(), build);
    assert_eq!(env.max_episode_length(), 4);

    env.reset().unwrap();
    let reset = strings(&[
        "curriculum [0, 1]",
        "reset [0, 1]",
        "resample [0, 1]",
        "observe [0, 0]",
    ]);
    assert_eq!(take_log(), reset);

    // Step 1: the decimation loop applies the actions before each of the 3 physics steps; the
    // counters are advanced before terminations and rewards; observations come last.
    let step_dt = 0.03_f32;
    let r = env.step(&[0.0, 0.0]).unwrap();
    assert_eq!(r.reward, &[2.0 * step_dt, 2.0 * step_dt]);
    assert_eq!(
        (r.terminated, r.time_outs),
        (&[false; 2][..], &[false; 2][..])
    );
    let plain_step = |ep: &str, obs: &str| {
        strings(&[
            "process",
            "apply",
            "apply",
            "apply",
            &format!("terminations {ep}"),
            &format!("rewards {ep}"),
            "metrics",
            "interval [0, 1]",
            &format!("observe {obs}"),
        ])
    };
    assert_eq!(take_log(), plain_step("[1, 1]", "[1, 1]"));

    // Step 2: env 1 terminates. Its reward is computed on the terminal state, then it is reset
    // (curriculum, reset event, command resampling) before the interval event and the
    // observations, so its observation belongs to the new episode.
    let r = env.step(&[0.0, 0.0]).unwrap();
    assert_eq!(
        (r.terminated, r.time_outs),
        (&[false, true][..], &[false; 2][..])
    );
    assert_eq!(r.reward, &[2.0 * step_dt, 2.0 * step_dt]);
    assert_eq!(
        r.extras.log.get("Episode Termination/probe"),
        Some(&1.0),
        "{:?}",
        r.extras.log
    );
    let step2 = strings(&[
        "process",
        "apply",
        "apply",
        "apply",
        "terminations [2, 2]",
        "rewards [2, 2]",
        "metrics",
        "curriculum [1]",
        "reset [1]",
        "resample [1]",
        "interval [0, 1]",
        "observe [2, 0]",
    ]);
    assert_eq!(take_log(), step2);
    assert_eq!(env.observation("policy").unwrap().0, &[2.0, 0.0]);

    // Step 3, then step 4: env 0 times out (a time-out, not a termination) after exactly 4
    // steps, while env 1 terminates again at its second step.
    env.step(&[0.0, 0.0]).unwrap();
    assert_eq!(take_log(), plain_step("[3, 1]", "[3, 1]"));
    let r = env.step(&[0.0, 0.0]).unwrap();
    assert_eq!(
        (r.terminated, r.time_outs),
        (&[false, true][..], &[true, false][..])
    );
    let log = &r.extras.log;
    assert_eq!(log["Episode Termination/time_out"], 1.0);
    assert_eq!(log["Episode Termination/probe"], 1.0);
    // Episode sums: env 0 4 × 2 × 0.03 = 0.24, env 1 2 × 2 × 0.03 = 0.12; the log holds their
    // mean divided by the episode length in seconds: 0.18 / 0.12 = 1.5.
    assert!((log["Episode Reward/probe"] - 1.5).abs() < 1e-5, "{log:?}");
    let step4 = strings(&[
        "process",
        "apply",
        "apply",
        "apply",
        "terminations [4, 2]",
        "rewards [4, 2]",
        "metrics",
        "curriculum [0, 1]",
        "reset [0, 1]",
        "resample [0, 1]",
        "interval [0, 1]",
        "observe [0, 0]",
    ]);
    assert_eq!(take_log(), step4);
}

#[test]
fn base_env_steps_without_episodes() {
    take_log();
    let mut env = ManagerBasedEnv::from_ron(&format!("({BASE})"), "base.ron", &[]).unwrap();
    assert_eq!(
        take_log(),
        strings(&[
            "build command",
            "build action",
            "build observation",
            "build event",
            "startup [0, 1]"
        ])
    );
    env.reset().unwrap();
    assert_eq!(
        take_log(),
        strings(&["reset [0, 1]", "resample [0, 1]", "observe [0, 0]"])
    );
    for k in 1..=6u32 {
        env.step(&[0.0, 0.0]).unwrap();
        let expected = strings(&[
            "process",
            "apply",
            "apply",
            "apply",
            "interval [0, 1]",
            &format!("observe [{k}, {k}]"),
        ]);
        assert_eq!(take_log(), expected, "step {k}");
    }
    // An RL-only field is not part of a base env config.
    let err = ManagerBasedEnv::from_ron(&format!("({BASE}{RL})"), "base.ron", &[])
        .err()
        .unwrap()
        .to_string();
    assert!(
        err.contains("base.ron") && err.contains("episode_length_s"),
        "{err}"
    );
    // The physics advanced 6 × 3 substeps of 10 ms: the arm, which the probe action does not
    // drive, has sagged under gravity.
    let arm = env.scene.backend.articulation(0);
    let default = &env.scene.desc.articulations[0].default_joint_pos;
    let moved = arm.joint_pos[..default.len()]
        .iter()
        .zip(default)
        .any(|(q, q0)| (q - q0).abs() > 1e-4);
    assert!(moved, "no physics step happened");
}
