// ---------------------------------------------------------------- an env's dispatch

// Runs this invocation's env for `params.substeps` substeps and publishes its state; with no
// substeps, only republishes (the envs marked for it, or all).
fn run_env() {
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

// A substep's constraints and integration, once its rows are built: warm starts, the sweeps,
// velocity limits and integration, the soft step's relaxation sweeps, and the impulses kept
// for the next substep's warm start.
fn solve_and_integrate() {
    warm_start();
    solve(ITERATIONS);
    integrate();
    if SOFT_STEP {
        relax_rows();
        solve(ITERATIONS);
    }
    store_warm();
}
