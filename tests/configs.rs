//! Configs as files: a task's exported files edited on disk, bundled variants that include
//! their base, a run's `params/` fed back to `train`, and clear errors for broken includes.

use std::path::{Path, PathBuf};

use clap::Parser;
use orbit::managers::managers::Manager;
use orbit::managers::{ManagerBasedRlEnv, make_from_file};
use orbit::train::{TrainArgs, train};

/// A scratch directory, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("orbit-configs-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn edit(path: &Path, from: &str, to: &str) {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains(from), "{} has no `{from}`", path.display());
    std::fs::write(path, text.replacen(from, to, 1)).unwrap();
}

fn build(path: &Path, overrides: &[&str]) -> Result<ManagerBasedRlEnv, String> {
    orbit::link_registrations();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    make_from_file(path, &overrides).map_err(|e| e.to_string())
}

fn obs_dim(env: &ManagerBasedRlEnv) -> usize {
    env.observation("policy").unwrap().1
}

/// `list_tasks --export` writes the torque task's files with the base they include; editing
/// the copied base changes the copied variant (the include follows the file on disk), and a
/// user's file including the copy adds an observation term on top.
#[test]
fn an_exported_and_edited_task_gives_the_edited_env() {
    orbit::link_registrations();
    let dir = TempDir::new("export");
    let written =
        orbit::managers::export_task_configs("BoxPushing-ProMP-Franka-v0", &dir.0).unwrap();
    let names: Vec<String> = written
        .iter()
        .map(|p| p.strip_prefix(&dir.0).unwrap().display().to_string())
        .collect();
    assert_eq!(
        names,
        [
            "box_pushing/env/torque.ron",
            "box_pushing/env/base.ron",
            "box_pushing/agents/bbrl_ppo.ron",
            "box_pushing/black_box/promp.ron",
        ]
    );
    // Exporting again refuses and writes nothing.
    let again = orbit::managers::export_task_configs("BoxPushing-ProMP-Franka-v0", &dir.0);
    assert!(again.unwrap_err().to_string().contains("exists"));

    let variant = dir.0.join("box_pushing/env/torque.ron");
    let original = build(&variant, &["num_envs=1"]).unwrap();
    assert_eq!(
        (original.max_episode_length(), obs_dim(&original)),
        (100, 35)
    );
    // 2 s episodes of 0.02 s steps become 1 s ones.
    edit(
        &dir.0.join("box_pushing/env/base.ron"),
        "episode_length_s: 2.0",
        "episode_length_s: 1.0",
    );
    let edited = build(&variant, &["num_envs=1"]).unwrap();
    assert_eq!(edited.max_episode_length(), 50);

    let mine = dir.0.join("mine.ron");
    std::fs::write(
        &mine,
        "#include \"box_pushing/env/torque.ron\"\n(observations: {\"policy\": (terms: {\
         \"rod_tip\": (func: \"frame_pos\", params: (frame: \"rod_tip\"))})})\n",
    )
    .unwrap();
    let mut env = build(&mine, &["num_envs=1"]).unwrap();
    assert_eq!((env.max_episode_length(), obs_dim(&env)), (50, 38));
    // The new term is the rod tip's position: at Fancy Gym's start pose it is above the box.
    env.reset().unwrap();
    let (obs, _) = env.observation("policy").unwrap();
    let tip = &obs[35..38];
    assert!(
        (tip[0] - 0.4).abs() < 0.05 && (tip[1] - 0.3).abs() < 0.05 && tip[2] > 0.0,
        "rod tip {tip:?}"
    );
}

/// A bundled variant that includes its base resolves in memory: the joint-space task has the
/// base's timing, the shared implicit-PD settings and its own action term.
#[test]
fn a_bundled_variant_resolves_its_includes() {
    orbit::link_registrations();
    let task = orbit::managers::task("BoxPushing-JointPos-Franka-v0").unwrap();
    assert_eq!(
        task.env,
        Path::new("<bundled>/box_pushing/env/joint_pos.ron")
    );
    let doc = orbit::managers::load_env_config(&task.env, &[]).unwrap();
    let at = |path: &str| {
        let node = orbit::core::config::node_at(&doc, path).unwrap();
        node.to_ron().trim_end().to_string()
    };
    assert_eq!(at("decimation"), "10");
    assert_eq!(at("actions[\"arm\"].func"), "\"joint_position\"");
    assert!(at("sim.contact.model").starts_with("SoftStep"));
    assert_eq!(
        at("scene.articulations[0].actuators[\"arm\"].stiffness"),
        "400.0"
    );
    let env = build(&task.env, &["num_envs=1"]).unwrap();
    // Fancy Gym's 28 values and the last action, the rod tip, the box's velocities and its
    // error to the target.
    assert_eq!(obs_dim(&env), 53);
    // The variant's action term replaces none of the base's (the base has none); the command
    // comes from the base.
    assert_eq!(env.actions().active_terms(), ["arm"]);
    assert_eq!(env.commands().active_terms(), ["target"]);
}

/// An include cycle and a missing include in a user's file are errors naming the file and
/// the line of the `#include`.
#[test]
fn broken_includes_in_a_user_file_are_clear_errors() {
    let dir = TempDir::new("broken");
    let a = dir.0.join("a.ron");
    std::fs::write(&a, "#include \"b.ron\"\n(num_envs: 1)\n").unwrap();
    std::fs::write(dir.0.join("b.ron"), "\n#include \"a.ron\"\n(num_envs: 2)\n").unwrap();
    let message = build(&a, &[]).err().expect("an include cycle");
    assert!(message.contains("include cycle"), "{message}");
    assert!(
        message.contains(&format!("{}:2:1", dir.0.join("b.ron").display())),
        "{message}"
    );

    let c = dir.0.join("c.ron");
    std::fs::write(
        &c,
        "// mine\n#include \"<bundled>/box_pushing/env/nope.ron\"\n()\n",
    )
    .unwrap();
    let message = build(&c, &[]).err().expect("a missing include");
    assert!(
        message.contains(&format!("{}:2:1", c.display())) && message.contains("nope.ron"),
        "{message}"
    );
}

/// The resolved configs a run writes to `params/` rebuild the same env (observations equal
/// bit for bit over ten steps), and training from them reproduces the run.
#[test]
fn a_runs_params_rebuild_the_same_env_and_run() {
    let dir = TempDir::new("params");
    let root = dir.0.to_str().unwrap();
    let common = [
        "--num-envs",
        "4",
        "--max-iterations",
        "1",
        "--log-root",
        root,
    ];
    let mut args: Vec<&str> = vec!["train", "--task", "Reach-Franka-v0", "--run-name", "a"];
    args.extend(common);
    let first = train(&TrainArgs::parse_from(&args), false).unwrap_or_else(|e| panic!("{e}"));
    let params = first.log_dir().unwrap().join("params");
    let history = first.history.clone();
    drop(first);

    let env_file = params.join("env.ron");
    let agent_file = params.join("agent.ron");
    let mut from_params = build(&env_file, &[]).unwrap();
    let agent = orbit::rl::RunnerCfg::load(&agent_file, &[]).unwrap();
    let seed = format!("seed={}", agent.seed);
    let mut from_task = orbit::make("Reach-Franka-v0", &["num_envs=4".into(), seed]).unwrap();
    from_params.reset().unwrap();
    from_task.reset().unwrap();
    let d = from_task.action_dim();
    for step in 0..10 {
        let action: Vec<f32> = (0..4 * d)
            .map(|i| ((i + step) as f32 * 0.37).sin())
            .collect();
        let a = from_params.step(&action).unwrap().reward.to_vec();
        let b = from_task.step(&action).unwrap().reward.to_vec();
        assert_eq!(a, b, "rewards at step {step}");
        let (oa, _) = from_params.observation("policy").unwrap();
        let (ob, _) = from_task.observation("policy").unwrap();
        assert_eq!(oa, ob, "observations at step {step}");
    }

    let (env_arg, agent_arg) = (env_file.to_str().unwrap(), agent_file.to_str().unwrap());
    let mut args = vec![
        "train",
        "--task-config",
        env_arg,
        "--agent-config",
        agent_arg,
    ];
    args.extend(["--run-name", "b"]);
    args.extend(common);
    let second = train(&TrainArgs::parse_from(&args), false).unwrap_or_else(|e| panic!("{e}"));
    let learned = |h: &[orbit::rl::IterationLog]| -> Vec<String> {
        h.iter()
            .map(|i| format!("{:?}", (&i.losses, i.learning_rate, i.mean_noise_std)))
            .collect()
    };
    assert_eq!(
        learned(&second.history),
        learned(&history),
        "the run from params/ repeats the first"
    );
}
