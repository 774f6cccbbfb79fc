//! Data-parallel ranks for `train`: a process as one rank of an MPI job (`--distributed`, one
//! process per GPU as Isaac Lab's `torchrun … --distributed`, in builds with the `distributed`
//! feature), or threads of one process as ranks (`--ranks K`, which splits the CPU learner's
//! update over cores).

use std::sync::Arc;

use orbit_rl::collective::threads::ThreadRank;
use orbit_rl::{Collective, RlError};

/// A rank's place in a data-parallel run.
pub struct Rank {
    /// The rank group the learner exchanges through.
    pub collective: Arc<dyn Collective>,
    /// Number of hosts.
    pub hosts: usize,
    /// The MPI job, for a rank that is a process of one.
    #[cfg(feature = "distributed")]
    mpi: Option<Arc<orbit_distributed::Mpi>>,
    /// The thread group, for a rank that is a thread.
    thread: Option<Arc<ThreadRank>>,
}

impl Rank {
    /// Joins the MPI job this process was started in (`mpiexec -n N …`; without a launcher, a
    /// job of one) and puts this rank on its host's GPU number `local_rank`.
    #[cfg(feature = "distributed")]
    pub fn join() -> Result<Self, RlError> {
        let mpi =
            Arc::new(orbit_distributed::Mpi::init().map_err(|e| RlError::Device(e.to_string()))?);
        orbit_physics_wgpu::select_gpu(mpi.local_rank()).map_err(RlError::Device)?;
        share_cores(mpi.local_size());
        Ok(Self {
            collective: mpi.clone(),
            hosts: mpi.hosts(),
            mpi: Some(mpi),
            thread: None,
        })
    }

    /// This rank, `0..world_size()`.
    pub fn rank(&self) -> usize {
        self.collective.rank()
    }

    /// Number of ranks.
    pub fn world_size(&self) -> usize {
        self.collective.world_size()
    }

    /// Without the `distributed` feature: an error that says how to build it.
    #[cfg(not(feature = "distributed"))]
    pub fn join() -> Result<Self, RlError> {
        Err(RlError::Device(
            "this build has no distributed training: build with `--features distributed` (it \
             links MPI; Debian: `apt-get install mpich libmpich-dev libclang-dev`) and launch \
             with `mpiexec -n <GPUs> …/train --distributed`"
                .into(),
        ))
    }

    /// Fails on every rank unless all ranks resolved the same `settings` (the physics backend,
    /// the training config): ranks that differ there would exchange mismatched data.
    pub fn check_same_settings(&self, settings: &str) -> Result<(), RlError> {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        settings.hash(&mut hasher);
        let mine = hasher.finish().to_le_bytes();
        let differ = orbit_rl::collective::ranks_differing(&*self.collective, &mine);
        if differ.is_empty() {
            return Ok(());
        }
        Err(RlError::EnvMismatch(format!(
            "rank {} resolved other settings than ranks {differ:?} (the physics backend or the \
             training config); ranks must train alike. A rank without a GPU of its own picks \
             another backend under `sim.backend: \"auto\"`: start at most one rank per GPU of a \
             host, or pass --backend",
            self.rank()
        )))
    }

    /// A thread of this process as rank `thread.rank()` of a group of threads.
    pub fn thread(thread: ThreadRank) -> Self {
        let thread = Arc::new(thread);
        Self {
            collective: thread.clone(),
            hosts: 1,
            #[cfg(feature = "distributed")]
            mpi: None,
            thread: Some(thread),
        }
    }

    /// Ends every rank after a failure on this one: a rank that fails alone would leave the
    /// others waiting for it. Thread ranks leave their next exchange (see
    /// [`ThreadRank::abort`]) and this returns; a process rank ends the job with `status`.
    pub fn abort(&self, status: u8) {
        if let Some(thread) = &self.thread {
            return thread.abort();
        }
        #[cfg(feature = "distributed")]
        if let Some(mpi) = &self.mpi {
            mpi.abort(i32::from(status));
        }
        std::process::exit(i32::from(status))
    }
}

/// Shares the host's cores among its ranks: each rank's rayon pool (the env's managers, the
/// CPU-side policy work) gets `cores / ranks on this host` threads, unless `RAYON_NUM_THREADS`
/// sets it. Every rank using every core would oversubscribe them.
#[cfg(feature = "distributed")]
fn share_cores(ranks_on_host: usize) {
    if ranks_on_host > 1 && std::env::var_os("RAYON_NUM_THREADS").is_none() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        // Fails only if the pool was already built; it then keeps its size.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads((cores / ranks_on_host).max(1))
            .build_global();
    }
}
