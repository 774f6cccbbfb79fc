//! What the box-pushing test binaries share: the task and Fancy Gym's seed-0 target.

/// The task most tests run.
pub const TASK: &str = "BoxPushing-Torque-Franka-v0";

/// Fancy Gym's target pose after `reset(seed=0)`, `(x, y, z, qw, qx, qy, qz)` (yaw ≈ 3.0377 rad).
pub const SEED0_TARGET: [f32; 7] = [
    0.491_088_5,
    -0.207_191_96,
    -0.01,
    0.051_899_77,
    0.0,
    0.0,
    0.998_652_3,
];

/// The override that fixes the target command to [`SEED0_TARGET`].
pub fn seed0_target_override() -> String {
    format!(
        "commands.target.params.fixed=Some([{}])",
        SEED0_TARGET.map(|v| v.to_string()).join(", ")
    )
}
