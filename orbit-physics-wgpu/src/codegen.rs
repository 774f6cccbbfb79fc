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

use std::fmt::Write as _;

use glam::{Mat3, Quat, Vec3};
use orbit_core::physics::{ContactModel, SimCfg};
use orbit_core::scene::JointKind;

use crate::compile::{
    CONTACT_MARGIN, CompiledScene, MAX_CONTACTS, SOLVER_RELAXATION, default_solver_iterations,
};
use crate::layout;
use crate::weights::InverseWeights;

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
    g.out + include_str!("step.wgsl")
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

    fn constants(&mut self, sim: &SimCfg, workgroup: usize) {
        let s = self.scene;
        let (nl, nd, no, ns) = (s.links.len(), s.dofs.len(), s.objects.len(), s.shapes.len());
        let c = |g: &mut Self, name: &str, v: String| g.line(format!("const {name} = {v};"));
        c(self, "NL", format!("{nl}u"));
        c(self, "ND", format!("{nd}u"));
        c(self, "NO", format!("{no}u"));
        c(self, "NS", format!("{ns}u"));
        c(self, "NB", format!("{}u", s.num_bodies()));
        // Array lengths must be at least 1.
        c(self, "NL1", format!("{}u", nl.max(1)));
        c(self, "ND1", format!("{}u", nd.max(1)));
        c(self, "NO1", format!("{}u", no.max(1)));
        c(self, "NB1", format!("{}u", s.num_bodies().max(1)));
        c(self, "NDD", format!("{}u", (nd * nd).max(1)));
        c(self, "MAX_C", format!("{MAX_CONTACTS}u"));
        c(self, "WORKGROUP", format!("{workgroup}u"));
        c(self, "DT", f(sim.dt));
        c(self, "GRAVITY", v3(sim.gravity));
        c(
            self,
            "ITERATIONS",
            format!(
                "{}u",
                sim.iterations_or(default_solver_iterations(&sim.contact.model))
            ),
        );
        c(self, "MARGIN", f(CONTACT_MARGIN));
        c(self, "REPUBLISH", f(layout::REPUBLISH));
        let contact = &sim.contact;
        // MuJoCo's rows (`normal_row` in step.wgsl); the soft step's as its target and
        // regulariser scales.
        let (soft_step, relaxation, soft_target, soft_r) = match contact.model {
            ContactModel::MuJoCo => (false, SOLVER_RELAXATION, 0.0, 0.0),
            ContactModel::SoftStep {
                frequency,
                damping_ratio,
            } => {
                let a1 = 2.0 * damping_ratio + sim.dt * frequency;
                (true, 1.0, frequency / a1, 1.0 / (sim.dt * frequency * a1))
            }
        };
        c(self, "SOFT_STEP", soft_step.to_string());
        c(self, "RELAXATION", f(relaxation));
        c(self, "SOFT_TARGET_SCALE", f(soft_target));
        c(self, "SOFT_R_SCALE", f(soft_r));
        c(self, "REF_K", f(contact.stiffness(sim.dt)));
        c(self, "REF_B", f(contact.damping(sim.dt)));
        c(self, "IMP0", f(contact.solimp.0));
        c(self, "IMP1", f(contact.solimp.1));
        c(self, "IMP_WIDTH", f(contact.solimp.2));
        c(self, "IMP_MID", f(contact.solimp.3));
        c(self, "IMPRATIO", f(contact.impratio));
        let weights = InverseWeights::new(s);
        let list = |v: &[f32]| {
            if v.is_empty() {
                "0.0".to_string()
            } else {
                v.iter().map(|x| f(*x)).collect::<Vec<_>>().join(", ")
            }
        };
        self.line("// Inverse weights at the reference configuration (weights.rs).");
        self.line(format!(
            "var<private> body_invw: array<f32, NB1> = array<f32, NB1>({});",
            list(&weights.body)
        ));
        self.line(format!(
            "var<private> dof_invw: array<f32, ND1> = array<f32, ND1>({});",
            list(&weights.dof)
        ));
        self.out.push_str(&layout::lay_constants(s));
        self.line("");
    }

    /// `(articulation dofs, links, local link index)` of every link, for buffer addresses.
    fn link_strides(&self) -> Vec<(usize, usize, usize)> {
        let mut out = Vec::new();
        for &(_, links, _, dofs) in &self.scene.articulations {
            out.extend((0..links).map(|i| (dofs, links, i)));
        }
        out
    }

    fn state_io(&mut self) {
        let s = self.scene;
        let strides = self.link_strides();
        let (nl, nd) = (s.links.len(), s.dofs.len());
        let stride = |d: usize| self.dof_block(d).1;
        let dof_strides: Vec<usize> = (0..nd).map(stride).collect();

        self.open("fn load_state()");
        for (d, st) in dof_strides.iter().enumerate() {
            self.line(format!("q[{d}] = st[dof_addr(0u, {d}u, {st}u)];"));
            self.line(format!("qd[{d}] = st[dof_addr(1u, {d}u, {st}u)];"));
        }
        for b in 0..s.num_bodies() {
            self.line(format!(
                "mscale[{b}] = inp[lay[LAY_IN_MASS_SCALE] + env * NB + {b}u];"
            ));
        }
        self.line("// Drive inputs hold for the whole dispatch.");
        for (d, dof) in s.dofs.iter().enumerate() {
            let st = dof_strides[d];
            self.line(format!("in_ef[{d}] = inp[inp_addr(2u, {d}u, {st}u)];"));
            self.line(format!(
                "in_comp[{d}] = inp[lay[LAY_IN_COMPENSATE] + {d}u] != 0.0;"
            ));
            if dof.stiffness > 0.0 || dof.drive_damping > 0.0 {
                self.line(format!("in_qt[{d}] = inp[inp_addr(0u, {d}u, {st}u)];"));
                self.line(format!("in_vt[{d}] = inp[inp_addr(1u, {d}u, {st}u)];"));
            }
        }
        for (o, obj) in s.objects.iter().enumerate() {
            self.line(format!("opos[{o}] = ld3(obj_addr(0u, {o}u));"));
            self.line(format!("orot[{o}] = normalize(ld4(obj_addr(1u, {o}u)));"));
            self.line(format!("oang[{o}] = ld3(obj_addr(3u, {o}u));"));
            self.line(
                "// The state holds the origin's velocity; dynamics use the centre of mass's.",
            );
            self.line(format!(
                "ovel[{o}] = ld3(obj_addr(2u, {o}u)) + cross(oang[{o}], qrot(orot[{o}], {}));",
                v3(obj.com)
            ));
        }
        self.close();

        self.open("fn load_applied()");
        for (d, st) in dof_strides.iter().enumerate() {
            self.line(format!("applied[{d}] = st[dof_addr(3u, {d}u, {st}u)];"));
        }
        self.close();

        self.open("fn publish()");
        self.line("kinematics();");
        self.line("rnea_bias();");
        for (d, st) in dof_strides.iter().enumerate() {
            self.line(format!("st[dof_addr(0u, {d}u, {st}u)] = q[{d}];"));
            self.line(format!("st[dof_addr(1u, {d}u, {st}u)] = qd[{d}];"));
            self.line(format!("st[dof_addr(2u, {d}u, {st}u)] = bias[{d}];"));
            self.line(format!("st[dof_addr(3u, {d}u, {st}u)] = applied[{d}];"));
        }
        for (l, &(_, links, local)) in strides.iter().enumerate().take(nl) {
            let a = |k: u32| format!("link_addr({k}u, {l}u, {links}u, {local}u)");
            self.line(format!("st3({}, lpos[{l}]);", a(0)));
            self.line(format!("st4({}, lrot[{l}]);", a(1)));
            self.line(format!(
                "st3({}, vu[{l}] + cross(vw[{l}], lpos[{l}]));",
                a(2)
            ));
            self.line(format!("st3({}, vw[{l}]);", a(3)));
        }
        for (o, obj) in s.objects.iter().enumerate() {
            self.line(format!("st3(obj_addr(0u, {o}u), opos[{o}]);"));
            self.line(format!("st4(obj_addr(1u, {o}u), orot[{o}]);"));
            self.line(format!(
                "st3(obj_addr(2u, {o}u), ovel[{o}] - cross(oang[{o}], qrot(orot[{o}], {})));",
                v3(obj.com)
            ));
            self.line(format!("st3(obj_addr(3u, {o}u), oang[{o}]);"));
        }
        self.close();
        self.line("");
    }

    /// Forward kinematics, joint motion subspaces, link velocities and spatial inertias.
    fn kinematics(&mut self) {
        self.line(
            "// Forward kinematics, joint motion subspaces, link spatial inertias and velocities.",
        );
        self.open("fn kinematics()");
        for (l, link) in self.scene.links.iter().enumerate() {
            let Some(p) = link.parent else {
                // A root is welded to the env frame: a constant pose, at rest.
                self.line(format!("lpos[{l}] = {};", v3(link.origin.pos)));
                self.line(format!("lrot[{l}] = {};", q4(link.origin.rot)));
                self.line(format!("vw[{l}] = vec3<f32>(0.0);"));
                self.line(format!("vu[{l}] = vec3<f32>(0.0);"));
                continue;
            };
            let d = link.dof.expect("non-root links have a dof");
            self.open("");
            self.line(format!(
                "var pos = lpos[{p}] + qrot(lrot[{p}], {});",
                v3(link.origin.pos)
            ));
            self.line(format!(
                "var rot = qmul(lrot[{p}], {});",
                q4(link.origin.rot)
            ));
            self.line(format!("let axis_w = qrot(rot, {});", v3(link.axis)));
            if link.kind == JointKind::Prismatic {
                self.line(format!("pos = pos + axis_w * q[{d}];"));
                self.line(format!("sw[{l}] = vec3<f32>(0.0);"));
                self.line(format!("su[{l}] = axis_w;"));
            } else {
                self.line(format!(
                    "rot = qmul(rot, qaxis({}, q[{d}]));",
                    v3(link.axis)
                ));
                self.line(format!("sw[{l}] = axis_w;"));
                self.line(format!("su[{l}] = cross(pos, axis_w);"));
            }
            self.line(format!("lpos[{l}] = pos;"));
            self.line(format!("lrot[{l}] = rot;"));
            self.line(format!("vw[{l}] = vw[{p}] + sw[{l}] * qd[{d}];"));
            self.line(format!("vu[{l}] = vu[{p}] + su[{l}] * qd[{d}];"));
            self.line("// Spatial inertia at the env origin.");
            let i = &link.inertial;
            self.line(format!("let s = mscale[{l}];"));
            self.line(format!("let m = {} * s;", f(i.mass)));
            self.line(format!("let c = pos + qrot(rot, {});", v3(i.com)));
            self.line("let r = qmat(rot);");
            self.line(format!(
                "let ic = r * ({} * s) * transpose(r);",
                m3(i.inertia)
            ));
            self.line("let cc = dot(c, c);");
            self.line(format!("im[{l}] = m;"));
            self.line(format!("ih[{l}] = m * c;"));
            self.line(format!(
                "ij[{l}] = ic + m * (mat3x3<f32>(cc, 0.0, 0.0, 0.0, cc, 0.0, 0.0, 0.0, cc) - outer(c, c));"
            ));
            self.close();
        }
        self.close();
        self.line("");
    }

    /// Non-root links with their parent (`None` when the parent is a root) and dof.
    fn moving_links(&self) -> Vec<(usize, Option<usize>, usize)> {
        let links = &self.scene.links;
        links
            .iter()
            .enumerate()
            .filter_map(|(l, link)| {
                let p = link.parent?;
                let moving_parent = links[p].parent.is_some().then_some(p);
                Some((
                    l,
                    moving_parent,
                    link.dof.expect("non-root links have a dof"),
                ))
            })
            .collect()
    }

    /// Bias forces c(q, q̇) by recursive Newton–Euler with q̈ = 0 (gravity as a base
    /// acceleration of the roots).
    fn rnea_bias(&mut self) {
        self.line("// Bias forces c(q, q̇) by recursive Newton–Euler with q̈ = 0 (gravity as a base acceleration).");
        self.open("fn rnea_bias()");
        let moving = self.moving_links();
        for &(l, p, d) in &moving {
            let (aw0, au0) = match p {
                Some(p) => (format!("aw{p}"), format!("au{p}")),
                None => ("vec3<f32>(0.0)".into(), "-GRAVITY".into()),
            };
            self.line("// (v × S) q̇ with the motion cross product; f = I a + v ×* (I v).");
            self.line(format!(
                "let aw{l} = {aw0} + cross(vw[{l}], sw[{l}]) * qd[{d}];"
            ));
            self.line(format!(
                "let au{l} = {au0} + (cross(vw[{l}], su[{l}]) + cross(vu[{l}], sw[{l}])) * qd[{d}];"
            ));
            self.line(format!(
                "let ivw{l} = ij[{l}] * vw[{l}] + cross(ih[{l}], vu[{l}]);"
            ));
            self.line(format!(
                "let ivu{l} = im[{l}] * vu[{l}] - cross(ih[{l}], vw[{l}]);"
            ));
            self.line(format!(
                "var fw{l} = ij[{l}] * aw{l} + cross(ih[{l}], au{l}) + cross(vw[{l}], ivw{l}) + cross(vu[{l}], ivu{l});"
            ));
            self.line(format!(
                "var fu{l} = im[{l}] * au{l} - cross(ih[{l}], aw{l}) + cross(vw[{l}], ivu{l});"
            ));
        }
        for &(l, p, d) in moving.iter().rev() {
            self.line(format!(
                "bias[{d}] = dot(sw[{l}], fw{l}) + dot(su[{l}], fu{l});"
            ));
            if let Some(p) = p {
                self.line(format!("fw{p} = fw{p} + fw{l};"));
                self.line(format!("fu{p} = fu{p} + fu{l};"));
            }
        }
        self.close();
        self.line("");
    }

    /// The joint-space mass matrix by the composite-rigid-body algorithm, plus armature.
    fn crba(&mut self) {
        self.line("// Joint-space mass matrix (lower triangle) by the composite-rigid-body algorithm, plus armature.");
        self.open("fn crba()");
        let moving = self.moving_links();
        for &(l, _, _) in &moving {
            self.line(format!("var cm{l} = im[{l}];"));
            self.line(format!("var ch{l} = ih[{l}];"));
            self.line(format!("var cj{l} = ij[{l}];"));
        }
        for &(l, p, _) in moving.iter().rev() {
            if let Some(p) = p {
                self.line(format!("cm{p} = cm{p} + cm{l};"));
                self.line(format!("ch{p} = ch{p} + ch{l};"));
                self.line(format!("cj{p} = cj{p} + cj{l};"));
            }
        }
        let nd = self.nd();
        let mut set = vec![false; nd * nd];
        for &(l, _, di) in &moving {
            self.line(format!(
                "let fw{l} = cj{l} * sw[{l}] + cross(ch{l}, su[{l}]);"
            ));
            self.line(format!(
                "let fu{l} = cm{l} * su[{l}] - cross(ch{l}, sw[{l}]);"
            ));
            for (j, dj) in self.chain(l) {
                self.line(format!(
                    "amat[{}] = dot(sw[{j}], fw{l}) + dot(su[{j}], fu{l});",
                    di * nd + dj
                ));
                set[di * nd + dj] = true;
            }
        }
        // Dofs of one articulation off each other's chain: structural zeros of the factor's
        // dense block. Entries across articulations are never read.
        for i in 0..nd {
            let (d0, _) = self.dof_block(i);
            for j in d0..i {
                if !set[i * nd + j] {
                    self.line(format!("amat[{}] = 0.0;", i * nd + j));
                }
            }
        }
        for (d, dof) in self.scene.dofs.iter().enumerate() {
            if dof.armature != 0.0 {
                self.line(format!(
                    "amat[{}] = amat[{}] + {};",
                    d * nd + d,
                    d * nd + d,
                    f(dof.armature)
                ));
            }
        }
        self.close();
        self.line("");
    }

    /// In-place Cholesky factorisation A = L Lᵀ (each articulation's dense block) and the
    /// solve A x = b with it.
    fn cholesky(&mut self) {
        let nd = self.nd();
        let at = |i: usize, j: usize| format!("amat[{}]", i * nd + j);
        self.line("// In-place Cholesky factorisation A = L Lᵀ of each articulation's block (lower triangle of amat).");
        self.open("fn cholesky()");
        for j in 0..nd {
            let (d0, n) = self.dof_block(j);
            let mut s = at(j, j);
            for k in d0..j {
                write!(s, " - {} * {}", at(j, k), at(j, k)).expect("write to string");
            }
            self.line(format!("{} = sqrt(max({s}, 1e-12));", at(j, j)));
            self.line(format!("linv[{j}] = 1.0 / {};", at(j, j)));
            for i in j + 1..d0 + n {
                let mut t = at(i, j);
                for k in d0..j {
                    write!(t, " - {} * {}", at(i, k), at(j, k)).expect("write to string");
                }
                self.line(format!("{} = ({t}) * linv[{j}];", at(i, j)));
            }
        }
        self.close();
        self.line("");
        self.line("// Solves A x = b in place with the Cholesky factor.");
        self.open("fn chol_solve(b: ptr<function, array<f32, ND1>>)");
        for i in 0..nd {
            let (d0, _) = self.dof_block(i);
            let mut t = format!("(*b)[{i}]");
            for k in d0..i {
                write!(t, " - {} * (*b)[{k}]", at(i, k)).expect("write to string");
            }
            self.line(format!("(*b)[{i}] = ({t}) * linv[{i}];"));
        }
        for i in (0..nd).rev() {
            let (d0, n) = self.dof_block(i);
            let mut t = format!("(*b)[{i}]");
            for k in i + 1..d0 + n {
                write!(t, " - {} * (*b)[{k}]", at(k, i)).expect("write to string");
            }
            self.line(format!("(*b)[{i}] = ({t}) * linv[{i}];"));
        }
        self.close();
        self.line("");
    }

    /// Drives and damping: A = M + h(D + d) + h²K and the unconstrained velocity update.
    fn drives(&mut self) {
        let nd = self.nd();
        self.line(
            "// Drives and damping: A = M + h(D + d) + h²K and the unconstrained velocity update.",
        );
        self.open("fn drives()");
        self.line("var dv: array<f32, ND1>;");
        for (d, dof) in self.scene.dofs.iter().enumerate() {
            let (k, dd, lim, damp) = (
                dof.stiffness,
                dof.drive_damping,
                dof.effort_limit,
                dof.damping,
            );
            let diag = format!("amat[{}]", d * nd + d);
            self.open("");
            self.line(format!("var ef = in_ef[{d}];"));
            self.line(format!("if in_comp[{d}] {{ ef += bias[{d}]; }}"));
            if k > 0.0 || dd > 0.0 {
                self.line(format!("let qt = in_qt[{d}];"));
                self.line(format!("let vt = in_vt[{d}];"));
                self.line(format!(
                    "let pd = {} * (qt - q[{d}]) + {} * (vt - qd[{d}]);",
                    f(k),
                    f(dd)
                ));
                self.line("var tau: f32;");
                self.line("// Implicit while the drive stays inside its effort limit.");
                self.open(format!("if abs(pd + ef) <= {}", f(lim)));
                self.line(format!(
                    "tau = ef + {} * (qt - q[{d}] - DT * qd[{d}]) + {} * (vt - qd[{d}]);",
                    f(k),
                    f(dd)
                ));
                self.line(format!(
                    "{diag} = {diag} + DT * {} + DT * DT * {};",
                    f(dd + damp),
                    f(k)
                ));
                self.close();
                self.open("else");
                self.line(format!("tau = clamp(pd + ef, {}, {});", f(-lim), f(lim)));
                if damp != 0.0 {
                    self.line(format!("{diag} = {diag} + DT * {};", f(damp)));
                }
                self.close();
                self.line(format!(
                    "applied[{d}] = clamp(pd + ef, {}, {});",
                    f(-lim),
                    f(lim)
                ));
            } else {
                self.line(format!("let tau = clamp(ef, {}, {});", f(-lim), f(lim)));
                self.line(format!("applied[{d}] = tau;"));
                if damp != 0.0 {
                    self.line(format!("{diag} = {diag} + DT * {};", f(damp)));
                }
            }
            self.line(format!(
                "dv[{d}] = DT * (tau - {} * qd[{d}] - bias[{d}]);",
                f(damp)
            ));
            self.close();
        }
        self.line("cholesky();");
        self.line("chol_solve(&dv);");
        for d in 0..nd {
            self.line(format!("qd[{d}] += dv[{d}];"));
        }
        self.close();
        self.line("");
    }

    /// Free bodies: gravity, the explicit gyroscopic term and world inverse inertias; and the
    /// accessors the constraint rows use.
    fn objects(&mut self) {
        self.line(
            "// Gravity and the explicit gyroscopic term on free bodies; world inverse inertias.",
        );
        self.open("fn objects_free_velocity()");
        let nl = self.scene.links.len();
        for (o, obj) in self.scene.objects.iter().enumerate() {
            self.open("");
            self.line(format!("let s = mscale[{}];", nl + o));
            self.line(format!("let r = qmat(orot[{o}]);"));
            self.line(format!(
                "let iw = r * ({} * s) * transpose(r);",
                m3(obj.inertia)
            ));
            self.line("let inv = inverse3(iw);");
            self.line(format!("oinvm[{o}] = 1.0 / ({} * s);", f(obj.mass)));
            self.line(format!("oinvi[{o}] = inv;"));
            self.line(format!(
                "ocom[{o}] = opos[{o}] + qrot(orot[{o}], {});",
                v3(obj.com)
            ));
            self.line(format!("ovel[{o}] = ovel[{o}] + DT * GRAVITY;"));
            self.line(format!(
                "oang[{o}] = oang[{o}] - DT * (inv * cross(oang[{o}], iw * oang[{o}]));"
            ));
            self.close();
        }
        self.close();
        self.line("");
        let no = self.scene.objects.len();
        let accessor = |g: &mut Self, sig: &str, body: &dyn Fn(usize) -> String, default: &str| {
            g.open(format!("fn {sig}"));
            g.open("switch o");
            for o in 0..no {
                g.line(format!("case {o}: {{ {} }}", body(o)));
            }
            g.line("default: {}");
            g.close();
            if !default.is_empty() {
                g.line(default);
            }
            g.close();
        };
        self.line(
            "// Free object o's quantities for the constraint rows (o is only known at run time).",
        );
        accessor(
            self,
            "obj_com(o: i32) -> vec3<f32>",
            &|o| format!("return ocom[{o}];"),
            "return vec3<f32>(0.0);",
        );
        accessor(
            self,
            "obj_invm(o: i32) -> f32",
            &|o| format!("return oinvm[{o}];"),
            "return 0.0;",
        );
        accessor(
            self,
            "obj_invi(o: i32, v: vec3<f32>) -> vec3<f32>",
            &|o| format!("return oinvi[{o}] * v;"),
            "return vec3<f32>(0.0);",
        );
        accessor(
            self,
            "obj_point_vel(o: i32, p: vec3<f32>) -> vec3<f32>",
            &|o| format!("return ovel[{o}] + cross(oang[{o}], p);"),
            "return vec3<f32>(0.0);",
        );
        accessor(
            self,
            "obj_push(o: i32, impulse: vec3<f32>, p: vec3<f32>)",
            &|o| {
                format!(
                    "ovel[{o}] = ovel[{o}] + impulse * oinvm[{o}]; oang[{o}] = oang[{o}] + oinvi[{o}] * cross(p, impulse);"
                )
            },
            "",
        );
        self.line("");
    }

    /// The narrow phase's view of the bodies: their poses copied into arrays that the
    /// data-driven pair loop of `step.wgsl` indexes at run time, so that the articulation's
    /// own arrays keep constant indices.
    fn collide(&mut self) {
        let s = self.scene;
        let geo = s.geometry_table();
        let c = |g: &mut Self, name: &str, v: usize| g.line(format!("const {name} = {v}u;"));
        c(self, "GEO_LEN", geo.data.len().max(1));
        c(self, "GEO_SHAPES", geo.shapes);
        c(self, "GEO_BODIES", geo.bodies);
        c(self, "GEO_GROUPS", geo.groups);
        c(self, "GEO_PAIRS", geo.pairs);
        c(self, "NG", geo.num_groups);
        self.line("// Body poses for the narrow phase (links, then free objects).");
        self.open("fn copy_body_poses()");
        let nl = s.links.len();
        for b in 0..s.num_bodies() {
            if s.is_fixed_body(b) || !s.shapes.iter().any(|x| x.body == Some(b)) {
                continue;
            }
            let (pos, rot) = if b < nl {
                (format!("lpos[{b}]"), format!("lrot[{b}]"))
            } else {
                (format!("opos[{}]", b - nl), format!("orot[{}]", b - nl))
            };
            self.line(format!("bpos[{b}] = {pos};"));
            self.line(format!("brot[{b}] = {rot};"));
        }
        self.close();
        self.line("");
    }

    /// Row Jacobians of points on links, and the arm parts of the rows.
    fn jacobians(&mut self) {
        let nd = self.nd();
        self.line("// Adds s times the generalised-force direction of a unit impulse along d at p on body b to jt;");
        self.line("// false if b moves no dof.");
        self.open("fn body_jt(b: i32, p: vec3<f32>, d: vec3<f32>, s: f32, jt: ptr<function, array<f32, ND1>>) -> bool");
        self.line("let pd = cross(p, d);");
        self.open("switch b");
        for l in 0..self.scene.links.len() {
            let chain = self.chain(l);
            if chain.is_empty() || !self.scene.shapes.iter().any(|s| s.body == Some(l)) {
                continue;
            }
            self.open(format!("case {l}:"));
            for (k, d) in chain {
                self.line(format!(
                    "(*jt)[{d}] += s * (dot(d, su[{k}]) + dot(sw[{k}], pd));"
                ));
            }
            self.line("return true;");
            self.close();
        }
        self.line("default: {}");
        self.close();
        self.line("return false;");
        self.close();
        self.line("");
        self.line("// Stores a row's arm Jacobian and W = A⁻¹ Jᵀ at `base`; returns J W.");
        self.open("fn arm_store(base: u32, jt: array<f32, ND1>, w: array<f32, ND1>) -> f32");
        let mut jw = String::from("0.0");
        for d in 0..nd {
            self.line(format!("r_j[base + {d}u] = jt[{d}];"));
            self.line(format!("r_w[base + {d}u] = w[{d}];"));
            write!(jw, " + jt[{d}] * w[{d}]").expect("write to string");
        }
        self.line(format!("return {jw};"));
        self.close();
        self.line("");
        self.line("// J_arm q̇ of the row at `base`.");
        self.open("fn arm_dot(base: u32) -> f32");
        let mut dot = String::from("0.0");
        for d in 0..nd {
            write!(dot, " + r_j[base + {d}u] * qd[{d}]").expect("write to string");
        }
        self.line(format!("return {dot};"));
        self.close();
        self.line("");
        self.line("// q̇ += W x for the row at `base`.");
        self.open("fn arm_axpy(base: u32, x: f32)");
        for d in 0..nd {
            self.line(format!("qd[{d}] += r_w[base + {d}u] * x;"));
        }
        self.close();
        self.line("");
    }

    /// Joint-limit rows for joints that could reach a limit within this substep.
    fn limit_rows(&mut self) {
        self.line("// A limit row when the joint could reach its limit within this substep.");
        self.open("fn limit_rows()");
        for (d, dof) in self.scene.dofs.iter().enumerate() {
            let (lower, upper) = (dof.lower.is_finite(), dof.upper.is_finite());
            if !lower && !upper {
                continue;
            }
            self.open("");
            self.line(format!("let reach = abs(qd[{d}]) * DT + MARGIN;"));
            self.line("var jt: array<f32, ND1>;");
            if lower {
                self.line(format!("let lo = q[{d}] - {};", f(dof.lower)));
            }
            if upper {
                self.line(format!("let hi = {} - q[{d}];", f(dof.upper)));
            }
            if lower {
                self.open("if lo < reach");
                self.line(format!("jt[{d}] = 1.0;"));
                self.line(format!("limit_row(jt, LIMIT_SLOT + {}u, lo);", 2 * d));
            }
            if upper {
                if lower {
                    self.reopen("else if hi < reach");
                } else {
                    self.open("if hi < reach");
                }
                self.line(format!("jt[{d}] = -1.0;"));
                self.line(format!("limit_row(jt, LIMIT_SLOT + {}u, hi);", 2 * d + 1));
            }
            self.close();
            self.close();
        }
        self.close();
        self.line("");
    }

    /// Velocity limits and semi-implicit Euler (quaternions renormalised).
    fn integrate(&mut self) {
        self.line("// Velocity limits, then semi-implicit Euler (quaternions renormalised).");
        self.open("fn integrate()");
        for (d, dof) in self.scene.dofs.iter().enumerate() {
            if dof.velocity_limit.is_finite() {
                let v = dof.velocity_limit;
                self.line(format!("qd[{d}] = clamp(qd[{d}], {}, {});", f(-v), f(v)));
            }
            self.line(format!("q[{d}] += DT * qd[{d}];"));
        }
        for (o, obj) in self.scene.objects.iter().enumerate() {
            self.open("");
            self.line(format!("let com = ocom[{o}] + DT * ovel[{o}];"));
            self.line(format!(
                "let dq = qmul(vec4<f32>(oang[{o}], 0.0), orot[{o}]) * (0.5 * DT);"
            ));
            self.line(format!("orot[{o}] = normalize(orot[{o}] + dq);"));
            self.line(format!(
                "opos[{o}] = com - qrot(orot[{o}], {});",
                v3(obj.com)
            ));
            self.close();
        }
        self.close();
        self.line("");
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
