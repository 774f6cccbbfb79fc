// ---------------------------------------------------------------- constraints

// A free object's share of J A⁻¹ Jᵀ for the three rows of a contact at lever p.
fn object_k(o: i32, p: vec3<f32>, basis: mat3x3<f32>) -> vec3<f32> {
    var k = vec3<f32>(0.0);
    for (var d = 0u; d < 3u; d++) {
        let r = cross(p, basis[d]);
        k[d] = obj_invm(o) + dot(r, obj_invi(o, r));
    }
    return k;
}

// Stores the arm row `row` of branch `br` (J_arm = jt, W = A⁻¹ jtᵀ); returns J W.
fn arm_row(row: u32, jt: array<f32, ND1>, br: u32) -> f32 {
    var w = jt;
    chol_solve(&w);
    return arm_store(row, jt, w, br);
}

// The branch of a limit row with this slot (LIMIT_SLOT + 2 dof + side).
fn limit_branch(slot: u32) -> u32 {
    return dof_branch((slot - LIMIT_SLOT) / 2u);
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

// 1 if body b is a link of the floating root whose entries the rows leave out, else 0.
fn on_root_links(b: i32) -> i32 {
    return i32((b >= ROOT_LINKS.x) && (b < ROOT_LINKS.y));
}

// Contact c between bodies ba and bb (body code: -1 static, link, NL + object).
fn build_contact(c: u32) {
    let ba = c_ba[c];
    let bb = c_bb[c];
    let p = c_p[c];
    let basis = contact_basis(c_n[c]);
    var k = vec3<f32>(0.0);
    var info = 0u;
    // The arm's part of the rows' start velocities, J_arm q̇₀, taken while each row's Jacobian
    // is still in registers rather than read back from the rows' storage.
    var v_arm = vec3<f32>(0.0);
    let br = row_branch(ba, bb);
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
            k[d] += arm_row(c * 3u + d, jt, br);
            var s = 0.0;
            for (var i = 0u; i < ND1; i++) {
                s += jt[i] * qd0[i];
            }
            v_arm[d] = s;
        }
    }
    // The floating root's entries of the rows, left out of their storage: its factor plus one.
    info |= u32(on_root_links(ba) - on_root_links(bb) + 1) << 24u;
    info |= br << 26u;
    k_info[c] = info;
    // Start velocities of the three rows.
    let v0 = contact_object_vel0(info, k_pa[c], k_pb[c]) * basis + v_arm;
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
    let br = limit_branch(slot);
    let row = normal_row(s, v0, arm_row(3u * MAX_C + l, jt, br), a0);
    l_meff[l] = row.meff;
    l_tgt[l] = row.tgt;
    l_r[l] = row.r;
    l_lam[l] = 0.0;
    l_slot[l] = slot;
    l_br[l] = br;
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

// No warm-start entry's slot: an empty entry's, and one without a normal impulse (see
// `warm_start`).
const NO_WARM_SLOT: u32 = 0xFFFFFFFFu;

// The first of the entries' `slots` equal to `slot`, or MAX_C.
fn warm_find(slots: ptr<function, array<u32, MAX_C>>, slot: u32) -> u32 {
    var found = MAX_C;
    for (var k = MAX_C; k > 0u; k--) {
        if (*slots)[k - 1u] == slot {
            found = k - 1u;
        }
    }
    return found;
}

// Applies last substep's impulses to the constraints with the same slot (contacts store their
// normal and both tangents, limit rows their normal entry). An env written since the last
// step has no last substep to warm-start from in its first.
fn warm_start() {
    if first_substep && inp[lay[LAY_IN_FRESH] + env] != 0.0 {
        return;
    }
    // Every entry's slot first, as independent loads: a search that loads as it compares
    // waits for each load in turn. An entry without a normal impulse matches nothing.
    var slots: array<u32, MAX_C>;
    for (var k = 0u; k < MAX_C; k++) {
        let slot = bitcast<u32>(warm[warm_addr(k, 0u)]);
        slots[k] = select(NO_WARM_SLOT, slot, warm[warm_addr(k, 1u)] != 0.0);
    }
    for (var c = 0u; c < nc; c++) {
        let k = warm_find(&slots, c_slot[c]);
        if k == MAX_C {
            continue;
        }
        let lam = vec3<f32>(warm[warm_addr(k, 1u)], warm[warm_addr(k, 2u)], warm[warm_addr(k, 3u)]);
        let info = k_info[c];
        k_lam[c] = lam;
        contact_object_push(c, info, contact_basis(c_n[c]) * lam);
        if (info & ROW_ARM) != 0u {
            for (var d = 0u; d < 3u; d++) {
                arm_axpy(c * 3u + d, lam[d]);
            }
        }
    }
    for (var l = 0u; l < nlim; l++) {
        let k = warm_find(&slots, l_slot[l]);
        if k == MAX_C {
            continue;
        }
        l_lam[l] = warm[warm_addr(k, 1u)];
        arm_axpy(3u * MAX_C + l, l_lam[l]);
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
        warm[warm_addr(k, 0u)] = bitcast<f32>(NO_WARM_SLOT);
        warm[warm_addr(k, 1u)] = 0.0;
    }
}

// One Gauss–Seidel visit of contact c: its normal row, then both tangents together, clamped to
// the friction disk μ λn.
fn solve_contact(c: u32) {
    let info = k_info[c];
    let arm = (info & ROW_ARM) != 0u;
    let br = info >> 26u;
    let basis = contact_basis(c_n[c]);
    let row = c * 3u;
    let meff = k_meff[c];
    let lam = k_lam[c];
    var jn = dot(contact_object_vel(c, info) + contact_root_vel(c, info), basis[0]);
    if arm {
        jn += arm_dot(row, br);
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
        let v = contact_object_vel(c, info) + contact_root_vel(c, info);
        var jt = vec2<f32>(dot(v, basis[1]), dot(v, basis[2]));
        if arm {
            jt += vec2<f32>(arm_dot(row + 1u, br), arm_dot(row + 2u, br));
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
            arm_axpy(row + 1u, dt.x);
            arm_axpy(row + 2u, dt.y);
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
            let row = 3u * MAX_C + l;
            let lam = l_lam[l];
            let nl = normal_impulse(lam, arm_dot(row, l_br[l]), l_tgt[l], l_r[l], l_meff[l]);
            if nl != lam {
                arm_axpy(row, nl - lam);
                l_lam[l] = nl;
            }
        }
    }
}

