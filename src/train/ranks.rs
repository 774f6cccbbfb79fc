//! Data-parallel ranks of a `train` run: threads of this process sharing the run's envs
//! (`--ranks`), or this process as one rank of an MPI job (`--distributed`).

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use orbit_rl::{LearnerDevice, OnPolicyRunner, RlError, VecEnv};

use super::{ResolvedRun, TrainArgs, agent_file, resolve, train_rank};

/// How many thread ranks share a run's envs (`--ranks`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RankCount {
    /// One per core, at most [`AUTO_RANKS_MAX`] and with at least [`AUTO_MIN_ENVS_PER_RANK`]
    /// envs each, when the physics and the learner both run on the CPU; else one.
    Auto,
    /// This many (at least one).
    Fixed(u16),
}

/// Most thread ranks `--ranks auto` starts: on 16 cores box pushing's CPU config trained
/// fastest with 8 (of 1, 4 and 8 tried), each rank then stepping 128 envs.
pub const AUTO_RANKS_MAX: usize = 8;

/// Fewest envs per rank `--ranks auto` gives a rank: a smaller run is not split, its update
/// being short already.
pub const AUTO_MIN_ENVS_PER_RANK: usize = 64;

impl std::str::FromStr for RankCount {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            _ => match s.parse::<u16>() {
                Ok(k) if k > 0 => Ok(Self::Fixed(k)),
                _ => Err(format!(
                    "`{s}` is not a number of ranks: pass `auto` or a whole number from 1"
                )),
            },
        }
    }
}

/// [`train_with`] on `ranks` threads as ranks sharing the run's `total_envs` envs; rank 0, on
/// this thread, logs and returns its runner, or the run's error (a failed rank's).
pub(super) fn train_in_threads(
    args: &TrainArgs,
    run: ResolvedRun,
    show_progress: bool,
    stop: Option<Arc<AtomicBool>>,
    ranks: usize,
    total_envs: usize,
) -> Result<OnPolicyRunner<Box<dyn VecEnv>>, Box<dyn std::error::Error>> {
    let why = match args.ranks {
        RankCount::Auto => {
            " (--ranks auto: the physics and the learner run on the CPU, where one \
                            process updates on about one core; --ranks 1 trains on one thread)"
        }
        RankCount::Fixed(_) => "",
    };
    println!(
        "data-parallel training: {ranks} ranks as threads of this process{why}, {} envs each; \
         rank 0 logs and checkpoints",
        total_envs / ranks
    );
    let mut group = orbit_rl::collective::threads::group(ranks).into_iter();
    let first = group.next().expect("at least one rank");
    std::thread::scope(|s| {
        let others: Vec<_> = group
            .map(|thread| {
                let (stop, run) = (stop.clone(), run.clone());
                // An error crosses threads as its message.
                s.spawn(move || {
                    train_thread_rank(args, run, false, stop, thread, ranks)
                        .map(drop)
                        .map_err(|e| (stopped_for_another(e.as_ref()), e.to_string()))
                })
            })
            .collect();
        let first = train_thread_rank(args, run, show_progress, stop, first, ranks);
        let others: Vec<_> = (others.into_iter())
            .map(|h| h.join().expect("a rank's panic is caught"))
            .collect();
        match first {
            Err(e) if stopped_for_another(e.as_ref()) => {
                // Rank 0 stopped for another rank: that rank's error is the run's.
                let failed = others.into_iter().enumerate().find_map(|(i, r)| match r {
                    Err((false, message)) => Some((i + 1, message)),
                    _ => None,
                });
                Err(match failed {
                    Some((rank, message)) => RlError::RankFailed { rank, message }.into(),
                    None => e,
                })
            }
            first => first,
        }
    })
}

/// Whether `e` ended a rank because another rank failed (the run's error is that rank's).
fn stopped_for_another(e: &(dyn std::error::Error + 'static)) -> bool {
    matches!(
        e.downcast_ref::<RlError>(),
        Some(RlError::RankStopped { .. })
    )
}

/// [`train_with`] as one rank of the MPI job this process was started in.
pub(super) fn train_in_mpi_job(
    args: &TrainArgs,
    show_progress: bool,
    stop: Option<Arc<AtomicBool>>,
) -> Result<OnPolicyRunner<Box<dyn VecEnv>>, Box<dyn std::error::Error>> {
    if matches!(args.ranks, RankCount::Fixed(k) if k > 1) {
        return Err(RlError::EnvMismatch(
            "--ranks (threads of one process) and --distributed (processes under MPI) \
             exclude each other: pass one"
                .into(),
        )
        .into());
    }
    // Before the GPU is first used: it picks this rank's.
    let rank = crate::distributed::Rank::join()?;
    if rank.rank() == 0 {
        println!(
            "data-parallel training: {} ranks on {} host(s) (MPI); rank 0 logs and checkpoints",
            rank.world_size(),
            rank.hosts
        );
    }
    let result = resolve(args).map_err(Into::into).and_then(|run| {
        train_rank(
            args,
            run,
            show_progress && rank.rank() == 0,
            stop,
            Some(&rank),
            1,
        )
    });
    if let Err(e) = &result
        && rank.world_size() > 1
    {
        end_rank(&rank, e.as_ref());
    }
    result
}

/// The number of envs `run` makes (its env config's `num_envs` with the overrides).
pub(super) fn run_num_envs(run: &ResolvedRun) -> Result<usize, Box<dyn std::error::Error>> {
    let doc = orbit_managers::load_env_config(&run.configs.env, &run.env_overrides)?;
    let node = orbit_core::config::node_at(&doc, "num_envs").ok_or_else(|| {
        RlError::EnvMismatch(format!("{} sets no `num_envs`", run.configs.env.display()))
    })?;
    Ok(orbit_core::config::from_node(node)?)
}

/// How many thread ranks share `run`'s `total_envs` envs: `requested`, or for `auto` the most
/// (up to one per core of `cores` and [`AUTO_RANKS_MAX`], each with at least
/// [`AUTO_MIN_ENVS_PER_RANK`]) that share them evenly when the physics and the learner both
/// run on the CPU. Each rank's share must divide evenly and fill the minibatches.
pub fn thread_ranks(
    requested: RankCount,
    run: &ResolvedRun,
    total_envs: usize,
    cores: usize,
) -> Result<usize, RlError> {
    let file = agent_file(&run.configs)?.display().to_string();
    let fits = |k: usize| {
        total_envs.is_multiple_of(k)
            && (k == 1 || total_envs / k >= AUTO_MIN_ENVS_PER_RANK)
            && run.agent.validate_batch(total_envs / k, &file).is_ok()
    };
    match requested {
        RankCount::Fixed(k) => {
            let k = usize::from(k);
            if !total_envs.is_multiple_of(k) {
                return Err(RlError::InvalidConfig {
                    file: "<command line>".into(),
                    field: "--ranks".into(),
                    message: format!(
                        "{k} ranks cannot share {total_envs} envs evenly: pass a --num-envs \
                         that {k} divides, or another --ranks"
                    ),
                });
            }
            run.agent.validate_batch(total_envs / k, &file)?;
            Ok(k)
        }
        RankCount::Auto if run.physics_on_cpu && run.agent.device == LearnerDevice::Cpu => Ok((1
            ..=cores.min(AUTO_RANKS_MAX))
            .rev()
            .find(|&k| fits(k))
            .unwrap_or(1)),
        RankCount::Auto => Ok(1),
    }
}

/// One thread rank's training, its share of the run's envs one of `ranks`. A failure other
/// than a stop, a panic included, stops the other ranks at their next exchange.
fn train_thread_rank(
    args: &TrainArgs,
    run: ResolvedRun,
    show_progress: bool,
    stop: Option<Arc<AtomicBool>>,
    thread: orbit_rl::collective::threads::ThreadRank,
    ranks: usize,
) -> Result<OnPolicyRunner<Box<dyn VecEnv>>, Box<dyn std::error::Error>> {
    use orbit_rl::collective::threads::GroupAborted;
    let rank = crate::distributed::Rank::thread(thread);
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        // Dropped at the end of this closure: the runner it returns keeps the device.
        let _device = (run.backend == orbit_physics_wgpu::BACKEND_NAME)
            .then(orbit_physics_wgpu::open_device_for_this_thread)
            .transpose()
            .map_err(|e| RlError::EnvMismatch(format!("a rank's physics device: {e}")))?;
        train_rank(args, run, show_progress, stop, Some(&rank), ranks)
    }))
    .unwrap_or_else(|payload| match payload.downcast::<GroupAborted>() {
        Ok(aborted) => Err(RlError::RankStopped { by: aborted.by }.into()),
        Err(panic) => {
            let message = (panic.downcast_ref::<&str>().map(|m| m.to_string()))
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(RlError::RankFailed {
                rank: rank.rank(),
                message: format!("panicked: {message}"),
            }
            .into())
        }
    });
    if let Err(e) = &result
        && !is_interrupted(e.as_ref())
        && !stopped_for_another(e.as_ref())
    {
        rank.abort(crate::failure_status(e.as_ref()));
    }
    result
}

/// After `e` on the MPI rank `rank`: every rank stops together on a stop request; any other
/// error ends the job, named with the rank.
fn end_rank(rank: &crate::distributed::Rank, e: &(dyn std::error::Error + 'static)) {
    if !is_interrupted(e) {
        eprintln!("error on rank {}: {e}", rank.rank());
        rank.abort(crate::failure_status(e))
    }
}

/// Whether `e` is a stop request's end (every rank stops together).
fn is_interrupted(e: &(dyn std::error::Error + 'static)) -> bool {
    matches!(
        e.downcast_ref::<RlError>(),
        Some(RlError::Interrupted { .. })
    )
}
