//! The `.vti` writer: the arrays of a field, the XML header that lists them, and the appended data
//! streamed cell by cell.

use super::base64::{B64, b64_len};
use super::{comment_escape, gradient_magnitude};
use crate::field::Field;
use crate::ftpd::Weighting;
use crate::ftpd::moments::{CellValue, Moments};
use crate::output::exact::{EXACT, EXACT_COMP, shift_columns};
use crate::output::{FileError, f32_of, write_file_atomically};
use glam::DVec3;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// Writes a volume (`field.depth` ≥ 1 layers of `width` × `height` voxels) with the first point at
/// `origin` (the centre of voxel (0, 0, 0)) and `spacing` between points. Written to a temporary
/// name, then renamed.
pub fn write_vti(
    path: &Path,
    field: &Field,
    origin: DVec3,
    spacing: DVec3,
) -> Result<(), FileError> {
    write_vti_with(path, field, origin, spacing, &[])
}

/// [`write_vti`] with extra Float64 arrays (one value per voxel, field order), read back exactly
/// into [`Vti::extra`](super::Vti::extra): a partial run's `pass.done` and `pass.units`, which a
/// resumed run needs.
pub fn write_vti_with(
    path: &Path,
    field: &Field,
    origin: DVec3,
    spacing: DVec3,
    extra: &[(&str, Vec<f64>)],
) -> Result<(), FileError> {
    let n = check_volume(path, field, origin, spacing)?;
    let derived = Derived::of(path, field, spacing)?;
    let arrays = derived.arrays(path, field, extra, n)?;
    let dims = [field.width, field.height, field.depth];
    let header = header(dims, origin, spacing, &field.meta, &arrays, n);
    write_file_atomically(path, |tmp| {
        write_file(tmp, &header, &arrays, n).map_err(|source| FileError::write(path, source))
    })
}

/// One array of a `.vti` as [`write_vti_with`] stores it: its name, VTK type (`Float32`,
/// `Float64`, `UInt32`, `UInt8`), components per voxel, and the little-endian bytes of every
/// voxel in point order (x fastest, then y, then z).
#[derive(Clone, Debug, PartialEq)]
pub struct VtiArray {
    pub name: String,
    pub ty: &'static str,
    pub components: usize,
    pub bytes: Vec<u8>,
}

/// Every array that [`write_vti_with`] writes for `field`, `spacing` and `extra`, in the file's
/// order, computed by the writer's own steps: what a front end shows as the file's arrays without
/// writing it. Holds every array in memory at once (the writer streams them); `path` names the
/// volume in errors.
pub fn vti_arrays(
    path: &Path,
    field: &Field,
    origin: DVec3,
    spacing: DVec3,
    extra: &[(&str, Vec<f64>)],
) -> Result<Vec<VtiArray>, FileError> {
    let n = check_volume(path, field, origin, spacing)?;
    let derived = Derived::of(path, field, spacing)?;
    let arrays = derived.arrays(path, field, extra, n)?;
    Ok(arrays
        .iter()
        .map(|a| {
            let mut bytes = Vec::with_capacity(a.bytes(n) as usize);
            for i in 0..n {
                (a.put)(i, &mut bytes);
            }
            VtiArray {
                name: a.name.clone(),
                ty: a.ty,
                components: a.comps,
                bytes,
            }
        })
        .collect())
}

/// What the arrays are computed from besides the sums: the finalised values, the gradient
/// magnitude, and whether the run was radiance-weighted (else `fluence` is zeros).
struct Derived {
    vals: Vec<CellValue>,
    grad: Vec<f32>,
    radiance: bool,
}

impl Derived {
    fn of(path: &Path, field: &Field, spacing: DVec3) -> Result<Derived, FileError> {
        let dims = [field.width, field.height, field.depth];
        let vals = field.values();
        let grad = gradient_magnitude(&vals, dims, spacing);
        let info = field.info(&path.display().to_string())?;
        Ok(Derived {
            vals,
            grad,
            radiance: info.weighting == Some(Weighting::Radiance),
        })
    }

    /// The arrays of the file: the view, the exact sums (a gradient-domain run's replayed sums
    /// among them), then `extra` (each checked to hold one value per voxel of the `n`).
    fn arrays<'a>(
        &'a self,
        path: &Path,
        field: &'a Field,
        extra: &'a [(&str, Vec<f64>)],
        n: usize,
    ) -> Result<Vec<Array<'a>>, FileError> {
        let mut arrays = view_arrays(&field.cells, &self.vals, &self.grad, self.radiance);
        arrays.extend(exact_arrays(&field.cells));
        // A gradient-domain run's replayed sums, read in place as the file is streamed.
        for c in shift_columns(path, field)? {
            arrays.push(f64_array(format!("exact.{}", c.name), move |i| c.value(i)));
        }
        for (name, values) in extra {
            if values.len() != n {
                return Err(FileError::unfit(
                    path,
                    format!("array '{name}' has {} values for {n} voxels", values.len()),
                ));
            }
            arrays.push(f64_array(name.to_string(), |i| values[i]));
        }
        Ok(arrays)
    }
}

/// The number of voxels, once the field is a whole grid on a valid lattice whose counts fit the
/// file's UInt32 arrays.
fn check_volume(
    path: &Path,
    field: &Field,
    origin: DVec3,
    spacing: DVec3,
) -> Result<usize, FileError> {
    let dims = [field.width, field.height, field.depth];
    let n = dims.iter().product::<usize>();
    if n == 0 || n != field.cells.len() {
        return Err(FileError::unfit(
            path,
            format!(
                "a {}x{}x{} volume with {} cells",
                dims[0],
                dims[1],
                dims[2],
                field.cells.len()
            ),
        ));
    }
    if !(origin.is_finite() && spacing.is_finite() && spacing.min_element() > 0.0) {
        return Err(FileError::unfit(
            path,
            format!("origin {origin} and spacing {spacing} must be finite, spacing > 0"),
        ));
    }
    if let Some(c) = field.cells.iter().find(|c| c.n > u32::MAX as u64) {
        return Err(FileError::unfit(
            path,
            format!(
                "a voxel holds {} samples, more than the UInt32 'samples' array can count",
                c.n
            ),
        ));
    }
    Ok(n)
}

/// Appends the little-endian bytes of one cell's value(s).
type PutCell<'a> = Box<dyn Fn(usize, &mut Vec<u8>) + 'a>;

/// One array of the file: name, VTK type, components, bytes per component, and the bytes of a cell.
struct Array<'a> {
    name: String,
    ty: &'static str,
    comps: usize,
    size: usize,
    put: PutCell<'a>,
}

impl Array<'_> {
    fn bytes(&self, cells: usize) -> u64 {
        (cells * self.comps * self.size) as u64
    }
}

fn f32_array<'a>(name: &str, f: impl Fn(usize) -> f64 + 'a) -> Array<'a> {
    Array {
        name: name.into(),
        ty: "Float32",
        comps: 1,
        size: 4,
        put: Box::new(move |i, b| b.extend_from_slice(&f32_of(f(i)).to_le_bytes())),
    }
}

fn u32_array<'a>(name: &str, f: impl Fn(usize) -> u32 + 'a) -> Array<'a> {
    Array {
        name: name.into(),
        ty: "UInt32",
        comps: 1,
        size: 4,
        put: Box::new(move |i, b| b.extend_from_slice(&f(i).to_le_bytes())),
    }
}

fn f64_array<'a>(name: String, f: impl Fn(usize) -> f64 + 'a) -> Array<'a> {
    Array {
        name,
        ty: "Float64",
        comps: 1,
        size: 8,
        put: Box::new(move |i, b| b.extend_from_slice(&f(i).to_le_bytes())),
    }
}

/// The arrays a viewer reads, and the counts: σ (the active scalars), its error, the moments of
/// Δ, the weight, the fluence (zeros unless radiance-weighted), the gradient magnitude, validity,
/// and the sample, batch and group counts.
fn view_arrays<'a>(
    cells: &'a [Moments],
    v: &'a [CellValue],
    grad: &'a [f32],
    radiance: bool,
) -> Vec<Array<'a>> {
    vec![
        f32_array("ftpd", |i| v[i].sigma),
        f32_array("ftpd.stderr", |i| v[i].stderr),
        f32_array("ftpd.relerr", |i| v[i].relative_error()),
        f32_array("ftpd.mean", |i| v[i].mean),
        f32_array("ftpd.m2", |i| v[i].m2),
        f32_array("weight", |i| v[i].weight),
        Array {
            name: "fluence".into(),
            ty: "Float32",
            comps: 3,
            size: 4,
            put: Box::new(move |i, b| {
                let f = if radiance {
                    cells[i].fluence()
                } else {
                    DVec3::ZERO
                };
                for x in f.to_array() {
                    b.extend_from_slice(&f32_of(x).to_le_bytes());
                }
            }),
        },
        Array {
            name: "grad.mag".into(),
            ty: "Float32",
            comps: 1,
            size: 4,
            put: Box::new(|i, b| b.extend_from_slice(&grad[i].to_le_bytes())),
        },
        Array {
            name: "valid".into(),
            ty: "UInt8",
            comps: 1,
            size: 1,
            put: Box::new(|i, b| b.push(v[i].valid as u8)),
        },
        u32_array("samples", |i| cells[i].n as u32),
        u32_array("batches", |i| cells[i].batches.min(u32::MAX as u64) as u32),
        u32_array("groups", |i| cells[i].groups as u32),
    ]
}

/// Every exact sum as Float64, bit for bit, then the compensations of the weighted sums, so that
/// volumes merge and resume exactly.
fn exact_arrays(cells: &[Moments]) -> impl Iterator<Item = Array<'_>> {
    EXACT
        .iter()
        .chain(EXACT_COMP)
        .map(move |&(name, get, _)| f64_array(format!("exact.{name}"), move |i| get(&cells[i])))
}

/// Streams the header and the appended data of every array to `tmp`, in pieces of about 64 KiB,
/// and syncs the file.
fn write_file(tmp: &Path, header: &str, arrays: &[Array], n: usize) -> std::io::Result<()> {
    let file = std::fs::File::create(tmp)?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
    w.write_all(header.as_bytes())?;
    let (mut raw, mut text) = (Vec::with_capacity(1 << 16), Vec::with_capacity(1 << 17));
    for a in arrays {
        let mut enc = B64::default();
        enc.push(&a.bytes(n).to_le_bytes(), &mut text);
        for i in 0..n {
            (a.put)(i, &mut raw);
            if raw.len() >= 1 << 16 {
                enc.push(&raw, &mut text);
                raw.clear();
                w.write_all(&text)?;
                text.clear();
            }
        }
        enc.push(&raw, &mut text);
        raw.clear();
        enc.finish(&mut text);
        w.write_all(&text)?;
        text.clear();
    }
    w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")?;
    w.into_inner().map_err(|e| e.into_error())?.sync_all()
}

/// `x y z` with the shortest decimal that reads back as the same f64.
fn triple(v: DVec3) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

/// Everything before the first appended byte, ending in `_`.
fn header(
    dims: [usize; 3],
    origin: DVec3,
    spacing: DVec3,
    meta: &BTreeMap<String, String>,
    arrays: &[Array],
    cells: usize,
) -> String {
    let extent = format!("0 {} 0 {} 0 {}", dims[0] - 1, dims[1] - 1, dims[2] - 1);
    let mut h = String::new();
    h.push_str("<?xml version=\"1.0\"?>\n");
    h.push_str(
        "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n",
    );
    for (k, v) in meta {
        let _ = writeln!(
            h,
            "  <!-- ftpd3d {}={} -->",
            comment_escape(k),
            comment_escape(v)
        );
    }
    let _ = writeln!(
        h,
        "  <ImageData WholeExtent=\"{extent}\" Origin=\"{}\" Spacing=\"{}\">",
        triple(origin),
        triple(spacing)
    );
    let _ = writeln!(h, "    <Piece Extent=\"{extent}\">");
    h.push_str("      <PointData Scalars=\"ftpd\">\n");
    let mut offset = 0u64;
    for a in arrays {
        let comps = if a.comps > 1 {
            format!(" NumberOfComponents=\"{}\"", a.comps)
        } else {
            String::new()
        };
        let _ = writeln!(
            h,
            "        <DataArray type=\"{}\" Name=\"{}\"{comps} format=\"appended\" offset=\"{offset}\">\
             </DataArray>",
            a.ty, a.name
        );
        offset += b64_len(8 + a.bytes(cells));
    }
    h.push_str("      </PointData>\n    </Piece>\n  </ImageData>\n");
    h.push_str("  <AppendedData encoding=\"base64\">\n   _");
    h
}
