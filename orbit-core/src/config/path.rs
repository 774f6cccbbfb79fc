//! Field paths into a document — `scene.articulations[0].actuators.arm`, `init_pos["a.*"]` —
//! shared by overrides, [`node_at`](super::node_at) and error messages.
//!
//! `Some(x)` is transparent: a path step applied to `Some(x)` applies to `x`.

use super::node::{Node, NodeKind, is_ident, is_ident_continue, is_ident_start, write_quoted};
use super::parser::{self, MAX_DEPTH};

/// One step of a path.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Segment {
    /// `.name`: a struct field, or a map entry whose key text is `name`.
    Field(String),
    /// `[i]`: a list or tuple item (or a map entry whose key text is `i`).
    Index(usize),
    /// `["key"]`: a map entry (or a struct field).
    Key(String),
}

/// Formats segments as a path (`a.b[0]["x y"]`); the root is the empty string.
pub(crate) fn format_path(segments: &[Segment]) -> String {
    let mut out = String::new();
    for segment in segments {
        match segment {
            Segment::Field(name) | Segment::Key(name) if is_ident(name) => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(name);
            }
            Segment::Field(key) | Segment::Key(key) => {
                out.push('[');
                write_quoted(&mut out, key, '"');
                out.push(']');
            }
            Segment::Index(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

/// Parses a path at the start of `text`; returns the segments and the unparsed rest.
pub(crate) fn parse_path(text: &str) -> Result<(Vec<Segment>, &str), String> {
    let column = |rest: &str| text.len() - rest.len() + 1;
    let found = |rest: &str| match rest.chars().next() {
        None => "end of input".to_string(),
        Some(c) => format!("`{}`", c.escape_debug()),
    };
    let mut segments = Vec::new();
    let mut rest = text.trim_start();
    loop {
        if segments.len() > MAX_DEPTH {
            return Err(format!("path is longer than {MAX_DEPTH} steps"));
        }
        if let Some(inner) = rest.strip_prefix('[') {
            let inner = inner.trim_start();
            let after = if inner.starts_with('"') {
                let (key, len) = parser::string_prefix(inner)?;
                segments.push(Segment::Key(key));
                &inner[len..]
            } else {
                let len =
                    inner.len() - inner.trim_start_matches(|c: char| c.is_ascii_digit()).len();
                if len == 0 {
                    return Err(format!(
                        "expected an index or a quoted key after `[` at column {}, found {}",
                        column(inner),
                        found(inner)
                    ));
                }
                let index = inner[..len]
                    .parse()
                    .map_err(|_| format!("index `{}` is too large", &inner[..len]))?;
                segments.push(Segment::Index(index));
                &inner[len..]
            };
            let after = after.trim_start();
            rest = after.strip_prefix(']').ok_or_else(|| {
                format!(
                    "expected `]` at column {}, found {}",
                    column(after),
                    found(after)
                )
            })?;
        } else if segments.is_empty() || rest.starts_with('.') {
            let name_start = if segments.is_empty() {
                rest
            } else {
                &rest[1..]
            };
            let name = ident_prefix(name_start);
            if name.is_empty() {
                let place = if segments.is_empty() {
                    "at the start of the path"
                } else {
                    "after `.`"
                };
                return Err(format!(
                    "expected a field name {place} (column {}), found {}",
                    column(name_start),
                    found(name_start)
                ));
            }
            segments.push(Segment::Field(name.to_string()));
            rest = &name_start[name.len()..];
        } else {
            return Ok((segments, rest));
        }
    }
}

/// The identifier at the start of `text` (possibly empty).
fn ident_prefix(text: &str) -> &str {
    if !text.starts_with(is_ident_start) {
        return "";
    }
    let end = text.find(|c| !is_ident_continue(c)).unwrap_or(text.len());
    &text[..end]
}

/// The node at `path` below `root`, if the path is well formed and exists.
pub(crate) fn lookup<'a>(root: &'a Node, path: &str) -> Option<&'a Node> {
    let (segments, rest) = parse_path(path).ok()?;
    if !rest.trim().is_empty() {
        return None;
    }
    segments
        .iter()
        .try_fold(root, |node, segment| node.child(segment))
}

impl Node {
    /// `x` for `Some(x)`, else `self`.
    pub(crate) fn strip_some_mut(&mut self) -> &mut Node {
        if self.as_some().is_none() {
            return self;
        }
        match &mut self.kind {
            NodeKind::Tuple { items, .. } => &mut items[0],
            _ => unreachable!("`as_some` only matches a one-item tuple"),
        }
    }

    /// The child selected by `segment`.
    pub(crate) fn child(&self, segment: &Segment) -> Option<&Node> {
        let node = self.as_some().unwrap_or(self);
        let slot = node.slot(segment)?;
        match &node.kind {
            NodeKind::Struct { fields, .. } => fields.get(slot).map(|(_, v)| v),
            NodeKind::Tuple { items, .. } | NodeKind::List(items) => items.get(slot),
            NodeKind::Map(entries) => entries.get(slot).map(|(_, v)| v),
            _ => None,
        }
    }

    /// The child selected by `segment`, mutably (without the `Some` transparency; callers
    /// apply [`Node::strip_some_mut`] first).
    pub(crate) fn child_mut(&mut self, segment: &Segment) -> Option<&mut Node> {
        let slot = self.slot(segment)?;
        match &mut self.kind {
            NodeKind::Struct { fields, .. } => fields.get_mut(slot).map(|(_, v)| v),
            NodeKind::Tuple { items, .. } | NodeKind::List(items) => items.get_mut(slot),
            NodeKind::Map(entries) => entries.get_mut(slot).map(|(_, v)| v),
            _ => None,
        }
    }

    /// Position of the child selected by `segment` among this node's fields, items or entries.
    pub(crate) fn slot(&self, segment: &Segment) -> Option<usize> {
        match (&self.kind, segment) {
            (NodeKind::Struct { fields, .. }, Segment::Field(name) | Segment::Key(name)) => {
                fields.iter().position(|(field, _)| field == name)
            }
            (NodeKind::Tuple { items, .. } | NodeKind::List(items), Segment::Index(i)) => {
                (*i < items.len()).then_some(*i)
            }
            (NodeKind::Map(entries), segment) => {
                let wanted = match segment {
                    Segment::Field(key) | Segment::Key(key) => key.clone(),
                    Segment::Index(i) => i.to_string(),
                };
                entries.iter().position(|(key, _)| key.key_text() == wanted)
            }
            _ => None,
        }
    }
}
