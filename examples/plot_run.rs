//! Redraws a run's training curves from its `scalars.csv` (e.g. after a run was stopped before
//! it drew them): `cargo run --example plot_run -- logs/box_pushing/<run>`.

use std::path::PathBuf;

use clap::Parser;

/// Flags of `plot_run`.
#[derive(Parser, Debug)]
struct Args {
    /// The run directory (holding `scalars.csv`); `training_curves.png` is written there.
    run_dir: PathBuf,
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let history = orbit::rl::logger::read_scalars(&args.run_dir.join("scalars.csv"))?;
    let has_success = history.iter().any(|h| h.success_rate.is_some());
    orbit::rl::plot::write_training_curves(&args.run_dir, &history, has_success)?;
    println!(
        "{} iterations → {}",
        history.len(),
        args.run_dir.join("training_curves.png").display()
    );
    Ok(())
}
