//! Writers: OpenEXR for 2D fields, VTK XML ImageData (`.vti`) for volumes, PNG previews. Every file
//! is written under a temporary name in the destination directory and renamed into place, so a
//! failed run never leaves a truncated output.
//!
//! The EXR and VTI files keep each cell's accumulator exactly (`exact`), so that their readers
//! give back fields that merge and resume bit for bit. Reading and writing fail with a
//! [`FileError`] naming the file; [`OutputError`] says why an output path cannot take a file.

mod error;
mod exact;
pub mod exr;
pub mod plot;
pub mod png;
pub mod vti;

pub use error::{FileError, OutputError, preview_of};

use crate::field::Field;
use glam::DVec3;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// Temporary files being written now, so that a process quitting at once on a second signal can
/// remove them ([`remove_temporaries`]).
static IN_PROGRESS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Removes the temporary files of writes in progress (for a process about to exit mid-write).
pub fn remove_temporaries() {
    if let Ok(list) = IN_PROGRESS.lock() {
        for p in list.iter() {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// Temporary sibling name of `path` (same directory, so the rename is atomic), unique within and
/// across processes.
pub fn temp_path(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let k = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.{}-{k}.tmp", std::process::id()))
}

/// What is at `path` when it exists and is not a regular file (nor a link to one): "a directory",
/// "a character device", "a FIFO (named pipe)", ... Asks for the metadata only, so a FIFO is never
/// opened and nothing blocks. The rename that puts a finished file in place would replace such a
/// node (a device, as root), so no writer renames over one.
pub fn not_regular(path: &Path) -> Option<&'static str> {
    crate::scene::files::not_regular(path)
}

/// Runs `write` on a temporary path and renames the result to `path`; removes the temporary file
/// when writing fails. `write`'s errors come back as they are (the writers of this room name
/// `path` in them, not the temporary name); a failed rename is [`FileError::Rename`]. A `path`
/// that is not a regular file (a device, a FIFO, a directory) is refused before writing and again
/// before the rename ([`FileError::NotRegular`]): only a regular file or nothing is replaced.
pub fn write_file_atomically<E: From<FileError>>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    let refuse = |kind: &'static str| -> E {
        FileError::NotRegular {
            path: path.to_path_buf(),
            kind,
        }
        .into()
    };
    if let Some(kind) = not_regular(path) {
        return Err(refuse(kind));
    }
    create_parent(path).map_err(|e| {
        let dir = path.parent().unwrap_or(path).display();
        let source = std::io::Error::new(e.kind(), format!("cannot create folder {dir}: {e}"));
        FileError::write(path, source)
    })?;
    let tmp = temp_path(path);
    if let Ok(mut list) = IN_PROGRESS.lock() {
        list.push(tmp.clone());
    }
    let result = write(&tmp);
    if let Ok(mut list) = IN_PROGRESS.lock() {
        list.retain(|p| p != &tmp);
    }
    // The path may have changed while the file was written.
    let result = result.and_then(|()| not_regular(path).map_or(Ok(()), |k| Err(refuse(k))));
    match result {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|source| {
            FileError::Rename {
                path: path.to_path_buf(),
                source,
            }
            .into()
        }),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// [`write_file_atomically`] for writers whose errors are `anyhow`'s (reports, SVG, CSV): a
/// failure reads `<path>: writing failed: <cause>`.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    write_file_atomically(path, |tmp| {
        write(tmp).map_err(|e| e.context(format!("{}: writing failed", path.display())))
    })
}

/// Fails early when `path` cannot take a new file (before hours of work): creates its missing
/// folders, refuses a `path` that exists and is not a regular file (a directory, a device, a
/// FIFO: [`not_regular`]) and a folder that cannot take a new file.
pub fn check_writable(path: &Path) -> Result<(), OutputError> {
    check_writable_as(path, path)
}

/// [`check_writable`] for `path` and, when `png`, the PNG previews written beside it
/// (`<name>.png`, `<name>.grad.png`, [`write_previews`]).
pub fn check_writable_with_previews(path: &Path, png: bool) -> Result<(), OutputError> {
    check_writable(path)?;
    if png {
        for preview in preview_paths(path) {
            check_writable_as(path, &preview)?;
        }
    }
    Ok(())
}

/// [`check_writable`] of `file`, a file written for the output `path` (itself or a preview).
fn check_writable_as(path: &Path, file: &Path) -> Result<(), OutputError> {
    let dir = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let path_buf = path.to_path_buf();
    create_parent(file).map_err(|source| OutputError::CreateDir {
        path: path_buf.clone(),
        dir: dir.clone(),
        source,
    })?;
    match not_regular(file) {
        Some("a directory") if file == path => {
            return Err(OutputError::IsDirectory { path: path_buf });
        }
        Some(kind) => {
            return Err(OutputError::NotRegular {
                path: path_buf,
                file: file.to_path_buf(),
                kind,
            });
        }
        None => {}
    }
    let probe = temp_path(file);
    std::fs::write(&probe, b"").map_err(|source| OutputError::NotWritable {
        path: path_buf,
        dir: dir.clone(),
        source,
    })?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Creates the missing folders above `file`: every writer's rule (the command line's and the
/// Python module's), so a new output folder needs no step of its own.
pub fn create_parent(file: &Path) -> std::io::Result<()> {
    match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => std::fs::create_dir_all(p),
        _ => Ok(()),
    }
}

/// The PNG previews written beside `path`: `<name>.png` and `<name>.grad.png`.
pub fn preview_paths(path: &Path) -> [PathBuf; 2] {
    [path.with_extension("png"), path.with_extension("grad.png")]
}

/// Writes the EXR (with the Sobel gradient of σ as `grad.x`/`grad.y`, per cell) and, when asked,
/// PNG previews next to it: `<name>.png` (σ, equalised CIELAB map) and `<name>.grad.png` (gradient
/// direction as hue, magnitude as lightness).
pub fn write_outputs(field: &Field, path: &Path, png: bool) -> Result<(), FileError> {
    write_outputs_with(field, path, png, Vec::new())
}

/// [`write_outputs`] with extra f32 channels (one value per cell, field order).
pub fn write_outputs_with(
    field: &Field,
    path: &Path,
    png: bool,
    extra: Vec<(&str, Vec<f64>)>,
) -> Result<(), FileError> {
    let sigma = field.sigma();
    let valid = field.valid();
    let extra = with_gradient(field, &sigma, &valid, extra);
    exr::write_exr(path, field, &extra)?;
    if png {
        write_previews(path, &sigma, &valid, field.width, field.height)?;
    }
    Ok(())
}

/// The f32 channels of the EXR that [`write_outputs_with`] writes for `field` and `extra`, computed
/// by the writer's own steps ([`exr::view_channels`]): name and values in file order (row 0 at the
/// top), sorted by name. `name` stands for the field in errors.
pub fn exr_channels(
    field: &Field,
    name: &Path,
    extra: Vec<(&str, Vec<f64>)>,
) -> Result<Vec<(String, Vec<f32>)>, FileError> {
    exr::check_2d(name, field)?;
    let extra = with_gradient(field, &field.sigma(), &field.valid(), extra);
    exr::view_channels(name, field, &extra)
}

/// `extra` after the Sobel gradient of σ (`grad.x`, `grad.y`, per cell), as the EXR holds them.
fn with_gradient<'a>(
    field: &Field,
    sigma: &[f64],
    valid: &[bool],
    mut extra: Vec<(&'a str, Vec<f64>)>,
) -> Vec<(&'a str, Vec<f64>)> {
    let (gx, gy) = png::sobel(sigma, valid, field.width, field.height);
    extra.insert(0, ("grad.x", gx));
    extra.insert(1, ("grad.y", gy));
    extra
}

/// Writes the `.vti` (see [`vti`]; `origin` is the centre of voxel (0, 0, 0), `spacing` the voxel
/// size) and, when asked, PNG previews of the middle z-slice (voxel layer `nz / 2`) next to it:
/// `<name>.png` (σ) and `<name>.grad.png` (its gradient).
pub fn write_volume_outputs(
    field: &Field,
    origin: DVec3,
    spacing: DVec3,
    path: &Path,
    png: bool,
) -> Result<(), FileError> {
    write_volume_outputs_with(field, origin, spacing, path, png, &[])
}

/// [`write_volume_outputs`] with extra Float64 arrays (one value per voxel, field order).
pub fn write_volume_outputs_with(
    field: &Field,
    origin: DVec3,
    spacing: DVec3,
    path: &Path,
    png: bool,
    extra: &[(&str, Vec<f64>)],
) -> Result<(), FileError> {
    vti::write_vti_with(path, field, origin, spacing, extra)?;
    if png {
        let (w, h) = (field.width, field.height);
        let layer = &field.cells[(field.depth / 2) * w * h..][..w * h];
        let vals: Vec<_> = layer.iter().map(|c| c.finalize()).collect();
        let sigma: Vec<f64> = vals.iter().map(|v| v.sigma).collect();
        let valid: Vec<bool> = vals.iter().map(|v| v.valid).collect();
        write_previews(path, &sigma, &valid, w, h)?;
    }
    Ok(())
}

/// The PNG previews of a 2D grid of σ next to `path`: `<name>.png` (σ, equalised CIELAB map) and
/// `<name>.grad.png` (gradient direction as hue, magnitude as lightness).
pub fn write_previews(
    path: &Path,
    sigma: &[f64],
    valid: &[bool],
    w: usize,
    h: usize,
) -> Result<(), FileError> {
    let [field, gradient] = preview_paths(path);
    png::write_field_preview(&field, sigma, valid, w, h)?;
    png::write_gradient_preview(&gradient, sigma, valid, w, h)
}

/// Finite f32 for display channels (the field never holds NaN, but f64 → f32 can overflow).
pub fn f32_of(x: f64) -> f32 {
    let y = x as f32;
    if y.is_finite() {
        y
    } else if x > 0.0 {
        f32::MAX
    } else if x < 0.0 {
        f32::MIN
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fresh_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("ftpd3d-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A FIFO at the destination is refused before anything is written (it is never opened, so
    /// nothing blocks) and stays a FIFO; no temporary file is left.
    #[test]
    fn a_fifo_is_never_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let d = fresh_dir("fifo");
        let fifo = d.join("f.exr");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            assert!(std::env::var("CI").is_err(), "mkfifo failed in CI");
            eprintln!("skipped a_fifo_is_never_replaced: mkfifo failed");
            return;
        }
        let mut called = false;
        let r = write_atomically(&fifo, |tmp| {
            called = true;
            Ok(std::fs::write(tmp, b"x")?)
        });
        let e = r.unwrap_err();
        assert!(format!("{e:#}").contains("FIFO"), "{e:#}");
        assert!(!called, "nothing is written");
        let t = std::fs::symlink_metadata(&fifo).unwrap().file_type();
        assert!(t.is_fifo());
        assert_eq!(
            std::fs::read_dir(&d).unwrap().count(),
            1,
            "no temporary left"
        );
        let _ = std::fs::remove_dir_all(&d);
    }

    /// A file under folders that do not exist yet: they are created (every front end's rule).
    #[test]
    fn missing_folders_are_created() {
        let d = fresh_dir("folders");
        let deep = d.join("a/b/c.txt");
        write_atomically(&deep, |tmp| Ok(std::fs::write(tmp, b"x")?)).unwrap();
        assert_eq!(std::fs::read(&deep).unwrap(), b"x");
        let _ = std::fs::remove_dir_all(&d);
    }
}
