//! Errors shared by the readers and writers.

use std::path::PathBuf;

/// A file could not be written (atomically).
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {source}", path.display())]
pub struct WriteError {
    /// The target file.
    pub path: PathBuf,
    /// The underlying I/O error.
    #[source]
    pub source: std::io::Error,
}

/// A mesh file could not be read or understood.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A line does not contain what the format requires there.
    #[error("{file} line {line}: {message}")]
    Syntax {
        /// File name as given by the caller (or `<input>` for in-memory text).
        file: String,
        /// 1-based line number.
        line: usize,
        /// What was expected and what was found.
        message: String,
    },
    /// A problem that is not tied to one line (missing section, unsupported variant).
    #[error("{file}: {message}")]
    Content {
        /// File name as given by the caller.
        file: String,
        /// What is wrong.
        message: String,
    },
}

impl ReadError {
    /// The 1-based line number of a syntax error, if the error has one.
    pub fn line(&self) -> Option<usize> {
        match self {
            ReadError::Syntax { line, .. } => Some(*line),
            _ => None,
        }
    }
}

/// Reads a whole text file, mapping failures to [`ReadError::Io`].
pub(crate) fn read_text(path: &std::path::Path) -> Result<String, ReadError> {
    let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    String::from_utf8(bytes).map_err(|e| ReadError::Content {
        file: path.display().to_string(),
        message: format!(
            "not UTF-8 text (invalid byte at offset {}); binary files are not supported",
            e.utf8_error().valid_up_to()
        ),
    })
}
