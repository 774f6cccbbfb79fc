// ---------------------------------------------------------------- rows

// The constraint rows' model, the same for every form of the kernel: MuJoCo's soft rows, the
// projected impulse of a normal or limit row, and the warm-start slots.

// Warm-start slot ids: contacts by pair slot, joint limits after them.
const LIMIT_SLOT: u32 = 0x40000000u;

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

// A friction row's regulariser for a normal row's r.
fn friction_r(r: f32) -> f32 {
    if SOFT_STEP {
        return 0.0;
    }
    return r / IMPRATIO;
}

// Field f (0 slot id as bits, 1 λn, 2 λt1, 3 λt2) of warm-start entry k of this env; envs are
// the fastest-varying index, so a warp's loads are coalesced.
fn warm_addr(k: u32, f: u32) -> u32 {
    return (k * 4u + f) * num_envs + env;
}

// The new impulse of a normal or limit row with impulse lam and velocity jv (target tgt,
// regulariser r, 1 / (a + r) = meff; see `normal_row`).
fn normal_impulse(lam: f32, jv: f32, tgt: f32, r: f32, meff: f32) -> f32 {
    return max(lam - RELAXATION * meff * (jv - tgt + r * lam), 0.0);
}

// The contact frame of normal n: columns n, t1, t2 (right-handed, orthonormal).
fn contact_basis(n: vec3<f32>) -> mat3x3<f32> {
    var t1 = cross(n, vec3<f32>(1.0, 0.0, 0.0));
    if dot(t1, t1) < 0.01 {
        t1 = cross(n, vec3<f32>(0.0, 1.0, 0.0));
    }
    t1 = normalize(t1);
    return mat3x3<f32>(n, t1, cross(n, t1));
}

// The translational inverse weight of body b (0 for the static world).
fn body_weight(b: i32) -> f32 {
    if b < 0 {
        return 0.0;
    }
    return body_invw[b];
}
