//! Backends register themselves with `inventory` and are chosen by name at run time, so the
//! same task runs on any backend by changing `sim.backend`.

use super::{PhysicsBackend, PhysicsError, SimCfg};
use crate::scene::SceneDesc;

/// Builds a backend for a resolved scene.
pub type BackendBuilder =
    fn(&SceneDesc, usize, &SimCfg) -> Result<Box<dyn PhysicsBackend>, PhysicsError>;

/// A backend registration:
/// `inventory::submit! { BackendRegistration { name: "rapier", description, build, probe } }`.
pub struct BackendRegistration {
    /// Name used in `SimCfg::backend`.
    pub name: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Constructor.
    pub build: BackendBuilder,
    /// What this backend would run on here (for [`AUTO_BACKEND`]).
    pub probe: fn() -> BackendProbe,
}

/// The `sim.backend` that picks the best backend this machine can run: a GPU adapter, else a
/// CPU Vulkan driver (Mesa's lavapipe), else a CPU-only backend.
pub const AUTO_BACKEND: &str = "auto";

/// What a backend would run on, on this machine.
#[derive(Clone, Debug, PartialEq)]
pub struct BackendProbe {
    /// The kind of device; [`DeviceKind::Unavailable`] if the backend cannot run here.
    pub kind: DeviceKind,
    /// The device (an adapter's name), or why there is none and what would give one.
    pub detail: String,
}

/// Kinds of devices a backend runs on, from least to most preferred by [`AUTO_BACKEND`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum DeviceKind {
    /// The backend cannot run here (e.g. no Vulkan driver).
    Unavailable,
    /// The CPU, with the backend's own code.
    Cpu,
    /// The CPU through a Vulkan driver that runs compute kernels on it (Mesa's lavapipe).
    CpuVulkan,
    /// A GPU.
    Gpu,
}

impl DeviceKind {
    /// Whether the physics runs on the CPU (a config sized for CPUs then fits).
    pub fn is_cpu(self) -> bool {
        matches!(self, DeviceKind::Cpu | DeviceKind::CpuVulkan)
    }
}

/// A backend chosen for a run, with what it runs on.
#[derive(Clone, Debug, PartialEq)]
pub struct BackendChoice {
    /// The registered backend name.
    pub name: String,
    /// Its device.
    pub probe: BackendProbe,
    /// Why it was chosen, for the user (set for [`AUTO_BACKEND`]).
    pub reason: Option<String>,
}

/// The backend that `name` means here: the registered backend of that name, or for
/// [`AUTO_BACKEND`] the one on the most preferred device ([`DeviceKind`]), with the reason and,
/// when a faster kind is missing, how to get it.
pub fn choose_backend(name: &str) -> Result<BackendChoice, PhysicsError> {
    let registrations = || inventory::iter::<BackendRegistration>.into_iter();
    if name != AUTO_BACKEND {
        let reg = registrations()
            .find(|r| r.name == name)
            .ok_or_else(|| unknown_backend(name))?;
        return Ok(BackendChoice {
            name: name.to_string(),
            probe: (reg.probe)(),
            reason: None,
        });
    }
    let mut probes: Vec<(&str, BackendProbe)> =
        registrations().map(|r| (r.name, (r.probe)())).collect();
    // Stable order first, so that ties go the same way on every run.
    probes.sort_by(|a, b| a.0.cmp(b.0));
    let best = probes
        .iter()
        .filter(|(_, p)| p.kind != DeviceKind::Unavailable)
        .max_by_key(|(_, p)| p.kind)
        .ok_or_else(|| {
            PhysicsError::InvalidInput(format!(
                "sim.backend \"auto\" found no backend that can run here: {probes:?}"
            ))
        })?;
    let missing: Vec<String> = probes
        .iter()
        .filter(|(_, p)| p.kind == DeviceKind::Unavailable)
        .map(|(n, p)| format!("`{n}` unavailable: {}", p.detail))
        .collect();
    let mut reason = format!("the best device here: {}", best.1.detail);
    if !missing.is_empty() {
        reason += &format!("; {}", missing.join("; "));
    }
    Ok(BackendChoice {
        name: best.0.to_string(),
        probe: best.1.clone(),
        reason: Some(reason),
    })
}

fn unknown_backend(name: &str) -> PhysicsError {
    let mut available = backend_names();
    available.push(AUTO_BACKEND.to_string());
    PhysicsError::UnknownBackend {
        name: name.to_string(),
        available,
    }
}

inventory::collect!(BackendRegistration);

/// Names of all registered backends, sorted.
pub fn backend_names() -> Vec<String> {
    let mut names: Vec<String> = inventory::iter::<BackendRegistration>
        .into_iter()
        .map(|r| r.name.to_string())
        .collect();
    names.sort();
    names
}

/// Builds `num_envs` copies of `scene` on the backend named in `sim.backend` ([`AUTO_BACKEND`]:
/// the one [`choose_backend`] picks).
pub fn build_backend(
    scene: &SceneDesc,
    num_envs: usize,
    sim: &SimCfg,
) -> Result<Box<dyn PhysicsBackend>, PhysicsError> {
    sim.validate()?;
    if num_envs == 0 {
        return Err(PhysicsError::InvalidInput(
            "num_envs must be at least 1".into(),
        ));
    }
    if sim.backend == AUTO_BACKEND {
        let choice = choose_backend(AUTO_BACKEND)?;
        tracing::info!(backend = %choice.name, reason = ?choice.reason, "sim.backend \"auto\"");
        let sim = SimCfg {
            backend: choice.name,
            ..sim.clone()
        };
        return build_backend(scene, num_envs, &sim);
    }
    let reg = inventory::iter::<BackendRegistration>
        .into_iter()
        .find(|r| r.name == sim.backend)
        .ok_or_else(|| unknown_backend(&sim.backend))?;
    (reg.build)(scene, num_envs, sim)
}
