//! Agreement with a MuJoCo rollout of the Ant under open-loop joint torques
//! (`data/mujoco_ant_rollout.json`, written by `tools/mujoco_ant_rollout.py`): a floating base
//! in free fall, then landing.

use glam::{Quat, Vec3};
use orbit_core::physics::PhysicsBackend;
use orbit_core::scene::SceneCfg;
use serde::Deserialize;

use crate::scenes::{build, floating_ant, ground, resolve};

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

#[derive(Deserialize)]
struct AntRollout {
    dt: f32,
    record_every: usize,
    joints: Vec<String>,
    initial: Initial,
    first_contact: f32,
    efforts: Vec<Vec<f32>>,
    records: Vec<Record>,
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

/// The Ant's agreement with MuJoCo: before a foot first comes within MuJoCo's contact margin
/// (free fall, 0.29 s), and over the whole second.
#[derive(Clone, Copy, Debug)]
pub struct AntAgreement {
    /// Records before the first contact.
    pub records_before_contact: usize,
    /// Largest differences before the first contact.
    pub before_contact: StateError,
    /// Largest differences over the whole rollout.
    pub whole: StateError,
}

/// Replays MuJoCo's Ant rollout: the same initial state (tilted, moving, spinning), the same
/// joint torques every 2 ms step, on the ground plane. Prints and returns the agreement.
pub fn ant_mujoco_rollout(backend: &str) -> AntAgreement {
    let data: AntRollout =
        serde_json::from_str(include_str!("../data/mujoco_ant_rollout.json")).expect("rollout");
    let mut ant = floating_ant();
    let init = &data.initial;
    ant.init_state.pos = Vec3::from(init.root_pos);
    ant.init_state.rot = Quat::from_array(init.root_quat);
    ant.init_state.lin_vel = Vec3::from(init.lin_vel);
    ant.init_state.ang_vel = Vec3::from(init.ang_vel);
    ant.init_state.joint_pos = data
        .joints
        .iter()
        .zip(&init.joint_pos)
        .map(|(name, &q)| (format!("^{name}$"), q))
        .collect();
    let cfg = SceneCfg {
        env_spacing: 3.0,
        articulations: vec![ant],
        rigid_objects: vec![],
        static_objects: vec![ground(1.0)],
    };
    let desc = resolve(&cfg);
    assert_eq!(
        desc.articulations[0].model.joint_names(),
        data.joints,
        "the Ant's joints in MuJoCo's order"
    );
    let mut sim = build(backend, &desc, 1, data.dt);
    let mut agreement = AntAgreement {
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
        let error = state_error(&*sim, record);
        agreement.whole = agreement.whole.max(error);
        if record.t < data.first_contact {
            agreement.records_before_contact += 1;
            agreement.before_contact = agreement.before_contact.max(error);
        }
    }
    println!("ant_mujoco_rollout[{backend}]: {agreement:?}");
    agreement
}

fn state_error(sim: &dyn PhysicsBackend, record: &Record) -> StateError {
    let view = sim.articulation(0);
    let pos = view.link_pos[0].as_dvec3();
    let want = glam::DVec3::from(record.root_pos);
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
    StateError {
        root_pos: (pos - want).length(),
        root_rot,
        joint_pos,
    }
}

/// Asserts the Ant's agreement with MuJoCo in free fall, before its first contact, within
/// `tolerance` (each backend states its own, with the reason; measured: docs/fidelity.md).
/// After landing the contact models differ (MuJoCo's geoms touch from 1 cm away), so the whole
/// rollout is reported, not asserted.
pub fn ant_tracks_mujoco_rollout(backend: &str, tolerance: StateError) {
    let a = ant_mujoco_rollout(backend);
    assert!(a.records_before_contact >= 20, "the fall spans 0.2 s");
    let (e, tol) = (a.before_contact, tolerance);
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
