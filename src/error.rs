//! Error types. Every error that comes from user input names where it came from: load errors
//! carry a [`SourceLoc`] (file, line, column) and print as `FILE:LINE:COL: message`.

use std::fmt;
use std::path::PathBuf;

/// A position in a scene file (1-based line and column).
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct SourceLoc {
    pub file: PathBuf,
    pub line: u32,
    pub col: u32,
}

impl SourceLoc {
    pub fn new(file: impl Into<PathBuf>, line: u32, col: u32) -> Self {
        SourceLoc {
            file: file.into(),
            line,
            col,
        }
    }
}

impl fmt::Display for SourceLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.col)
    }
}

/// All errors of the library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad scene input at a known place: `FILE:LINE:COL: message`.
    #[error("{loc}: {msg}")]
    Scene { loc: SourceLoc, msg: String },
    /// A problem with a file that has no finer position (unreadable file, bad image...).
    #[error("{path}: {msg}")]
    File { path: PathBuf, msg: String },
    /// Bad command-line input.
    #[error("{0}")]
    Usage(String),
    /// Embree or another native component failed.
    #[error("{0}")]
    Native(String),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The render was cancelled (Ctrl-C).
    #[error("render cancelled")]
    Cancelled,
}

impl Error {
    pub fn scene(loc: &SourceLoc, msg: impl Into<String>) -> Self {
        Error::Scene {
            loc: loc.clone(),
            msg: msg.into(),
        }
    }
    pub fn file(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Error::File {
            path: path.into(),
            msg: msg.into(),
        }
    }
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
