//! Kernel generation: the scene-specific half of the WGSL kernel, written from the compiled
//! scene as straight-line code.
//!
//! Every env shares one topology, so each loop over links, dofs, free objects and shape pairs
//! can be unrolled here, with the scene's numbers as literals and every array index a constant.
//! The driver then keeps the articulation's quantities in registers instead of the local memory
//! that run-time indexed tables need, drops work on structural zeros (a root link's inertia,
//! mass-matrix entries off the kinematic chain, a torque-driven joint's drive terms). The
//! narrow phase stays a loop over the scene's geometry table (a uniform buffer, see
//! [`CompiledScene::geometry_table`]): unrolled per shape pair it would be tens of thousands of
//! instructions, more than an instruction cache holds. `step.wgsl`, the scene-independent half,
//! is appended to what this module writes.
//!
//! This module is the driver (the order of the sections, the writer and the scene's topology
//! queries they share, WGSL literals); each section of the kernel has its own module.

mod articulation;
mod constants;
mod constraints;
mod integrate;
mod objects;
mod state_io;

use glam::{Mat3, Quat, Vec3};
use orbit_core::physics::SimCfg;

use crate::compile::CompiledScene;

/// The full WGSL source of the step kernel for `scene`, with `workgroup` invocations per
/// workgroup.
pub fn kernel_source(scene: &CompiledScene, sim: &SimCfg, workgroup: usize) -> String {
    let mut g = Gen {
        scene,
        out: String::new(),
        indent: 0,
    };
    g.constants(sim, workgroup);
    g.state_io();
    g.kinematics();
    g.rnea_bias();
    g.crba();
    g.cholesky();
    g.drives();
    g.objects();
    g.collide();
    g.jacobians();
    g.limit_rows();
    g.integrate();
    g.out + include_str!("../step.wgsl")
}

/// The WGSL writer: the scene, the text so far and the current indentation.
struct Gen<'a> {
    scene: &'a CompiledScene,
    out: String,
    indent: usize,
}

impl Gen<'_> {
    fn line(&mut self, text: impl AsRef<str>) {
        for _ in 0..self.indent {
            self.out.push_str("    ");
        }
        self.out.push_str(text.as_ref());
        self.out.push('\n');
    }

    fn open(&mut self, text: impl AsRef<str>) {
        self.line(format!("{} {{", text.as_ref()));
        self.indent += 1;
    }

    fn close(&mut self) {
        self.indent -= 1;
        self.line("}");
    }

    /// Closes a block and opens the next one of the same statement (`} else {`).
    fn reopen(&mut self, text: impl AsRef<str>) {
        self.indent -= 1;
        self.line(format!("}} {} {{", text.as_ref()));
        self.indent += 1;
    }

    fn nd(&self) -> usize {
        self.scene.dofs.len()
    }

    /// The articulation `(first dof, dofs)` that dof `d` belongs to.
    fn dof_block(&self, d: usize) -> (usize, usize) {
        self.scene
            .articulations
            .iter()
            .find(|&&(_, _, d0, n)| (d0..d0 + n).contains(&d))
            .map(|&(_, _, d0, n)| (d0, n))
            .expect("every dof belongs to an articulation")
    }

    /// The links from `l` up to its articulation's root that carry a dof, child first.
    fn chain(&self, l: usize) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        let mut at = Some(l);
        while let Some(k) = at {
            if let Some(d) = self.scene.links[k].dof {
                out.push((k, d));
            }
            at = self.scene.links[k].parent;
        }
        out
    }
}

/// A WGSL float literal (infinities become ±3.4e38, which compare the same in every test made).
fn f(x: f32) -> String {
    if x.is_infinite() {
        return if x > 0.0 {
            "3.4e38".into()
        } else {
            "(-3.4e38)".into()
        };
    }
    let s = format!("{x:?}");
    // `-0.0` and friends need parentheses after a binary minus; keep every negative literal
    // wrapped.
    if x.is_sign_negative() {
        format!("({s})")
    } else {
        s
    }
}

fn v3(v: Vec3) -> String {
    format!("vec3<f32>({}, {}, {})", f(v.x), f(v.y), f(v.z))
}

fn q4(q: Quat) -> String {
    format!("vec4<f32>({}, {}, {}, {})", f(q.x), f(q.y), f(q.z), f(q.w))
}

fn m3(m: Mat3) -> String {
    format!(
        "mat3x3<f32>({}, {}, {})",
        v3(m.x_axis),
        v3(m.y_axis),
        v3(m.z_axis)
    )
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use orbit_conformance::{free_box, passive_articulation, pendulum, resolve, table};
    use orbit_core::physics::SimCfg;
    use orbit_core::scene::{RootStateCfg, SceneCfg};

    use super::kernel_source;
    use crate::compile::CompiledScene;

    /// Parses and validates a scene's kernel with naga (what wgpu does before any driver sees
    /// it), so a generator mistake fails here, with or without a GPU.
    fn validate(cfg: &SceneCfg) -> String {
        let scene = CompiledScene::new(&resolve(cfg)).expect("scene compiles");
        let src = kernel_source(&scene, &SimCfg::default(), 64);
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::default(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
        src
    }

    #[test]
    fn box_pushing_kernel_is_valid_wgsl() {
        let src = validate(&orbit_conformance::box_pushing_scene_cfg());
        if let Ok(path) = std::env::var("ORBIT_DUMP_KERNEL") {
            std::fs::write(path, &src).expect("write the kernel");
        }
        // The articulation is straight-line code: no link table is indexed at run time.
        assert!(!src.contains("L_PARENT") && src.contains("lpos[7]"));
    }

    /// A floating base is refused, with an error naming the backend that simulates it.
    #[test]
    fn floating_bases_are_refused() {
        let mut art = passive_articulation(orbit_conformance::floating_tree());
        art.fixed_base = false;
        let cfg = SceneCfg {
            env_spacing: 2.0,
            articulations: vec![art],
            rigid_objects: vec![],
            static_objects: vec![],
        };
        match CompiledScene::new(&resolve(&cfg)) {
            Ok(_) => panic!("a floating base compiled"),
            Err(e) => {
                let e = e.to_string();
                assert!(e.contains("floating base") && e.contains("rapier"), "{e}");
            }
        }
    }

    #[test]
    fn kernels_of_small_scenes_are_valid_wgsl() {
        let init = RootStateCfg {
            pos: Vec3::new(0.0, 0.0, 0.1),
            ..RootStateCfg::default()
        };
        // An articulation alone (no objects, no contacts), then free bodies alone (no dofs).
        validate(&SceneCfg {
            env_spacing: 2.0,
            articulations: vec![passive_articulation(pendulum(1.0, 0.5, 0.05, 1.0))],
            rigid_objects: vec![],
            static_objects: vec![],
        });
        validate(&SceneCfg {
            env_spacing: 2.0,
            articulations: vec![],
            rigid_objects: vec![free_box("box", Vec3::splat(0.05), 1.0, 0.5, init)],
            static_objects: vec![table(0.0, 0.5)],
        });
    }
}
