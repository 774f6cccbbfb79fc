// Four threads per env, one per leg. Each holds its leg's rows in registers, the root's
// velocity and its own leg's; the legs take Gauss–Seidel turns, and after each turn the others
// take the root's new velocity (`exchange`) and move their own dofs by C_k Δq̇_root.

// The rows of one leg: a contact's three rows and up to two limit rows.
struct LegRows {
    hc: bool,
    lever: vec3<f32>,
    basis: mat3x3<f32>,
    jk0: vec2<f32>,
    jk1: vec2<f32>,
    jk2: vec2<f32>,
    w0: RowW,
    w1: RowW,
    w2: RowW,
    cr: f32,
    cmeff: vec3<f32>,
    hl1: bool,
    jl0: vec2<f32>,
    wl0: RowW,
    jl1: vec2<f32>,
    wl1: RowW,
}

// A thread's velocities and impulses.
struct LegState {
    vr: vec3<f32>,
    wr: vec3<f32>,
    qk: vec2<f32>,
    lam: vec3<f32>,
    l0: f32,
    l1: f32,
}

fn push(st: ptr<function, LegState>, w: RowW, x: f32) {
    (*st).vr += w.wl * x;
    (*st).wr += w.wa * x;
    (*st).qk += w.wk * x;
}

fn limit_visit(st: ptr<function, LegState>, lam: f32, jk: vec2<f32>, w: RowW) -> f32 {
    let n = normal_impulse(lam, dot(jk, (*st).qk), 0.02, 0.1 * w.a, 1.0 / (1.1 * w.a));
    if n != lam {
        push(st, w, n - lam);
    }
    return n;
}

// The owner's turn: its contact, then its limit rows.
fn turn(rows: ptr<function, LegRows>, st: ptr<function, LegState>) {
    let r = *rows;
    if r.hc {
        let lam = (*st).lam;
        let jn = dot((*st).vr + cross((*st).wr, r.lever), r.basis[0]) + dot(r.jk0, (*st).qk);
        let ln = normal_impulse(lam.x, jn, 0.05, r.cr, r.cmeff.x);
        if ln != lam.x {
            push(st, r.w0, ln - lam.x);
        }
        var lt = vec2<f32>(0.0);
        if ln > 0.0 {
            let v = (*st).vr + cross((*st).wr, r.lever);
            let jt = vec2<f32>(dot(v, r.basis[1]) + dot(r.jk1, (*st).qk), dot(v, r.basis[2]) + dot(r.jk2, (*st).qk));
            lt = lam.yz - RELAX * r.cmeff.yz * (jt + r.cr / 3.0 * lam.yz);
            let mag = length(lt);
            if mag > ln {
                lt *= ln / max(mag, 1e-20);
            }
        }
        let dt = lt - lam.yz;
        if any(dt != vec2<f32>(0.0)) {
            push(st, r.w1, dt.x);
            push(st, r.w2, dt.y);
        }
        (*st).lam = vec3<f32>(ln, lt);
    }
    (*st).l0 = limit_visit(st, (*st).l0, r.jl0, r.wl0);
    if r.hl1 {
        (*st).l1 = limit_visit(st, (*st).l1, r.jl1, r.wl1);
    }
}

fn leg_rows(env: u32, s: u32, k: u32, fc: vec3<f32>, ck0l: vec3<f32>, ck0a: vec3<f32>, ck1l: vec3<f32>, ck1a: vec3<f32>, iml: vec3<f32>, ima: vec3<f32>, id: vec2<f32>) -> LegRows {
    var r: LegRows;
    r.hc = has_contact(env, s, k);
    r.lever = contact_p(env, s, k) - fc;
    r.basis = contact_basis(contact_n(env, s, k));
    r.jk0 = contact_jk(env, s, k, 0u);
    r.jk1 = contact_jk(env, s, k, 1u);
    r.jk2 = contact_jk(env, s, k, 2u);
    r.w0 = row_w(r.basis[0], r.lever, r.jk0, ck0l, ck0a, ck1l, ck1a, iml, ima, id);
    r.w1 = row_w(r.basis[1], r.lever, r.jk1, ck0l, ck0a, ck1l, ck1a, iml, ima, id);
    r.w2 = row_w(r.basis[2], r.lever, r.jk2, ck0l, ck0a, ck1l, ck1a, iml, ima, id);
    r.cr = 0.1 * r.w0.a;
    r.cmeff = vec3<f32>(1.0 / (r.w0.a + r.cr), 1.0 / (vec2<f32>(r.w1.a, r.w2.a) + r.cr / 3.0));
    r.hl1 = has_lim2(env, s, k);
    r.jl0 = lim_jk(env, s, k, 0u);
    r.wl0 = row_w(vec3<f32>(0.0), vec3<f32>(0.0), r.jl0, ck0l, ck0a, ck1l, ck1a, iml, ima, id);
    r.jl1 = lim_jk(env, s, k, 1u);
    r.wl1 = row_w(vec3<f32>(0.0), vec3<f32>(0.0), r.jl1, ck0l, ck0a, ck1l, ck1a, iml, ima, id);
    return r;
}

@compute @workgroup_size(32)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let e = gid.x / 4u;
    let k = gid.x % 4u;
    let slot = li / 4u;
    let live = e < prm.num_envs;
    // Threads past the last env run the last env's work: every thread must reach the barriers.
    let env = min(e, prm.num_envs - 1u);
    let ck0l = vec3<f32>(coup(env, k, 0u, 0u), coup(env, k, 0u, 1u), coup(env, k, 0u, 2u));
    let ck0a = vec3<f32>(coup(env, k, 0u, 3u), coup(env, k, 0u, 4u), coup(env, k, 0u, 5u));
    let ck1l = vec3<f32>(coup(env, k, 1u, 0u), coup(env, k, 1u, 1u), coup(env, k, 1u, 2u));
    let ck1a = vec3<f32>(coup(env, k, 1u, 3u), coup(env, k, 1u, 4u), coup(env, k, 1u, 5u));
    let iml = vec3<f32>(inv_mr(env, 0u), inv_mr(env, 1u), inv_mr(env, 2u));
    let ima = vec3<f32>(inv_mr(env, 3u), inv_mr(env, 4u), inv_mr(env, 5u));
    let id = vec2<f32>(inv_d(env, k, 0u), inv_d(env, k, 1u));
    let fc = com(env);
    var st: LegState;
    st.vr = 0.5 * (vec3<f32>(rnd(env, 100u), rnd(env, 101u), rnd(env, 102u)) - 0.5);
    st.wr = 0.5 * (vec3<f32>(rnd(env, 103u), rnd(env, 104u), rnd(env, 105u)) - 0.5);
    st.qk = 0.5 * (vec2<f32>(rnd(env, 106u + 2u * k), rnd(env, 107u + 2u * k)) - 0.5);
    for (var s = 0u; s < prm.substeps; s++) {
        st.vr *= 0.98;
        st.wr *= 0.98;
        st.qk *= 0.98;
        st.vr.z -= 0.08;
        var rows = leg_rows(env, s, k, fc, ck0l, ck0a, ck1l, ck1a, iml, ima, id);
        st.lam = vec3<f32>(0.0);
        st.l0 = 0.0;
        st.l1 = 0.0;
        for (var it = 0u; it < prm.sweeps; it++) {
            for (var t = 0u; t < 4u; t++) {
                if k == t {
                    turn(&rows, &st);
                }
                let root = exchange(slot, t, k == t, st.vr, st.wr);
                if k != t {
                    let dv = root[0] - st.vr;
                    let dw = root[1] - st.wr;
                    st.qk += vec2<f32>(dot(ck0l, dv) + dot(ck0a, dw), dot(ck1l, dv) + dot(ck1a, dw));
                    st.vr = root[0];
                    st.wr = root[1];
                }
            }
        }
    }
    if live {
        let n = prm.num_envs;
        if k == 0u {
            outq[0u * n + e] = st.vr.x;
            outq[1u * n + e] = st.vr.y;
            outq[2u * n + e] = st.vr.z;
            outq[3u * n + e] = st.wr.x;
            outq[4u * n + e] = st.wr.y;
            outq[5u * n + e] = st.wr.z;
        }
        outq[(6u + 2u * k) * n + e] = st.qk.x;
        outq[(7u + 2u * k) * n + e] = st.qk.y;
    }
}
