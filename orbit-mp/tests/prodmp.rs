//! ProDMP against MP_PyTorch 0.1.3's numbers for Fancy Gym's settings and the facts of the DMP
//! it solves: the boundary condition at the start, the critically damped homogeneous solution,
//! the ODE with its forcing term, and that a plan started from another plan's state continues it.

use orbit_mp::{MpError, ProDmp, ProDmpCfg};

/// Fancy Gym's `fancy_ProDMP/BoxPushing…` ProDMP (bandwidth 2, weights and goal learned).
fn cfg(factor: f64) -> ProDmpCfg {
    ProDmpCfg {
        num_dof: 7,
        num_basis: 5,
        alpha: 10.0,
        alpha_phase: 3.0,
        tau: 1.5,
        delay: 0.0,
        basis_bandwidth_factor: factor,
        weights_scale: 1.0,
        goal_scale: 1.0,
        auto_scale_basis: false,
        disable_goal: false,
        relative_goal: false,
        dt: 0.02,
        num_steps: 100,
        pre_compute_dt: 0.01,
        pre_compute_length_factor: 5.0,
    }
}

/// The replanning variant: bandwidth 3, auto-scaled basis, scales 0.3, no learned goal.
fn replan_cfg() -> ProDmpCfg {
    ProDmpCfg {
        auto_scale_basis: true,
        weights_scale: 0.3,
        goal_scale: 0.3,
        disable_goal: true,
        ..cfg(3.0)
    }
}

fn close(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: {got}, expected {want} ± {tol}"
    );
}

/// A deterministic pseudo-random parameter vector in [-1, 1].
fn params(n: usize, seed: u32) -> Vec<f32> {
    let mut x = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f32 / u32::MAX as f32) * 2.0 - 1.0
        })
        .collect()
}

/// Centres (evenly spaced in time, in phase) and widths for factors 2 and 3 (MP_PyTorch 0.1.3).
#[test]
fn centres_and_widths_match_mp_pytorch() {
    let centres = [1.0, 0.4723666, 0.2231302, 0.1053992, 0.0497871];
    for (factor, widths) in [
        (2.0, [7.184, 32.196, 144.294, 646.682, 646.682]),
        (3.0, [10.776, 48.295, 216.441, 970.022, 970.022]),
    ] {
        let p = ProDmp::new(cfg(factor)).unwrap();
        for j in 0..5 {
            close(p.basis().centres()[j], centres[j], 5e-8, "centre");
            close(p.basis().widths()[j], widths[j], 5e-4, "width");
        }
    }
}

/// Auto-scaling divides each column by its maximum: MP_PyTorch 0.1.3's factors for the replanning
/// config, times the weight and goal scale 0.3.
#[test]
fn auto_scale_factors_match_mp_pytorch() {
    let p = ProDmp::new(replan_cfg()).unwrap();
    let factors = [116.482, 145.776, 322.364, 814.242, 992.600, 1.0];
    for (j, (&got, want)) in p.column_scales().iter().zip(factors).enumerate() {
        close(got / 0.3, want, 1e-3, &format!("column {j}"));
    }
    assert_eq!(p.num_params(), 35);
    assert_eq!(ProDmp::new(cfg(2.0)).unwrap().num_params(), 42);
}

/// With no forcing and goal 0, a plan from rest at `q0` is the critically damped decay
/// `q0·(1 + αs/2)·e^{−αs/2}`, `s = t/τ`.
#[test]
fn homogeneous_solution_is_critically_damped() {
    let p = ProDmp::new(cfg(2.0)).unwrap();
    let q0: Vec<f32> = (0..7).map(|d| 0.1 * (d as f32 + 1.0)).collect();
    let (mut pos, mut vel) = (vec![0.0; 700], vec![0.0; 700]);
    p.trajectories(0.0, &[0.0; 42], &q0, &[0.0; 7], &mut pos, &mut vel)
        .unwrap();
    for k in 0..100 {
        let s = 0.02 * (k + 1) as f64 / 1.5;
        let shape = (1.0 + 5.0 * s) * (-5.0 * s).exp();
        let slope = -25.0 * s * (-5.0 * s).exp() / 1.5;
        for d in 0..7 {
            let q = f64::from(q0[d]);
            close(f64::from(pos[k * 7 + d]), q * shape, 1e-6, "position");
            close(f64::from(vel[k * 7 + d]), q * slope, 1e-5, "velocity");
        }
    }
}

/// The trajectory leaves `(q0, v0)` at `t0`: with a tiny sample step the first sample is
/// `q0 + v0·dt` to second order, and its velocity `v0` to first order.
#[test]
fn trajectory_starts_at_the_given_state() {
    let base = ProDmpCfg {
        dt: 1e-5,
        num_steps: 1,
        ..cfg(2.0)
    };
    let p = ProDmp::new(base).unwrap();
    let theta = params(2 * 42, 7);
    let q0 = params(14, 3);
    let v0: Vec<f32> = params(14, 5).iter().map(|v| 2.0 * v).collect();
    for t0 in [0.0, 0.5, 1.23] {
        let (mut pos, mut vel) = (vec![0.0; 14], vec![0.0; 14]);
        p.trajectories(t0, &theta, &q0, &v0, &mut pos, &mut vel)
            .unwrap();
        for i in 0..14 {
            let expected = f64::from(q0[i]) + f64::from(v0[i]) * 1e-5;
            close(f64::from(pos[i]), expected, 2e-6, "first position");
            close(f64::from(vel[i]), f64::from(v0[i]), 5e-3, "first velocity");
        }
    }
}

/// A plan started at a sample of another plan, from that sample's position and velocity,
/// with the same parameters, continues it: the DMP's solution is unique. The samples land on
/// grid nodes, so the interpolation is exact and only f32 rounding remains.
#[test]
fn replanning_from_a_planned_state_continues_the_plan() {
    let p = ProDmp::new(cfg(2.0)).unwrap();
    let theta = params(42, 11);
    let q0 = params(7, 1);
    let v0 = params(7, 2);
    let (mut pos, mut vel) = (vec![0.0; 700], vec![0.0; 700]);
    p.trajectories(0.0, &theta, &q0, &v0, &mut pos, &mut vel)
        .unwrap();
    // Sample 24 is t = 0.5 s.
    let (q1, v1) = (&pos[24 * 7..25 * 7], &vel[24 * 7..25 * 7]);
    let (mut pos2, mut vel2) = (vec![0.0; 700], vec![0.0; 700]);
    p.trajectories(0.5, &theta, q1, v1, &mut pos2, &mut vel2)
        .unwrap();
    for k in 0..75 {
        for d in 0..7 {
            let (a, b) = ((k + 25) * 7 + d, k * 7 + d);
            close(f64::from(pos2[b]), f64::from(pos[a]), 2e-5, "position");
            close(f64::from(vel2[b]), f64::from(vel[a]), 2e-4, "velocity");
        }
    }
}

/// The sampled trajectory solves `y'' = α(α/4·(g − y) − y') + x(s)·Σ_j B_j(s)·w_j` in scaled
/// time. Samples fall on the tabulation grid (10 ms), where the lookup is exact; derivatives
/// are central differences over ±10 ms, and the forced part comes from a trapezoid rule on
/// that grid, hence the 1 % tolerance on the forcing's size.
#[test]
fn trajectory_solves_the_dmp() {
    let dt = 0.01;
    let c = ProDmpCfg {
        num_dof: 1,
        dt,
        num_steps: 150,
        ..cfg(2.0)
    };
    let p = ProDmp::new(c).unwrap();
    let theta = [40.0f32, -25.0, 60.0, 10.0, -30.0, 0.4];
    let (mut pos, mut vel) = (vec![0.0; 150], vec![0.0; 150]);
    p.trajectories(0.0, &theta, &[0.2], &[0.5], &mut pos, &mut vel)
        .unwrap();
    let tau = 1.5;
    let mut b = vec![0.0; 5];
    let mut worst = 0.0f64;
    let mut forcing_size = 0.0f64;
    for k in 1..149 {
        let t = (k + 1) as f64 * dt;
        let y = f64::from(pos[k]);
        // Derivatives with respect to s = t/τ.
        let ds = dt / tau;
        let dy = f64::from(pos[k + 1] - pos[k - 1]) / (2.0 * ds);
        let ddy = f64::from(vel[k + 1] - vel[k - 1]) * tau / (2.0 * ds);
        let x = p.phase().phase(t);
        p.basis().row(x, &mut b);
        let forcing: f64 = (0..5).map(|j| x * b[j] * f64::from(theta[j])).sum();
        let rhs = 10.0 * (2.5 * (f64::from(theta[5]) - y) - dy) + forcing;
        worst = worst.max((ddy - rhs).abs());
        forcing_size = forcing_size.max(forcing.abs());
        // The analytic velocity agrees with the positions' central difference (its error,
        // h²/6·y''', reaches a few 1e-3 in the first steps where the forcing is strongest).
        close(
            f64::from(vel[k]) * tau,
            dy,
            5e-3 * (1.0 + dy.abs()),
            "velocity",
        );
    }
    assert!(
        worst < 0.01 * forcing_size,
        "ODE residual {worst} against a forcing of size {forcing_size}"
    );
}

/// A relative goal with no learned goal holds the start: zero weights from rest stay put.
#[test]
fn relative_goal_holds_the_start() {
    let p = ProDmp::new(ProDmpCfg {
        relative_goal: true,
        ..replan_cfg()
    })
    .unwrap();
    let q0 = params(7, 9);
    let (mut pos, mut vel) = (vec![0.0; 700], vec![0.0; 700]);
    p.trajectories(0.0, &[0.0; 35], &q0, &[0.0; 7], &mut pos, &mut vel)
        .unwrap();
    for k in 0..100 {
        for d in 0..7 {
            close(
                f64::from(pos[k * 7 + d]),
                f64::from(q0[d]),
                1e-6,
                "position",
            );
            close(f64::from(vel[k * 7 + d]), 0.0, 1e-5, "velocity");
        }
    }
}

/// Bad configs and inputs are errors that name the field; nothing is written.
#[test]
fn invalid_input_is_rejected() {
    let e = ProDmp::new(ProDmpCfg {
        tau: 0.0,
        ..cfg(2.0)
    })
    .unwrap_err();
    assert!(
        matches!(e, MpError::InvalidConfig { field: "tau", .. }),
        "{e}"
    );
    let p = ProDmp::new(cfg(2.0)).unwrap();
    let (mut pos, mut vel) = (vec![7.0; 700], vec![7.0; 700]);
    let mut theta = vec![0.0; 42];
    theta[13] = f32::NAN;
    let e = p
        .trajectories(0.0, &theta, &[0.0; 7], &[0.0; 7], &mut pos, &mut vel)
        .unwrap_err();
    assert!(
        matches!(
            e,
            MpError::NonFinite {
                name: "params",
                env: 0,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("params"), "{e}");
    let e = p
        .trajectories(0.0, &[0.0; 41], &[0.0; 7], &[0.0; 7], &mut pos, &mut vel)
        .unwrap_err();
    assert!(matches!(e, MpError::Length { name: "params", .. }), "{e}");
    // 100 samples from t0 = 6 s end at s = 5.33, beyond the grid's 5.
    let e = p
        .trajectories(6.0, &[0.0; 42], &[0.0; 7], &[0.0; 7], &mut pos, &mut vel)
        .unwrap_err();
    assert!(
        matches!(
            e,
            MpError::InvalidConfig {
                field: "pre_compute_length_factor",
                ..
            }
        ),
        "{e}"
    );
    assert!(pos.iter().chain(&vel).all(|&v| v == 7.0));
}
