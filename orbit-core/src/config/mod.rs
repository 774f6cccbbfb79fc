//! RON config loading with includes, command-line overrides, and errors that always say where.
//!
//! ```text
//! #include "base.ron"                // merged first; paths are relative to this file
//! Experiment(
//!     sim: (dt: 0.005),              // deep-merged over base.ron's `sim`
//!     gains: {"panda_joint.*": 400.0},
//! )
//! ```
//!
//! Loading goes: parse each file ([`Node`] tree with a [`Span`] on every value), resolve
//! `#include` lines (deep merge, see below), apply overrides such as `sim.dt=0.001` or
//! `scene.articulations[0].init_state.pos=(0.0, 0.0, 0.1)`, then deserialise with serde.
//!
//! * Deep merge: struct + struct merges field-wise (if both carry different names — another
//!   enum variant — the later replaces the earlier); map + map merges key-wise; anything else,
//!   the later value wins. Spans follow the winning value, so errors point into the file that
//!   supplied it.
//! * Overrides: `path=value` with `.field`, `[index]`, `["key"]` steps and a RON value (its
//!   span's file is ``override `path=value` ``, so errors name the override as written). Missing struct fields and map entries
//!   are created; indexing past a list's end or stepping into a scalar is an error.
//! * Deserialisation: structs ignore names, enums are externally tagged (`Unit`, `Newtype(x)`,
//!   `Tuple(1, 2)`, `Struct(a: 1)`), options accept `None`, `Some(x)` or a bare `x`, integers
//!   read as floats but not the reverse, and `deserialize_any` sees the natural kind, so
//!   untagged enums work.
//!
//! Every failure is a [`ConfigError`] whose `Display` starts with `file:line:col` (or names the
//! override), then the field path and what was expected.

#[cfg(test)]
mod bundled_tests;
mod de;
mod error;
mod include;
mod merge;
mod node;
mod overrides;
mod parser;
mod path;
#[cfg(test)]
mod tests;

use std::path::Path;

use serde::de::DeserializeOwned;

pub use error::ConfigError;
pub use include::{BUNDLED_ROOT, Bundled, is_bundled};
pub use node::{Node, NodeKind, Span};

/// Loads a `T` from the RON file at `path`, following its includes and applying `overrides`
/// (`a.b.c=value`) in order.
pub fn load<T: DeserializeOwned>(
    path: impl AsRef<Path>,
    overrides: &[String],
) -> Result<T, ConfigError> {
    let document = load_document(path, overrides)?;
    from_node(&document)
}

/// Loads a `T` from RON `text`, called `file_name` in errors; `#include` paths in it are
/// relative to the current directory.
pub fn from_str<T: DeserializeOwned>(
    text: &str,
    file_name: &str,
    overrides: &[String],
) -> Result<T, ConfigError> {
    let mut document = include::load_text(text, file_name)?;
    overrides::apply(&mut document, overrides)?;
    from_node(&document)
}

/// Loads the RON file at `path` as a merged document tree, with includes resolved and
/// `overrides` applied (for saving with [`Node::to_ron`] or inspecting with [`node_at`]).
pub fn load_document(path: impl AsRef<Path>, overrides: &[String]) -> Result<Node, ConfigError> {
    load_document_with(&Bundled::default(), path, overrides)
}

/// [`load_document`] where `path` and the files it includes may also be `bundled` ones: a
/// path starting with [`BUNDLED_ROOT`] names a bundled file, and a bundled file's includes
/// are relative to it, resolved in memory. A file on disk may include a bundled file by its
/// full name (`#include "<bundled>/reach/env/reach.ron"`).
pub fn load_document_with(
    bundled: &Bundled,
    path: impl AsRef<Path>,
    overrides: &[String],
) -> Result<Node, ConfigError> {
    let mut document = include::load_file(bundled, path.as_ref())?;
    overrides::apply(&mut document, overrides)?;
    Ok(document)
}

/// The file at `path` followed by every file it includes, directly or not, each once (what
/// must be copied for the file to load elsewhere); paths as the loader names them.
pub fn dependencies(
    bundled: &Bundled,
    path: impl AsRef<Path>,
) -> Result<Vec<std::path::PathBuf>, ConfigError> {
    include::dependencies(bundled, path.as_ref())
}

/// Parses RON `text` (called `file_name` in errors) into a merged document tree, with includes
/// resolved relative to the current directory and `overrides` applied.
pub fn parse_document(
    text: &str,
    file_name: &str,
    overrides: &[String],
) -> Result<Node, ConfigError> {
    let mut document = include::load_text(text, file_name)?;
    overrides::apply(&mut document, overrides)?;
    Ok(document)
}

/// Deserialises a `T` from a document tree. Errors about values set by overrides name the
/// override as written (``override `sim.dt="fast"`: sim.dt: invalid type: …``).
pub fn from_node<T: DeserializeOwned>(node: &Node) -> Result<T, ConfigError> {
    de::from_node(node)
}

/// Lays `top` over `base` with the deep merge of `#include` (structs field-wise, maps
/// key-wise, anything else replaced).
pub fn merge(base: &mut Node, top: Node) {
    merge::merge_into(base, top)
}

/// Applies command-line style overrides (`a.b[0]["k"]=value`) to a document tree in order.
pub fn apply_overrides(document: &mut Node, overrides: &[String]) -> Result<(), ConfigError> {
    overrides::apply(document, overrides)
}

/// The node at a field path such as `sim.backend`, `scene.articulations[0]` or
/// `init_pos["panda_joint.*"]`; `None` if the path is malformed or leads nowhere.
pub fn node_at<'a>(node: &'a Node, path: &str) -> Option<&'a Node> {
    path::lookup(node, path)
}
