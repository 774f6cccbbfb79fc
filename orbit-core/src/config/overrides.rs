//! Command-line overrides `path=value`, applied to the merged document.
//!
//! The path uses `.field`, `[index]` and `["key"]` steps; the value is RON. The value replaces
//! whatever was at the path. Missing struct fields and map entries along the path are created
//! (serde rejects unknown fields later, naming the override); anything else that does not
//! exist — an index past the end of a list, a step into a number — is an error.

use std::path::PathBuf;
use std::sync::Arc;

use super::error::ConfigError;
use super::node::{Node, NodeKind, Span, is_ident};
use super::parser;
use super::path::{Segment, format_path, parse_path};

/// Applies `overrides` in order.
pub(crate) fn apply(root: &mut Node, overrides: &[String]) -> Result<(), ConfigError> {
    for text in overrides {
        apply_one(root, text).map_err(|message| ConfigError::Override {
            override_text: text.clone(),
            message,
        })?;
    }
    Ok(())
}

/// The pseudo file of an override's value: the override itself, so that an error about the
/// value names the override as the user wrote it.
fn file_name(text: &str) -> PathBuf {
    PathBuf::from(format!("{OVERRIDE_FILE_PREFIX}{text}`"))
}

/// How the pseudo file of an override's value starts ([`file_name`]).
const OVERRIDE_FILE_PREFIX: &str = "override `";

/// Whether `file` is the pseudo file of an override's value (which has no lines to point at).
pub(crate) fn is_override_file(file: &std::path::Path) -> bool {
    file.to_str()
        .is_some_and(|f| f.starts_with(OVERRIDE_FILE_PREFIX) && f.ends_with('`'))
}

fn apply_one(root: &mut Node, text: &str) -> Result<(), String> {
    let (segments, rest) = parse_path(text)?;
    let rest = rest.trim_start();
    let Some(value_text) = rest.strip_prefix('=') else {
        return Err(match rest.chars().next() {
            None => "missing `=`: overrides look like `path.to.field=value`".to_string(),
            Some(c) => format!(
                "expected `=` after the path at column {}, found `{}`",
                text.len() - rest.len() + 1,
                c.escape_debug()
            ),
        });
    };
    let value =
        parser::parse_value(value_text, Arc::new(file_name(text))).map_err(|e| match e {
            ConfigError::Parse {
                line: 1,
                col,
                message,
                ..
            } => {
                let offset = (text.len() - value_text.len()) as u32;
                format!("bad value at column {}: {message}", offset + col)
            }
            other => format!("bad value: {other}"),
        })?;
    set(root, &segments, value)
}

/// Replaces (or adds) the node at `segments` with `value`.
fn set(root: &mut Node, segments: &[Segment], value: Node) -> Result<(), String> {
    let Some((last, parents)) = segments.split_last() else {
        return Err("empty path".into());
    };
    let mut node = root;
    for (depth, segment) in parents.iter().enumerate() {
        node = node.strip_some_mut();
        if node.slot(segment).is_none() {
            if let Some(Segment::Index(_)) = segments.get(depth + 1) {
                let missing = describe_path(&segments[..=depth]);
                return Err(format!("{missing} does not exist, so it cannot be indexed"));
            }
            // `a["k"]` creates `a` as a map (so it merges key-wise over an included map),
            // `a.f` as a struct.
            let kind = match segments.get(depth + 1) {
                Some(Segment::Key(_)) => NodeKind::Map(Vec::new()),
                _ => NodeKind::Struct {
                    name: None,
                    fields: Vec::new(),
                },
            };
            let empty = Node {
                kind,
                span: value.span.clone(),
            };
            insert(node, segment, empty, &segments[..depth])?;
        }
        node = node
            .child_mut(segment)
            .ok_or_else(|| format!("cannot follow {}", describe_path(&segments[..=depth])))?;
    }
    let node = node.strip_some_mut();
    match node.child_mut(last) {
        Some(slot) => *slot = value,
        None => insert(node, last, value, parents)?,
    }
    Ok(())
}

/// Adds `value` under `segment` to `node` (found at `here`), where that makes sense.
fn insert(node: &mut Node, segment: &Segment, value: Node, here: &[Segment]) -> Result<(), String> {
    let description = node.describe();
    match (&mut node.kind, segment) {
        (NodeKind::Struct { fields, .. }, Segment::Field(name) | Segment::Key(name)) => {
            if !is_ident(name) {
                return Err(format!(
                    "cannot add field {name:?} to {}: not a valid field name",
                    describe_path(here)
                ));
            }
            fields.push((name.clone(), value));
        }
        (NodeKind::Map(entries), key) => {
            let key = match key {
                Segment::Field(key) | Segment::Key(key) => NodeKind::Str(key.clone()),
                Segment::Index(i) => NodeKind::Int(*i as i128),
            };
            let span: Span = value.span.clone();
            entries.push((Node { kind: key, span }, value));
        }
        (NodeKind::Tuple { items, .. } | NodeKind::List(items), Segment::Index(i)) => {
            return Err(format!(
                "index {i} is out of range: {} has {} elements",
                describe_path(here),
                items.len()
            ));
        }
        (_, segment) => {
            let step = match segment {
                Segment::Field(name) => format!("field `{name}`"),
                Segment::Key(key) => format!("key {key:?}"),
                Segment::Index(i) => format!("index [{i}]"),
            };
            return Err(format!(
                "{} is {description}, which has no {step}",
                describe_path(here)
            ));
        }
    }
    Ok(())
}

fn describe_path(path: &[Segment]) -> String {
    if path.is_empty() {
        "the document root".into()
    } else {
        format!("`{}`", format_path(path))
    }
}
