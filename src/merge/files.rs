//! Merging files: EXR fields or VTI volumes, told apart by their extension, read, merged and
//! written in the same format.

use super::{MergeError, Merged, check_same_run, merge_fields};
use crate::output::{self, vti::Vti};
use std::path::{Path, PathBuf};

/// What `merge` reads and writes, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    /// 2D fields (slices, camera images): OpenEXR.
    Exr,
    /// Volumes: VTK XML ImageData.
    Vti,
}

impl Format {
    fn of(path: &Path) -> Option<Format> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("exr") => Some(Format::Exr),
            Some("vti") => Some(Format::Vti),
            _ => None,
        }
    }

    fn describe(self) -> &'static str {
        match self {
            Format::Exr => "an .exr field",
            Format::Vti => "a .vti volume",
        }
    }

    fn ext(self) -> &'static str {
        match self {
            Format::Exr => "exr",
            Format::Vti => "vti",
        }
    }
}

/// Checks that volume `b` (from `b_name`) lies on the same points as `a`: the same `Origin` and
/// `Spacing`, exactly (both are written as the shortest decimal that reads back as the same f64).
fn check_same_grid(a_name: &str, a: &Vti, b_name: &str, b: &Vti) -> Result<(), MergeError> {
    for (key, x, y) in [
        ("Origin", a.origin, b.origin),
        ("Spacing", a.spacing, b.spacing),
    ] {
        if x != y {
            return Err(MergeError::GridDiffers {
                file: b_name.to_string(),
                key,
                value: y,
                other: a_name.to_string(),
                other_value: x,
            });
        }
    }
    Ok(())
}

/// The one format of `inputs`, which `output` must have too.
fn format_of_all(inputs: &[PathBuf], output: &Path) -> Result<Format, MergeError> {
    let Some(first) = inputs.first() else {
        return Err(MergeError::NoFiles);
    };
    let format_of = |p: &Path| {
        Format::of(p).ok_or_else(|| MergeError::UnknownFormat {
            path: p.to_path_buf(),
        })
    };
    let format = format_of(first)?;
    for p in &inputs[1..] {
        let f = format_of(p)?;
        if f != format {
            return Err(MergeError::MixedFormats {
                path: p.clone(),
                kind: f.describe(),
                first: first.clone(),
                first_kind: format.describe(),
            });
        }
    }
    if Format::of(output) != Some(format) {
        return Err(MergeError::OutputFormat {
            output: output.to_path_buf(),
            ext: format.ext(),
        });
    }
    Ok(format)
}

/// Reads EXR fields or VTI volumes (all of one kind, told by the extension), merges them
/// ([`merge_fields`]) and writes the result in the same format to `output` (whose extension must
/// match), with fresh σ, standard error, gradient and (when `png`) previews (of the middle z-layer
/// for volumes). Input names in messages are the paths as given.
pub fn merge_files(inputs: &[PathBuf], output: &Path, png: bool) -> anyhow::Result<Merged> {
    let format = format_of_all(inputs, output)?;
    output::check_writable_with_previews(output, png)?;
    for p in inputs {
        if !p.exists() {
            return Err(MergeError::NoSuchFile { path: p.clone() }.into());
        }
    }
    let name = |p: &PathBuf| p.display().to_string();
    match format {
        Format::Exr => {
            let fields = inputs
                .iter()
                .map(|p| Ok((name(p), output::exr::read_exr(p)?)))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let merged = merge_fields(fields)?;
            output::write_outputs(&merged.field, output, png)?;
            Ok(merged)
        }
        Format::Vti => {
            let volumes = inputs
                .iter()
                .map(|p| Ok((name(p), output::vti::read_vti(p)?)))
                .collect::<anyhow::Result<Vec<_>>>()?;
            let (first_name, head) = &volumes[0];
            for (n, v) in &volumes[1..] {
                check_same_run(first_name, &head.field, n, &v.field)?;
                check_same_grid(first_name, head, n, v)?;
            }
            let (origin, spacing) = (head.origin, head.spacing);
            let merged = merge_fields(volumes.into_iter().map(|(n, v)| (n, v.field)).collect())?;
            output::write_volume_outputs(&merged.field, origin, spacing, output, png)?;
            Ok(merged)
        }
    }
}
