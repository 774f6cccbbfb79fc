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

