//! Statements that both forms of the straight-line kernel emit, one thread per env or per
//! branch: a joint link's kinematics, a body's spatial inertia, the bias forces' recursion, a
//! dof's drive and a dense Cholesky factorisation. Each takes the WGSL expressions of its
//! inputs, so the forms differ only in where their quantities live.

use std::fmt::Write as _;

use super::Gen;

impl Gen<'_> {
    /// Emits the kinematics of joint link `i` (its entries of `lpos`, `lrot`, `sw`, `su`, `vw`,
    /// `vu`) from its parent's pose and velocity `[pos, rot, vw, vu]`, its joint frame and axis
    /// `(origin position, origin rotation, axis)`, its kind and its joint's `(q, q̇)`; leaves
    /// `pos` and `rot` in scope.
    pub(super) fn joint_link_kinematics(
        &mut self,
        i: &str,
        [pp, pr, pw, pu]: [&str; 4],
        (opos, orot, axis): (&str, &str, &str),
        prismatic: bool,
        (q, qd): (&str, &str),
    ) {
        self.line(format!("var pos = {pp} + qrot({pr}, {opos});"));
        self.line(format!("var rot = qmul({pr}, {orot});"));
        self.line(format!("let axis_w = qrot(rot, {axis});"));
        if prismatic {
            self.line(format!("pos = pos + axis_w * {q};"));
            self.line(format!("sw[{i}] = vec3<f32>(0.0);"));
            self.line(format!("su[{i}] = axis_w;"));
        } else {
            self.line(format!("rot = qmul(rot, qaxis({axis}, {q}));"));
            self.line(format!("sw[{i}] = axis_w;"));
            self.line(format!("su[{i}] = cross(pos, axis_w);"));
        }
        self.line(format!("lpos[{i}] = pos;"));
        self.line(format!("lrot[{i}] = rot;"));
        self.line(format!("vw[{i}] = {pw} + sw[{i}] * {qd};"));
        self.line(format!("vu[{i}] = {pu} + su[{i}] * {qd};"));
    }

    /// Emits the spatial inertia at the kernel's origin of a body at `pos`, `rot` (in scope) of
    /// mass `mass`, centre of mass `com` and inertia `inertia` (body frame), all scaled by
    /// `scale`, into mass, first moment and rotational inertia `dst`.
    pub(super) fn spatial_inertia_at(
        &mut self,
        scale: &str,
        mass: &str,
        com: &str,
        inertia: &str,
        dst: [&str; 3],
    ) {
        self.line(format!("let m = {mass} * {scale};"));
        self.line(format!("let c = pos + qrot(rot, {com});"));
        self.line("let r = qmat(rot);");
        self.line(format!(
            "let ic = r * ({inertia} * {scale}) * transpose(r);"
        ));
        self.line("let cc = dot(c, c);");
        self.line(format!("{} = m;", dst[0]));
        self.line(format!("{} = m * c;", dst[1]));
        self.line(format!(
            "{} = ic + m * (mat3x3<f32>(cc, 0.0, 0.0, 0.0, cc, 0.0, 0.0, 0.0, cc) - outer(c, c));",
            dst[2]
        ));
    }

    /// Emits link `n`'s bias acceleration `(aw{n}, au{n})`: its parent's `(aw0, au0)` plus
    /// `(v × S) q̇` for its joint (motion subspace `sw[i]`, `su[i]`, velocity `vw[i]`, `vu[i]`,
    /// joint speed `qd`).
    pub(super) fn joint_acceleration(
        &mut self,
        n: &str,
        i: &str,
        (aw0, au0): (&str, &str),
        qd: &str,
    ) {
        self.line(format!(
            "let aw{n} = {aw0} + cross(vw[{i}], sw[{i}]) * {qd};"
        ));
        self.line(format!(
            "let au{n} = {au0} + (cross(vw[{i}], su[{i}]) + cross(vu[{i}], sw[{i}])) * {qd};"
        ));
    }

    /// Emits link `n`'s force `(fw{n}, fu{n}) = I a + v ×* (I v)` from its acceleration
    /// `(aw{n}, au{n})`, its inertia and velocity at `at("ij")`, `at("ih")`, `at("im")`,
    /// `at("vw")` and `at("vu")`.
    pub(super) fn link_force(&mut self, n: &str, at: &dyn Fn(&str) -> String) {
        let (ij, ih, im, vw, vu) = (at("ij"), at("ih"), at("im"), at("vw"), at("vu"));
        self.line(format!("let ivw{n} = {ij} * {vw} + cross({ih}, {vu});"));
        self.line(format!("let ivu{n} = {im} * {vu} - cross({ih}, {vw});"));
        self.line(format!(
            "var fw{n} = {ij} * aw{n} + cross({ih}, au{n}) + cross({vw}, ivw{n}) + cross({vu}, ivu{n});"
        ));
        self.line(format!(
            "var fu{n} = {im} * au{n} - cross({ih}, aw{n}) + cross({vw}, ivu{n});"
        ));
    }

    /// Emits dof `i`'s drive (its entries of `in_*`, `q`, `qd`, `bias`, `applied` and `dv`):
    /// the effort, implicit while the drive stays inside its effort limit, its terms added to
    /// the system matrix's diagonal entry `diag`, and `dv[i]`.
    pub(super) fn drive_lines(&mut self, i: &str, diag: &str, t: &DriveTerms) {
        let DriveTerms {
            k,
            dd,
            lim,
            neg_lim,
            dd_damp,
            damp,
            ..
        } = t;
        self.line(format!("var ef = in_ef[{i}];"));
        self.line(format!("if in_comp[{i}] {{ ef += bias[{i}]; }}"));
        if t.driven {
            self.line(format!("let qt = in_qt[{i}];"));
            self.line(format!("let vt = in_vt[{i}];"));
            self.line(format!(
                "let pd = {k} * (qt - q[{i}]) + {dd} * (vt - qd[{i}]);"
            ));
            self.line("var tau: f32;");
            self.line("// Implicit while the drive stays inside its effort limit.");
            self.open(format!("if abs(pd + ef) <= {lim}"));
            self.line(format!(
                "tau = ef + {k} * (qt - q[{i}] - DT * qd[{i}]) + {dd} * (vt - qd[{i}]);"
            ));
            self.line(format!("{diag} = {diag} + DT * {dd_damp} + DT * DT * {k};"));
            self.close();
            self.open("else");
            self.line(format!("tau = clamp(pd + ef, {neg_lim}, {lim});"));
            if t.damped {
                self.line(format!("{diag} = {diag} + DT * {damp};"));
            }
            self.close();
            self.line(format!("applied[{i}] = clamp(pd + ef, {neg_lim}, {lim});"));
        } else {
            self.line(format!("let tau = clamp(ef, {neg_lim}, {lim});"));
            self.line(format!("applied[{i}] = tau;"));
            if t.damped {
                self.line(format!("{diag} = {diag} + DT * {damp};"));
            }
        }
        let spring = if t.sprung {
            format!(" - {} * (q[{i}] - {})", t.spring, t.spring_ref)
        } else {
            String::new()
        };
        self.line(format!(
            "dv[{i}] = DT * (tau - {damp} * qd[{i}]{spring} - bias[{i}]);"
        ));
    }
}

/// A dof's drive as WGSL expressions: stiffness, drive damping, effort limit and its negative,
/// drive plus joint damping, joint damping; whether it has a drive, and damping.
pub(super) struct DriveTerms {
    pub k: String,
    pub dd: String,
    pub lim: String,
    pub neg_lim: String,
    pub dd_damp: String,
    pub damp: String,
    /// Passive spring stiffness and rest position.
    pub spring: String,
    pub spring_ref: String,
    pub driven: bool,
    pub damped: bool,
    pub sprung: bool,
}

/// An unrolled Cholesky factorisation `A = L Lᵀ` in place of the lower triangle in the WGSL
/// array `m` (`n` rows, row stride `n`), its inverse diagonal in `inv`, each row `i` coupled
/// only to the rows of its block `block(i) = (first row, rows)`.
pub(super) struct DenseCholesky<'a> {
    pub m: &'a str,
    pub inv: &'a str,
    pub n: usize,
    pub block: &'a dyn Fn(usize) -> (usize, usize),
}

impl DenseCholesky<'_> {
    fn at(&self, i: usize, j: usize) -> String {
        format!("{}[{}]", self.m, i * self.n + j)
    }

    /// The statements that factorise the matrix.
    pub fn factor_lines(&self) -> Vec<String> {
        let (at, inv) = (|i, j| self.at(i, j), self.inv);
        let mut out = Vec::new();
        for j in 0..self.n {
            let (d0, n) = (self.block)(j);
            let mut s = at(j, j);
            for k in d0..j {
                write!(s, " - {} * {}", at(j, k), at(j, k)).expect("write to string");
            }
            out.push(format!("{} = sqrt(max({s}, 1e-12));", at(j, j)));
            out.push(format!("{inv}[{j}] = 1.0 / {};", at(j, j)));
            for i in j + 1..d0 + n {
                let mut t = at(i, j);
                for k in d0..j {
                    write!(t, " - {} * {}", at(i, k), at(j, k)).expect("write to string");
                }
                out.push(format!("{} = ({t}) * {inv}[{j}];", at(i, j)));
            }
        }
        out
    }

    /// The statements that solve `A x = b` in place for `(*b)` with the factor.
    pub fn solve_lines(&self) -> Vec<String> {
        let (at, inv) = (|i, j| self.at(i, j), self.inv);
        let mut out = Vec::new();
        for i in 0..self.n {
            let (d0, _) = (self.block)(i);
            let mut t = format!("(*b)[{i}]");
            for k in d0..i {
                write!(t, " - {} * (*b)[{k}]", at(i, k)).expect("write to string");
            }
            out.push(format!("(*b)[{i}] = ({t}) * {inv}[{i}];"));
        }
        for i in (0..self.n).rev() {
            let (d0, n) = (self.block)(i);
            let mut t = format!("(*b)[{i}]");
            for k in i + 1..d0 + n {
                write!(t, " - {} * (*b)[{k}]", at(k, i)).expect("write to string");
            }
            out.push(format!("(*b)[{i}] = ({t}) * {inv}[{i}];"));
        }
        out
    }
}
