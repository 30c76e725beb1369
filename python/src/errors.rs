//! The library's typed errors as the Python exceptions of `ftpd3d._errors`: each error's chain is
//! searched, outermost first, for the first typed value, which decides the class; the message is
//! the whole chain, in the library's terms (a file, line, parameter or value), never a flag.

use ftpd3d::accel::AccelError;
use ftpd3d::analysis::separatrix::SeparatrixError;
use ftpd3d::app::LightError;
use ftpd3d::domain::DomainError;
use ftpd3d::output::{FileError, OutputError};
use ftpd3d::params::ParamError;
use ftpd3d::render::RunError;
use ftpd3d::run_info::InfoError;
use ftpd3d::scene::flat::FlatlandError;
use ftpd3d::scene::{CameraError, ImageError, LoadError};
use pyo3::prelude::*;
use std::path::Path;

/// The classes of `ftpd3d._errors`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Missing,
    Scene,
    Parameter,
    Format,
    File,
    Run,
    Error,
}

impl Kind {
    fn class(self) -> &'static str {
        match self {
            Kind::Missing => "MissingFileError",
            Kind::Scene => "SceneError",
            Kind::Parameter => "ParameterError",
            Kind::Format => "FormatError",
            Kind::File => "FileError",
            Kind::Run => "RunError",
            Kind::Error => "Error",
        }
    }
}

/// The exception `kind` with `message` (and, for a missing file, its path).
pub fn raise(kind: Kind, message: impl Into<String>, file: Option<&Path>) -> PyErr {
    let message = message.into();
    Python::attach(|py| {
        let class = py
            .import("ftpd3d._errors")
            .and_then(|m| m.getattr(kind.class()));
        let made = class.and_then(|c| match (kind, file) {
            (Kind::Missing, Some(f)) => c.call1((message.clone(), f.display().to_string())),
            _ => c.call1((message.clone(),)),
        });
        match made {
            Ok(e) => PyErr::from_value(e),
            // The package's Python part is missing (a bare extension module): a plain exception.
            Err(_) => pyo3::exceptions::PyRuntimeError::new_err(message),
        }
    })
}

/// A bad keyword value: `ParameterError` naming it.
pub fn param(message: impl Into<String>) -> PyErr {
    raise(Kind::Parameter, message, None)
}

/// The exception for an error of the library (with its context chain).
pub fn to_py(err: anyhow::Error) -> PyErr {
    let message = format!("{err:#}");
    let (kind, file) = classify(&err);
    raise(kind, message, file.as_deref())
}

/// Runs `f`, turning a panic (a bug: the library returns errors, but a dependency may panic) into
/// an error, so that no call raises `PanicException`, which `except Exception` does not catch.
pub fn no_panic<T>(f: impl FnOnce() -> anyhow::Result<T>) -> anyhow::Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let why = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "no message".into());
            Err(anyhow::Error::new(InternalError(why)))
        }
    }
}

/// A panic caught by [`no_panic`]: a bug of ftpd3d, raised as `RunError`.
#[derive(Debug)]
struct InternalError(String);

impl std::fmt::Display for InternalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "internal error (a bug of ftpd3d, please report it): {}",
            self.0
        )
    }
}

impl std::error::Error for InternalError {}

/// The class for the first typed error in the chain, and the missing file's path.
fn classify(err: &anyhow::Error) -> (Kind, Option<std::path::PathBuf>) {
    for cause in err.chain() {
        if let Some(e) = cause.downcast_ref::<LoadError>() {
            return match e {
                LoadError::NotFound { file } => (Kind::Missing, Some(file.clone())),
                _ => (Kind::Scene, None),
            };
        }
        if let Some(e) = cause.downcast_ref::<FileError>() {
            return match e {
                FileError::Read { path, source } if is_missing(source) => {
                    (Kind::Missing, Some(path.clone()))
                }
                FileError::Read { .. } | FileError::Write { .. } | FileError::NotRegular { .. } => {
                    (Kind::File, None)
                }
                _ if is_io(e) => (Kind::File, None),
                _ => (Kind::Format, None),
            };
        }
        if let Some(e) = cause.downcast_ref::<std::io::Error>() {
            return match is_missing(e) {
                true => (Kind::Missing, None),
                false => (Kind::File, None),
            };
        }
        if let Some(ImageError::Decode {
            name: Some(name),
            source,
            ..
        }) = cause.downcast_ref::<ImageError>()
            && source
                .downcast_ref::<std::io::Error>()
                .is_some_and(is_missing)
        {
            return (Kind::Missing, Some(name.into()));
        }
        if cause.is::<ImageError>() || cause.is::<CameraError>() || cause.is::<FlatlandError>() {
            return (Kind::Scene, None);
        }
        if cause.is::<ParamError>()
            || cause.is::<DomainError>()
            || cause.is::<LightError>()
            || cause.is::<SeparatrixError>()
        {
            return (Kind::Parameter, None);
        }
        if cause.is::<InfoError>() {
            return (Kind::Format, None);
        }
        if cause.is::<OutputError>() {
            return (Kind::File, None);
        }
        if cause.is::<RunError>() || cause.is::<AccelError>() || cause.is::<InternalError>() {
            return (Kind::Run, None);
        }
    }
    (Kind::Error, None)
}

fn is_missing(e: &std::io::Error) -> bool {
    e.kind() == std::io::ErrorKind::NotFound
}

/// A file error that comes from the file system (rather than the file's content).
fn is_io(e: &FileError) -> bool {
    std::error::Error::source(e).is_some_and(|s| s.is::<std::io::Error>())
}
