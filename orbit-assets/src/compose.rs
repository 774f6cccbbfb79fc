//! Scenes composed from asset configs by name.
//!
//! In a scene document, `articulations`, `rigid_objects` and `static_objects` may be maps from
//! entity name to entry, as Isaac Lab's scene configs name their assets:
//!
//! ```text
//! articulations: {"robot": (asset: "franka_panda_rod", init_state: (joint_pos: {…}))},
//! static_objects: {"table": (asset: "lab_table")},
//! ```
//!
//! Each entry with `asset` starts from that registered config ([`crate::asset_cfg`]) and is
//! deep-merged over it, so it restates only what it changes; an entry without `asset` is a
//! whole config. The map becomes the list `SceneCfg` reads, in map order, with the key as each
//! entity's `name`. Lists are left as they are.

use std::path::PathBuf;

use orbit_core::config::{Bundled, ConfigError, Node, NodeKind, Span};

use crate::asset_cfg::{AssetKind, asset_cfg, asset_cfgs};

/// Composes the scene document `scene` in place (see the module docs); `path` is its field
/// path in errors (`scene` in an env config, empty for a scene file).
pub fn compose_scene(scene: &mut Node, path: &str) -> Result<(), ConfigError> {
    let NodeKind::Struct { fields, .. } = &mut scene.kind else {
        return Ok(());
    };
    for kind in AssetKind::ALL {
        let field = kind.scene_field();
        let Some((_, list)) = fields.iter_mut().find(|(f, _)| f == field) else {
            continue;
        };
        let NodeKind::Map(entries) = &mut list.kind else {
            continue;
        };
        let mut items = Vec::with_capacity(entries.len());
        for (key, entry) in std::mem::take(entries) {
            let name = key.key_text();
            let entry_path = format!("{}{field}[{name:?}]", prefix(path));
            items.push(compose_entry(kind, &name, &key.span, entry, &entry_path)?);
        }
        list.kind = NodeKind::List(items);
    }
    Ok(())
}

/// An env config document with its `scene` field composed (see [`compose_scene`]) and its
/// model files' paths anchored to the files that name them
/// ([`anchor_asset_paths`](crate::anchor_asset_paths)).
pub fn compose_env_scene(document: &Node) -> Result<Node, ConfigError> {
    let mut document = document.clone();
    if let NodeKind::Struct { fields, .. } = &mut document.kind
        && let Some((_, scene)) = fields.iter_mut().find(|(f, _)| f == "scene")
    {
        compose_scene(scene, "scene")?;
        crate::anchor_asset_paths(scene);
    }
    Ok(document)
}

/// One map entry as a list item: the registered config it names with the entry laid over it,
/// and the key as `name`.
fn compose_entry(
    kind: AssetKind,
    name: &str,
    key_span: &Span,
    mut entry: Node,
    path: &str,
) -> Result<Node, ConfigError> {
    let NodeKind::Struct { fields, .. } = &mut entry.kind else {
        return Err(invalid(
            &entry.span,
            path,
            "expected an entry `(asset: \"<name>\", …)` or a whole config in parentheses",
        ));
    };
    if let Some((_, given)) = fields.iter().find(|(f, _)| f == "name") {
        return Err(invalid(
            &given.span,
            &format!("{path}.name"),
            &format!("the map key names the entity (`{name}`): remove `name`"),
        ));
    }
    let asset = fields
        .iter()
        .position(|(f, _)| f == "asset")
        .map(|i| fields.remove(i).1);
    let mut composed = match asset {
        None => entry,
        Some(asset) => {
            let asset_path = format!("{path}.asset");
            let NodeKind::Str(asset_name) = &asset.kind else {
                return Err(invalid(
                    &asset.span,
                    &asset_path,
                    "expected the name of an asset config as a string",
                ));
            };
            let def = asset_cfg(asset_name)
                .filter(|d| d.kind == kind)
                .ok_or_else(|| {
                    invalid(
                        &asset.span,
                        &asset_path,
                        &format!(
                            "no {} config named `{asset_name}`; registered: {:?}",
                            kind.scene_field().trim_end_matches('s').replace('_', " "),
                            asset_cfgs()
                                .iter()
                                .filter(|d| d.kind == kind)
                                .map(|d| d.name)
                                .collect::<Vec<_>>()
                        ),
                    )
                })?;
            let file = Bundled::full_path(def.file);
            let mut base =
                orbit_core::config::parse_document(def.config, &file.display().to_string(), &[])?;
            orbit_core::config::merge(&mut base, entry);
            base
        }
    };
    if let NodeKind::Struct { fields, .. } = &mut composed.kind {
        let name_node = Node {
            kind: NodeKind::Str(name.to_string()),
            span: key_span.clone(),
        };
        fields.insert(0, ("name".to_string(), name_node));
    }
    Ok(composed)
}

fn prefix(path: &str) -> String {
    if path.is_empty() {
        String::new()
    } else {
        format!("{path}.")
    }
}

fn invalid(span: &Span, path: &str, message: &str) -> ConfigError {
    ConfigError::Invalid {
        file: PathBuf::from(span.file.as_ref()),
        line: span.line,
        col: span.col,
        path: path.to_string(),
        message: message.to_string(),
    }
}
