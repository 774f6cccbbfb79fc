//! A bad scene config or override is an error that names the file, the field path and what is
//! expected — never a panic, never a half-built scene.

use orbit_assets::box_pushing_scene;

fn error_of(overrides: &[&str]) -> String {
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    match box_pushing_scene(&overrides) {
        Ok(_) => panic!("{overrides:?} was accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_bundled_scene_resolves() {
    let scene = box_pushing_scene(&[]).expect("bundled scene");
    assert_eq!(scene.articulations[0].num_dofs(), 7);
    assert_eq!(scene.rigid_objects[0].name, "box");
}

#[test]
fn a_joint_regex_matching_nothing_names_file_field_and_joints() {
    let e = error_of(&[r#"articulations[0].actuators.arm.joint_names_expr=["panda_joint9"]"#]);
    assert!(e.contains("scenes/box_pushing.ron"), "{e}");
    assert!(e.contains("actuators.arm.joint_names_expr"), "{e}");
    assert!(e.contains("`panda_joint9` matches no joint"), "{e}");
    assert!(
        e.contains("panda_joint7"),
        "the message lists the joints: {e}"
    );
}

#[test]
fn a_bad_regex_is_reported() {
    let e = error_of(&[r#"articulations[0].init_state.joint_pos={"panda_joint[1-": 0.0}"#]);
    assert!(e.contains("init_state.joint_pos"), "{e}");
    assert!(e.contains("not a valid regex"), "{e}");
}

#[test]
fn a_joint_matched_twice_is_ambiguous() {
    let e = error_of(&[
        r#"articulations[0].init_state.joint_pos={"panda_joint.*": 0.0, "panda_joint1": 1.0}"#,
    ]);
    assert!(e.contains("panda_joint1"), "{e}");
    assert!(e.contains("more than one entry"), "{e}");
}

#[test]
fn a_misspelled_field_names_the_override() {
    let e = error_of(&["articulations[0].actuators.arm.stifness=1.0"]);
    assert!(e.contains("stifness"), "{e}");
    assert!(e.contains("override"), "{e}");
}

#[test]
fn a_wrong_type_names_the_field_and_the_expected_type() {
    let e = error_of(&[r#"env_spacing="far""#]);
    assert!(e.contains("env_spacing"), "{e}");
    assert!(e.contains("f32"), "{e}");
}

#[test]
fn a_negative_gain_is_rejected() {
    let e = error_of(&["articulations[0].actuators.arm.stiffness=-1.0"]);
    assert!(e.contains("actuators.arm.stiffness"), "{e}");
    assert!(e.contains(">= 0"), "{e}");
}

#[test]
fn an_unknown_urdf_names_what_was_tried() {
    let e = error_of(&[r#"articulations[0].spawn=Urdf(path: "no_such_robot.urdf")"#]);
    assert!(e.contains("no_such_robot.urdf"), "{e}");
    assert!(
        e.contains("franka_panda_rod.urdf"),
        "the message lists bundled assets: {e}"
    );
}

#[test]
fn a_massless_box_is_rejected() {
    let e = error_of(&["rigid_objects[0].shape_masses=[0.0, 0.0, 0.0, 0.0, 0.0]"]);
    assert!(e.contains("rigid_objects[0]"), "{e}");
    assert!(e.contains("positive mass"), "{e}");
}

/// Physically meaningless values are errors naming the field, the value and what is allowed:
/// a negative shape mass (was turned into a 4 g box), a negative friction (was accepted), and
/// a start outside a joint's limits (gave NaN rewards).
#[test]
fn physically_meaningless_values_are_errors() {
    let e = error_of(&["rigid_objects[0].shape_masses[0]=-2.0"]);
    assert!(
        e.contains("rigid_objects[0].shape_masses[0]") && e.contains("-2"),
        "{e}"
    );
    let e = error_of(&["rigid_objects[0].shapes[1].material.friction=-0.3"]);
    assert!(
        e.contains("rigid_objects[0].shapes[1].material.friction") && e.contains("-0.3"),
        "{e}"
    );
    let e = error_of(&["static_objects[0].shapes[0].material.friction=-1.0"]);
    assert!(
        e.contains("static_objects[0].shapes[0].material.friction"),
        "{e}"
    );
    let e = error_of(&[r#"articulations[0].init_state.joint_pos["panda_joint4"]=0.5"#]);
    assert!(
        e.contains("init_state.joint_pos") && e.contains("`panda_joint4`") && e.contains("0.5"),
        "{e}"
    );
    assert!(e.contains("[-3.1416, 0.0873]"), "the URDF's limits: {e}");
}

#[test]
fn a_fixed_base_cannot_start_moving() {
    let e = error_of(&["articulations[0].init_state.lin_vel=(0.0, 0.0, 1.0)"]);
    assert!(e.contains("articulations[0].init_state"), "{e}");
    assert!(e.contains("fixed_base: false"), "{e}");
}
