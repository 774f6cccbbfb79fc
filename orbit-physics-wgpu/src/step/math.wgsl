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

