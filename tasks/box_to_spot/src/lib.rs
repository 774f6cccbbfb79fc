//! BoxToSpot: the Franka pushes the box to a fixed spot (joint-position control).

mod rewards;

pub use rewards::ObjectPointParams;

inventory::submit! {
    orbit_managers::TaskDef {
        id: "BoxToSpot-JointPos-Franka-v0",
        description: "Franka pushes the box to a fixed spot on the table, joint position targets",
        file_name: "box_to_spot.ron (bundled)",
        config: include_str!("../config/box_to_spot.ron"),
        overrides: &[], // a variant reuses `config` with its own overrides
    }
}
