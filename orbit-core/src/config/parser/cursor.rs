//! The parser's cursor: its position in the text (byte offset, line and column), lookahead,
//! whitespace and comments, and the syntax errors it reports.

use std::path::PathBuf;
use std::sync::Arc;

use crate::config::error::ConfigError;
use crate::config::node::Span;

/// A syntax error before its file name is attached.
pub(super) struct SyntaxError {
    line: u32,
    col: u32,
    pub(super) message: String,
}

impl SyntaxError {
    pub(super) fn into_config(self, file: &Arc<PathBuf>) -> ConfigError {
        ConfigError::Parse {
            file: file.to_path_buf(),
            line: self.line,
            col: self.col,
            message: self.message,
        }
    }
}

pub(super) type PResult<T> = Result<T, SyntaxError>;

/// A position in the text: (line, column).
pub(super) type Pos = (u32, u32);

/// The parser: a cursor over `src`. Its value, document and literal rules are implemented in
/// the sibling modules.
#[derive(Clone)]
pub(super) struct Parser<'a> {
    pub(super) src: &'a str,
    pub(super) pos: usize,
    line: u32,
    col: u32,
    pub(super) file: Arc<PathBuf>,
    pub(super) depth: usize,
}

impl<'a> Parser<'a> {
    pub(super) fn new(src: &'a str, file: Arc<PathBuf>) -> Self {
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

    pub(super) fn rest(&self) -> &'a str {
        &self.src[self.pos..]
    }

    pub(super) fn peek(&self) -> Option<char> {
        self.rest().chars().next()
    }

    pub(super) fn peek_nth(&self, n: usize) -> Option<char> {
        self.rest().chars().nth(n)
    }

    pub(super) fn bump(&mut self) -> Option<char> {
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

    pub(super) fn eat(&mut self, c: char) -> bool {
        let hit = self.peek() == Some(c);
        if hit {
            self.bump();
        }
        hit
    }

    /// Moves past `n` bytes (which must end on a character boundary).
    pub(super) fn advance(&mut self, n: usize) {
        let target = self.pos + n;
        while self.pos < target && self.bump().is_some() {}
    }

    pub(super) fn here(&self) -> Pos {
        (self.line, self.col)
    }

    pub(super) fn span_at(&self, (line, col): Pos) -> Span {
        Span {
            file: self.file.clone(),
            line,
            col,
        }
    }

    /// What the cursor is looking at, for "found ..." in messages.
    pub(super) fn found(&self) -> String {
        match self.peek() {
            None => "end of input".into(),
            Some(c) => format!("`{}`", c.escape_debug()),
        }
    }

    pub(super) fn error(&self, message: impl Into<String>) -> SyntaxError {
        self.error_at(self.here(), message)
    }

    pub(super) fn error_at(&self, (line, col): Pos, message: impl Into<String>) -> SyntaxError {
        SyntaxError {
            line,
            col,
            message: message.into(),
        }
    }

    /// "expected {what}, found X", noting the unclosed bracket at `open` when input ran out.
    pub(super) fn expected(&self, what: &str, (open, bracket): (Pos, char)) -> SyntaxError {
        let mut message = format!("expected {what}, found {}", self.found());
        if self.peek().is_none() {
            let (line, col) = open;
            message += &format!(" (the `{bracket}` at {line}:{col} is never closed)");
        }
        self.error(message)
    }

    /// Skips whitespace and comments.
    pub(super) fn skip_ws(&mut self) -> PResult<()> {
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
}
