//! Lists the registered tasks, or writes one task's config files to edit:
//!
//! ```text
//! cargo run --example list_tasks
//! cargo run --example list_tasks -- --export Reach-Franka-v0 my_reach
//! cargo run --release --example train -- --task-config my_reach/reach/env/reach.ron \
//!     --agent-config my_reach/reach/agents/ppo.ron
//! ```

use std::path::PathBuf;

use clap::Parser;

/// Flags of `list_tasks`.
#[derive(Parser, Debug)]
struct Args {
    /// Write the config files of task ID (env, training, black-box, and the files they include)
    /// under DIR, keeping their layout, then print their paths.
    #[arg(long, num_args = 2, value_names = ["ID", "DIR"])]
    export: Option<Vec<String>>,
}

fn main() -> std::process::ExitCode {
    orbit::init_logging();
    orbit::exit_code(run(Args::parse()))
}

fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    orbit::link_registrations();
    if let Some(export) = args.export {
        let (id, dir) = (&export[0], PathBuf::from(&export[1]));
        for path in orbit::managers::export_task_configs(id, &dir)? {
            println!("{}", path.display());
        }
        return Ok(());
    }
    println!("{:<52} {:<10} description", "task id", "training");
    for task in orbit::managers::tasks() {
        let training = match (&task.agent, task.is_black_box()) {
            (None, _) => "-",
            (Some(_), false) => "PPO",
            (Some(_), true) => "BBRL-PPO",
        };
        println!("{:<52} {training:<10} {}", task.id, task.description);
    }
    println!(
        "\nBBRL-PPO tasks are black-box: one movement primitive per episode.\n\
         asset configs: {:?}\nphysics backends: {:?}",
        orbit::assets::asset_cfgs()
            .iter()
            .map(|a| a.name)
            .collect::<Vec<_>>(),
        orbit::core::physics::backend_names()
    );
    Ok(())
}
