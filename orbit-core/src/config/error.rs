//! [`ConfigError`]: every way loading a config can fail, each naming where.

use std::path::PathBuf;

use super::node::Span;

/// An error while loading a config. Its `Display` starts with `file:line:col` (or names the
/// override) and says what was expected.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A file could not be read.
    #[error("{}", io_message(file, included_from.as_ref(), source))]
    Io {
        /// The file that could not be read.
        file: PathBuf,
        /// The `#include` line that named the file, if it was included.
        included_from: Option<Span>,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The text is not valid RON (or not UTF-8).
    #[error("{}:{line}:{col}: {message}", file.display())]
    Parse {
        /// The file being parsed.
        file: PathBuf,
        /// 1-based line.
        line: u32,
        /// 1-based column.
        col: u32,
        /// What was wrong and what was expected.
        message: String,
    },
    /// An `#include` could not be followed (for example, an include cycle).
    #[error("{}:{line}:{col}: {message}", file.display())]
    Include {
        /// The file holding the `#include` line.
        file: PathBuf,
        /// Line of the `#include`.
        line: u32,
        /// Column of the `#include`.
        col: u32,
        /// What was wrong.
        message: String,
    },
    /// A command-line override is malformed or its path does not exist.
    #[error("override `{override_text}`: {message}")]
    Override {
        /// The override as given (`sim.dt=0.001`).
        override_text: String,
        /// What was wrong.
        message: String,
    },
    /// The document does not match the type it is deserialised into.
    #[error("{}", invalid_message(file, *line, *col, path, message))]
    Invalid {
        /// The file that supplied the offending value.
        file: PathBuf,
        /// 1-based line of the offending value.
        line: u32,
        /// 1-based column of the offending value.
        col: u32,
        /// Field path of the offending value (`scene.articulations[0].actuators.arm.stiffness`);
        /// empty for the document root.
        path: String,
        /// What serde expected.
        message: String,
    },
}

impl ConfigError {
    /// A value at `span` (field path `path`) that does not fit what is expected.
    pub fn invalid_at(span: &Span, path: impl Into<String>, message: impl Into<String>) -> Self {
        ConfigError::Invalid {
            file: span.file.to_path_buf(),
            line: span.line,
            col: span.col,
            path: path.into(),
            message: message.into(),
        }
    }

    /// A parse error at `span`.
    pub(crate) fn parse_at(span: &Span, message: impl Into<String>) -> Self {
        ConfigError::Parse {
            file: span.file.to_path_buf(),
            line: span.line,
            col: span.col,
            message: message.into(),
        }
    }
}

fn io_message(file: &std::path::Path, from: Option<&Span>, source: &std::io::Error) -> String {
    match from {
        Some(span) => format!(
            "{span}: cannot read included file `{}`: {source}",
            file.display()
        ),
        None => format!("{}: cannot read config file: {source}", file.display()),
    }
}

/// Where a value was written: `file:line:col`, or for an override its text alone (one line the
/// user typed: its text says more than a position).
pub(crate) fn location(file: &std::path::Path, line: u32, col: u32) -> String {
    if super::overrides::is_override_file(file) {
        file.display().to_string()
    } else {
        format!("{}:{line}:{col}", file.display())
    }
}

fn invalid_message(file: &std::path::Path, line: u32, col: u32, path: &str, msg: &str) -> String {
    let at = location(file, line, col);
    if path.is_empty() {
        format!("{at}: {msg}")
    } else {
        format!("{at}: {path}: {msg}")
    }
}
