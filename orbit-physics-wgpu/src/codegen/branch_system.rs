//! The one-thread-per-branch kernel's system and solver: drives, the factorisation through the
//! root's Schur complement, the joint-limit rows and their sweeps in turns, integration, and
//! the state's loads and stores.

use std::fmt::Write as _;

use super::branch_threads::Branches;
use super::emitters::{DenseCholesky, DriveTerms};
use super::{Gen, f, v3};
use crate::compile::DofData;
use crate::weights::InverseWeights;

impl Gen<'_> {
    /// The dof of chain slot `k` on this lane, as a WGSL `u32`.
    fn lane_dof(&self, br: &Branches, k: usize) -> String {
        self.per_lane(br, k, |l| {
            format!(
                "{}u",
                self.scene.links[l].dof.expect("chain links have a dof")
            )
        })
    }

    /// A per-lane float of chain slot `k`'s dof.
    fn lane_dof_f(&self, br: &Branches, k: usize, value: impl Fn(usize) -> f32) -> String {
        self.per_lane(br, k, |l| {
            f(value(
                self.scene.links[l].dof.expect("chain links have a dof"),
            ))
        })
    }

    /// Whether any branch's dof at slot `k` has `test`.
    fn any_dof(&self, br: &Branches, k: usize, test: impl Fn(usize) -> bool) -> bool {
        br.chains
            .iter()
            .any(|c| test(self.scene.links[c[k]].dof.expect("chain links have a dof")))
    }

    pub(super) fn branch_drives(&mut self, br: &Branches) {
        let n = br.chain_len();
        let bm = Self::masked(br);
        let dofs = &self.scene.dofs;
        self.line(
            "// Drives and damping: A = M + h(D + d) + h²K and the unconstrained velocity update,",
        );
        self.line("// the root's through S, each chain's through A_bb and C_b.");
        self.open("fn drives()");
        self.line("var dv: array<f32, NCH>;");
        for j in 0..n {
            let lane = |v: &dyn Fn(&DofData) -> f32| self.lane_dof_f(br, j, |d| v(&dofs[d]));
            let terms = DriveTerms {
                k: lane(&|d| d.stiffness),
                dd: lane(&|d| d.drive_damping),
                lim: lane(&|d| d.effort_limit),
                neg_lim: lane(&|d| -d.effort_limit),
                dd_damp: lane(&|d| d.drive_damping + d.damping),
                damp: lane(&|d| d.damping),
                spring: lane(&|d| d.spring),
                spring_ref: lane(&|d| d.spring_ref),
                driven: self.any_dof(br, j, |d| {
                    dofs[d].stiffness > 0.0 || dofs[d].drive_damping > 0.0
                }),
                damped: self.any_dof(br, j, |d| dofs[d].damping != 0.0),
                sprung: self.any_dof(br, j, |d| dofs[d].spring != 0.0),
            };
            self.open("");
            self.drive_lines(&j.to_string(), &format!("abb[{}]", j * n + j), &terms);
            self.close();
        }
        self.line("var dr: array<f32, 6>;");
        for k in 0..6 {
            self.line(format!("dr[{k}] = -DT * rbias[{k}];"));
        }
        self.line("factor();");
        self.line("var y = dv;");
        self.line("b_solve(&y);");
        for k in 0..6 {
            let mut t = String::new();
            for j in 0..n {
                write!(t, " + cc[{j}][{k}] * dv[{j}]").expect("write to string");
            }
            self.line(format!("dr[{k}] += quad_sum((0.0{t}){bm});"));
        }
        self.line("s_solve(&dr);");
        self.line("rv += vec3<f32>(dr[0], dr[1], dr[2]);");
        self.line("rw += vec3<f32>(dr[3], dr[4], dr[5]);");
        for j in 0..n {
            let t: String = (0..6)
                .map(|k| format!(" + cc[{j}][{k}] * dr[{k}]"))
                .collect();
            self.line(format!("qd[{j}] += y[{j}]{t};"));
        }
        self.close();
        self.line("");
    }

    /// A dense Cholesky factorisation of the `n × n` system in `m` (one block).
    fn dense(m: &'static str, inv: &'static str, n: usize) -> (Vec<String>, Vec<String>) {
        let block = move |_| (0, n);
        let chol = DenseCholesky {
            m,
            inv,
            n,
            block: &block,
        };
        (chol.factor_lines(), chol.solve_lines())
    }

    /// Emits `fn name(b)`: `lines` solving an `n`-vector in place.
    fn solve_fn(&mut self, name: &str, len: &str, lines: Vec<String>) {
        self.open(format!("fn {name}(b: ptr<function, array<f32, {len}>>)"));
        for line in lines {
            self.line(line);
        }
        self.close();
        self.line("");
    }

    pub(super) fn branch_factor(&mut self, br: &Branches) {
        let n = br.chain_len();
        let bm = Self::masked(br);
        self.line("// Factorises A_bb, forms C_b and the Schur complement S, and factorises S.");
        self.open("fn factor()");
        let (b_factor, b_solve) = Self::dense("abb", "abb_inv", n);
        let (s_factor, s_solve) = Self::dense("sm", "sm_inv", 6);
        for line in b_factor {
            self.line(line);
        }
        for k in 0..6 {
            self.open("");
            self.line("var x: array<f32, NCH>;");
            for j in 0..n {
                self.line(format!("x[{j}] = -abr[{j}][{k}];"));
            }
            self.line("b_solve(&x);");
            for j in 0..n {
                self.line(format!("cc[{j}][{k}] = x[{j}];"));
            }
            self.close();
        }
        for a in 0..6 {
            for b in 0..=a {
                let t: String = (0..n)
                    .map(|j| format!(" + abr[{j}][{a}] * cc[{j}][{b}]"))
                    .collect();
                self.line(format!("sm[{}] += quad_sum((0.0{t}){bm});", a * 6 + b));
            }
        }
        for line in s_factor {
            self.line(line);
        }
        self.close();
        self.line("");
        self.solve_fn("b_solve", "NCH", b_solve);
        self.solve_fn("s_solve", "6", s_solve);
    }

    pub(super) fn branch_limit_rows(&mut self, br: &Branches) {
        let n = br.chain_len();
        let s = self.scene;
        let weights = InverseWeights::new(s);
        self.line(
            "// This lane's joint-limit rows, one slot per dof: on, side, W's root part (6) and",
        );
        self.line("// chain part, target, regulariser, 1 / (a + R), impulse and warm-start slot.");
        self.line("var<private> l_on: array<bool, NCH>;");
        for v in ["l_sd", "l_tgt", "l_r", "l_meff", "l_lam"] {
            self.line(format!("var<private> {v}: array<f32, NCH>;"));
        }
        self.line("var<private> l_slot: array<u32, NCH>;");
        self.line("var<private> l_wr: array<array<f32, 6>, NCH>;");
        self.line("var<private> l_wb: array<array<f32, NCH>, NCH>;");
        self.line("// A limit row when a joint could reach its limit within this substep.");
        self.open("fn limit_rows()");
        for j in 0..n {
            self.line(format!("l_on[{j}] = false;"));
            // An inert row for the sweeps, which visit it regardless.
            self.line(format!("l_meff[{j}] = 0.0;"));
            self.line(format!("l_lam[{j}] = 0.0;"));
            let limited = self.any_dof(br, j, |d| {
                s.dofs[d].lower.is_finite() || s.dofs[d].upper.is_finite()
            });
            if !limited {
                continue;
            }
            let lower = self.lane_dof_f(br, j, |d| s.dofs[d].lower);
            let upper = self.lane_dof_f(br, j, |d| s.dofs[d].upper);
            let dof = self.lane_dof(br, j);
            let a0 = self.lane_dof_f(br, j, |d| weights.dof[d]);
            self.open("");
            self.line(format!("let reach = abs(qd[{j}]) * DT + MARGIN;"));
            self.line(format!("let lo = q[{j}] - {lower};"));
            self.line(format!("let hi = {upper} - q[{j}];"));
            self.line("var side = 0.0;");
            self.line("var gap = 0.0;");
            self.line("if lo < reach { side = 1.0; gap = lo; } else if hi < reach { side = -1.0; gap = hi; }");
            self.open("if side != 0.0");
            self.line("// J = side e_j: its root part in (q̇_root, u) is side C_b[j]; W = A⁻¹ Jᵀ.");
            self.line("var w: array<f32, 6>;");
            for k in 0..6 {
                self.line(format!("w[{k}] = side * cc[{j}][{k}];"));
            }
            self.line("s_solve(&w);");
            self.line("var y: array<f32, NCH>;");
            self.line(format!("y[{j}] = side;"));
            self.line("b_solve(&y);");
            for i in 0..n {
                let t: String = (0..6)
                    .map(|k| format!(" + cc[{i}][{k}] * w[{k}]"))
                    .collect();
                self.line(format!("l_wb[{j}][{i}] = y[{i}]{t};"));
            }
            self.line(format!("l_wr[{j}] = w;"));
            self.line(format!(
                "let row = normal_row(gap, side * qd0[{j}], side * l_wb[{j}][{j}], {a0});"
            ));
            self.line(format!("l_on[{j}] = true;"));
            self.line(format!("l_sd[{j}] = side;"));
            self.line(format!("l_tgt[{j}] = row.tgt;"));
            self.line(format!("l_r[{j}] = row.r;"));
            self.line(format!("l_meff[{j}] = row.meff;"));
            self.line(format!("l_lam[{j}] = 0.0;"));
            self.line(format!(
                "l_slot[{j}] = LIMIT_SLOT + 2u * {dof} + select(1u, 0u, side > 0.0);"
            ));
            self.close();
            self.close();
        }
        self.close();
        self.line("");
    }

    /// Emits `x` applied through row `row`'s W (root part in `wr`, chain part in `wb`) to the
    /// root's and this chain's velocities.
    pub(super) fn branch_push(&mut self, n: usize, (wr, wb, row): (&str, &str, &str), x: &str) {
        self.line(format!(
            "rv += vec3<f32>({wr}[{row}][0], {wr}[{row}][1], {wr}[{row}][2]) * {x};"
        ));
        self.line(format!(
            "rw += vec3<f32>({wr}[{row}][3], {wr}[{row}][4], {wr}[{row}][5]) * {x};"
        ));
        for i in 0..n {
            self.line(format!("qd[{i}] += {wb}[{row}][{i}] * {x};"));
        }
    }

    /// Emits: this chain's velocities follow the root's change `(dv, dw)` made elsewhere.
    fn branch_follow(&mut self, n: usize, dv: &str, dw: &str) {
        for i in 0..n {
            self.line(format!(
                "qd[{i}] += dot(vec3<f32>(cc[{i}][0], cc[{i}][1], cc[{i}][2]), {dv}) + dot(vec3<f32>(cc[{i}][3], cc[{i}][4], cc[{i}][5]), {dw});"
            ));
        }
    }

    pub(super) fn branch_solver(&mut self, br: &Branches) {
        let n = br.chain_len();
        let bm = Self::masked(br);
        self.line("// Warm starts: the last substep's impulses of the rows with the same slot, each lane's");
        self.line("// in its own entries; the root takes every lane's, each chain the others' through C_b.");
        self.open("fn warm_start()");
        self.line("if first_substep && inp[lay[LAY_IN_FRESH] + env] != 0.0 { return; }");
        self.line("let v0 = rv;");
        self.line("let w0 = rw;");
        // Every entry is loaded before anything waits on one; an entry that does not match
        // pushes a zero impulse (selects, not branches).
        for j in 0..n {
            self.line(format!("let lk{j} = lane * WARM_LANE + C_CAP + {j}u;"));
            self.line(format!(
                "let lw{j} = vec2<f32>(warm[warm_addr(lk{j}, 0u)], warm[warm_addr(lk{j}, 1u)]);"
            ));
        }
        self.branch_contact_warm(br);
        for j in 0..n {
            self.line(format!(
                "l_lam[{j}] = select(0.0, lw{j}.y, l_on[{j}] && bitcast<u32>(lw{j}.x) == l_slot[{j}] && lw{j}.y != 0.0);"
            ));
            self.branch_push(n, ("l_wr", "l_wb", &j.to_string()), &format!("l_lam[{j}]"));
        }
        self.line(format!("let dv = quad_sum3((rv - v0){bm});"));
        self.line(format!("let dw = quad_sum3((rw - w0){bm});"));
        self.branch_follow(n, "v0 + dv - rv", "w0 + dw - rw");
        self.line("rv = v0 + dv;");
        self.line("rw = w0 + dw;");
        self.close();
        self.line("");
        self.open("fn store_warm()");
        self.branch_contact_store(br);
        for j in 0..n {
            self.line(format!("let k{j} = lane * WARM_LANE + C_CAP + {j}u;"));
            self.line(format!(
                "warm[warm_addr(k{j}, 0u)] = bitcast<f32>(select(0xFFFFFFFFu, l_slot[{j}], l_on[{j}]));"
            ));
            self.line(format!(
                "warm[warm_addr(k{j}, 1u)] = select(0.0, l_lam[{j}], l_on[{j}]);"
            ));
        }
        self.close();
        self.line("");
        self.line(
            "// The soft step's relaxation rows: penetrating rows become rigid with target 0.",
        );
        self.open("fn relax_rows()");
        self.branch_contact_relax(br);
        for j in 0..n {
            self.open(format!("if l_on[{j}] && l_r[{j}] != 0.0"));
            self.line(format!(
                "l_meff[{j}] = 1.0 / max(1.0 / l_meff[{j}] - l_r[{j}], 1e-12);"
            ));
            self.line(format!("l_r[{j}] = 0.0;"));
            self.line(format!("l_tgt[{j}] = 0.0;"));
            self.close();
        }
        self.close();
        self.line("");
        self.line(
            "// `sweeps` of over-relaxed projected Gauss–Seidel: the branches' rows in turn, then",
        );
        self.line("// the other lanes take the root's velocity from the owner.");
        self.open("fn solve(sweeps: u32)");
        self.open("for (var it = 0u; it < sweeps; it++)");
        self.line(
            "// One copy of the turn's code: the owner's velocity by a shuffle within the quad.",
        );
        self.open("for (var t = 0u; t < NBR; t++)");
        // Every lane runs the turn on its own rows and keeps only the owner's changes: a branch
        // on the owner (or on a row being active) costs the quad more than the idle arithmetic.
        self.open("");
        self.line("let own = lane == t;");
        self.branch_contact_visits(br);
        for j in 0..n {
            self.open("");
            self.line(format!("let lam = l_lam[{j}];"));
            self.line(format!(
                "let nl = normal_impulse(lam, l_sd[{j}] * qd[{j}], l_tgt[{j}], l_r[{j}], l_meff[{j}]);"
            ));
            self.line("let dl = select(0.0, nl - lam, own);");
            self.branch_push(n, ("l_wr", "l_wb", &j.to_string()), "dl");
            self.line(format!("l_lam[{j}] = select(lam, nl, own);"));
            self.close();
        }
        self.close();
        self.line("let owner = (sid & ~3u) | t;");
        self.line("let nv = subgroupShuffle(rv, owner);");
        self.line("let nw = subgroupShuffle(rw, owner);");
        self.line("// The owner's own difference is zero.");
        self.branch_follow(n, "nv - rv", "nw - rw");
        self.line("rv = nv;");
        self.line("rw = nw;");
        self.close();
        self.close();
        self.close();
        self.line("");
    }

    pub(super) fn branch_integrate(&mut self, br: &Branches) {
        let s = self.scene;
        self.line(
            "// Velocity limits, then semi-implicit Euler (the root's quaternion renormalised).",
        );
        self.open("fn integrate()");
        for j in 0..br.chain_len() {
            if self.any_dof(br, j, |d| s.dofs[d].velocity_limit.is_finite()) {
                let v = self.lane_dof_f(br, j, |d| s.dofs[d].velocity_limit);
                self.line(format!("qd[{j}] = clamp(qd[{j}], -{v}, {v});"));
            }
            self.line(format!("q[{j}] += DT * qd[{j}];"));
        }
        self.line("fcom = fcom + DT * rv;");
        self.line("rrot = normalize(rrot + qmul(vec4<f32>(rw, 0.0), rrot) * (0.5 * DT));");
        self.close();
        self.line("");
    }

    pub(super) fn branch_state_io(&mut self, br: &Branches) {
        let s = self.scene;
        let strides = self.link_strides();
        let n = br.chain_len();
        let stride = s.articulations[0].joint_dofs();
        let (_, links, local) = strides[br.root];
        let ra = |k: u32| format!("link_addr({k}u, {}u, {links}u, {local}u)", br.root);
        let drives = (0..n).any(|j| {
            self.any_dof(br, j, |d| {
                s.dofs[d].stiffness > 0.0 || s.dofs[d].drive_damping > 0.0
            })
        });
        self.open("fn load_state()");
        self.line("bmask = select(0.0, 1.0, lane < NBR);");
        self.line(format!("let rot = normalize(ld4({}));", ra(1)));
        self.line(format!("let w = ld3({});", ra(3)));
        self.line(format!(
            "let c = qrot(rot, {});",
            v3(s.links[br.root].inertial.com)
        ));
        self.line("rrot = rot;");
        self.line(format!("shift = ld3({}) + c;", ra(0)));
        self.line("fcom = vec3<f32>(0.0);");
        self.line(format!("rv = ld3({}) + cross(w, c);", ra(2)));
        self.line("rw = w;");
        self.line(format!(
            "rms = inp[lay[LAY_IN_MASS_SCALE] + env * NB + {}u];",
            br.root
        ));
        for j in 0..n {
            let d = self.lane_dof(br, j);
            let l = self.per_lane(br, j, |l| format!("{l}u"));
            self.open("");
            self.line(format!("let d = {d};"));
            self.line(format!("q[{j}] = st[dof_addr(0u, d, {stride}u)];"));
            self.line(format!("qd[{j}] = st[dof_addr(1u, d, {stride}u)];"));
            self.line(format!(
                "ms[{j}] = inp[lay[LAY_IN_MASS_SCALE] + env * NB + {l}];"
            ));
            self.line(format!("in_ef[{j}] = inp[inp_addr(2u, d, {stride}u)];"));
            self.line(format!(
                "in_comp[{j}] = inp[lay[LAY_IN_COMPENSATE] + d] != 0.0;"
            ));
            if drives {
                self.line(format!("in_qt[{j}] = inp[inp_addr(0u, d, {stride}u)];"));
                self.line(format!("in_vt[{j}] = inp[inp_addr(1u, d, {stride}u)];"));
            }
            self.close();
        }
        self.line("load_frictions();");
        self.close();
        self.line("");
        self.open("fn load_applied()");
        for j in 0..n {
            let d = self.lane_dof(br, j);
            self.line(format!("applied[{j}] = st[dof_addr(3u, {d}, {stride}u)];"));
        }
        self.close();
        self.line("");
        self.open("fn publish()");
        self.line("kinematics();");
        self.line("rnea_bias();");
        self.open("if lane < NBR");
        for j in 0..n {
            let d = self.lane_dof(br, j);
            let l = self.per_lane(br, j, |l| format!("{l}u"));
            let loc = self.per_lane(br, j, |l| format!("{}u", strides[l].2));
            self.open("");
            self.line(format!("let d = {d};"));
            self.line(format!("st[dof_addr(0u, d, {stride}u)] = q[{j}];"));
            self.line(format!("st[dof_addr(1u, d, {stride}u)] = qd[{j}];"));
            self.line(format!("st[dof_addr(2u, d, {stride}u)] = bias[{j}];"));
            self.line(format!("st[dof_addr(3u, d, {stride}u)] = applied[{j}];"));
            self.line(format!("let l = {l};"));
            self.line(format!("let loc = {loc};"));
            self.line(format!(
                "st3(link_addr(0u, l, {links}u, loc), lpos[{j}] + shift);"
            ));
            self.line(format!("st4(link_addr(1u, l, {links}u, loc), lrot[{j}]);"));
            self.line(format!(
                "st3(link_addr(2u, l, {links}u, loc), vu[{j}] + cross(vw[{j}], lpos[{j}]));"
            ));
            self.line(format!("st3(link_addr(3u, l, {links}u, loc), vw[{j}]);"));
            self.close();
        }
        self.close();
        self.open("if lane == 0u");
        self.line(format!("st3({}, rpos + shift);", ra(0)));
        self.line(format!("st4({}, rrot);", ra(1)));
        self.line(format!("st3({}, rvu + cross(rvw, rpos));", ra(2)));
        self.line(format!("st3({}, rvw);", ra(3)));
        self.close();
        self.close();
        self.line("");
    }
}
