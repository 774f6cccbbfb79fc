//! Articulation dynamics as straight-line code: forward kinematics, bias forces (RNEA), the
//! mass matrix (CRBA), its Cholesky factorisation and the drives' velocity update.

use std::fmt::Write as _;

use orbit_core::scene::JointKind;

use super::emitters::{DenseCholesky, DriveTerms};
use super::{Gen, f, m3, q4, v3};
use crate::compile::FreeRoot;

/// Up to this many dofs a serial chain's system matrix is factorised by an unrolled dense
/// Cholesky.
const UNROLLED_DOFS: usize = 16;

/// Up to this many multiply-adds the factorisation along the tree of dofs is unrolled (the
/// Humanoid's 27 dofs take 1 170); beyond, it loops. Unrolled, the solve with every constraint
/// row keeps its vector in registers, where a loop indexes it at run time.
const UNROLLED_TREE_TERMS: usize = 2000;

/// How the kernel factorises the system matrix A.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Factorisation {
    /// Unrolled Cholesky A = L Lᵀ of each articulation's dense block: serial chains, whose
    /// matrix has no structural zeros.
    Dense,
    /// Unrolled A = Lᵀ D L along a branching tree of dofs: with the dofs ordered root first,
    /// a dense factorisation would fill in the zeros between branches (the Ant's legs), and
    /// along the tree it fills in nothing.
    UnrolledTree,
    /// The same along the tree, as loops: beyond [`UNROLLED_TREE_TERMS`] multiply-adds.
    Looped,
}

impl Gen<'_> {
    /// Forward kinematics, joint motion subspaces, link velocities and spatial inertias.
    pub(super) fn kinematics(&mut self) {
        let roots: Vec<(usize, FreeRoot)> = self.scene.free_roots().collect();
        if !roots.is_empty() {
            self.line(
                "// Floating roots: the root link's centre of mass (its orientation is in lrot).",
            );
            self.line(format!(
                "var<private> fcom: array<vec3<f32>, {}>;",
                roots.len()
            ));
        }
        self.line("// The env-frame position of the kernel's frame origin (zero unless SHIFTED).");
        self.line("var<private> shift: vec3<f32>;");
        self.line(
            "// Forward kinematics, joint motion subspaces, link spatial inertias and velocities.",
        );
        self.open("fn kinematics()");
        for (l, link) in self.scene.links.iter().enumerate() {
            let Some(p) = link.parent else {
                if let Some(root) = link.free_root {
                    self.floating_root_kinematics(l, root);
                    continue;
                }
                // A fixed root is welded to the env frame: a constant pose, at rest.
                let pos = v3(link.origin.pos);
                self.line(format!("lpos[{l}] = {pos}{};", self.minus_shift()));
                self.line(format!("lrot[{l}] = {};", q4(link.origin.rot)));
                self.line(format!("vw[{l}] = vec3<f32>(0.0);"));
                self.line(format!("vu[{l}] = vec3<f32>(0.0);"));
                continue;
            };
            let d = link.dof.expect("non-root links have a dof");
            self.open("");
            let (opos, orot, axis) = (v3(link.origin.pos), q4(link.origin.rot), v3(link.axis));
            self.joint_link_kinematics(
                &l.to_string(),
                [
                    &format!("lpos[{p}]"),
                    &format!("lrot[{p}]"),
                    &format!("vw[{p}]"),
                    &format!("vu[{p}]"),
                ],
                (&opos, &orot, &axis),
                link.kind == JointKind::Prismatic,
                (&format!("q[{d}]"), &format!("qd[{d}]")),
            );
            self.spatial_inertia(l);
            self.close();
        }
        self.close();
        self.line("");
    }

    /// A floating root: its origin from the integrated centre of mass and orientation, its
    /// velocity from the six root dofs.
    fn floating_root_kinematics(&mut self, l: usize, root: FreeRoot) {
        let link = &self.scene.links[l];
        let (v, w) = Self::root_velocity(root);
        self.open("");
        self.line(format!("let rot = lrot[{l}];"));
        self.line(format!(
            "let pos = fcom[{}] - qrot(rot, {});",
            root.index,
            v3(link.inertial.com)
        ));
        self.line(format!("lpos[{l}] = pos;"));
        self.line(format!("vw[{l}] = {w};"));
        self.line(format!(
            "vu[{l}] = {v} + cross(fcom[{}], vw[{l}]);",
            root.index
        ));
        self.spatial_inertia(l);
        self.close();
    }

    /// Link `l`'s spatial inertia at the env origin, from `pos` and `rot` in scope.
    fn spatial_inertia(&mut self, l: usize) {
        self.line("// Spatial inertia at the env origin.");
        let i = &self.scene.links[l].inertial;
        let (mass, com, inertia) = (f(i.mass), v3(i.com), m3(i.inertia));
        self.line(format!("let s = mscale[{l}];"));
        let dst = [format!("im[{l}]"), format!("ih[{l}]"), format!("ij[{l}]")];
        self.spatial_inertia_at("s", &mass, &com, &inertia, [&dst[0], &dst[1], &dst[2]]);
    }

    /// Links with inertia that moves (all but fixed roots), parents first, with their parent
    /// when it is one of them and their dofs.
    fn moving_links(&self) -> Vec<(usize, Option<usize>, Vec<usize>)> {
        let links = &self.scene.links;
        (0..links.len())
            .filter(|&l| !self.scene.is_fixed_body(l))
            .map(|l| {
                let moving_parent = links[l].parent.filter(|&p| !self.scene.is_fixed_body(p));
                (l, moving_parent, self.link_dofs(l))
            })
            .collect()
    }

    /// Bias forces c(q, q̇) by recursive Newton–Euler with q̈ = 0 (gravity as a base
    /// acceleration of the roots).
    pub(super) fn rnea_bias(&mut self) {
        self.line("// Bias forces c(q, q̇) by recursive Newton–Euler with q̈ = 0 (gravity as a base acceleration).");
        self.open("fn rnea_bias()");
        let moving = self.moving_links();
        for (l, p, dofs) in &moving {
            let l = *l;
            if let Some(root) = self.scene.links[l].free_root {
                // The root's axes stay with the env while its centre of mass moves at v:
                // Ṡ q̇ = (0, v × ω).
                let (v, _) = Self::root_velocity(root);
                self.line(format!("let aw{l} = vec3<f32>(0.0);"));
                self.line(format!("let au{l} = -GRAVITY + cross({v}, vw[{l}]);"));
            } else {
                let d = dofs[0];
                let (aw0, au0) = match p {
                    Some(p) => (format!("aw{p}"), format!("au{p}")),
                    None => ("vec3<f32>(0.0)".into(), "-GRAVITY".into()),
                };
                self.line("// (v × S) q̇ with the motion cross product; f = I a + v ×* (I v).");
                self.joint_acceleration(
                    &l.to_string(),
                    &l.to_string(),
                    (&aw0, &au0),
                    &format!("qd[{d}]"),
                );
            }
            let at = |x: &str| format!("{x}[{l}]");
            self.link_force(&l.to_string(), &at);
        }
        for (l, p, dofs) in moving.iter().rev() {
            for &d in dofs {
                let (sw, su) = self.motion(d);
                self.line(format!("bias[{d}] = dot({sw}, fw{l}) + dot({su}, fu{l});"));
            }
            if let Some(p) = p {
                self.line(format!("fw{p} = fw{p} + fw{l};"));
                self.line(format!("fu{p} = fu{p} + fu{l};"));
            }
        }
        self.close();
        self.line("");
    }

    /// The joint-space mass matrix by the composite-rigid-body algorithm, plus armature.
    pub(super) fn crba(&mut self) {
        self.line("// Joint-space mass matrix (lower triangle) by the composite-rigid-body algorithm, plus armature.");
        self.open("fn crba()");
        let moving = self.moving_links();
        for (l, _, _) in &moving {
            self.line(format!("var cm{l} = im[{l}];"));
            self.line(format!("var ch{l} = ih[{l}];"));
            self.line(format!("var cj{l} = ij[{l}];"));
        }
        for (l, p, _) in moving.iter().rev() {
            if let Some(p) = p {
                self.line(format!("cm{p} = cm{p} + cm{l};"));
                self.line(format!("ch{p} = ch{p} + ch{l};"));
                self.line(format!("cj{p} = cj{p} + cj{l};"));
            }
        }
        let nd = self.nd();
        let mut set = vec![false; nd * nd];
        for (l, _, dofs) in &moving {
            let l = *l;
            let floating = dofs.len() > 1;
            for &di in dofs {
                // F = I_c S of this dof; a floating root's six get a suffix each.
                let name = if floating {
                    format!("{l}_{}", di - dofs[0])
                } else {
                    l.to_string()
                };
                let (sw, su) = self.motion(di);
                self.line(format!("let fw{name} = cj{l} * {sw} + cross(ch{l}, {su});"));
                self.line(format!("let fu{name} = cm{l} * {su} - cross(ch{l}, {sw});"));
                for dj in self.chain(l).into_iter().filter(|&dj| dj <= di) {
                    let (swj, suj) = self.motion(dj);
                    self.line(format!(
                        "amat[{}] = dot({swj}, fw{name}) + dot({suj}, fu{name});",
                        di * nd + dj
                    ));
                    set[di * nd + dj] = true;
                }
            }
        }
        // Dofs of one articulation off each other's chain: structural zeros of the dense
        // Cholesky block. Entries across articulations, and for the tree factorisations any
        // entry off a chain, are never read.
        let dense = self.factorisation() == Factorisation::Dense;
        for i in (0..nd).filter(|_| dense) {
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

    /// How the system matrix is factorised: see [`Factorisation`].
    fn factorisation(&self) -> Factorisation {
        let parents = self.dof_parents();
        let chains = (0..self.nd()).all(|d| parents[d] < 0 || parents[d] as usize == d - 1);
        if chains && self.nd() <= UNROLLED_DOFS {
            Factorisation::Dense
        } else if self.tree_factor_terms() <= UNROLLED_TREE_TERMS {
            Factorisation::UnrolledTree
        } else {
            Factorisation::Looped
        }
    }

    /// The multiply-adds of the factorisation along the tree of dofs, as
    /// [`Gen::unrolled_tree_factorisation`] writes them: for each dof, for each ancestor, that
    /// ancestor and its own ancestors.
    pub(super) fn tree_factor_terms(&self) -> usize {
        let ancestors = self.dof_ancestors();
        (ancestors.iter().flatten())
            .map(|&i| 1 + ancestors[i].len())
            .sum()
    }

    /// Each dof's ancestors in its articulation's tree of dofs, nearest first.
    fn dof_ancestors(&self) -> Vec<Vec<usize>> {
        let parents = self.dof_parents();
        (0..self.nd())
            .map(|d| {
                let mut out = vec![];
                let mut p = parents[d];
                while p >= 0 {
                    out.push(p as usize);
                    p = parents[p as usize];
                }
                out
            })
            .collect()
    }

    /// In-place factorisation of the system matrix and the solve A x = b with it, in the form
    /// [`Gen::factorisation`] picks.
    pub(super) fn cholesky(&mut self) {
        match self.factorisation() {
            Factorisation::Dense => self.dense_cholesky(),
            Factorisation::UnrolledTree => self.unrolled_tree_factorisation(),
            Factorisation::Looped => self.tree_factorisation(),
        }
    }

    /// A Cholesky factorisation A = L Lᵀ of each articulation's dense block and its solve as
    /// straight-line code.
    fn dense_cholesky(&mut self) {
        let nd = self.nd();
        let block = |d: usize| self.dof_block(d);
        let chol = DenseCholesky {
            m: "amat",
            inv: "linv",
            n: nd,
            block: &block,
        };
        let (factor, solve) = (chol.factor_lines(), chol.solve_lines());
        self.line("// In-place Cholesky factorisation A = L Lᵀ of each articulation's block (lower triangle of amat).");
        self.open("fn cholesky()");
        for line in factor {
            self.line(line);
        }
        self.close();
        self.line("");
        self.line("// Solves A x = b in place with the Cholesky factor.");
        self.open("fn chol_solve(b: ptr<function, array<f32, ND1>>)");
        for line in solve {
            self.line(line);
        }
        self.close();
        self.line("");
    }

    /// Featherstone's factorisation A = Lᵀ D L along the tree of dofs and its solve as
    /// straight-line code, each dof's entries updated only along its chain of ancestors.
    fn unrolled_tree_factorisation(&mut self) {
        let nd = self.nd();
        let chains = self.dof_ancestors();
        let ancestors = |d: usize| chains[d].iter().copied();
        let at = |i: usize, j: usize| format!("amat[{}]", i * nd + j);
        self.line("// In-place factorisation A = Lᵀ D L along the tree of dofs (1/D in linv, L below the diagonal).");
        self.open("fn cholesky()");
        for k in (0..nd).rev() {
            self.line(format!("linv[{k}] = 1.0 / max({}, 1e-12);", at(k, k)));
            for i in ancestors(k) {
                self.open("");
                self.line(format!("let a = {} * linv[{k}];", at(k, i)));
                for j in std::iter::once(i).chain(ancestors(i)) {
                    self.line(format!("{} -= a * {};", at(i, j), at(k, j)));
                }
                self.line(format!("{} = a;", at(k, i)));
                self.close();
            }
        }
        self.close();
        self.line("");
        self.line("// Solves A x = b in place: Lᵀ z = b, then D y = z, then L x = y.");
        self.open("fn chol_solve(b: ptr<function, array<f32, ND1>>)");
        for i in (0..nd).rev() {
            for j in ancestors(i) {
                self.line(format!("(*b)[{j}] -= {} * (*b)[{i}];", at(i, j)));
            }
        }
        for i in 0..nd {
            let mut t = format!("(*b)[{i}] * linv[{i}]");
            for j in ancestors(i) {
                write!(t, " - {} * (*b)[{j}]", at(i, j)).expect("write to string");
            }
            self.line(format!("(*b)[{i}] = {t};"));
        }
        self.close();
        self.line("");
    }

    /// Each dof's parent in its articulation's tree of dofs (`-1` for the first): the next dof
    /// towards the root; a floating root's six dofs form a chain.
    fn dof_parents(&self) -> Vec<i32> {
        let mut parents = vec![-1; self.nd()];
        for l in 0..self.scene.links.len() {
            let chain = self.chain(l);
            for d in self.link_dofs(l) {
                let at = chain
                    .iter()
                    .position(|&c| c == d)
                    .expect("a link's dof is on its chain");
                parents[d] = chain.get(at + 1).map_or(-1, |&p| p as i32);
            }
        }
        parents
    }

    /// Each dof's parent as a private table `dof_parent` (the looped passes walk it).
    pub(super) fn dof_parent_table(&mut self) {
        let parents: Vec<String> = self.dof_parents().iter().map(|p| p.to_string()).collect();
        self.line("// Each dof's parent in its articulation's tree of dofs (-1: none).");
        self.line(format!(
            "var<private> dof_parent: array<i32, ND1> = array<i32, ND1>({});",
            parents.join(", ")
        ));
        self.line("");
    }

    /// Featherstone's factorisation A = Lᵀ D L of a tree's system matrix, whose entries join
    /// only a dof and its ancestors, as loops over `dof_parent`: it fills nothing in, and the
    /// loops keep the kernel small where the unrolled form would not be (the shader compilers
    /// slow down faster than a kernel grows).
    fn tree_factorisation(&mut self) {
        self.line("// In-place factorisation A = Lᵀ D L along the tree of dofs (D on the diagonal, L below it).");
        self.open("fn cholesky()");
        self.open("for (var k = i32(ND) - 1; k >= 0; k = k - 1)");
        self.line("let kk = k * i32(ND) + k;");
        self.line("amat[kk] = max(amat[kk], 1e-12);");
        self.line("var i = dof_parent[k];");
        self.open("while (i >= 0)");
        self.line("let a = amat[k * i32(ND) + i] / amat[kk];");
        self.line("var j = i;");
        self.open("while (j >= 0)");
        self.line("amat[i * i32(ND) + j] -= a * amat[k * i32(ND) + j];");
        self.line("j = dof_parent[j];");
        self.close();
        self.line("amat[k * i32(ND) + i] = a;");
        self.line("i = dof_parent[i];");
        self.close();
        self.close();
        self.close();
        self.line("");
        self.line("// Solves A x = b in place: Lᵀ z = b, then D y = z, then L x = y.");
        self.open("fn chol_solve(b: ptr<function, array<f32, ND1>>)");
        self.open("for (var i = i32(ND) - 1; i >= 0; i = i - 1)");
        self.line("var j = dof_parent[i];");
        self.open("while (j >= 0)");
        self.line("(*b)[j] -= amat[i * i32(ND) + j] * (*b)[i];");
        self.line("j = dof_parent[j];");
        self.close();
        self.close();
        self.open("for (var i = 0; i < i32(ND); i = i + 1)");
        self.line("(*b)[i] = (*b)[i] / amat[i * i32(ND) + i];");
        self.line("var j = dof_parent[i];");
        self.open("while (j >= 0)");
        self.line("(*b)[i] -= amat[i * i32(ND) + j] * (*b)[j];");
        self.line("j = dof_parent[j];");
        self.close();
        self.close();
        self.close();
        self.line("");
    }

    /// Drives and damping: A = M + h(D + d) + h²K and the unconstrained velocity update.
    pub(super) fn drives(&mut self) {
        let nd = self.nd();
        self.line(
            "// Drives and damping: A = M + h(D + d) + h²K and the unconstrained velocity update.",
        );
        self.open("fn drives()");
        self.line("var dv: array<f32, ND1>;");
        for (d, dof) in self.scene.dofs.iter().enumerate() {
            if dof.root_axis.is_some() {
                // A floating root has no drive: only the bias forces act on it.
                self.line(format!("dv[{d}] = -DT * bias[{d}];"));
                continue;
            }
            let terms = DriveTerms {
                k: f(dof.stiffness),
                dd: f(dof.drive_damping),
                lim: f(dof.effort_limit),
                neg_lim: f(-dof.effort_limit),
                dd_damp: f(dof.drive_damping + dof.damping),
                damp: f(dof.damping),
                spring: f(dof.spring),
                spring_ref: f(dof.spring_ref),
                driven: dof.stiffness > 0.0 || dof.drive_damping > 0.0,
                damped: dof.damping != 0.0,
                sprung: dof.spring != 0.0,
            };
            self.open("");
            self.drive_lines(&d.to_string(), &format!("amat[{}]", d * nd + d), &terms);
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
}
