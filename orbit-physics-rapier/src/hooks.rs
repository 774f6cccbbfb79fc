//! Contact rules rapier's built-in ones cannot express: friction mixing by priority (MuJoCo's
//! rule: a contact takes the friction of the higher-priority shape, or the larger one when
//! priorities are equal) and self-collision filtering of links that an articulation's
//! [`collision_parent`](orbit_core::scene::ArticulationModel::collision_parent) joins (rapier
//! filters only links joined directly by a joint, and only when asked per joint).
//!
//! A collider's `user_data` packs its material in the low 64 bits and, for a link of an
//! articulation with self-collisions, a [`SelfCollisionKey`] above them.

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

/// Which link of which articulation a collider belongs to, and that link's collision parent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SelfCollisionKey {
    /// The articulation's index in its env.
    pub articulation: u32,
    /// The link's index in its articulation.
    pub link: u32,
    /// The link's collision parent, if any.
    pub parent: Option<u32>,
}

impl SelfCollisionKey {
    /// `user_data` with `data`'s material and this key.
    pub fn encode(self, data: u128) -> u128 {
        let parent = self.parent.map_or(0, |p| u128::from(p) + 1);
        let key =
            1 | u128::from(self.articulation) << 1 | u128::from(self.link) << 17 | parent << 33;
        (data & u128::from(u64::MAX)) | key << 64
    }

    fn decode(data: u128) -> Option<Self> {
        let key = (data >> 64) as u64;
        (key & 1 == 1).then(|| SelfCollisionKey {
            articulation: (key >> 1) as u32 & 0xffff,
            link: (key >> 17) as u32 & 0xffff,
            parent: ((key >> 33) as u32).checked_sub(1),
        })
    }
}

/// The physics hooks of every env world.
pub(crate) struct ContactHooks;

impl PhysicsHooks for ContactHooks {
    fn filter_contact_pair(&self, context: &PairFilterContext) -> Option<SolverFlags> {
        let key = |c: ColliderHandle| SelfCollisionKey::decode(context.colliders[c].user_data);
        if let (Some(a), Some(b)) = (key(context.collider1), key(context.collider2))
            && a.articulation == b.articulation
            && (a.parent == Some(b.link) || b.parent == Some(a.link))
        {
            return None;
        }
        Some(SolverFlags::default())
    }

    fn modify_solver_contacts(&self, context: &mut ContactModificationContext) {
        let m1 = decode_material(context.colliders[context.collider1].user_data);
        let m2 = decode_material(context.colliders[context.collider2].user_data);
        let friction = m1.combined_friction(&m2);
        if let Some(manifold) = context.rigid_mut() {
            *manifold.friction = friction;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A key survives the round trip through `user_data` beside the material.
    #[test]
    fn keys_and_materials_share_user_data() {
        let material = Material {
            friction: 0.7,
            restitution: 0.0,
            priority: -3,
        };
        for parent in [None, Some(0), Some(24)] {
            let key = SelfCollisionKey {
                articulation: 2,
                link: 25,
                parent,
            };
            let data = key.encode(encode_material(&material));
            assert_eq!(SelfCollisionKey::decode(data), Some(key));
            assert_eq!(decode_material(data), material);
        }
        assert_eq!(SelfCollisionKey::decode(encode_material(&material)), None);
    }
}
