//! Free rigid objects: their unconstrained velocity update and the accessors by run-time index
//! that the constraint rows use.

use super::{Gen, f, m3, v3};

impl Gen<'_> {
    /// Free bodies: gravity, the explicit gyroscopic term and world inverse inertias; and the
    /// accessors the constraint rows use.
    pub(super) fn objects(&mut self) {
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
}
