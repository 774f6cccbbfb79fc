//! `sim.backend: "auto"` (the tasks' default) picks a GPU, else Mesa's lavapipe, else rapier,
//! says why, and `train` then takes the task's training config sized for CPUs when the physics
//! runs on the CPU.

use clap::Parser;
use orbit::core::physics::{AUTO_BACKEND, DeviceKind, PhysicsError, choose_backend};
use orbit::train::{TrainArgs, resolve};

/// With a Vulkan adapter (lavapipe in CI) `auto` is `wgpu` on it, with the reason; without one
/// it is rapier, and the reason says how to install lavapipe. A named backend is itself.
#[test]
fn auto_prefers_vulkan_and_says_why() {
    orbit::link_registrations();
    let choice = choose_backend(AUTO_BACKEND).unwrap();
    let reason = choice.reason.clone().expect("auto gives its reason");
    if orbit::physics_wgpu::gpu_available_for_tests() {
        assert_eq!(choice.name, "wgpu");
        assert!(choice.probe.kind >= DeviceKind::CpuVulkan, "{choice:?}");
        assert!(reason.contains("Vulkan adapter"), "{reason}");
    } else {
        assert_eq!(choice.name, "rapier");
        assert!(reason.contains("mesa-vulkan-drivers"), "{reason}");
    }
    let rapier = choose_backend("rapier").unwrap();
    assert_eq!((rapier.probe.kind, rapier.reason), (DeviceKind::Cpu, None));
    match choose_backend("nope") {
        Err(PhysicsError::UnknownBackend { available, .. }) => {
            assert!(
                available.contains(&AUTO_BACKEND.to_string()),
                "{available:?}"
            )
        }
        other => panic!("expected an unknown backend, got {other:?}"),
    }
}

/// Physics on the CPU trains the default task with its CPU-sized config (fewer envs), and the
/// run pins the chosen backend so that its `params/env.ron` repeats it; a given agent config
/// wins.
#[test]
fn cpu_physics_trains_with_the_cpu_sized_config() {
    let args = TrainArgs::parse_from(["train", "--backend", "rapier"]);
    let run = resolve(&args).unwrap();
    let agent = run.configs.agent.as_ref().unwrap().display().to_string();
    assert!(agent.ends_with("agents/ppo_cpu.ron"), "{agent}");
    assert!(run.env_overrides.contains(&"num_envs=1024".to_string()));
    assert_eq!(
        run.env_overrides.last(),
        Some(&"sim.backend=\"rapier\"".to_string())
    );

    let gpu_config = orbit::managers::task(orbit::DEFAULT_TASK).unwrap().agent;
    let gpu_config = gpu_config.unwrap();
    let args = TrainArgs::parse_from([
        "train",
        "--backend",
        "rapier",
        "--agent-config",
        gpu_config.to_str().unwrap(),
    ]);
    let run = resolve(&args).unwrap();
    assert_eq!(run.configs.agent.as_ref(), Some(&gpu_config));
    assert!(run.env_overrides.contains(&"num_envs=4096".to_string()));
}
