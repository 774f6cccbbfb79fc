//! Data-parallel training across processes on MPI, as Isaac Lab does it with one process per
//! GPU (`torchrun --nproc_per_node=N … --distributed`) and RSL-RL's multi-GPU PPO.
//!
//! Launched by MPI's `mpiexec -n N` (on one host or, with a host file, several), every process
//! is a rank: it steps its own envs, seeded apart by the global rank, on the GPU of its local
//! rank, and holds a replica of the learner. [`Mpi`] is the [`Collective`] the replicas
//! exchange their gradients and statistics through (see [`orbit_rl::collective`]).
//!
//! ```text
//! mpiexec -n 2 target/release/examples/train --distributed --task BoxPushing-JointPos-Franka-v0
//! ```

#![warn(missing_docs)]

use mpi::Threading;
use mpi::environment::Universe;
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::CommunicatorCollectives;
use orbit_rl::Collective;

/// Why a process could not join a data-parallel run.
#[derive(Debug, thiserror::Error)]
pub enum DistributedError {
    /// MPI was initialised before (it can be only once per process).
    #[error("MPI is already initialised in this process: join a data-parallel run once")]
    AlreadyInitialized,
    /// The MPI library cannot call from more than one thread.
    #[error(
        "the MPI library offers thread level {0:?}; the learner needs `Serialized` (calls from \
         any one thread at a time): use an MPI built with thread support (MPICH, Open MPI)"
    )]
    Threading(Threading),
}

/// This process's place in an MPI job: its rank among all processes and among those on its
/// host. MPI is finalised when it is dropped.
pub struct Mpi {
    world: SimpleCommunicator,
    local_rank: usize,
    local_size: usize,
    hosts: usize,
    // Dropped last: finalises MPI.
    _universe: Universe,
}

impl Mpi {
    /// Joins the job this process was launched in (`mpiexec`); a process started without a
    /// launcher is a job of one.
    pub fn init() -> Result<Self, DistributedError> {
        let (universe, threading) = mpi::initialize_with_threading(Threading::Serialized)
            .ok_or(DistributedError::AlreadyInitialized)?;
        if threading < Threading::Serialized {
            return Err(DistributedError::Threading(threading));
        }
        let world = universe.world();
        // The ranks that share memory with this one: those on this host.
        let host = world.split_shared(world.rank());
        let local_rank = host.rank() as usize;
        let local_size = host.size() as usize;
        let mut firsts = vec![0u8; world.size() as usize];
        world.all_gather_into(&[u8::from(local_rank == 0)], &mut firsts[..]);
        let hosts = firsts.iter().filter(|&&f| f != 0).count();
        Ok(Self {
            world,
            local_rank,
            local_size,
            hosts,
            _universe: universe,
        })
    }

    /// This process's rank among those on its host (it picks the host's GPU).
    pub fn local_rank(&self) -> usize {
        self.local_rank
    }

    /// Number of ranks on this process's host.
    pub fn local_size(&self) -> usize {
        self.local_size
    }

    /// Number of hosts in the job.
    pub fn hosts(&self) -> usize {
        self.hosts
    }

    /// Ends every rank of the job with `code` (a rank that fails alone would leave the others
    /// waiting for it).
    pub fn abort(&self, code: i32) -> ! {
        self.world.abort(code)
    }
}

impl Collective for Mpi {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn world_size(&self) -> usize {
        self.world.size() as usize
    }

    fn all_gather(&self, local: &[u8], out: &mut [u8]) {
        assert_eq!(
            out.len(),
            local.len() * self.world_size(),
            "an all-gather's output holds every rank's input"
        );
        self.world.all_gather_into(local, out);
    }
}
