//! Why a scene, an image or a camera could not be loaded, in the library's terms: each error names
//! the file (and the line, where the format has lines) and says what is wrong. They are values a
//! caller can match: a command line maps them to its own words (`crate::cli::errors` names the
//! flag of strict loading), a binding to its exceptions (a missing file, unreadable data, content
//! that cannot be read as its format). A leaf: it imports nothing of `crate::scene`.
//!
//! `{}` prints an error's own message; `{:#}` prints it with its causes after it, `outer: inner:
//! …`, as `anyhow` does, so that a caller without `anyhow` gets the whole message. (That is why
//! [`LoadError`] and [`ImageError`] write their `Display` and `source` by hand rather than derive
//! them: a derived `Display` cannot see the `{:#}` flag, and a sidecar's mesh error must be its
//! own [`LoadError`] link, not a box of one.)

use crate::accel::AccelError;
use std::error::Error;
use std::fmt;
use std::path::PathBuf;

/// A scene file that could not be loaded.
#[derive(Debug)]
pub enum LoadError {
    /// There is nothing at the path.
    NotFound { file: PathBuf },
    /// What is at the path is not a regular file (`kind`: "a directory", "a FIFO (named pipe)",
    /// ...): it is refused before it is opened, which could block.
    NotRegular { file: PathBuf, kind: &'static str },
    /// The file could not be read.
    Unreadable {
        file: PathBuf,
        source: std::io::Error,
    },
    /// The file changed while it was read (it was still being written).
    Changed { file: PathBuf },
    /// The file's extension names no scene format (`None`: it has no extension).
    UnsupportedFormat {
        file: PathBuf,
        extension: Option<String>,
    },
    /// The content cannot be read as its format: `what` says why, at `line` for formats of lines.
    Malformed {
        file: PathBuf,
        line: Option<usize>,
        what: String,
    },
    /// Strict loading refused, at `line`, what a tolerant load goes on past with a warning
    /// (`what`: a face of fewer than 3 vertices, a statement without its name, a statement the
    /// loader does not use, text that is not UTF-8).
    Strict {
        file: PathBuf,
        line: usize,
        what: String,
    },
    /// More vertices (or normals, texture coordinates) than 32-bit indices address.
    TooLarge { file: PathBuf, what: String },
    /// The file holds no triangles to load: `what` says why.
    NoGeometry { file: PathBuf, what: String },
    /// A file the scene file refers to (`what`: which, e.g. a glTF buffer) could not be read.
    Referenced {
        file: PathBuf,
        what: String,
        source: std::io::Error,
    },
    /// A file the scene file names lies outside the folder it may read (its own and the folders
    /// below it; see `crate::scene::files::Reach`): `what` says which reference (a buffer, an
    /// image, a material library), `name` gives it as the file does, `why` how it leaves `folder`.
    /// Nothing was read from it. The load option `allow_outside_uris` opts in.
    Outside {
        file: PathBuf,
        what: String,
        name: String,
        folder: PathBuf,
        why: String,
    },
    /// An image the scene file refers to or holds (`image`: which) could not be decoded.
    Image {
        file: PathBuf,
        image: String,
        source: ImageError,
    },
    /// The mesh a sidecar scene file names could not be loaded.
    Mesh {
        sidecar: PathBuf,
        source: Box<LoadError>,
    },
    /// The environment map of a sidecar scene file could not be loaded.
    Environment {
        sidecar: PathBuf,
        source: ImageError,
    },
    /// Camera `index` (from 1) of a sidecar scene file defines no view.
    Camera {
        sidecar: PathBuf,
        index: usize,
        source: CameraError,
    },
    /// The acceleration structure could not be built.
    Build { file: PathBuf, source: AccelError },
    /// A light to scale or switch off that the scene file does not have (`known`: the names of
    /// those it has, [`crate::scene::dimmer`]), or one named twice.
    UnknownLight {
        file: PathBuf,
        name: String,
        known: Vec<String>,
        twice: bool,
    },
}

impl LoadError {
    /// This error's own message, without its causes.
    fn message(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use LoadError as E;
        match self {
            E::NotFound { file } => write!(f, "{}: no such scene file", file.display()),
            E::NotRegular { file, kind } => write!(
                f,
                "{}: {kind}, not a regular file; a scene must be a regular file",
                file.display()
            ),
            E::Unreadable { file, .. } => write!(f, "{}: cannot read", file.display()),
            E::Changed { file } => write!(
                f,
                "{}: the file changed while it was read; load it again once it is complete",
                file.display()
            ),
            E::UnsupportedFormat {
                file,
                extension: Some(ext),
            } => write!(
                f,
                "{}: unsupported scene format '.{ext}' (supported: .obj, .gltf, .glb, .toml)",
                file.display()
            ),
            E::UnsupportedFormat {
                file,
                extension: None,
            } => write!(
                f,
                "{}: no file extension; expected a .obj, .gltf, .glb or .toml scene",
                file.display()
            ),
            E::Malformed {
                file,
                line: Some(line),
                what,
            } => write!(f, "{}:{line}: {what}", file.display()),
            E::Malformed {
                file,
                line: None,
                what,
            } => write!(f, "{}: {what}", file.display()),
            E::Strict { file, line, what } => {
                write!(f, "{}:{line}: {what} (strict loading)", file.display())
            }
            E::TooLarge { file, what } => write!(f, "{}: {what}", file.display()),
            E::NoGeometry { file, what } => write!(f, "{}: no geometry: {what}", file.display()),
            E::Referenced { file, what, .. } => write!(f, "{}: {what}", file.display()),
            E::Outside { .. } => f.write_str(
                &self
                    .outside_message("allow_outside_uris")
                    .unwrap_or_default(),
            ),
            E::Image { file, image, .. } => write!(f, "{}: {image}", file.display()),
            E::Mesh { sidecar, .. } => write!(f, "{}: loading its mesh", sidecar.display()),
            E::Environment { sidecar, .. } => write!(f, "{}: [environment]", sidecar.display()),
            E::Camera { sidecar, index, .. } => {
                write!(f, "{}: camera #{index}", sidecar.display())
            }
            E::Build { file, .. } => write!(f, "{}: building the scene", file.display()),
            E::UnknownLight {
                file, name, twice, ..
            } if *twice => write!(f, "{}: the light '{name}' is scaled twice", file.display()),
            E::UnknownLight {
                file, name, known, ..
            } => write!(
                f,
                "{}: no light named '{name}'; {}",
                file.display(),
                if known.is_empty() {
                    "it has no lights of its own".to_string()
                } else {
                    format!("its lights: {} (or * for all)", known.join(", "))
                }
            ),
        }
    }

    /// For [`LoadError::Outside`]: its message, naming `opt_in` as the way to read such files
    /// anyway (a flag on the command line, a keyword in Python).
    pub fn outside_message(&self, opt_in: &str) -> Option<String> {
        let LoadError::Outside {
            file,
            what,
            name,
            folder,
            why,
        } = self
        else {
            return None;
        };
        Some(format!(
            "{}: {what} '{name}' lies outside the scene's folder {} ({why}); a scene file reads \
             files only inside its own folder, and {opt_in} lets it read them anyway",
            file.display(),
            folder.display()
        ))
    }

    /// A scene file at `file` whose metadata could not be read (`source`): missing, or unreadable
    /// for the cause the system gives (a loop of symbolic links, a permission), never a loop
    /// reported as missing.
    pub fn unopened(file: &std::path::Path, source: std::io::Error) -> LoadError {
        match source.kind() {
            std::io::ErrorKind::NotFound => LoadError::NotFound {
                file: file.to_path_buf(),
            },
            _ => LoadError::Unreadable {
                file: file.to_path_buf(),
                source,
            },
        }
    }

    /// The file the error is about (for a sidecar's part: the sidecar).
    pub fn file(&self) -> &std::path::Path {
        use LoadError as E;
        match self {
            E::NotFound { file }
            | E::NotRegular { file, .. }
            | E::Unreadable { file, .. }
            | E::Changed { file }
            | E::UnsupportedFormat { file, .. }
            | E::Malformed { file, .. }
            | E::Strict { file, .. }
            | E::TooLarge { file, .. }
            | E::NoGeometry { file, .. }
            | E::Referenced { file, .. }
            | E::Outside { file, .. }
            | E::Image { file, .. }
            | E::Build { file, .. }
            | E::UnknownLight { file, .. } => file,
            E::Mesh { sidecar, .. }
            | E::Environment { sidecar, .. }
            | E::Camera { sidecar, .. } => sidecar,
        }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.message(f)?;
        write_causes(f, self)
    }
}

impl Error for LoadError {
    fn source(&self) -> Option<&(dyn Error + 'static)> {
        use LoadError as E;
        match self {
            E::Unreadable { source, .. } | E::Referenced { source, .. } => Some(source),
            E::Image { source, .. } | E::Environment { source, .. } => Some(source),
            E::Mesh { source, .. } => Some(source.as_ref()),
            E::Camera { source, .. } => Some(source),
            E::Build { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// An image (a texture or an environment map) that could not be read or used. `name` is the file
/// (or what the image is called), `None` for bytes held in memory, whose holder names them.
#[derive(Debug)]
pub enum ImageError {
    /// The file could not be opened or read, or its bytes not decoded: `what` says which step
    /// failed, `source` why.
    Decode {
        name: Option<String>,
        what: &'static str,
        source: Box<dyn Error + Send + Sync>,
    },
    /// The image was decoded, but its texels cannot be used: `what` says why.
    Invalid { name: Option<String>, what: String },
    /// What is at the path is not a regular file (`kind`: "a directory", "a FIFO (named pipe)",
    /// ...): refused before it is opened, which could block.
    NotRegular { name: String, kind: &'static str },
}

impl ImageError {
    /// For `map_err`: the failure of step `what` of reading the image `name`.
    pub fn failed<E: Error + Send + Sync + 'static>(
        name: &str,
        what: &'static str,
    ) -> impl FnOnce(E) -> ImageError {
        let name = name.to_string();
        move |e| ImageError::Decode {
            name: Some(name),
            what,
            source: Box::new(e),
        }
    }

    /// The same error for bytes whose holder names them.
    pub fn unnamed(self) -> ImageError {
        match self {
            ImageError::Decode { what, source, .. } => ImageError::Decode {
                name: None,
                what,
                source,
            },
            ImageError::Invalid { what, .. } => ImageError::Invalid { name: None, what },
            e @ ImageError::NotRegular { .. } => e,
        }
    }
}

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (name, what) = match self {
            ImageError::Decode { name, what, .. } => (name, *what),
            ImageError::Invalid { name, what } => (name, what.as_str()),
            ImageError::NotRegular { name, kind } => {
                return write!(
                    f,
                    "{name}: {kind}, not a regular file; only regular files are read as images"
                );
            }
        };
        match name {
            Some(name) => write!(f, "{name}: {what}")?,
            None => f.write_str(what)?,
        }
        write_causes(f, self)
    }
}

impl Error for ImageError {
    fn source(&self) -> Option<&(dyn Error + 'static)> {
        match self {
            ImageError::Decode { source, .. } => Some(source.as_ref()),
            ImageError::Invalid { .. } | ImageError::NotRegular { .. } => None,
        }
    }
}

/// A camera given by eye, target and up that defines no view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CameraError {
    #[error("target equals eye")]
    TargetAtEye,
    #[error("up is parallel to the viewing direction")]
    UpAlongView,
}

/// For `{:#}`: the causes of `e` after its message, each as `: cause`.
fn write_causes(f: &mut fmt::Formatter<'_>, e: &dyn Error) -> fmt::Result {
    if f.alternate() {
        let mut cause = e.source();
        while let Some(c) = cause {
            write!(f, ": {c}")?;
            cause = c.source();
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_alternate_form_prints_the_causes() {
        let e = LoadError::Mesh {
            sidecar: "a.toml".into(),
            source: Box::new(LoadError::Image {
                file: "b.gltf".into(),
                image: "image #0".into(),
                source: ImageError::Decode {
                    name: None,
                    what: "cannot decode",
                    source: "bad bytes".into(),
                },
            }),
        };
        assert_eq!(e.to_string(), "a.toml: loading its mesh");
        assert_eq!(
            format!("{e:#}"),
            "a.toml: loading its mesh: b.gltf: image #0: cannot decode: bad bytes"
        );
        // The chain anyhow walks gives the same text.
        assert_eq!(format!("{:#}", anyhow::Error::from(e)), {
            "a.toml: loading its mesh: b.gltf: image #0: cannot decode: bad bytes"
        });
    }
}
