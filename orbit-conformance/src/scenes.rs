//! Small scenes built in code for the conformance checks.

use glam::{Mat3, Vec3};
use orbit_core::math::Pose;
use orbit_core::physics::{PhysicsBackend, SimCfg, build_backend};
use orbit_core::scene::{
    ActuatorCfg, ArticulationCfg, ArticulationModel, AssetSource, Geometry, Inertial, Joint,
    JointKind, Link, Material, PerJoint, RigidObjectCfg, RootStateCfg, SceneCfg, SceneDesc, Shape,
    StaticObjectCfg,
};

/// Resolves a scene config whose models are inline or bundled assets.
pub fn resolve(cfg: &SceneCfg) -> SceneDesc {
    cfg.resolve(&orbit_assets::model_loader(None))
        .unwrap_or_else(|e| panic!("conformance scene does not resolve: {e}"))
}

/// Builds a backend by name for a scene.
pub fn build(
    backend: &str,
    scene: &SceneDesc,
    num_envs: usize,
    dt: f32,
) -> Box<dyn PhysicsBackend> {
    build_with(&sim_cfg(backend), scene, num_envs, dt)
}

/// The default simulation settings for a backend.
pub fn sim_cfg(backend: &str) -> SimCfg {
    SimCfg {
        backend: backend.to_string(),
        ..SimCfg::default()
    }
}

/// Builds a backend with `sim`'s settings (its step set to `dt`, one thread) for a scene.
pub fn build_with(
    sim: &SimCfg,
    scene: &SceneDesc,
    num_envs: usize,
    dt: f32,
) -> Box<dyn PhysicsBackend> {
    let sim = SimCfg {
        dt,
        num_threads: 1,
        ..sim.clone()
    };
    build_backend(scene, num_envs, &sim)
        .unwrap_or_else(|e| panic!("backend `{}` failed to build: {e}", sim.backend))
}

/// A box shape with a material.
pub fn box_shape(half_extents: Vec3, pos: Vec3, friction: f32) -> Shape {
    Shape {
        geometry: Geometry::Box { half_extents },
        pose: Pose::from_pos(pos),
        material: Material {
            friction,
            ..Material::default()
        },
        filter: Default::default(),
    }
}

/// A static table: a box whose top face is at `top_z`.
pub fn table(top_z: f32, friction: f32) -> StaticObjectCfg {
    StaticObjectCfg {
        name: "table".into(),
        pose: Pose::from_pos(Vec3::new(0.0, 0.0, top_z - 0.05)),
        shapes: vec![box_shape(Vec3::new(2.0, 2.0, 0.05), Vec3::ZERO, friction)],
    }
}

/// A free solid box of the given mass and half-extents.
pub fn free_box(
    name: &str,
    half: Vec3,
    mass: f32,
    friction: f32,
    init: RootStateCfg,
) -> RigidObjectCfg {
    RigidObjectCfg {
        name: name.into(),
        shapes: vec![box_shape(half, Vec3::ZERO, friction)],
        inertial: None,
        shape_masses: vec![mass],
        init_state: init,
    }
}

/// A pendulum: a fixed pivot link and one link on a revolute joint about y, carrying a point-like
/// mass `mass` at distance `length` below the pivot (inertia of a solid sphere of radius
/// `radius` about its centre). The pivot sits at height `pivot_z`.
pub fn pendulum(mass: f32, length: f32, radius: f32, pivot_z: f32) -> ArticulationModel {
    let sphere_i = 0.4 * mass * radius * radius;
    ArticulationModel {
        name: "pendulum".into(),
        links: vec![
            Link {
                name: "pivot".into(),
                parent: None,
                joint: None,
                inertial: Inertial::ZERO,
                shapes: vec![],
                frames: vec![],
            },
            Link {
                name: "bob".into(),
                parent: Some(0),
                joint: Some(Joint::revolute(
                    "hinge",
                    Pose::from_pos(Vec3::new(0.0, 0.0, pivot_z)),
                    Vec3::Y,
                    None,
                )),
                inertial: Inertial {
                    mass,
                    com: Vec3::new(0.0, 0.0, -length),
                    inertia: Mat3::from_diagonal(Vec3::splat(sphere_i)),
                },
                shapes: vec![],
                frames: vec![],
            },
        ],
    }
}

/// A pendulum on a cart: a massless rail, a cart of mass `cart_mass` on a prismatic joint along
/// x (`slider`), and below it the [`pendulum`]'s bob on a revolute joint about y (`hinge`).
pub fn cart_pendulum(
    cart_mass: f32,
    mass: f32,
    length: f32,
    radius: f32,
    rail_z: f32,
) -> ArticulationModel {
    let mut model = pendulum(mass, length, radius, 0.0);
    model.name = "cart_pendulum".into();
    let cart = Link {
        name: "cart".into(),
        parent: Some(0),
        joint: Some(Joint {
            kind: JointKind::Prismatic,
            axis: Vec3::X,
            ..Joint::fixed("slider", Pose::from_pos(Vec3::new(0.0, 0.0, rail_z)))
        }),
        inertial: Inertial {
            mass: cart_mass,
            com: Vec3::ZERO,
            inertia: Mat3::from_diagonal(Vec3::splat(0.01 * cart_mass)),
        },
        shapes: vec![],
        frames: vec![],
    };
    model.links[0].name = "rail".into();
    model.links[1].parent = Some(1);
    model.links.insert(1, cart);
    model
}

/// An articulation config around an inline model with no actuators.
pub fn passive_articulation(model: ArticulationModel) -> ArticulationCfg {
    ArticulationCfg {
        name: model.name.clone(),
        spawn: AssetSource::Model(model),
        init_state: Default::default(),
        actuators: Default::default(),
        self_collisions: false,
        fixed_base: true,
    }
}

/// A floating tree of three links without shapes: a body of mass 2 (its centre of mass off its
/// origin) carrying two arms of mass 0.5 on hinges about z at one end and about y at the other.
pub fn floating_tree() -> ArticulationModel {
    let solid = |mass: f32, com: Vec3, half: Vec3| Inertial {
        mass,
        com,
        inertia: Mat3::from_diagonal(
            mass / 3.0
                * Vec3::new(
                    half.y * half.y + half.z * half.z,
                    half.x * half.x + half.z * half.z,
                    half.x * half.x + half.y * half.y,
                ),
        ),
    };
    let arm = |name: &str, at: Vec3, axis: Vec3| Link {
        name: name.into(),
        parent: Some(0),
        joint: Some(Joint::revolute(
            format!("{name}_hinge"),
            Pose::from_pos(at),
            axis,
            None,
        )),
        inertial: solid(
            0.5,
            Vec3::new(at.x.signum() * 0.15, 0.02, 0.0),
            Vec3::new(0.15, 0.02, 0.02),
        ),
        shapes: vec![],
        frames: vec![],
    };
    ArticulationModel {
        name: "tree".into(),
        links: vec![
            Link {
                name: "body".into(),
                parent: None,
                joint: None,
                inertial: solid(2.0, Vec3::new(0.03, 0.0, 0.01), Vec3::new(0.2, 0.1, 0.05)),
                shapes: vec![],
                frames: vec![],
            },
            arm("right", Vec3::new(0.2, 0.0, 0.0), Vec3::Z),
            arm("left", Vec3::new(-0.2, 0.0, 0.0), Vec3::Y),
        ],
    }
}

/// A ground plane at `z = 0` (a static object with the default collision filter).
pub fn ground(friction: f32) -> StaticObjectCfg {
    StaticObjectCfg {
        name: "ground".into(),
        pose: Pose::IDENTITY,
        shapes: vec![Shape {
            geometry: Geometry::Plane,
            pose: Pose::IDENTITY,
            material: Material {
                friction,
                ..Material::default()
            },
            filter: Default::default(),
        }],
    }
}

/// The bundled Ant (`ant.xml`) as a floating base without actuators (its joints take efforts),
/// starting at the origin.
pub fn floating_ant() -> ArticulationCfg {
    floating_mjcf("ant", "ant.xml")
}

/// The MJCF model at `path` (a bundled name or a file) as a floating base named `name`, without
/// actuators (its joints take efforts), starting at the origin.
pub fn floating_mjcf(name: &str, path: &str) -> ArticulationCfg {
    let mut robot = passive_articulation(ArticulationModel {
        name: name.into(),
        links: vec![],
    });
    robot.spawn = AssetSource::Mjcf { path: path.into() };
    robot.fixed_base = false;
    robot
}

/// The bundled Ant (`ant.xml`) as a floating base at `height`, its joints starting at
/// `joint_pos` (by name) and held there by stiff drives (stiffness 1 000 N·m/rad, damping
/// 10 N·m·s/rad).
pub fn standing_ant(height: f32, joint_pos: &[(&str, f32)]) -> ArticulationCfg {
    let mut ant = floating_ant();
    ant.init_state.pos = Vec3::new(0.0, 0.0, height);
    ant.init_state.joint_pos = joint_pos.iter().map(|&(n, q)| (n.into(), q)).collect();
    ant.actuators.insert(
        "legs".into(),
        ActuatorCfg {
            joint_names_expr: vec![".*".into()],
            stiffness: PerJoint::All(1000.0),
            damping: PerJoint::All(10.0),
            effort_limit: None,
            velocity_limit: None,
            armature: None,
            friction: None,
        },
    );
    ant
}
