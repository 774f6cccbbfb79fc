//! Constraint rows: the narrow phase's view of the body poses, the rows' Jacobians and arm
//! terms, and joint-limit rows.

use std::fmt::Write as _;
use std::ops::Range;

use super::row_windows::{JacobianWindows, window_dot};
use super::{Gen, f};
use crate::compile::{CompiledScene, MAX_CONTACTS};

/// Up to this many dofs each joint-limit row is built where its joint is tested; beyond, the
/// tests list the rows and one loop builds them. Building a row inlines a solve with the
/// system matrix, so rows built in place grow the kernel as n², and shader compilers slow down
/// faster than that (docs/physics.md).
const UNROLLED_LIMIT_DOFS: usize = 8;

impl Gen<'_> {
    /// The narrow phase's view of the bodies: their poses copied into arrays that the
    /// data-driven pair loop of `step/narrow_phase.wgsl` indexes at run time, so that the articulation's
    /// own arrays keep constant indices.
    pub(super) fn collide(&mut self) {
        let s = self.scene;
        self.geometry_constants();
        self.line("// Contacts an env keeps (the deepest), and the groups of pairs this invocation tests.");
        self.line("const C_CAP = MAX_C;");
        self.line("fn group_here(g: u32) -> bool { return true; }");
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

    /// The geometry table's length and offsets, and its number of groups of pairs.
    pub(super) fn geometry_constants(&mut self) {
        let geo = self.scene.geometry_table();
        let c = |g: &mut Self, name: &str, v: usize| g.line(format!("const {name} = {v}u;"));
        c(self, "GEO_LEN", geo.data.len().max(1));
        c(self, "GEO_SHAPES", geo.shapes);
        c(self, "GEO_BODIES", geo.bodies);
        c(self, "GEO_GROUPS", geo.groups);
        c(self, "GEO_PAIRS", geo.pairs);
        c(self, "NG", geo.num_groups);
        // The narrow phase's cases for kinds of pairs the scene lacks compile to nothing: a
        // smaller kernel runs faster where one thread's latency sets the step.
        let s = self.scene;
        let kinds = s.pairs.iter().fold(0u32, |m, p| {
            m | 1 << (s.shapes[p.a].kind.code() * 4 + s.shapes[p.b].kind.code())
        });
        self.line(format!("const PAIR_KINDS = {kinds:#x}u;"));
    }

    /// Row Jacobians of points on links, and the arm parts of the rows.
    pub(super) fn jacobians(&mut self) {
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
            for dof in chain {
                let (sw, su) = self.motion(dof);
                self.line(format!(
                    "(*jt)[{dof}] += s * (dot(d, {su}) + dot({sw}, pd));"
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
        self.arm_rows();
    }

    /// The rows' storage and the arm parts of the rows, unrolled over the dofs in both forms:
    /// the solver's sweeps run them for every row, and unrolled, a row's loads from the
    /// storage buffer are issued together rather than one after another. Row `r`'s arm
    /// Jacobian holds the entries from dof [`stored_jacobian`]'s first on (`NJ` floats from
    /// `r · NJ`), or with Jacobian windows (`row_windows`) the first of them, its branch
    /// `br`'s window; its `W` all `ND1` (from `r · ND1`).
    pub(super) fn arm_rows(&mut self) {
        let nd = self.nd();
        let (j0, nj) = stored_jacobian(self.scene);
        self.line(format!("const NJ = {nj}u;"));
        self.root_velocity_of_contacts();
        let windows = JacobianWindows::of(self.scene, j0, nj);
        self.row_branches(windows.as_ref());
        let (rj, rw) = self.row_storage();
        let rj = |k: usize| rj.replace('#', &format!("row * NJ + {k}u"));
        let rw = |d: usize| rw.replace('#', &format!("row * ND1 + {d}u"));
        self.line(
            "// Stores row `row`'s arm Jacobian (for branch `br`) and W = A⁻¹ Jᵀ; returns J W.",
        );
        self.open(
            "fn arm_store(row: u32, jt: array<f32, ND1>, w: array<f32, ND1>, br: u32) -> f32",
        );
        if let Some(win) = &windows {
            self.window_store(win, &rj);
        }
        let mut jw = String::from("0.0");
        for d in 0..nd {
            if d >= j0 && windows.is_none() {
                self.line(format!("{} = jt[{d}];", rj(d - j0)));
            }
            self.line(format!("{} = w[{d}];", rw(d)));
            write!(jw, " + jt[{d}] * w[{d}]").expect("write to string");
        }
        self.line(format!("return {jw};"));
        self.close();
        self.line("");
        self.line("// J_arm q̇ of row `row` (of branch `br`), over the stored entries.");
        self.open("fn arm_dot(row: u32, br: u32) -> f32");
        let dot = match &windows {
            Some(win) => window_dot(win, &rj),
            None => {
                let mut dot = String::from("0.0");
                for d in j0..nd {
                    write!(dot, " + {} * qd[{d}]", rj(d - j0)).expect("write to string");
                }
                dot
            }
        };
        self.line(format!("return {dot};"));
        self.close();
        self.line("");
        self.line("// q̇ += W x for row `row`.");
        self.open("fn arm_axpy(row: u32, x: f32)");
        for d in 0..nd {
            self.line(format!("qd[{d}] += {} * x;", rw(d)));
        }
        self.close();
        self.line("");
    }

    /// `contact_root_vel(c, info)`: the floating root's part of contact c's relative velocity,
    /// `f (v + ω × (p − c))` for the root's centre-of-mass velocity v, angular velocity ω and
    /// centre of mass c, with f = 1 for a contact on its links on side a, −1 on side b, 0 on
    /// both or neither (`ROOT_LINKS`, bits 24–25 of the contact's info). These are the root
    /// dofs' entries of the contact's rows times q̇, which the rows then need not store.
    fn root_velocity_of_contacts(&mut self) {
        let links = computed_root_links(self.scene);
        let (l0, l1) = links.clone().map_or((0, 0), |r| (r.start, r.end));
        self.line(format!("const ROOT_LINKS = vec2<i32>({l0}, {l1});"));
        self.line(
            "// The floating root's part of contact c's relative velocity (side a minus side b).",
        );
        self.open("fn contact_root_vel(c: u32, info: u32) -> vec3<f32>");
        if links.is_none() {
            self.line("// No floating root whose entries the rows leave out.");
            self.line("return vec3<f32>(0.0);");
        } else {
            self.line("let f = f32(i32((info >> 24u) & 3u) - 1);");
            self.line("let w = vec3<f32>(qd[3], qd[4], qd[5]);");
            self.line("return f * (vec3<f32>(qd[0], qd[1], qd[2]) + cross(w, c_p[c] - fcom[0]));");
        }
        self.close();
        self.line("");
    }

    /// Where the rows' arm Jacobians and `W = A⁻¹ Jᵀ` live, as WGSL expressions of an index
    /// `#`: private arrays, or beyond [`PRIVATE_ROW_DOFS`] dofs the `rows` storage buffer.
    fn row_storage(&mut self) -> (String, String) {
        if row_storage_floats(self.scene, 1).is_none() {
            self.line("var<private> r_j: array<f32, RMAX * NJ>;");
            self.line("var<private> r_w: array<f32, RMAX * ND1>;");
            return ("r_j[#]".into(), "r_w[#]".into());
        }
        self.line("// Rows of every env, env-interleaved: J_arm, then W.");
        self.line("@group(0) @binding(6) var<storage, read_write> rows: array<f32>;");
        (
            "rows[(#) * num_envs + env]".into(),
            "rows[(RMAX * NJ + #) * num_envs + env]".into(),
        )
    }

    /// Joint-limit rows for joints that could reach a limit within this substep: each row built
    /// where its test is for up to [`UNROLLED_LIMIT_DOFS`] dofs, in one loop beyond.
    pub(super) fn limit_rows(&mut self) {
        if self.nd() > UNROLLED_LIMIT_DOFS {
            return self.limit_rows_loop();
        }
        self.line("// A limit row when the joint could reach its limit within this substep.");
        self.open("fn limit_rows()");
        self.limit_tests(Some("var jt: array<f32, ND1>;"), |g, d, lower| {
            let (side, gap, slot) = if lower {
                ("1.0", "lo", 2 * d)
            } else {
                ("-1.0", "hi", 2 * d + 1)
            };
            g.line(format!("jt[{d}] = {side};"));
            g.line(format!("limit_row(jt, LIMIT_SLOT + {slot}u, {gap});"));
        });
        self.close();
        self.line("");
    }

    /// Per limited dof, in a block of its own: `reach`, then `prelude`, then the gaps `lo` and
    /// `hi` to its limits, and `row(d, lower)` where the lower or the upper limit is in reach.
    fn limit_tests(&mut self, prelude: Option<&str>, row: impl Fn(&mut Self, usize, bool)) {
        for (d, dof) in self.scene.dofs.iter().enumerate() {
            let (lower, upper) = (dof.lower.is_finite(), dof.upper.is_finite());
            if !lower && !upper {
                continue;
            }
            self.open("");
            self.line(format!("let reach = abs(qd[{d}]) * DT + MARGIN;"));
            if let Some(line) = prelude {
                self.line(line);
            }
            if lower {
                self.line(format!("let lo = q[{d}] - {};", f(dof.lower)));
            }
            if upper {
                self.line(format!("let hi = {} - q[{d}];", f(dof.upper)));
            }
            if lower {
                self.open("if lo < reach");
                row(self, d, true);
            }
            if upper {
                if lower {
                    self.reopen("else if hi < reach");
                } else {
                    self.open("if hi < reach");
                }
                row(self, d, false);
            }
            self.close();
            self.close();
        }
    }

    /// [`Gen::limit_rows`] in two passes: unrolled tests of the limits (the joint state keeps
    /// constant indices, so it stays in registers) that list the rows, then one loop that
    /// builds them.
    fn limit_rows_loop(&mut self) {
        self.line(
            "// Limit rows due this substep: dof, direction and gap, listed before they are built.",
        );
        self.line("var<private> due_dof: array<u32, ND1>;");
        self.line("var<private> due_side: array<f32, ND1>;");
        self.line("var<private> due_gap: array<f32, ND1>;");
        self.line("// A limit row when a joint could reach its limit within this substep.");
        self.open("fn limit_rows()");
        self.line("var due = 0u;");
        self.limit_tests(None, |g, d, lower| {
            let (side, gap) = if lower { ("1.0", "lo") } else { ("-1.0", "hi") };
            g.line(format!("due_dof[due] = {d}u;"));
            g.line(format!("due_side[due] = {side};"));
            g.line(format!("due_gap[due] = {gap};"));
            g.line("due += 1u;");
        });
        self.open("for (var k = 0u; k < due; k++)");
        self.line("var jt: array<f32, ND1>;");
        self.line("let d = due_dof[k];");
        self.line("jt[d] = due_side[k];");
        self.line("let slot = 2u * d + select(1u, 0u, due_side[k] > 0.0);");
        self.line("limit_row(jt, LIMIT_SLOT + slot, due_gap[k]);");
        self.close();
        self.close();
        self.line("");
    }
}

/// Beyond this many dofs the rows' arm Jacobians and `W = A⁻¹ Jᵀ` live in a storage buffer:
/// in private memory they are about `2 (3 C + n) n` floats a thread, more than NVIDIA's driver
/// builds a kernel with at the Humanoid's 27 dofs (docs/experiments/large-kernels.md).
const PRIVATE_ROW_DOFS: usize = 16;

/// Floats of the `rows` storage buffer for `num_envs` envs, or `None` where the rows live in
/// private memory.
pub fn row_storage_floats(scene: &CompiledScene, num_envs: usize) -> Option<usize> {
    let nd = scene.dofs.len();
    let (_, nj) = stored_jacobian(scene);
    (nd > PRIVATE_ROW_DOFS).then(|| (3 * MAX_CONTACTS + nd) * (nj + nd) * num_envs)
}

/// The links of the floating root whose Jacobian entries the rows leave out, computing them
/// from the contact's point instead (`contact_root_vel`): the scene's only floating root, when
/// its six dofs are the first. In the sweeps, which are bound by the rows' bytes at many envs,
/// that is 6 of every row's `2 n` floats.
fn computed_root_links(scene: &CompiledScene) -> Option<Range<usize>> {
    let mut roots = scene.free_roots();
    let (_, root) = roots.next()?;
    if roots.next().is_some() || root.dof0 != 0 {
        return None;
    }
    let block = scene
        .articulations
        .iter()
        .find(|b| b.floating && b.dof0 == 0)?;
    Some(block.link0..block.link0 + block.links)
}

/// The first dof whose entry the rows' arm Jacobians store, and the floats they hold per row
/// (`NJ`): the stored entries, at least one, so that a floating body without joints still
/// declares its array.
fn stored_jacobian(scene: &CompiledScene) -> (usize, usize) {
    let nd = scene.dofs.len();
    let j0 = if computed_root_links(scene).is_some() {
        6
    } else {
        0
    };
    (j0, (nd - j0).max(1))
}
