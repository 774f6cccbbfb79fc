//! Documents: leading `#include "path"` lines and `#![...]` headers, then at most one value and
//! nothing but whitespace and comments after it.

use super::cursor::{PResult, Parser};
use super::{Document, Include};

impl Parser<'_> {
    pub(super) fn document(&mut self) -> PResult<Document> {
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
    pub(super) fn end(&mut self) -> PResult<()> {
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
}
