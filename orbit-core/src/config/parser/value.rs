//! Values: lists, maps, structs and tuples (named or not), bare identifiers and booleans;
//! literals are dispatched to the `literal` module.

use std::collections::HashMap;

use crate::config::node::{Node, NodeKind, is_ident_continue, is_ident_start};

use super::MAX_DEPTH;
use super::cursor::{PResult, Parser, Pos};

impl Parser<'_> {
    pub(super) fn value(&mut self) -> PResult<Node> {
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
}
