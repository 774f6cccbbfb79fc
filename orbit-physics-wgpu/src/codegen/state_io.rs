//! The state buffer's loads and stores: `load_state`, `load_applied` and `publish`, with every
//! address a constant of the scene's layout.

use super::{Gen, v3};

impl Gen<'_> {
    /// Whether the kernel works in a frame at the first floating root (one exists) rather
    /// than at the env origin.
    pub(super) fn shifted(&self) -> bool {
        self.scene.free_roots().next().is_some()
    }

    /// ` - shift` in a shifted kernel, else nothing: an env-frame position into the kernel's
    /// frame.
    pub(super) fn minus_shift(&self) -> &'static str {
        if self.shifted() { " - shift" } else { "" }
    }

    /// ` + shift` in a shifted kernel: a kernel-frame position into the env's.
    fn plus_shift(&self) -> &'static str {
        if self.shifted() { " + shift" } else { "" }
    }

    /// `(articulation dofs, links, local link index)` of every link, for buffer addresses.
    pub(super) fn link_strides(&self) -> Vec<(usize, usize, usize)> {
        let mut out = Vec::new();
        for b in &self.scene.articulations {
            out.extend((0..b.links).map(|i| (b.joint_dofs(), b.links, i)));
        }
        out
    }

    pub(super) fn state_io(&mut self) {
        let s = self.scene;
        let strides = self.link_strides();
        let (nl, nd) = (s.links.len(), s.dofs.len());
        // The state buffer holds joint dofs only: (dof, its articulation's joint dofs).
        let joints: Vec<(usize, usize)> = (0..nd)
            .filter(|&d| s.dofs[d].root_axis.is_none())
            .map(|d| (d, self.block(d).joint_dofs()))
            .collect();

        self.open("fn load_state()");
        for &(d, st) in &joints {
            self.line(format!("q[{d}] = st[dof_addr(0u, {d}u, {st}u)];"));
            self.line(format!("qd[{d}] = st[dof_addr(1u, {d}u, {st}u)];"));
        }
        for (l, root) in s.free_roots() {
            let (_, links, local) = strides[l];
            let a = |k: u32| format!("link_addr({k}u, {l}u, {links}u, {local}u)");
            self.line(
                "// A floating root's state is its link's published pose and origin velocity.",
            );
            self.open("");
            self.line(format!("let rot = normalize(ld4({}));", a(1)));
            self.line(format!("let w = ld3({});", a(3)));
            self.line(format!(
                "let c = qrot(rot, {});",
                v3(s.links[l].inertial.com)
            ));
            self.line(format!("lrot[{l}] = rot;"));
            self.line(format!("fcom[{}] = ld3({}) + c;", root.index, a(0)));
            self.line(format!("let v = ld3({}) + cross(w, c);", a(2)));
            for k in 0..3 {
                let x = ["x", "y", "z"][k];
                self.line(format!("qd[{}] = v.{x};", root.dof0 + k));
                self.line(format!("qd[{}] = w.{x};", root.dof0 + 3 + k));
            }
            self.close();
        }
        if let Some((_, first)) = s.free_roots().next() {
            self.line("// The kernel's frame: origin at the first floating root's centre of mass.");
            self.line(format!("shift = fcom[{}];", first.index));
            for (_, root) in s.free_roots() {
                self.line(format!("fcom[{0}] = fcom[{0}] - shift;", root.index));
            }
        }
        for b in 0..s.num_bodies() {
            self.line(format!(
                "mscale[{b}] = inp[lay[LAY_IN_MASS_SCALE] + env * NB + {b}u];"
            ));
        }
        self.line("// Drive inputs hold for the whole dispatch.");
        for &(d, st) in &joints {
            let dof = &s.dofs[d];
            self.line(format!("in_ef[{d}] = inp[inp_addr(2u, {d}u, {st}u)];"));
            self.line(format!(
                "in_comp[{d}] = inp[lay[LAY_IN_COMPENSATE] + {d}u] != 0.0;"
            ));
            if dof.stiffness > 0.0 || dof.drive_damping > 0.0 {
                self.line(format!("in_qt[{d}] = inp[inp_addr(0u, {d}u, {st}u)];"));
                self.line(format!("in_vt[{d}] = inp[inp_addr(1u, {d}u, {st}u)];"));
            }
        }
        self.load_object_lines();
        self.close();

        self.open("fn load_applied()");
        for &(d, st) in &joints {
            self.line(format!("applied[{d}] = st[dof_addr(3u, {d}u, {st}u)];"));
        }
        self.close();

        self.open("fn publish()");
        self.line("kinematics();");
        self.line("rnea_bias();");
        for &(d, st) in &joints {
            self.line(format!("st[dof_addr(0u, {d}u, {st}u)] = q[{d}];"));
            self.line(format!("st[dof_addr(1u, {d}u, {st}u)] = qd[{d}];"));
            self.line(format!("st[dof_addr(2u, {d}u, {st}u)] = bias[{d}];"));
            self.line(format!("st[dof_addr(3u, {d}u, {st}u)] = applied[{d}];"));
        }
        for (l, &(_, links, local)) in strides.iter().enumerate().take(nl) {
            let a = |k: u32| format!("link_addr({k}u, {l}u, {links}u, {local}u)");
            self.line(format!("st3({}, lpos[{l}]{});", a(0), self.plus_shift()));
            self.line(format!("st4({}, lrot[{l}]);", a(1)));
            self.line(format!(
                "st3({}, vu[{l}] + cross(vw[{l}], lpos[{l}]));",
                a(2)
            ));
            self.line(format!("st3({}, vw[{l}]);", a(3)));
        }
        self.publish_object_lines();
        self.close();
        self.line("");
    }

    /// The free objects' part of `load_state`: their state into the kernel's frame.
    pub(super) fn load_object_lines(&mut self) {
        for (o, obj) in self.scene.objects.iter().enumerate() {
            let shift = self.minus_shift();
            self.line(format!("opos[{o}] = ld3(obj_addr(0u, {o}u)){shift};"));
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
    }

    /// The free objects' part of `publish`: their state back in the env frame.
    pub(super) fn publish_object_lines(&mut self) {
        for (o, obj) in self.scene.objects.iter().enumerate() {
            let shift = self.plus_shift();
            self.line(format!("st3(obj_addr(0u, {o}u), opos[{o}]{shift});"));
            self.line(format!("st4(obj_addr(1u, {o}u), orot[{o}]);"));
            self.line(format!(
                "st3(obj_addr(2u, {o}u), ovel[{o}] - cross(oang[{o}], qrot(orot[{o}], {})));",
                v3(obj.com)
            ));
            self.line(format!("st3(obj_addr(3u, {o}u), oang[{o}]);"));
        }
    }
}
