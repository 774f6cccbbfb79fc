// One invocation simulates one env for `params.substeps` substeps, then publishes its state.
//
// This file is the scene-independent half of the kernel. `codegen.rs` prepends the other half,
// generated from the compiled scene: the constants (NL, ND, ..., the LAY_* and GEO_* offsets)
// and straight-line functions in which every link, dof and object is spelled out with constant
// indices (load_state, publish, kinematics, rnea_bias, crba, cholesky, chol_solve, drives,
// objects_free_velocity, copy_body_poses, body_jt, limit_rows, integrate and the obj_*
// accessors). Constant indices let the driver keep the articulation in registers. The narrow
// phase loops over the scene's geometry table `geo` (shapes, body spheres, groups of pairs,
// pairs; see `GeometryTable` in compile.rs) and the contact rows, whose number varies, are
// indexed at run time.
//
// Per substep: forward kinematics → RNEA bias forces → CRBA mass matrix + armature → implicit
// drives and joint damping folded into A = M + h(D + d) + h²K → Cholesky → free velocities →
// free bodies (gravity, explicit gyroscopic term) → contacts (narrow phase per shape pair) and
// joint limits as MuJoCo's soft constraint rows → over-relaxed projected Gauss–Seidel with warm
// start → velocity limits → semi-implicit Euler (quaternions renormalised).
//
// Spatial vectors are (angular, linear) pairs in env-frame coordinates taken at the env origin;
// a link's spatial inertia there is (mass m, first moment h = m c, rotational inertia J).

struct Params {
    substeps: u32,
    // With no substeps: 1 to publish only the envs whose fresh input has REPUBLISH added
    // (the others keep their published state untouched), 0 to publish every env.
    only_marked: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read_write> st: array<f32>;
@group(0) @binding(1) var<storage, read> inp: array<f32>;
@group(0) @binding(2) var<storage, read_write> warm: array<f32>;
@group(0) @binding(3) var<uniform> params: Params;
// Buffer offsets that depend on the number of envs (see layout.rs), so one compiled kernel
// serves every env count of a scene.
@group(0) @binding(4) var<storage, read> lay: array<u32>;
// The scene's geometry table (compile.rs, `GeometryTable`): the same for every env.
@group(0) @binding(5) var<uniform> geo: array<vec4<f32>, GEO_LEN>;

const RMAX: u32 = MAX_C * 3u + ND1;
// Warm-start slot ids: contacts by pair slot, joint limits after them.
const LIMIT_SLOT: u32 = 0x40000000u;

var<private> env: u32;
var<private> num_envs: u32;
// Whether the substep running is the first of this dispatch (a written env skips the warm
// start of that one only).
var<private> first_substep: bool;
// Articulation state and kinematics (indexed by constants only).
var<private> q: array<f32, ND1>;
var<private> qd: array<f32, ND1>;
var<private> lpos: array<vec3<f32>, NL1>;
var<private> lrot: array<vec4<f32>, NL1>;
var<private> sw: array<vec3<f32>, NL1>;
var<private> su: array<vec3<f32>, NL1>;
var<private> vw: array<vec3<f32>, NL1>;
var<private> vu: array<vec3<f32>, NL1>;
var<private> im: array<f32, NL1>;
var<private> ih: array<vec3<f32>, NL1>;
var<private> ij: array<mat3x3<f32>, NL1>;
var<private> bias: array<f32, ND1>;
// A = M + h(D + d) + h²K, overwritten by its factors (lower triangle), and, for the dense
// Cholesky factor, its inverse diagonal.
var<private> amat: array<f32, NDD>;
var<private> linv: array<f32, ND1>;
var<private> applied: array<f32, ND1>;
// This dispatch's drive inputs: effort, bias compensation on, position and velocity targets.
var<private> in_ef: array<f32, ND1>;
var<private> in_comp: array<bool, ND1>;
var<private> in_qt: array<f32, ND1>;
var<private> in_vt: array<f32, ND1>;
// Free bodies: origin pose, centre-of-mass velocity, angular velocity.
var<private> opos: array<vec3<f32>, NO1>;
var<private> orot: array<vec4<f32>, NO1>;
var<private> ovel: array<vec3<f32>, NO1>;
var<private> oang: array<vec3<f32>, NO1>;
var<private> ocom: array<vec3<f32>, NO1>;
var<private> oinvm: array<f32, NO1>;
var<private> oinvi: array<mat3x3<f32>, NO1>;
var<private> mscale: array<f32, NB1>;
// Body poses for the narrow phase, which indexes them at run time.
var<private> bpos: array<vec3<f32>, NB1>;
var<private> brot: array<vec4<f32>, NB1>;
// Contacts of the current substep.
var<private> nc: u32;
var<private> c_n: array<vec3<f32>, MAX_C>;
var<private> c_p: array<vec3<f32>, MAX_C>;
var<private> c_sep: array<f32, MAX_C>;
var<private> c_ba: array<i32, MAX_C>;
var<private> c_bb: array<i32, MAX_C>;
var<private> c_mu: array<f32, MAX_C>;
var<private> c_slot: array<u32, MAX_C>;
// Constraints: one block per contact (its normal row and two tangent rows along the basis
// `contact_basis(n)`) and the joint-limit rows. A contact's rows see the relative velocity of
// its two sides at the contact point: J_arm q̇ (arm part) plus, per free object, the velocity of
// the object's material point there, v + ω × p (p from the object's centre of mass). An impulse
// P moves an object by (P / m, I⁻¹ (p × P)) and q̇ by W x per row (W = A⁻¹ J_armᵀ). Only the
// levers and effective masses are stored, not per-row object Jacobians: the solver is bound by
// the traffic of this storage (it lives in local memory, and 65 536 envs' worth does not fit in
// L2), so it recomputes the tangents and the object terms instead. `k_info` holds whether a
// contact has an arm part (ROW_ARM) and its two sides' free objects plus one (bits 8–15 and
// 16–23, 0 for none). A penetrating contact or limit is a soft row of the configured contact
// model (its rows' target velocities `k_tgt` and the normal row's regulariser `k_r`; see
// `normal_row`), a gap a rigid speculative row.
var<private> k_info: array<u32, MAX_C>;
var<private> k_pa: array<vec3<f32>, MAX_C>;
var<private> k_pb: array<vec3<f32>, MAX_C>;
var<private> k_meff: array<vec3<f32>, MAX_C>;
var<private> k_tgt: array<vec3<f32>, MAX_C>;
var<private> k_r: array<f32, MAX_C>;
var<private> k_lam: array<vec3<f32>, MAX_C>;
var<private> nlim: u32;
var<private> l_meff: array<f32, ND1>;
var<private> l_tgt: array<f32, ND1>;
var<private> l_r: array<f32, ND1>;
var<private> l_lam: array<f32, ND1>;
var<private> l_slot: array<u32, ND1>;
// Arm rows: J_arm and W of contact c's direction d at row 3c + d, of limit l at row 3 MAX_C + l
// (ND1 floats each), in `r_j` and `r_w` or in the `rows` buffer (generated with their accessors).

const ROW_ARM: u32 = 4u;
// Velocities at the start of the substep: MuJoCo's reference acceleration
// aref = −REF_B v − REF_K d(pos) pos uses them (`ContactCfg::stiffness`, `ContactCfg::damping`).
var<private> qd0: array<f32, ND1>;
var<private> ovel0: array<vec3<f32>, NO1>;
var<private> oang0: array<vec3<f32>, NO1>;

// ---------------------------------------------------------------- quaternions (x, y, z, w)

fn qmul(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz), a.w * b.w - dot(a.xyz, b.xyz));
}

fn qrot(r: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(r.xyz, v);
    return v + r.w * t + cross(r.xyz, t);
}

fn qconj(r: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(-r.xyz, r.w);
}

fn qmat(r: vec4<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(qrot(r, vec3<f32>(1.0, 0.0, 0.0)), qrot(r, vec3<f32>(0.0, 1.0, 0.0)), qrot(r, vec3<f32>(0.0, 0.0, 1.0)));
}

fn qaxis(axis: vec3<f32>, angle: f32) -> vec4<f32> {
    let sc = sincos(0.5 * angle);
    return vec4<f32>(axis * sc.x, sc.y);
}

// (sin x, cos x) to a few ulp. Vulkan lets built-in sin/cos err by 2⁻¹¹ (lavapipe does), far
// too coarse for kinematics: reduce by π/2 (Cody–Waite) and evaluate Taylor polynomials on
// [−π/4, π/4], whose truncation error is below 3e-8.
fn sincos(x: f32) -> vec2<f32> {
    let k = round(x * 0.63661977);
    let r = (x - k * 1.5707963705062866) + k * 4.371139e-8;
    let r2 = r * r;
    let s = r + r * r2 * (-0.16666667 + r2 * (0.008333334 + r2 * (-0.0001984127 + r2 * 2.7557319e-6)));
    let c = 1.0 + r2 * (-0.5 + r2 * (0.041666668 + r2 * (-0.0013888889 + r2 * 2.4801588e-5)));
    let quadrant = i32(k) & 3;
    switch quadrant {
        case 0: { return vec2<f32>(s, c); }
        case 1: { return vec2<f32>(c, -s); }
        case 2: { return vec2<f32>(-s, -c); }
        default: { return vec2<f32>(-c, s); }
    }
}

fn outer(a: vec3<f32>, b: vec3<f32>) -> mat3x3<f32> {
    return mat3x3<f32>(a * b.x, a * b.y, a * b.z);
}

fn inverse3(m: mat3x3<f32>) -> mat3x3<f32> {
    let a = m[0];
    let b = m[1];
    let c = m[2];
    let r0 = cross(b, c);
    let r1 = cross(c, a);
    let r2 = cross(a, b);
    let det = dot(a, r0);
    return transpose(mat3x3<f32>(r0, r1, r2)) * (1.0 / det);
}

// ---------------------------------------------------------------- buffer addresses

// Quantity k (0 joint_pos, 1 joint_vel, 2 bias, 3 applied) of dof d (of an articulation with
// `stride` dofs) in this env.
fn dof_addr(k: u32, d: u32, stride: u32) -> u32 {
    return lay[LAY_D_BASE + d] + k * lay[LAY_D_SECTION + d] + env * stride;
}

// Input k (0 position target, 1 velocity target, 2 effort) of dof d in this env.
fn inp_addr(k: u32, d: u32, stride: u32) -> u32 {
    return lay[LAY_D_IBASE + d] + k * lay[LAY_D_SECTION + d] + env * stride;
}

// Link state k: position (3), quaternion (4), linear velocity (3), angular velocity (3) of link
// l, the `local`-th of an articulation with `links` links.
fn link_addr(k: u32, l: u32, links: u32, local: u32) -> u32 {
    let row = env * links + local;
    let cols = num_envs * links;
    let block = lay[LAY_L_BLOCK + l];
    let quat = block + pad4(cols * 3u);
    let lin = quat + cols * 4u;
    switch k {
        case 0u: { return block + row * 3u; }
        case 1u: { return quat + row * 4u; }
        case 2u: { return lin + row * 3u; }
        default: { return lin + pad4(cols * 3u) + row * 3u; }
    }
}

fn pad4(n: u32) -> u32 {
    return (n + 3u) / 4u * 4u;
}

fn obj_addr(k: u32, o: u32) -> u32 {
    let block = lay[LAY_O_BLOCK + o];
    let quat = block + pad4(num_envs * 3u);
    let lin = quat + num_envs * 4u;
    switch k {
        case 0u: { return block + env * 3u; }
        case 1u: { return quat + env * 4u; }
        case 2u: { return lin + env * 3u; }
        default: { return lin + pad4(num_envs * 3u) + env * 3u; }
    }
}

fn ld3(a: u32) -> vec3<f32> {
    return vec3<f32>(st[a], st[a + 1u], st[a + 2u]);
}

fn ld4(a: u32) -> vec4<f32> {
    return vec4<f32>(st[a], st[a + 1u], st[a + 2u], st[a + 3u]);
}

fn st3(a: u32, v: vec3<f32>) {
    st[a] = v.x;
    st[a + 1u] = v.y;
    st[a + 2u] = v.z;
}

fn st4(a: u32, v: vec4<f32>) {
    st[a] = v.x;
    st[a + 1u] = v.y;
    st[a + 2u] = v.z;
    st[a + 3u] = v.w;
}

// This env's friction coefficient of shape s.
fn friction(s: u32) -> f32 {
    return inp[lay[LAY_IN_FRICTION] + env * NS + s];
}

// ---------------------------------------------------------------- narrow phase

struct Closest {
    dist: f32,
    normal: vec3<f32>,
    point: vec3<f32>,
}

// Signed distance from p to a box's surface, the outward normal there and the closest surface
// point.
fn closest_box(bpos: vec3<f32>, brot: vec4<f32>, size: vec3<f32>, p: vec3<f32>) -> Closest {
    var out: Closest;
    let pl = qrot(qconj(brot), p - bpos);
    let cl = clamp(pl, -size, size);
    let dv = pl - cl;
    let dl = length(dv);
    if dl > 1e-9 {
        out.dist = dl;
        out.normal = qrot(brot, dv / dl);
        out.point = bpos + qrot(brot, cl);
    } else {
        // Inside: leave through the nearest face.
        let gap = size - abs(pl);
        var axis = 0u;
        if gap.y < gap.x && gap.y <= gap.z {
            axis = 1u;
        } else if gap.z < gap.x && gap.z < gap.y {
            axis = 2u;
        }
        var nl = vec3<f32>(0.0);
        var face = pl;
        let sgn = select(-1.0, 1.0, pl[axis] >= 0.0);
        nl[axis] = sgn;
        face[axis] = sgn * size[axis];
        out.dist = -gap[axis];
        out.normal = qrot(brot, nl);
        out.point = bpos + qrot(brot, face);
    }
    return out;
}

// The same for the half-space z <= 0 of a plane's frame.
fn closest_plane(bpos: vec3<f32>, brot: vec4<f32>, p: vec3<f32>) -> Closest {
    var out: Closest;
    let nz = qrot(brot, vec3<f32>(0.0, 0.0, 1.0));
    let h = dot(p - bpos, nz);
    out.dist = h;
    out.normal = nz;
    out.point = p - h * nz;
    return out;
}

// The same for a sphere of radius r about c.
fn closest_sphere(c: vec3<f32>, r: f32, p: vec3<f32>) -> Closest {
    var out: Closest;
    let dv = p - c;
    let dl = length(dv);
    var n = vec3<f32>(0.0, 0.0, 1.0);
    if dl > 1e-9 {
        n = dv / dl;
    }
    out.dist = dl - r;
    out.normal = n;
    out.point = c + r * n;
    return out;
}

// The same for a z-aligned capsule (radius r, half segment length h).
fn closest_capsule(bpos: vec3<f32>, brot: vec4<f32>, r: f32, h: f32, p: vec3<f32>) -> Closest {
    let axis = qrot(brot, vec3<f32>(0.0, 0.0, 1.0));
    let t = clamp(dot(p - bpos, axis), -h, h);
    return closest_sphere(bpos + t * axis, r, p);
}

// Distance from p to a box (0 inside): pair culling against boxes.
fn box_gap(bpos: vec3<f32>, brot: vec4<f32>, size: vec3<f32>, p: vec3<f32>) -> f32 {
    let pl = qrot(qconj(brot), p - bpos);
    return length(max(abs(pl) - size, vec3<f32>(0.0)));
}

// Height of p above a plane (culling against planes).
fn plane_gap(bpos: vec3<f32>, brot: vec4<f32>, p: vec3<f32>) -> f32 {
    return dot(p - bpos, qrot(brot, vec3<f32>(0.0, 0.0, 1.0)));
}

fn add_contact(sep: f32, n: vec3<f32>, p: vec3<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    var i = nc;
    if nc == MAX_C {
        // Full: replace the shallowest contact if this one is deeper.
        var worst = 0u;
        for (var k = 1u; k < MAX_C; k++) {
            if c_sep[k] > c_sep[worst] {
                worst = k;
            }
        }
        if sep >= c_sep[worst] {
            return;
        }
        i = worst;
    } else {
        nc += 1u;
    }
    c_sep[i] = sep;
    c_n[i] = n;
    c_p[i] = p;
    c_ba[i] = ba;
    c_bb[i] = bb;
    c_mu[i] = mu;
    c_slot[i] = slot;
}

// A sphere of radius r about p (on body ba) against the surface `cl` found for it on body bb.
fn point_contact(cl: Closest, p: vec3<f32>, r: f32, ba: i32, bb: i32, mu: f32, slot: u32) {
    let sep = cl.dist - r;
    if sep >= MARGIN {
        return;
    }
    let pa = p - r * cl.normal;
    add_contact(sep, cl.normal, 0.5 * (pa + cl.point), ba, bb, mu, slot);
}

// Capsule a against box b: both end spheres, plus the segment point nearest the box when it
// lies inside the segment (slots slot, slot + 1, slot + 2).
fn capsule_box(apos: vec3<f32>, arot: vec4<f32>, ra: f32, ha: f32, bpos: vec3<f32>, brot: vec4<f32>, bsize: vec3<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    let axis = qrot(arot, vec3<f32>(0.0, 0.0, 1.0));
    let e0 = apos - ha * axis;
    let e1 = apos + ha * axis;
    point_contact(closest_box(bpos, brot, bsize, e0), e0, ra, ba, bb, mu, slot);
    point_contact(closest_box(bpos, brot, bsize, e1), e1, ra, ba, bb, mu, slot + 1u);
    // The segment point nearest the box, by alternating projections.
    var t = 0.0;
    for (var it = 0u; it < 4u; it++) {
        let pt = apos + t * axis;
        let pl = qrot(qconj(brot), pt - bpos);
        let cb = bpos + qrot(brot, clamp(pl, -bsize, bsize));
        t = clamp(dot(cb - apos, axis), -ha, ha);
    }
    if abs(t) < 0.95 * ha {
        let pm = apos + t * axis;
        point_contact(closest_box(bpos, brot, bsize, pm), pm, ra, ba, bb, mu, slot + 2u);
    }
}

// Capsule a against a plane: both end spheres.
fn capsule_plane(apos: vec3<f32>, arot: vec4<f32>, ra: f32, ha: f32, bpos: vec3<f32>, brot: vec4<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    let axis = qrot(arot, vec3<f32>(0.0, 0.0, 1.0));
    let e0 = apos - ha * axis;
    let e1 = apos + ha * axis;
    point_contact(closest_plane(bpos, brot, e0), e0, ra, ba, bb, mu, slot);
    point_contact(closest_plane(bpos, brot, e1), e1, ra, ba, bb, mu, slot + 1u);
}

// Capsule a against a capsule b (hb = 0: a sphere): the closest points of the two segments.
fn capsule_capsule(apos: vec3<f32>, arot: vec4<f32>, ra: f32, ha: f32, bpos: vec3<f32>, brot: vec4<f32>, rb: f32, hb: f32, ba: i32, bb: i32, mu: f32, slot: u32) {
    let axis = qrot(arot, vec3<f32>(0.0, 0.0, 1.0));
    let baxis = qrot(brot, vec3<f32>(0.0, 0.0, 1.0)) * hb;
    let d1 = 2.0 * ha * axis;
    let d2 = 2.0 * baxis;
    let p1 = apos - ha * axis;
    let p2 = bpos - baxis;
    let rr = p1 - p2;
    let aa = dot(d1, d1);
    let ee = dot(d2, d2);
    let ff = dot(d2, rr);
    let cc = dot(d1, rr);
    let bbd = dot(d1, d2);
    let den = aa * ee - bbd * bbd;
    var s = 0.0;
    if den > 1e-12 {
        s = clamp((bbd * ff - cc * ee) / den, 0.0, 1.0);
    }
    var t = 0.0;
    if ee > 1e-12 {
        t = (bbd * s + ff) / ee;
        if t < 0.0 {
            t = 0.0;
            s = clamp(-cc / aa, 0.0, 1.0);
        } else if t > 1.0 {
            t = 1.0;
            s = clamp((bbd - cc) / aa, 0.0, 1.0);
        }
    }
    let ca = p1 + s * d1;
    let cbp = p2 + t * d2;
    let dv = ca - cbp;
    let dl = length(dv);
    var n = vec3<f32>(0.0, 0.0, 1.0);
    if dl > 1e-9 {
        n = dv / dl;
    }
    let sep = dl - ra - rb;
    if sep < MARGIN {
        let pa = ca - ra * n;
        let pb = cbp + rb * n;
        add_contact(sep, n, 0.5 * (pa + pb), ba, bb, mu, slot);
    }
}

fn box_vertex(k: u32, size: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        select(-size.x, size.x, (k & 1u) != 0u),
        select(-size.y, size.y, (k & 2u) != 0u),
        select(-size.z, size.z, (k & 4u) != 0u),
    );
}

// Box a against a plane: its 8 vertices.
fn box_plane(apos: vec3<f32>, arot: vec4<f32>, asize: vec3<f32>, bpos: vec3<f32>, brot: vec4<f32>, ba: i32, bb: i32, mu: f32, slot: u32) {
    for (var k = 0u; k < 8u; k++) {
        let v = apos + qrot(arot, box_vertex(k, asize));
        point_contact(closest_plane(bpos, brot, v), v, 0.0, ba, bb, mu, slot + k);
    }
}

// Box a's 8 vertices against box b (slots slot .. slot + 7); b's bounding radius `rb` skips
// vertices too far from b to touch it.
fn box_vertices_in_box(apos: vec3<f32>, arot: vec4<f32>, asize: vec3<f32>, bpos: vec3<f32>, brot: vec4<f32>, bsize: vec3<f32>, rb: f32, ba: i32, bb: i32, mu: f32, slot: u32) {
    for (var k = 0u; k < 8u; k++) {
        let v = apos + qrot(arot, box_vertex(k, asize));
        if distance(v, bpos) <= rb + MARGIN {
            point_contact(closest_box(bpos, brot, bsize, v), v, 0.0, ba, bb, mu, slot + k);
        }
    }
}

struct ShapePose {
    pos: vec3<f32>,
    rot: vec4<f32>,
}

// Where shape s is now.
fn shape_pose(s: u32) -> ShapePose {
    let e = GEO_SHAPES + 4u * s;
    let b = i32(geo[e + 3u].z);
    var out: ShapePose;
    if b < 0 {
        out.pos = geo[e].xyz;
        if SHIFTED {
            out.pos -= shift;
        }
        out.rot = geo[e + 1u];
    } else {
        out.pos = bpos[b] + qrot(brot[b], geo[e].xyz);
        out.rot = qmul(brot[b], geo[e + 1u]);
    }
    return out;
}

// False only if a sphere (c, r) is farther than the margin from fixed shape s.
fn near_fixed(s: u32, c: vec3<f32>, r: f32) -> bool {
    let e = GEO_SHAPES + 4u * s;
    var pos = geo[e].xyz;
    if SHIFTED {
        pos -= shift;
    }
    let rot = geo[e + 1u];
    let size = geo[e + 2u];
    let kind = u32(geo[e + 3u].x);
    if kind == 2u {
        return box_gap(pos, rot, size.xyz, c) <= r + MARGIN;
    }
    if kind == 3u {
        return plane_gap(pos, rot, c) <= r + MARGIN;
    }
    return distance(c, pos) <= size.w + r + MARGIN;
}

// The bounding sphere (centre, radius) of group side `side` if it is a moving body; `w < 0`
// for a fixed shape.
fn side_sphere(side: i32) -> vec4<f32> {
    if side < 0 {
        return vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    let sph = geo[GEO_BODIES + u32(side)];
    return vec4<f32>(bpos[side] + qrot(brot[side], sph.xyz), sph.w);
}

// False only if a sphere (c, r) is farther than the margin from group side `side`, whose
// bounding sphere (from `side_sphere`) is `sph`.
fn near_side(c: vec3<f32>, r: f32, side: i32, sph: vec4<f32>) -> bool {
    if side < 0 {
        return near_fixed(u32(-1 - side), c, r);
    }
    return distance(c, sph.xyz) <= r + sph.w + MARGIN;
}

// False only if two boxes are separated by more than the margin along one of their six face
// normals (a conservative separating-axis test).
fn boxes_near(apos: vec3<f32>, arot: vec4<f32>, asize: vec3<f32>, bpos: vec3<f32>, brot: vec4<f32>, bsize: vec3<f32>) -> bool {
    let ra = qmat(arot);
    let rb = qmat(brot);
    // b's axes in a's frame, and the centre offset in both frames.
    let r = transpose(ra) * rb;
    let t = bpos - apos;
    let ta = transpose(ra) * t;
    let tb = transpose(rb) * t;
    let ar = mat3x3<f32>(abs(r[0]), abs(r[1]), abs(r[2]));
    // Extent of b along a's axes, of a along b's axes.
    let eb = ar * bsize;
    let ea = transpose(ar) * asize;
    return all(abs(ta) <= asize + eb + vec3<f32>(MARGIN)) && all(abs(tb) <= bsize + ea + vec3<f32>(MARGIN));
}

// The contacts of pair k (shapes a and b, a's kind code not above b's; a is at `pa` and
// has passed the test against the group's second side).
fn collide_pair(k: u32, pa: ShapePose) {
    let pr = geo[GEO_PAIRS + k];
    let a = u32(pr.x);
    let b = u32(pr.y);
    let slot = u32(pr.z);
    let ea = GEO_SHAPES + 4u * a;
    let eb = GEO_SHAPES + 4u * b;
    let pb = shape_pose(b);
    let sa = geo[ea + 2u];
    let sb = geo[eb + 2u];
    let ia = geo[ea + 3u];
    let ib = geo[eb + 3u];
    // Bounding spheres (or a fixed shape's exact geometry) farther apart than the margin: no
    // contact can come of this pair. A fixed b is the group's second side, which `collide`
    // has already tested a against.
    if ia.z >= 0.0 && ib.z >= 0.0 {
        if distance(pa.pos, pb.pos) > sa.w + sb.w + MARGIN {
            return;
        }
    } else if ia.z < 0.0 && !near_fixed(a, pb.pos, sb.w) {
        return;
    }
    let ba = i32(geo[ea].w);
    let bb = i32(geo[eb].w);
    // MuJoCo's rule: the higher priority's friction, else the larger one.
    var mu: f32;
    if ia.y > ib.y {
        mu = friction(a);
    } else if ib.y > ia.y {
        mu = friction(b);
    } else {
        mu = max(friction(a), friction(b));
    }
    switch u32(ia.x) * 4u + u32(ib.x) {
        case 0u: {
            point_contact(closest_sphere(pb.pos, sb.x, pa.pos), pa.pos, sa.x, ba, bb, mu, slot);
        }
        case 1u: {
            point_contact(closest_capsule(pb.pos, pb.rot, sb.x, sb.y, pa.pos), pa.pos, sa.x, ba, bb, mu, slot);
        }
        case 2u: {
            point_contact(closest_box(pb.pos, pb.rot, sb.xyz, pa.pos), pa.pos, sa.x, ba, bb, mu, slot);
        }
        case 3u: {
            point_contact(closest_plane(pb.pos, pb.rot, pa.pos), pa.pos, sa.x, ba, bb, mu, slot);
        }
        case 4u, 5u: {
            // A sphere's half length is 0.
            capsule_capsule(pa.pos, pa.rot, sa.x, sa.y, pb.pos, pb.rot, sb.x, sb.y, ba, bb, mu, slot);
        }
        case 6u: {
            capsule_box(pa.pos, pa.rot, sa.x, sa.y, pb.pos, pb.rot, sb.xyz, ba, bb, mu, slot);
        }
        case 7u: {
            capsule_plane(pa.pos, pa.rot, sa.x, sa.y, pb.pos, pb.rot, ba, bb, mu, slot);
        }
        case 10u: {
            if !boxes_near(pa.pos, pa.rot, sa.xyz, pb.pos, pb.rot, sb.xyz) {
                return;
            }
            box_vertices_in_box(pa.pos, pa.rot, sa.xyz, pb.pos, pb.rot, sb.xyz, sb.w, ba, bb, mu, slot);
            // b's vertices against a, the roles swapped.
            box_vertices_in_box(pb.pos, pb.rot, sb.xyz, pa.pos, pa.rot, sa.xyz, sa.w, bb, ba, mu, slot + 8u);
        }
        case 11u: {
            box_plane(pa.pos, pa.rot, sa.xyz, pb.pos, pb.rot, ba, bb, mu, slot);
        }
        default: {}
    }
}

// Contacts of every shape pair that can touch: a group of pairs between two bodies is skipped
// when the bodies' bounding spheres are apart, a shape of the group's first side when it is
// apart from the second side, then each pair by its shapes' bounds.
fn collide() {
    nc = 0u;
    copy_body_poses();
    for (var g = 0u; g < NG; g++) {
        let grp = geo[GEO_GROUPS + g];
        let side_a = i32(grp.x);
        let side_b = i32(grp.y);
        let first = u32(grp.z);
        let count = u32(grp.w);
        let sph_b = side_sphere(side_b);
        if count > 1u {
            // A moving side's sphere against the other side (a fixed side exactly).
            let sph_a = side_sphere(side_a);
            var near_group: bool;
            if side_a >= 0 {
                near_group = near_side(sph_a.xyz, sph_a.w, side_b, sph_b);
            } else {
                near_group = near_side(sph_b.xyz, sph_b.w, side_a, sph_a);
            }
            if !near_group {
                continue;
            }
        }
        // Pairs of one group are ordered by their first shape: its pose and its test against
        // the second side serve all of them.
        var last = 0xFFFFFFFFu;
        var pa: ShapePose;
        var near = false;
        for (var k = first; k < first + count; k++) {
            let a = u32(geo[GEO_PAIRS + k].x);
            if a != last {
                last = a;
                pa = shape_pose(a);
                near = side_a < 0 || near_side(pa.pos, geo[GEO_SHAPES + 4u * a + 2u].w, side_b, sph_b);
            }
            if near {
                collide_pair(k, pa);
            }
        }
    }
}

// ---------------------------------------------------------------- constraints

// The contact frame of normal n: columns n, t1, t2 (right-handed, orthonormal).
fn contact_basis(n: vec3<f32>) -> mat3x3<f32> {
    var t1 = cross(n, vec3<f32>(1.0, 0.0, 0.0));
    if dot(t1, t1) < 0.01 {
        t1 = cross(n, vec3<f32>(0.0, 1.0, 0.0));
    }
    t1 = normalize(t1);
    return mat3x3<f32>(n, t1, cross(n, t1));
}

// A free object's share of J A⁻¹ Jᵀ for the three rows of a contact at lever p.
fn object_k(o: i32, p: vec3<f32>, basis: mat3x3<f32>) -> vec3<f32> {
    var k = vec3<f32>(0.0);
    for (var d = 0u; d < 3u; d++) {
        let r = cross(p, basis[d]);
        k[d] = obj_invm(o) + dot(r, obj_invi(o, r));
    }
    return k;
}

// Stores the arm row `row` (J_arm = jt, W = A⁻¹ jtᵀ); returns J W.
fn arm_row(row: u32, jt: array<f32, ND1>) -> f32 {
    var w = jt;
    chol_solve(&w);
    return arm_store(row * ND1, jt, w);
}

// MuJoCo's impedance d(pos) of a penetration pos < 0 (solimp: IMP0 at contact, IMP1 from
// IMP_WIDTH deep, a power-2 sigmoid with midpoint IMP_MID between).
fn impedance(pos: f32) -> f32 {
    let x = clamp(-pos / IMP_WIDTH, 0.0, 1.0);
    var y: f32;
    if x <= IMP_MID {
        y = x * x / IMP_MID;
    } else {
        y = 1.0 - (1.0 - x) * (1.0 - x) / (1.0 - IMP_MID);
    }
    return IMP0 + y * (IMP1 - IMP0);
}

// A normal or limit row with distance s, start-of-substep velocity v0, J A⁻¹ Jᵀ = a and
// inverse weight a0 at the reference configuration (weights.rs): its target velocity,
// regulariser R and 1 / (a + R). A penetration (s < 0) is MuJoCo's soft constraint: the
// impulse λ ≥ 0 minimises ½ λ(a + R)λ + λ(v_free − v0 − h aref), i.e. the row's velocity goes
// to v0 + h aref − R λ, with aref = −B v0 − K d s and R = (1 − d)/d · a0 (MuJoCo scales R
// by the fixed a0, not by a). A gap (s >= 0) is a rigid speculative row that lets the gap
// close within this substep.
struct Row {
    tgt: f32,
    r: f32,
    meff: f32,
}

fn normal_row(s: f32, v0: f32, a: f32, a0: f32) -> Row {
    // The soft step pushes out of a contact at s = 0 as well.
    if s > 0.0 || (s == 0.0 && !SOFT_STEP) {
        return Row(-s / DT, 0.0, 1.0 / max(a, 1e-12));
    }
    if SOFT_STEP {
        // Box2D's soft step (`ContactModel::SoftStep`) is the same kind of row: its bias
        // s·ω/(2ζ + hω) as target, R = a / (hω(2ζ + hω)); the relaxation sweeps after the
        // position update (`relax_rows`) then take out the velocity it added.
        let r = a * SOFT_R_SCALE;
        return Row(-s * SOFT_TARGET_SCALE, r, 1.0 / max(a + r, 1e-12));
    }
    let d = impedance(s);
    let r = (1.0 - d) / d * a0;
    return Row(v0 - DT * (REF_B * v0 + REF_K * d * s), r, 1.0 / max(a + r, 1e-12));
}

// The soft step's relaxation rows: penetrating rows become rigid with target 0 (a gap keeps its
// speculative target).
fn relax_rows() {
    for (var c = 0u; c < nc; c++) {
        let r = k_r[c];
        if r != 0.0 {
            k_meff[c].x = 1.0 / max(1.0 / k_meff[c].x - r, 1e-12);
            k_r[c] = 0.0;
            k_tgt[c].x = 0.0;
        }
    }
    for (var l = 0u; l < nlim; l++) {
        let r = l_r[l];
        if r != 0.0 {
            l_meff[l] = 1.0 / max(1.0 / l_meff[l] - r, 1e-12);
            l_r[l] = 0.0;
            l_tgt[l] = 0.0;
        }
    }
}

// A friction row's regulariser for a normal row's r.
fn friction_r(r: f32) -> f32 {
    if SOFT_STEP {
        return 0.0;
    }
    return r / IMPRATIO;
}

// The translational inverse weight of body b (0 for the static world).
fn body_weight(b: i32) -> f32 {
    if b < 0 {
        return 0.0;
    }
    return body_invw[b];
}

// Contact c between bodies ba and bb (body code: -1 static, link, NL + object).
fn build_contact(c: u32) {
    let ba = c_ba[c];
    let bb = c_bb[c];
    let p = c_p[c];
    let basis = contact_basis(c_n[c]);
    var k = vec3<f32>(0.0);
    var info = 0u;
    if ba >= i32(NL) {
        let o = ba - i32(NL);
        k_pa[c] = p - obj_com(o);
        k += object_k(o, k_pa[c], basis);
        info |= u32(o + 1) << 8u;
    }
    if bb >= i32(NL) {
        let o = bb - i32(NL);
        k_pb[c] = p - obj_com(o);
        k += object_k(o, k_pb[c], basis);
        info |= u32(o + 1) << 16u;
    }
    for (var d = 0u; d < 3u; d++) {
        var jt: array<f32, ND1>;
        let arm_a = body_jt(ba, p, basis[d], 1.0, &jt);
        let arm_b = body_jt(bb, p, basis[d], -1.0, &jt);
        if arm_a || arm_b {
            info |= ROW_ARM;
            k[d] += arm_row(c * 3u + d, jt);
        }
    }
    k_info[c] = info;
    // Start velocities of the three rows.
    var v0 = contact_object_vel0(info, k_pa[c], k_pb[c]) * basis;
    if (info & ROW_ARM) != 0u {
        for (var d = 0u; d < 3u; d++) {
            v0[d] += arm_dot0((c * 3u + d) * ND1);
        }
    }
    let n = normal_row(c_sep[c], v0.x, k.x, body_weight(ba) + body_weight(bb));
    // Tangents: R = R_n / IMPRATIO and target v0 (1 − h B) (MuJoCo's elliptic cones); rigid
    // for the soft step and for a speculative contact.
    let rt = friction_r(n.r);
    var tt = v0.yz * (1.0 - DT * REF_B);
    if SOFT_STEP || c_sep[c] >= 0.0 {
        tt = vec2<f32>(0.0);
    }
    k_meff[c] = vec3<f32>(n.meff, 1.0 / max(k.yz + rt, vec2<f32>(1e-12)));
    k_tgt[c] = vec3<f32>(n.tgt, tt);
    k_r[c] = n.r;
    k_lam[c] = vec3<f32>(0.0);
}

// A joint-limit row: `jt` is ±1 at the dof; `s` the distance to the limit.
fn limit_row(jt: array<f32, ND1>, slot: u32, s: f32) {
    let l = nlim;
    nlim += 1u;
    var v0 = 0.0;
    var a0 = 0.0;
    for (var d = 0u; d < ND1; d++) {
        v0 += jt[d] * qd0[d];
        a0 += abs(jt[d]) * dof_invw[d];
    }
    let row = normal_row(s, v0, arm_row(3u * MAX_C + l, jt), a0);
    l_meff[l] = row.meff;
    l_tgt[l] = row.tgt;
    l_r[l] = row.r;
    l_lam[l] = 0.0;
    l_slot[l] = slot;
}

fn build_rows() {
    for (var c = 0u; c < nc; c++) {
        build_contact(c);
    }
    nlim = 0u;
    limit_rows();
}

fn object_a(info: u32) -> i32 {
    return i32((info >> 8u) & 255u) - 1;
}

fn object_b(info: u32) -> i32 {
    return i32((info >> 16u) & 255u) - 1;
}

// The free objects' part of contact c's relative velocity (side a minus side b).
fn contact_object_vel(c: u32, info: u32) -> vec3<f32> {
    var v = vec3<f32>(0.0);
    let oa = object_a(info);
    if oa >= 0 {
        v = obj_point_vel(oa, k_pa[c]);
    }
    let ob = object_b(info);
    if ob >= 0 {
        v -= obj_point_vel(ob, k_pb[c]);
    }
    return v;
}

// The same at the start of the substep, for levers pa and pb.
fn contact_object_vel0(info: u32, pa: vec3<f32>, pb: vec3<f32>) -> vec3<f32> {
    var v = vec3<f32>(0.0);
    let oa = object_a(info);
    if oa >= 0 {
        v = ovel0[oa] + cross(oang0[oa], pa);
    }
    let ob = object_b(info);
    if ob >= 0 {
        v -= ovel0[ob] + cross(oang0[ob], pb);
    }
    return v;
}

// Applies the world impulse `impulse` (side a; −impulse on side b) of contact c to its free
// objects.
fn contact_object_push(c: u32, info: u32, impulse: vec3<f32>) {
    let oa = object_a(info);
    if oa >= 0 {
        obj_push(oa, impulse, k_pa[c]);
    }
    let ob = object_b(info);
    if ob >= 0 {
        obj_push(ob, -impulse, k_pb[c]);
    }
}

// Field f (0 slot id as bits, 1 λn, 2 λt1, 3 λt2) of warm-start entry k of this env; envs are
// the fastest-varying index, so a warp's loads are coalesced.
fn warm_addr(k: u32, f: u32) -> u32 {
    return (k * 4u + f) * num_envs + env;
}

// The warm-start entry with this slot and a non-zero normal impulse, or MAX_C.
fn warm_find(slot: u32) -> u32 {
    for (var k = 0u; k < MAX_C; k++) {
        if bitcast<u32>(warm[warm_addr(k, 0u)]) == slot && warm[warm_addr(k, 1u)] != 0.0 {
            return k;
        }
    }
    return MAX_C;
}

// Applies last substep's impulses to the constraints with the same slot (contacts store their
// normal and both tangents, limit rows their normal entry). An env written since the last
// step has no last substep to warm-start from in its first.
fn warm_start() {
    if first_substep && inp[lay[LAY_IN_FRESH] + env] != 0.0 {
        return;
    }
    for (var c = 0u; c < nc; c++) {
        let k = warm_find(c_slot[c]);
        if k == MAX_C {
            continue;
        }
        let lam = vec3<f32>(warm[warm_addr(k, 1u)], warm[warm_addr(k, 2u)], warm[warm_addr(k, 3u)]);
        let info = k_info[c];
        k_lam[c] = lam;
        contact_object_push(c, info, contact_basis(c_n[c]) * lam);
        if (info & ROW_ARM) != 0u {
            for (var d = 0u; d < 3u; d++) {
                arm_axpy((c * 3u + d) * ND1, lam[d]);
            }
        }
    }
    for (var l = 0u; l < nlim; l++) {
        let k = warm_find(l_slot[l]);
        if k == MAX_C {
            continue;
        }
        l_lam[l] = warm[warm_addr(k, 1u)];
        arm_axpy((3u * MAX_C + l) * ND1, l_lam[l]);
    }
}

fn store_warm() {
    var k = 0u;
    for (var c = 0u; c < nc; c++) {
        warm[warm_addr(k, 0u)] = bitcast<f32>(c_slot[c]);
        warm[warm_addr(k, 1u)] = k_lam[c].x;
        warm[warm_addr(k, 2u)] = k_lam[c].y;
        warm[warm_addr(k, 3u)] = k_lam[c].z;
        k += 1u;
    }
    for (var l = 0u; l < nlim && k < MAX_C; l++) {
        warm[warm_addr(k, 0u)] = bitcast<f32>(l_slot[l]);
        warm[warm_addr(k, 1u)] = l_lam[l];
        k += 1u;
    }
    for (; k < MAX_C; k++) {
        warm[warm_addr(k, 0u)] = bitcast<f32>(0xFFFFFFFFu);
        warm[warm_addr(k, 1u)] = 0.0;
    }
}

// The new impulse of a normal or limit row with impulse lam and velocity jv (target tgt,
// regulariser r, 1 / (a + r) = meff; see `normal_row`).
fn normal_impulse(lam: f32, jv: f32, tgt: f32, r: f32, meff: f32) -> f32 {
    return max(lam - RELAXATION * meff * (jv - tgt + r * lam), 0.0);
}

// One Gauss–Seidel visit of contact c: its normal row, then both tangents together, clamped to
// the friction disk μ λn.
fn solve_contact(c: u32) {
    let info = k_info[c];
    let arm = (info & ROW_ARM) != 0u;
    let basis = contact_basis(c_n[c]);
    let row = c * 3u * ND1;
    let meff = k_meff[c];
    let lam = k_lam[c];
    var jn = dot(contact_object_vel(c, info), basis[0]);
    if arm {
        jn += arm_dot(row);
    }
    let tgt = k_tgt[c];
    let r = k_r[c];
    let ln = normal_impulse(lam.x, jn, tgt.x, r, meff.x);
    if ln != lam.x {
        contact_object_push(c, info, basis[0] * (ln - lam.x));
        if arm {
            arm_axpy(row, ln - lam.x);
        }
    }
    let lim = c_mu[c] * ln;
    var lt = vec2<f32>(0.0);
    if lim > 0.0 {
        let v = contact_object_vel(c, info);
        var jt = vec2<f32>(dot(v, basis[1]), dot(v, basis[2]));
        if arm {
            jt += vec2<f32>(arm_dot(row + ND1), arm_dot(row + 2u * ND1));
        }
        lt = lam.yz - RELAXATION * meff.yz * (jt - tgt.yz + friction_r(r) * lam.yz);
        let mag = length(lt);
        if mag > lim {
            lt *= lim / max(mag, 1e-20);
        }
    }
    let dt = lt - lam.yz;
    let slip = any(dt != vec2<f32>(0.0));
    if slip {
        contact_object_push(c, info, basis[1] * dt.x + basis[2] * dt.y);
        if arm {
            arm_axpy(row + ND1, dt.x);
            arm_axpy(row + 2u * ND1, dt.y);
        }
    }
    if slip || ln != lam.x {
        k_lam[c] = vec3<f32>(ln, lt);
    }
}

// `sweeps` of over-relaxed projected Gauss–Seidel over the contacts, then the limit rows. An
// impulse that does not change applies nothing, and the tangents of a contact without normal
// impulse (friction limit 0) need no velocity at all: speculative contacts cost little.
fn solve(sweeps: u32) {
    for (var it = 0u; it < sweeps; it++) {
        for (var c = 0u; c < nc; c++) {
            solve_contact(c);
        }
        for (var l = 0u; l < nlim; l++) {
            let row = (3u * MAX_C + l) * ND1;
            let lam = l_lam[l];
            let nl = normal_impulse(lam, arm_dot(row), l_tgt[l], l_r[l], l_meff[l]);
            if nl != lam {
                arm_axpy(row, nl - lam);
                l_lam[l] = nl;
            }
        }
    }
}

// ---------------------------------------------------------------- the step

fn substep() {
    qd0 = qd;
    ovel0 = ovel;
    oang0 = oang;
    kinematics();
    rnea_bias();
    crba();
    drives();
    objects_free_velocity();
    collide();
    build_rows();
    warm_start();
    solve(ITERATIONS);
    integrate();
    if SOFT_STEP {
        relax_rows();
        solve(ITERATIONS);
    }
    store_warm();
}

@compute @workgroup_size(WORKGROUP)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    env = gid.x;
    num_envs = lay[LAY_NUM_ENVS];
    if env >= num_envs {
        return;
    }
    if params.substeps == 0u && params.only_marked != 0u && inp[lay[LAY_IN_FRESH] + env] < REPUBLISH {
        return;
    }
    load_state();
    if params.substeps == 0u {
        // Publish only (after a state write or a parameter change): keep the applied efforts
        // of the last step.
        load_applied();
    }
    for (var s = 0u; s < params.substeps; s++) {
        first_substep = s == 0u;
        substep();
    }
    publish();
}
