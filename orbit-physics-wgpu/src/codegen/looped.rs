//! The kernel's looped form: the scene's links and dofs as tables that the loops of
//! `step/articulation_loops.wgsl` read, and the few scene-specific pieces those loops call
//! (free objects, the rows' storage and arm parts, the tree factorisation).

use orbit_core::scene::JointKind;

use super::{Gen, f, m3, q4, v3};
use crate::compile::DofData;

/// One number of a dof, for its table.
type DofField = fn(&DofData) -> f32;

impl Gen<'_> {
    /// Everything of the articulation that the looped form generates: tables, the root state,
    /// the factorisation, the rows' arm parts and the free objects' state I/O and integration.
    pub(super) fn looped_articulation(&mut self) {
        let roots: Vec<usize> = self.scene.free_roots().map(|(l, _)| l).collect();
        self.line(format!("const NR = {}u;", roots.len()));
        self.line(format!("const NR1 = {}u;", roots.len().max(1)));
        self.line(
            "// Floating roots: the root link's centre of mass (its orientation is in lrot).",
        );
        self.line("var<private> fcom: array<vec3<f32>, NR1>;");
        self.line("// The env-frame position of the kernel's frame origin (zero unless SHIFTED).");
        self.line("var<private> shift: vec3<f32>;");
        self.link_tables();
        self.dof_tables();
        let root_links: Vec<String> = roots.iter().map(|l| format!("{l}u")).collect();
        self.table("root_link", "u32", "NR1", root_links, "0u");
        self.line("");
        self.dof_parent_table();
        self.cholesky();
        self.arm_rows();
        self.open("fn load_objects()");
        self.load_object_lines();
        self.close();
        self.open("fn publish_objects()");
        self.publish_object_lines();
        self.close();
        self.open("fn integrate_objects()");
        self.integrate_object_lines();
        self.close();
        self.line("");
    }

    /// A private array initialised with `values` (`empty` alone if there are none).
    fn table(&mut self, name: &str, ty: &str, len: &str, values: Vec<String>, empty: &str) {
        let values = if values.is_empty() {
            empty.to_string()
        } else {
            values.join(", ")
        };
        self.line(format!(
            "var<private> {name}: array<{ty}, {len}> = array<{ty}, {len}>({values});"
        ));
    }

    /// Per link: kind, parent, first dof and dofs, joint frame and axis, mass properties, its
    /// place in the state buffer.
    fn link_tables(&mut self) {
        let s = self.scene;
        let fixed = |l: usize| s.is_fixed_body(l);
        let mut kind = Vec::new();
        let mut parent = Vec::new();
        let mut moving_parent = Vec::new();
        let mut dof = Vec::new();
        let mut dofs = Vec::new();
        let mut chain_dof = Vec::new();
        let mut root = Vec::new();
        for (l, link) in s.links.iter().enumerate() {
            let (k, d0, n, r) = match (link.parent, link.free_root) {
                (None, Some(fr)) => (1, fr.dof0, 6, fr.index),
                (None, None) => (0, 0, 0, 0),
                (Some(_), _) => {
                    let d = link.dof.expect("non-root links have a dof");
                    let k = if link.kind == JointKind::Prismatic {
                        3
                    } else {
                        2
                    };
                    (k, d, 1, 0)
                }
            };
            kind.push(format!("{k}u"));
            parent.push(link.parent.map_or(-1, |p| p as i32).to_string());
            let mp = link.parent.filter(|&p| !fixed(p));
            moving_parent.push(mp.map_or(-1, |p| p as i32).to_string());
            dof.push(format!("{d0}u"));
            dofs.push(format!("{n}u"));
            // The first dof on the chain from this link to the root: the tree walks start there.
            chain_dof.push(self.chain(l).first().map_or(-1, |&d| d as i32).to_string());
            root.push(format!("{r}u"));
        }
        let links = &s.links;
        let col = |g: &dyn Fn(usize) -> String| (0..links.len()).map(g).collect::<Vec<_>>();
        self.line(
            "// The scene's links: kind (LINK_*), parent, first dof and dofs, joint frame in",
        );
        self.line("// the parent and axis, mass properties, place in the state buffer.");
        self.table("link_kind", "u32", "NL1", kind, "0u");
        self.table("link_parent", "i32", "NL1", parent, "-1");
        self.table("link_moving_parent", "i32", "NL1", moving_parent, "-1");
        self.table("link_dof", "u32", "NL1", dof, "0u");
        self.table("link_dofs", "u32", "NL1", dofs, "0u");
        self.table("link_chain_dof", "i32", "NL1", chain_dof, "-1");
        self.table("link_root", "u32", "NL1", root, "0u");
        let opos = col(&|l| {
            // A fixed root's pose is in the env frame; the others' in their parent.
            v3(links[l].origin.pos)
        });
        self.table("link_opos", "vec3<f32>", "NL1", opos, "vec3<f32>()");
        let orot = col(&|l| q4(links[l].origin.rot));
        self.table("link_orot", "vec4<f32>", "NL1", orot, "vec4<f32>()");
        let axis = col(&|l| v3(links[l].axis));
        self.table("link_axis", "vec3<f32>", "NL1", axis, "vec3<f32>()");
        let mass = col(&|l| f(links[l].inertial.mass));
        self.table("link_mass", "f32", "NL1", mass, "0.0");
        let com = col(&|l| v3(links[l].inertial.com));
        self.table("link_com", "vec3<f32>", "NL1", com, "vec3<f32>()");
        let inertia = col(&|l| m3(links[l].inertial.inertia));
        self.table(
            "link_inertia",
            "mat3x3<f32>",
            "NL1",
            inertia,
            "mat3x3<f32>()",
        );
        let block: Vec<String> = self
            .link_strides()
            .iter()
            .map(|&(_, links, local)| format!("vec2<u32>({links}u, {local}u)"))
            .collect();
        self.table("link_block", "vec2<u32>", "NL1", block, "vec2<u32>()");
    }

    /// Per dof: its link and root axis, its articulation's stride in the state buffer, its
    /// drive, damping, armature, limits and spring.
    fn dof_tables(&mut self) {
        let s = self.scene;
        let nd = s.dofs.len();
        let col = |g: &dyn Fn(usize) -> String| (0..nd).map(g).collect::<Vec<_>>();
        let dofs = &s.dofs;
        self.line(
            "// The scene's dofs: link, root axis (-1 for a joint), the articulation's joint",
        );
        self.line("// dofs (the state buffer's stride), drive, damping, armature and limits.");
        let link = col(&|d| format!("{}u", self.dof_link(d)));
        self.table("dof_link", "u32", "ND1", link, "0u");
        let axis = col(&|d| dofs[d].root_axis.map_or(-1, |a| a as i32).to_string());
        self.table("dof_axis", "i32", "ND1", axis, "-1");
        let stride = col(&|d| format!("{}u", self.block(d).joint_dofs()));
        self.table("dof_stride", "u32", "ND1", stride, "0u");
        let fields: [(&str, DofField); 8] = [
            ("dof_stiffness", |x| x.stiffness),
            ("dof_drive_damping", |x| x.drive_damping),
            ("dof_effort_limit", |x| x.effort_limit),
            ("dof_damping", |x| x.damping),
            ("dof_armature", |x| x.armature),
            ("dof_velocity_limit", |x| x.velocity_limit),
            ("dof_spring", |x| x.spring),
            ("dof_spring_ref", |x| x.spring_ref),
        ];
        for (name, get) in fields {
            let values = col(&|d| f(get(&dofs[d])));
            self.table(name, "f32", "ND1", values, "0.0");
        }
        // Bit 0: a finite lower limit, bit 1: a finite upper one.
        let limited = col(&|d| {
            let x = &dofs[d];
            format!(
                "{}u",
                u32::from(x.lower.is_finite()) | (u32::from(x.upper.is_finite()) << 1)
            )
        });
        self.table("dof_limited", "u32", "ND1", limited, "0u");
        let finite = |x: f32| if x.is_finite() { x } else { 0.0 };
        let lower = col(&|d| f(finite(dofs[d].lower)));
        self.table("dof_lower", "f32", "ND1", lower, "0.0");
        let upper = col(&|d| f(finite(dofs[d].upper)));
        self.table("dof_upper", "f32", "ND1", upper, "0.0");
    }
}
