//! The bundled Franka (`franka_panda_rod.urdf`) and box-pushing scene against the MuJoCo
//! reference data in `tests/data/franka_reference.json` (Fancy Gym's `panda_rod.xml` and
//! `push_box.xml` compiled with MuJoCo 2.3.3; the same numbers as
//! `tools/franka_box_pushing_params.json`).

use glam::{Quat, Vec3};
use orbit_assets::{asset_cfg, asset_cfgs, box_pushing_scene_cfg, load_model, model_loader};
use orbit_core::kinematics::ArticulationKinematics;
use orbit_core::math::{Pose, quat_wxyz};
use orbit_core::scene::{ArticulationModel, AssetSource, Geometry, JointKind, Shape};
use serde_json::Value;

fn reference() -> Value {
    serde_json::from_str(include_str!("data/franka_reference.json")).expect("reference JSON")
}

fn franka() -> ArticulationModel {
    load_model(
        &AssetSource::Urdf {
            path: "franka_panda_rod.urdf".into(),
            skip_mesh_collisions: false,
        },
        None,
    )
    .expect("bundled Franka loads")
}

fn f32s(v: &Value) -> Vec<f32> {
    v.as_array()
        .expect("array")
        .iter()
        .map(|x| x.as_f64().expect("number") as f32)
        .collect()
}

fn vec3(v: &Value) -> Vec3 {
    Vec3::from_slice(&f32s(v))
}

/// Angle between two orientations, accurate for small angles (unlike `2 acos |<a, b>|` in f32).
fn angle(a: Quat, b: Quat) -> f32 {
    let d = a.conjugate() * b;
    2.0 * Vec3::new(d.x, d.y, d.z).length().atan2(d.w.abs())
}

const ARM: [&str; 7] = [
    "panda_joint1",
    "panda_joint2",
    "panda_joint3",
    "panda_joint4",
    "panda_joint5",
    "panda_joint6",
    "panda_joint7",
];

#[test]
fn structure_joints_and_limits() {
    let model = franka();
    assert_eq!(model.links[0].name, "panda_link0");
    let merged = model.merge_fixed_joints();
    assert_eq!(merged.joint_names(), ARM);
    assert_eq!(merged.links.len(), 8, "fixed links merge into panda_link7");
    #[allow(clippy::approx_constant)] // -3.1416 is the XML's value, not π
    let xml_ranges = [
        [-2.9671, 2.9671],
        [-1.8326, 1.8326],
        [-2.9671, 2.9671],
        [-3.1416, 0.0873],
        [-2.9671, 2.9671],
        [-0.0873, 3.8223],
        [-2.9671, 2.9671],
    ];
    let effort = [87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0];
    let velocity = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61];
    for (d, &li) in merged.dof_links().iter().enumerate() {
        let j = merged.links[li].joint.as_ref().unwrap();
        assert_eq!(j.kind, JointKind::Revolute);
        assert_eq!(j.axis, Vec3::Z);
        assert_eq!(j.limits, Some(xml_ranges[d]));
        assert_eq!(j.effort_limit, Some(effort[d]));
        assert_eq!(j.velocity_limit, Some(velocity[d]));
        assert_eq!((j.damping, j.friction, j.armature), (0.0, 0.0, 0.0));
    }
    for frame in [
        "panda_link8",
        "panda_hand",
        "push_rod",
        "tcp",
        "rod_tip",
        "panda_leftfinger",
        "panda_rightfinger",
        "finger_joint1_tip",
        "finger_joint2_tip",
    ] {
        let (link, _) = merged.find_frame(frame).unwrap();
        assert_eq!(merged.links[link].name, "panda_link7", "{frame}");
    }
}

/// FK of every MuJoCo body and the rod_tip site for the three reference configurations:
/// positions within 1e-4 m, orientations within 1e-4 rad.
#[test]
fn forward_kinematics_matches_mujoco() {
    let reference = reference();
    let merged = franka().merge_fixed_joints();
    let mut kin = ArticulationKinematics::new(&merged);
    let (mut max_pos, mut max_rot) = (0.0f32, 0.0f32);
    let cases = reference["fk_test_vectors"].as_object().unwrap();
    assert_eq!(cases.len(), 3);
    for (case, data) in cases {
        let q = f32s(&data["q"]);
        kin.forward(&Pose::IDENTITY, &q);
        let bodies = data["bodies"].as_object().unwrap();
        assert_eq!(bodies.len(), 12);
        for (body, want) in bodies {
            let (link, offset) = merged
                .find_frame(body)
                .unwrap_or_else(|| panic!("no frame {body}"));
            let pose = kin.frame_pose(link, &offset);
            let pos_err = (pose.pos - vec3(&want["xpos"])).length();
            let w = f32s(&want["xquat_wxyz"]);
            let rot_err = angle(pose.rot, quat_wxyz([w[0], w[1], w[2], w[3]]));
            assert!(pos_err < 1e-4, "{case} {body}: position error {pos_err} m");
            assert!(
                rot_err < 1e-4,
                "{case} {body}: orientation error {rot_err} rad"
            );
            max_pos = max_pos.max(pos_err);
            max_rot = max_rot.max(rot_err);
        }
        let (link, offset) = merged.find_frame("rod_tip").unwrap();
        let tip = kin.frame_pose(link, &offset).pos;
        let err = (tip - vec3(&data["rod_tip_site_xpos"])).length();
        assert!(err < 1e-4, "{case} rod_tip: position error {err} m");
        max_pos = max_pos.max(err);
    }
    println!("FK: max position error {max_pos:e} m, max orientation error {max_rot:e} rad");
}

/// Gravity torques at rest (RNE with q̇ = 0) against MuJoCo's `qfrc_bias`, within 1e-4 N·m.
///
/// Measured maximum error: about 1e-5 N·m, i.e. f32 round-off (the reference is printed to
/// 1e-6 N·m). Welding the fingers costs nothing here: at rest MuJoCo's RNE runs with zero joint
/// accelerations, so its slide-jointed fingers load the hand exactly like welded ones, and the
/// 1.22 mm opening moves both fingers symmetrically, leaving their common COM in place.
#[test]
fn gravity_torques_match_mujoco() {
    let reference = reference();
    let merged = franka().merge_fixed_joints();
    let mut kin = ArticulationKinematics::new(&merged);
    let gravity = vec3(&reference["gravity"]);
    let mut max_err = 0.0f32;
    for (case, data) in reference["fk_test_vectors"].as_object().unwrap() {
        let q = f32s(&data["q"]);
        let want = f32s(&data["qfrc_bias_arm_at_rest"]);
        let mut tau = [0.0f32; 7];
        kin.bias_forces(
            &Pose::IDENTITY,
            Vec3::ZERO,
            &q,
            &[0.0; 7],
            gravity,
            &mut tau,
        );
        for d in 0..7 {
            let err = (tau[d] - want[d]).abs();
            max_err = max_err.max(err);
            assert!(
                err < 1e-4,
                "{case} joint {}: bias {} vs MuJoCo {} (error {err} N m)",
                d + 1,
                tau[d],
                want[d]
            );
        }
    }
    println!("bias forces at rest: max error {max_err:e} N m");
}

/// Total mass of the merged model equals the MuJoCo bodies' masses (arm, hand, rod, fingers,
/// finger tips) within 1e-5 kg.
#[test]
fn total_mass_matches() {
    let reference = reference();
    let want: f64 = reference["body_masses"]
        .as_object()
        .unwrap()
        .values()
        .map(|m| m.as_f64().unwrap())
        .sum();
    let merged = franka().merge_fixed_joints();
    let got: f64 = merged.links.iter().map(|l| l.inertial.mass as f64).sum();
    assert!((got - want).abs() < 1e-5, "mass {got} vs {want}");
}

/// Distance by which a point (link frame) lies outside a shape (negative inside).
fn outside(shape: &Shape, p: Vec3) -> f32 {
    let local = shape.pose.inverse().transform_point(p);
    match shape.geometry {
        Geometry::Capsule {
            radius,
            half_length,
        } => {
            let z = local.z.clamp(-half_length, half_length);
            (local - Vec3::new(0.0, 0.0, z)).length() - radius
        }
        Geometry::Box { half_extents } => {
            let d = local.abs() - half_extents;
            d.max(Vec3::ZERO).length() + d.max_element().min(0.0)
        }
        other => panic!("unexpected shape {other:?}"),
    }
}

/// Arm collision capsules against the MuJoCo collision hulls: the capsule union's volume
/// (Monte Carlo, 200k samples, ~1 % noise) is within [0.85, 1.2] of the hull volume and no hull
/// vertex lies more than 20 mm outside the union (40 mm for the static base link0). The finger
/// boxes contain the finger hull (within 0.1 mm: the hull points are rounded to 0.1 mm, the
/// boxes are the exact AABB).
#[test]
fn collision_primitives_fit_the_hulls() {
    let reference = reference();
    let model = franka();
    let link = |name: &str| model.links.iter().find(|l| l.name == name).unwrap();
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    for (mesh, hull) in reference["collision_hulls"].as_object().unwrap() {
        let points: Vec<Vec3> = hull["decimated_hull_points"]
            .as_array()
            .unwrap()
            .iter()
            .map(vec3)
            .collect();
        let shapes = &link(hull["link"].as_str().unwrap()).shapes;
        if mesh == "fingerv" {
            let left = &link("panda_leftfinger").shapes;
            let right = &link("panda_rightfinger").shapes;
            assert_eq!((left.len(), right.len()), (1, 1));
            for p in &points {
                assert!(outside(&left[0], *p) < 1e-4, "left finger misses {p}");
                // The right finger's mesh is rotated 180° about z.
                let q = Vec3::new(-p.x, -p.y, p.z);
                assert!(outside(&right[0], q) < 1e-4, "right finger misses {q}");
            }
            continue;
        }
        assert!(
            (1..=2).contains(&shapes.len()),
            "{mesh}: {} shapes",
            shapes.len()
        );
        let inside_union = |p: Vec3| {
            shapes
                .iter()
                .map(|s| outside(s, p))
                .fold(f32::MAX, f32::min)
        };
        let worst = points
            .iter()
            .map(|&p| inside_union(p))
            .fold(f32::MIN, f32::max);
        // The base link's rear corner (cable connector, resting on the mount) sticks out most.
        let allowed = if mesh == "link0v" { 0.04 } else { 0.02 };
        assert!(
            worst < allowed,
            "{mesh}: a hull vertex is {worst} m outside"
        );
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for p in &points {
            lo = lo.min(*p - 0.08);
            hi = hi.max(*p + 0.08);
        }
        let n = 200_000;
        let hits = (0..n)
            .filter(|_| {
                let u = Vec3::new(uniform(), uniform(), uniform());
                inside_union(lo + u * (hi - lo)) <= 0.0
            })
            .count();
        let union = hits as f64 / n as f64 * ((hi - lo).x * (hi - lo).y * (hi - lo).z) as f64;
        let ratio = union / hull["hull_volume_m3"].as_f64().unwrap();
        println!(
            "{mesh}: {} capsule(s), union/hull volume {ratio:.3}, farthest vertex {:.1} mm outside",
            shapes.len(),
            worst * 1000.0
        );
        assert!(
            (0.85..1.2).contains(&ratio),
            "{mesh}: union/hull volume {ratio}"
        );
    }
}

/// The bundled scene is its registered asset configs under the scene's names, in the scene's
/// order; overrides apply to the composed scene.
#[test]
fn bundled_scene_is_composed_of_the_asset_configs() {
    fn asset<T: serde::de::DeserializeOwned>(asset: &str, name: &str) -> T {
        let def = asset_cfg(asset).unwrap_or_else(|| panic!("`{asset}` is registered"));
        orbit_core::config::from_str(def.config, def.file, &[format!("name={name:?}")]).unwrap()
    }
    let cfg = box_pushing_scene_cfg(&[]).expect("scene loads through orbit_core::config");
    assert_eq!(cfg.env_spacing, 2.5);
    assert_eq!(cfg.articulations, [asset("franka_panda_rod", "robot")]);
    assert_eq!(cfg.rigid_objects, [asset("push_box", "box")]);
    assert_eq!(
        cfg.static_objects,
        [
            asset("lab_table", "table"),
            asset("franka_mount", "robot_mount")
        ]
    );
    let names: Vec<&str> = asset_cfgs().iter().map(|a| a.name).collect();
    assert_eq!(
        names,
        [
            "ant",
            "cartpole",
            "franka_mount",
            "franka_panda_rod",
            "ground_plane",
            "humanoid",
            "lab_table",
            "push_box"
        ]
    );
    let changed =
        box_pushing_scene_cfg(&["articulations[0].actuators.arm.stiffness=400.0".into()]).unwrap();
    assert_eq!(
        changed.articulations[0].actuators["arm"].stiffness,
        orbit_core::scene::PerJoint::All(400.0)
    );
    let err = box_pushing_scene_cfg(&["articulations[3].name=\"x\"".into()]);
    assert!(err.is_err());
}

/// The bundled scene resolves with the bundled Franka; its numbers are MuJoCo's.
#[test]
fn bundled_scene_resolves() {
    let reference = reference();
    let cfg = box_pushing_scene_cfg(&[]).unwrap();
    let scene = cfg.resolve(&model_loader(None)).expect("scene resolves");

    let robot = &scene.articulations[0];
    assert_eq!(robot.name, "robot");
    let q0 = f32s(&reference["initial_qpos_default_init_arm"]);
    assert_eq!(robot.default_joint_pos, q0);
    let efforts: Vec<f32> = robot.drives.iter().map(|d| d.effort_limit).collect();
    assert_eq!(efforts, [87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0]);
    assert!(
        robot
            .drives
            .iter()
            .all(|d| d.stiffness == 0.0 && d.damping == 0.0)
    );

    // Box mass properties equal MuJoCo's (computed from the five uniform boxes).
    let object = &scene.rigid_objects[0];
    assert_eq!(object.name, "box");
    let box_ref = &reference["box"];
    let inertial = object.body.inertial;
    assert!((inertial.mass as f64 - box_ref["mass_total"].as_f64().unwrap()).abs() < 1e-6);
    assert!((inertial.com - vec3(&box_ref["com_in_box_frame"])).length() < 1e-7);
    for (r, row) in box_ref["inertia_full_in_box_frame"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
    {
        for (c, want) in f32s(row).iter().enumerate() {
            let got = inertial.inertia.col(c)[r];
            assert!(
                (got - want).abs() < 1e-8,
                "box inertia [{r}][{c}] {got} vs {want}"
            );
        }
    }
    let frictions: Vec<f32> = object
        .body
        .shapes
        .iter()
        .map(|s| s.material.friction)
        .collect();
    assert_eq!(frictions, [0.3, 1.0, 1.0, 1.0, 1.0]);
    let init = object.default_root_state.pose;
    assert_eq!(init.pos, Vec3::new(0.4, 0.3, -0.01));
    assert!(angle(init.rot, Quat::from_rotation_z(std::f32::consts::PI)) < 1e-6);

    // Static fixtures; the mount and link0 never collide, both collide with the rest.
    let names: Vec<&str> = scene
        .static_objects
        .iter()
        .map(|s| s.name.as_str())
        .collect();
    assert_eq!(names, ["table", "robot_mount"]);
    let table = &scene.static_objects[0];
    let top = table.pose.pos.z + table.body.shapes[0].pose.pos.z + 0.001;
    assert!((top - -0.019).abs() < 1e-6, "table top at {top}");
    let mount = &scene.static_objects[1].body.shapes[0].filter;
    let link0 = &robot.model.links[0];
    assert_eq!(link0.name, "panda_link0");
    assert!(!link0.shapes.is_empty());
    for s in &link0.shapes {
        assert!(!s.filter.allows(mount));
        assert!(s.filter.allows(&table.body.shapes[0].filter));
        assert!(s.filter.allows(&object.body.shapes[0].filter));
    }
    for l in &robot.model.links[1..] {
        for s in &l.shapes {
            assert!(s.filter.allows(mount), "{} must touch the mount", l.name);
        }
    }
}
