//! Agreement with MuJoCo rollouts of the Ant and the Humanoid under open-loop joint torques
//! (`data/mujoco_{ant,humanoid}_rollout.json`, written by `tools/mujoco_rollout.py`): a
//! floating base in free fall, then landing.

use std::path::Path;

use glam::{Quat, Vec3};
use orbit_core::math::Pose;
use orbit_core::physics::PhysicsBackend;
use orbit_core::scene::{ArticulationCfg, SceneCfg, SceneDesc};
use serde::Deserialize;

use crate::scenes::{build, floating_ant, floating_mjcf, ground, resolve};

#[derive(Deserialize)]
struct Initial {
    root_pos: [f32; 3],
    root_quat: [f32; 4],
    lin_vel: [f32; 3],
    ang_vel: [f32; 3],
    joint_pos: Vec<f32>,
}

#[derive(Deserialize)]
struct Record {
    t: f32,
    root_pos: [f64; 3],
    root_quat: [f64; 4],
    joint_pos: Vec<f64>,
}

/// Joint spring and damper gains of the MuJoCo model, by joint.
#[derive(Deserialize)]
struct Gains {
    stiffness: Vec<f32>,
    damping: Vec<f32>,
}

#[derive(Deserialize)]
struct Rollout {
    dt: f32,
    record_every: usize,
    joints: Vec<String>,
    initial: Initial,
    first_contact: f32,
    efforts: Vec<Vec<f32>>,
    records: Vec<Record>,
    #[serde(default)]
    gains: Option<Gains>,
}

/// Largest differences from MuJoCo over a span of the rollout.
#[derive(Clone, Copy, Debug, Default)]
pub struct StateError {
    /// Root position (m).
    pub root_pos: f64,
    /// Root orientation: angle of the relative rotation (rad).
    pub root_rot: f64,
    /// Joint positions (rad).
    pub joint_pos: f64,
}

impl StateError {
    fn max(self, other: Self) -> Self {
        Self {
            root_pos: self.root_pos.max(other.root_pos),
            root_rot: self.root_rot.max(other.root_rot),
            joint_pos: self.joint_pos.max(other.joint_pos),
        }
    }
}

/// Agreement with a MuJoCo rollout: before MuJoCo's first contact (free fall), and over the
/// whole rollout.
#[derive(Clone, Copy, Debug)]
pub struct FreeFallAgreement {
    /// Records before the first contact.
    pub records_before_contact: usize,
    /// Largest differences before the first contact.
    pub before_contact: StateError,
    /// Largest differences over the whole rollout.
    pub whole: StateError,
}

/// Replays MuJoCo's Ant rollout: the same initial state (tilted, moving, spinning), the same
/// joint torques every 2 ms step, on the ground plane. Prints and returns the agreement.
pub fn ant_mujoco_rollout(backend: &str) -> FreeFallAgreement {
    let data = include_str!("../data/mujoco_ant_rollout.json");
    replay_ant("ant", backend, data)
}

/// Replays an Ant rollout `data` on the bundled Ant over the ground plane.
fn replay_ant(name: &str, backend: &str, data: &str) -> FreeFallAgreement {
    let scene = on_ground(floating_ant(), 3.0);
    replay(name, backend, scene, data, Vec3::ZERO, GainsIn::Drives)
}

/// `robot` alone on the ground plane.
fn on_ground(robot: ArticulationCfg, env_spacing: f32) -> SceneDesc {
    resolve(&SceneCfg {
        env_spacing,
        articulations: vec![robot],
        rigid_objects: vec![],
        static_objects: vec![ground(1.0)],
    })
}

/// Replays MuJoCo's rollout of the Ant standing on the ground (joint armature 1, large against
/// its legs' inertias) under joint torques, in contact from its first step. Prints and returns
/// the agreement (all of it is `whole`).
pub fn ant_standing_mujoco_rollout(backend: &str) -> FreeFallAgreement {
    let data = include_str!("../data/mujoco_ant_standing_rollout.json");
    replay_ant("ant_standing", backend, data)
}

/// Asserts that the Ant stands as MuJoCo's does, within `tolerance` over the whole second of
/// the rollout, every record in contact with the ground.
pub fn ant_stands_like_mujoco(backend: &str, tolerance: StateError) {
    assert_within(ant_standing_mujoco_rollout(backend).whole, tolerance);
}

/// Replays MuJoCo's Humanoid rollout: the `humanoid` asset (its drives towards 0 are MuJoCo's
/// joint springs and dampers) from a tilted, moving, spinning start 2 m up, under joint
/// torques every 2 ms step, on the ground plane, with the robot moved by `offset` in its env
/// (MuJoCo's positions are compared moved by it). Prints and returns the agreement.
pub fn humanoid_mujoco_rollout(backend: &str, offset: Vec3) -> FreeFallAgreement {
    let file =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../orbit-assets/assets/scenes/humanoid.ron");
    let scene = orbit_assets::load_scene(&file, &[])
        .unwrap_or_else(|e| panic!("the humanoid scene does not resolve: {e}"));
    let data = include_str!("../data/mujoco_humanoid_rollout.json");
    replay("humanoid", backend, scene, data, offset, GainsIn::Drives)
}

/// Replays MuJoCo's Humanoid rollout on `tools/humanoid_standing.xml` imported as it is, on the
/// ground plane: its joint springs (`stiffness`) and dampers are the model's own, simulated as
/// MuJoCo does (the spring explicit, the damping implicit), and no drive acts. Prints and
/// returns the agreement.
pub fn humanoid_springs_mujoco_rollout(backend: &str) -> FreeFallAgreement {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/humanoid_standing.xml");
    let mut robot = floating_mjcf("humanoid", &file.display().to_string());
    robot.self_collisions = true;
    let scene = on_ground(robot, 5.0);
    let data = include_str!("../data/mujoco_humanoid_rollout.json");
    replay(
        "humanoid_springs",
        backend,
        scene,
        data,
        Vec3::ZERO,
        GainsIn::Joints,
    )
}

/// Where the model carries MuJoCo's joint springs and dampers.
#[derive(Clone, Copy, PartialEq)]
enum GainsIn {
    /// As drives towards 0 (Isaac Lab's implicit actuators).
    Drives,
    /// As the joints' own passive springs and damping (MuJoCo's).
    Joints,
}

/// Replays rollout `data` on the first articulation of `scene`, from the rollout's initial
/// state moved by `offset`.
fn replay(
    name: &str,
    backend: &str,
    mut scene: SceneDesc,
    data: &str,
    offset: Vec3,
    carried: GainsIn,
) -> FreeFallAgreement {
    let data: Rollout = serde_json::from_str(data).expect("rollout");
    let init = &data.initial;
    let robot = &mut scene.articulations[0];
    assert_eq!(
        robot.model.joint_names(),
        data.joints,
        "the {name}'s joints in MuJoCo's order"
    );
    let start = Vec3::from(init.root_pos) + offset;
    robot.root_pose = Pose::new(start, Quat::from_array(init.root_quat));
    robot.root_lin_vel = Vec3::from(init.lin_vel);
    robot.root_ang_vel = Vec3::from(init.ang_vel);
    robot.default_joint_pos = init.joint_pos.clone();
    if let Some(gains) = &data.gains {
        let joints = robot.model.dof_links().into_iter().map(|l| {
            let j = robot.model.links[l].joint.as_ref().expect("a dof's joint");
            (j.spring_stiffness, j.damping)
        });
        for ((d, drive), (spring, damping)) in robot.drives.iter().enumerate().zip(joints) {
            let carried = match carried {
                GainsIn::Drives => (drive.stiffness, drive.damping),
                GainsIn::Joints => (spring, damping),
            };
            assert_eq!(
                carried,
                (gains.stiffness[d], gains.damping[d]),
                "joint `{}`: the model's gains against MuJoCo's spring and damper",
                data.joints[d]
            );
        }
    }
    let mut sim = build(backend, &scene, 1, data.dt);
    // MuJoCo's springs pull towards 0, not towards the start.
    let zeros = vec![0.0; data.joints.len()];
    sim.set_joint_position_targets(0, &zeros).expect("targets");
    let mut agreement = FreeFallAgreement {
        records_before_contact: 0,
        before_contact: StateError::default(),
        whole: StateError::default(),
    };
    for (k, efforts) in data.efforts.iter().enumerate() {
        sim.set_joint_efforts(0, efforts).expect("efforts");
        sim.step().expect("step");
        if (k + 1) % data.record_every != 0 {
            continue;
        }
        let record = &data.records[(k + 1) / data.record_every - 1];
        let error = state_error(&*sim, record, offset);
        agreement.whole = agreement.whole.max(error);
        if record.t < data.first_contact {
            agreement.records_before_contact += 1;
            agreement.before_contact = agreement.before_contact.max(error);
        }
    }
    println!("{name}_mujoco_rollout[{backend}] at {offset}: {agreement:?}");
    agreement
}

fn state_error(sim: &dyn PhysicsBackend, record: &Record, offset: Vec3) -> StateError {
    let view = sim.articulation(0);
    let pos = view.link_pos[0].as_dvec3();
    let want = glam::DVec3::from(record.root_pos) + offset.as_dvec3();
    let want_rot = glam::DQuat::from_array(record.root_quat).normalize();
    // The relative rotation's angle from its sine and cosine halves: `acos` of a dot product
    // near 1 would lose half the digits.
    let rel = want_rot.inverse() * view.link_quat[0].as_dquat().normalize();
    let root_rot = 2.0 * rel.xyz().length().atan2(rel.w.abs());
    let joint_pos = view
        .joint_pos
        .iter()
        .zip(&record.joint_pos)
        .map(|(&q, &r)| (f64::from(q) - r).abs())
        .fold(0.0, f64::max);
    // A NaN is the largest difference, not one that `max` skips.
    let nan_as_inf = |x: f64| if x.is_nan() { f64::INFINITY } else { x };
    let joint_nan = view.joint_pos.iter().any(|q| q.is_nan());
    StateError {
        root_pos: nan_as_inf((pos - want).length()),
        root_rot: nan_as_inf(root_rot),
        joint_pos: if joint_nan { f64::INFINITY } else { joint_pos },
    }
}

/// Asserts the Ant's agreement with MuJoCo in free fall, before its first contact, within
/// `tolerance` (each backend states its own, with the reason; measured: docs/fidelity.md).
/// After landing the contact models differ (MuJoCo's geoms touch from 1 cm away), so the whole
/// rollout is reported, not asserted.
pub fn ant_tracks_mujoco_rollout(backend: &str, tolerance: StateError) {
    assert_agreement(ant_mujoco_rollout(backend), tolerance, 20);
}

/// Asserts the Humanoid's agreement with MuJoCo in free fall, before its first contact (self
/// contacts included), within `tolerance`; the whole rollout is reported, not asserted.
pub fn humanoid_tracks_mujoco_rollout(backend: &str, tolerance: StateError) {
    assert_agreement(humanoid_mujoco_rollout(backend, Vec3::ZERO), tolerance, 20);
}

/// Where a robot has walked to in its env does not change its dynamics: the Humanoid's MuJoCo
/// rollout, started 180 m from the env origin (a trained Humanoid runs 100 m and more in an
/// episode), agrees with MuJoCo before the first contact within the `tolerance` that holds at
/// the origin, the root's position within `tolerance.root_pos` plus 2e-4 m: positions are
/// f32, 1.5e-5 m apart at 180 m, and the fall's 235 steps round the root's position once
/// each.
pub fn humanoid_tracks_mujoco_rollout_far_from_origin(backend: &str, tolerance: StateError) {
    let offset = Vec3::new(150.0, -100.0, 0.0);
    let tolerance = StateError {
        root_pos: tolerance.root_pos + 2e-4,
        ..tolerance
    };
    assert_agreement(humanoid_mujoco_rollout(backend, offset), tolerance, 20);
}

/// Asserts that the Humanoid imported with MuJoCo's joint springs and dampers
/// (`tools/humanoid_standing.xml`) tracks MuJoCo's rollout before its first contact within
/// `tolerance`; the whole rollout is reported, not asserted.
pub fn humanoid_springs_track_mujoco_rollout(backend: &str, tolerance: StateError) {
    assert_agreement(humanoid_springs_mujoco_rollout(backend), tolerance, 20);
}

/// Asserts `a` within `tolerance` over at least `records` records before the first contact.
fn assert_agreement(a: FreeFallAgreement, tolerance: StateError, records: usize) {
    assert!(
        a.records_before_contact >= records,
        "the fall spans {records} records"
    );
    assert_within(a.before_contact, tolerance);
}

/// Asserts each of `e`'s differences within `tol`'s.
fn assert_within(e: StateError, tol: StateError) {
    assert!(
        e.root_pos <= tol.root_pos,
        "root position off by {} m (tolerance {})",
        e.root_pos,
        tol.root_pos
    );
    assert!(
        e.root_rot <= tol.root_rot,
        "root orientation off by {} rad (tolerance {})",
        e.root_rot,
        tol.root_rot
    );
    assert!(
        e.joint_pos <= tol.joint_pos,
        "joint positions off by {} rad (tolerance {})",
        e.joint_pos,
        tol.joint_pos
    );
}
