//! Time per forward pass of an actor and a critic of Isaac Lab's locomotion widths (60 inputs,
//! [400, 200, 100] ELU, 8 outputs) at 4 096 and 65 536 rows: 200 passes after 20 of warm-up,
//! the upload of the inputs and the read of the outputs included. Constant weights: the time
//! does not depend on the values.
//!
//! `cargo run --release -p orbit-mlp-wgpu --example mlp_speed`
use orbit_mlp_wgpu::{Activation, StackedMlp};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let gpu = orbit_physics_wgpu::gpu()?;
    for &(rows, widths) in &[
        (4096usize, [60usize, 400, 200, 100, 8]),
        (65536, [60, 400, 200, 100, 8]),
    ] {
        let mut mlp = StackedMlp::new(&gpu.device, &gpu.queue, rows, 2, &widths, Activation::Elu)?;
        for l in 0..4 {
            let (k, n) = (widths[l], widths[l + 1]);
            mlp.load_layer(l, &vec![0.01; 2 * k * n], &vec![0.1; 2 * n])?;
        }
        let x = vec![0.5f32; rows * 60];
        let mut out = vec![0.0; 2 * rows * 8];
        for _ in 0..20 {
            mlp.forward(&[&x], &mut out)?;
        }
        let t = Instant::now();
        let reps = 200;
        for _ in 0..reps {
            mlp.forward(&[&x], &mut out)?;
        }
        println!(
            "{rows} rows: {:.3} ms per forward pass",
            t.elapsed().as_secs_f64() * 1e3 / reps as f64
        );
    }
    Ok(())
}
