//! BoxToSpot: the Franka pushes the box to a fixed spot (joint-position control).

mod rewards;

pub use rewards::ObjectPointParams;

inventory::submit! {
    orbit_managers::TaskTable {
        root: "box_to_spot",                       // bundled as <bundled>/box_to_spot/…
        files: orbit_managers::config_files!("box_to_spot.ron", "agents/ppo.ron"),
        tasks: &[orbit_managers::TaskDef {
            id: "BoxToSpot-JointPos-Franka-v0",
            description: "Franka pushes the box to a fixed spot on the table, joint position targets",
            env: "box_to_spot.ron",                // paths are relative to config/
            agent: Some("agents/ppo.ron"),         // what `train` uses
            black_box: None,                       // a step-based task
            cpu_agent: None,                       // no config sized for CPU physics
        }],
    }
}
