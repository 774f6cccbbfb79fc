//! MJCF import against MuJoCo: the shipped Ant's and Humanoid's and a several-joint body's masses,
//! inertias and forward kinematics agree with MuJoCo's compiled models
//! (`tests/data/*_mujoco_reference.json`, written by `tools/mjcf_reference.py`), and malformed
//! documents are errors naming element, attribute and line.

use std::path::Path;

use glam::{Quat, Vec3};
use orbit_assets::{MjcfModel, model_from_mjcf_file, model_from_mjcf_str};
use orbit_core::kinematics::ArticulationKinematics;
use orbit_core::math::{Pose, quat_wxyz, rotation_distance};
use orbit_core::scene::{CollisionFilter, Geometry};
use serde_json::Value;

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(name)
}

fn ant() -> MjcfModel {
    model_from_mjcf_file(&data("assets/ant.xml")).unwrap()
}

fn reference(name: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(data(name)).unwrap()).unwrap()
}

fn f32s(v: &Value) -> Vec<f32> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap() as f32)
        .collect()
}

fn vec3(v: &Value) -> Vec3 {
    Vec3::from_slice(&f32s(v))
}

fn quat(v: &Value) -> Quat {
    let q = f32s(v);
    quat_wxyz([q[0], q[1], q[2], q[3]])
}

/// Every MuJoCo body of `reference` against the imported `model`: its mass (relative 1e-6) and
/// inertia tensor about its centre (1e-6 of its largest entry; a link has its body's axes),
/// and its world pose and centre of mass (1e-5 m, 1e-5 rad) at the reference configuration and
/// at the moved one.
fn check_against_mujoco(model: &MjcfModel, reference: &Value) {
    let articulation = &model.articulation;
    let link = |name: &str| {
        let i = articulation.link_index(name);
        i.unwrap_or_else(|| panic!("no link `{name}`"))
    };
    for (name, want) in reference["bodies"].as_object().unwrap() {
        let inertial = &articulation.links[link(name)].inertial;
        let mass = want["mass"].as_f64().unwrap() as f32;
        assert!(
            (inertial.mass - mass).abs() <= 1e-6 * mass,
            "{name}: mass {} against {mass}",
            inertial.mass
        );
        let rows: Vec<Vec<f32>> = want["inertia"]
            .as_array()
            .unwrap()
            .iter()
            .map(f32s)
            .collect();
        let scale = rows.iter().flatten().fold(0.0f32, |m, v| m.max(v.abs()));
        for (r, row) in rows.iter().enumerate() {
            for (c, &v) in row.iter().enumerate() {
                let got = inertial.inertia.col(c)[r];
                assert!(
                    (got - v).abs() <= 1e-6 * scale,
                    "{name}: inertia[{r}][{c}] {got} against {v}"
                );
            }
        }
    }
    let mut kin = ArticulationKinematics::new(articulation);
    let moved = &reference["moved"];
    let q: Vec<f32> = (articulation.joint_names().iter())
        .map(|j| moved["joints"][j].as_f64().unwrap() as f32)
        .collect();
    let root = match moved["root"].is_null() {
        true => model.root_pose,
        false => Pose::new(vec3(&moved["root"]["pos"]), quat(&moved["root"]["quat"])),
    };
    let cases = [
        (
            model.root_pose,
            vec![0.0; q.len()],
            &reference["reference_poses"],
        ),
        (root, q, &moved["poses"]),
    ];
    for (root, q, poses) in cases {
        let links = kin.forward(&root, &q).to_vec();
        for (name, want) in poses.as_object().unwrap() {
            let i = link(name);
            let pose = links[i];
            let com = pose.transform_point(articulation.links[i].inertial.com);
            let com_err = (com - vec3(&want["com"])).length();
            let rot_err = rotation_distance(pose.rot, quat(&want["quat"]));
            assert!(com_err < 1e-5, "{name}: centre of mass off by {com_err} m");
            assert!(rot_err < 1e-5, "{name}: orientation off by {rot_err} rad");
        }
    }
}

/// The Ant's bodies agree with MuJoCo's compiled model: masses and inertias computed from the
/// capsules and the sphere at density 5, poses with the free joint moved and turned and every
/// hinge in its range.
#[test]
fn ant_matches_mujoco() {
    let model = ant();
    let reference = reference("tests/data/ant_mujoco_reference.json");
    assert_eq!(
        model.articulation.links.len(),
        reference["bodies"].as_object().unwrap().len()
    );
    check_against_mujoco(&model, &reference);
}

/// Isaac Gym's Humanoid agrees with MuJoCo: its 16 bodies' masses and inertias from capsules
/// and spheres at density 1000, poses with the free joint moved and turned and every hinge in
/// its range (bodies with two or three joints composed in file order); 21 joints in MuJoCo's
/// order.
#[test]
fn humanoid_matches_mujoco() {
    let model = model_from_mjcf_file(&data("assets/isaac_humanoid.xml")).unwrap();
    assert!(model.floating_base);
    let names = model.articulation.joint_names();
    assert_eq!(names.len(), 21);
    assert_eq!(
        &names[..4],
        ["abdomen_z", "abdomen_y", "abdomen_x", "right_hip_x"]
    );
    let reference = reference("tests/data/isaac_humanoid_mujoco_reference.json");
    assert_eq!(reference["bodies"].as_object().unwrap().len(), 16);
    check_against_mujoco(&model, &reference);
}

/// A body moved by three joints (two hinges at different points, then a slide) and a child
/// on an offset hinge agree with MuJoCo, which composes a body's joints in file order.
#[test]
fn bodies_with_several_joints_match_mujoco() {
    let model = model_from_mjcf_file(&data("tests/data/multi_joint.xml")).unwrap();
    assert!(!model.floating_base);
    assert_eq!(
        model.articulation.joint_names(),
        ["swing", "lift", "reach", "elbow"]
    );
    check_against_mujoco(
        &model,
        &reference("tests/data/multi_joint_mujoco_reference.json"),
    );
}

/// The Ant's floating base, joints, motors and contacts as the file declares them: hinge
/// ranges in radians, the default class's armature and damping, legs that touch the floor but
/// not each other (MuJoCo's contype/conaffinity rule).
#[test]
fn ant_structure_follows_the_file() {
    let model = ant();
    assert!(model.floating_base);
    assert_eq!(model.root_pose.pos, Vec3::new(0.0, 0.0, 0.75));
    let a = &model.articulation;
    let names = a.joint_names();
    assert_eq!(names.len(), 8);
    assert_eq!(&names[..2], ["hip_1", "ankle_1"]);
    let joint = |name: &str| {
        (a.links.iter())
            .filter_map(|l| l.joint.as_ref())
            .find(|j| j.name == name)
            .unwrap()
    };
    let hip = joint("hip_1");
    let limits = hip.limits.unwrap();
    assert!((limits[1] - 30f32.to_radians()).abs() < 1e-6);
    assert_eq!((hip.armature, hip.damping), (1.0, 1.0));
    let ankle = joint("ankle_1");
    assert!((ankle.axis - Vec3::new(-1.0, 1.0, 0.0).normalize()).length() < 1e-6);
    assert_eq!(model.actuators.len(), 8);
    assert!(
        model
            .actuators
            .iter()
            .all(|m| m.gear == 150.0 && m.ctrl_range == Some([-1.0, 1.0]))
    );
    let floor = &model.world_shapes[0];
    assert_eq!(floor.geometry, Geometry::Plane);
    let leg = &a.links[a.link_index("front_left_foot").unwrap()].shapes[0];
    let other = &a.links[a.link_index("back_right_foot").unwrap()].shapes[0];
    assert!(leg.filter.allows(&floor.filter));
    assert!(!leg.filter.allows(&other.filter));
    // A scene's own ground (the default filter) is a default MuJoCo geom: the legs touch it.
    assert!(leg.filter.allows(&CollisionFilter::default()));
    match leg.geometry {
        Geometry::Capsule {
            radius,
            half_length,
        } => {
            assert_eq!(radius, 0.08);
            assert!((half_length - 0.4 * 2f32.sqrt() / 2.0).abs() < 1e-6);
        }
        other => panic!("the foot is a {other:?}"),
    }
}

/// Malformed or unsupported documents fail with the line, the element and the attribute.
#[test]
fn malformed_documents_name_line_element_and_attribute() {
    let body = |inner: &str| {
        format!(
            "<mujoco>\n<worldbody>\n<body name=\"b\">\n<freejoint/>\n<geom size=\"0.1\"/>\n\
             <body name=\"c\">\n{inner}\n</body>\n</body>\n</worldbody>\n</mujoco>"
        )
    };
    let cases = [
        (
            body("<joint type=\"ball\"/>"),
            "test.xml:7: <joint> attribute `type`: `ball` joints are not supported",
        ),
        (
            body("<geom type=\"capsule\" size=\"0.1 x\"/>"),
            "test.xml:7: <geom> attribute `size`: `x` is not a finite number",
        ),
        (
            body("<geom type=\"ellipsoid\" size=\"0.1 0.1 0.1\"/>"),
            "test.xml:7: <geom> attribute `type`: `ellipsoid` is not supported",
        ),
        (
            body("<geom type=\"sphere\" size=\"-0.1\"/>"),
            "test.xml:7: <geom> attribute `size`: -0.1 must be positive",
        ),
        (
            body("<joint stiffness=\"-20\"/><geom size=\"0.1\"/>"),
            "test.xml:7: <joint> attribute `stiffness`: -20 must be >= 0",
        ),
        (
            "<mujoco>\n<worldbody>\n<body>\n<geom size=\"1\"/>\n</body>\n</worldbody>\n\
             <actuator>\n<general joint=\"j\" biastype=\"affine\"/>\n</actuator>\n</mujoco>"
                .to_string(),
            "test.xml:8: <general> attribute `biastype`: not an attribute",
        ),
        (
            body("<joint range=\"30 10\"/><geom size=\"0.1\"/>"),
            "test.xml:7: <joint> attribute `range`: the lower end 30 is above the upper end 10",
        ),
        (
            "<mujoco>\n<worldbody>\n<body>\n<freejoint/>\n<joint/>\n<geom size=\"1\"/>\n</body>\n\
             </worldbody>\n</mujoco>"
                .to_string(),
            "test.xml:4: <freejoint>: body `body0`: a free joint must be the body's only joint",
        ),
        (
            body("<freejoint/><geom size=\"0.1\"/>"),
            "only the top-level body may have a free joint",
        ),
        (
            body("<geom class=\"nope\" size=\"0.1\"/>"),
            "test.xml:7: <geom> attribute `class`: class `nope` is not defined",
        ),
        (
            body("<geom size=\"0.1\" fromto=\"0 0 0 1 1\"/>"),
            "<geom> attribute `fromto`: `0 0 0 1 1` has 5 numbers; 6 are expected",
        ),
        (
            body("<inertial mass=\"-1\" diaginertia=\"1 1 1\"/>"),
            "<inertial> attribute `mass`: -1 must be >= 0",
        ),
        (
            "<mujoco>\n<worldbody>\n<body>\n<joint type=\"hinge\"/>\n<geom size=\"1\"/>\n</body>\n\
             </worldbody>\n</mujoco>"
                .to_string(),
            "test.xml:4: <joint>: body `body0` is a top-level body",
        ),
        (
            "<mujoco>\n<worldbody>\n<body>\n<geom size=\"1\"/>\n</body>\n</worldbody>\n<actuator>\n\
             <motor joint=\"missing\"/>\n</actuator>\n</mujoco>"
                .to_string(),
            "test.xml:8: <motor> attribute `joint`: no hinge or slide joint is named `missing`",
        ),
        (
            body("<geom size=\"0.1\" densty=\"300\"/>"),
            "test.xml:7: <geom> attribute `densty`: not an attribute the importer takes on \
             `<geom>`; it takes",
        ),
        (
            body("<joint ref=\"0.5\"/><geom size=\"0.1\"/>"),
            "test.xml:7: <joint> attribute `ref`: not an attribute the importer takes",
        ),
        (
            "<mujoco>\n<default>\n<default class=\"leg\">\n<geom densty=\"3\"/>\n</default>\n\
             </default>\n<worldbody>\n<body>\n<geom size=\"1\"/>\n</body>\n</worldbody>\n</mujoco>"
                .to_string(),
            "test.xml:4: <geom> attribute `densty`: not an attribute",
        ),
        (
            "<mujoco>\n<compiler angel=\"radian\"/>\n<worldbody>\n<body>\n<geom size=\"1\"/>\n\
             </body>\n</worldbody>\n</mujoco>"
                .to_string(),
            "test.xml:2: <compiler> attribute `angel`: not an attribute",
        ),
        (
            "<mujoco>\n<worldbody>\n<body>\n<geom size=\"1\"/>\n</body>\n</worldbody>\n\
             <actuator>\n<motor joint=\"j\" forcerange=\"-1 1\"/>\n</actuator>\n</mujoco>"
                .to_string(),
            "test.xml:8: <motor> attribute `forcerange`: not an attribute",
        ),
        (
            "<mujoco>\n<worldbody>\n<body>\n<geom size=\"1\"\n</body>".to_string(),
            "test.xml:4: not well-formed XML: <geom>:",
        ),
        (
            "<mujoco>\n<worldbody>\n<body>\n<geom size=\"1\"/>\n</body>".to_string(),
            "test.xml:5: not well-formed XML: `<worldbody>` is never closed",
        ),
    ];
    for (text, expected) in cases {
        let message = model_from_mjcf_str(&text, "test.xml")
            .err()
            .unwrap_or_else(|| panic!("accepted:\n{text}"))
            .to_string();
        assert!(message.contains(expected), "`{expected}` not in: {message}");
    }
}

/// Joint springs keep MuJoCo's values (`qpos_spring` in radians for a hinge of a file in degrees,
/// as MuJoCo compiles it), and a `<general>` with MuJoCo's default gain, bias and dynamics is a
/// motor.
#[test]
fn joint_springs_and_general_actuators_import() {
    let doc = "<mujoco><worldbody><body><freejoint/><geom size=\"0.1\"/>\
               <body><joint name=\"h\" stiffness=\"20\" springref=\"30\"/><geom size=\"0.1\"/></body>\
               <body><joint name=\"s\" type=\"slide\" stiffness=\"5\" springref=\"0.2\"/>\
               <geom size=\"0.1\"/></body></body></worldbody>\
               <actuator><general joint=\"h\" gear=\"3\"/></actuator></mujoco>";
    let model = model_from_mjcf_str(doc, "springs.xml").unwrap();
    let joint = |name: &str| {
        (model.articulation.links.iter())
            .filter_map(|l| l.joint.as_ref())
            .find(|j| j.name == name)
            .unwrap()
            .clone()
    };
    let (h, s) = (joint("h"), joint("s"));
    assert_eq!((h.spring_stiffness, s.spring_stiffness), (20.0, 5.0));
    assert!(
        (h.spring_ref - 30f32.to_radians()).abs() < 1e-7,
        "{}",
        h.spring_ref
    );
    assert_eq!(s.spring_ref, 0.2);
    assert_eq!(model.actuators.len(), 1);
    assert_eq!(
        (model.actuators[0].joint.as_str(), model.actuators[0].gear),
        ("h", 3.0)
    );
}

/// Visual attributes are ignored and MuJoCo's contact settings accepted (with a warning that
/// they are not simulated): the model is the one without them.
#[test]
fn visual_and_unsimulated_attributes_leave_the_model_unchanged() {
    let doc = |extra: &str| {
        format!(
            "<mujoco><worldbody><body name=\"b\"><freejoint/><geom size=\"0.1\" {extra}/>\
             </body></worldbody></mujoco>"
        )
    };
    let plain = model_from_mjcf_str(&doc(""), "plain.xml").unwrap();
    let decorated = doc("rgba=\"1 0 0 1\" group=\"2\" material=\"m\" condim=\"6\" margin=\"0.01\"");
    assert_eq!(model_from_mjcf_str(&decorated, "plain.xml").unwrap(), plain);
}

/// A joint away from its body's origin puts the link frame at the joint: the geom and the
/// child move by the offset, so the world positions stay those of the file.
#[test]
fn a_joint_offset_moves_the_link_frame_to_the_joint() {
    let text = "<mujoco><compiler angle=\"radian\"/><worldbody><body name=\"base\">\
        <geom type=\"box\" size=\"0.1 0.1 0.1\"/>\
        <body name=\"arm\" pos=\"1 0 0\"><joint name=\"j\" pos=\"0 0 0.5\" axis=\"0 1 0\"/>\
        <geom type=\"sphere\" size=\"0.1\" pos=\"0 0 1\"/></body></body></worldbody></mujoco>";
    let model = model_from_mjcf_str(text, "offset.xml").unwrap();
    assert!(!model.floating_base);
    let arm = &model.articulation.links[1];
    let joint = arm.joint.as_ref().unwrap();
    assert!((joint.origin.pos - Vec3::new(1.0, 0.0, 0.5)).length() < 1e-6);
    assert!((arm.shapes[0].pose.pos - Vec3::new(0.0, 0.0, 0.5)).length() < 1e-6);
    assert!((arm.inertial.com - Vec3::new(0.0, 0.0, 0.5)).length() < 1e-6);
    // A quarter turn about y takes the sphere from above the joint to beside it.
    let mut kin = ArticulationKinematics::new(&model.articulation);
    let links = kin
        .forward(&Pose::default(), &[std::f32::consts::FRAC_PI_2])
        .to_vec();
    let sphere = links[1].transform_point(arm.shapes[0].pose.pos);
    assert!(
        (sphere - Vec3::new(1.5, 0.0, 0.5)).length() < 1e-5,
        "{sphere}"
    );
}
