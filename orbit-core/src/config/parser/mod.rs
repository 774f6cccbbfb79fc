//! A hand-written parser for the RON subset used by configs. Unlike `ron::Value` it keeps
//! struct and variant names, and it records a [`Span`] for every value.
//!
//! Grammar: structs `Name(a: 1)` / `(a: 1)`, tuples `Name(1, 2)` / `(1, 2)` / `()`, bare
//! identifiers, lists `[..]`, maps `{k: v}`, strings (escapes and raw `r#"..."#`), chars,
//! integers (`0x`/`0o`/`0b`, `_` separators), floats, `true`/`false`; `//` and nested `/* */`
//! comments; trailing commas. A document may start with `#include "path"` lines and
//! `#![enable(..)]` headers (the latter are skipped).
//!
//! The parser is one cursor type, `Parser`, whose methods are spread over
//! the submodules: `cursor` (position tracking, whitespace and comments, syntax errors),
//! `document` (`#include` lines, headers, end of input), `value` (lists, maps, structs,
//! tuples, identifiers) and `literal` (strings, chars, numbers).

use std::path::PathBuf;
use std::sync::Arc;

use super::error::ConfigError;
use super::node::{Node, Span};

mod cursor;
mod document;
mod literal;
mod value;

use cursor::Parser;

/// Deepest nesting of brackets accepted; deeper input is an error rather than a stack overflow.
pub(crate) const MAX_DEPTH: usize = 128;

/// A parsed file: its `#include` lines and its own value (absent in an include-only file).
pub(crate) struct Document {
    pub file: Arc<PathBuf>,
    pub includes: Vec<Include>,
    pub value: Option<Node>,
}

/// One `#include "path"` line.
pub(crate) struct Include {
    /// The path as written.
    pub path: String,
    /// Where the `#include` starts.
    pub span: Span,
}

/// Checks that `bytes` are UTF-8, reporting the position of the first bad byte.
pub(crate) fn decode<'a>(bytes: &'a [u8], file: &Arc<PathBuf>) -> Result<&'a str, ConfigError> {
    std::str::from_utf8(bytes).map_err(|e| {
        let good = std::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default();
        let mut cursor = Parser::new(good, file.clone());
        while cursor.bump().is_some() {}
        let byte = bytes.get(e.valid_up_to()).copied().unwrap_or_default();
        let message = format!("invalid UTF-8 (byte 0x{byte:02x}); config files must be UTF-8");
        cursor.error(message).into_config(file)
    })
}

/// Parses a whole file: leading `#include` lines and headers, then at most one value.
pub(crate) fn parse_document(text: &str, file: Arc<PathBuf>) -> Result<Document, ConfigError> {
    let mut p = Parser::new(text, file.clone());
    p.document().map_err(|e| e.into_config(&file))
}

/// Parses text holding exactly one value (a command-line override's right-hand side).
pub(crate) fn parse_value(text: &str, file: Arc<PathBuf>) -> Result<Node, ConfigError> {
    let mut p = Parser::new(text, file.clone());
    let value = p.value().and_then(|v| p.end().map(|()| v));
    value.map_err(|e| e.into_config(&file))
}

/// Parses the string literal at the start of `text`, returning its value and its length in
/// bytes.
pub(crate) fn string_prefix(text: &str) -> Result<(String, usize), String> {
    let mut p = Parser::new(text, Arc::new(PathBuf::new()));
    match p.string() {
        Ok(s) => Ok((s, p.pos)),
        Err(e) => Err(e.message),
    }
}
