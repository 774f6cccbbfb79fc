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
