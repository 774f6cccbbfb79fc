//! Inverse weights at the reference configuration (all joints at 0, a floating root at its
//! initial pose): MuJoCo's
//! `body_invweight0` (translational part) and `dof_invweight0`. MuJoCo scales a soft
//! constraint's regulariser by these fixed numbers rather than by the row's exact
//! `J M⁻¹ Jᵀ` (see `normal_row` in step/constraints.wgsl), so the contact softness does not change as the
//! arm moves; this backend does the same to follow MuJoCo's contact dynamics.

use glam::{DMat3, DVec3};
use orbit_core::math::{Pose, rotate_inertia};
use orbit_core::scene::JointKind;

use crate::compile::CompiledScene;

/// Translational inverse weight of every body (links, then free objects; 0 for a link that
/// cannot move) and the inverse weight of every dof, at the reference configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct InverseWeights {
    /// Per body: the mean of the diagonal of `J M⁻¹ Jᵀ` for the translation of its centre of
    /// mass (1/m for a free object).
    pub body: Vec<f32>,
    /// Per dof: the diagonal of `M⁻¹`.
    pub dof: Vec<f32>,
}

impl InverseWeights {
    /// Computes the weights of a compiled scene.
    pub fn new(scene: &CompiledScene) -> Self {
        let nd = scene.dofs.len();
        let links = &scene.links;
        // Link poses with every joint at 0, and each link's joint position and world axis.
        let mut poses: Vec<Pose> = Vec::with_capacity(links.len());
        for l in links {
            let pose = match l.parent {
                Some(p) => poses[p].mul_pose(&l.origin),
                None => l.origin,
            };
            poses.push(pose);
        }
        // Translational Jacobian of the centre of mass of each link (nd columns), rotational
        // Jacobian (world frame).
        let jacobian = |k: usize, point: DVec3| {
            let mut jp = vec![DVec3::ZERO; nd];
            let mut jr = vec![DVec3::ZERO; nd];
            let mut at = Some(k);
            while let Some(i) = at {
                if let Some(root) = links[i].free_root {
                    // Translations of the root's centre of mass, rotations about it.
                    let c = poses[i].transform_point(links[i].inertial.com).as_dvec3();
                    for (axis, e) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
                        jp[root.dof0 + axis] = e;
                        jp[root.dof0 + 3 + axis] = e.cross(point - c);
                        jr[root.dof0 + 3 + axis] = e;
                    }
                }
                if let Some(d) = links[i].dof {
                    let s = (poses[i].rot * links[i].axis).as_dvec3();
                    match links[i].kind {
                        JointKind::Revolute => {
                            jp[d] = s.cross(point - poses[i].pos.as_dvec3());
                            jr[d] = s;
                        }
                        JointKind::Prismatic => jp[d] = s,
                        JointKind::Fixed => {}
                    }
                }
                at = links[i].parent;
            }
            (jp, jr)
        };
        let coms: Vec<DVec3> = links
            .iter()
            .zip(&poses)
            .map(|(l, p)| p.transform_point(l.inertial.com).as_dvec3())
            .collect();
        let jacobians: Vec<_> = (0..links.len()).map(|k| jacobian(k, coms[k])).collect();
        // M = Σ m Jpᵀ Jp + Jrᵀ I Jr, plus the armature.
        let mut m = vec![0.0f64; nd * nd];
        for (k, l) in links.iter().enumerate() {
            let (jp, jr) = &jacobians[k];
            let inertia: DMat3 = rotate_inertia(poses[k].rot, l.inertial.inertia).as_dmat3();
            let mass = f64::from(l.inertial.mass);
            for a in 0..nd {
                for b in 0..nd {
                    m[a * nd + b] += mass * jp[a].dot(jp[b]) + jr[a].dot(inertia * jr[b]);
                }
            }
        }
        for (d, dof) in scene.dofs.iter().enumerate() {
            m[d * nd + d] += f64::from(dof.armature);
        }
        let minv = invert(&m, nd);
        let dof = (0..nd).map(|d| minv[d * nd + d] as f32).collect();
        let mut body: Vec<f32> = jacobians
            .iter()
            .map(|(jp, _)| {
                let mut trace = 0.0;
                for a in 0..nd {
                    for b in 0..nd {
                        trace += jp[a].dot(jp[b]) * minv[a * nd + b];
                    }
                }
                (trace / 3.0) as f32
            })
            .collect();
        body.extend(scene.objects.iter().map(|o| 1.0 / o.mass));
        Self { body, dof }
    }
}

/// Inverse of a symmetric positive-definite `n × n` matrix (row-major) by Gauss–Jordan
/// elimination; a singular block (a dof without inertia) gets 0.
fn invert(m: &[f64], n: usize) -> Vec<f64> {
    let mut a = m.to_vec();
    let mut inv = vec![0.0; n * n];
    for i in 0..n {
        inv[i * n + i] = 1.0;
    }
    for c in 0..n {
        let pivot = a[c * n + c];
        if pivot.abs() < 1e-12 {
            continue;
        }
        for j in 0..n {
            a[c * n + j] /= pivot;
            inv[c * n + j] /= pivot;
        }
        for r in 0..n {
            let f = a[r * n + c];
            if r != c && f != 0.0 {
                for j in 0..n {
                    a[r * n + j] -= f * a[c * n + j];
                    inv[r * n + j] -= f * inv[c * n + j];
                }
            }
        }
    }
    inv
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use orbit_conformance::{free_box, passive_articulation, pendulum, resolve};
    use orbit_core::scene::{RootStateCfg, SceneCfg};

    use super::InverseWeights;
    use crate::compile::CompiledScene;

    /// A pendulum of mass m at distance l (sphere inertia I about its centre) has M = m l² + I
    /// about its hinge, and its bob's centre moves along one axis with J = l; a free box weighs
    /// 1/m in every direction.
    #[test]
    fn pendulum_and_free_box_weights() {
        let (m, l, r) = (2.0f32, 0.5f32, 0.05f32);
        let box_mass = 3.0;
        let cfg = SceneCfg {
            env_spacing: 2.0,
            articulations: vec![passive_articulation(pendulum(m, l, r, 1.0))],
            rigid_objects: vec![free_box(
                "box",
                Vec3::splat(0.05),
                box_mass,
                0.5,
                RootStateCfg::default(),
            )],
            static_objects: vec![],
        };
        let scene = CompiledScene::new(&resolve(&cfg)).expect("scene compiles");
        let w = InverseWeights::new(&scene);
        let hinge = m * l * l + 0.4 * m * r * r;
        assert_eq!(w.dof.len(), 1);
        assert!((w.dof[0] - 1.0 / hinge).abs() < 1e-6 / hinge);
        // Links: the fixed pivot, the bob; then the box.
        assert_eq!(w.body.len(), 3);
        assert_eq!(w.body[0], 0.0);
        let bob = l * l / hinge / 3.0;
        assert!(
            (w.body[1] - bob).abs() < 1e-6 * bob,
            "{} vs {bob}",
            w.body[1]
        );
        assert!((w.body[2] - 1.0 / box_mass).abs() < 1e-7);
    }
}
