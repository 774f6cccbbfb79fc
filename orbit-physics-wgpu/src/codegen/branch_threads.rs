//! The kernel with one thread per branch of a floating root ([`KernelForm::ThreadPerBranch`],
//! `step/branch_threads.wgsl`): which scenes it serves, its per-thread state, and the
//! articulation's kinematics, bias forces and mass matrix. The system's factorisation, the
//! limit rows and their solver, integration and the state's loads and stores are in
//! `branch_system.rs`.
//!
//! [`KernelForm::ThreadPerBranch`]: super::KernelForm::ThreadPerBranch

use orbit_core::scene::JointKind;

use super::{Gen, f, m3, q4, root_motion, v3};
use crate::compile::{self, CompiledScene, MAX_CONTACTS};

/// At most this many branches: the lanes of a quad.
const MAX_BRANCHES: usize = 4;

/// A floating root and its branches, for a scene the one-thread-per-branch kernel serves.
#[derive(Clone, Debug, PartialEq)]
pub struct Branches {
    /// The floating root's link.
    pub root: usize,
    /// Each branch's links, from the root outwards.
    pub chains: Vec<Vec<usize>>,
    /// Each lane's shape pairs (indices of the geometry table's pairs, in its order): a group of
    /// pairs that joins a branch is its lane's; the pairs of the others (the root's link
    /// against fixed shapes) are dealt out, those that make the most contacts first, each to
    /// the lane with the fewest contact slots so far.
    pub lane_pairs: Vec<Vec<usize>>,
    /// Contact slots per lane: the most contacts any lane's pairs can make, at most
    /// `MAX_CONTACTS`.
    pub contact_slots: usize,
}

impl Branches {
    /// The branches of a scene that is one floating root whose 2–4 branches are chains of the
    /// same joints in the same order (the Ant's legs), without free objects, where no shape pair
    /// joins two branches.
    pub fn of(scene: &CompiledScene) -> Option<Self> {
        let links = &scene.links;
        if scene.articulations.len() != 1 || !scene.objects.is_empty() {
            return None;
        }
        let (root, _) = scene.free_roots().next()?;
        let children = |l: usize| -> Vec<usize> {
            (0..links.len())
                .filter(|&c| links[c].parent == Some(l))
                .collect()
        };
        let firsts = children(root);
        if !(2..=MAX_BRANCHES).contains(&firsts.len()) {
            return None;
        }
        let mut chains = Vec::new();
        for first in firsts {
            let mut chain = vec![first];
            loop {
                match children(chain[chain.len() - 1])[..] {
                    [] => break,
                    [next] => chain.push(next),
                    _ => return None,
                }
            }
            chains.push(chain);
        }
        let shape: Vec<JointKind> = chains[0].iter().map(|&l| links[l].kind).collect();
        let same = chains.iter().all(|c| {
            c.len() == shape.len()
                && c.iter()
                    .zip(&shape)
                    .all(|(&l, &k)| links[l].kind == k && links[l].dof.is_some())
        });
        if !same || 1 + chains.len() * shape.len() != links.len() {
            return None;
        }
        // Each group of pairs joins at most one branch (and the root's link or fixed shapes).
        let branch_of = |side: f32| -> Option<usize> {
            let b = side as i64;
            (b >= 0).then(|| chains.iter().position(|c| c.contains(&(b as usize))))?
        };
        let geo = scene.geometry_table();
        let pair_slots = |k: usize| {
            let [a, b, _, _] = geo.data[geo.pairs + k];
            compile::slots(scene.shapes[a as usize].kind, scene.shapes[b as usize].kind)
        };
        let mut lane_pairs = vec![Vec::new(); chains.len()];
        let mut shared = Vec::new();
        for g in 0..geo.num_groups {
            let [a, b, first, count] = geo.data[geo.groups + g];
            let pairs = first as usize..(first + count) as usize;
            match (branch_of(a), branch_of(b)) {
                (Some(x), Some(y)) if x != y => return None,
                (Some(x), _) | (_, Some(x)) => lane_pairs[x].extend(pairs),
                (None, None) => shared.extend(pairs),
            }
        }
        let mut slots: Vec<usize> = lane_pairs
            .iter()
            .map(|pairs| pairs.iter().map(|&k| pair_slots(k)).sum())
            .collect();
        // A lane's contact slots size every lane's arrays and warm-start entries: the root's
        // pairs on one lane would give all of them its count.
        shared.sort_by_key(|&k| std::cmp::Reverse(pair_slots(k)));
        for k in shared {
            let lane = (0..slots.len())
                .min_by_key(|&l| slots[l])
                .expect("two branches or more");
            slots[lane] += pair_slots(k);
            lane_pairs[lane].push(k);
        }
        for pairs in &mut lane_pairs {
            pairs.sort_unstable();
        }
        let contact_slots = slots.into_iter().max().unwrap_or(0).min(MAX_CONTACTS);
        Some(Self {
            root,
            chains,
            lane_pairs,
            contact_slots,
        })
    }

    /// Links (and dofs) per chain.
    pub fn chain_len(&self) -> usize {
        self.chains[0].len()
    }
}

/// Lane `l`'s value `values[l]`: a select over the lanes, the value of lane 0 where `values`
/// has no entry for a lane.
pub(super) fn lane_select(values: &[String]) -> String {
    let mut s = values[0].clone();
    for (l, v) in values.iter().enumerate().skip(1) {
        if *v != values[0] {
            s = format!("select({s}, {v}, lane == {l}u)");
        }
    }
    s
}

impl Gen<'_> {
    /// The value of chain slot `i` on this lane, `value` of each branch's link there: a select
    /// over the lanes (lanes past the last branch take branch 0's).
    pub(super) fn per_lane(
        &self,
        br: &Branches,
        i: usize,
        value: impl Fn(usize) -> String,
    ) -> String {
        let values: Vec<String> = br.chains.iter().map(|c| value(c[i])).collect();
        lane_select(&values)
    }

    /// ` * bmask` where some lanes hold no branch (their share of a sum is zero), else nothing.
    pub(super) fn masked(br: &Branches) -> &'static str {
        if br.chains.len() < MAX_BRANCHES {
            " * bmask"
        } else {
            ""
        }
    }

    /// The form's scene half: state, articulation, system, rows, integration, loads and stores.
    pub(super) fn branch_threads(&mut self, br: &Branches) {
        self.branch_state(br);
        self.branch_contact_state(br);
        self.branch_narrow_phase(br);
        self.branch_kinematics(br);
        self.branch_rnea(br);
        self.branch_crba(br);
        self.branch_drives(br);
        self.branch_factor(br);
        self.branch_contact_rows(br);
        self.branch_limit_rows(br);
        self.branch_solver(br);
        self.branch_integrate(br);
        self.branch_state_io(br);
    }

    fn branch_state(&mut self, br: &Branches) {
        let n = br.chain_len();
        self.line(format!("const NBR = {}u;", br.chains.len()));
        self.line(format!("const NCH = {n}u;"));
        self.line("// 1 on lanes that hold a branch, 0 on the others.");
        self.line("var<private> bmask: f32;");
        self.line("// The env-frame position of the kernel's frame origin (the root's centre of mass at load).");
        self.line("var<private> shift: vec3<f32>;");
        self.line("// The floating root: centre of mass, orientation, their velocities now and at the substep's start (every lane).");
        for v in [
            "fcom: vec3<f32>",
            "rrot: vec4<f32>",
            "rv: vec3<f32>",
            "rw: vec3<f32>",
            "rv0: vec3<f32>",
            "rw0: vec3<f32>",
        ] {
            self.line(format!("var<private> {v};"));
        }
        self.line(
            "// Its link's origin, spatial velocity and inertia, mass scale and bias forces.",
        );
        for v in [
            "rpos: vec3<f32>",
            "rvw: vec3<f32>",
            "rvu: vec3<f32>",
            "rim: f32",
            "rih: vec3<f32>",
            "rij: mat3x3<f32>",
            "rms: f32",
            "rbias: array<f32, 6>",
        ] {
            self.line(format!("var<private> {v};"));
        }
        self.line("// This lane's chain (indexed by constants only).");
        for v in [
            "q", "qd", "qd0", "bias", "applied", "in_ef", "in_qt", "in_vt", "ms", "im",
        ] {
            self.line(format!("var<private> {v}: array<f32, NCH>;"));
        }
        self.line("var<private> in_comp: array<bool, NCH>;");
        for v in ["lpos", "sw", "su", "vw", "vu", "ih"] {
            self.line(format!("var<private> {v}: array<vec3<f32>, NCH>;"));
        }
        self.line("var<private> lrot: array<vec4<f32>, NCH>;");
        self.line("var<private> ij: array<mat3x3<f32>, NCH>;");
        self.line(
            "// A_bb (lower triangle, then its Cholesky factor and inverse diagonal), A_b,root,",
        );
        self.line("// C_b = −A_bb⁻¹ A_b,root and the root's block: A_root, then S and its factor.");
        self.line("var<private> abb: array<f32, NCH * NCH>;");
        self.line("var<private> abb_inv: array<f32, NCH>;");
        self.line("var<private> abr: array<array<f32, 6>, NCH>;");
        self.line("var<private> cc: array<array<f32, 6>, NCH>;");
        self.line("var<private> sm: array<f32, 36>;");
        self.line("var<private> sm_inv: array<f32, 6>;");
        self.line("");
    }

    fn branch_kinematics(&mut self, br: &Branches) {
        let s = self.scene;
        let root = &s.links[br.root];
        self.line("// Forward kinematics, motion subspaces, spatial velocities and inertias.");
        self.open("fn kinematics()");
        self.open("");
        self.line("let rot = rrot;");
        self.line(format!(
            "let pos = fcom - qrot(rot, {});",
            v3(root.inertial.com)
        ));
        self.line("rpos = pos;");
        self.line("rvw = rw;");
        self.line("rvu = rv + cross(fcom, rvw);");
        let i = &root.inertial;
        let (mass, com, inertia) = (f(i.mass), v3(i.com), m3(i.inertia));
        self.spatial_inertia_at("rms", &mass, &com, &inertia, ["rim", "rih", "rij"]);
        self.close();
        for k in 0..br.chain_len() {
            let (pp, pr, pw, pu) = if k == 0 {
                ("rpos".into(), "rrot".into(), "rvw".into(), "rvu".into())
            } else {
                let p = k - 1;
                (
                    format!("lpos[{p}]"),
                    format!("lrot[{p}]"),
                    format!("vw[{p}]"),
                    format!("vu[{p}]"),
                )
            };
            let opos = self.per_lane(br, k, |l| v3(s.links[l].origin.pos));
            let orot = self.per_lane(br, k, |l| q4(s.links[l].origin.rot));
            let axis = self.per_lane(br, k, |l| v3(s.links[l].axis));
            self.open("");
            self.line(format!("let axis = {axis};"));
            let prismatic = s.links[br.chains[0][k]].kind == JointKind::Prismatic;
            self.joint_link_kinematics(
                &k.to_string(),
                [&pp, &pr, &pw, &pu],
                (&opos, &orot, "axis"),
                prismatic,
                (&format!("q[{k}]"), &format!("qd[{k}]")),
            );
            let mass = self.per_lane(br, k, |l| f(s.links[l].inertial.mass));
            let com = self.per_lane(br, k, |l| v3(s.links[l].inertial.com));
            // `select` takes no matrices: a matrix of per-lane columns.
            let column =
                |c: usize| self.per_lane(br, k, |l| v3(s.links[l].inertial.inertia.col(c)));
            let inertia = format!("mat3x3<f32>({}, {}, {})", column(0), column(1), column(2));
            let dst = [format!("im[{k}]"), format!("ih[{k}]"), format!("ij[{k}]")];
            self.spatial_inertia_at(
                &format!("ms[{k}]"),
                &mass,
                &com,
                &inertia,
                [&dst[0], &dst[1], &dst[2]],
            );
            self.close();
        }
        self.close();
        self.line("");
    }

    fn branch_rnea(&mut self, br: &Branches) {
        let n = br.chain_len();
        let bm = Self::masked(br);
        self.line("// Bias forces c(q, q̇) by recursive Newton–Euler with q̈ = 0 (gravity as a base acceleration).");
        self.open("fn rnea_bias()");
        self.line("let awr = vec3<f32>(0.0);");
        self.line("let aur = -GRAVITY + cross(rv, rvw);");
        self.link_force("r", &|x: &str| format!("r{x}"));
        for k in 0..n {
            let parent = if k == 0 {
                "r".to_string()
            } else {
                (k - 1).to_string()
            };
            let (aw0, au0) = (format!("aw{parent}"), format!("au{parent}"));
            let (kn, qd) = (k.to_string(), format!("qd[{k}]"));
            self.joint_acceleration(&kn, &kn, (&aw0, &au0), &qd);
            self.link_force(&kn, &|x: &str| format!("{x}[{k}]"));
        }
        for k in (0..n).rev() {
            self.line(format!(
                "bias[{k}] = dot(sw[{k}], fw{k}) + dot(su[{k}], fu{k});"
            ));
            if k > 0 {
                self.line(format!("fw{} = fw{} + fw{k};", k - 1, k - 1));
                self.line(format!("fu{} = fu{} + fu{k};", k - 1, k - 1));
            }
        }
        self.line("// The root's force: its own and its branches', summed in lane order.");
        self.line(format!("let tw = fwr + quad_sum3(fw0{bm});"));
        self.line(format!("let tu = fur + quad_sum3(fu0{bm});"));
        for k in 0..6 {
            let (sw, su) = root_motion(k, "fcom");
            self.line(format!("rbias[{k}] = dot({sw}, tw) + dot({su}, tu);"));
        }
        self.close();
        self.line("");
    }

    fn branch_crba(&mut self, br: &Branches) {
        let n = br.chain_len();
        let bm = Self::masked(br);
        let s = self.scene;
        self.line(
            "// The mass matrix by the composite-rigid-body algorithm, plus armature: A_bb and",
        );
        self.line("// A_b,root of this lane's chain, A_root into sm.");
        self.open("fn crba()");
        for k in 0..n {
            self.line(format!("var cm{k} = im[{k}];"));
            self.line(format!("var ch{k} = ih[{k}];"));
            self.line(format!("var cj{k} = ij[{k}];"));
        }
        for k in (1..n).rev() {
            let p = k - 1;
            self.line(format!("cm{p} = cm{p} + cm{k};"));
            self.line(format!("ch{p} = ch{p} + ch{k};"));
            self.line(format!("cj{p} = cj{p} + cj{k};"));
        }
        self.line(format!("let cm = rim + quad_sum(cm0{bm});"));
        self.line(format!("let ch = rih + quad_sum3(ch0{bm});"));
        self.line(format!(
            "let cj = rij + mat3x3<f32>(quad_sum3(cj0[0]{bm}), quad_sum3(cj0[1]{bm}), quad_sum3(cj0[2]{bm}));"
        ));
        for b in 0..6 {
            let (sw, su) = root_motion(b, "fcom");
            self.open("");
            self.line(format!("let fw = cj * {sw} + cross(ch, {su});"));
            self.line(format!("let fu = cm * {su} - cross(ch, {sw});"));
            for a in b..6 {
                let (swa, sua) = root_motion(a, "fcom");
                self.line(format!(
                    "sm[{}] = dot({swa}, fw) + dot({sua}, fu);",
                    a * 6 + b
                ));
            }
            self.close();
        }
        for j in 0..n {
            self.open("");
            self.line(format!("let fw = cj{j} * sw[{j}] + cross(ch{j}, su[{j}]);"));
            self.line(format!("let fu = cm{j} * su[{j}] - cross(ch{j}, sw[{j}]);"));
            for i in 0..=j {
                self.line(format!(
                    "abb[{}] = dot(sw[{i}], fw) + dot(su[{i}], fu);",
                    j * n + i
                ));
            }
            for k in 0..6 {
                let (swk, suk) = root_motion(k, "fcom");
                self.line(format!("abr[{j}][{k}] = dot({swk}, fw) + dot({suk}, fu);"));
            }
            let arm = self.per_lane(br, j, |l| {
                f(s.dofs[s.links[l].dof.expect("chain links have a dof")].armature)
            });
            if arm != f(0.0) {
                self.line(format!("abb[{}] += {arm};", j * n + j));
            }
            self.close();
        }
        self.close();
        self.line("");
    }
}
