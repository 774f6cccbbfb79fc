//! Two MPI ranks on this machine (CPU learner, rapier physics): replicas stay bit-identical
//! while their envs differ, a two-rank update equals one learner's update on both ranks'
//! rollouts together, and two ranks launched as on two hosts find their places. Each test
//! launches MPICH's `mpiexec` (Hydra) on an ignored test of this binary (`MPIEXEC` names
//! another path to it).

use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use orbit_distributed::Mpi;
use orbit_envs::RlVecEnv;
use orbit_managers::make;
use orbit_physics_rapier as _;
use orbit_rl::burn::tensor::Device;
use orbit_rl::model::ActorCritic;
use orbit_rl::ppo::Ppo;
use orbit_rl::{Collective, OnPolicyRunner, RunnerCfg, VecEnv};
use orbit_task_reach::TASK_ID;

/// The environment variable that gives a rank its output directory.
const RANK_DIR: &str = "ORBIT_TEST_RANK_DIR";

/// Runs the ignored test `name` of this binary on two ranks; panics unless both succeed.
fn on_two_ranks(name: &str, dir: &Path) {
    launch(&["-n", "2"], name, dir);
}

/// Runs the ignored test `name` of this binary under the launcher with `launcher_args`;
/// panics unless every rank succeeds.
fn launch(launcher_args: &[&str], name: &str, dir: &Path) {
    let launcher = std::env::var("MPIEXEC").unwrap_or_else(|_| "mpiexec".into());
    let exe = std::env::current_exe().unwrap();
    let out = Command::new(&launcher)
        .args(launcher_args)
        .arg(exe)
        .args([
            "--ignored",
            "--exact",
            name,
            "--nocapture",
            "--test-threads=1",
        ])
        .env(RANK_DIR, dir)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "`{launcher}` did not start ({e}): install MPI (Debian: `apt-get install mpich \
                 libmpich-dev`) or name the launcher in MPIEXEC"
            )
        });
    assert!(
        out.status.success(),
        "the ranks failed ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The reach task's runner config with a few overrides.
fn reach_agent(overrides: &[&str]) -> RunnerCfg {
    let agent = orbit_managers::task(TASK_ID).unwrap().agent.unwrap();
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    RunnerCfg::load(&agent, &o).unwrap()
}

/// One rank of [`replicas_stay_identical_while_their_envs_differ`] under MPI.
#[test]
#[ignore = "run on two MPI ranks by replicas_stay_identical_while_their_envs_differ"]
fn rank_trains_reach() {
    let Ok(dir) = std::env::var(RANK_DIR) else {
        return;
    };
    train_reach(Arc::new(Mpi::init().unwrap()), Path::new(&dir), "rank");
}

/// A rank's training: 8 reach envs seeded by the rank, four iterations with a checkpoint in
/// `<dir>/<name><rank>`; then, from rank 0's checkpoint, two more in `<name><rank>-resumed`.
fn train_reach(c: Arc<dyn Collective>, dir: &Path, name: &str) {
    let rank = c.rank();
    let env_overrides = vec![
        "num_envs=8".to_string(),
        format!("seed={}", 3 + rank),
        "episode_length_s=0.5".into(),
    ];
    let runner_in = |run: String| {
        let env = RlVecEnv::new(make(TASK_ID, &env_overrides).unwrap()).unwrap();
        let cfg = reach_agent(&[
            "seed=3",
            "num_steps_per_env=8",
            "empirical_normalization=true",
        ]);
        OnPolicyRunner::new(env, cfg, Some(dir.join(run)), Device::flex()).unwrap()
    };
    let mut runner = runner_in(format!("{name}{rank}"));
    runner.distribute(c.clone());
    runner.learn(4).unwrap();
    let obs = format!("{:?}", runner.env.observations());
    std::fs::write(dir.join(format!("{name}{rank}")).join("observations"), obs).unwrap();
    // Resumed from rank 0's checkpoint (once it is written) on both ranks, two more iterations.
    c.all_gather(&[0], &mut [0; 2]);
    let mut resumed = runner_in(format!("{name}{rank}-resumed"));
    resumed
        .load_checkpoint(&dir.join(format!("{name}0")).join("model_3"))
        .unwrap();
    resumed.distribute(c);
    resumed.learn(2).unwrap();
}

/// After four updates on different envs, the two ranks' checkpoints (parameters, Adam's
/// moments, learning rate, observation statistics) are bit-identical, while their envs'
/// states differ (their logs, which pool every rank's episodes, agree); resumed on both ranks from rank 0's checkpoint, they stay identical; two
/// ranks as threads of one process end with the same bits.
#[test]
fn replicas_stay_identical_while_their_envs_differ() {
    let dir = std::env::temp_dir().join(format!("orbit-two-ranks-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    on_two_ranks("rank_trains_reach", &dir);
    let read = |rank: usize, file: &str| {
        std::fs::read(dir.join(format!("rank{rank}")).join(file))
            .unwrap_or_else(|e| panic!("rank {rank}'s {file}: {e}"))
    };
    // The parameters' values (the files also hold their ids, which differ by process); equal
    // parameters after an update mean equal Adam moments before it.
    let weights_in = |run: String, checkpoint: &str| {
        let base = dir.join(run).join(checkpoint);
        let s = orbit_rl::checkpoint::read_state(&base).unwrap();
        let (no, nc, na) = (s.num_obs, s.num_critic_obs, s.num_actions);
        let model = ActorCritic::new(&s.policy, no, nc, na, 0, &Device::flex());
        let model = orbit_rl::ppo::load_model(model, &base).unwrap();
        model.parameter_values()
    };
    let weights = |rank: usize| weights_in(format!("rank{rank}"), "model_3");
    assert!(weights(0) == weights(1), "the ranks' parameters differ");
    let resumed = |rank: usize| weights_in(format!("rank{rank}-resumed"), "model_5");
    assert!(
        resumed(0) == resumed(1),
        "the resumed ranks' parameters differ"
    );
    assert!(resumed(0) != weights(0), "the resumed run did not train");
    // The same two ranks as threads of this process: the same bits as the MPI ranks.
    std::thread::scope(|s| {
        for thread in orbit_rl::collective::threads::group(2) {
            let dir = &dir;
            s.spawn(move || train_reach(Arc::new(thread), dir, "thread"));
        }
    });
    assert!(
        weights_in("thread1".into(), "model_3") == weights(0),
        "thread ranks differ from MPI ranks"
    );
    assert!(weights_in("thread0-resumed".into(), "model_5") == resumed(0));
    let state = |rank: usize| {
        let mut json: serde_json::Value =
            serde_json::from_slice(&read(rank, "model_3.json")).unwrap();
        json.as_object_mut().unwrap().remove("wall_time");
        json
    };
    assert_eq!(state(0), state(1));
    assert!(state(0)["obs_normalizer"]["count"].as_u64() == Some(2 * 8 * (4 * 8 + 1)));
    let returns = |rank: usize| {
        let csv = dir.join(format!("rank{rank}")).join("scalars.csv");
        let logs = orbit_rl::logger::read_scalars(&csv).unwrap();
        logs.iter().map(|l| l.mean_return).collect::<Vec<_>>()
    };
    assert!(returns(0).iter().any(Option::is_some));
    assert_eq!(
        returns(0),
        returns(1),
        "both ranks log every rank's episodes"
    );
    assert_ne!(
        read(0, "observations"),
        read(1, "observations"),
        "the ranks' envs are in the same state"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Observations of the global env `g` at step `t` (3 per env), a fixed pseudo-random pattern.
fn observation(g: usize, t: usize) -> [f32; 3] {
    let h = |k: usize| ((g * 2654435761 + t * 40503 + k * 9973) % 1000) as f32 / 500.0 - 1.0;
    [h(0), h(1), h(2)]
}

/// The learner of [`a_two_rank_update_equals_one_learner_on_the_whole_batch`] for `envs`
/// envs: the reach task's PPO settings, one minibatch, 3 observations, 2 actions.
fn learner(envs: usize, steps: usize) -> Ppo {
    let mut cfg = reach_agent(&["seed=11"]);
    cfg.algorithm.num_mini_batches = 1;
    let device = Device::flex().autodiff();
    let model = ActorCritic::new(&cfg.policy, 3, 3, 2, cfg.seed, &device);
    Ppo::new(
        cfg.algorithm,
        model,
        envs,
        steps,
        (3, 3, 2),
        cfg.seed,
        device,
    )
}

/// Collects `steps` steps on the global envs `first..first + envs` and updates; returns the
/// parameters.
fn collect_and_update(p: &mut Ppo, first: usize, steps: usize) -> Vec<f32> {
    let n = p.storage.num_envs;
    let obs =
        |t: usize| -> Vec<f32> { (first..first + n).flat_map(|g| observation(g, t)).collect() };
    let mut actions = vec![0.0; n * 2];
    for t in 0..steps {
        let o = obs(t);
        p.act(&o, &o, &mut actions).unwrap();
        let rewards: Vec<f32> = actions
            .chunks(2)
            .map(|a| 0.5 - a[0].abs() - a[1] * a[1])
            .collect();
        let ends: Vec<bool> = (first..first + n).map(|g| (g * 5 + t) % 7 == 0).collect();
        p.process_env_step(&rewards, &ends, &vec![false; n]);
    }
    p.compute_returns(&obs(steps));
    p.update().unwrap();
    p.model.parameter_values()
}

/// One rank of [`a_two_rank_update_equals_one_learner_on_the_whole_batch`]: rank 0 also
/// updates one learner on all 32 envs and compares.
#[test]
#[ignore = "run on two MPI ranks by a_two_rank_update_equals_one_learner_on_the_whole_batch"]
fn rank_updates_half_the_batch() {
    if std::env::var(RANK_DIR).is_err() {
        return;
    }
    const ENVS: usize = 32;
    const STEPS: usize = 6;
    let mpi = Arc::new(Mpi::init().unwrap());
    let rank = mpi.rank();
    let mut p = learner(ENVS / 2, STEPS);
    p.distribute(mpi.clone());
    let params = collect_and_update(&mut p, rank * ENVS / 2, STEPS);
    let bytes: Vec<u8> = params.iter().flat_map(|v| v.to_le_bytes()).collect();
    let mut both = vec![0u8; 2 * bytes.len()];
    mpi.all_gather(&bytes, &mut both);
    assert!(
        both[..bytes.len()] == both[bytes.len()..],
        "the replicas differ"
    );
    if rank == 0 {
        let mut whole = learner(ENVS, STEPS);
        let initial = whole.model.parameter_values();
        let one = collect_and_update(&mut whole, 0, STEPS);
        let max_diff = |a: &[f32], b: &[f32]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0f32, f32::max)
        };
        let moved = max_diff(&one, &initial);
        let diff = max_diff(&one, &params);
        assert!(moved > 1e-3, "the update moved the parameters by {moved}");
        assert!(diff < 1e-6, "two ranks differ from one learner by {diff}");
    }
}

/// With a fixed rollout split over two ranks, the ranks end the update with bit-identical
/// parameters, equal within 1e-6 to those of one learner updated on both halves together
/// (the update moves them by more than 1e-3): gradients and KL averaged, advantages
/// normalised over both ranks.
#[test]
fn a_two_rank_update_equals_one_learner_on_the_whole_batch() {
    on_two_ranks("rank_updates_half_the_batch", &std::env::temp_dir());
}

/// One rank of [`ranks_launched_on_two_hosts_find_their_places`].
#[test]
#[ignore = "run on two MPI ranks by ranks_launched_on_two_hosts_find_their_places"]
fn rank_on_its_own_host() {
    if std::env::var(RANK_DIR).is_err() {
        return;
    }
    let mpi = Mpi::init().unwrap();
    assert_eq!((mpi.world_size(), mpi.hosts()), (2, 2));
    assert_eq!((mpi.local_rank(), mpi.local_size()), (0, 1));
    let mut ranks = [0u8; 2];
    mpi.all_gather(&[mpi.rank() as u8 + 10], &mut ranks);
    assert_eq!(ranks, [10, 11]);
}

/// Launched as across two hosts (Hydra's proxies, one per host, started by its `fork`
/// launcher in place of ssh; the ranks wire up through Hydra's process-management interface
/// as on a cluster), each rank is rank 0 of its host, and the job counts two hosts.
#[test]
fn ranks_launched_on_two_hosts_find_their_places() {
    let args = [
        "-launcher",
        "fork",
        "-hosts",
        "host-a,host-b",
        "-n",
        "2",
        "-ppn",
        "1",
    ];
    launch(&args, "rank_on_its_own_host", &std::env::temp_dir());
}
