struct Params { num_envs: u32, substeps: u32, sweeps: u32, pad: u32 }
@group(0) @binding(0) var<uniform> prm: Params;
@group(0) @binding(1) var<storage, read_write> outq: array<f32>;

const RELAX = 1.5;

fn hash(x: u32) -> u32 {
    var h = x * 747796405u + 2891336453u;
    h = ((h >> ((h >> 28u) + 4u)) ^ h) * 277803737u;
    return (h >> 22u) ^ h;
}
fn rnd(a: u32, b: u32) -> f32 {
    return f32(hash(a ^ hash(b)) >> 8u) / 16777216.0;
}

fn contact_basis(n: vec3<f32>) -> mat3x3<f32> {
    var t1 = cross(n, vec3<f32>(1.0, 0.0, 0.0));
    if dot(t1, t1) < 0.01 {
        t1 = cross(n, vec3<f32>(0.0, 1.0, 0.0));
    }
    t1 = normalize(t1);
    return mat3x3<f32>(n, t1, cross(n, t1));
}

fn normal_impulse(lam: f32, jv: f32, tgt: f32, r: f32, meff: f32) -> f32 {
    return max(lam - RELAX * meff * (jv - tgt + r * lam), 0.0);
}

// Synthetic env data: inverse z-space masses of the root (6) and legs (2 each), couplings C.
fn inv_mr(e: u32, i: u32) -> f32 { return 0.3 + 0.5 * rnd(e * 64u + i, 11u); }
fn inv_d(e: u32, k: u32, j: u32) -> f32 { return 5.0 + 20.0 * rnd(e * 64u + k * 2u + j, 12u); }
fn coup(e: u32, k: u32, j: u32, i: u32) -> f32 { return 0.2 * (rnd(e * 64u + k * 12u + j * 6u + i, 13u) - 0.5); }
fn com(e: u32) -> vec3<f32> { return vec3<f32>(0.01 * (rnd(e, 14u) - 0.5), 0.01 * (rnd(e, 15u) - 0.5), 0.5); }
fn has_contact(e: u32, s: u32, k: u32) -> bool { return rnd(e * 4u + k, s * 7u + 1u) < 0.9; }
fn contact_p(e: u32, s: u32, k: u32) -> vec3<f32> {
    return vec3<f32>(select(-0.4, 0.4, (k & 1u) != 0u) + 0.02 * rnd(e * 4u + k, s * 7u + 2u),
                     select(-0.4, 0.4, (k & 2u) != 0u) + 0.02 * rnd(e * 4u + k, s * 7u + 3u),
                     -0.001 * rnd(e * 4u + k, s * 7u + 4u));
}
fn contact_n(e: u32, s: u32, k: u32) -> vec3<f32> {
    return normalize(vec3<f32>(0.05 * (rnd(e * 4u + k, s * 7u + 5u) - 0.5), 0.05 * (rnd(e * 4u + k, s * 7u + 6u) - 0.5), 1.0));
}
fn contact_jk(e: u32, s: u32, k: u32, d: u32) -> vec2<f32> {
    return vec2<f32>(0.3 * (rnd(e * 16u + k * 4u + d, s * 9u + 1u) - 0.5), 0.3 * (rnd(e * 16u + k * 4u + d, s * 9u + 2u) - 0.5));
}
// Limit rows of leg k: the first always (dof lim_dof, side lim_side), a second with p = 0.1.
fn lim_dof(e: u32, s: u32, k: u32) -> u32 { return u32(rnd(e * 4u + k, s * 5u + 1u) < 0.5); }
fn lim_side(e: u32, s: u32, k: u32) -> f32 { return select(-1.0, 1.0, rnd(e * 4u + k, s * 5u + 2u) < 0.5); }
fn has_lim2(e: u32, s: u32, k: u32) -> bool { return rnd(e * 4u + k, s * 5u + 3u) < 0.1; }
fn lim_jk(e: u32, s: u32, k: u32, i: u32) -> vec2<f32> {
    var d = lim_dof(e, s, k);
    var side = lim_side(e, s, k);
    if i == 1u { d = 1u - d; side = -side; }
    return select(vec2<f32>(side, 0.0), vec2<f32>(0.0, side), d == 1u);
}

// A row's W in q̇ space: W_r (lin, ang), the own leg's W_k; a = J W.
struct RowW { wl: vec3<f32>, wa: vec3<f32>, wk: vec2<f32>, a: f32 }
// ck: the leg's coupling, rows e = 0, 1 of 6 (ck0 lin/ang, ck1 lin/ang).
fn row_w(dir: vec3<f32>, lever: vec3<f32>, jk: vec2<f32>, ck0l: vec3<f32>, ck0a: vec3<f32>, ck1l: vec3<f32>, ck1a: vec3<f32>, iml: vec3<f32>, ima: vec3<f32>, id: vec2<f32>) -> RowW {
    let jl = dir + jk.x * ck0l + jk.y * ck1l;
    let ja = cross(lever, dir) + jk.x * ck0a + jk.y * ck1a;
    let wl = jl * iml;
    let wa = ja * ima;
    let wzk = jk * id;
    let a = dot(jl, wl) + dot(ja, wa) + dot(jk, wzk);
    let wk = vec2<f32>(dot(ck0l, wl) + dot(ck0a, wa), dot(ck1l, wl) + dot(ck1a, wa)) + wzk;
    return RowW(wl, wa, wk, a);
}
