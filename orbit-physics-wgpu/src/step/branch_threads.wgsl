// ---------------------------------------------------------------- one thread per branch

// The kernel form for a floating root whose branches are chains of the same shape (the Ant's
// four legs): four invocations (a quad) simulate one env, invocation `lane` holding branch
// `lane`'s chain (lanes past the last branch hold none). Every invocation keeps the root's state
// and the parts of the system that couple the branches; the rest is its own chain's. The
// branches meet only at the root, so the mass matrix is block-diagonal in the velocities
// (q̇_root, u_b = q̇_b − C_b q̇_root), C_b = −A_bb⁻¹ A_b,root: the root's block is the Schur
// complement S = A_root + Σ_b A_b,rootᵀ C_b, and an impulse on branch b's dofs moves the other
// branches' only through the root. Sums over the branches are taken in lane order on every
// lane, so the four hold the same bits. The solver's sweeps visit the branches' rows in turn
// (Gauss–Seidel as in the one-thread kernel); after each turn the other lanes take the root's
// new velocity from the owner and move their dofs by C_b Δq̇_root.

var<private> env: u32;
var<private> num_envs: u32;
var<private> lane: u32;
// This invocation's index in its subgroup (a quad is four consecutive ones).
var<private> sid: u32;
// Whether the substep running is the first of this dispatch (a written env skips the warm
// start of that one only).
var<private> first_substep: bool;

// x summed over the env's four lanes, in lane order.
fn quad_sum(x: f32) -> f32 {
    return quadBroadcast(x, 0u) + quadBroadcast(x, 1u) + quadBroadcast(x, 2u) + quadBroadcast(x, 3u);
}

fn quad_sum3(x: vec3<f32>) -> vec3<f32> {
    return quadBroadcast(x, 0u) + quadBroadcast(x, 1u) + quadBroadcast(x, 2u) + quadBroadcast(x, 3u);
}

fn substep() {
    qd0 = qd;
    rv0 = rv;
    rw0 = rw;
    kinematics();
    rnea_bias();
    crba();
    drives();
    collide();
    build_contacts();
    limit_rows();
    solve_and_integrate();
}

@compute @workgroup_size(WORKGROUP)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(subgroup_invocation_id) si: u32) {
    sid = si;
    env = gid.x / 4u;
    lane = gid.x % 4u;
    num_envs = lay[LAY_NUM_ENVS];
    // The four lanes of an env leave together: every quad operation below sees all four.
    if env >= num_envs {
        return;
    }
    run_env();
}
