//! Where each quantity lives in the kernel's buffers. The state buffer holds exactly what the
//! backend publishes, laid out as the batched views expect (per articulation: joint positions,
//! velocities, bias forces and applied efforts, `num_envs × dofs` each, then link poses and
//! velocities; per object: pose and velocities), so a readback is one copy. Every section
//! starts at a multiple of 4 floats, so quaternion sections can be viewed as `Quat`s in place.

use std::fmt::Write as _;
use std::ops::Range;

use crate::compile::{CompiledScene, MAX_CONTACTS};

/// An env's fresh input ([`BufferLayout::fresh`]) when its state has not been written since the
/// last step.
pub const NOT_FRESH: f32 = 0.0;
/// The fresh input of an env written since the last step: that step's first substep runs the
/// env's solver without warm starts.
pub const FRESH: f32 = 1.0;
/// Added to the fresh input of the envs a republish publishes, for that dispatch only (the
/// others return at once); subtracted again after it, which restores the flag exactly.
pub const REPUBLISH: f32 = 2.0;

/// The floats of the rows of `env_ids` in a per-env section that starts at float `section`
/// with `per_env` floats per env: the span from the lowest env's row to the end of the
/// highest's (every row in between included); None for no envs.
pub fn env_rows(section: usize, per_env: usize, env_ids: &[usize]) -> Option<Range<usize>> {
    let (lo, hi) = (env_ids.iter().min()?, env_ids.iter().max()?);
    Some(section + lo * per_env..section + (hi + 1) * per_env)
}

/// Float offsets of one articulation's sections in the state and input buffers.
#[derive(Clone, Debug)]
pub struct ArticulationOffsets {
    /// Dofs of this articulation.
    pub dofs: usize,
    /// Links of this articulation.
    pub links: usize,
    /// State: joint positions; velocities, bias forces and applied efforts follow, each
    /// `num_envs × dofs` (padded to 4).
    pub joints: usize,
    /// Length of one joint section (padded).
    pub joint_len: usize,
    /// State: link positions (`× 3`), then quaternions (`× 4`), linear and angular velocities.
    pub link_pos: usize,
    /// State: link quaternions.
    pub link_quat: usize,
    /// State: link linear velocities.
    pub link_lin: usize,
    /// State: link angular velocities.
    pub link_ang: usize,
    /// Inputs: position targets; velocity targets and efforts follow (`joint_len` apart).
    pub inputs: usize,
}

/// Float offsets of one free object's sections in the state buffer.
#[derive(Clone, Debug)]
pub struct ObjectOffsets {
    /// Positions (`num_envs × 3`); quaternions, linear and angular velocities follow.
    pub pos: usize,
    /// Quaternions `(x, y, z, w)`.
    pub quat: usize,
    /// Origin linear velocities.
    pub lin: usize,
    /// Angular velocities.
    pub ang: usize,
}

impl ArticulationOffsets {
    /// State section `k` of the joints (0 positions, 1 velocities, 2 bias forces, 3 applied
    /// efforts) as `(first float, floats per env)`.
    pub fn joint_section(&self, k: usize) -> (usize, usize) {
        (self.joints + k * self.joint_len, self.dofs)
    }

    /// The link state sections (positions, quaternions, linear and angular velocities) as
    /// `(first float, floats per env)`.
    pub fn link_sections(&self) -> [(usize, usize); 4] {
        let (l3, l4) = (3 * self.links, 4 * self.links);
        [
            (self.link_pos, l3),
            (self.link_quat, l4),
            (self.link_lin, l3),
            (self.link_ang, l3),
        ]
    }
}

impl ObjectOffsets {
    /// The object's state sections (position, quaternion, linear and angular velocity) as
    /// `(first float, floats per env)`.
    pub fn sections(&self) -> [(usize, usize); 4] {
        [(self.pos, 3), (self.quat, 4), (self.lin, 3), (self.ang, 3)]
    }
}

/// The whole buffer layout.
#[derive(Clone, Debug)]
pub struct BufferLayout {
    /// Envs.
    pub num_envs: usize,
    /// Per articulation.
    pub articulations: Vec<ArticulationOffsets>,
    /// Per free object.
    pub objects: Vec<ObjectOffsets>,
    /// Floats in the state buffer.
    pub state_len: usize,
    /// Inputs: per-env mass scale of each body (`num_envs × bodies`).
    pub mass_scale: usize,
    /// Inputs: per-env friction of each shape (`num_envs × shapes`).
    pub friction: usize,
    /// Inputs: per-env fresh flag, [`NOT_FRESH`] or [`FRESH`] (state written since the last
    /// step: do not warm-start), plus [`REPUBLISH`] during a republish of some envs.
    pub fresh: usize,
    /// Inputs: per dof (all envs), 1 where the bias forces are added to the effort input.
    pub compensate: usize,
    /// Floats in the input buffer.
    pub inputs_len: usize,
    /// Floats in the warm-start buffer.
    pub warm_len: usize,
}

fn pad4(n: usize) -> usize {
    n.div_ceil(4) * 4
}

impl BufferLayout {
    /// The layout of a compiled scene for `num_envs` envs.
    pub fn new(scene: &CompiledScene, num_envs: usize) -> Self {
        let n = num_envs;
        let mut state = 0;
        let mut inputs = 0;
        let mut articulations = Vec::new();
        for b in &scene.articulations {
            let (links, dofs) = (b.links, b.joint_dofs());
            let joint_len = pad4(n * dofs);
            let joints = state;
            state += 4 * joint_len;
            let link_pos = state;
            let link_quat = link_pos + pad4(n * links * 3);
            let link_lin = link_quat + n * links * 4;
            let link_ang = link_lin + pad4(n * links * 3);
            state = link_ang + pad4(n * links * 3);
            articulations.push(ArticulationOffsets {
                dofs,
                links,
                joints,
                joint_len,
                link_pos,
                link_quat,
                link_lin,
                link_ang,
                inputs,
            });
            inputs += 3 * joint_len;
        }
        let mut objects = Vec::new();
        for _ in &scene.objects {
            let pos = state;
            let quat = pos + pad4(n * 3);
            let lin = quat + n * 4;
            let ang = lin + pad4(n * 3);
            state = ang + pad4(n * 3);
            objects.push(ObjectOffsets {
                pos,
                quat,
                lin,
                ang,
            });
        }
        let mass_scale = inputs;
        let friction = mass_scale + pad4(n * scene.num_bodies());
        let fresh = friction + pad4(n * scene.shapes.len());
        let compensate = fresh + pad4(n);
        let inputs_len = compensate + pad4(scene.dofs.len());
        Self {
            num_envs,
            articulations,
            objects,
            state_len: state.max(4),
            mass_scale,
            friction,
            fresh,
            compensate,
            inputs_len,
            warm_len: n * MAX_CONTACTS * 4,
        }
    }

    /// Every section of the state as `(first float, floats per env)`: env `e`'s row of a
    /// section is `first + e · width .. first + (e + 1) · width`.
    pub fn env_sections(&self) -> Vec<(usize, usize)> {
        let mut sections = Vec::new();
        for a in &self.articulations {
            sections.extend((0..4).map(|k| a.joint_section(k)));
            sections.extend(a.link_sections());
        }
        for o in &self.objects {
            sections.extend(o.sections());
        }
        sections
    }

    /// The `lay` table of env-count-dependent offsets the kernel reads: env count, the input
    /// offsets (mass scale, friction, fresh, compensation), then per dof the state base, section length and input base, per link the
    /// articulation's link block, per object its block (positions given by [`lay_constants`]).
    pub fn table(&self, scene: &CompiledScene) -> Vec<u32> {
        let mut t = vec![
            self.num_envs as u32,
            self.mass_scale as u32,
            self.friction as u32,
            self.fresh as u32,
            self.compensate as u32,
        ];
        // One entry per dof of the kernel; a floating root's dofs are not in the state buffer
        // and get 0.
        let per_dof = |f: &dyn Fn(&ArticulationOffsets, usize) -> usize| -> Vec<u32> {
            let mut out = vec![0; scene.dofs.len()];
            for (a, b) in scene.articulations.iter().enumerate() {
                for i in 0..b.joint_dofs() {
                    out[b.joint_dof0() + i] = f(&self.articulations[a], i) as u32;
                }
            }
            out
        };
        t.extend(per_dof(&|o, i| o.joints + i));
        t.extend(per_dof(&|o, _| o.joint_len));
        t.extend(per_dof(&|o, i| o.inputs + i));
        for (a, b) in scene.articulations.iter().enumerate() {
            t.extend(std::iter::repeat_n(
                self.articulations[a].link_pos as u32,
                b.links,
            ));
        }
        t.extend(self.objects.iter().map(|o| o.pos as u32));
        t
    }
}

/// The positions of the `lay` table's parts, as WGSL constants.
pub fn lay_constants(scene: &CompiledScene) -> String {
    let (nd, nl) = (scene.dofs.len(), scene.links.len());
    let mut s = String::new();
    let mut c = |name: &str, v: usize| {
        writeln!(s, "const {name} = {v}u;").expect("write to string");
    };
    c("LAY_NUM_ENVS", 0);
    c("LAY_IN_MASS_SCALE", 1);
    c("LAY_IN_FRICTION", 2);
    c("LAY_IN_FRESH", 3);
    c("LAY_IN_COMPENSATE", 4);
    c("LAY_D_BASE", 5);
    c("LAY_D_SECTION", 5 + nd);
    c("LAY_D_IBASE", 5 + 2 * nd);
    c("LAY_L_BLOCK", 5 + 3 * nd);
    c("LAY_O_BLOCK", 5 + 3 * nd + nl);
    s
}

#[cfg(test)]
mod tests {
    use super::env_rows;

    /// The span runs from the lowest env's first float to the highest env's last, whatever
    /// the order of the ids, and covers the rows in between.
    #[test]
    fn env_rows_spans_lowest_to_highest_env() {
        assert_eq!(env_rows(10, 3, &[4, 1, 2]), Some(13..25));
        assert_eq!(env_rows(0, 7, &[5]), Some(35..42));
        assert_eq!(env_rows(10, 3, &[]), None);
    }
}
