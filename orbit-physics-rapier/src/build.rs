//! Building one env's rapier world: colliders from shapes, rigid bodies, and articulations as
//! multibodies (a floating base's root body centred on its centre of mass).

use glam::{Quat, Vec3};
use orbit_core::kinematics::ArticulationKinematics;
use orbit_core::math::Pose as OrbitPose;
use orbit_core::physics::PhysicsError;
use orbit_core::scene::{ArticulationDesc, Geometry, Inertial, JointKind, RigidBodyModel, Shape};
use rapier3d::prelude::*;

use crate::env_world::{ArticulationRow, EnvArticulation, MAX_DOFS};
use crate::hooks::{SelfCollisionKey, encode_material};

pub(crate) fn to_rapier_pose(p: &OrbitPose) -> Pose {
    Pose::from_parts(p.pos, p.rot)
}

/// Rapier cylinders are y-aligned; ours are z-aligned.
fn z_to_y() -> Quat {
    Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)
}

fn collider_for(shape: &Shape) -> ColliderBuilder {
    let (builder, local) = match shape.geometry {
        Geometry::Sphere { radius } => (ColliderBuilder::ball(radius), Quat::IDENTITY),
        Geometry::Capsule {
            radius,
            half_length,
        } => (
            ColliderBuilder::capsule_z(half_length, radius),
            Quat::IDENTITY,
        ),
        Geometry::Box { half_extents: h } => {
            (ColliderBuilder::cuboid(h.x, h.y, h.z), Quat::IDENTITY)
        }
        Geometry::Cylinder {
            radius,
            half_length,
        } => (ColliderBuilder::cylinder(half_length, radius), z_to_y()),
        Geometry::Plane => (
            ColliderBuilder::halfspace(rapier3d::na::Unit::new_unchecked(Vec3::Z)),
            Quat::IDENTITY,
        ),
    };
    let pose = OrbitPose::new(shape.pose.pos, shape.pose.rot * local);
    let mut hooks = ActiveHooks::empty();
    if shape.material.priority != 0 {
        hooks |= ActiveHooks::MODIFY_SOLVER_CONTACTS;
    }
    builder
        .position(to_rapier_pose(&pose))
        .density(0.0)
        .friction(shape.material.friction)
        .friction_combine_rule(CoefficientCombineRule::Max)
        .restitution(shape.material.restitution)
        .collision_groups(InteractionGroups::new(
            Group::from_bits_truncate(shape.filter.groups),
            Group::from_bits_truncate(shape.filter.mask),
            InteractionTestMode::And,
        ))
        .active_hooks(hooks)
        .user_data(encode_material(&shape.material))
}

pub(crate) fn mass_props(i: &Inertial) -> MassProperties {
    MassProperties::with_inertia_matrix(i.com, i.mass, i.inertia)
}

fn add_shapes(world: &mut PhysicsWorld, body: RigidBodyHandle, shapes: &[Shape]) {
    for s in shapes {
        world
            .colliders
            .insert_with_parent(collider_for(s), body, &mut world.bodies);
    }
}

pub(crate) fn add_body(
    world: &mut PhysicsWorld,
    model: &RigidBodyModel,
    pose: &OrbitPose,
    dynamic: bool,
) -> RigidBodyHandle {
    let builder = if dynamic {
        RigidBodyBuilder::dynamic().additional_mass_properties(mass_props(&model.inertial))
    } else {
        RigidBodyBuilder::fixed()
    };
    let body = world
        .bodies
        .insert(builder.pose(to_rapier_pose(pose)).can_sleep(false));
    add_shapes(world, body, &model.shapes);
    // Fold the mass properties in now, not at the first step: a state write before then
    // converts the velocity of the body origin with the centre of mass.
    world.bodies[body].recompute_mass_properties_from_colliders(&world.colliders);
    body
}

/// The joint between a link and its parent, as a rapier generic joint. Rapier's revolute and
/// prismatic joints move about/along the joint frame's x axis.
fn rapier_joint(
    origin: &OrbitPose,
    axis: Vec3,
    kind: JointKind,
    limits: Option<[f32; 2]>,
) -> GenericJoint {
    let x_to_axis = Quat::from_rotation_arc(Vec3::X, axis.normalize());
    let locked = match kind {
        JointKind::Revolute => JointAxesMask::LOCKED_REVOLUTE_AXES,
        JointKind::Prismatic => JointAxesMask::LOCKED_PRISMATIC_AXES,
        JointKind::Fixed => JointAxesMask::LOCKED_FIXED_AXES,
    };
    let mut builder = GenericJointBuilder::new(locked)
        .local_frame1(Pose::from_parts(origin.pos, origin.rot * x_to_axis))
        .local_frame2(Pose::from_parts(Vec3::ZERO, x_to_axis));
    if let Some(l) = limits {
        let axis = if kind == JointKind::Revolute {
            JointAxis::AngX
        } else {
            JointAxis::LinX
        };
        builder = builder.limits(axis, l);
    }
    builder.build()
}

/// Builds articulation `index` of an env.
pub(crate) fn build_articulation(
    world: &mut PhysicsWorld,
    desc: &ArticulationDesc,
    index: usize,
) -> Result<EnvArticulation, PhysicsError> {
    let model = &desc.model;
    let mut kin = ArticulationKinematics::new(model);
    let poses = kin
        .forward(&desc.root_pose, &desc.default_joint_pos)
        .to_vec();
    // A floating root's rigid body has its origin at the link's centre of mass: rapier moves a
    // free root's origin with the velocity of its centre of mass.
    let root_com = if desc.fixed_base {
        Vec3::ZERO
    } else {
        model.links[0].inertial.com
    };
    let to_root_body = OrbitPose::from_pos(-root_com);
    let mut links = Vec::with_capacity(model.links.len());
    for (i, link) in model.links.iter().enumerate() {
        let mut body = RigidBodyModel {
            name: link.name.clone(),
            inertial: link.inertial,
            shapes: link.shapes.clone(),
        };
        let mut pose = poses[i];
        if i == 0 && !desc.fixed_base {
            body.inertial.com = Vec3::ZERO;
            for s in &mut body.shapes {
                s.pose = to_root_body.mul_pose(&s.pose);
            }
            pose = pose.mul_pose(&OrbitPose::from_pos(root_com));
        }
        links.push(add_body(world, &body, &pose, i > 0 || !desc.fixed_base));
    }
    let mut dof_mb_link = Vec::new();
    let mut dof_axis = Vec::new();
    let mut dof_link = Vec::new();
    let mut multibody = None;
    for (i, link) in model.links.iter().enumerate().skip(1) {
        let (Some(parent), Some(joint)) = (link.parent, &link.joint) else {
            unreachable!("validated model: every non-root link has a parent joint")
        };
        let origin = if parent == 0 {
            to_root_body.mul_pose(&joint.origin)
        } else {
            joint.origin
        };
        let gj = rapier_joint(&origin, joint.axis, joint.kind, joint.limits);
        let handle = world
            .multibody_joints
            .insert(links[parent], links[i], gj, false)
            .ok_or_else(|| PhysicsError::Unsupported {
                backend: "rapier".into(),
                reason: format!(
                    "could not add joint `{}` of `{}` to a multibody",
                    joint.name, desc.name
                ),
            })?;
        let (mb, link_id) = world
            .multibody_joints
            .get(handle)
            .map(|(mb, id)| (mb.root().rigid_body_handle(), id))
            .expect("joint just inserted");
        let index = world
            .multibody_joints
            .rigid_body_link(mb)
            .expect("root is a multibody link")
            .multibody;
        multibody = Some(index);
        if joint.kind != JointKind::Fixed {
            dof_mb_link.push(link_id);
            dof_axis.push(if joint.kind == JointKind::Revolute {
                3
            } else {
                0
            });
            dof_link.push(i);
        }
    }
    // A floating base adds its six free dofs in front of the joints' in the multibody.
    let root_dofs = if desc.fixed_base { 0 } else { 6 };
    if dof_link.len() + root_dofs > MAX_DOFS {
        return Err(PhysicsError::Unsupported {
            backend: "rapier".into(),
            reason: format!(
                "articulation `{}` has {} dofs; at most {MAX_DOFS} are supported",
                desc.name,
                dof_link.len() + root_dofs
            ),
        });
    }
    let multibody = multibody.ok_or_else(|| PhysicsError::Unsupported {
        backend: "rapier".into(),
        reason: format!(
            "articulation `{}` has a single link; use a static or rigid object",
            desc.name
        ),
    })?;
    let mb = world
        .multibody_joints
        .get_multibody_mut(multibody)
        .expect("multibody exists");
    mb.set_self_contacts_enabled(desc.self_collisions);
    if desc.self_collisions {
        // Links and their collision parents must not touch (the filter hook drops them).
        for (l, &body) in links.iter().enumerate() {
            let key = SelfCollisionKey {
                articulation: index as u32,
                link: l as u32,
                parent: model.collision_parent(l).map(|p| p as u32),
            };
            for &c in world.bodies[body].colliders() {
                let collider = &mut world.colliders[c];
                collider.user_data = key.encode(collider.user_data);
                collider
                    .set_active_hooks(collider.active_hooks() | ActiveHooks::FILTER_CONTACT_PAIRS);
            }
        }
    }
    // Rapier gives new angular dofs a default damping of 0.1; use the model's values instead.
    mb.damping_mut().fill(0.0);
    for (d, &l) in dof_link.iter().enumerate() {
        let j = model.links[l].joint.as_ref().expect("dof link has a joint");
        let id = mb.link(dof_mb_link[d]).expect("link exists").assembly_id();
        mb.damping_mut()[id] = j.damping;
        mb.armature_mut()[id] = j.armature;
        mb.frictions_mut()[id] = j.friction;
    }
    let n_links = model.links.len();
    let n_dofs = dof_link.len();
    let joint_damping = dof_link
        .iter()
        .map(|&l| model.links[l].joint.as_ref().map_or(0.0, |j| j.damping))
        .collect();
    let springs = dof_link
        .iter()
        .map(|&l| {
            let j = model.links[l].joint.as_ref().expect("dof link has a joint");
            (j.spring_stiffness, j.spring_ref)
        })
        .collect();
    Ok(EnvArticulation {
        links,
        multibody,
        dof_mb_link,
        dof_axis,
        dof_link,
        kin,
        root: desc.root_pose,
        fixed_base: desc.fixed_base,
        root_com,
        out: ArticulationRow::new(n_dofs, n_links),
        joint_damping,
        springs,
        effort: vec![0.0; n_dofs],
    })
}
