//! Loading files with their `#include` lines: includes are resolved relative to the including
//! file, loaded recursively (cycles are errors), merged in order, and the including file's own
//! value is merged on top. Files come from disk or, under [`BUNDLED_ROOT`], from the copies
//! compiled into the binaries ([`Bundled`]), so bundled files include each other the same way.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};
use std::sync::Arc;

use super::error::ConfigError;
use super::merge::merge_into;
use super::node::{Node, Span};
use super::parser::{self, Document};

/// The root under which bundled files are named, as in `<bundled>/reach/env/reach.ron`: no
/// file on disk is reached through it.
pub const BUNDLED_ROOT: &str = "<bundled>";

/// Config files compiled into the binaries, keyed by their path under [`BUNDLED_ROOT`]
/// (`reach/env/reach.ron`). Includes between them resolve in memory, relative to the
/// including file, as on disk.
#[derive(Clone, Debug, Default)]
pub struct Bundled {
    files: BTreeMap<PathBuf, &'static str>,
}

impl Bundled {
    /// A set of bundled files from `(path under the root, text)` pairs.
    pub fn new<P: AsRef<Path>>(files: impl IntoIterator<Item = (P, &'static str)>) -> Self {
        Self {
            files: files
                .into_iter()
                .map(|(path, text)| (normalize(path.as_ref()), text))
                .collect(),
        }
    }

    /// The text of the bundled file at `path`, given under the root or as
    /// `<bundled>/path`; `None` if there is none.
    pub fn get(&self, path: &Path) -> Option<&'static str> {
        let path = normalize(path);
        let path = path.strip_prefix(BUNDLED_ROOT).unwrap_or(&path);
        self.files.get(path).copied()
    }

    /// Paths of all bundled files (under the root), sorted.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.files.keys().map(PathBuf::as_path)
    }

    /// `path` under the root as it is named in errors and includes: `<bundled>/path`.
    pub fn full_path(path: &str) -> PathBuf {
        Path::new(BUNDLED_ROOT).join(path)
    }
}

/// Whether `path` names a bundled file (starts with [`BUNDLED_ROOT`]).
pub fn is_bundled(path: &Path) -> bool {
    path.components().next() == Some(Component::Normal(BUNDLED_ROOT.as_ref()))
}

/// Loads the file at `path` (on disk, or bundled if it starts with [`BUNDLED_ROOT`]) and
/// everything it includes.
pub(crate) fn load_file(bundled: &Bundled, path: &Path) -> Result<Node, ConfigError> {
    Loader::new(bundled).load(path, None)
}

/// Parses `text` (named `file_name` in errors); includes are relative to the current directory.
pub(crate) fn load_text(text: &str, file_name: &str) -> Result<Node, ConfigError> {
    let document = parser::parse_document(text, Arc::new(PathBuf::from(file_name)))?;
    Loader::new(&Bundled::default()).resolve(document, Path::new(""))
}

/// The file at `path` and every file it includes, directly or not, each once, in the order
/// they are first reached (the file itself first).
pub(crate) fn dependencies(bundled: &Bundled, path: &Path) -> Result<Vec<PathBuf>, ConfigError> {
    let mut loader = Loader::new(bundled);
    loader.record = Some(Vec::new());
    loader.load(path, None)?;
    Ok(loader.record.unwrap_or_default())
}

/// The chain of files being loaded, to detect include cycles.
struct Loader<'a> {
    bundled: &'a Bundled,
    /// (canonical path, path as shown) of each file being loaded, outermost first.
    stack: Vec<(PathBuf, PathBuf)>,
    /// Every file loaded, in order, when asked for.
    record: Option<Vec<PathBuf>>,
}

impl<'a> Loader<'a> {
    fn new(bundled: &'a Bundled) -> Self {
        Self {
            bundled,
            stack: Vec::new(),
            record: None,
        }
    }

    fn load(&mut self, path: &Path, included_from: Option<&Span>) -> Result<Node, ConfigError> {
        let bytes = self.read(path, included_from)?;
        let file = Arc::new(path.to_path_buf());
        let document = parser::parse_document(parser::decode(&bytes, &file)?, file)?;
        if let Some(record) = &mut self.record
            && !record.iter().any(|p| p == path)
        {
            record.push(path.to_path_buf());
        }
        self.stack.push((canonical(path), path.to_path_buf()));
        let result = self.resolve(document, path.parent().unwrap_or(Path::new("")));
        self.stack.pop();
        result
    }

    /// The text of `path`: a bundled file's, or the file's on disk.
    fn read(
        &self,
        path: &Path,
        included_from: Option<&Span>,
    ) -> Result<Cow<'static, [u8]>, ConfigError> {
        let io_error = |source| ConfigError::Io {
            file: path.to_path_buf(),
            included_from: included_from.cloned(),
            source,
        };
        if is_bundled(path) {
            return self
                .bundled
                .get(path)
                .map(|t| Cow::Borrowed(t.as_bytes()))
                .ok_or_else(|| {
                    io_error(std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        "no bundled config file of that name",
                    ))
                });
        }
        std::fs::read(path).map(Cow::Owned).map_err(io_error)
    }

    /// Loads `document`'s includes (relative to `base`, or bundled when they start with
    /// [`BUNDLED_ROOT`]) and merges them under its value.
    fn resolve(&mut self, document: Document, base: &Path) -> Result<Node, ConfigError> {
        let mut merged: Option<Node> = None;
        for include in document.includes {
            let given = Path::new(&include.path);
            let target = if is_bundled(given) {
                normalize(given)
            } else if is_bundled(base) {
                normalize(&base.join(given))
            } else {
                base.join(given)
            };
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

/// `path` made absolute and free of `..` and links, if it exists on disk; a bundled path
/// with its `.` and `..` steps resolved; else `path` itself.
fn canonical(path: &Path) -> PathBuf {
    if is_bundled(path) {
        return normalize(path);
    }
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// `path` with `.` steps dropped and each `..` removing the step before it (lexically: bundled
/// files have no links).
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            other => out.push(other),
        }
    }
    out
}
