//! Time per PPO update of the fused trainer for the shapes of three registered configs: box
//! pushing (53 observations, [256, 128, 64] ELU, 7 actions, 4 096 envs × 24 steps, 10 epochs of
//! 16 minibatches), the Ant (60, [400, 200, 100], 8, 4 096 × 32, 5 × 4) and the Humanoid (87,
//! [400, 200, 100], 21, 4 096 × 32, 5 × 4). Each update is timed from its first upload to its
//! last read (one update after one of warm-up; the median of five), on random data: the time
//! does not depend on the values. On devices with timestamp queries each kernel of one more
//! step is then timed on its own.
//!
//! `cargo run --release -p orbit-mlp-wgpu --example ppo_update_speed`
use orbit_mlp_wgpu::{Activation, PpoSettings, PpoShape, PpoTrainer, UpdateInputs};
use std::time::Instant;

/// A reproducible value in [-1, 1) (a hash of `i`).
fn value(i: usize) -> f32 {
    let mut h = (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    h ^= h >> 31;
    h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h ^= h >> 29;
    (h >> 40) as f32 / (1u64 << 23) as f32 - 1.0
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let gpu = orbit_physics_wgpu::gpu()?;
    let configs = [
        ("box pushing", 53, vec![256, 128, 64], 7, 4096 * 24, 10, 16),
        ("Ant", 60, vec![400, 200, 100], 8, 4096 * 32, 5, 4),
        ("Humanoid", 87, vec![400, 200, 100], 21, 4096 * 32, 5, 4),
    ];
    for (name, obs, hidden, actions, batch, epochs, minibatches) in configs {
        let widths = |input: usize, output: usize| {
            let mut w = vec![input];
            w.extend(&hidden);
            w.push(output);
            w
        };
        let shape = PpoShape {
            actor_widths: widths(obs, actions),
            critic_widths: widths(obs, 1),
            activation: Activation::Elu,
            log_std: false,
            batch,
            minibatches,
            separate_critic: false,
        };
        let settings = PpoSettings {
            clip: 0.2,
            value_coef: 1.0,
            entropy_coef: 0.005,
            clipped_value_loss: true,
            desired_kl: Some(0.01),
            max_grad_norm: 1.0,
            per_network_clip: true,
            epochs,
        };
        let mut trainer = PpoTrainer::new(&gpu.device, &gpu.queue, shape, settings)?;
        let p = trainer.num_params();
        let params: Vec<f32> = (0..p).map(|i| 0.05 * value(i)).collect();
        let zeros = vec![0.0; p];
        trainer.load_state(&params, (&zeros, &zeros), 0, 1e-4)?;
        let envs = 4096;
        for t in 0..batch / envs {
            let o: Vec<f32> = (0..envs * obs).map(|i| value(i + t)).collect();
            let a: Vec<f32> = (0..envs * actions).map(|i| value(i + 7 * t)).collect();
            trainer.write_step(t, &o, None, &a)?;
        }
        let rows: Vec<f32> = (0..batch).map(value).collect();
        let mu: Vec<f32> = (0..batch * actions).map(|i| value(3 * i)).collect();
        let perm: Vec<u32> = (0..batch as u32)
            .map(|i| (i * 7919) % batch as u32)
            .collect();
        let sigma = vec![1.0; actions];
        let inputs = UpdateInputs {
            mu: &mu,
            log_prob: &rows,
            advantages: &rows,
            returns: &rows,
            values: &rows,
            sigma: &sigma,
            perm: &perm,
        };
        trainer.update(inputs)?;
        let mut times: Vec<f64> = (0..5)
            .map(|_| {
                let t = Instant::now();
                trainer.update(inputs).map(|_| t.elapsed().as_secs_f64())
            })
            .collect::<Result<_, _>>()?;
        times.sort_by(f64::total_cmp);
        let steps = epochs * minibatches;
        println!(
            "{name}: {:.1} ms per update ({steps} steps of {} rows; {:.3} ms per step)",
            times[2] * 1e3,
            batch / minibatches,
            times[2] * 1e3 / steps as f64
        );
        if let Some(profile) = trainer.profile_step()? {
            let total: f64 = profile.iter().map(|(_, t)| t).sum();
            println!("  one step, kernel by kernel: {:.3} ms in all", total * 1e3);
            for (label, t) in profile {
                println!("  {label:<20} {:7.1} µs", t * 1e6);
            }
        }
    }
    Ok(())
}
