//! Errors that reach the user. Every input error names where it happened
//! (file and line) and why, so a user can fix the scene without a debugger.

use std::fmt;
use std::path::PathBuf;

/// A place in an input file: `file:line` (lines count from 1; 0 = whole file).
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct SourceLoc {
    pub file: PathBuf,
    pub line: usize,
    /// Column on the line, counting from 1 (0 = not known); expression
    /// errors name it.
    #[serde(default)]
    pub column: usize,
}

impl SourceLoc {
    pub fn new(file: impl Into<PathBuf>, line: usize) -> Self {
        Self {
            file: file.into(),
            line,
            column: 0,
        }
    }

    /// A place with its column (`file:line:column`).
    pub fn with_column(file: impl Into<PathBuf>, line: usize, column: usize) -> Self {
        Self {
            file: file.into(),
            line,
            column,
        }
    }
}

impl fmt::Display for SourceLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line == 0 {
            write!(f, "{}", self.file.display())
        } else if self.column > 0 {
            write!(f, "{}:{}:{}", self.file.display(), self.line, self.column)
        } else {
            write!(f, "{}:{}", self.file.display(), self.line)
        }
    }
}

/// All user-facing errors of the ray tracer.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Malformed scene, view or material input, with its location.
    #[error("{loc}: {reason}")]
    Parse { loc: SourceLoc, reason: String },
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// An impossible option or option combination (exit code 2).
    #[error("invalid option: {0}")]
    Usage(String),
    /// Geometry that cannot be rendered (NaN coordinates, zero radius, ...).
    #[error("{loc}: invalid geometry: {reason}")]
    Geometry { loc: SourceLoc, reason: String },
    /// Anything else that stops a render, with an explanation.
    #[error("{0}")]
    Other(String),
}

impl Error {
    pub fn parse(loc: SourceLoc, reason: impl Into<String>) -> Self {
        Error::Parse {
            loc,
            reason: reason.into(),
        }
    }
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
    /// The process exit code this error maps to: 2 for usage errors, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Usage(_) => 2,
            _ => 1,
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
