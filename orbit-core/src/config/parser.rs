//! A hand-written parser for the RON subset used by configs. Unlike `ron::Value` it keeps
//! struct and variant names, and it records a [`Span`] for every value.
//!
//! Grammar: structs `Name(a: 1)` / `(a: 1)`, tuples `Name(1, 2)` / `(1, 2)` / `()`, bare
//! identifiers, lists `[..]`, maps `{k: v}`, strings (escapes and raw `r#"..."#`), chars,
//! integers (`0x`/`0o`/`0b`, `_` separators), floats, `true`/`false`; `//` and nested `/* */`
//! comments; trailing commas. A document may start with `#include "path"` lines and
//! `#![enable(..)]` headers (the latter are skipped).

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use super::error::ConfigError;
use super::node::{Node, NodeKind, Span, is_ident_continue, is_ident_start};

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

/// A syntax error before its file name is attached.
struct SyntaxError {
    line: u32,
    col: u32,
    message: String,
}

impl SyntaxError {
    fn into_config(self, file: &Arc<PathBuf>) -> ConfigError {
        ConfigError::Parse {
            file: file.to_path_buf(),
            line: self.line,
            col: self.col,
            message: self.message,
        }
    }
}

type PResult<T> = Result<T, SyntaxError>;

/// A position in the text: (line, column).
type Pos = (u32, u32);

#[derive(Clone)]
struct Parser<'a> {
    src: &'a str,
    pos: usize,
    line: u32,
    col: u32,
    file: Arc<PathBuf>,
    depth: usize,
}

impl<'a> Parser<'a> {
    fn new(src: &'a str, file: Arc<PathBuf>) -> Self {
        let bom = if src.starts_with('\u{feff}') { 3 } else { 0 };
        Parser {
            src,
            pos: bom,
            line: 1,
            col: 1,
            file,
            depth: 0,
        }
    }

    // ---- cursor ----

    fn rest(&self) -> &'a str {
        &self.src[self.pos..]
    }

    fn peek(&self) -> Option<char> {
        self.rest().chars().next()
    }

    fn peek_nth(&self, n: usize) -> Option<char> {
        self.rest().chars().nth(n)
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek()?;
        self.pos += c.len_utf8();
        if c == '\n' {
            self.line += 1;
            self.col = 1;
        } else {
            self.col += 1;
        }
        Some(c)
    }

    fn eat(&mut self, c: char) -> bool {
        let hit = self.peek() == Some(c);
        if hit {
            self.bump();
        }
        hit
    }

    /// Moves past `n` bytes (which must end on a character boundary).
    fn advance(&mut self, n: usize) {
        let target = self.pos + n;
        while self.pos < target && self.bump().is_some() {}
    }

    fn here(&self) -> Pos {
        (self.line, self.col)
    }

    fn span_at(&self, (line, col): Pos) -> Span {
        Span {
            file: self.file.clone(),
            line,
            col,
        }
    }

    /// What the cursor is looking at, for "found ..." in messages.
    fn found(&self) -> String {
        match self.peek() {
            None => "end of input".into(),
            Some(c) => format!("`{}`", c.escape_debug()),
        }
    }

    fn error(&self, message: impl Into<String>) -> SyntaxError {
        self.error_at(self.here(), message)
    }

    fn error_at(&self, (line, col): Pos, message: impl Into<String>) -> SyntaxError {
        SyntaxError {
            line,
            col,
            message: message.into(),
        }
    }

    /// "expected {what}, found X", noting the unclosed bracket at `open` when input ran out.
    fn expected(&self, what: &str, (open, bracket): (Pos, char)) -> SyntaxError {
        let mut message = format!("expected {what}, found {}", self.found());
        if self.peek().is_none() {
            let (line, col) = open;
            message += &format!(" (the `{bracket}` at {line}:{col} is never closed)");
        }
        self.error(message)
    }

    /// Skips whitespace and comments.
    fn skip_ws(&mut self) -> PResult<()> {
        loop {
            match (self.peek(), self.peek_nth(1)) {
                (Some(c), _) if c.is_whitespace() => {
                    self.bump();
                }
                (Some('/'), Some('/')) => {
                    while self.peek().is_some_and(|c| c != '\n') {
                        self.bump();
                    }
                }
                (Some('/'), Some('*')) => self.block_comment()?,
                _ => return Ok(()),
            }
        }
    }

    fn block_comment(&mut self) -> PResult<()> {
        let start = self.here();
        self.advance(2);
        let mut depth = 1;
        while depth > 0 {
            match self.bump() {
                None => return Err(self.error_at(start, "unterminated block comment")),
                Some('*') if self.eat('/') => depth -= 1,
                Some('/') if self.eat('*') => depth += 1,
                Some(_) => {}
            }
        }
        Ok(())
    }

    // ---- documents ----

    fn document(&mut self) -> PResult<Document> {
        let mut includes = Vec::new();
        loop {
            self.skip_ws()?;
            if self.rest().starts_with("#include") {
                let span = self.span_at(self.here());
                self.advance("#include".len());
                self.skip_ws()?;
                if self.peek() != Some('"') {
                    let found = self.found();
                    return Err(self.error(format!(
                        "expected a quoted path after `#include`, found {found}"
                    )));
                }
                let path = self.string()?;
                includes.push(Include { path, span });
            } else if self.rest().starts_with("#![") {
                self.extension_header()?;
            } else {
                break;
            }
        }
        let value = match self.peek() {
            None => None,
            Some(_) => Some(self.value()?),
        };
        self.end()?;
        Ok(Document {
            file: self.file.clone(),
            includes,
            value,
        })
    }

    /// Skips `#![enable(...)]`.
    fn extension_header(&mut self) -> PResult<()> {
        let start = self.here();
        self.advance(2);
        let mut depth = 0;
        loop {
            match self.bump() {
                None => return Err(self.error_at(start, "unterminated `#![...]` header")),
                Some('[' | '(') => depth += 1,
                Some(')') => depth -= 1,
                Some(']') => {
                    depth -= 1;
                    if depth == 0 {
                        return Ok(());
                    }
                }
                Some(_) => {}
            }
        }
    }

    /// Requires that only whitespace and comments are left.
    fn end(&mut self) -> PResult<()> {
        self.skip_ws()?;
        if self.peek().is_none() {
            Ok(())
        } else if self.rest().starts_with("#include") {
            Err(self.error("`#include` lines must come before the value"))
        } else {
            let found = self.found();
            Err(self.error(format!(
                "expected end of input after the value, found {found}"
            )))
        }
    }

    // ---- values ----

    fn value(&mut self) -> PResult<Node> {
        self.skip_ws()?;
        let start = self.here();
        let Some(c) = self.peek() else {
            return Err(self.error("expected a value, found end of input"));
        };
        let kind = match c {
            '[' => self.nested(Self::list)?,
            '{' => self.nested(Self::map)?,
            '(' => self.nested(|p| p.parens(None))?,
            '"' => NodeKind::Str(self.string()?),
            '\'' => NodeKind::Char(self.char_literal()?),
            'r' if self.raw_string_ahead() => NodeKind::Str(self.raw_string()?),
            '0'..='9' | '+' | '-' | '.' => self.number()?,
            c if is_ident_start(c) => {
                let name = self.ident();
                match name.as_str() {
                    "true" => NodeKind::Bool(true),
                    "false" => NodeKind::Bool(false),
                    _ => {
                        self.skip_ws()?;
                        if self.peek() == Some('(') {
                            self.nested(|p| p.parens(Some(name)))?
                        } else {
                            NodeKind::Unit(name)
                        }
                    }
                }
            }
            _ => {
                let found = self.found();
                return Err(self.error(format!("expected a value, found {found}")));
            }
        };
        Ok(Node {
            kind,
            span: self.span_at(start),
        })
    }

    /// Runs `f` one bracket level deeper, refusing to go past [`MAX_DEPTH`].
    fn nested(&mut self, f: impl FnOnce(&mut Self) -> PResult<NodeKind>) -> PResult<NodeKind> {
        if self.depth >= MAX_DEPTH {
            return Err(self.error(format!(
                "nesting too deep: more than {MAX_DEPTH} levels of brackets"
            )));
        }
        self.depth += 1;
        let result = f(self);
        self.depth -= 1;
        result
    }

    fn ident(&mut self) -> String {
        let begin = self.pos;
        while self.peek().is_some_and(is_ident_continue) {
            self.bump();
        }
        self.src[begin..self.pos].to_string()
    }

    fn list(&mut self) -> PResult<NodeKind> {
        let open = (self.here(), '[');
        self.bump();
        let mut items = Vec::new();
        loop {
            self.skip_ws()?;
            if self.eat(']') {
                return Ok(NodeKind::List(items));
            }
            items.push(self.value()?);
            self.skip_ws()?;
            if !self.eat(',') && self.peek() != Some(']') {
                return Err(self.expected("`,` or `]` after list element", open));
            }
        }
    }

    fn map(&mut self) -> PResult<NodeKind> {
        let open = (self.here(), '{');
        self.bump();
        let mut entries: Vec<(Node, Node)> = Vec::new();
        let mut seen = HashMap::new();
        loop {
            self.skip_ws()?;
            if self.eat('}') {
                return Ok(NodeKind::Map(entries));
            }
            let key = self.value()?;
            self.skip_ws()?;
            if !self.eat(':') {
                return Err(self.expected("`:` after map key", open));
            }
            let value = self.value()?;
            let key_pos = (key.span.line, key.span.col);
            if let Some((line, col)) = seen.insert(key.key_text(), key_pos) {
                let key = key.key_text();
                let message = format!("duplicate map key `{key}` (first at {line}:{col})");
                return Err(self.error_at(key_pos, message));
            }
            entries.push((key, value));
            self.skip_ws()?;
            if !self.eat(',') && self.peek() != Some('}') {
                return Err(self.expected("`,` or `}` after map entry", open));
            }
        }
    }

    /// `( ... )` after an optional name: a struct if it starts with `ident:`, else a tuple.
    fn parens(&mut self, name: Option<String>) -> PResult<NodeKind> {
        let open = (self.here(), '(');
        self.bump();
        self.skip_ws()?;
        if self.field_ahead() {
            self.fields(name, open)
        } else {
            self.tuple(name, open)
        }
    }

    fn field_ahead(&self) -> bool {
        let mut look = self.clone();
        if !look.peek().is_some_and(is_ident_start) || look.raw_string_ahead() {
            return false;
        }
        look.ident();
        look.skip_ws().is_ok() && look.peek() == Some(':')
    }

    fn fields(&mut self, name: Option<String>, open: (Pos, char)) -> PResult<NodeKind> {
        let mut fields: Vec<(String, Node)> = Vec::new();
        let mut seen = HashMap::new();
        loop {
            self.skip_ws()?;
            if self.eat(')') {
                return Ok(NodeKind::Struct { name, fields });
            }
            let at = self.here();
            if !self.peek().is_some_and(is_ident_start) {
                return Err(self.expected("a field name or `)`", open));
            }
            let field = self.ident();
            self.skip_ws()?;
            if !self.eat(':') {
                return Err(self.expected(&format!("`:` after field name `{field}`"), open));
            }
            let value = self.value()?;
            if let Some((line, col)) = seen.insert(field.clone(), at) {
                let message = format!("duplicate field `{field}` (first at {line}:{col})");
                return Err(self.error_at(at, message));
            }
            self.skip_ws()?;
            if !self.eat(',') && self.peek() != Some(')') {
                return Err(self.expected(&format!("`,` or `)` after field `{field}`"), open));
            }
            fields.push((field, value));
        }
    }

    fn tuple(&mut self, name: Option<String>, open: (Pos, char)) -> PResult<NodeKind> {
        let mut items: Vec<Node> = Vec::new();
        loop {
            self.skip_ws()?;
            if self.eat(')') {
                return Ok(NodeKind::Tuple { name, items });
            }
            items.push(self.value()?);
            self.skip_ws()?;
            if !self.eat(',') && self.peek() != Some(')') {
                let mut err = self.expected("`,` or `)` after tuple element", open);
                if let [
                    Node {
                        kind: NodeKind::Unit(first),
                        ..
                    },
                ] = items.as_slice()
                {
                    err.message += &format!(" (missing `:` after field name `{first}`?)");
                }
                return Err(err);
            }
        }
    }

    // ---- literals ----

    fn string(&mut self) -> PResult<String> {
        let start = self.here();
        self.bump();
        let mut out = String::new();
        loop {
            match self.bump() {
                None => return Err(self.error_at(start, "unterminated string")),
                Some('"') => return Ok(out),
                Some('\\') => out.push(self.escape(start)?),
                Some(c) => out.push(c),
            }
        }
    }

    /// The character after a `\` (already consumed) in a string or char literal.
    fn escape(&mut self, literal_start: Pos) -> PResult<char> {
        let at = self.here();
        match self.bump() {
            None => Err(self.error_at(literal_start, "unterminated string")),
            Some('n') => Ok('\n'),
            Some('t') => Ok('\t'),
            Some('r') => Ok('\r'),
            Some('0') => Ok('\0'),
            Some(c @ ('\\' | '"' | '\'')) => Ok(c),
            Some('u') => self.unicode_escape(at),
            Some(c) => Err(self.error_at(
                at,
                format!("unknown escape sequence `\\{}`", c.escape_debug()),
            )),
        }
    }

    /// `\u{1F600}` or `\u00e9`, after the `u`.
    fn unicode_escape(&mut self, at: Pos) -> PResult<char> {
        let mut hex = String::new();
        let braced = self.eat('{');
        let wanted = if braced { 6 } else { 4 };
        while hex.len() < wanted && self.peek().is_some_and(|c| c.is_ascii_hexdigit()) {
            hex.extend(self.bump());
        }
        if braced && !self.eat('}') {
            return Err(self.error("expected `}` to close the `\\u{...}` escape"));
        }
        u32::from_str_radix(&hex, 16)
            .ok()
            .filter(|_| braced || hex.len() == 4)
            .and_then(char::from_u32)
            .ok_or_else(|| self.error_at(at, format!("invalid unicode escape `\\u{hex}`")))
    }

    fn raw_string_ahead(&self) -> bool {
        let after_r = self.rest().strip_prefix('r').unwrap_or_default();
        after_r.trim_start_matches('#').starts_with('"')
    }

    /// `r"..."`, `r#"..."#`, ...
    fn raw_string(&mut self) -> PResult<String> {
        let start = self.here();
        self.bump();
        let mut hashes = 0;
        while self.eat('#') {
            hashes += 1;
        }
        self.bump();
        let closing = format!("\"{}", "#".repeat(hashes));
        let Some(len) = self.rest().find(&closing) else {
            return Err(self.error_at(start, "unterminated raw string"));
        };
        let text = self.rest()[..len].to_string();
        self.advance(len + closing.len());
        Ok(text)
    }

    fn char_literal(&mut self) -> PResult<char> {
        let start = self.here();
        self.bump();
        let c = match self.bump() {
            None => return Err(self.error_at(start, "unterminated character literal")),
            Some('\'') => return Err(self.error_at(start, "empty character literal")),
            Some('\\') => self.escape(start)?,
            Some(c) => c,
        };
        if !self.eat('\'') {
            let found = self.found();
            return Err(self.error(format!(
                "expected `'` to close the character literal, found {found}"
            )));
        }
        Ok(c)
    }

    fn number(&mut self) -> PResult<NodeKind> {
        let start = self.here();
        let begin = self.pos;
        let mut text = String::new();
        match self.peek() {
            Some('-') => {
                self.bump();
                text.push('-');
            }
            Some('+') => {
                self.bump();
            }
            _ => {}
        }
        if self.peek() == Some('0') && matches!(self.peek_nth(1), Some('x' | 'o' | 'b')) {
            return self.radix_integer(start, begin, text);
        }
        let mut digits = self.digits(&mut text, 10);
        let mut is_float = false;
        if self.eat('.') {
            is_float = true;
            text.push('.');
            digits += self.digits(&mut text, 10);
        }
        if digits == 0 {
            let found = self.found();
            return Err(self.error(format!("expected a digit, found {found}")));
        }
        if let Some(e @ ('e' | 'E')) = self.peek() {
            self.bump();
            is_float = true;
            text.push(e);
            if let Some(sign @ ('+' | '-')) = self.peek() {
                self.bump();
                text.push(sign);
            }
            if self.digits(&mut text, 10) == 0 {
                let found = self.found();
                return Err(self.error(format!("expected exponent digits, found {found}")));
            }
        }
        self.number_end()?;
        let literal = &self.src[begin..self.pos];
        if is_float {
            match text.parse::<f64>() {
                Ok(f) if f.is_finite() => Ok(NodeKind::Float(f)),
                _ => Err(self.error_at(
                    start,
                    format!("number `{literal}` is out of range for a 64-bit float"),
                )),
            }
        } else {
            text.parse::<i128>().map(NodeKind::Int).map_err(|_| {
                self.error_at(
                    start,
                    format!("integer `{literal}` does not fit in 128 bits"),
                )
            })
        }
    }

    /// `0x..`, `0o..`, `0b..` after an optional sign (already in `text`).
    fn radix_integer(&mut self, start: Pos, begin: usize, mut text: String) -> PResult<NodeKind> {
        self.bump();
        let radix = match self.bump() {
            Some('x') => 16,
            Some('o') => 8,
            _ => 2,
        };
        if self.digits(&mut text, radix) == 0 {
            let found = self.found();
            return Err(self.error(format!("expected a base-{radix} digit, found {found}")));
        }
        self.number_end()?;
        let literal = &self.src[begin..self.pos];
        i128::from_str_radix(&text, radix)
            .map(NodeKind::Int)
            .map_err(|_| {
                self.error_at(
                    start,
                    format!("integer `{literal}` does not fit in 128 bits"),
                )
            })
    }

    /// Appends digits of `radix` (skipping `_`) to `text`; returns how many there were.
    fn digits(&mut self, text: &mut String, radix: u32) -> usize {
        let mut count = 0;
        while let Some(c) = self.peek() {
            if c.is_digit(radix) {
                text.push(c);
                count += 1;
            } else if c != '_' {
                break;
            }
            self.bump();
        }
        count
    }

    /// A number must not run straight into letters or another `.`.
    fn number_end(&self) -> PResult<()> {
        match self.peek() {
            Some(c) if is_ident_continue(c) || c == '.' => {
                Err(self.error(format!("unexpected `{c}` in number")))
            }
            _ => Ok(()),
        }
    }
}
