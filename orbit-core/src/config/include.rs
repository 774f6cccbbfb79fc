//! Loading files with their `#include` lines: includes are resolved relative to the including
//! file, loaded recursively (cycles are errors), merged in order, and the including file's own
//! value is merged on top.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::error::ConfigError;
use super::merge::merge_into;
use super::node::{Node, Span};
use super::parser::{self, Document};

/// Loads the file at `path` and everything it includes.
pub(crate) fn load_file(path: &Path) -> Result<Node, ConfigError> {
    Loader::default().load(path, None)
}

/// Parses `text` (named `file_name` in errors); includes are relative to the current directory.
pub(crate) fn load_text(text: &str, file_name: &str) -> Result<Node, ConfigError> {
    let document = parser::parse_document(text, Arc::new(PathBuf::from(file_name)))?;
    Loader::default().resolve(document, Path::new(""))
}

/// The chain of files being loaded, to detect include cycles.
#[derive(Default)]
struct Loader {
    /// (canonical path, path as shown) of each file being loaded, outermost first.
    stack: Vec<(PathBuf, PathBuf)>,
}

impl Loader {
    fn load(&mut self, path: &Path, included_from: Option<&Span>) -> Result<Node, ConfigError> {
        let io_error = |source| ConfigError::Io {
            file: path.to_path_buf(),
            included_from: included_from.cloned(),
            source,
        };
        let bytes = std::fs::read(path).map_err(io_error)?;
        let file = Arc::new(path.to_path_buf());
        let document = parser::parse_document(parser::decode(&bytes, &file)?, file)?;
        self.stack.push((canonical(path), path.to_path_buf()));
        let result = self.resolve(document, path.parent().unwrap_or(Path::new("")));
        self.stack.pop();
        result
    }

    /// Loads `document`'s includes (relative to `base`) and merges them under its value.
    fn resolve(&mut self, document: Document, base: &Path) -> Result<Node, ConfigError> {
        let mut merged: Option<Node> = None;
        for include in document.includes {
            let target = base.join(&include.path);
            let key = canonical(&target);
            if let Some(start) = self.stack.iter().position(|(k, _)| *k == key) {
                let chain: Vec<String> = self.stack[start..]
                    .iter()
                    .map(|(_, shown)| shown.display().to_string())
                    .chain([target.display().to_string()])
                    .collect();
                return Err(ConfigError::Include {
                    file: include.span.file.to_path_buf(),
                    line: include.span.line,
                    col: include.span.col,
                    message: format!("include cycle: {}", chain.join(" -> ")),
                });
            }
            let node = self.load(&target, Some(&include.span))?;
            match &mut merged {
                Some(base) => merge_into(base, node),
                None => merged = Some(node),
            }
        }
        match (merged, document.value) {
            (Some(mut base), Some(value)) => {
                merge_into(&mut base, value);
                Ok(base)
            }
            (Some(node), None) | (None, Some(node)) => Ok(node),
            (None, None) => {
                let start = Span {
                    file: document.file,
                    line: 1,
                    col: 1,
                };
                Err(ConfigError::parse_at(
                    &start,
                    "empty document: expected a RON value",
                ))
            }
        }
    }
}

/// `path` made absolute and free of `..` and links, if it exists; else `path` itself.
fn canonical(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}
