//! Integration: velocity limits and semi-implicit Euler for dofs and free objects.

use super::{Gen, f, v3};

impl Gen<'_> {
    /// Velocity limits and semi-implicit Euler (quaternions renormalised).
    pub(super) fn integrate(&mut self) {
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
