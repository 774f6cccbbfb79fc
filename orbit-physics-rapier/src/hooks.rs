//! Contact friction mixing by priority (MuJoCo's rule), which rapier's combine rules cannot
//! express: a contact takes the friction of the higher-priority shape, or the larger one when
//! priorities are equal.

use orbit_core::scene::Material;
use rapier3d::prelude::*;

/// Packs a material's priority and friction into a collider's `user_data`.
pub(crate) fn encode_material(m: &Material) -> u128 {
    (u128::from(m.priority as u32) << 32) | u128::from(m.friction.to_bits())
}

fn decode_material(data: u128) -> Material {
    Material {
        friction: f32::from_bits(data as u32),
        restitution: 0.0,
        priority: (data >> 32) as u32 as i32,
    }
}

/// Physics hooks that rewrite contact friction for pairs involving a prioritised shape.
pub(crate) struct FrictionPriority;

impl PhysicsHooks for FrictionPriority {
    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        let m1 = decode_material(context.colliders[context.collider1].user_data);
        let m2 = decode_material(context.colliders[context.collider2].user_data);
        let friction = m1.combined_friction(&m2);
        if let Some(manifold) = context.rigid_mut() {
            *manifold.friction = friction;
        }
    }
}
