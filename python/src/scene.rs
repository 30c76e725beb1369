//! `ftpd3d.Scene`: a loaded scene with the lights added to it, and its runs (slices, flatland
//! slices, camera images, volumes) as the command line runs them: the same resolution of the
//! domain, the same estimator settings and description, the same driver ([`run_domain`]), so the
//! same field bit for bit.
//!
//! [`run_domain`]: ftpd3d::app::run_domain

use crate::errors::{no_panic, param, to_py};
use crate::keywords::RunKeywords;
use crate::options::{self, LightArgs, Vec3};
use crate::result::{Extra, Field, Lattice, Stat};
use crate::run::{self, Report, RunInput};
use ftpd3d::analysis::separatrix;
use ftpd3d::app::{self, JobDomain};
use ftpd3d::domain::slice::{SliceArg, resolve_plane};
use ftpd3d::domain::volume::Volume;
use ftpd3d::domain::{CameraView, MAX_RES, VolumeRes};
use ftpd3d::ftpd::Weighting;
use ftpd3d::params::EstimatorArgs;
use ftpd3d::scene::load::{LoadOptions, load_scene_with};
use ftpd3d::scene::sidecar::{CameraSpec, camera_of};
use ftpd3d::scene::{Light, Scene as LibScene};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};

/// A sun: the direction towards it, its irradiance, and optionally its angular diameter.
#[derive(FromPyObject)]
pub enum Sun {
    WithDiameter(Vec3, Vec3, f64),
    Plain(Vec3, Vec3),
}

/// One sun or a list of them.
#[derive(FromPyObject)]
pub enum Suns {
    Many(Vec<Sun>),
    One(Sun),
}

/// The forms `sun` takes, as its errors name them.
const SUN_FORM: &str = "((x, y, z), (r, g, b)) (the direction towards the sun and its \
                        irradiance), ((x, y, z), (r, g, b), diameter in degrees), or a list of them";

/// The value of keyword `name` as `T`, or a `TypeError` naming the keyword, the `form` it takes
/// and what was given (rather than PyO3's account of the types it tried).
fn keyword<'py, T: for<'a> FromPyObject<'a, 'py>>(
    value: &Bound<'py, PyAny>,
    name: &str,
    form: &str,
) -> PyResult<T> {
    value.extract::<T>().map_err(|_| {
        let given = value.repr().map(|r| r.to_string()).unwrap_or_default();
        pyo3::exceptions::PyTypeError::new_err(format!(
            "Scene() argument '{name}': expected {form}; got {given}"
        ))
    })
}

/// An environment map: its file, or (file, scale) or (file, scale, rotation in degrees).
#[derive(FromPyObject)]
pub enum Env {
    Rotated(PathBuf, f64, f64),
    Scaled(PathBuf, f64),
    File(PathBuf),
}

/// A volume's resolution: voxels along the longest side, or (nx, ny, nz).
#[derive(FromPyObject)]
pub enum VolRes {
    Dims(i64, i64, i64),
    Longest(i64),
}

/// Where a run's samples start, before it is resolved against the scene.
enum DomainSpec {
    Slice {
        arg: SliceArg,
        window: Option<[f64; 4]>,
        res: usize,
    },
    Camera {
        which: Which,
        size: (usize, usize),
    },
    Volume {
        res: VolumeRes,
        bbox: Option<[f64; 6]>,
    },
}

/// A camera of the scene file (by name or index, `None`: the first), or one placed by eye and
/// target.
enum Which {
    Scene(Option<String>),
    Placed {
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        fov: f64,
    },
}

/// A scene loaded from an OBJ (with its MTL), glTF/GLB or sidecar TOML file, with the lights
/// added to the file's.
#[pyclass(module = "ftpd3d", name = "Scene", frozen)]
pub struct Scene {
    path: PathBuf,
    lights: Vec<Light>,
    inner: Mutex<LibScene>,
    warnings: Vec<String>,
}

impl Scene {
    fn lock(&self) -> MutexGuard<'_, LibScene> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Runs `spec` as the command line would, returning the field with its channels.
    fn run(
        &self,
        py: Python<'_>,
        spec: DomainSpec,
        kw: RunKeywords<'_>,
        flatland: bool,
    ) -> PyResult<Field> {
        let RunKeywords {
            est,
            sampling,
            sep,
            progress,
        } = kw;
        let camera_run = matches!(spec, DomainSpec::Camera { .. });
        if camera_run != (est.weighting == Weighting::Importance) {
            return Err(param(if camera_run {
                "weighting: camera images are importance-weighted (pairs start along the pixel \
                 rays); leave weighting out or give \"importance\""
            } else {
                "weighting=\"importance\" needs a camera (Scene.camera); slices and volumes take \
                 \"radiance\" or \"unweighted\""
            }));
        }
        let opts = sampling.sampling()?.render_options();
        let args = est.args();
        let mut scene = self.lock();
        // A flatland run prepares the scene for its plane; any other run starts from the scene as
        // loaded, as a new process would.
        scene.flat = None;
        let domain = resolve(&scene, spec, &args)?;
        let params = domain.params(&mut scene, &args, flatland).map_err(to_py)?;
        let info = app::describe_domain(&scene, &domain, &params, &opts, &self.lights);
        // The header a write would hold is checked now, so that nothing can fail after the run.
        ftpd3d::output::exr::check_header(
            std::path::Path::new(&domain.name()),
            &info.to_attributes(),
        )
        .map_err(|e| to_py(e.into()))?;
        let (w, h, d) = domain.dims();
        let total = opts
            .budget
            .cap_spp
            .then(|| opts.active_cells(w, h, d).len() as u64 * opts.spp as u64);
        let name = domain.name();
        let report = Report::new(py, progress.as_ref(), total, &name)?;
        let input = RunInput {
            scene: &scene,
            domain: &domain,
            params: &params,
            opts: &opts,
            info,
        };
        let done = run::run(py, input, &report, total)?;
        if done.none_deflected() {
            warn(
                py,
                &format!(
                    "no pair was deflected: every walk ran straight for its whole run length (T \
                     in [{:.4}, {:.4}]) without reaching any geometry, so the field is 0 \
                     everywhere; give longer run lengths t0/t1 (the scene's diagonal is {:.4})",
                    params.t0,
                    params.t1,
                    scene.extent()
                ),
            )?;
        }
        drop(scene);
        let path = PathBuf::from(&name);
        let extra: Extra = match &sep {
            None => Vec::new(),
            Some(sp) => {
                let (s, _) = py
                    .detach(|| no_panic(|| separatrix::of_field(&done.field, &name, sp)))
                    .map_err(to_py)?;
                s.arrays()
            }
        };
        let lattice = match &domain {
            JobDomain::Volume(v) => Some(Lattice {
                origin: v.vtk_origin(),
                spacing: v.spacing,
            }),
            _ => None,
        };
        let s = &done.stats;
        let stats = BTreeMap::from([
            ("samples", Stat::Count(s.samples)),
            ("rays", Stat::Count(s.rays)),
            ("capped", Stat::Count(s.capped)),
            ("clamped", Stat::Count(s.clamped)),
            ("seconds", Stat::Seconds(s.seconds)),
            ("passes", Stat::Count(s.passes.into())),
            ("stop", Stat::Text(s.stop.to_string())),
        ]);
        py.detach(|| Field::new(done.field, done.progress, lattice, extra, &path, stats))
            .map_err(to_py)
    }
}

/// `warnings.warn(message)`.
fn warn(py: Python<'_>, message: &str) -> PyResult<()> {
    py.import("warnings")?.call_method1("warn", (message,))?;
    Ok(())
}

/// The domain of `spec` in `scene`, checked as the command line checks it.
fn resolve(scene: &LibScene, spec: DomainSpec, args: &EstimatorArgs) -> PyResult<JobDomain> {
    match spec {
        DomainSpec::Slice { arg, window, res } => {
            if res == 0 || res > MAX_RES {
                return Err(param(format!("res={res}: must be between 1 and {MAX_RES}")));
            }
            let plane = resolve_plane(&arg, scene, window, res).map_err(|e| to_py(e.into()))?;
            Ok(JobDomain::Plane(plane))
        }
        DomainSpec::Camera { which, size } => {
            let (w, h) = size;
            if w == 0 || h == 0 || w > MAX_RES || h > MAX_RES {
                return Err(param(format!(
                    "size=({w}, {h}): each side must be between 1 and {MAX_RES}"
                )));
            }
            Ok(JobDomain::Camera(camera_view(scene, which, size)?))
        }
        DomainSpec::Volume { res, bbox } => {
            let bbox = Volume::resolve_box(&scene.bounds, bbox).map_err(|e| to_py(e.into()))?;
            args.resolve_for_box(scene, &bbox)
                .map_err(|e| to_py(e.into()))?;
            let (available, measured) = app::available_memory();
            let dims = app::check_volume_memory(res, bbox.max - bbox.min, available, measured)
                .map_err(|e| param(format!("res={res}: {e:#}")))?;
            let volume = Volume::new(&bbox, dims).map_err(|e| to_py(e.into()))?;
            Ok(JobDomain::Volume(volume))
        }
    }
}

/// The camera a camera run starts from, its eye moved off any surface it lies on (as the
/// command line does once per run).
fn camera_view(scene: &LibScene, which: Which, size: (usize, usize)) -> PyResult<CameraView> {
    let camera = match which {
        Which::Placed {
            eye,
            target,
            up,
            fov,
        } => camera_of(&CameraSpec {
            name: Some(app::PLACED_CAMERA.into()),
            eye: [eye.0, eye.1, eye.2],
            target: [target.0, target.1, target.2],
            up: Some([up.0, up.1, up.2]),
            fov,
        })
        .map_err(|e| param(format!("eye={eye:?}, target={target:?}, up={up:?}: {e}")))?,
        Which::Scene(name) => {
            if scene.cameras.is_empty() {
                return Err(param(format!(
                    "{} defines no camera; give eye=(x, y, z) and target=(x, y, z)",
                    scene.source.display()
                )));
            }
            match name {
                None => scene.cameras[0].clone(),
                Some(n) => {
                    let by_name = scene.cameras.iter().find(|c| c.name == n);
                    let by_index = n.parse::<usize>().ok().and_then(|i| scene.cameras.get(i));
                    let names: Vec<_> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
                    by_name.or(by_index).cloned().ok_or_else(|| {
                        param(format!(
                            "name={n:?}: no such camera (the scene has: {})",
                            names.join(", ")
                        ))
                    })?
                }
            }
        }
    };
    let mut camera = camera;
    camera.eye = scene.off_surfaces(camera.eye);
    CameraView::new(camera, size.0, size.1).map_err(|e| to_py(e.into()))
}

#[pymethods]
impl Scene {
    /// Loads a scene file: `.obj` (with its `.mtl`), `.gltf`/`.glb`, or a sidecar `.toml` naming
    /// one, and adds lights to the file's: `point_lights` [((x, y, z), (r, g, b)), ...] (radiant
    /// intensity per steradian), `sun` ((direction), (irradiance)[, diameter in degrees]) or a
    /// list of them, `sky` (r, g, b) (radiance from every direction leaving the scene), `env` a
    /// lat-long `.exr`/`.hdr` map (+y up) or (file, scale[, rotation in degrees]). `strict`
    /// refuses, naming the file and line, what a tolerant load goes on past with a warning.
    /// `allow_outside_uris` lets the scene file read files outside its own folder (URIs and
    /// paths that are absolute, climb out with `..` or lead elsewhere through a link), which are
    /// refused otherwise.
    #[new]
    // Python's keyword arguments, one parameter each.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (path, *, point_lights = None, sun = None, sky = None, env = None, strict = false, allow_outside_uris = false))]
    fn new(
        py: Python<'_>,
        path: PathBuf,
        point_lights: Option<&Bound<'_, PyAny>>,
        sun: Option<&Bound<'_, PyAny>>,
        sky: Option<&Bound<'_, PyAny>>,
        env: Option<&Bound<'_, PyAny>>,
        strict: bool,
        allow_outside_uris: bool,
    ) -> PyResult<Scene> {
        let point_lights: Vec<(Vec3, Vec3)> = match point_lights {
            None => Vec::new(),
            Some(p) => keyword(p, "point_lights", "[((x, y, z), (r, g, b)), ...]")?,
        };
        let sun: Option<Suns> = sun.map(|s| keyword(s, "sun", SUN_FORM)).transpose()?;
        let sky: Option<Vec3> = sky.map(|s| keyword(s, "sky", "(r, g, b)")).transpose()?;
        let env: Option<Env> = env
            .map(|e| {
                keyword(
                    e,
                    "env",
                    "a file, (file, scale) or (file, scale, rotation in degrees)",
                )
            })
            .transpose()?;
        let suns = match sun {
            None => Vec::new(),
            Some(Suns::One(s)) => vec![s],
            Some(Suns::Many(v)) => v,
        };
        let lights = LightArgs {
            point_lights,
            suns: suns
                .into_iter()
                .map(|s| match s {
                    Sun::WithDiameter(d, e, a) => (d, e, Some(a)),
                    Sun::Plain(d, e) => (d, e, None),
                })
                .collect(),
            sky,
            env: env.map(|e| match e {
                Env::Rotated(f, s, r) => (f, s, r),
                Env::Scaled(f, s) => (f, s, 0.0),
                Env::File(f) => (f, 1.0, 0.0),
            }),
        };
        let lights = py.detach(|| lights.lights())?;
        let load = LoadOptions {
            strict,
            allow_outside_uris,
            ..Default::default()
        };
        let scene = py
            .detach(|| no_panic(|| Ok(load_scene_with(&path, &lights, &load)?)))
            .map_err(to_py)?;
        let warnings = scene.report.warnings.clone();
        for w in &warnings {
            warn(py, &format!("{}: {w}", path.display()))?;
        }
        Ok(Scene {
            path,
            lights,
            inner: Mutex::new(scene),
            warnings: warnings.iter().map(|w| w.to_string()).collect(),
        })
    }

    /// The scene file's path.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The loader's warnings (each also issued as a Python warning when the scene loaded).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }

    /// Triangles, lights and cameras, and the bounds ((xmin, ymin, zmin), (xmax, ymax, zmax)).
    #[getter]
    fn triangles(&self) -> usize {
        self.lock().triangles.len()
    }

    #[getter]
    fn bounds(&self) -> (Vec3, Vec3) {
        let b = self.lock().bounds;
        ((b.min.x, b.min.y, b.min.z), (b.max.x, b.max.y, b.max.z))
    }

    #[getter]
    fn cameras(&self) -> Vec<String> {
        self.lock().cameras.iter().map(|c| c.name.clone()).collect()
    }

    fn __repr__(&self) -> String {
        format!("<ftpd3d.Scene {}>", self.path.display())
    }

    /// The FTPD field of a slice: `slice` is `"z=0"` (x=c spans z,y; y=c spans x,z; z=c spans
    /// x,y), the name of a slice in the scene file, or a plane `"origin=X,Y,Z normal=X,Y,Z
    /// [up=X,Y,Z] [size=W,H]"`; `window` (u0, v0, u1, v1) restricts an axis slice; `res` cells
    /// along the longer side. Sampling: `spp` (samples per cell), `time` (seconds), `target_error`
    /// (p95 relative error); none of them: stop at 0.05 or after 60 s, whichever comes first (a
    /// reproducible run gives `spp`). `pairs` (kA, kB, J, M): the deflection pairs of a sample
    /// (None: the weighting's). `flatland` confines directions to the plane; `separatrices` adds
    /// the separatrix channels (`sep_threshold`, `sep_scale`, `sep_tau`). `progress`: None (a
    /// tqdm bar when tqdm is installed), False, True or f(done, total).
    #[pyo3(signature = (slice = "z=0".to_string(), *, res = app::DEFAULT_RES as i64, window = None,
        flatland = false, **options))]
    // What help() shows: the defaults keywords::RunKeywords reads, as Python values (a test holds
    // them equal).
    #[pyo3(
        text_signature = "(self, slice='z=0', *, res=256, window=None, flatland=False, spp=None, time=None, target_error=None, seed=1, weighting='radiance', t0=None, t1=None, angle=2.0, max_bounces=32, radiance_bounces=None, pairs=None, guide=False, batches=8, pass_spp=None, adaptive=None, adaptive_cap=None, gradient_domain=False, gradient_alpha=None, threads=0, tile=None, separatrices=False, sep_threshold=3.0, sep_scale=None, sep_tau=None, progress=None)"
    )]
    fn slice<'py>(
        &self,
        py: Python<'py>,
        slice: String,
        res: i64,
        window: Option<(f64, f64, f64, f64)>,
        flatland: bool,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Field> {
        let method = if flatland { "flatland" } else { "slice" };
        let kw = RunKeywords::new(py, method, options, "radiance")?;
        let spec = DomainSpec::Slice {
            arg: options::slice_arg(&slice)?,
            window: window.map(|(a, b, c, d)| [a, b, c, d]),
            res: options::count("res", res)?,
        };
        self.run(py, spec, kw, flatland)
    }

    /// A flatland slice: [`slice`](Scene::slice) with every direction confined to the plane (2D
    /// light transport in the scene extruded across it); the same keywords.
    #[pyo3(signature = (slice = "z=0".to_string(), *, res = app::DEFAULT_RES as i64, window = None,
        **options))]
    #[pyo3(
        text_signature = "(self, slice='z=0', *, res=256, window=None, spp=None, time=None, target_error=None, seed=1, weighting='radiance', t0=None, t1=None, angle=2.0, max_bounces=32, radiance_bounces=None, pairs=None, guide=False, batches=8, pass_spp=None, adaptive=None, adaptive_cap=None, gradient_domain=False, gradient_alpha=None, threads=0, tile=None, separatrices=False, sep_threshold=3.0, sep_scale=None, sep_tau=None, progress=None)"
    )]
    fn flatland<'py>(
        &self,
        py: Python<'py>,
        slice: String,
        res: i64,
        window: Option<(f64, f64, f64, f64)>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Field> {
        self.slice(py, slice, res, window, true, options)
    }

    /// A camera image of `size` (width, height) pixels, importance-weighted (pairs start along
    /// the pixel rays), with the path-traced beauty image in `radiance.R/G/B`: a camera of the
    /// scene file by `name` (or index; None: the first), or one placed by `eye`, `target`, `up`
    /// and `fov` (vertical, degrees). The sampling and estimator keywords of `slice`.
    #[pyo3(signature = (name = None, *, eye = None, target = None, up = None,
        fov = app::DEFAULT_FOV_DEG,
        size = (app::DEFAULT_IMAGE_SIZE.0 as i64, app::DEFAULT_IMAGE_SIZE.1 as i64), **options))]
    #[pyo3(
        text_signature = "(self, name=None, *, eye=None, target=None, up=None, fov=40.0, size=(512, 512), spp=None, time=None, target_error=None, seed=1, weighting='importance', t0=None, t1=None, angle=2.0, max_bounces=32, radiance_bounces=None, pairs=None, guide=False, batches=8, pass_spp=None, adaptive=None, adaptive_cap=None, gradient_domain=False, gradient_alpha=None, threads=0, tile=None, separatrices=False, sep_threshold=3.0, sep_scale=None, sep_tau=None, progress=None)"
    )]
    #[allow(clippy::too_many_arguments)]
    fn camera<'py>(
        &self,
        py: Python<'py>,
        name: Option<String>,
        eye: Option<Vec3>,
        target: Option<Vec3>,
        up: Option<Vec3>,
        fov: f64,
        size: (i64, i64),
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Field> {
        let kw = RunKeywords::new(py, "camera", options, "importance")?;
        let which = match (eye, target) {
            (Some(eye), Some(target)) => {
                if name.is_some() {
                    return Err(param("give a camera's name or eye and target, not both"));
                }
                let d = app::DEFAULT_UP;
                Which::Placed {
                    eye,
                    target,
                    up: up.unwrap_or((d.x, d.y, d.z)),
                    fov,
                }
            }
            (None, None) if up.is_none() => Which::Scene(name),
            _ => return Err(param("eye and target go together (up and fov with them)")),
        };
        let size = (
            options::count("size", size.0)?,
            options::count("size", size.1)?,
        );
        let spec = DomainSpec::Camera { which, size };
        self.run(py, spec, kw, false)
    }

    /// A voxel grid: `res` voxels along the longest side of the box (the others by aspect) or
    /// (nx, ny, nz), over `box` (xmin, ymin, zmin, xmax, ymax, zmax; None: the scene's bounds,
    /// flat sides padded). Channels as the `.vti` holds them, shaped (nz, ny, nx). The sampling
    /// and estimator keywords of `slice`.
    #[pyo3(signature = (res, *, r#box = None, **options))]
    #[pyo3(
        text_signature = "(self, res, *, box=None, spp=None, time=None, target_error=None, seed=1, weighting='radiance', t0=None, t1=None, angle=2.0, max_bounces=32, radiance_bounces=None, pairs=None, guide=False, batches=8, pass_spp=None, adaptive=None, adaptive_cap=None, gradient_domain=False, gradient_alpha=None, threads=0, tile=None, separatrices=False, sep_threshold=3.0, sep_scale=None, sep_tau=None, progress=None)"
    )]
    fn volume<'py>(
        &self,
        py: Python<'py>,
        res: VolRes,
        r#box: Option<(f64, f64, f64, f64, f64, f64)>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Field> {
        let kw = RunKeywords::new(py, "volume", options, "radiance")?;
        let res = match res {
            VolRes::Longest(n) if n > 0 => VolumeRes::Longest(options::count("res", n)?),
            VolRes::Dims(x, y, z) if x > 0 && y > 0 && z > 0 => VolumeRes::Dims([
                options::count("res", x)?,
                options::count("res", y)?,
                options::count("res", z)?,
            ]),
            _ => return Err(param("res: every axis needs at least 1 voxel")),
        };
        let bbox = r#box.map(|(a, b, c, d, e, f)| [a, b, c, d, e, f]);
        let spec = DomainSpec::Volume { res, bbox };
        self.run(py, spec, kw, false)
    }
}
