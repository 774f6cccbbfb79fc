//! Floating-base articulations: momentum in free flight, resting on the ground, root-state
//! writes, replays from a state snapshot.

use glam::{Quat, Vec3};
use orbit_core::kinematics::ArticulationKinematics;
use orbit_core::math::{Pose, rotate_inertia};
use orbit_core::physics::{ArticulationState, EnvState, PhysicsBackend, SimCfg, StateSnapshot};
use orbit_core::scene::{ArticulationCfg, ArticulationModel, Geometry, RootState, SceneCfg};

use crate::scenes::*;

/// A scene of `art` alone, 2 m between envs.
fn alone(art: ArticulationCfg) -> SceneCfg {
    SceneCfg {
        env_spacing: 2.0,
        articulations: vec![art],
        rigid_objects: vec![],
        static_objects: vec![],
    }
}

/// Linear and angular momentum of articulation `a` in env `e`, about the env origin, from the
/// published link states and the model's mass properties.
pub fn articulation_momentum(sim: &dyn PhysicsBackend, a: usize, e: usize) -> (Vec3, Vec3) {
    let model = &sim.layout().articulations[a].model;
    let view = sim.articulation(a);
    let (mut p, mut l) = (Vec3::ZERO, Vec3::ZERO);
    for (i, link) in model.links.iter().enumerate() {
        let k = e * view.num_links + i;
        let (rot, w) = (view.link_quat[k], view.link_ang_vel[k]);
        let r = rot * link.inertial.com;
        let (x, v) = (view.link_pos[k] + r, view.link_lin_vel[k] + w.cross(r));
        let m = link.inertial.mass;
        p += m * v;
        l += m * x.cross(v) + rotate_inertia(rot, link.inertial.inertia) * w;
    }
    (p, l)
}

/// A floating tree of three links tumbling without gravity for 1 s in 2 ms steps, its joints
/// spinning: nothing acts from outside, so its linear momentum and its angular momentum about
/// a fixed point keep their starting values, to 1e-3 of their size. Semi-implicit Euler
/// conserves them only to first order in the step; the drift of a wrong bias force would not
/// shrink with the step (docs/fidelity.md).
pub fn free_flight_momentum(backend: &str) {
    let mut art = passive_articulation(floating_tree());
    art.fixed_base = false;
    art.init_state.pos = Vec3::new(0.1, -0.2, 1.0);
    art.init_state.lin_vel = Vec3::new(0.3, -0.2, 0.1);
    art.init_state.ang_vel = Vec3::new(0.5, 1.0, -0.7);
    art.init_state.joint_vel = [
        ("right_hinge".to_string(), 2.0),
        ("left_hinge".into(), -1.5),
    ]
    .into_iter()
    .collect();
    let cfg = alone(art);
    let sim_cfg = SimCfg {
        gravity: Vec3::ZERO,
        ..sim_cfg(backend)
    };
    let mut sim = build_with(&sim_cfg, &resolve(&cfg), 1, 0.002);
    let (p0, l0) = articulation_momentum(&*sim, 0, 0);
    let (mut dp, mut dl) = (0.0f32, 0.0f32);
    for _ in 0..500 {
        sim.step().expect("step");
        let (p, l) = articulation_momentum(&*sim, 0, 0);
        dp = dp.max((p - p0).length() / p0.length());
        dl = dl.max((l - l0).length() / l0.length());
    }
    println!(
        "free_flight_momentum[{backend}]: p0 {p0:?}, l0 {l0:?}; largest drift {dp:.2e} (linear), \
         {dl:.2e} (angular)"
    );
    assert!(dp < 1e-3, "linear momentum drifted by {dp:.2e} of its size");
    assert!(
        dl < 1e-3,
        "angular momentum drifted by {dl:.2e} of its size"
    );
}

/// The height of a floating articulation's root above the ground when its lowest shape touches
/// it, with the root upright and the joints at `q` (capsules and spheres; from forward
/// kinematics).
pub fn resting_root_height(model: &ArticulationModel, q: &[f32]) -> f32 {
    let mut kin = ArticulationKinematics::new(model);
    let poses = kin.forward(&Pose::IDENTITY, q).to_vec();
    let mut lowest = f32::INFINITY;
    for (link, pose) in model.links.iter().zip(&poses) {
        for shape in &link.shapes {
            let p = pose.mul_pose(&shape.pose);
            lowest = lowest.min(match shape.geometry {
                Geometry::Sphere { radius } => p.pos.z - radius,
                Geometry::Capsule {
                    radius,
                    half_length,
                } => p.pos.z - (p.rot * Vec3::Z * half_length).z.abs() - radius,
                ref g => panic!("resting_root_height takes capsules and spheres, not {g:?}"),
            });
        }
    }
    -lowest
}

/// MuJoCo's Ant, its hips held at 0 and its ankles at ±45° by stiff drives, dropped 5 cm above
/// the height at which its feet touch the ground (from forward kinematics), comes to rest on
/// its four feet at that height within 5 mm, upright within 1° and still (below 1 cm/s), 2 s
/// later.
pub fn ant_standing_height(backend: &str) {
    let a = 45f32.to_radians();
    let pose = [
        ("ankle_1", a),
        ("ankle_2", -a),
        ("ankle_3", -a),
        ("ankle_4", a),
    ];
    let scene = |height: f32| SceneCfg {
        env_spacing: 3.0,
        articulations: vec![standing_ant(height, &pose)],
        rigid_objects: vec![],
        static_objects: vec![ground(1.0)],
    };
    let desc = resolve(&scene(1.0));
    let ant = &desc.articulations[0];
    let expected = resting_root_height(&ant.model, &ant.default_joint_pos);
    let mut sim = build(backend, &resolve(&scene(expected + 0.05)), 2, 0.002);
    for _ in 0..1000 {
        sim.step().expect("step");
    }
    let view = sim.articulation(0);
    for e in 0..2 {
        let root = e * view.num_links;
        let (z, up) = (view.link_pos[root].z, view.link_quat[root] * Vec3::Z);
        let tilt = up.angle_between(Vec3::Z).to_degrees();
        let speed = view.link_lin_vel[root].length();
        println!(
            "ant_standing_height[{backend}] env {e}: torso at {z:.4} m (analytic {expected:.4}), \
             tilt {tilt:.3}°, speed {speed:.2e} m/s"
        );
        assert!(
            (z - expected).abs() < 5e-3,
            "the Ant rests at {z} m, not at its standing height {expected} m"
        );
        assert!(tilt < 1.0, "the Ant leans {tilt}° from upright");
        assert!(speed < 1e-2, "the Ant still moves at {speed} m/s");
    }
}

/// The floating tree's root state written to one env reads back as written (to 1e-5) with the
/// joint state kept and the root's children on it, the other env is untouched, and a fixed
/// base refuses root writes with an error naming `fixed_base`.
pub fn floating_root_writes(backend: &str) {
    let mut art = passive_articulation(floating_tree());
    art.fixed_base = false;
    art.init_state.pos = Vec3::new(0.0, 0.0, 1.0);
    art.init_state.joint_pos = [("right_hinge".to_string(), 0.3)].into_iter().collect();
    let cfg = alone(art);
    let mut sim = build(backend, &resolve(&cfg), 2, 0.002);
    let state = RootState {
        pose: Pose::new(
            Vec3::new(0.4, -0.3, 1.2),
            Quat::from_rotation_y(0.7) * Quat::from_rotation_z(-0.4),
        ),
        lin_vel: Vec3::new(0.2, 0.1, -0.3),
        ang_vel: Vec3::new(-0.5, 0.8, 0.3),
    };
    sim.write_articulation_root_state(0, &[1], std::slice::from_ref(&state))
        .expect("a floating base takes root writes");
    let view = sim.articulation(0);
    let root = view.num_links;
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
    println!(
        "floating_root_writes[{backend}]: root {:?} {:?} {:?} {:?}",
        view.link_pos[root], view.link_quat[root], view.link_lin_vel[root], view.link_ang_vel[root]
    );
    assert!(close(view.link_pos[root], state.pose.pos), "root position");
    let (q, want) = (view.link_quat[root], state.pose.rot);
    assert!(
        [Vec3::X, Vec3::Y].iter().all(|&v| close(q * v, want * v)),
        "root orientation"
    );
    assert!(
        close(view.link_lin_vel[root], state.lin_vel),
        "root velocity"
    );
    assert!(
        close(view.link_ang_vel[root], state.ang_vel),
        "root angular velocity"
    );
    assert!(
        (view.joint_pos[2] - 0.3).abs() < 1e-6,
        "the joint state is kept"
    );
    // The root's children follow it: a child's origin is its joint frame on the root.
    let model = &sim.layout().articulations[0].model;
    for (i, link) in model.links.iter().enumerate().skip(1) {
        let (Some(0), Some(joint)) = (link.parent, link.joint.as_ref()) else {
            continue;
        };
        let want = state.pose.transform_point(joint.origin.pos);
        assert!(
            close(view.link_pos[root + i], want),
            "link `{}` at {:?}, not on the written root at {want:?}",
            link.name,
            view.link_pos[root + i]
        );
    }
    assert!(
        close(view.link_pos[0], Vec3::new(0.0, 0.0, 1.0)),
        "env 0 is untouched"
    );

    let mut fixed = passive_articulation(floating_tree());
    fixed.init_state.pos = Vec3::new(0.0, 0.0, 1.0);
    let cfg = SceneCfg {
        articulations: vec![fixed],
        ..cfg
    };
    let mut sim = build(backend, &resolve(&cfg), 1, 0.002);
    let err = sim
        .write_articulation_root_state(0, &[0], &[state])
        .expect_err("a fixed base refuses root writes")
        .to_string();
    assert!(err.contains("fixed_base"), "{err}");
}

/// A step replays from a snapshot: the floating tree tumbles under gravity with joint efforts
/// in env 0, its state is captured mid-flight and written into env 1 (whose own motion
/// differs), and both envs then take the same steps. With no contact or limit (nothing that
/// warm-starts a solver), env 1 follows env 0 to 1e-4; what separates them is the write's
/// re-normalisation of the last bits. Env 0 must also have moved away from env 1's start, so
/// that the agreement is not that of two states that were equal anyway.
pub fn snapshot_replays_a_step(backend: &str) {
    let mut art = passive_articulation(floating_tree());
    art.fixed_base = false;
    art.init_state.pos = Vec3::new(0.0, 0.0, 5.0);
    art.init_state.ang_vel = Vec3::new(0.5, 1.0, -0.7);
    let cfg = alone(art);
    let mut sim = build(backend, &resolve(&cfg), 2, 0.002);
    // Env 0 drives its hinges, env 1 leaves them free, until the capture.
    sim.set_joint_efforts(0, &[0.3, -0.2, 0.0, 0.0])
        .expect("efforts");
    for _ in 0..50 {
        sim.step().expect("step");
    }
    let mut snapshot = StateSnapshot::default();
    snapshot.capture(&*sim);
    let state = snapshot.env_state(&*sim, 0);
    let before = snapshot.env_state(&*sim, 1);
    let apart = |a: &EnvState, b: &EnvState| {
        let (a, b) = (&a.articulations["tree"], &b.articulations["tree"]);
        let root = |s: &ArticulationState| s.root.clone().expect("a floating root");
        let (ra, rb) = (root(a), root(b));
        let joints = a.joint_pos.iter().chain(&a.joint_vel);
        let other = b.joint_pos.iter().chain(&b.joint_vel);
        joints
            .zip(other)
            .map(|(x, y)| (x - y).abs())
            .chain([
                (ra.pos - rb.pos).abs().max_element(),
                (ra.lin_vel - rb.lin_vel).abs().max_element(),
                (ra.ang_vel - rb.ang_vel).abs().max_element(),
                ra.rot.angle_between(rb.rot),
            ])
            .fold(0.0f32, f32::max)
    };
    assert!(
        apart(&state, &before) > 0.1,
        "the envs must differ before the write"
    );
    state.write(&mut *sim, 1).expect("the snapshot writes back");
    sim.set_joint_efforts(0, &[0.3, -0.2, 0.3, -0.2])
        .expect("efforts");
    for _ in 0..25 {
        sim.step().expect("step");
    }
    snapshot.capture(&*sim);
    let gap = apart(&snapshot.env_state(&*sim, 0), &snapshot.env_state(&*sim, 1));
    println!("snapshot_replays_a_step[{backend}]: env 1 is {gap:e} from env 0 after 25 steps");
    assert!(gap < 1e-4, "the replayed env is {gap} from the original");
}
