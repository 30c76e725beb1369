//! A field's separatrices end to end: where its cells lie in the scene, extraction from a field,
//! and the files written beside it.

use super::{
    Grid, SepParams, Separatrices, SeparatrixError, extract, surface, write_overlay_png, write_svg,
    write_vtp,
};
use crate::field::Field;
use anyhow::Context;
use glam::DVec3;
use std::path::Path;

/// Where a field's cells are in the scene.
#[derive(Clone, Debug)]
pub enum Placement {
    /// A slice: corner, axes (unit), size; cells w × h.
    Plane {
        origin: DVec3,
        u: DVec3,
        v: DVec3,
        size: (f64, f64),
    },
    /// A volume: the centre of voxel (0, 0, 0), the voxel size.
    Volume { origin: DVec3, spacing: DVec3 },
    /// A camera image (or a field without a plane): pixel coordinates, z = 0.
    Pixels,
}

impl Placement {
    /// The placement a field's description gives (`file` names it in errors).
    pub fn of_field(field: &Field, file: &str) -> anyhow::Result<Placement> {
        let info = field.info(file)?;
        Ok(if field.depth > 1 {
            match info.volume {
                Some(v) => Placement::Volume {
                    origin: v.min + 0.5 * v.spacing,
                    spacing: v.spacing,
                },
                None => Placement::Volume {
                    origin: DVec3::ZERO,
                    spacing: DVec3::ONE,
                },
            }
        } else {
            match info.plane {
                Some(p) if p.size.0 > 0.0 && p.size.1 > 0.0 => Placement::Plane {
                    origin: p.origin,
                    u: p.u,
                    v: p.v,
                    size: p.size,
                },
                _ => Placement::Pixels,
            }
        })
    }

    /// Cell size per axis in scene units.
    pub fn cell(&self, dims: [usize; 3]) -> [f64; 3] {
        match self {
            Placement::Plane { size, .. } => [
                size.0 / dims[0].max(1) as f64,
                size.1 / dims[1].max(1) as f64,
                1.0,
            ],
            Placement::Volume { spacing, .. } => spacing.to_array(),
            Placement::Pixels => [1.0; 3],
        }
    }

    /// Scene position of grid coordinates (2D: cell units from the lower-left corner; 3D: voxel
    /// index units, voxel centres at integers).
    pub fn position(&self, dims: [usize; 3], p: [f64; 3]) -> DVec3 {
        match self {
            Placement::Plane { origin, u, v, size } => {
                *origin
                    + *u * (p[0] / dims[0].max(1) as f64 * size.0)
                    + *v * (p[1] / dims[1].max(1) as f64 * size.1)
            }
            Placement::Volume { origin, spacing } => *origin + *spacing * DVec3::from_array(p),
            Placement::Pixels => DVec3::new(p[0], p[1], 0.0),
        }
    }
}

/// Extracts the separatrices of `field` (`file` names it in errors).
pub fn of_field(
    field: &Field,
    file: &str,
    params: &SepParams,
) -> anyhow::Result<(Separatrices, Placement)> {
    let placement = Placement::of_field(field, file)?;
    let grid = Grid::of_field(
        field,
        placement.cell([field.width, field.height, field.depth]),
    );
    let sep = extract(&grid, params).with_context(|| format!("{file}: separatrices"))?;
    Ok((sep, placement))
}

/// The files written beside an output `path`: `<name>.sep.vtp` (lines, or a volume's surface),
/// and for 2D fields `<name>.sep.svg` and `<name>.sep.png` (σ with the lines over it).
pub fn side_paths(path: &Path, volume: bool) -> Vec<std::path::PathBuf> {
    let mut out = vec![path.with_extension("sep.vtp")];
    if !volume {
        out.push(path.with_extension("sep.svg"));
        out.push(path.with_extension("sep.png"));
    }
    out
}

/// Writes the side files of [`side_paths`] for `sep` beside `path`.
pub fn write_side_files(
    path: &Path,
    field: &Field,
    sep: &Separatrices,
    placement: &Placement,
) -> anyhow::Result<()> {
    let dims = sep.dims;
    let files = side_paths(path, dims[2] > 1);
    if dims[2] > 1 {
        let mesh = surface(sep);
        let pts: Vec<DVec3> = mesh
            .points
            .iter()
            .map(|p| placement.position(dims, *p))
            .collect();
        write_vtp(&files[0], &[], Some((&pts, &mesh.triangles)))?;
        return Ok(());
    }
    let lines: Vec<_> = sep
        .lines
        .iter()
        .map(|l| {
            (
                l.kind,
                l.points
                    .iter()
                    .map(|p| placement.position(dims, [p[0], p[1], 0.0]))
                    .collect(),
                l.strength.clone(),
                l.z.clone(),
            )
        })
        .collect();
    write_vtp(&files[0], &lines, None)?;
    write_svg(&files[1], sep)?;
    let grid_sigma = Grid::of_field(field, [1.0; 3]);
    write_overlay_png(&files[2], &grid_sigma.sigma, &grid_sigma.valid, sep)
}

/// What [`rerun`] wrote.
#[derive(Clone, Debug)]
pub struct Rerun {
    pub summary: String,
    /// The field first, then the side files.
    pub files: Vec<std::path::PathBuf>,
    pub separatrices: Separatrices,
}

/// `ftpd3d separatrices`: reads a finished (or merged) field, extracts its separatrices with
/// `params` and writes the field again with the `separatrix*` channels (its sums unchanged, so it
/// still merges) to `output` [default: `<input name>_sep.<ext>`], with the side files beside it.
pub fn rerun(
    input: &Path,
    output: Option<&Path>,
    params: &SepParams,
    png: bool,
) -> anyhow::Result<Rerun> {
    use crate::output;
    let ext = crate::scene::load::extension(input).unwrap_or_default();
    let volume = match ext.as_str() {
        "exr" => false,
        "vti" => true,
        _ => {
            return Err(SeparatrixError::NotAField {
                path: input.to_path_buf(),
            }
            .into());
        }
    };
    let out = match output {
        Some(p) => p.to_path_buf(),
        None => {
            let stem = input
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "field".into());
            input.with_file_name(format!("{stem}_sep.{ext}"))
        }
    };
    if crate::scene::load::extension(&out).as_deref() != Some(ext.as_str()) {
        return Err(SeparatrixError::OutputFormat {
            output: out,
            input: input.to_path_buf(),
            ext,
        }
        .into());
    }
    output::check_writable(&out)?;
    let name = input.display().to_string();
    let (field, placement, origin_spacing) = if volume {
        let v = output::vti::read_vti(input)?;
        let placement = Placement::Volume {
            origin: v.origin,
            spacing: v.spacing,
        };
        (v.field, placement, Some((v.origin, v.spacing)))
    } else {
        let f = output::exr::read_exr(input)?;
        let placement = Placement::of_field(&f, &name)?;
        (f, placement, None)
    };
    let dims = [field.width, field.height, field.depth];
    let grid = Grid::of_field(&field, placement.cell(dims));
    let sep = extract(&grid, params).with_context(|| format!("{name}: separatrices"))?;
    let arrays = sep.arrays();
    match origin_spacing {
        Some((origin, spacing)) => {
            output::write_volume_outputs_with(&field, origin, spacing, &out, png, &arrays)?
        }
        None => output::write_outputs_with(&field, &out, png, arrays)?,
    }
    write_side_files(&out, &field, &sep, &placement)?;
    let mut files = vec![out.clone()];
    files.extend(side_paths(&out, volume));
    Ok(Rerun {
        summary: sep.summary(),
        files,
        separatrices: sep,
    })
}
