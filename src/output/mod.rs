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

pub use error::{FileError, OutputError};

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

/// Runs `write` on a temporary path and renames the result to `path`; removes the temporary file
/// when writing fails. `write`'s errors come back as they are (the writers of this room name
/// `path` in them, not the temporary name); a failed rename is [`FileError::Rename`].
pub fn write_file_atomically<E: From<FileError>>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    let tmp = temp_path(path);
    if let Ok(mut list) = IN_PROGRESS.lock() {
        list.push(tmp.clone());
    }
    let result = write(&tmp);
    if let Ok(mut list) = IN_PROGRESS.lock() {
        list.retain(|p| p != &tmp);
    }
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

/// Fails early when `path`'s directory cannot take a new file (before hours of work).
pub fn check_writable(path: &Path) -> Result<(), OutputError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let path_buf = path.to_path_buf();
    std::fs::create_dir_all(&dir).map_err(|source| OutputError::CreateDir {
        path: path_buf.clone(),
        dir: dir.clone(),
        source,
    })?;
    if path.is_dir() {
        return Err(OutputError::IsDirectory { path: path_buf });
    }
    let probe = temp_path(path);
    std::fs::write(&probe, b"").map_err(|source| OutputError::NotWritable {
        path: path_buf,
        dir: dir.clone(),
        source,
    })?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
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
    png::write_field_preview(&path.with_extension("png"), sigma, valid, w, h)?;
    png::write_gradient_preview(&path.with_extension("grad.png"), sigma, valid, w, h)
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
