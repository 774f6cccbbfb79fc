//! Deep merge of documents: how an including file's value is laid over its includes.
//!
//! Struct + struct merges field-wise (the later name wins if present; if both are named and the
//! names differ — another enum variant — the later value replaces the earlier wholesale).
//! Map + map merges key-wise, keys compared by [`Node::key_text`]. Anything else: the later
//! value replaces the earlier. Merged nodes take the later node's span.

use super::node::{Node, NodeKind};

/// Merges `top` into `base`.
pub(crate) fn merge_into(base: &mut Node, top: Node) {
    match (&mut base.kind, top.kind) {
        (
            NodeKind::Struct { name, fields },
            NodeKind::Struct {
                name: top_name,
                fields: top_fields,
            },
        ) if name.is_none() || top_name.is_none() || *name == top_name => {
            if top_name.is_some() {
                *name = top_name;
            }
            for (field, value) in top_fields {
                match fields.iter_mut().find(|(f, _)| *f == field) {
                    Some((_, old)) => merge_into(old, value),
                    None => fields.push((field, value)),
                }
            }
            base.span = top.span;
        }
        (NodeKind::Map(entries), NodeKind::Map(top_entries)) => {
            for (key, value) in top_entries {
                let text = key.key_text();
                match entries.iter_mut().find(|(k, _)| k.key_text() == text) {
                    Some((_, old)) => merge_into(old, value),
                    None => entries.push((key, value)),
                }
            }
            base.span = top.span;
        }
        (_, kind) => {
            *base = Node {
                kind,
                span: top.span,
            }
        }
    }
}
