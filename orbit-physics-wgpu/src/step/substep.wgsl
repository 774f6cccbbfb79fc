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
    solve_and_integrate();
}

@compute @workgroup_size(WORKGROUP)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    env = gid.x;
    num_envs = lay[LAY_NUM_ENVS];
    if env >= num_envs {
        return;
    }
    run_env();
}
