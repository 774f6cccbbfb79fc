//! Resolving floating-base articulations: the root state they start in, and the configs that
//! cannot float.

use glam::{Mat3, Vec3};
use orbit_core::math::Pose;
use orbit_core::scene::{
    ArticulationCfg, ArticulationModel, AssetSource, Inertial, Joint, Link, SceneCfg, SceneDesc,
    SceneError,
};

/// A two-link model whose root has mass `root_mass`.
fn two_links(root_mass: f32) -> ArticulationModel {
    let inertial = |mass: f32| Inertial {
        mass,
        com: Vec3::ZERO,
        inertia: Mat3::from_diagonal(Vec3::splat(0.01 * mass)),
    };
    let link = |name: &str, parent: Option<usize>, joint: Option<Joint>, mass: f32| Link {
        name: name.into(),
        parent,
        joint,
        inertial: inertial(mass),
        shapes: vec![],
        frames: vec![],
    };
    ArticulationModel {
        name: "two".into(),
        links: vec![
            link("base", None, None, root_mass),
            link(
                "arm",
                Some(0),
                Some(Joint::revolute("hinge", Pose::IDENTITY, Vec3::Z, None)),
                1.0,
            ),
        ],
    }
}

fn resolve(
    model: ArticulationModel,
    edit: impl FnOnce(&mut ArticulationCfg),
) -> Result<SceneDesc, SceneError> {
    let mut art = ArticulationCfg {
        name: "robot".into(),
        spawn: AssetSource::Model(model),
        init_state: Default::default(),
        actuators: Default::default(),
        self_collisions: false,
        fixed_base: false,
    };
    edit(&mut art);
    let scene = SceneCfg {
        env_spacing: 1.0,
        articulations: vec![art],
        rigid_objects: vec![],
        static_objects: vec![],
    };
    scene.resolve(&|source: &AssetSource| match source {
        AssetSource::Model(m) => Ok(m.clone()),
        other => Err(format!("no loader for {other:?}")),
    })
}

#[test]
fn a_floating_base_keeps_its_starting_velocities() {
    let scene = resolve(two_links(2.0), |a| {
        a.init_state.pos = Vec3::new(0.0, 0.0, 1.0);
        a.init_state.lin_vel = Vec3::new(0.5, 0.0, 0.0);
        a.init_state.ang_vel = Vec3::new(0.0, 0.0, 2.0);
    })
    .expect("a floating base resolves");
    let art = &scene.articulations[0];
    assert!(!art.fixed_base);
    assert_eq!(art.root_pose.pos, Vec3::new(0.0, 0.0, 1.0));
    assert_eq!(art.root_lin_vel, Vec3::new(0.5, 0.0, 0.0));
    assert_eq!(art.root_ang_vel, Vec3::new(0.0, 0.0, 2.0));
}

#[test]
fn a_massless_root_cannot_float() {
    let e = resolve(two_links(0.0), |_| {}).unwrap_err().to_string();
    assert!(
        e.contains("robot.fixed_base") || e.contains("fixed_base"),
        "{e}"
    );
    assert!(e.contains("`base`") && e.contains("has no mass"), "{e}");
}

#[test]
fn a_joint_must_move_mass_or_armature() {
    let mut model = two_links(2.0);
    model.links[1].inertial = Inertial::ZERO;
    let e = resolve(model.clone(), |_| {}).unwrap_err().to_string();
    assert!(e.contains("`hinge`") && e.contains("moves no mass"), "{e}");
    // A massless link carrying a massive one (an MJCF body's first joint) is fine.
    let mut chain = model.clone();
    let mut tip = chain.links[1].clone();
    tip.name = "tip".into();
    tip.parent = Some(1);
    tip.inertial = two_links(1.0).links[1].inertial;
    tip.joint = Some(Joint::revolute("tip_hinge", Pose::IDENTITY, Vec3::X, None));
    chain.links.push(tip);
    assert!(resolve(chain, |_| {}).is_ok());
    // So is a massless link on a joint with armature.
    model.links[1].joint.as_mut().unwrap().armature = 0.01;
    assert!(resolve(model, |_| {}).is_ok());
}

#[test]
fn a_fixed_base_cannot_move() {
    let e = resolve(two_links(2.0), |a| {
        a.fixed_base = true;
        a.init_state.ang_vel = Vec3::X;
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("init_state") && e.contains("fixed_base: false"),
        "{e}"
    );
}

#[test]
fn non_finite_root_velocities_are_errors() {
    let e = resolve(two_links(2.0), |a| {
        a.init_state.lin_vel = Vec3::new(f32::NAN, 0.0, 0.0)
    })
    .unwrap_err()
    .to_string();
    assert!(e.contains("root velocities must be finite"), "{e}");
}
