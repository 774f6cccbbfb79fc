//! Integration: velocity limits and semi-implicit Euler for dofs, floating roots and free
//! objects.

use super::{Gen, f, v3};

impl Gen<'_> {
    /// Velocity limits and semi-implicit Euler (quaternions renormalised).
    pub(super) fn integrate(&mut self) {
        self.line("// Velocity limits, then semi-implicit Euler (quaternions renormalised).");
        self.open("fn integrate()");
        for (d, dof) in self.scene.dofs.iter().enumerate() {
            if dof.root_axis.is_some() {
                continue;
            }
            if dof.velocity_limit.is_finite() {
                let v = dof.velocity_limit;
                self.line(format!("qd[{d}] = clamp(qd[{d}], {}, {});", f(-v), f(v)));
            }
            self.line(format!("q[{d}] += DT * qd[{d}];"));
        }
        let roots: Vec<_> = self.scene.free_roots().collect();
        for (l, root) in roots {
            let (v, w) = Self::root_velocity(root);
            let i = root.index;
            self.open("");
            self.line(format!("fcom[{i}] = fcom[{i}] + DT * {v};"));
            self.line(format!(
                "lrot[{l}] = normalize(lrot[{l}] + qmul(vec4<f32>({w}, 0.0), lrot[{l}]) * (0.5 * DT));"
            ));
            self.close();
        }
        self.integrate_object_lines();
        self.close();
        self.line("");
    }

    /// Semi-implicit Euler of the free objects (quaternions renormalised).
    pub(super) fn integrate_object_lines(&mut self) {
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
    }
}
