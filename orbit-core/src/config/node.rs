//! The configuration AST: [`Node`], [`NodeKind`] and [`Span`], and printing a tree back to RON.

use std::fmt::{self, Write as _};
use std::path::PathBuf;
use std::sync::Arc;

/// Where a node starts: the file, and a 1-based line and column (columns count characters).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Span {
    /// The file the node was read from (``override `path=value` `` for command-line overrides).
    pub file: Arc<PathBuf>,
    /// 1-based line.
    pub line: u32,
    /// 1-based column, in characters.
    pub col: u32,
}

impl fmt::Display for Span {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.col)
    }
}

impl Span {
    /// Where the value was written, for an error: `file:line:col`, or the override as the
    /// user typed it (one line, so its text says more than a position).
    pub fn location(&self) -> String {
        super::error::location(&self.file, self.line, self.col)
    }
}

/// A RON value together with the place it was written.
///
/// Equality compares the values only and ignores spans.
#[derive(Clone, Debug)]
pub struct Node {
    /// The value.
    pub kind: NodeKind,
    /// Where the value starts.
    pub span: Span,
}

impl PartialEq for Node {
    fn eq(&self, other: &Self) -> bool {
        self.kind == other.kind
    }
}

/// The shape of a [`Node`].
#[derive(Clone, Debug, PartialEq)]
pub enum NodeKind {
    /// Named fields: `Name(a: 1, b: 2)` or `(a: 1)`.
    Struct {
        /// The struct or enum-variant name, if written.
        name: Option<String>,
        /// Fields in source order (names are unique).
        fields: Vec<(String, Node)>,
    },
    /// Positional items: `Name(1, 2)`, `(1, 2)`, `Some(x)`, `()`.
    Tuple {
        /// The tuple-struct or enum-variant name, if written.
        name: Option<String>,
        /// Items in source order.
        items: Vec<Node>,
    },
    /// A bare identifier other than `true`/`false`: `None`, or a unit enum variant.
    Unit(String),
    /// `[a, b, c]`.
    List(Vec<Node>),
    /// `{key: value}`; keys are unique (string and identifier keys compare by their text).
    Map(Vec<(Node, Node)>),
    /// A string.
    Str(String),
    /// A character literal `'c'`.
    Char(char),
    /// An integer literal.
    Int(i128),
    /// A floating-point literal (always finite).
    Float(f64),
    /// `true` or `false`.
    Bool(bool),
}

/// Whether `c` may start an identifier.
pub(crate) fn is_ident_start(c: char) -> bool {
    c.is_ascii_alphabetic() || c == '_'
}

/// Whether `c` may continue an identifier.
pub(crate) fn is_ident_continue(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Whether `s` is a RON identifier (and so can be written as a field name).
pub(crate) fn is_ident(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(is_ident_start) && chars.all(is_ident_continue)
}

/// Appends `s` as a quoted, escaped literal (`quote` is `"` or `'`).
pub(crate) fn write_quoted(out: &mut String, s: &str, quote: char) {
    out.push(quote);
    for c in s.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            '\r' => out.push_str("\\r"),
            c if c == quote => {
                out.push('\\');
                out.push(c);
            }
            c if c.is_control() => {
                let _ = write!(out, "\\u{{{:x}}}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push(quote);
}

const INDENT: &str = "    ";

impl Node {
    /// Pretty-prints the tree as RON that parses back to an equal tree (spans aside). Used to
    /// save resolved configs; `#include`s are already merged in. The one shape the parser never
    /// produces, an empty anonymous struct, prints as `()` and reads back as an empty tuple,
    /// which deserialises the same way.
    pub fn to_ron(&self) -> String {
        let mut out = String::new();
        self.write_ron(&mut out, 0);
        out.push('\n');
        out
    }

    /// The text that identifies a map key: strings and identifiers by their contents, other
    /// values by their RON form. Keys are compared (in merges, overrides, duplicate checks) by it.
    pub fn key_text(&self) -> String {
        match &self.kind {
            NodeKind::Str(s) | NodeKind::Unit(s) => s.clone(),
            _ => self.to_ron().trim_end().to_string(),
        }
    }

    /// A short description of the value, as used in error messages (`string "abc"`, `list`).
    pub(crate) fn describe(&self) -> String {
        match &self.kind {
            NodeKind::Struct { name: Some(n), .. } => format!("struct `{n}`"),
            NodeKind::Struct { name: None, .. } => "struct".into(),
            NodeKind::Tuple { name: Some(n), .. } => format!("`{n}(..)`"),
            NodeKind::Tuple { name: None, items } if items.is_empty() => "unit `()`".into(),
            NodeKind::Tuple { name: None, .. } => "tuple".into(),
            NodeKind::Unit(n) if n == "None" => "`None`".into(),
            NodeKind::Unit(n) => format!("identifier `{n}`"),
            NodeKind::List(_) => "list".into(),
            NodeKind::Map(_) => "map".into(),
            NodeKind::Str(s) => format!("string {s:?}"),
            NodeKind::Char(c) => format!("character `{c}`"),
            NodeKind::Int(i) => format!("integer `{i}`"),
            NodeKind::Float(f) => format!("floating point `{f:?}`"),
            NodeKind::Bool(b) => format!("boolean `{b}`"),
        }
    }

    /// The `x` of `Some(x)`.
    pub(crate) fn as_some(&self) -> Option<&Node> {
        match &self.kind {
            NodeKind::Tuple {
                name: Some(name),
                items,
            } if name == "Some" => match items.as_slice() {
                [inner] => Some(inner),
                _ => None,
            },
            _ => None,
        }
    }

    fn is_scalar(&self) -> bool {
        !matches!(
            self.kind,
            NodeKind::Struct { .. } | NodeKind::Tuple { .. } | NodeKind::List(_) | NodeKind::Map(_)
        )
    }

    fn write_ron(&self, out: &mut String, indent: usize) {
        match &self.kind {
            NodeKind::Struct { name, fields } => {
                out.push_str(name.as_deref().unwrap_or(""));
                out.push('(');
                if !fields.is_empty() {
                    out.push('\n');
                    for (field, value) in fields {
                        push_indent(out, indent + 1);
                        out.push_str(field);
                        out.push_str(": ");
                        value.write_ron(out, indent + 1);
                        out.push_str(",\n");
                    }
                    push_indent(out, indent);
                }
                out.push(')');
            }
            NodeKind::Tuple { name, items } => {
                out.push_str(name.as_deref().unwrap_or(""));
                write_items(out, ('(', ')'), items, indent);
            }
            NodeKind::List(items) => write_items(out, ('[', ']'), items, indent),
            NodeKind::Map(entries) => {
                out.push('{');
                if !entries.is_empty() {
                    out.push('\n');
                    for (key, value) in entries {
                        push_indent(out, indent + 1);
                        key.write_ron(out, indent + 1);
                        out.push_str(": ");
                        value.write_ron(out, indent + 1);
                        out.push_str(",\n");
                    }
                    push_indent(out, indent);
                }
                out.push('}');
            }
            NodeKind::Str(s) => write_quoted(out, s, '"'),
            NodeKind::Char(c) => write_quoted(out, c.encode_utf8(&mut [0; 4]), '\''),
            NodeKind::Int(i) => {
                let _ = write!(out, "{i}");
            }
            // `{:?}` keeps a `.0` or an exponent, so the value reads back as a float, exactly.
            NodeKind::Float(f) => {
                let _ = write!(out, "{f:?}");
            }
            NodeKind::Bool(b) => {
                let _ = write!(out, "{b}");
            }
            NodeKind::Unit(name) => out.push_str(name),
        }
    }
}

fn push_indent(out: &mut String, level: usize) {
    for _ in 0..level {
        out.push_str(INDENT);
    }
}

/// Writes `items` between `open` and `close`: on one line when all are scalars, else one per line.
fn write_items(out: &mut String, (open, close): (char, char), items: &[Node], indent: usize) {
    out.push(open);
    if items.iter().all(Node::is_scalar) {
        for (i, item) in items.iter().enumerate() {
            if i > 0 {
                out.push_str(", ");
            }
            item.write_ron(out, indent);
        }
    } else {
        out.push('\n');
        for item in items {
            push_indent(out, indent + 1);
            item.write_ron(out, indent + 1);
            out.push_str(",\n");
        }
        push_indent(out, indent);
    }
    out.push(close);
}
