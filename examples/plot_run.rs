//! Redraws a run's training curves from its `scalars.csv` (e.g. after a run was stopped before
//! it drew them): `cargo run --example plot_run -- logs/box_pushing/<run>`. A run resumed
//! across several run directories plots as one curve: list them oldest first (iterations that a
//! later directory logged again replace the earlier ones); the curves go into the last.

use std::path::PathBuf;

use clap::Parser;

/// Flags of `plot_run`.
#[derive(Parser, Debug)]
struct Args {
    /// The run directories (each holding `scalars.csv`), oldest first; `training_curves.png` is
    /// written into the last.
    #[arg(required = true)]
    run_dirs: Vec<PathBuf>,
}

// Errors are printed as their messages, not as debug structs.
fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(run())
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let segments = args
        .run_dirs
        .iter()
        .map(|d| orbit::rl::logger::read_scalars(&d.join(orbit::rl::logger::SCALARS_FILE)))
        .collect::<Result<Vec<_>, _>>()?;
    let history = orbit::rl::logger::merge_segments(segments);
    let has_success = history.iter().any(|h| h.success_rate.is_some());
    let out = args.run_dirs.last().expect("clap requires one directory");
    orbit::rl::plot::write_training_curves(out, &history, has_success)?;
    println!(
        "{} iterations → {}",
        history.len(),
        out.join("training_curves.png").display()
    );
    Ok(())
}
