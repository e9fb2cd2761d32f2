//! The host's error type: every message names the file and, where it applies, the frame, the
//! row, the pixel or the field (SPEC §6).

use std::fmt;
use std::io;
use std::path::{Path, PathBuf};

use fsm_core::wire::WireError;

/// Result of a host operation.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// What went wrong, and where.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The operating system's error.
        source: io::Error,
    },
    /// A scan-plan file is malformed or describes an invalid plan.
    #[error("{}: {source}", path.display())]
    PlanFile {
        /// The plan file (or the option that set the value).
        path: PathBuf,
        /// What is wrong.
        source: crate::plan_file::PlanFileError,
    },
    /// A projector-response (gamma) file is malformed.
    #[error("{}: {message}", path.display())]
    ProjectorResponse {
        /// The calibration file.
        path: PathBuf,
        /// What is wrong, naming the field.
        message: String,
    },
    /// A captured image stack does not match the plan, or one of its images is unreadable.
    #[error(transparent)]
    Stack(#[from] crate::stack::StackError),
    /// A row dump is truncated, corrupted or made with another plan.
    #[error(transparent)]
    Dump(#[from] crate::dump::DumpError),
    /// A candidate file is truncated, corrupted or inconsistent.
    #[error(transparent)]
    CandidateFile(#[from] crate::candidate_file::CandidateFileError),
    /// An image could not be encoded.
    #[error("{}: {message}", path.display())]
    Encode {
        /// The image being written.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
    /// A request the data cannot satisfy (pixel outside the image, output in the way, …).
    #[error("{0}")]
    Usage(String),
}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// The operating system's error alone, for a caller whose own error type names the path
    /// (the calibration files' and the simulator's writers over [`crate::outputs`]). Errors
    /// other than [`Error::Io`] become [`io::ErrorKind::Other`] with their message.
    pub fn into_io_error(self) -> io::Error {
        match self {
            Error::Io { source, .. } => source,
            other => io::Error::other(other.to_string()),
        }
    }
}

/// Attaches a path to I/O results.
pub(crate) trait IoContext<T> {
    fn at(self, path: &Path) -> Result<T>;
}

impl<T> IoContext<T> for io::Result<T> {
    fn at(self, path: &Path) -> Result<T> {
        self.map_err(|e| Error::io(path, e))
    }
}

/// `fsm_core`'s wire errors as a `std::error::Error` (core is `no_std` and implements only
/// `Display`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wire(pub WireError);

impl fmt::Display for Wire {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for Wire {}
