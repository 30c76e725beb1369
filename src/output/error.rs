//! The errors of the output room, as values a caller can match: [`OutputError`] when an output
//! path cannot take a file (checked before a run), [`FileError`] when a field file (EXR, VTI) or a
//! picture (PNG) cannot be read or written. Each names the file and says what is wrong in the
//! library's terms; the command line maps them to its own words (`crate::cli::errors`), and a
//! binding to another language can map the kinds to its own exceptions (a missing file is
//! [`FileError::Read`] with an I/O error of kind `NotFound`; a file that is not this tool's is
//! [`FileError::Format`] or [`FileError::EarlierVersion`]).

use crate::run_info::InfoError;
use std::path::{Path, PathBuf};

/// Why an output path cannot take the file (the command line names the `-o` flag:
/// `crate::cli::errors`).
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("output {path}: cannot create directory {dir}")]
    CreateDir {
        path: PathBuf,
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("output {path}: is a directory")]
    IsDirectory { path: PathBuf },
    /// `file` (the output itself or a preview written beside it) exists and is not a regular
    /// file: writing the output would replace it (a device node, as root), so it is refused.
    #[error(
        "output {}: {}{kind}, not a regular file (the finished file is renamed into place, which \
         would replace it): name a regular file or a new one",
        path.display(),
        preview_of(path, file)
    )]
    NotRegular {
        path: PathBuf,
        file: PathBuf,
        kind: &'static str,
    },
    #[error("output {path}: directory {dir} is not writable")]
    NotWritable {
        path: PathBuf,
        dir: PathBuf,
        source: std::io::Error,
    },
}

/// `its preview P is ` when `file` is not the output `path` itself, else `is `.
pub fn preview_of(path: &Path, file: &Path) -> String {
    if path == file {
        "is ".to_string()
    } else {
        format!("its preview {} is ", file.display())
    }
}

/// Why a field file (EXR, VTI) or a PNG cannot be read or written; every variant names the file.
/// Causes from the system (I/O errors) follow as the error's source, as the next link of a chain.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// The file cannot be opened or read: missing, not permitted, or an I/O failure (the source
    /// says which).
    #[error("{}: cannot read", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Not a file of the format this tool writes, or a damaged one: what is wrong with it.
    #[error("{}: {detail}", path.display())]
    Format { path: PathBuf, detail: String },
    /// A field file written by an earlier version, whose standard error came from batch σ sums:
    /// the per-sample product sums the error needs now are not in it.
    #[error(
        "{}: written by an earlier ftpd3d, whose standard error came from batch σ sums; the \
         per-sample product sums the error needs now are not in it, so it cannot be merged or \
         resumed: run it again",
        path.display()
    )]
    EarlierVersion { path: PathBuf },
    /// The file has no channel of that name.
    #[error("{}: no channel '{name}'", path.display())]
    NoChannel { path: PathBuf, name: String },
    /// An attribute of the run's description does not read as what it should be (it names the
    /// file and the attribute).
    #[error(transparent)]
    Info(#[from] InfoError),
    /// What was given cannot be stored in this format: a volume for an EXR, more samples than a
    /// count channel holds, an array of the wrong length, an empty image.
    #[error("{}: {detail}", path.display())]
    Unfit { path: PathBuf, detail: String },
    /// Writing the file failed (the source says why).
    #[error("{}: writing failed", path.display())]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The encoder of the format refused the data: what it said.
    #[error("{}: writing failed ({detail})", path.display())]
    Encode { path: PathBuf, detail: String },
    /// The path is not a regular file (a directory, a device, a FIFO): the finished file, renamed
    /// into place, would replace it, so nothing is written.
    #[error(
        "{}: is {kind}, not a regular file; the finished file would replace it, so nothing was \
         written",
        path.display()
    )]
    NotRegular { path: PathBuf, kind: &'static str },
    /// The finished file could not be renamed from its temporary name into place.
    #[error("{}: cannot move the finished file into place", path.display())]
    Rename {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl FileError {
    /// The path the error names.
    pub fn path(&self) -> Option<&Path> {
        match self {
            FileError::Read { path, .. }
            | FileError::Format { path, .. }
            | FileError::EarlierVersion { path }
            | FileError::NoChannel { path, .. }
            | FileError::Unfit { path, .. }
            | FileError::Write { path, .. }
            | FileError::Encode { path, .. }
            | FileError::Rename { path, .. }
            | FileError::NotRegular { path, .. } => Some(path),
            // The attribute's error names the file as text.
            FileError::Info(_) => None,
        }
    }

    pub(crate) fn read(path: &Path, source: std::io::Error) -> Self {
        FileError::Read {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn format(path: &Path, detail: impl Into<String>) -> Self {
        FileError::Format {
            path: path.to_path_buf(),
            detail: detail.into(),
        }
    }

    pub(crate) fn unfit(path: &Path, detail: impl Into<String>) -> Self {
        FileError::Unfit {
            path: path.to_path_buf(),
            detail: detail.into(),
        }
    }

    pub(crate) fn write(path: &Path, source: std::io::Error) -> Self {
        FileError::Write {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn encode(path: &Path, detail: impl std::fmt::Display) -> Self {
        FileError::Encode {
            path: path.to_path_buf(),
            detail: detail.to_string(),
        }
    }
}
