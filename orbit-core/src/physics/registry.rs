//! Backends register themselves with `inventory` and are chosen by name at run time, so the
//! same task runs on any backend by changing `sim.backend`.

use super::{PhysicsBackend, PhysicsError, SimCfg};
use crate::scene::SceneDesc;

/// Builds a backend for a resolved scene.
pub type BackendBuilder =
    fn(&SceneDesc, usize, &SimCfg) -> Result<Box<dyn PhysicsBackend>, PhysicsError>;

/// A backend registration: `inventory::submit! { BackendRegistration { name: "rapier", build } }`.
pub struct BackendRegistration {
    /// Name used in `SimCfg::backend`.
    pub name: &'static str,
    /// One-line description.
    pub description: &'static str,
    /// Constructor.
    pub build: BackendBuilder,
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

/// Builds `num_envs` copies of `scene` on the backend named in `sim.backend`.
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
    let reg = inventory::iter::<BackendRegistration>
        .into_iter()
        .find(|r| r.name == sim.backend)
        .ok_or_else(|| PhysicsError::UnknownBackend {
            name: sim.backend.clone(),
            available: backend_names(),
        })?;
    (reg.build)(scene, num_envs, sim)
}
