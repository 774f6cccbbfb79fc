//! The one-thread-per-branch kernel's contacts: each lane runs the narrow phase over its shape
//! pairs (`branch_narrow_phase.rs`), then keeps the rows of its first
//! contact in arrays indexed by constants (registers) and those of any further contacts in
//! arrays indexed at run time (local memory): a leg mostly touches the ground at one point, and
//! registers for more slots would spill (docs/experiments/ant-four-threads-per-env.md). Each
//! row is `W`'s six root entries and its chain's, and its chain's Jacobian entries.

use super::Gen;
use super::branch_threads::Branches;

impl Gen<'_> {
    /// Warm-start entries per lane: its contact slots, then one per chain dof.
    pub(super) fn warm_per_lane(br: &Branches) -> usize {
        br.contact_slots + br.chain_len()
    }

    pub(super) fn branch_contact_state(&mut self, br: &Branches) {
        let c = br.contact_slots.max(1);
        self.geometry_constants();
        self.line("// Contacts a lane keeps (the deepest) and its slots of contact rows.");
        self.line(format!("const C_CAP = {}u;", br.contact_slots));
        self.line(format!("const CX = {c}u;"));
        self.line(format!("const WARM_LANE = {}u;", Self::warm_per_lane(br)));
        self.line("// This lane's contacts of the substep, from the narrow phase.");
        self.line("var<private> nc: u32;");
        for v in ["c_n: array<vec3<f32>", "c_p: array<vec3<f32>"] {
            self.line(format!("var<private> {v}, MAX_C>;"));
        }
        for v in [
            "c_sep: array<f32",
            "c_mu: array<f32",
            "c_ba: array<i32",
            "c_bb: array<i32",
        ] {
            self.line(format!("var<private> {v}, MAX_C>;"));
        }
        self.line("var<private> c_slot: array<u32, MAX_C>;");
        self.line(
            "// A contact's slot (k_ for the first, in registers; kx_ for the others, at their",
        );
        self.line(
            "// index): its frame (normal, tangents) times the root factor (side a moving minus",
        );
        self.line(
            "// side b moving), lever from the root's centre of mass, friction, warm-start slot;",
        );
        self.line(
            "// its rows 3c + d: the chain's Jacobian entries and W's root and chain parts; effective",
        );
        self.line("// masses, targets, the normal row's regulariser and the impulses.");
        for (p, len) in [("k_", "1"), ("kx_", "CX")] {
            for v in ["mu", "r"] {
                self.line(format!("var<private> {p}{v}: array<f32, {len}>;"));
            }
            for v in ["lv", "meff", "tgt", "lam"] {
                self.line(format!("var<private> {p}{v}: array<vec3<f32>, {len}>;"));
            }
            self.line(format!("var<private> {p}fb: array<mat3x3<f32>, {len}>;"));
            self.line(format!("var<private> {p}slot: array<u32, {len}>;"));
            self.line(format!(
                "var<private> {p}jb: array<array<f32, NCH>, 3 * {len}>;"
            ));
            self.line(format!(
                "var<private> {p}wr: array<array<f32, 6>, 3 * {len}>;"
            ));
            self.line(format!(
                "var<private> {p}wb: array<array<f32, NCH>, 3 * {len}>;"
            ));
        }
        self.line("");
        self.line("// The chain slot of body b on this lane, -1 for the root's link or none.");
        self.open("fn body_slot(b: i32) -> i32");
        self.line("var s = -1;");
        for j in 0..br.chain_len() {
            let l = self.per_lane(br, j, |l| format!("{l}"));
            self.line(format!("s = select(s, {j}, b == {l});"));
        }
        self.line("return s;");
        self.close();
        self.line("");
    }

    /// Emits `body` for this lane's first contact (`k_`, index `0u`), then in a loop for the
    /// others (`kx_`, index `c`).
    fn each_contact(&mut self, br: &Branches, body: impl Fn(&mut Self, &str, &str)) {
        if br.contact_slots == 0 {
            return;
        }
        self.open("if 0u < nc");
        body(self, "k_", "0u");
        self.close();
        self.open("for (var c = 1u; c < nc; c++)");
        body(self, "kx_", "c");
        self.close();
    }

    pub(super) fn branch_contact_rows(&mut self, br: &Branches) {
        self.line("// The rows of this lane's contacts; without one, the first slot is inert (no");
        self.line("// effective mass, no friction) for the sweeps, which visit it regardless.");
        self.open("fn build_contacts()");
        if br.contact_slots > 0 {
            self.line("k_meff[0u] = vec3<f32>(0.0);");
            self.line("k_mu[0u] = 0.0;");
            self.line("k_lam[0u] = vec3<f32>(0.0);");
        }
        self.each_contact(br, |g, p, c| g.contact_build(br.chain_len(), p, c));
        self.close();
        self.line("");
    }

    /// Emits the rows of contact `c` (from the narrow phase's arrays) into the `p` slots.
    fn contact_build(&mut self, n: usize, p: &str, c: &str) {
        self.line(format!("let ba = c_ba[{c}];"));
        self.line(format!("let bb = c_bb[{c}];"));
        self.line(format!("let p = c_p[{c}];"));
        self.line(format!("let basis = contact_basis(c_n[{c}]);"));
        self.line("let f = f32(i32(ba >= 0) - i32(bb >= 0));");
        self.line("let lever = p - fcom;");
        self.line("let sa = body_slot(ba);");
        self.line("let sb = body_slot(bb);");
        // f is ±1: the sweeps' products with the scaled frame round as with f applied after.
        self.line(format!("{p}fb[{c}] = f * basis;"));
        self.line(format!("{p}lv[{c}] = lever;"));
        self.line(format!("{p}mu[{c}] = c_mu[{c}];"));
        self.line(format!("{p}slot[{c}] = c_slot[{c}];"));
        self.line("var a = vec3<f32>(0.0);");
        self.line("var v0 = vec3<f32>(0.0);");
        for d in 0..3 {
            let row = format!("3u * {c} + {d}u");
            self.open("");
            self.line(format!("let dir = basis[{d}];"));
            self.line("var jb: array<f32, NCH>;");
            for j in 0..n {
                self.line(format!(
                    "jb[{j}] = (select(0.0, 1.0, sa >= {j}) - select(0.0, 1.0, sb >= {j})) * dot(dir, cross(sw[{j}], p) + su[{j}]);"
                ));
            }
            self.line("let jl = f * dir;");
            self.line("let ja = f * cross(lever, dir);");
            self.line("// The root part in (q̇_root, u): J_root + J_b C_b.");
            self.line("var jt: array<f32, 6>;");
            for k in 0..6 {
                let base = format!("{}.{}", ["jl", "ja"][k / 3], ["x", "y", "z"][k % 3]);
                let t: String = (0..n)
                    .map(|j| format!(" + jb[{j}] * cc[{j}][{k}]"))
                    .collect();
                self.line(format!("jt[{k}] = {base}{t};"));
            }
            self.line("var w = jt;");
            self.line("s_solve(&w);");
            self.line("var y = jb;");
            self.line("b_solve(&y);");
            let ta: String = (0..6).map(|k| format!(" + jt[{k}] * w[{k}]")).collect();
            let tb: String = (0..n).map(|j| format!(" + jb[{j}] * y[{j}]")).collect();
            self.line(format!("a[{d}] = 0.0{ta}{tb};"));
            self.line(format!("{p}jb[{row}] = jb;"));
            self.line(format!("{p}wr[{row}] = w;"));
            for i in 0..n {
                let t: String = (0..6)
                    .map(|k| format!(" + cc[{i}][{k}] * w[{k}]"))
                    .collect();
                self.line(format!("{p}wb[{row}][{i}] = y[{i}]{t};"));
            }
            let tv: String = (0..n).map(|j| format!(" + jb[{j}] * qd0[{j}]")).collect();
            self.line(format!(
                "v0[{d}] = dot(f * (rv0 + cross(rw0, lever)), dir){tv};"
            ));
            self.close();
        }
        self.line(format!(
            "let nr = normal_row(c_sep[{c}], v0.x, a.x, body_weight(ba) + body_weight(bb));"
        ));
        self.line("let rt = friction_r(nr.r);");
        self.line("var tt = v0.yz * (1.0 - DT * REF_B);");
        self.line(format!(
            "if SOFT_STEP || c_sep[{c}] >= 0.0 {{ tt = vec2<f32>(0.0); }}"
        ));
        self.line(format!(
            "{p}meff[{c}] = vec3<f32>(nr.meff, 1.0 / max(a.yz + rt, vec2<f32>(1e-12)));"
        ));
        self.line(format!("{p}tgt[{c}] = vec3<f32>(nr.tgt, tt);"));
        self.line(format!("{p}r[{c}] = nr.r;"));
        self.line(format!("{p}lam[{c}] = vec3<f32>(0.0);"));
    }

    /// Emits one Gauss–Seidel visit of each of this lane's contacts (its normal row, then both
    /// tangents clamped to the friction disk), as the one-thread kernel's `solve_contact`. Every
    /// lane runs it on its own rows and only the owner's (`own`) changes count, so no branch
    /// splits the quad: the first slot is visited even when inert, the others by the owner.
    pub(super) fn branch_contact_visits(&mut self, br: &Branches) {
        if br.contact_slots == 0 {
            return;
        }
        self.open("");
        self.contact_visit(br.chain_len(), "k_", "0u");
        self.close();
        self.open("for (var c = 1u; c < select(1u, nc, own); c++)");
        self.contact_visit(br.chain_len(), "kx_", "c");
        self.close();
    }

    fn contact_visit(&mut self, n: usize, p: &str, c: &str) {
        let row = |d: usize| format!("3u * {c} + {d}u");
        let jq = |d: usize| -> String {
            (0..n)
                .map(|j| format!(" + {p}jb[{}][{j}] * qd[{j}]", row(d)))
                .collect()
        };
        let (wr, wb) = (format!("{p}wr"), format!("{p}wb"));
        self.line(format!("let basis = {p}fb[{c}];"));
        self.line(format!("let lam = {p}lam[{c}];"));
        self.line(format!("let meff = {p}meff[{c}];"));
        self.line(format!("let tgt = {p}tgt[{c}];"));
        self.line(format!("let r = {p}r[{c}];"));
        self.line(format!("let lever = {p}lv[{c}];"));
        self.line(format!(
            "let jn = dot(rv + cross(rw, lever), basis[0]){};",
            jq(0)
        ));
        self.line("let ln = normal_impulse(lam.x, jn, tgt.x, r, meff.x);");
        // Selects, not branches: an unchanged impulse pushes zero.
        self.line("let dn = select(0.0, ln - lam.x, own);");
        self.branch_push(n, (&wr, &wb, &row(0)), "dn");
        self.line(format!("let lim = {p}mu[{c}] * ln;"));
        self.line("let v = rv + cross(rw, lever);");
        self.line(format!(
            "let jt = vec2<f32>(dot(v, basis[1]){}, dot(v, basis[2]){});",
            jq(1),
            jq(2)
        ));
        self.line(
            "var lt = lam.yz - RELAXATION * meff.yz * (jt - tgt.yz + friction_r(r) * lam.yz);",
        );
        self.line("let mag = length(lt);");
        self.line("lt = select(lt, lt * (lim / max(mag, 1e-20)), mag > lim);");
        self.line("lt = select(vec2<f32>(0.0), lt, lim > 0.0);");
        self.line("let dt = select(vec2<f32>(0.0), lt - lam.yz, own);");
        self.branch_push(n, (&wr, &wb, &row(1)), "dt.x");
        self.branch_push(n, (&wr, &wb, &row(2)), "dt.y");
        self.line(format!(
            "{p}lam[{c}] = select(lam, vec3<f32>(ln, lt), own);"
        ));
    }

    /// Emits the warm start of this lane's contacts: the entry among its own with the same
    /// slot (an entry's slot is unique), if it has a normal impulse; without one the impulses
    /// pushed are zero (selects, not branches).
    pub(super) fn branch_contact_warm(&mut self, br: &Branches) {
        if br.contact_slots == 0 {
            return;
        }
        // All slots first, as independent loads: a search that loads as it compares waits for
        // each load in turn.
        self.line("var wslot: array<u32, C_CAP>;");
        self.open("for (var i = 0u; i < C_CAP; i++)");
        self.line("wslot[i] = bitcast<u32>(warm[warm_addr(lane * WARM_LANE + i, 0u)]);");
        self.close();
        self.each_contact(br, |g, p, c| {
            g.line("var found = C_CAP;");
            g.open("for (var i = 0u; i < C_CAP; i++)");
            g.line(format!("if wslot[i] == {p}slot[{c}] {{ found = i; }}"));
            g.close();
            g.line("let k = lane * WARM_LANE + select(0u, found, found != C_CAP);");
            g.line(
                "let lw = vec3<f32>(warm[warm_addr(k, 1u)], warm[warm_addr(k, 2u)], warm[warm_addr(k, 3u)]);",
            );
            g.line("let lam = select(vec3<f32>(0.0), lw, found != C_CAP && lw.x != 0.0);");
            g.line(format!("{p}lam[{c}] = lam;"));
            let (wr, wb) = (format!("{p}wr"), format!("{p}wb"));
            for d in 0..3 {
                let x = ["lam.x", "lam.y", "lam.z"][d];
                g.branch_push(br.chain_len(), (&wr, &wb, &format!("3u * {c} + {d}u")), x);
            }
        });
    }

    /// Emits the stores of this lane's contacts' warm-start entries (empty past its last).
    pub(super) fn branch_contact_store(&mut self, br: &Branches) {
        if br.contact_slots == 0 {
            return;
        }
        self.open("for (var i = 0u; i < C_CAP; i++)");
        self.line("let k = lane * WARM_LANE + i;");
        self.line("let on = i < nc;");
        self.line("let slot = select(kx_slot[i], k_slot[0], i == 0u);");
        self.line("let lam = select(vec3<f32>(0.0), select(kx_lam[i], k_lam[0], i == 0u), on);");
        self.line("warm[warm_addr(k, 0u)] = bitcast<f32>(select(0xFFFFFFFFu, slot, on));");
        self.line("warm[warm_addr(k, 1u)] = lam.x;");
        self.line("warm[warm_addr(k, 2u)] = lam.y;");
        self.line("warm[warm_addr(k, 3u)] = lam.z;");
        self.close();
    }

    /// Emits the soft step's relaxation of this lane's contacts' normal rows.
    pub(super) fn branch_contact_relax(&mut self, br: &Branches) {
        self.each_contact(br, |g, p, c| {
            g.open(format!("if {p}r[{c}] != 0.0"));
            g.line(format!(
                "{p}meff[{c}].x = 1.0 / max(1.0 / {p}meff[{c}].x - {p}r[{c}], 1e-12);"
            ));
            g.line(format!("{p}r[{c}] = 0.0;"));
            g.line(format!("{p}tgt[{c}].x = 0.0;"));
            g.close();
        });
    }
}
