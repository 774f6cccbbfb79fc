//! ProMP against MP_PyTorch 0.1.3's basis rows and Fancy Gym's desired trajectories from the
//! MuJoCo reference rollouts, plus the identities the construction implies.

use orbit_mp::{MpError, ProMp, ProMpCfg};
use serde::Deserialize;

/// Fancy Gym's `fancy_ProMP/BoxPushing…` ProMP (its `box_pushing/mp_wrapper.py` settings).
fn box_pushing() -> ProMp {
    ProMp::new(ProMpCfg {
        num_dof: 7,
        num_basis: 5,
        num_basis_zero_start: 1,
        num_basis_zero_goal: 0,
        basis_bandwidth_factor: 2.0,
        tau: 2.0,
        delay: 0.0,
        weights_scale: 1.0,
        dt: 0.02,
        num_steps: 100,
    })
    .unwrap()
}

/// Centres (0, 0.2, …, 1) and widths h = 2/0.2² = 50, as MP_PyTorch 0.1.3 places them.
#[test]
fn basis_centres_and_widths() {
    let p = box_pushing();
    let b = p.basis();
    assert_eq!(b.len(), 6);
    for (j, (&c, &h)) in b.centres().iter().zip(b.widths()).enumerate() {
        assert!((c - 0.2 * j as f64).abs() < 1e-12, "centre {j}: {c}");
        assert!((h - 50.0).abs() < 1e-9, "width {j}: {h}");
    }
    assert_eq!(b.learned(), 1..6);
}

/// The basis rows at t = 0.02, 0.5, 1.0 and 2.0 s that MP_PyTorch 0.1.3 computes (6 decimals).
#[test]
fn basis_rows_match_mp_pytorch() {
    let p = box_pushing();
    let rows: [(usize, [f64; 6]); 4] = [
        (0, [0.699738, 0.284492, 0.015654, 0.000117, 0.0, 0.0]),
        (24, [0.118686, 0.531914, 0.322622, 0.026482, 0.000294, 0.0]),
        (
            49,
            [0.001089, 0.059472, 0.439439, 0.439439, 0.059472, 0.001089],
        ),
        (99, [0.0, 0.0, 0.000089, 0.013212, 0.265364, 0.721335]),
    ];
    for (k, expected) in rows {
        let row = p.basis_row(k);
        for (j, (&got, want)) in row.iter().zip(expected).enumerate() {
            assert!(
                (got - want).abs() < 6e-7,
                "t = {}: basis {j} is {got}, MP_PyTorch gives {want}",
                p.times()[k]
            );
        }
        assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
    assert!((p.times()[0] - 0.02).abs() < 1e-12 && (p.times()[99] - 2.0).abs() < 1e-12);
}

#[derive(Deserialize)]
struct Reference {
    q_start: Vec<f32>,
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Case {
    name: String,
    weights_dof_major: Vec<Vec<f32>>,
    desired_pos: Vec<Vec<f64>>,
}

/// Fancy Gym's desired joint positions for zero and random weights, all cases as envs of one
/// batched call: agreement to 1e-6 rad (the reference is float64, we round to f32 at the end).
#[test]
fn trajectories_match_fancy_gym() {
    let r: Reference = serde_json::from_str(include_str!("data/promp_reference.json")).unwrap();
    let p = box_pushing();
    let n = r.cases.len();
    let params: Vec<f32> = r
        .cases
        .iter()
        .flat_map(|c| c.weights_dof_major.iter().flatten().copied())
        .collect();
    let q_start: Vec<f32> = (0..n).flat_map(|_| r.q_start.iter().copied()).collect();
    let mut pos = vec![0.0; n * 100 * 7];
    let mut vel = vec![0.0; n * 100 * 7];
    p.trajectories(&params, &q_start, &mut pos, &mut vel)
        .unwrap();
    for (e, case) in r.cases.iter().enumerate() {
        let mut worst = 0.0f64;
        for (k, want) in case.desired_pos.iter().enumerate() {
            for (d, &w) in want.iter().enumerate() {
                let got = f64::from(pos[(e * 100 + k) * 7 + d]);
                worst = worst.max((got - w).abs());
            }
        }
        assert!(worst < 1e-6, "{}: max error {worst} rad", case.name);
    }
}

/// Velocities are forward differences of the positions, the last one repeated; zero weights
/// hold the start position.
#[test]
fn forward_difference_velocities_and_offset() {
    let p = box_pushing();
    let params: Vec<f32> = (0..35)
        .map(|i| ((i * 7919) % 13) as f32 * 0.1 - 0.6)
        .collect();
    let q_start: Vec<f32> = (0..7).map(|d| d as f32 * 0.3 - 1.0).collect();
    let (mut pos, mut vel) = (vec![0.0; 700], vec![0.0; 700]);
    p.trajectories(&params, &q_start, &mut pos, &mut vel)
        .unwrap();
    for k in 0..99 {
        for d in 0..7 {
            let fd = (pos[(k + 1) * 7 + d] - pos[k * 7 + d]) / 0.02;
            assert!(
                (vel[k * 7 + d] - fd).abs() < 2e-4 * (1.0 + fd.abs()),
                "k {k} d {d}"
            );
        }
    }
    assert_eq!(vel[99 * 7..], vel[98 * 7..99 * 7]);
    let zeros = vec![0.0; 35];
    p.trajectories(&zeros, &q_start, &mut pos, &mut vel)
        .unwrap();
    assert!(pos.chunks_exact(7).all(|row| row == q_start.as_slice()));
    assert!(vel.iter().all(|&v| v == 0.0));
}

/// A weight moves only its own dof, by its basis function's value.
#[test]
fn weights_are_dof_major() {
    let p = box_pushing();
    let mut params = vec![0.0f32; 35];
    params[3 * 5 + 2] = 1.0; // dof 3, learned function 2 = basis column 3 (centre 0.6)
    let q_start = vec![0.0f32; 7];
    let (mut pos, mut vel) = (vec![0.0; 700], vec![0.0; 700]);
    p.trajectories(&params, &q_start, &mut pos, &mut vel)
        .unwrap();
    for k in 0..100 {
        for d in 0..7 {
            let want = if d == 3 {
                p.basis_row(k)[3] as f32
            } else {
                0.0
            };
            assert!((pos[k * 7 + d] - want).abs() < 1e-7);
        }
    }
}

/// Bad configs and inputs are errors that name the field, and leave the outputs untouched.
#[test]
fn invalid_input_is_rejected() {
    let mut cfg = box_pushing().cfg().clone();
    cfg.tau = 0.0;
    assert!(matches!(
        ProMp::new(cfg),
        Err(MpError::InvalidConfig { field: "tau", .. })
    ));
    let p = box_pushing();
    let (mut pos, mut vel) = (vec![7.0; 1400], vec![7.0; 1400]);
    let mut params = vec![0.0f32; 70];
    params[40] = f32::NAN;
    let err = p
        .trajectories(&params, &[0.0; 14], &mut pos, &mut vel)
        .unwrap_err();
    assert!(
        matches!(
            err,
            MpError::NonFinite {
                name: "params",
                env: 1,
                ..
            }
        ),
        "{err}"
    );
    assert!(pos.iter().chain(&vel).all(|&v| v == 7.0));
    let err = p
        .trajectories(&params[..34], &[0.0; 7], &mut pos[..700], &mut vel[..700])
        .unwrap_err();
    assert_eq!(
        err,
        MpError::Length {
            name: "params",
            expected: 35,
            got: 34
        }
    );
}
