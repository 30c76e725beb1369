//! A finished (or read back) field as Python sees it: its channels by the names of the file the
//! command line writes (the EXR's for slices and camera images, the VTI's for volumes), computed
//! by the writers' own steps, so `r["ftpd"]` holds the very values of the file; the run's
//! description (`meta`); `write` and `read`.

use crate::errors::{no_panic, param, to_py};
use ftpd3d::analysis::separatrix::{self, SepParams};
use ftpd3d::app;
use ftpd3d::field::Field as LibField;
use ftpd3d::output::{self, exr, vti};
use ftpd3d::render::Progress;
use ftpd3d::scene::load::extension;
use glam::DVec3;
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::exceptions::PyKeyError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// Per-cell arrays written with a field besides those its sums give (the separatrices', an
/// interrupted pass's).
pub type Extra = Vec<(&'static str, Vec<f64>)>;

/// One channel's values in file order, of the file's type.
#[derive(Clone, Debug)]
enum Data {
    F32(Vec<f32>),
    F64(Vec<f64>),
    U32(Vec<u32>),
    U8(Vec<u8>),
}

/// Channels by name, in the file's order.
type Channels = Vec<(String, Data)>;

/// A volume's lattice: the centre of voxel (0, 0, 0) and the voxel size.
#[derive(Clone, Copy, Debug)]
pub struct Lattice {
    pub origin: DVec3,
    pub spacing: DVec3,
}

/// A field with its channels: what a run returns and `ftpd3d.read` gives back.
#[pyclass(module = "ftpd3d", name = "Field", frozen)]
pub struct Field {
    field: LibField,
    progress: Progress,
    lattice: Option<Lattice>,
    extra: Extra,
    /// Names the field in errors.
    name: PathBuf,
    /// The channels, computed when first asked for: part 0's (or the VTI's arrays), and part 1's
    /// exact counts and sums (not held until asked for by name or listed).
    view: OnceLock<Channels>,
    exact: OnceLock<Channels>,
    shape: Vec<usize>,
    stats: BTreeMap<&'static str, Stat>,
}

/// One of a run's statistics, of its own type.
#[derive(Clone, Debug)]
pub enum Stat {
    Count(u64),
    Seconds(f64),
    Text(String),
}

/// The description's keys whose values are text even where they read as numbers (a camera named
/// `1`, a plane `z=0`).
const TEXT_KEYS: [&str; 16] = [
    "tool",
    "embree",
    "scene",
    "domain",
    "plane",
    "camera",
    "weighting",
    "features",
    "kernel",
    "pairs",
    "guide",
    "schedule",
    "adaptive",
    "stop",
    "merged",
    "budget.time",
];

/// The description's keys whose numbers are counts (int); every other number is a float, so a
/// key's type does not change with its value (an angle of `2` is `2.0`).
const COUNT_KEYS: [&str; 11] = [
    "seed",
    "gradient.replicates",
    "seeds",
    "spp",
    "batches",
    "max_bounces",
    "radiance_bounces",
    "passes",
    "samples",
    "remaining.samples",
    "volume.dims",
];

/// A value of the description as Python sees it: `true`/`false` as bool, a number as int (the
/// keys of [`COUNT_KEYS`]) or float, comma-separated numbers as a tuple, anything else (and every
/// key of [`TEXT_KEYS`]) as the text the header holds.
fn typed<'py>(py: Python<'py>, key: &str, text: &str) -> PyResult<Bound<'py, PyAny>> {
    let counts = COUNT_KEYS.contains(&key);
    let number = |t: &str| -> Option<PyResult<Bound<'py, PyAny>>> {
        if counts {
            let u = t.parse::<u64>().ok()?;
            return Some(
                u.into_pyobject(py)
                    .map(|v| v.into_any())
                    .map_err(Into::into),
            );
        }
        // Only text that looks like a number (not "inf" or "nan" spelt out in a name).
        let looks = t
            .bytes()
            .next()
            .is_some_and(|b| b.is_ascii_digit() || b == b'-' || b == b'.');
        let f = t.parse::<f64>().ok().filter(|_| looks)?;
        Some(
            f.into_pyobject(py)
                .map(|v| v.into_any())
                .map_err(Into::into),
        )
    };
    let as_text = || {
        text.into_pyobject(py)
            .map(|v| v.into_any())
            .map_err(Into::into)
    };
    if TEXT_KEYS.contains(&key) {
        return as_text();
    }
    match text {
        "true" => return Ok(true.into_pyobject(py)?.to_owned().into_any()),
        "false" => return Ok(false.into_pyobject(py)?.to_owned().into_any()),
        _ => {}
    }
    if let Some(n) = number(text) {
        return n;
    }
    if text.contains(',') {
        let parts: Option<Vec<_>> = text.split(',').map(|t| number(t.trim())).collect();
        if let Some(parts) = parts {
            let items = parts.into_iter().collect::<PyResult<Vec<_>>>()?;
            return Ok(pyo3::types::PyTuple::new(py, items)?.into_any());
        }
    }
    as_text()
}

/// `name` with a `'static` lifetime, as the writers take extra arrays' names: names read from
/// files are interned, so each distinct name is kept once for the life of the process.
fn intern(name: &str) -> &'static str {
    static NAMES: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());
    let mut names = NAMES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(n) = names.get(name) {
        return n;
    }
    let leaked: &'static str = Box::leak(name.to_string().into_boxed_str());
    names.insert(leaked);
    leaked
}

impl Field {
    /// The channels of `field` as the command line's file holds them, with `extra`, named in
    /// errors by `name`.
    pub fn new(
        field: LibField,
        progress: Progress,
        lattice: Option<Lattice>,
        extra: Extra,
        name: &Path,
        stats: BTreeMap<&'static str, Stat>,
    ) -> anyhow::Result<Field> {
        let shape = match lattice {
            None => vec![field.height, field.width],
            Some(_) => vec![field.depth, field.height, field.width],
        };
        Ok(Field {
            field,
            progress,
            lattice,
            extra,
            name: name.to_path_buf(),
            view: OnceLock::new(),
            exact: OnceLock::new(),
            shape,
            stats,
        })
    }

    /// Writes the field as the command line does, by the extension of `path`.
    fn write_to(&self, path: &Path, png: bool) -> anyhow::Result<()> {
        let ext = extension(path);
        match (ext.as_deref(), self.lattice) {
            (Some("exr"), None) => {
                app::write_progress_with(&self.field, &self.progress, path, png, self.extra.clone())
            }
            (Some("vti"), Some(l)) => {
                let mut extra = app::progress_arrays(&self.progress);
                extra.extend(self.extra.iter().cloned());
                Ok(output::write_volume_outputs_with(
                    &self.field,
                    l.origin,
                    l.spacing,
                    path,
                    png,
                    &extra,
                )?)
            }
            (Some("png"), None) => {
                let (w, h) = (self.field.width, self.field.height);
                let preview = path.with_extension("exr");
                Ok(output::write_previews(
                    &preview,
                    &self.field.sigma(),
                    &self.field.valid(),
                    w,
                    h,
                )?)
            }
            (Some("png"), Some(_)) => {
                let (w, h, d) = (self.field.width, self.field.height, self.field.depth);
                let layer = &self.field.cells[(d / 2) * w * h..][..w * h];
                let vals: Vec<_> = layer.iter().map(|c| c.finalize()).collect();
                let sigma: Vec<f64> = vals.iter().map(|v| v.sigma).collect();
                let valid: Vec<bool> = vals.iter().map(|v| v.valid).collect();
                Ok(output::write_previews(
                    &path.with_extension("vti"),
                    &sigma,
                    &valid,
                    w,
                    h,
                )?)
            }
            _ => anyhow::bail!("{}: no format for this extension", path.display()),
        }
    }
}

/// Refuses an extension the field cannot be written as.
fn check_extension(path: &Path, volume: bool) -> PyResult<()> {
    match (extension(path).as_deref(), volume) {
        (Some("exr" | "png"), false) | (Some("vti" | "png"), true) => Ok(()),
        (_, false) => Err(param(format!(
            "{}: a slice or camera image is written as .exr (or its previews as .png)",
            path.display()
        ))),
        (_, true) => Err(param(format!(
            "{}: a volume is written as .vti (VTK ImageData), or its middle z layer as .png",
            path.display()
        ))),
    }
}

/// The EXR's part 0 (f32 channels), each in file order.
fn two_d_view(field: &LibField, name: &Path, extra: Extra) -> anyhow::Result<Channels> {
    Ok(output::exr_channels(field, name, extra)?
        .into_iter()
        .map(|(n, v)| (n, Data::F32(v)))
        .collect())
}

/// The EXR's part 1 (exact u32 counts and sums) but the names part 0 already has, in file order.
fn two_d_exact(field: &LibField, name: &Path, view: &[String]) -> anyhow::Result<Channels> {
    Ok(exr::exact_channel_values(name, field)?
        .into_iter()
        .filter(|(n, _)| !view.contains(n))
        .map(|(n, v)| (n, Data::U32(v)))
        .collect())
}

/// The VTI's arrays, each of its VTK type; the shape (nz, ny, nx).
fn volume_channels(
    field: &LibField,
    name: &Path,
    l: Lattice,
    extra: &[(&str, Vec<f64>)],
) -> anyhow::Result<Channels> {
    let arrays = vti::vti_arrays(name, field, l.origin, l.spacing, extra)?;
    let mut out = Vec::new();
    for a in arrays {
        let b = &a.bytes;
        let data = match a.ty {
            "Float32" => Data::F32(
                b.chunks_exact(4)
                    .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            ),
            "Float64" => Data::F64(
                b.chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            ),
            "UInt32" => Data::U32(
                b.chunks_exact(4)
                    .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            ),
            _ => Data::U8(b.clone()),
        };
        let name = if a.components > 1 {
            format!("{}#{}", a.name, a.components)
        } else {
            a.name
        };
        out.push((name, data));
    }
    Ok(out)
}

#[pymethods]
impl Field {
    /// The channel `name` as a new NumPy array shaped like the file: (height, width) for slices
    /// and camera images, row 0 at the top as in the EXR; (nz, ny, nx) for volumes, as in the
    /// VTI (x fastest), with a last axis for arrays of several components. f32 for the EXR's
    /// view channels, uint32 for its exact counts and sums; the VTI's own types.
    fn __getitem__<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let is = |n: &String| n == name || n.split_once('#').is_some_and(|(base, _)| base == name);
        let found = match self.view(py)?.iter().find(|(n, _)| is(n)) {
            Some(c) => Some(c),
            None => self.exact(py)?.iter().find(|(n, _)| is(n)),
        };
        let Some((stored, data)) = found else {
            return Err(PyKeyError::new_err(format!(
                "no channel {name:?}; the channels are: {}",
                self.names(py)?.join(", ")
            )));
        };
        let mut shape = self.shape.clone();
        if let Some((_, comps)) = stored.split_once('#') {
            shape.push(comps.parse().unwrap_or(1));
        }
        let array = match data {
            Data::F32(v) => v.clone().into_pyarray(py).reshape(shape)?.into_any(),
            Data::F64(v) => v.clone().into_pyarray(py).reshape(shape)?.into_any(),
            Data::U32(v) => v.clone().into_pyarray(py).reshape(shape)?.into_any(),
            Data::U8(v) => v.clone().into_pyarray(py).reshape(shape)?.into_any(),
        };
        Ok(array)
    }

    fn __contains__(&self, py: Python<'_>, name: &str) -> PyResult<bool> {
        Ok(self.names(py)?.iter().any(|n| n == name))
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.names(py)?.len())
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyResult<Bound<'_, PyAny>> {
        let names = slf.names(slf.py())?;
        let list = pyo3::types::PyList::new(slf.py(), names)?;
        Ok(list.try_iter()?.into_any())
    }

    /// The channel names, in the file's order (the EXR's part 0, then part 1's others).
    #[getter]
    fn channels(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        self.names(py)
    }

    /// The run's description (`ftpd3d.<key>` attributes of the EXR, the VTI's field data), each
    /// value of its type: numbers as int or float, lists of numbers (a point, a size) as tuples,
    /// flags as bool, the rest (paths, names, the plane) as text. `header` has the text.
    #[getter]
    fn meta<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in &self.field.meta {
            d.set_item(k, typed(py, k, v)?)?;
        }
        Ok(d)
    }

    /// The run's description as the file's header holds it, key to text.
    #[getter]
    fn header<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in &self.field.meta {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    /// What the run did (samples, rays, passes, seconds, why it stopped); empty for a field read
    /// from a file.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (k, v) in &self.stats {
            match v {
                Stat::Count(n) => d.set_item(k, n)?,
                Stat::Seconds(s) => d.set_item(k, s)?,
                Stat::Text(t) => d.set_item(k, t)?,
            }
        }
        Ok(d)
    }

    /// The grid's shape: (height, width), or (nz, ny, nx) for a volume.
    #[getter]
    fn shape(&self) -> Vec<usize> {
        self.shape.clone()
    }

    /// Whether the run stopped before its budget (interrupted, or at a pass limit).
    #[getter]
    fn partial(&self) -> bool {
        self.field.meta.get("partial").is_some_and(|v| v == "true")
    }

    /// Writes the field as the command line does, by extension: `.exr` (slices, camera images)
    /// or `.vti` (volumes), with the PNG previews beside it when `png` is true; `.png` writes the
    /// previews alone (σ at `path`, its gradient at `<name>.grad.png`). Missing folders are created
    /// (as the command line does). Files are written under a temporary name and renamed, so a
    /// failed write leaves no half-written file; a path that is not a regular file (a device, a
    /// FIFO, a directory) is refused, never replaced.
    #[pyo3(signature = (path, png = false))]
    fn write(&self, py: Python<'_>, path: PathBuf, png: bool) -> PyResult<()> {
        check_extension(&path, self.lattice.is_some())?;
        py.detach(|| no_panic(|| self.write_to(&path, png)))
            .map_err(to_py)
    }

    /// A new field with the separatrix channels (`separatrix`, `separatrix.strength`, ...)
    /// extracted from this one, as `separatrices=True` on a run or the command line's
    /// `separatrices` subcommand adds them: significance `threshold` (standard errors), filter
    /// `scale` in cells, strength threshold `tau` in units of σ (None: the defaults).
    #[pyo3(signature = (threshold = SepParams::default().z, scale = None, tau = None))]
    fn separatrices(
        &self,
        py: Python<'_>,
        threshold: f64,
        scale: Option<f64>,
        tau: Option<f64>,
    ) -> PyResult<Field> {
        let params = crate::options::sep_params(threshold, scale, tau)?;
        py.detach(|| {
            no_panic(|| {
                let name = self.field.meta.get("domain").cloned().unwrap_or_default();
                let (sep, _) = separatrix::of_field(&self.field, &name, &params)?;
                let mut extra: Extra = self
                    .extra
                    .iter()
                    .filter(|(n, _)| !n.starts_with("separatrix"))
                    .cloned()
                    .collect();
                extra.extend(sep.arrays());
                Field::new(
                    self.field.clone(),
                    self.progress.clone(),
                    self.lattice,
                    extra,
                    Path::new(&name),
                    self.stats.clone(),
                )
            })
        })
        .map_err(to_py)
    }

    fn __repr__(&self) -> String {
        let dims = self
            .shape
            .iter()
            .map(|d| d.to_string())
            .collect::<Vec<_>>()
            .join("x");
        let what = self.field.meta.get("domain").cloned().unwrap_or_default();
        format!(
            "<ftpd3d.Field {what} {dims}{}>",
            if self.partial() { ", partial" } else { "" }
        )
    }
}

impl Field {
    /// Part 0's channels (the VTI's arrays for a volume), computed on first use.
    fn view(&self, py: Python<'_>) -> PyResult<&Channels> {
        if let Some(c) = self.view.get() {
            return Ok(c);
        }
        let mut all = app::progress_arrays(&self.progress);
        all.extend(self.extra.iter().cloned());
        let made = py
            .detach(|| {
                no_panic(|| match self.lattice {
                    None => two_d_view(&self.field, &self.name, all),
                    Some(l) => volume_channels(&self.field, &self.name, l, &all),
                })
            })
            .map_err(to_py)?;
        Ok(self.view.get_or_init(|| made))
    }

    /// Part 1's channels but those part 0 names (none for a volume), computed on first use.
    fn exact(&self, py: Python<'_>) -> PyResult<&Channels> {
        if let Some(c) = self.exact.get() {
            return Ok(c);
        }
        let made = match self.lattice {
            Some(_) => Vec::new(),
            None => {
                let view: Vec<String> = self.view(py)?.iter().map(|(n, _)| n.clone()).collect();
                py.detach(|| no_panic(|| two_d_exact(&self.field, &self.name, &view)))
                    .map_err(to_py)?
            }
        };
        Ok(self.exact.get_or_init(|| made))
    }

    fn names(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        let view = self.view(py)?;
        let exact = self.exact(py)?;
        Ok(view
            .iter()
            .chain(exact)
            .map(|(n, _)| n.split_once('#').map_or(n.as_str(), |(b, _)| b).to_string())
            .collect())
    }
}

/// Reads a field ftpd3d wrote (`.exr` slice or camera image, `.vti` volume) into the same object
/// a run returns, with the channels the sums do not give back (separatrices, an interrupted
/// pass's) kept as they were.
#[pyfunction]
pub fn read(py: Python<'_>, path: PathBuf) -> PyResult<Field> {
    py.detach(|| no_panic(|| read_file(&path))).map_err(to_py)
}

fn read_file(path: &Path) -> anyhow::Result<Field> {
    if !path.is_file() {
        return Err(anyhow::Error::new(ftpd3d::output::FileError::Read {
            path: path.to_path_buf(),
            source: std::io::Error::from(std::io::ErrorKind::NotFound),
        }));
    }
    if extension(path).as_deref() == Some("vti") {
        let v = vti::read_vti(path)?;
        let extra = v
            .extra
            .iter()
            .map(|(n, a)| (intern(n), a.clone()))
            .collect();
        let lattice = Lattice {
            origin: v.origin,
            spacing: v.spacing,
        };
        return Field::new(
            v.field,
            Progress::default(),
            Some(lattice),
            extra,
            path,
            BTreeMap::new(),
        );
    }
    let field = exr::read_exr(path)?;
    let computed: BTreeSet<String> = output::exr_channels(&field, path, Vec::new())?
        .into_iter()
        .map(|(n, _)| n)
        .collect();
    let extra = exr::read_f32_channels(path)?
        .into_iter()
        .filter(|(n, _)| !computed.contains(n))
        .map(|(n, v)| (intern(&n), v.into_iter().map(f64::from).collect()))
        .collect();
    Field::new(
        field,
        Progress::default(),
        None,
        extra,
        path,
        BTreeMap::new(),
    )
}
