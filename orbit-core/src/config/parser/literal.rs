//! Literals: strings (with escapes), raw strings, chars, and integers and floats.

use crate::config::node::{NodeKind, is_ident_continue};

use super::cursor::{PResult, Parser, Pos};

impl Parser<'_> {
    pub(super) fn string(&mut self) -> PResult<String> {
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

    pub(super) fn raw_string_ahead(&self) -> bool {
        let after_r = self.rest().strip_prefix('r').unwrap_or_default();
        after_r.trim_start_matches('#').starts_with('"')
    }

    /// `r"..."`, `r#"..."#`, ...
    pub(super) fn raw_string(&mut self) -> PResult<String> {
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

    pub(super) fn char_literal(&mut self) -> PResult<char> {
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

    pub(super) fn number(&mut self) -> PResult<NodeKind> {
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
