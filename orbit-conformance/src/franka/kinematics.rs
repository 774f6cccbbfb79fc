//! Forward kinematics of the Franka against MuJoCo's (`data/franka_fk_vectors.json`).

use std::collections::BTreeMap;

use glam::Vec3;
use orbit_core::math::{Pose, quat_wxyz, rotation_distance};
use orbit_core::physics::PhysicsBackend;
use serde::Deserialize;

use super::box_pushing_scene_cfg;
use crate::scenes::{build, resolve};

#[derive(Deserialize)]
struct BodyPose {
    xpos: [f32; 3],
    xquat_wxyz: [f32; 4],
}

#[derive(Deserialize)]
struct FkVector {
    q: Vec<f32>,
    bodies: BTreeMap<String, BodyPose>,
    rod_tip_site_xpos: [f32; 3],
}

#[derive(Deserialize)]
struct FkFile {
    fk_test_vectors: BTreeMap<String, FkVector>,
}

/// World pose of a named frame of articulation 0 in env `e`, from the backend's link poses.
pub fn frame_pose(sim: &dyn PhysicsBackend, e: usize, frame: &str) -> Pose {
    let layout = &sim.layout().articulations[0];
    let (link, offset) = layout
        .model
        .find_frame(frame)
        .unwrap_or_else(|| panic!("frame `{frame}` not in the model"));
    sim.articulation(0).frame_pose(e, link, &offset)
}

/// After writing the FK test configurations, every body origin is within 1e-4 m and every body
/// orientation within 1e-4 rad of MuJoCo's, and so is the rod-tip site.
pub fn franka_forward_kinematics(backend: &str) {
    let file: FkFile =
        serde_json::from_str(include_str!("../../data/franka_fk_vectors.json")).expect("fk data");
    let scene = resolve(&box_pushing_scene_cfg());
    let n = file.fk_test_vectors.len();
    let mut sim = build(backend, &scene, n, 0.002);
    let ids: Vec<usize> = (0..n).collect();
    let q: Vec<f32> = file
        .fk_test_vectors
        .values()
        .flat_map(|v| v.q.clone())
        .collect();
    sim.write_joint_state(0, &ids, &q, &vec![0.0; q.len()])
        .expect("write joint state");
    let (mut worst_pos, mut worst_rot) = (0.0f32, 0.0f32);
    for (e, (name, vector)) in file.fk_test_vectors.iter().enumerate() {
        for (body, expected) in &vector.bodies {
            let got = frame_pose(sim.as_ref(), e, body);
            let dp = (got.pos - Vec3::from(expected.xpos)).length();
            let dr = rotation_distance(got.rot, quat_wxyz(expected.xquat_wxyz));
            worst_pos = worst_pos.max(dp);
            worst_rot = worst_rot.max(dr);
            assert!(dp < 1e-4, "{name}: `{body}` position off by {dp} m");
            assert!(dr < 1e-4, "{name}: `{body}` orientation off by {dr} rad");
        }
        let tip = frame_pose(sim.as_ref(), e, "rod_tip").pos;
        let dp = (tip - Vec3::from(vector.rod_tip_site_xpos)).length();
        worst_pos = worst_pos.max(dp);
        assert!(dp < 1e-4, "{name}: rod tip off by {dp} m");
    }
    println!(
        "franka_forward_kinematics[{backend}]: worst position error {worst_pos:.2e} m, worst orientation error {worst_rot:.2e} rad"
    );
}
