//! URDF import facts on small hand-written documents.

use glam::{DMat3, DVec3, Mat3, Vec3};
use orbit_assets::{
    AssetError, UrdfOptions, load_model, model_from_urdf_str, model_from_urdf_str_with,
};
use orbit_core::scene::{AssetSource, CollisionFilter, Geometry, JointKind};

const INERTIAL: &str = r#"<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>"#;

fn robot(body: &str) -> String {
    format!(r#"<?xml version="1.0"?><robot name="test">{body}</robot>"#)
}

/// URDF rpy is fixed-axis roll-pitch-yaw, R = Rz(yaw)·Ry(pitch)·Rx(roll): checked against the
/// elementary rotation matrices written out by hand (tolerance 1e-6, f32 storage).
#[test]
fn rpy_is_fixed_axis_zyx() {
    let (roll, pitch, yaw) = (0.3_f64, -0.7_f64, 1.9_f64);
    let text = robot(&format!(
        r#"<link name="a">{INERTIAL}</link><link name="b">{INERTIAL}</link>
        <joint name="j" type="fixed"><origin xyz="1 2 3" rpy="{roll} {pitch} {yaw}"/>
          <parent link="a"/><child link="b"/></joint>"#
    ));
    let model = model_from_urdf_str(&text, "rpy.urdf").unwrap();
    let origin = model.links[1].joint.as_ref().unwrap().origin;
    assert_eq!(origin.pos, Vec3::new(1.0, 2.0, 3.0));
    let (c, s) = (f64::cos, f64::sin);
    let rx = DMat3::from_cols(
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, c(roll), s(roll)),
        DVec3::new(0.0, -s(roll), c(roll)),
    );
    let ry = DMat3::from_cols(
        DVec3::new(c(pitch), 0.0, -s(pitch)),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(s(pitch), 0.0, c(pitch)),
    );
    let rz = DMat3::from_cols(
        DVec3::new(c(yaw), s(yaw), 0.0),
        DVec3::new(-s(yaw), c(yaw), 0.0),
        DVec3::new(0.0, 0.0, 1.0),
    );
    let expected = (rz * ry * rx).as_mat3();
    let got = Mat3::from_quat(origin.rot);
    for (e, g) in expected.to_cols_array().iter().zip(got.to_cols_array()) {
        assert!((e - g).abs() < 1e-6, "expected {expected:?}, got {got:?}");
    }
    // A known case: roll 90° then yaw 90° maps y → z and z → x.
    let text = robot(&format!(
        r#"<link name="a">{INERTIAL}</link><link name="b">{INERTIAL}</link>
        <joint name="j" type="fixed"><origin rpy="1.5707963267948966 0 1.5707963267948966"/>
          <parent link="a"/><child link="b"/></joint>"#
    ));
    let rot = model_from_urdf_str(&text, "rpy2.urdf").unwrap().links[1]
        .joint
        .as_ref()
        .unwrap()
        .origin
        .rot;
    assert!((rot * Vec3::Y - Vec3::Z).length() < 1e-6);
    assert!((rot * Vec3::Z - Vec3::X).length() < 1e-6);
}

/// The inertia tensor given in a rotated inertial frame is rotated into the link frame (R I Rᵀ);
/// the inertial origin's xyz is the COM. Tolerance 1e-6 (f32).
#[test]
fn inertia_is_rotated_into_the_link_frame() {
    let text = robot(
        r#"<link name="a"><inertial><origin xyz="0.1 0.2 0.3" rpy="0 0 0.7853981633974483"/>
           <mass value="2"/><inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="3"/></inertial></link>"#,
    );
    let model = model_from_urdf_str(&text, "inertia.urdf").unwrap();
    let i = model.links[0].inertial;
    assert_eq!(i.mass, 2.0);
    assert!((i.com - Vec3::new(0.1, 0.2, 0.3)).length() < 1e-7);
    // Rz(45°) diag(1, 2, 3) Rz(45°)ᵀ = [[1.5, -0.5, 0], [-0.5, 1.5, 0], [0, 0, 3]].
    let expected = Mat3::from_cols(
        Vec3::new(1.5, -0.5, 0.0),
        Vec3::new(-0.5, 1.5, 0.0),
        Vec3::new(0.0, 0.0, 3.0),
    );
    assert!(
        (i.inertia - expected)
            .to_cols_array()
            .iter()
            .all(|d| d.abs() < 1e-6),
        "{:?}",
        i.inertia
    );
    // Off-diagonal terms are read in the URDF order ixy, ixz, iyz.
    let text = robot(
        r#"<link name="a"><inertial><mass value="1"/>
           <inertia ixx="1" ixy="0.1" ixz="0.2" iyy="2" iyz="0.3" izz="3"/></inertial></link>"#,
    );
    let m = model_from_urdf_str(&text, "inertia2.urdf").unwrap().links[0]
        .inertial
        .inertia;
    assert_eq!((m.x_axis.y, m.x_axis.z, m.y_axis.z), (0.1, 0.2, 0.3));
    assert_eq!((m.y_axis.x, m.z_axis.x, m.z_axis.y), (0.1, 0.2, 0.3));
}

/// Joint kinds, limits and dynamics.
#[test]
fn joint_kinds_limits_and_dynamics() {
    let text = robot(&format!(
        r#"<link name="base">{INERTIAL}</link><link name="wheel">{INERTIAL}</link>
        <link name="slider">{INERTIAL}</link><link name="arm">{INERTIAL}</link>
        <joint name="spin" type="continuous"><parent link="base"/><child link="wheel"/>
          <axis xyz="0 2 0"/><limit effort="5" velocity="3"/><dynamics damping="0.5" friction="0.1"/></joint>
        <joint name="lift" type="prismatic"><parent link="base"/><child link="slider"/>
          <axis xyz="0 0 1"/><limit lower="-0.1" upper="0.2" effort="100" velocity="0.5"/></joint>
        <joint name="elbow" type="revolute"><parent link="base"/><child link="arm"/>
          <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="0" velocity="0"/></joint>"#
    ));
    let model = model_from_urdf_str(&text, "joints.urdf").unwrap();
    let joint = |name: &str| {
        model
            .links
            .iter()
            .find_map(|l| l.joint.as_ref().filter(|j| j.name == name))
            .unwrap()
    };
    let spin = joint("spin");
    assert_eq!(spin.kind, JointKind::Revolute);
    assert_eq!(
        spin.limits, None,
        "continuous joints have no position limits"
    );
    assert_eq!(spin.axis, Vec3::Y, "axis is normalised");
    assert_eq!(
        (spin.effort_limit, spin.velocity_limit),
        (Some(5.0), Some(3.0))
    );
    assert_eq!(
        (spin.damping, spin.friction, spin.armature),
        (0.5, 0.1, 0.0)
    );
    let lift = joint("lift");
    assert_eq!(lift.kind, JointKind::Prismatic);
    assert_eq!(lift.limits, Some([-0.1, 0.2]));
    let elbow = joint("elbow");
    assert_eq!(elbow.limits, Some([-1.0, 1.0]));
    assert_eq!(
        (elbow.effort_limit, elbow.velocity_limit),
        (None, None),
        "zero effort/velocity mean: not declared"
    );
    assert_eq!(model.joint_names(), ["spin", "lift", "elbow"]);
}

/// Links come out parent-before-child (depth-first, children in file order) whatever the file
/// order; the root is the link that is nobody's child.
#[test]
fn links_are_topologically_sorted() {
    let text = robot(&format!(
        r#"<link name="tip">{INERTIAL}</link><link name="mid">{INERTIAL}</link>
        <link name="side">{INERTIAL}</link><link name="root">{INERTIAL}</link>
        <joint name="j_tip" type="fixed"><parent link="mid"/><child link="tip"/></joint>
        <joint name="j_mid" type="fixed"><parent link="root"/><child link="mid"/></joint>
        <joint name="j_side" type="fixed"><parent link="root"/><child link="side"/></joint>"#
    ));
    let model = model_from_urdf_str(&text, "order.urdf").unwrap();
    let names: Vec<&str> = model.links.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["root", "mid", "tip", "side"]);
    assert_eq!(model.links[2].parent, Some(1));
    assert_eq!(model.links[3].parent, Some(0));
}

/// Collision primitives: sizes converted to half extents / half lengths, origins kept; meshes
/// skipped when the import is told to; the `<orbit_collision_filter>` extension sets the
/// link's filter.
#[test]
fn collision_shapes_and_filters() {
    let text = robot(
        r#"<link name="a">
          <collision><origin xyz="0 0 0.5"/><geometry><box size="0.2 0.4 0.6"/></geometry></collision>
          <collision><geometry><sphere radius="0.1"/></geometry></collision>
          <collision><geometry><cylinder radius="0.05" length="0.3"/></geometry></collision>
          <collision><geometry><capsule radius="0.04" length="0.2"/></geometry></collision>
          <collision><geometry><mesh filename="x.stl"/></geometry></collision>
        </link>
        <orbit_collision_filter link="a" groups="0x4" mask="3"/>"#,
    );
    let options = UrdfOptions {
        skip_mesh_collisions: true,
    };
    let model = model_from_urdf_str_with(&text, "shapes.urdf", options).unwrap();
    let shapes = &model.links[0].shapes;
    assert_eq!(shapes.len(), 4, "the mesh is skipped");
    assert_eq!(
        shapes[0].geometry,
        Geometry::Box {
            half_extents: Vec3::new(0.1, 0.2, 0.3)
        }
    );
    assert_eq!(shapes[0].pose.pos, Vec3::new(0.0, 0.0, 0.5));
    assert_eq!(shapes[1].geometry, Geometry::Sphere { radius: 0.1 });
    assert_eq!(
        shapes[2].geometry,
        Geometry::Cylinder {
            radius: 0.05,
            half_length: 0.15
        }
    );
    assert_eq!(
        shapes[3].geometry,
        Geometry::Capsule {
            radius: 0.04,
            half_length: 0.1
        }
    );
    for s in shapes {
        assert_eq!(s.filter, CollisionFilter { groups: 4, mask: 3 });
        assert_eq!(s.material.friction, 1.0);
    }
}

/// Fixed children (an inertial tool, a massless tip) merge into their parent as named frames;
/// masses add up and the frame poses compose.
#[test]
fn merge_keeps_fixed_links_as_frames() {
    let text = robot(&format!(
        r#"<link name="base">{INERTIAL}</link><link name="arm">{INERTIAL}</link>
        <link name="tool"><inertial><origin xyz="0 0 0.05"/><mass value="0.5"/>
          <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
          <collision><geometry><sphere radius="0.02"/></geometry></collision></link>
        <link name="tcp"/>
        <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
          <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        <joint name="arm_tool" type="fixed"><origin xyz="0 0 0.3" rpy="0 0 1.5707963267948966"/>
          <parent link="arm"/><child link="tool"/></joint>
        <joint name="tool_tcp" type="fixed"><origin xyz="0.1 0 0"/>
          <parent link="tool"/><child link="tcp"/></joint>"#
    ));
    let model = model_from_urdf_str(&text, "merge.urdf").unwrap();
    assert_eq!(model.links.len(), 4);
    let merged = model.merge_fixed_joints();
    assert_eq!(merged.links.len(), 2);
    let arm = &merged.links[1];
    assert!((arm.inertial.mass - 1.5).abs() < 1e-6);
    assert_eq!(arm.shapes.len(), 1);
    let (link, tool) = merged.find_frame("tool").unwrap();
    assert_eq!(link, 1);
    assert!((tool.pos - Vec3::new(0.0, 0.0, 0.3)).length() < 1e-6);
    let (link, tcp) = merged.find_frame("tcp").unwrap();
    assert_eq!(link, 1);
    // tcp = tool · (0.1, 0, 0) with the tool yawed 90°: (0, 0.1, 0.3).
    assert!(
        (tcp.pos - Vec3::new(0.0, 0.1, 0.3)).length() < 1e-6,
        "{tcp:?}"
    );
    assert!((arm.shapes[0].pose.pos - Vec3::new(0.0, 0.0, 0.3)).length() < 1e-6);
}

/// `load_model`: a file relative to `base_dir` wins; else a bundled asset; else an error that
/// lists what was tried and the bundled names. `Model` sources pass through.
#[test]
fn load_model_resolution() {
    let dir = std::env::temp_dir().join(format!("orbit-assets-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("one.urdf"),
        robot(&format!(r#"<link name="only">{INERTIAL}</link>"#)),
    )
    .unwrap();
    let src = |p: &str| AssetSource::Urdf {
        path: p.into(),
        skip_mesh_collisions: false,
    };

    let m = load_model(&src("one.urdf"), Some(&dir)).unwrap();
    assert_eq!(m.links[0].name, "only");
    let abs = dir.join("one.urdf").display().to_string();
    assert_eq!(load_model(&src(&abs), None).unwrap(), m);

    let franka = load_model(&src("franka_panda_rod.urdf"), Some(&dir)).unwrap();
    assert_eq!(franka.links[0].name, "panda_link0");

    let err = load_model(&src("nope.urdf"), Some(&dir)).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, AssetError::NotFound { .. }));
    assert!(
        msg.contains("nope.urdf") && msg.contains(&dir.display().to_string()),
        "{msg}"
    );
    assert!(msg.contains("franka_panda_rod.urdf"), "{msg}");

    assert_eq!(load_model(&AssetSource::Model(m.clone()), None).unwrap(), m);
    std::fs::remove_dir_all(&dir).unwrap();
}
