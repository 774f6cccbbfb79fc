// ---------------------------------------------------------------- the articulation as loops

// The kernel's looped form (`KernelForm::Looped`): the articulation's passes run as loops over
// the scene's link and dof tables (`link_*`, `dof_*`, `root_link`, written by
// `codegen/looped.rs`) instead of straight-line code. The arithmetic is the straight-line
// form's, term for term; only the driver's constant folding differs. Shader compilers take far
// longer than linearly on long straight-line kernels, so large articulations compile much
// sooner this way.

// Link kinds in `link_kind`.
const LINK_FIXED: u32 = 0u;
const LINK_FLOATING: u32 = 1u;
const LINK_REVOLUTE: u32 = 2u;
const LINK_PRISMATIC: u32 = 3u;

// A dof's motion subspace at the env origin: angular and linear parts.
struct Motion {
    w: vec3<f32>,
    u: vec3<f32>,
}

// Dof d's motion subspace: a joint's from `kinematics`; a floating root's a unit translation
// of its centre of mass or a unit rotation about it, along an env axis.
fn dof_motion(d: u32) -> Motion {
    let l = dof_link[d];
    let a = dof_axis[d];
    if a < 0 {
        return Motion(sw[l], su[l]);
    }
    let k = u32(a) % 3u;
    let e = vec3<f32>(f32(k == 0u), f32(k == 1u), f32(k == 2u));
    if a < 3 {
        return Motion(vec3<f32>(0.0), e);
    }
    return Motion(e, cross(fcom[link_root[l]], e));
}

// Forward kinematics, joint motion subspaces, link spatial inertias and velocities.
fn kinematics() {
    for (var l = 0u; l < NL; l++) {
        let kind = link_kind[l];
        if kind == LINK_FIXED {
            // Welded to the env frame: a constant pose, at rest.
            lpos[l] = link_opos[l] - shift;
            lrot[l] = link_orot[l];
            vw[l] = vec3<f32>(0.0);
            vu[l] = vec3<f32>(0.0);
            continue;
        }
        let d = link_dof[l];
        var pos: vec3<f32>;
        var rot: vec4<f32>;
        if kind == LINK_FLOATING {
            // The origin from the integrated centre of mass and orientation, the velocity from
            // the six root dofs.
            let r = link_root[l];
            rot = lrot[l];
            pos = fcom[r] - qrot(rot, link_com[l]);
            lpos[l] = pos;
            vw[l] = vec3<f32>(qd[d + 3u], qd[d + 4u], qd[d + 5u]);
            vu[l] = vec3<f32>(qd[d], qd[d + 1u], qd[d + 2u]) + cross(fcom[r], vw[l]);
        } else {
            let p = u32(link_parent[l]);
            pos = lpos[p] + qrot(lrot[p], link_opos[l]);
            rot = qmul(lrot[p], link_orot[l]);
            let axis = link_axis[l];
            let axis_w = qrot(rot, axis);
            if kind == LINK_PRISMATIC {
                pos = pos + axis_w * q[d];
                sw[l] = vec3<f32>(0.0);
                su[l] = axis_w;
            } else {
                rot = qmul(rot, qaxis(axis, q[d]));
                sw[l] = axis_w;
                su[l] = cross(pos, axis_w);
            }
            lpos[l] = pos;
            lrot[l] = rot;
            vw[l] = vw[p] + sw[l] * qd[d];
            vu[l] = vu[p] + su[l] * qd[d];
        }
        // Spatial inertia at the env origin.
        let s = mscale[l];
        let m = link_mass[l] * s;
        let c = pos + qrot(rot, link_com[l]);
        let r = qmat(rot);
        let ic = r * (link_inertia[l] * s) * transpose(r);
        let cc = dot(c, c);
        im[l] = m;
        ih[l] = m * c;
        ij[l] = ic + m * (mat3x3<f32>(cc, 0.0, 0.0, 0.0, cc, 0.0, 0.0, 0.0, cc) - outer(c, c));
    }
}

// Bias forces c(q, q̇) by recursive Newton–Euler with q̈ = 0 (gravity as a base acceleration
// of the roots).
fn rnea_bias() {
    var aw: array<vec3<f32>, NL1>;
    var au: array<vec3<f32>, NL1>;
    var fw: array<vec3<f32>, NL1>;
    var fu: array<vec3<f32>, NL1>;
    for (var l = 0u; l < NL; l++) {
        let kind = link_kind[l];
        if kind == LINK_FIXED {
            continue;
        }
        let d = link_dof[l];
        if kind == LINK_FLOATING {
            // The root's axes stay with the env while its centre of mass moves at v:
            // Ṡ q̇ = (0, v × ω).
            let v = vec3<f32>(qd[d], qd[d + 1u], qd[d + 2u]);
            aw[l] = vec3<f32>(0.0);
            au[l] = -GRAVITY + cross(v, vw[l]);
        } else {
            // (v × S) q̇ with the motion cross product.
            var aw0 = vec3<f32>(0.0);
            var au0 = -GRAVITY;
            let p = link_moving_parent[l];
            if p >= 0 {
                aw0 = aw[p];
                au0 = au[p];
            }
            aw[l] = aw0 + cross(vw[l], sw[l]) * qd[d];
            au[l] = au0 + (cross(vw[l], su[l]) + cross(vu[l], sw[l])) * qd[d];
        }
        // f = I a + v ×* (I v).
        let ivw = ij[l] * vw[l] + cross(ih[l], vu[l]);
        let ivu = im[l] * vu[l] - cross(ih[l], vw[l]);
        fw[l] = ij[l] * aw[l] + cross(ih[l], au[l]) + cross(vw[l], ivw) + cross(vu[l], ivu);
        fu[l] = im[l] * au[l] - cross(ih[l], aw[l]) + cross(vw[l], ivu);
    }
    for (var k = i32(NL) - 1; k >= 0; k--) {
        let l = u32(k);
        if link_kind[l] == LINK_FIXED {
            continue;
        }
        let d0 = link_dof[l];
        for (var d = d0; d < d0 + link_dofs[l]; d++) {
            let s = dof_motion(d);
            bias[d] = dot(s.w, fw[l]) + dot(s.u, fu[l]);
        }
        let p = link_moving_parent[l];
        if p >= 0 {
            fw[p] = fw[p] + fw[l];
            fu[p] = fu[p] + fu[l];
        }
    }
}

// Joint-space mass matrix by the composite-rigid-body algorithm, plus armature: the entries
// between each dof and the dofs up its chain (the only ones the tree factorisation reads).
fn crba() {
    var cm: array<f32, NL1>;
    var ch: array<vec3<f32>, NL1>;
    var cj: array<mat3x3<f32>, NL1>;
    for (var l = 0u; l < NL; l++) {
        cm[l] = im[l];
        ch[l] = ih[l];
        cj[l] = ij[l];
    }
    for (var k = i32(NL) - 1; k >= 0; k--) {
        let l = u32(k);
        let p = link_moving_parent[l];
        if link_kind[l] != LINK_FIXED && p >= 0 {
            cm[p] = cm[p] + cm[l];
            ch[p] = ch[p] + ch[l];
            cj[p] = cj[p] + cj[l];
        }
    }
    for (var l = 0u; l < NL; l++) {
        if link_kind[l] == LINK_FIXED {
            continue;
        }
        let d0 = link_dof[l];
        for (var di = d0; di < d0 + link_dofs[l]; di++) {
            // F = I_c S of this dof against each dof up its chain.
            let s = dof_motion(di);
            let fw = cj[l] * s.w + cross(ch[l], s.u);
            let fu = cm[l] * s.u - cross(ch[l], s.w);
            var dj = i32(di);
            while dj >= 0 {
                let sj = dof_motion(u32(dj));
                amat[di * ND + u32(dj)] = dot(sj.w, fw) + dot(sj.u, fu);
                dj = dof_parent[dj];
            }
        }
    }
    for (var d = 0u; d < ND; d++) {
        amat[d * ND + d] = amat[d * ND + d] + dof_armature[d];
    }
}

// Drives and damping: A = M + h(D + d) + h²K and the unconstrained velocity update.
fn drives() {
    var dv: array<f32, ND1>;
    for (var d = 0u; d < ND; d++) {
        if dof_axis[d] >= 0 {
            // A floating root has no drive: only the bias forces act on it.
            dv[d] = -DT * bias[d];
            continue;
        }
        let k = dof_stiffness[d];
        let kd = dof_drive_damping[d];
        let lim = dof_effort_limit[d];
        let damp = dof_damping[d];
        let diag = d * ND + d;
        var ef = in_ef[d];
        if in_comp[d] {
            ef += bias[d];
        }
        var tau: f32;
        if k > 0.0 || kd > 0.0 {
            let qt = in_qt[d];
            let vt = in_vt[d];
            let pd = k * (qt - q[d]) + kd * (vt - qd[d]);
            // Implicit while the drive stays inside its effort limit.
            if abs(pd + ef) <= lim {
                tau = ef + k * (qt - q[d] - DT * qd[d]) + kd * (vt - qd[d]);
                amat[diag] = amat[diag] + DT * (kd + damp) + DT * DT * k;
            } else {
                tau = clamp(pd + ef, -lim, lim);
                amat[diag] = amat[diag] + DT * damp;
            }
            applied[d] = clamp(pd + ef, -lim, lim);
        } else {
            tau = clamp(ef, -lim, lim);
            applied[d] = tau;
            amat[diag] = amat[diag] + DT * damp;
        }
        let spring = dof_spring[d] * (q[d] - dof_spring_ref[d]);
        dv[d] = DT * (tau - damp * qd[d] - spring - bias[d]);
    }
    cholesky();
    chol_solve(&dv);
    for (var d = 0u; d < ND; d++) {
        qd[d] += dv[d];
    }
}

// Adds s times the generalised-force direction of a unit impulse along d at p on body b to jt;
// false if b moves no dof.
fn body_jt(b: i32, p: vec3<f32>, d: vec3<f32>, s: f32, jt: ptr<function, array<f32, ND1>>) -> bool {
    if b < 0 || b >= i32(NL) {
        return false;
    }
    var dof = link_chain_dof[b];
    if dof < 0 {
        return false;
    }
    let pd = cross(p, d);
    while dof >= 0 {
        let m = dof_motion(u32(dof));
        (*jt)[dof] += s * (dot(d, m.u) + dot(m.w, pd));
        dof = dof_parent[dof];
    }
    return true;
}

// A limit row when a joint could reach its limit within this substep.
fn limit_rows() {
    for (var d = 0u; d < ND; d++) {
        let limited = dof_limited[d];
        if limited == 0u {
            continue;
        }
        let reach = abs(qd[d]) * DT + MARGIN;
        let lo = q[d] - dof_lower[d];
        let hi = dof_upper[d] - q[d];
        var side = 0.0;
        var gap = 0.0;
        if (limited & 1u) != 0u && lo < reach {
            side = 1.0;
            gap = lo;
        } else if (limited & 2u) != 0u && hi < reach {
            side = -1.0;
            gap = hi;
        }
        if side != 0.0 {
            var jt: array<f32, ND1>;
            jt[d] = side;
            let slot = 2u * d + select(1u, 0u, side > 0.0);
            limit_row(jt, LIMIT_SLOT + slot, gap);
        }
    }
}

// Velocity limits, then semi-implicit Euler (quaternions renormalised).
fn integrate() {
    for (var d = 0u; d < ND; d++) {
        if dof_axis[d] >= 0 {
            continue;
        }
        let v = dof_velocity_limit[d];
        qd[d] = clamp(qd[d], -v, v);
        q[d] += DT * qd[d];
    }
    for (var r = 0u; r < NR; r++) {
        let l = root_link[r];
        let d = link_dof[l];
        let v = vec3<f32>(qd[d], qd[d + 1u], qd[d + 2u]);
        let w = vec3<f32>(qd[d + 3u], qd[d + 4u], qd[d + 5u]);
        fcom[r] = fcom[r] + DT * v;
        lrot[l] = normalize(lrot[l] + qmul(vec4<f32>(w, 0.0), lrot[l]) * (0.5 * DT));
    }
    integrate_objects();
}

// Link state k (see `link_addr`) of link l.
fn link_state_addr(k: u32, l: u32) -> u32 {
    return link_addr(k, l, link_block[l].x, link_block[l].y);
}

fn load_state() {
    for (var d = 0u; d < ND; d++) {
        if dof_axis[d] < 0 {
            q[d] = st[dof_addr(0u, d, dof_stride[d])];
            qd[d] = st[dof_addr(1u, d, dof_stride[d])];
        }
    }
    // A floating root's state is its link's published pose and origin velocity.
    for (var r = 0u; r < NR; r++) {
        let l = root_link[r];
        let d = link_dof[l];
        let rot = normalize(ld4(link_state_addr(1u, l)));
        let w = ld3(link_state_addr(3u, l));
        let c = qrot(rot, link_com[l]);
        lrot[l] = rot;
        fcom[r] = ld3(link_state_addr(0u, l)) + c;
        let v = ld3(link_state_addr(2u, l)) + cross(w, c);
        qd[d] = v.x;
        qd[d + 1u] = v.y;
        qd[d + 2u] = v.z;
        qd[d + 3u] = w.x;
        qd[d + 4u] = w.y;
        qd[d + 5u] = w.z;
    }
    if SHIFTED {
        // The kernel's frame: origin at the first floating root's centre of mass.
        shift = fcom[0];
        for (var r = 0u; r < NR; r++) {
            fcom[r] = fcom[r] - shift;
        }
    }
    for (var b = 0u; b < NB; b++) {
        mscale[b] = inp[lay[LAY_IN_MASS_SCALE] + env * NB + b];
    }
    // Drive inputs hold for the whole dispatch.
    for (var d = 0u; d < ND; d++) {
        if dof_axis[d] >= 0 {
            continue;
        }
        in_ef[d] = inp[inp_addr(2u, d, dof_stride[d])];
        in_comp[d] = inp[lay[LAY_IN_COMPENSATE] + d] != 0.0;
        if dof_stiffness[d] > 0.0 || dof_drive_damping[d] > 0.0 {
            in_qt[d] = inp[inp_addr(0u, d, dof_stride[d])];
            in_vt[d] = inp[inp_addr(1u, d, dof_stride[d])];
        }
    }
    load_objects();
}

fn load_applied() {
    for (var d = 0u; d < ND; d++) {
        if dof_axis[d] < 0 {
            applied[d] = st[dof_addr(3u, d, dof_stride[d])];
        }
    }
}

fn publish() {
    kinematics();
    rnea_bias();
    for (var d = 0u; d < ND; d++) {
        if dof_axis[d] < 0 {
            let stride = dof_stride[d];
            st[dof_addr(0u, d, stride)] = q[d];
            st[dof_addr(1u, d, stride)] = qd[d];
            st[dof_addr(2u, d, stride)] = bias[d];
            st[dof_addr(3u, d, stride)] = applied[d];
        }
    }
    for (var l = 0u; l < NL; l++) {
        var pos = lpos[l];
        if SHIFTED {
            pos = pos + shift;
        }
        st3(link_state_addr(0u, l), pos);
        st4(link_state_addr(1u, l), lrot[l]);
        st3(link_state_addr(2u, l), vu[l] + cross(vw[l], lpos[l]));
        st3(link_state_addr(3u, l), vw[l]);
    }
    publish_objects();
}
