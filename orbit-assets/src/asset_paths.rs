//! Where a config's model files come from, decided once when the config is loaded: a bare name
//! of a bundled asset (`cartpole.urdf`) is the bundled file, whatever lies in the working
//! directory; any other relative path, and any path written explicitly (`./robot.urdf`,
//! `../x.xml`), is relative to the config file that names it (the working directory for a
//! command-line override) and becomes absolute, so that a run's `params/env.ron` names the same
//! file from wherever it is read. [`asset_record`] lists what a config loads, with a hash of
//! each file's bytes, for a run's `params/`.

use std::path::{Path, PathBuf};

use orbit_core::config::{Node, NodeKind, is_bundled};
use sha2::{Digest, Sha256};

use crate::bundled::{Found, bundled, find_file};

/// The enum variants of `AssetSource` that name a file.
const FILE_SOURCES: &[&str] = &["Urdf", "Mjcf"];

/// Whether `path` is written as a file path rather than an asset name: absolute, or starting
/// with `./` or `../`.
pub fn is_explicit_path(path: &str) -> bool {
    let p = Path::new(path);
    p.is_absolute() || path.starts_with("./") || path.starts_with("../")
}

/// Rewrites every `Urdf(path: …)` and `Mjcf(path: …)` below `doc` that is not a bundled name to
/// the absolute path of the file it names, relative to the file whose text wrote it (see the
/// module docs). Bundled configs name bundled assets and are left as written.
pub fn anchor_asset_paths(doc: &mut Node) {
    visit_sources(doc, &mut |path_node| {
        let NodeKind::Str(path) = &path_node.kind else {
            return;
        };
        if Path::new(path).is_absolute() || (!is_explicit_path(path) && bundled(path).is_some()) {
            return;
        }
        let written_in = path_node.span.file.as_path();
        if is_bundled(written_in) {
            return;
        }
        let base = if written_in.is_file() {
            written_in.parent().unwrap_or(Path::new("")).to_path_buf()
        } else {
            // A command-line override: relative to the working directory.
            PathBuf::new()
        };
        if let Ok(absolute) = std::path::absolute(base.join(path)) {
            path_node.kind = NodeKind::Str(absolute.display().to_string());
        }
    });
}

/// The model files a config document loads, as RON: for each, the path as written, where it
/// was loaded from (`<bundled>/name` or the file's path) and the SHA-256 of its bytes (`None`
/// where the file cannot be read).
pub fn asset_record(doc: &Node) -> String {
    let mut seen: Vec<String> = Vec::new();
    visit_sources(&mut doc.clone(), &mut |path_node| {
        if let NodeKind::Str(path) = &path_node.kind
            && !seen.contains(path)
        {
            seen.push(path.clone());
        }
    });
    let mut out = String::from("[\n");
    for path in seen {
        let (loaded, bytes) = match find_file(&path, None) {
            Ok(Found::Bundled(text)) => {
                (format!("<bundled>/{path}"), Some(text.as_bytes().to_vec()))
            }
            Ok(Found::File(file)) => (file.display().to_string(), std::fs::read(&file).ok()),
            Err(_) => (path.clone(), None),
        };
        let hash = bytes.map_or("None".to_string(), |b| {
            let digest = Sha256::digest(&b);
            let hex: String = digest.iter().map(|x| format!("{x:02x}")).collect();
            format!("Some(\"{hex}\")")
        });
        out.push_str(&format!(
            "    (path: {path:?}, loaded: {loaded:?}, sha256: {hash}),\n"
        ));
    }
    out.push_str("]\n");
    out
}

/// Calls `f` on the `path` node of every file-naming asset source below `node`.
fn visit_sources(node: &mut Node, f: &mut dyn FnMut(&mut Node)) {
    match &mut node.kind {
        NodeKind::Struct { name, fields } => {
            let names_file = name.as_deref().is_some_and(|n| FILE_SOURCES.contains(&n));
            for (field, value) in fields {
                if names_file && field == "path" {
                    f(value);
                } else {
                    visit_sources(value, f);
                }
            }
        }
        NodeKind::Tuple { items, .. } | NodeKind::List(items) => {
            for item in items {
                visit_sources(item, f);
            }
        }
        NodeKind::Map(entries) => {
            for (_, value) in entries {
                visit_sources(value, f);
            }
        }
        _ => {}
    }
}
