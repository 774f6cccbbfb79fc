//! Asset configs registered by name, as Isaac Lab exports `FRANKA_PANDA_CFG`: a scene entry
//! `"robot": (asset: "franka_panda_rod")` starts from the registered config and restates only
//! what it changes. Any crate may register more with
//! `inventory::submit! { orbit_assets::AssetCfgDef { … } }`.

/// The kind of scene entity an asset config describes (the list of `SceneCfg` it belongs to).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AssetKind {
    /// An articulation (`SceneCfg::articulations`, `ArticulationCfg`).
    Articulation,
    /// A free rigid body (`SceneCfg::rigid_objects`, `RigidObjectCfg`).
    RigidObject,
    /// Fixed collision geometry (`SceneCfg::static_objects`, `StaticObjectCfg`).
    StaticObject,
}

impl AssetKind {
    /// The `SceneCfg` field holding entities of this kind.
    pub fn scene_field(self) -> &'static str {
        match self {
            AssetKind::Articulation => "articulations",
            AssetKind::RigidObject => "rigid_objects",
            AssetKind::StaticObject => "static_objects",
        }
    }

    /// Every kind, in `SceneCfg`'s field order.
    pub const ALL: [AssetKind; 3] = [
        AssetKind::Articulation,
        AssetKind::RigidObject,
        AssetKind::StaticObject,
    ];
}

/// A registered asset config: the RON of an `ArticulationCfg`, `RigidObjectCfg` or
/// `StaticObjectCfg` without its `name` (the scene entry's key gives it).
pub struct AssetCfgDef {
    /// The name scenes refer to it by.
    pub name: &'static str,
    /// Which scene list it belongs to.
    pub kind: AssetKind,
    /// One-line description.
    pub description: &'static str,
    /// Its path under the bundled root, named in errors (`assets/franka_panda_rod.ron`).
    pub file: &'static str,
    /// The config (RON text).
    pub config: &'static str,
}

inventory::collect!(AssetCfgDef);

/// All registered asset configs, sorted by name.
pub fn asset_cfgs() -> Vec<&'static AssetCfgDef> {
    let mut v: Vec<&AssetCfgDef> = inventory::iter::<AssetCfgDef>.into_iter().collect();
    v.sort_by_key(|a| a.name);
    v
}

/// The asset config registered as `name`.
pub fn asset_cfg(name: &str) -> Option<&'static AssetCfgDef> {
    inventory::iter::<AssetCfgDef>
        .into_iter()
        .find(|a| a.name == name)
}

inventory::submit! {
    AssetCfgDef {
        name: "franka_panda_rod",
        kind: AssetKind::Articulation,
        description: "Franka Emika Panda with Fancy Gym's push rod, torque-driven, at Fancy Gym's box-pushing start pose",
        file: "assets/franka_panda_rod.ron",
        config: include_str!("../assets/franka_panda_rod.ron"),
    }
}

inventory::submit! {
    AssetCfgDef {
        name: "push_box",
        kind: AssetKind::RigidObject,
        description: "Fancy Gym's open box (base plate and four walls, 2.004 kg) at its default pose",
        file: "assets/push_box.ron",
        config: include_str!("../assets/push_box.ron"),
    }
}

inventory::submit! {
    AssetCfgDef {
        name: "lab_table",
        kind: AssetKind::StaticObject,
        description: "Fancy Gym's lab table in front of the robot (top surface at z = -0.019)",
        file: "assets/lab_table.ron",
        config: include_str!("../assets/lab_table.ron"),
    }
}

inventory::submit! {
    AssetCfgDef {
        name: "franka_mount",
        kind: AssetKind::StaticObject,
        description: "the plate under the Franka's base (top at z = 0), not colliding with panda_link0",
        file: "assets/franka_mount.ron",
        config: include_str!("../assets/franka_mount.ron"),
    }
}

inventory::submit! {
    AssetCfgDef {
        name: "cartpole",
        kind: AssetKind::Articulation,
        description: "the cart-pole of Isaac Lab's Isaac-Cartpole-v0: a cart on an 8 m rail, a 1 m pole, both effort-driven",
        file: "assets/cartpole.ron",
        config: include_str!("../assets/cartpole.ron"),
    }
}

inventory::submit! {
    AssetCfgDef {
        name: "ant",
        kind: AssetKind::Articulation,
        description: "The Ant of Isaac Lab's ANT_CFG (isaac_ant.xml): a floating base at 0.5 m, eight effort-driven hinges",
        file: "assets/ant.ron",
        config: include_str!("../assets/ant.ron"),
    }
}

inventory::submit! {
    AssetCfgDef {
        name: "humanoid",
        kind: AssetKind::Articulation,
        description: "The Humanoid of Isaac Lab's HUMANOID_CFG (isaac_humanoid.xml): a floating torso at 1.34 m, 21 effort-driven hinges held by springs towards 0",
        file: "assets/humanoid.ron",
        config: include_str!("../assets/humanoid.ron"),
    }
}

inventory::submit! {
    AssetCfgDef {
        name: "ground_plane",
        kind: AssetKind::StaticObject,
        description: "an infinite ground plane at z = 0 with friction 1",
        file: "assets/ground_plane.ron",
        config: include_str!("../assets/ground_plane.ron"),
    }
}
