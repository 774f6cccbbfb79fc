// One thread per env, as the generated Ant kernel: the rows in private arrays indexed at run
// time (so in local memory), q̇ in registers, each leg's two Jacobian entries read through a
// chain of selects. `LEG_ORDER` visits the rows leg by leg, in the four-thread order.
const ND = 14u;
const NJ = 8u;
const MAXC = 12u;
const RMAX = 50u;
var<private> qd: array<f32, 14>;
var<private> r_j: array<f32, 400>;
var<private> r_w: array<f32, 700>;
var<private> nc: u32;
var<private> nlim: u32;
var<private> c_n: array<vec3<f32>, 12>;
var<private> c_p: array<vec3<f32>, 12>;
var<private> c_mu: array<f32, 12>;
var<private> k_info: array<u32, 12>;
var<private> k_meff: array<vec3<f32>, 12>;
var<private> k_tgt: array<vec3<f32>, 12>;
var<private> k_r: array<f32, 12>;
var<private> k_lam: array<vec3<f32>, 12>;
var<private> l_meff: array<f32, 14>;
var<private> l_tgt: array<f32, 14>;
var<private> l_r: array<f32, 14>;
var<private> l_lam: array<f32, 14>;
var<private> l_br: array<u32, 14>;
var<private> cc: array<f32, 48>;
var<private> fcom: vec3<f32>;
var<private> env: u32;

fn arm_dot(row: u32, br: u32) -> f32 {
    return 0.0 + r_j[row * NJ + 0u] * select(select(select(qd[6], qd[8], br == 1u), qd[10], br == 2u), qd[12], br == 3u) + r_j[row * NJ + 1u] * select(select(select(qd[7], qd[9], br == 1u), qd[11], br == 2u), qd[13], br == 3u);
}

fn arm_axpy(row: u32, x: f32) {
    qd[0] += r_w[row * ND + 0u] * x;
    qd[1] += r_w[row * ND + 1u] * x;
    qd[2] += r_w[row * ND + 2u] * x;
    qd[3] += r_w[row * ND + 3u] * x;
    qd[4] += r_w[row * ND + 4u] * x;
    qd[5] += r_w[row * ND + 5u] * x;
    qd[6] += r_w[row * ND + 6u] * x;
    qd[7] += r_w[row * ND + 7u] * x;
    qd[8] += r_w[row * ND + 8u] * x;
    qd[9] += r_w[row * ND + 9u] * x;
    qd[10] += r_w[row * ND + 10u] * x;
    qd[11] += r_w[row * ND + 11u] * x;
    qd[12] += r_w[row * ND + 12u] * x;
    qd[13] += r_w[row * ND + 13u] * x;
}

fn ckv(k: u32, e: u32, ang: u32) -> vec3<f32> {
    let b = k * 12u + e * 6u + ang * 3u;
    return vec3<f32>(cc[b], cc[b + 1u], cc[b + 2u]);
}

// Builds row `row` of leg k; returns J W.
fn build_row(row: u32, k: u32, dir: vec3<f32>, lever: vec3<f32>, jk: vec2<f32>) -> f32 {
    let iml = vec3<f32>(inv_mr(env, 0u), inv_mr(env, 1u), inv_mr(env, 2u));
    let ima = vec3<f32>(inv_mr(env, 3u), inv_mr(env, 4u), inv_mr(env, 5u));
    let id = vec2<f32>(inv_d(env, k, 0u), inv_d(env, k, 1u));
    let w = row_w(dir, lever, jk, ckv(k, 0u, 0u), ckv(k, 0u, 1u), ckv(k, 1u, 0u), ckv(k, 1u, 1u), iml, ima, id);
    r_j[row * NJ + 0u] = jk.x;
    r_j[row * NJ + 1u] = jk.y;
    r_w[row * ND + 0u] = w.wl.x;
    r_w[row * ND + 1u] = w.wl.y;
    r_w[row * ND + 2u] = w.wl.z;
    r_w[row * ND + 3u] = w.wa.x;
    r_w[row * ND + 4u] = w.wa.y;
    r_w[row * ND + 5u] = w.wa.z;
    for (var j = 0u; j < 4u; j++) {
        var wj = w.wk;
        if j != k {
            wj = vec2<f32>(dot(ckv(j, 0u, 0u), w.wl) + dot(ckv(j, 0u, 1u), w.wa), dot(ckv(j, 1u, 0u), w.wl) + dot(ckv(j, 1u, 1u), w.wa));
        }
        r_w[row * ND + 6u + 2u * j] = wj.x;
        r_w[row * ND + 7u + 2u * j] = wj.y;
    }
    return w.a;
}

fn build(s: u32) {
    nc = 0u;
    nlim = 0u;
    for (var k = 0u; k < 4u; k++) {
        if has_contact(env, s, k) {
            let c = nc;
            nc += 1u;
            let p = contact_p(env, s, k);
            let n = contact_n(env, s, k);
            c_p[c] = p;
            c_n[c] = n;
            c_mu[c] = 1.0;
            let basis = contact_basis(n);
            var a = vec3<f32>(0.0);
            for (var d = 0u; d < 3u; d++) {
                a[d] = build_row(c * 3u + d, k, basis[d], p - fcom, contact_jk(env, s, k, d));
            }
            k_info[c] = k << 26u;
            let r = 0.1 * a.x;
            k_r[c] = r;
            k_meff[c] = vec3<f32>(1.0 / (a.x + r), 1.0 / (a.yz + r / 3.0));
            k_tgt[c] = vec3<f32>(0.05, 0.0, 0.0);
            k_lam[c] = vec3<f32>(0.0);
        }
    }
    for (var k = 0u; k < 4u; k++) {
        for (var i = 0u; i < 2u; i++) {
            if i == 1u && !has_lim2(env, s, k) {
                continue;
            }
            let l = nlim;
            nlim += 1u;
            let a = build_row(3u * MAXC + l, k, vec3<f32>(0.0), vec3<f32>(0.0), lim_jk(env, s, k, i));
            l_r[l] = 0.1 * a;
            l_meff[l] = 1.0 / (1.1 * a);
            l_tgt[l] = 0.02;
            l_lam[l] = 0.0;
            l_br[l] = k;
        }
    }
}

fn root_vel(c: u32) -> vec3<f32> {
    let w = vec3<f32>(qd[3], qd[4], qd[5]);
    return vec3<f32>(qd[0], qd[1], qd[2]) + cross(w, c_p[c] - fcom);
}

fn solve_contact(c: u32) {
    let info = k_info[c];
    let br = info >> 26u;
    let basis = contact_basis(c_n[c]);
    let row = c * 3u;
    let meff = k_meff[c];
    let lam = k_lam[c];
    let jn = dot(root_vel(c), basis[0]) + arm_dot(row, br);
    let tgt = k_tgt[c];
    let r = k_r[c];
    let ln = normal_impulse(lam.x, jn, tgt.x, r, meff.x);
    if ln != lam.x {
        arm_axpy(row, ln - lam.x);
    }
    let lim = c_mu[c] * ln;
    var lt = vec2<f32>(0.0);
    if lim > 0.0 {
        let v = root_vel(c);
        let jt = vec2<f32>(dot(v, basis[1]) + arm_dot(row + 1u, br), dot(v, basis[2]) + arm_dot(row + 2u, br));
        lt = lam.yz - RELAX * meff.yz * (jt - tgt.yz + r / 3.0 * lam.yz);
        let mag = length(lt);
        if mag > lim {
            lt *= lim / max(mag, 1e-20);
        }
    }
    let dt = lt - lam.yz;
    let slip = any(dt != vec2<f32>(0.0));
    if slip {
        arm_axpy(row + 1u, dt.x);
        arm_axpy(row + 2u, dt.y);
    }
    if slip || ln != lam.x {
        k_lam[c] = vec3<f32>(ln, lt);
    }
}

const LEG_ORDER = false;

fn solve_limit(l: u32) {
    let row = 3u * MAXC + l;
    let lam = l_lam[l];
    let nl = normal_impulse(lam, arm_dot(row, l_br[l]), l_tgt[l], l_r[l], l_meff[l]);
    if nl != lam {
        arm_axpy(row, nl - lam);
        l_lam[l] = nl;
    }
}

fn solve(sweeps: u32) {
    if LEG_ORDER {
        for (var it = 0u; it < sweeps; it++) {
            for (var k = 0u; k < 4u; k++) {
                for (var c = 0u; c < nc; c++) {
                    if (k_info[c] >> 26u) == k {
                        solve_contact(c);
                    }
                }
                for (var l = 0u; l < nlim; l++) {
                    if l_br[l] == k {
                        solve_limit(l);
                    }
                }
            }
        }
        return;
    }
    for (var it = 0u; it < sweeps; it++) {
        for (var c = 0u; c < nc; c++) {
            solve_contact(c);
        }
        for (var l = 0u; l < nlim; l++) {
            solve_limit(l);
        }
    }
}

@compute @workgroup_size(32)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    env = gid.x;
    if env >= prm.num_envs {
        return;
    }
    for (var i = 0u; i < 48u; i++) {
        cc[i] = coup(env, i / 12u, (i / 6u) % 2u, i % 6u);
    }
    fcom = com(env);
    qd[0] = 0.5 * (rnd(env, 100u) - 0.5);
    qd[1] = 0.5 * (rnd(env, 101u) - 0.5);
    qd[2] = 0.5 * (rnd(env, 102u) - 0.5);
    qd[3] = 0.5 * (rnd(env, 103u) - 0.5);
    qd[4] = 0.5 * (rnd(env, 104u) - 0.5);
    qd[5] = 0.5 * (rnd(env, 105u) - 0.5);
    qd[6] = 0.5 * (rnd(env, 106u) - 0.5);
    qd[7] = 0.5 * (rnd(env, 107u) - 0.5);
    qd[8] = 0.5 * (rnd(env, 108u) - 0.5);
    qd[9] = 0.5 * (rnd(env, 109u) - 0.5);
    qd[10] = 0.5 * (rnd(env, 110u) - 0.5);
    qd[11] = 0.5 * (rnd(env, 111u) - 0.5);
    qd[12] = 0.5 * (rnd(env, 112u) - 0.5);
    qd[13] = 0.5 * (rnd(env, 113u) - 0.5);
    for (var s = 0u; s < prm.substeps; s++) {
        qd[0] *= 0.98;
        qd[1] *= 0.98;
        qd[2] *= 0.98;
        qd[3] *= 0.98;
        qd[4] *= 0.98;
        qd[5] *= 0.98;
        qd[6] *= 0.98;
        qd[7] *= 0.98;
        qd[8] *= 0.98;
        qd[9] *= 0.98;
        qd[10] *= 0.98;
        qd[11] *= 0.98;
        qd[12] *= 0.98;
        qd[13] *= 0.98;
        qd[2] -= 0.08;
        build(s);
        solve(prm.sweeps);
    }
    outq[0u * prm.num_envs + env] = qd[0];
    outq[1u * prm.num_envs + env] = qd[1];
    outq[2u * prm.num_envs + env] = qd[2];
    outq[3u * prm.num_envs + env] = qd[3];
    outq[4u * prm.num_envs + env] = qd[4];
    outq[5u * prm.num_envs + env] = qd[5];
    outq[6u * prm.num_envs + env] = qd[6];
    outq[7u * prm.num_envs + env] = qd[7];
    outq[8u * prm.num_envs + env] = qd[8];
    outq[9u * prm.num_envs + env] = qd[9];
    outq[10u * prm.num_envs + env] = qd[10];
    outq[11u * prm.num_envs + env] = qd[11];
    outq[12u * prm.num_envs + env] = qd[12];
    outq[13u * prm.num_envs + env] = qd[13];
}
