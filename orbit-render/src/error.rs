//! Errors of rendering and video writing.

use std::path::PathBuf;

/// What can go wrong while rendering or writing a video.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A viewer setting is out of range.
    #[error("viewer.{field}: {message}")]
    InvalidViewer {
        /// The field of the env config's `viewer`.
        field: String,
        /// What was expected.
        message: String,
    },
    /// A video setting or frame is out of range (not a `viewer` field: the recording's own).
    #[error("video: {0}")]
    InvalidVideo(String),
    /// A file could not be written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The GIF encoder failed.
    #[error("{}: writing the GIF failed: {source}", path.display())]
    Gif {
        /// The video file.
        path: PathBuf,
        /// The cause.
        source: gif::EncodingError,
    },
}
