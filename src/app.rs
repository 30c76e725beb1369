//! The validated job and what the command line runs: load, estimate, write, summarise.
//! `main.rs` parses arguments into a [`Job`] or a [`VolumeJob`]; everything here returns errors,
//! never panics.

use crate::domain::slice::SliceSpec;
use crate::domain::volume::Volume;
use crate::domain::{CameraView, Domain, Plane, PlaneOnSurfaces, Subset, VolumeRes};
use crate::field::Field;
use crate::ftpd::{self, Params, Weighting};
use crate::kernel::{self, Kernel, WithKernel};
use crate::output;
pub use crate::output::{check_writable, write_outputs, write_outputs_with, write_volume_outputs};
use crate::render::{
    self, ErrorStats, Hooks, InFlight, Progress, RenderOptions, RunStats, Schedule, StopReason,
};
use crate::rng::Sampler;
use crate::scene::flat::Flatland;
use crate::scene::{self, Scene};
use anyhow::{Context, bail};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Estimator settings as the user gave them; `None` means "relative to the scene" (see [`resolve`]).
#[derive(Clone, Debug)]
pub struct EstimatorArgs {
    pub weighting: Weighting,
    pub t0: Option<f64>,
    pub t1: Option<f64>,
    /// Perturbation half-angle in degrees.
    pub angle_deg: f64,
    pub max_bounces: u32,
}

/// Default run-length window as fractions of the scene diagonal D: T ∈ [0.1 D, 0.5 D].
pub const DEFAULT_T0_OF_DIAGONAL: f64 = 0.1;
pub const DEFAULT_T1_OF_DIAGONAL: f64 = 0.5;

impl EstimatorArgs {
    /// Checks the values and fills scene-relative defaults.
    pub fn resolve(&self, scene: &Scene) -> anyhow::Result<Params> {
        self.resolve_with_extent(scene, scene.extent())
    }

    /// [`resolve`](Self::resolve) with run-length defaults relative to the length `d` instead of the
    /// scene diagonal (flatland uses the diagonal of the scene's cross-section).
    pub fn resolve_with_extent(&self, scene: &Scene, d: f64) -> anyhow::Result<Params> {
        let t0 = self.t0.unwrap_or(DEFAULT_T0_OF_DIAGONAL * d);
        let t1 = self
            .t1
            .unwrap_or(DEFAULT_T1_OF_DIAGONAL * d)
            .max(if self.t1.is_none() { t0 } else { 0.0 });
        if !t0.is_finite() || t0 < 0.0 {
            bail!("--t0 {t0}: the shortest run length must be finite and ≥ 0");
        }
        if !t1.is_finite() || t1 <= 0.0 {
            bail!("--t1 {t1}: the longest run length must be finite and > 0");
        }
        if t0 > t1 {
            bail!("--t0 {t0} is larger than --t1 {t1}: the run-length interval [t0, t1] is empty");
        }
        if !(self.angle_deg > 0.0 && self.angle_deg < 90.0) {
            bail!(
                "--angle {}: the perturbation half-angle must lie strictly between 0 and 90 degrees",
                self.angle_deg
            );
        }
        if self.weighting == Weighting::Radiance && scene.lights.is_empty() {
            bail!(
                "--weight radiance: {} has no lights (no emissive material, Ke); \
                 use --weight unweighted or add a light",
                scene.source.display()
            );
        }
        Ok(Params {
            t0,
            t1,
            theta_max: self.angle_deg.to_radians(),
            weighting: self.weighting,
            max_bounces: self.max_bounces,
            flat: None,
        })
    }
}

/// Diagonal of the bounds projected onto the plane of `fl` (the size of a flatland scene).
pub fn flat_extent(bounds: &scene::Aabb, fl: &Flatland) -> f64 {
    if bounds.is_empty() {
        return 1.0;
    }
    let (mut lo, mut hi) = (
        glam::DVec2::splat(f64::INFINITY),
        glam::DVec2::splat(f64::NEG_INFINITY),
    );
    for c in bounds.corners() {
        let q = glam::DVec2::new(c.dot(fl.e1), c.dot(fl.e2));
        lo = lo.min(q);
        hi = hi.max(q);
    }
    let d = (hi - lo).length();
    if d > 0.0 && d.is_finite() { d } else { 1.0 }
}

/// Sets up a flatland run on `plane`: validates and prepares the scene
/// ([`Scene::prepare_flatland`]), resolves the estimator settings with run-length defaults relative
/// to the cross-section's diagonal, and returns them with [`Params::flat`] set.
pub fn prepare_flatland(
    scene: &mut Scene,
    plane: &Plane,
    args: &EstimatorArgs,
) -> anyhow::Result<Params> {
    let fl = plane.flatland();
    scene.prepare_flatland(fl, &plane.label)?;
    let mut params = args.resolve_with_extent(scene, flat_extent(&scene.bounds, &fl))?;
    if params.weighting == Weighting::Radiance && scene.flat().lights.is_empty() {
        bail!(
            "--flatland --weight radiance: no light of {} meets the slice plane {} (emissive \
             triangles must cross it, point lights lie in it); use --weight unweighted or another \
             slice",
            scene.source.display(),
            plane.label
        );
    }
    params.flat = Some(fl);
    Ok(params)
}

/// Where a run's samples start.
#[derive(Clone, Debug)]
pub enum DomainArg {
    /// One or more planes (axis slices, named slices or arbitrary planes), optionally a window
    /// (axis slices only), cells along the longer side. Each plane is written to its own file.
    Slice {
        slices: Vec<SliceArg>,
        window: Option<[f64; 4]>,
        res: usize,
    },
    /// A camera image of `size` pixels (width, height).
    Camera {
        camera: CameraArg,
        size: (usize, usize),
    },
}

/// One plane of a slice run.
#[derive(Clone, Debug)]
pub enum SliceArg {
    /// `AXIS=VALUE` or the name of a slice in the scene file.
    Axis(String),
    /// `origin=… normal=… [up=…] [size=…]`.
    Plane(crate::domain::slice::PlaneSpec),
}

impl SliceArg {
    /// A short name for file names: `z0.5`, `plane2`.
    pub fn file_label(&self, index: usize) -> String {
        match self {
            SliceArg::Axis(a) => a.replace(['=', '/', ' '], ""),
            SliceArg::Plane(_) => format!("plane{index}"),
        }
    }
}

/// The output file of slice `index` of `count`: the job's output itself for a single slice, else
/// `<stem>_<label>.exr` next to it.
pub fn slice_output(output: &Path, slice: &SliceArg, index: usize, count: usize) -> PathBuf {
    if count <= 1 {
        return output.to_path_buf();
    }
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    output.with_file_name(format!("{stem}_{}.exr", slice.file_label(index)))
}

/// Which camera.
#[derive(Clone, Debug)]
pub enum CameraArg {
    /// A camera of the scene file, by name or index (`None`: the first).
    Scene(Option<String>),
    /// Given on the command line.
    Explicit {
        eye: glam::DVec3,
        target: glam::DVec3,
        up: glam::DVec3,
        fov_deg: f64,
    },
}

/// A run, validated enough to start (the rest is checked against the loaded scene).
#[derive(Clone, Debug)]
pub struct Job {
    pub scene: PathBuf,
    pub domain: DomainArg,
    /// Extra point lights: position, radiant intensity.
    pub point_lights: Vec<(glam::DVec3, glam::DVec3)>,
    pub estimator: EstimatorArgs,
    /// How many samples, when to stop, and which stripe of the grid (`render.tile`, `--tile i/N`).
    pub render: RenderOptions,
    pub output: PathBuf,
    pub png: bool,
    pub quiet: bool,
    /// Confine every direction to the slice plane (2D light transport in an extruded scene).
    pub flatland: bool,
    /// Write the field so far (marked partial) to `output` at the first pass boundary after each
    /// such interval.
    pub checkpoint_every: Option<Duration>,
    /// Continue the run saved in this file (a partial or finished field of the same job).
    pub resume: Option<PathBuf>,
    /// The command line that started the job, without any `--resume`, for the resume hint.
    pub command: Option<String>,
}

/// Largest accepted `--res`.
pub const MAX_RES: usize = 16384;

/// Loads a scene by its extension: `.obj`, or a sidecar `.toml` naming a mesh plus point lights,
/// cameras and named slices.
pub fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    match extension(path).as_deref() {
        Some("toml") => {
            let sc = scene::sidecar::read(path)?;
            let mesh = path.parent().unwrap_or(Path::new(".")).join(&sc.mesh);
            if extension(&mesh).as_deref() == Some("toml") {
                bail!(
                    "{}: mesh = \"{}\" must be a mesh file, not another .toml",
                    path.display(),
                    sc.mesh
                );
            }
            let mut scene = load_mesh(&mesh)
                .with_context(|| format!("{}: loading its mesh", path.display()))?;
            scene::sidecar::apply(&sc, &mut scene)?;
            scene.named_slices = sc
                .slice
                .iter()
                .map(|s| (s.name.clone(), s.plane.clone()))
                .collect();
            Ok(scene)
        }
        _ => load_mesh(path),
    }
}

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

fn load_mesh(path: &Path) -> anyhow::Result<Scene> {
    match extension(path).as_deref() {
        Some("obj") => scene::obj::load(path),
        Some("gltf" | "glb") => scene::gltf::load(path),
        Some(other) => bail!(
            "{}: unsupported scene format '.{other}' (supported: .obj, .gltf, .glb, .toml)",
            path.display()
        ),
        None => bail!(
            "{}: no file extension; expected a .obj, .gltf, .glb or .toml scene",
            path.display()
        ),
    }
}

/// Resolves `--slice`: `AXIS=VALUE`, or the name of a slice in the sidecar scene file.
pub fn resolve_slice(arg: &str, scene: &Scene) -> anyhow::Result<SliceSpec> {
    if arg.contains('=') {
        return arg
            .parse::<SliceSpec>()
            .map_err(|e| anyhow::anyhow!("--slice {e}"));
    }
    match scene.named_slices.iter().find(|(n, _)| n == arg) {
        Some((_, plane)) => plane
            .parse::<SliceSpec>()
            .map_err(|e| anyhow::anyhow!("--slice {arg}: the scene file's plane {e}")),
        None if scene.named_slices.is_empty() => {
            bail!("--slice {arg}: expected AXIS=VALUE such as z=1.2 (the scene names no slices)")
        }
        None => bail!(
            "--slice {arg}: not AXIS=VALUE and not a slice of the scene file (it names: {})",
            scene
                .named_slices
                .iter()
                .map(|(n, _)| n.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Parses `--point-light x,y,z:r,g,b` (position, then radiant intensity per steradian).
pub fn parse_point_light(s: &str) -> Result<(glam::DVec3, glam::DVec3), String> {
    let (p, i) = s
        .split_once(':')
        .ok_or_else(|| format!("'{s}': expected x,y,z:r,g,b"))?;
    let three = |t: &str, what: &str| -> Result<glam::DVec3, String> {
        let v: Vec<f64> = t
            .split(',')
            .map(|x| {
                x.trim()
                    .parse::<f64>()
                    .map_err(|_| format!("'{s}': {what} '{x}' is not a number"))
            })
            .collect::<Result<_, _>>()?;
        match v.as_slice() {
            [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok(glam::DVec3::new(*a, *b, *c)),
            [_, _, _] => Err(format!("'{s}': {what} must be finite")),
            _ => Err(format!("'{s}': {what} needs 3 comma-separated numbers")),
        }
    };
    let (pos, int) = (three(p, "position")?, three(i, "intensity")?);
    if int.min_element() < 0.0 {
        return Err(format!("'{s}': intensity must be ≥ 0"));
    }
    Ok((pos, int))
}

/// Describes the run in the field's metadata (EXR header attributes).
pub fn describe_run(
    field: &mut Field,
    scene: &Scene,
    params: &Params,
    opts: &RenderOptions,
    domain: &str,
) {
    let m = &mut field.meta;
    m.insert(
        "tool".into(),
        format!("ftpd3d {}", env!("CARGO_PKG_VERSION")),
    );
    m.insert("embree".into(), crate::embree_version().into());
    m.insert("scene".into(), scene.source.display().to_string());
    m.insert("domain".into(), domain.into());
    m.insert("weighting".into(), params.weighting.to_string());
    m.insert("t0".into(), format!("{:e}", params.t0));
    m.insert("t1".into(), format!("{:e}", params.t1));
    m.insert(
        "angle_deg".into(),
        format!("{}", params.theta_max.to_degrees()),
    );
    m.insert("max_bounces".into(), params.max_bounces.to_string());
    m.insert("seed".into(), opts.seed.to_string());
    m.insert(
        "spp".into(),
        if opts.budget.cap_spp {
            opts.spp.to_string()
        } else {
            "none".into()
        },
    );
    m.insert("batches".into(), opts.batches.to_string());
    m.insert("schedule".into(), Schedule::of(opts).key());
    m.insert(
        "adaptive".into(),
        match opts.adaptive {
            Some(a) => format!("max {}x", a.max_share),
            None => "off".into(),
        },
    );
    m.insert(
        "budget.time".into(),
        opts.budget.time.map_or_else(|| "none".into(), fmt_duration),
    );
    m.insert(
        "budget.target_error".into(),
        opts.budget
            .target_error
            .map_or_else(|| "none".into(), |t| t.to_string()),
    );
    m.insert("features".into(), scene.features.to_string());
    m.insert("flatland".into(), params.flat.is_some().to_string());
}

/// Runs FTPD over a plane (the whole grid, or the stripe `opts.tile`); the field comes back with
/// its metadata filled in. A plane with a surface lying in it (a slice through a wall) starts its
/// points on the surfaces' front sides ([`PlaneOnSurfaces`]).
pub fn run_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    check_flatland(scene, plane, params)?;
    let on_surfaces = PlaneOnSurfaces(plane);
    let domain: &dyn Domain = if scene.surface_in_plane(plane.origin, plane.normal()) {
        &on_surfaces
    } else {
        plane
    };
    let (mut field, stats) = run_domain(scene, domain, params, opts)?;
    describe_run(&mut field, scene, params, opts, "slice");
    field.meta.extend(plane_meta(plane));
    Ok((field, stats))
}

/// Runs FTPD over any domain (the whole grid, or the stripe `opts.tile`) with the kernel `params`
/// needs ([`ftpd::kernel_for`]).
pub fn run_domain(
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    let (w, h, d) = domain.dims();
    let mut field = Field::new(w, h, d);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let stats = run_domain_progressive(
        &pool,
        scene,
        domain,
        params,
        opts,
        &mut field,
        &mut Progress::default(),
        Hooks::default(),
    )?;
    field
        .meta
        .insert("kernel".into(), ftpd::kernel_for(params).to_string());
    if let Some(t) = opts.tile {
        field.meta.insert("tile".into(), t.to_string());
    }
    Ok((field, stats))
}

/// Runs passes over `field` (new, or resumed at `progress`) with the kernel `params` needs until a
/// budget of `opts` is reached or `hooks.stop` is set; see [`render::run_progressive`].
#[allow(clippy::too_many_arguments)]
pub fn run_domain_progressive(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
    field: &mut Field,
    progress: &mut Progress,
    hooks: Hooks,
) -> anyhow::Result<RunStats> {
    let dims = domain.dims();
    if (field.width, field.height, field.depth) != dims {
        bail!(
            "the field is {}x{}x{} cells, the domain {}x{}x{}",
            field.width,
            field.height,
            field.depth,
            dims.0,
            dims.1,
            dims.2
        );
    }
    struct DomainRun<'a, 'h> {
        pool: &'a rayon::ThreadPool,
        scene: &'a Scene,
        domain: &'a dyn Domain,
        params: &'a Params,
        opts: &'a RenderOptions,
        field: &'a mut Field,
        progress: &'a mut Progress,
        hooks: Hooks<'h>,
    }
    impl WithKernel for DomainRun<'_, '_> {
        type Output = anyhow::Result<RunStats>;
        fn run<K: Kernel>(self) -> Self::Output {
            let DomainRun {
                pool,
                scene,
                domain,
                params,
                opts,
                field,
                progress,
                hooks,
            } = self;
            render::run_progressive(
                pool,
                field,
                opts,
                progress,
                hooks,
                |cell, s: &mut Sampler| {
                    let start = domain.start(scene, cell, s);
                    ftpd::sample::<K>(scene, start, params, s)
                },
            )
        }
    }
    kernel::dispatch(
        ftpd::kernel_for(params),
        DomainRun {
            pool,
            scene,
            domain,
            params,
            opts,
            field,
            progress,
            hooks,
        },
    )
}

/// A flatland run needs a flatland kernel, a scene prepared for its plane, and a domain in it.
fn check_flatland(scene: &Scene, plane: &Plane, params: &Params) -> anyhow::Result<()> {
    match params.flat {
        None => Ok(()),
        Some(fl) => {
            let prepared = scene.flat.as_ref().map(|f| f.plane);
            if prepared != Some(fl) {
                bail!(
                    "flatland run on {}: the scene was not prepared for this plane \
                     (Scene::prepare_flatland)",
                    plane.label
                );
            }
            let tol = 1e-9 * scene.extent().max(plane.origin.abs().max_element());
            if plane.normal().cross(fl.normal).length() > 1e-12
                || fl.distance(plane.origin).abs() > tol
            {
                bail!(
                    "flatland run: the domain {} does not lie in the flatland plane",
                    plane.label
                );
            }
            Ok(())
        }
    }
}

/// The metadata that places a slice.
pub fn plane_meta(plane: &Plane) -> Vec<(String, String)> {
    vec![
        ("plane".into(), plane.label.clone()),
        ("plane.origin".into(), fmt_vec(plane.origin)),
        ("plane.u".into(), fmt_vec(plane.u_axis)),
        ("plane.v".into(), fmt_vec(plane.v_axis)),
        (
            "plane.size".into(),
            format!("{},{}", plane.size.0, plane.size.1),
        ),
    ]
}

/// The metadata that places a camera image.
pub fn camera_meta(view: &CameraView) -> Vec<(String, String)> {
    let c = &view.camera;
    vec![
        ("camera".into(), c.name.clone()),
        ("camera.eye".into(), fmt_vec(c.eye)),
        ("camera.forward".into(), fmt_vec(c.forward)),
        ("camera.up".into(), fmt_vec(c.up)),
        (
            "camera.fov_y_deg".into(),
            format!("{}", c.fov_y.to_degrees()),
        ),
    ]
}

fn fmt_vec(v: glam::DVec3) -> String {
    format!("{},{},{}", v.x, v.y, v.z)
}

/// Mean and 95th percentile of the relative standard error over valid cells with σ > 0 (see
/// [`render::error_stats`] for the definitions).
pub fn relative_error_summary(field: &Field) -> (f64, f64) {
    let e = render::error_stats(&field.cells);
    (e.mean, e.p95)
}

/// Loads the job's scene and adds its command-line point lights.
pub fn load_job_scene(job: &Job) -> anyhow::Result<Scene> {
    load_scene_with_lights(&job.scene, &job.point_lights)
}

/// Loads a scene and adds point lights (position, radiant intensity) to it.
pub fn load_scene_with_lights(
    path: &Path,
    point_lights: &[(glam::DVec3, glam::DVec3)],
) -> anyhow::Result<Scene> {
    let mut scene = load_scene(path)?;
    for (p, i) in point_lights {
        scene.lights.add_point(*p, *i);
    }
    scene.features = scene::Features::of(&scene.materials, &scene.tri_material, &scene.lights);
    Ok(scene)
}

/// Resolves the camera of a job against the scene.
pub fn resolve_camera(
    arg: &CameraArg,
    scene: &Scene,
    size: (usize, usize),
) -> anyhow::Result<CameraView> {
    let camera = match arg {
        CameraArg::Explicit {
            eye,
            target,
            up,
            fov_deg,
        } => scene::sidecar::camera_of(&scene::sidecar::CameraSpec {
            name: Some("command line".into()),
            eye: eye.to_array(),
            target: target.to_array(),
            up: Some(up.to_array()),
            fov: *fov_deg,
        })
        .context("--eye/--target/--up")?,
        CameraArg::Scene(which) => {
            if scene.cameras.is_empty() {
                bail!(
                    "--camera: {} defines no camera; give --eye X,Y,Z --target X,Y,Z [--up X,Y,Z] [--fov DEG]",
                    scene.source.display()
                );
            }
            match which {
                None => scene.cameras[0].clone(),
                Some(w) => {
                    let by_index = w.parse::<usize>().ok().and_then(|i| scene.cameras.get(i));
                    let by_name = scene.cameras.iter().find(|c| &c.name == w);
                    by_name.or(by_index).cloned().with_context(|| {
                        let names: Vec<_> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
                        format!(
                            "--camera {w}: no such camera (the scene has: {})",
                            names.join(", ")
                        )
                    })?
                }
            }
        }
    };
    // An eye on a surface starts on its front side (once per run).
    let mut camera = camera;
    camera.eye = scene.off_surfaces(camera.eye);
    CameraView::new(camera, size.0, size.1)
}

/// What [`run_job`] did.
#[derive(Clone, Debug)]
pub struct RunOutcome {
    pub field: Field,
    pub stats: RunStats,
    pub error: ErrorStats,
    pub progress: Progress,
}

/// Parses a duration such as `90s`, `10m`, `1h30m`, `2.5h`, `1d`, `500ms`; a bare number is
/// seconds.
pub fn parse_duration(s: &str) -> Result<Duration, String> {
    let t = s.trim();
    if t.is_empty() {
        return Err("empty duration; expected e.g. 90s, 10m or 1h30m".into());
    }
    if let Ok(x) = t.parse::<f64>() {
        return Duration::try_from_secs_f64(x)
            .map_err(|_| format!("'{s}': a duration must be finite and ≥ 0"));
    }
    let mut total = 0.0f64;
    let mut rest = t;
    while !rest.is_empty() {
        let num_len = rest
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .unwrap_or(rest.len());
        if num_len == 0 {
            return Err(format!(
                "'{s}': expected a number before '{rest}' (e.g. 90s, 10m, 1h30m)"
            ));
        }
        let x: f64 = rest[..num_len]
            .parse()
            .map_err(|_| format!("'{s}': '{}' is not a number", &rest[..num_len]))?;
        rest = rest[num_len..].trim_start();
        let unit_len = rest
            .find(|c: char| !c.is_ascii_alphabetic())
            .unwrap_or(rest.len());
        let unit = match &rest[..unit_len] {
            "ms" => 1e-3,
            "s" | "sec" | "secs" => 1.0,
            "m" | "min" | "mins" => 60.0,
            "h" | "hr" | "hrs" => 3600.0,
            "d" => 86400.0,
            "" => {
                return Err(format!(
                    "'{s}': a unit must follow '{x}' (ms, s, m, h or d)"
                ));
            }
            u => return Err(format!("'{s}': unknown unit '{u}' (ms, s, m, h or d)")),
        };
        total += x * unit;
        rest = rest[unit_len..].trim_start();
    }
    Duration::try_from_secs_f64(total).map_err(|_| format!("'{s}': duration out of range"))
}

/// `1h02m03s`, `4m05s`, `12.3s`: a duration as [`parse_duration`] reads it back.
pub fn fmt_duration(d: Duration) -> String {
    let secs = d.as_secs_f64();
    if secs < 60.0 {
        return format!("{}s", (secs * 1000.0).round() / 1000.0);
    }
    let s = d.as_secs();
    let (h, m, sec) = (s / 3600, s / 60 % 60, s % 60);
    if h > 0 {
        format!("{h}h{m:02}m{sec:02}s")
    } else {
        format!("{m}m{sec:02}s")
    }
}

/// Keys of a field's metadata beyond [`crate::merge::MUST_MATCH`] (what the samples estimate)
/// that must agree for a run to resume from it: which random streams, pass sizes and kernel
/// produced them. Budgets (spp cap, time, target error) may change between invocations.
pub const RESUME_KEYS: &[&str] = &["seed", "schedule", "adaptive", "kernel"];

/// Checks that the field read from `path` was made by the run described by `meta` on a grid of
/// `dims`; the error names the first key that differs.
pub fn check_resume(
    path: &Path,
    file: &Field,
    meta: &BTreeMap<String, String>,
    dims: (usize, usize, usize),
) -> anyhow::Result<()> {
    let have = (file.width, file.height, file.depth);
    if have != dims {
        bail!(
            "--resume {}: grid size differs: the file has {}x{} cells, this run {}x{} \
             (give the --res/--window/--size the run was started with)",
            path.display(),
            have.0,
            have.1,
            dims.0,
            dims.1
        );
    }
    if !file.meta.contains_key("schedule") {
        bail!(
            "--resume {}: not a field this version of ftpd3d can resume (no 'schedule' key)",
            path.display()
        );
    }
    for key in crate::merge::MUST_MATCH.iter().chain(RESUME_KEYS) {
        let (a, b) = (file.meta.get(*key), meta.get(*key));
        if a != b {
            let show = |v: Option<&String>| v.map_or_else(|| "(none)".to_string(), Clone::clone);
            bail!(
                "--resume {}: {key} differs: the file has {}, this run {}; a run resumes only with \
                 the scene, domain, parameters, seed and pass schedule it was started with",
                path.display(),
                show(a),
                show(b)
            );
        }
    }
    Ok(())
}

/// Records where a run stands in the field's metadata: `partial`, `passes`, `samples`, `elapsed`
/// (compute seconds so far), `remaining.samples` and `remaining.time` (what is left of the budgets),
/// `pass.inflight`, and `stop` (why it stopped, when it has).
pub fn mark_progress(
    field: &mut Field,
    progress: &Progress,
    opts: &RenderOptions,
    partial: bool,
    stop: Option<StopReason>,
) {
    let samples = field.total_samples();
    // The cells the run samples: a tile's, or the whole grid.
    let cells = opts.tile.map_or(field.cells.len(), |t| {
        t.cells(field.width, field.height, field.depth).len()
    }) as u64;
    let m = &mut field.meta;
    m.insert("partial".into(), partial.to_string());
    m.insert("passes".into(), progress.passes.to_string());
    m.insert("samples".into(), samples.to_string());
    m.insert("elapsed".into(), progress.elapsed.to_string());
    m.insert(
        "remaining.samples".into(),
        if opts.budget.cap_spp {
            (cells * opts.spp as u64)
                .saturating_sub(samples)
                .to_string()
        } else {
            "unbounded".into()
        },
    );
    m.insert(
        "remaining.time".into(),
        opts.budget.time.map_or_else(
            || "none".into(),
            |t| fmt_duration(t.saturating_sub(Duration::from_secs_f64(progress.elapsed))),
        ),
    );
    m.insert(
        "pass.inflight".into(),
        progress.inflight.is_some().to_string(),
    );
    match stop {
        Some(s) => m.insert("stop".into(), s.to_string()),
        None => m.remove("stop"),
    };
}

/// Writes a field with its progress: for a pass interrupted part-way, the channels `pass.done`
/// (1 where the cell completed it) and, for adaptive passes, `pass.units` (the pass's allocation).
pub fn write_progress(
    field: &Field,
    progress: &Progress,
    path: &Path,
    png: bool,
) -> anyhow::Result<()> {
    let mut extra = Vec::new();
    if let Some(f) = &progress.inflight {
        extra.push((
            "pass.done",
            f.done.iter().map(|&d| if d { 1.0 } else { 0.0 }).collect(),
        ));
        if let Some(u) = &f.units {
            extra.push(("pass.units", u.iter().map(|&x| x as f64).collect()));
        }
    }
    write_outputs_with(field, path, png, extra)
}

/// Reads a field to resume from, with where its run stands (see [`mark_progress`]).
pub fn read_progress(path: &Path) -> anyhow::Result<(Field, Progress)> {
    let field =
        output::exr::read_exr(path).with_context(|| format!("--resume {}", path.display()))?;
    let num = |key: &str| -> anyhow::Result<&str> {
        field.meta.get(key).map(String::as_str).with_context(|| {
            format!(
                "--resume {}: no '{key}' in the file (not written by a progressive run?)",
                path.display()
            )
        })
    };
    let passes: u32 = num("passes")?
        .parse()
        .with_context(|| format!("--resume {}: 'passes' is not a number", path.display()))?;
    let elapsed: f64 = num("elapsed")?
        .parse()
        .with_context(|| format!("--resume {}: 'elapsed' is not a number", path.display()))?;
    let inflight = if field.meta.get("pass.inflight").is_some_and(|v| v == "true") {
        let (_, _, done) = output::exr::read_channel(path, "pass.done")?;
        let units = if field.meta.get("adaptive").is_some_and(|a| a != "off") && passes >= 2 {
            let (_, _, u) = output::exr::read_channel(path, "pass.units")?;
            Some(u.iter().map(|&x| x as u32).collect())
        } else {
            None
        };
        Some(InFlight {
            done: done.iter().map(|&d| d != 0.0).collect(),
            units,
        })
    } else {
        None
    };
    Ok((
        field,
        Progress {
            passes,
            inflight,
            elapsed,
        },
    ))
}

/// The domain of a job, resolved against its scene.
enum JobDomain {
    Plane(Plane),
    Camera(CameraView),
}

/// Runs a job end to end: load the scene once, resolve every plane (or the camera) and check every
/// output before any work, then run each domain in progressive passes (resuming a saved run if
/// asked), checkpoint, write EXR (and PNG) and print a summary on stderr. A run stopped by
/// [`render::INTERRUPT`] writes what it has, marked partial, and says how to resume.
pub fn run_job(job: &Job) -> anyhow::Result<Vec<RunOutcome>> {
    let opts = &job.render;
    if opts.budget.cap_spp && opts.spp == 0 {
        bail!("--spp 0: at least one sample per cell is needed");
    }
    if opts.pass_spp == Some(0) {
        bail!("--pass-spp 0: a pass needs at least one sample per cell");
    }
    if let Some(t) = opts.budget.target_error
        && !(t > 0.0 && t.is_finite())
    {
        bail!("--target-error {t}: must be a finite relative error > 0 (e.g. 0.05)");
    }
    if opts.budget.time.is_some_and(|t| t.is_zero()) {
        bail!("--time 0: the time budget must be positive");
    }
    if job.checkpoint_every.is_some_and(|t| t.is_zero()) {
        bail!("--checkpoint-every 0: the interval must be positive");
    }
    if opts.adaptive.is_some_and(|a| a.max_share == 0) {
        bail!("--adaptive-cap 0: a cell must be allowed at least the uniform share");
    }
    match &job.domain {
        DomainArg::Slice { res, .. } if *res == 0 || *res > MAX_RES => {
            bail!("--res {res}: must be between 1 and {MAX_RES}")
        }
        DomainArg::Slice { slices, .. }
            if slices.len() > 1 && (job.resume.is_some() || job.checkpoint_every.is_some()) =>
        {
            bail!(
                "--resume and --checkpoint-every work on one output; this job has {} slices \
                 (run them one by one)",
                slices.len()
            )
        }
        DomainArg::Camera { size: (w, h), .. }
            if *w == 0 || *h == 0 || *w > MAX_RES || *h > MAX_RES =>
        {
            bail!("--size {w},{h}: each side must be between 1 and {MAX_RES}")
        }
        DomainArg::Camera { .. } if job.flatland => {
            bail!(
                "--flatland works on slices (the plane confines the directions), not camera images"
            )
        }
        _ => {}
    }
    if let Some(r) = &job.resume
        && !r.is_file()
    {
        bail!("--resume {}: no such file", r.display());
    }
    if matches!(job.domain, DomainArg::Camera { .. }) {
        check_writable(&job.output)?;
    }
    let t_load = Instant::now();
    let mut scene = load_job_scene(job)?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    say(
        job,
        format!(
            "scene {}: {} triangles ({} degenerate dropped), {} lights, features: {} (loaded in {:.2} s)",
            job.scene.display(),
            scene.triangles.len(),
            scene.report.degenerate_dropped,
            scene.lights.lights.len(),
            scene.features,
            t_load.elapsed().as_secs_f64()
        ),
    );
    // Every plane and output is resolved and checked before the first one runs.
    let mut domains = Vec::new();
    match &job.domain {
        DomainArg::Slice {
            slices,
            window,
            res,
        } => {
            for (k, arg) in slices.iter().enumerate() {
                let plane = match arg {
                    SliceArg::Axis(a) => {
                        Plane::axis_slice(&scene.bounds, resolve_slice(a, &scene)?, *window, *res)?
                    }
                    SliceArg::Plane(spec) => Plane::from_spec(&scene.bounds, spec, *res)?,
                };
                let out = slice_output(&job.output, arg, k, slices.len());
                check_writable(&out)?;
                domains.push((JobDomain::Plane(plane), out));
            }
            if !job.flatland {
                job.estimator.resolve(&scene)?;
            }
        }
        DomainArg::Camera { camera, size } => {
            domains.push((
                JobDomain::Camera(resolve_camera(camera, &scene, *size)?),
                job.output.clone(),
            ));
        }
    }
    let mut outcomes = Vec::with_capacity(domains.len());
    for (domain, out) in &domains {
        let params = match domain {
            JobDomain::Plane(plane) if job.flatland => {
                let params = prepare_flatland(&mut scene, plane, &job.estimator)?;
                if let Some(f) = &scene.flat {
                    say(
                        job,
                        format!(
                            "flatland in {}: {} light cross-sections, 2D power {:.4}",
                            plane.label,
                            f.lights.lights.len(),
                            f.lights.total_power()
                        ),
                    );
                }
                params
            }
            _ => job.estimator.resolve(&scene)?,
        };
        let outcome = run_domain_job(job, &scene, domain, &params, out)?;
        let interrupted = !outcome.stats.stop.is_complete()
            && render::INTERRUPT.load(std::sync::atomic::Ordering::Relaxed);
        outcomes.push(outcome);
        if interrupted {
            break;
        }
    }
    Ok(outcomes)
}

/// Records the command-line point lights in the field's metadata: they are part of the scene, and
/// merging refuses fields computed with other lights.
fn annotate_point_lights(field: &mut Field, job: &Job) {
    if !job.point_lights.is_empty() {
        let lights: Vec<String> = job
            .point_lights
            .iter()
            .map(|(p, i)| format!("{}:{}", fmt_vec(*p), fmt_vec(*i)))
            .collect();
        field.meta.insert("point_lights".into(), lights.join(";"));
    }
}

fn say(job: &Job, s: String) {
    if !job.quiet {
        eprintln!("{s}");
    }
}

/// One domain of a job: progressive passes, checkpoints, resume, tile, summary, outputs.
fn run_domain_job(
    job: &Job,
    scene: &Scene,
    domain: &JobDomain,
    params: &Params,
    output: &Path,
) -> anyhow::Result<RunOutcome> {
    let opts = &job.render;
    let (name, kind) = match domain {
        JobDomain::Plane(p) => (format!("slice {}", p.label), "slice"),
        JobDomain::Camera(v) => (format!("camera '{}'", v.camera.name), "camera"),
    };
    let (w, h, d) = match domain {
        JobDomain::Plane(p) => p.dims(),
        JobDomain::Camera(v) => v.dims(),
    };
    let kernel = ftpd::kernel_for(params);
    if let JobDomain::Plane(p) = domain {
        check_flatland(scene, p, params)?;
    }
    let mut fresh = Field::new(w, h, d);
    describe_run(&mut fresh, scene, params, opts, kind);
    fresh.meta.extend(match domain {
        JobDomain::Plane(p) => plane_meta(p),
        JobDomain::Camera(v) => camera_meta(v),
    });
    fresh.meta.insert("kernel".into(), kernel.to_string());
    annotate_point_lights(&mut fresh, job);
    if let Some(t) = opts.tile {
        fresh.meta.insert("tile".into(), t.to_string());
    }
    let (mut field, mut progress) = match &job.resume {
        None => (fresh, Progress::default()),
        Some(path) => {
            let (mut f, p) = read_progress(path)?;
            check_resume(path, &f, &fresh.meta, (w, h, d))?;
            f.meta = fresh.meta;
            say(
                job,
                format!(
                    "resuming {}: {} passes done, {} samples, {:.1} s of compute so far{}",
                    path.display(),
                    p.passes,
                    f.total_samples(),
                    p.elapsed,
                    if p.inflight.is_some() {
                        "; finishing the interrupted pass first"
                    } else {
                        ""
                    }
                ),
            );
            (f, p)
        }
    };
    let mut budget_text = Vec::new();
    if opts.budget.cap_spp {
        budget_text.push(format!("{} spp", opts.spp));
    }
    if let Some(t) = opts.budget.time {
        budget_text.push(format!("time {}", fmt_duration(t)));
    }
    if let Some(e) = opts.budget.target_error {
        budget_text.push(format!("target error {e}"));
    }
    let tile_note = match opts.tile {
        Some(t) if t.rows(h).is_empty() => {
            eprintln!(
                "warning: --tile {t}: the grid has {h} rows, fewer than {} tiles; this tile is empty",
                t.count
            );
            String::new()
        }
        Some(t) => {
            let r = t.rows(h);
            format!(", tile {t} (rows {}..{})", r.start, r.end)
        }
        None => String::new(),
    };
    say(
        job,
        format!(
            "{name} → {w}x{h} cells{tile_note}, budget {}, passes: {}{}, weighting {}, T ∈ [{:.4}, {:.4}], θmax {}°",
            budget_text.join(" or "),
            Schedule::of(opts).key(),
            match opts.adaptive {
                Some(a) => format!(", adaptive (at most {}x the uniform share)", a.max_share),
                None => String::new(),
            },
            params.weighting,
            params.t0,
            params.t1,
            job.estimator.angle_deg
        ),
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let mut last_checkpoint = Instant::now();
    let mut checkpoint = |f: &mut Field, p: &Progress, _: &RunStats| -> anyhow::Result<()> {
        let Some(every) = job.checkpoint_every else {
            return Ok(());
        };
        if last_checkpoint.elapsed() < every {
            return Ok(());
        }
        mark_progress(f, p, opts, true, None);
        write_progress(f, p, output, false)?;
        last_checkpoint = Instant::now();
        say(
            job,
            format!(
                "checkpoint: {} passes written to {}",
                p.passes,
                output.display()
            ),
        );
        Ok(())
    };
    let hooks = Hooks {
        stop: Some(&render::INTERRUPT),
        after_pass: Some(&mut checkpoint),
    };
    let on_surfaces;
    let dom: &dyn Domain = match domain {
        // A slice through a wall: its points start on the surfaces' front sides.
        JobDomain::Plane(p) if scene.surface_in_plane(p.origin, p.normal()) => {
            on_surfaces = PlaneOnSurfaces(p);
            &on_surfaces
        }
        JobDomain::Plane(p) => p,
        JobDomain::Camera(v) => v,
    };
    let stats = run_domain_progressive(
        &pool,
        scene,
        dom,
        params,
        opts,
        &mut field,
        &mut progress,
        hooks,
    )?;
    let error = render::error_stats(&field.cells);
    let partial = !stats.stop.is_complete();
    mark_progress(&mut field, &progress, opts, partial, Some(stats.stop));
    say(job, summary(&field, &stats, &error, params));
    write_progress(&field, &progress, output, job.png)?;
    say(
        job,
        format!(
            "wrote {}{}",
            output.display(),
            if partial { " (partial)" } else { "" }
        ),
    );
    if partial {
        eprintln!(
            "to resume: {} --resume {}",
            job.command
                .as_deref()
                .unwrap_or("ftpd3d <the same arguments>"),
            shell_quote(&output.display().to_string())
        );
    }
    Ok(RunOutcome {
        field,
        stats,
        error,
        progress,
    })
}

/// The run summary: time, rates, passes, why the run stopped, the error, and what was clamped.
pub fn summary(field: &Field, stats: &RunStats, error: &ErrorStats, params: &Params) -> String {
    let unestimated = if error.unestimated > 0 {
        format!(
            " ({} of {} cells with σ > 0 have no estimate yet)",
            error.unestimated, error.cells
        )
    } else {
        String::new()
    };
    let total = field.total_samples();
    let earlier = if total > stats.samples {
        format!(" ({total} in the field with the resumed ones)")
    } else {
        String::new()
    };
    format!(
        "stopped after {} passes ({}): {} samples in {:.2} s{earlier}, {:.3e} samples/s, \
         {:.3e} rays/s; relative error mean {:.4}, p95 {:.4}{unestimated}; {} pairs hit the \
         bounce cap ({}), {} non-finite samples dropped",
        stats.passes,
        stats.stop,
        stats.samples,
        stats.seconds,
        stats.samples_per_second(),
        stats.rays_per_second(),
        error.mean,
        error.p95,
        stats.capped,
        params.max_bounces,
        stats.clamped
    ) + &cost_of_accuracy(
        total,
        stats.samples_per_second(),
        error.p95,
        params.weighting,
    )
    .map(|c| format!("\n{c}"))
    .unwrap_or_default()
}

/// What more accuracy costs, projected from this run: `None` without an error or a rate.
///
/// Monte Carlo error falls as samples^−½, so halving the p95 relative error takes 4× the samples
/// in all and one more digit 100×; the extra time is the samples still missing at the rate just
/// measured. Radiance weighting is slower than that at first (its contributions are heavy-tailed,
/// and its estimated error is optimistic at low samples), which the text says.
pub fn cost_of_accuracy(
    total_samples: u64,
    samples_per_second: f64,
    p95: f64,
    weighting: Weighting,
) -> Option<String> {
    if total_samples == 0 || !(samples_per_second > 0.0) || !(p95 > 0.0 && p95.is_finite()) {
        return None;
    }
    let more = |factor: f64| {
        let secs = (factor - 1.0) * total_samples as f64 / samples_per_second;
        Duration::try_from_secs_f64(secs).map_or_else(|_| "forever".into(), fmt_duration)
    };
    let caveat = if weighting == Weighting::Radiance {
        "; radiance weighting converges slower than this at first, `ftpd3d converge` measures it"
    } else {
        ""
    };
    Some(format!(
        "cost of accuracy (error ∝ samples^-1/2): p95 {:.3} needs 4x the samples (about {} more \
         at this rate), p95 {:.4} 100x (about {} more){caveat}",
        p95 / 2.0,
        more(4.0),
        p95 / 10.0,
        more(100.0)
    ))
}

/// `s` quoted for a POSIX shell when it needs it.
pub fn shell_quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

/// Importance-weighted FTPD over a camera image (the whole image, or the stripe `opts.tile`), with
/// its beauty image (`radiance.R/G/B`).
pub fn run_camera(
    scene: &Scene,
    view: &CameraView,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    let (mut field, stats) = run_domain(scene, view, params, opts)?;
    describe_run(&mut field, scene, params, opts, "camera");
    field.meta.extend(camera_meta(view));
    Ok((field, stats))
}

/// A volume run, validated enough to start (the rest is checked against the loaded scene).
#[derive(Clone, Debug)]
pub struct VolumeJob {
    pub scene: PathBuf,
    /// Extra point lights: position, radiant intensity.
    pub point_lights: Vec<(glam::DVec3, glam::DVec3)>,
    /// `--volume`: voxels along the longest side, or along each axis.
    pub res: VolumeRes,
    /// `--box xmin,ymin,zmin,xmax,ymax,zmax`; `None` = the scene bounds (flat sides padded).
    pub bbox: Option<[f64; 6]>,
    pub estimator: EstimatorArgs,
    pub render: RenderOptions,
    /// The `.vti` to write.
    pub output: PathBuf,
    /// Also write PNG previews of the middle z-slice.
    pub png: bool,
    pub quiet: bool,
}

/// Memory assumed when `/proc/meminfo` cannot be read: 8 GiB.
pub const FALLBACK_MEMORY_BYTES: u64 = 8 << 30;

/// Memory available to a new run: `MemAvailable` from `/proc/meminfo`, and whether it was read
/// (else [`FALLBACK_MEMORY_BYTES`]).
pub fn available_memory() -> (u64, bool) {
    let kb = std::fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines()
            .find_map(|l| l.strip_prefix("MemAvailable:"))
            .and_then(|r| r.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
    });
    match kb {
        Some(kb) => (kb.saturating_mul(1024), true),
        None => (FALLBACK_MEMORY_BYTES, false),
    }
}

/// `1.5 GB`, `640 GB`, `3.2 TB` (decimal units).
pub fn human_bytes(b: f64) -> String {
    let units = ["B", "kB", "MB", "GB", "TB", "PB", "EB"];
    let mut x = b;
    let mut u = 0;
    while x >= 1000.0 && u + 1 < units.len() {
        x /= 1000.0;
        u += 1;
    }
    if u == 0 || x >= 100.0 {
        format!("{x:.0} {}", units[u])
    } else {
        format!("{x:.1} {}", units[u])
    }
}

/// Memory a volume of `dims` voxels needs ([`output::vti::bytes_per_voxel`] each), without
/// overflowing however large the request.
pub fn volume_bytes(dims: [usize; 3]) -> u128 {
    dims.iter()
        .fold(1u128, |a, &d| a.saturating_mul(d as u128))
        .saturating_mul(output::vti::bytes_per_voxel() as u128)
}

/// The voxel counts of `res` over a box of `size`, refused (naming `--volume` and the largest grid
/// of the same shape that would fit) when they need more than `available` bytes. Arithmetic only:
/// this runs before anything is allocated.
pub fn check_volume_memory(
    res: VolumeRes,
    size: glam::DVec3,
    available: u64,
    measured: bool,
) -> anyhow::Result<[usize; 3]> {
    let dims = Volume::dims_for(res, size);
    let need = volume_bytes(dims);
    let fits = |d: [usize; 3]| volume_bytes(d) <= available as u128;
    if !fits(dims) {
        let suggestion = match res {
            VolumeRes::Longest(n) => {
                // Largest m < n whose grid fits (the count grows with m).
                let (mut lo, mut hi) = (0usize, n);
                while hi - lo > 1 {
                    let mid = lo + (hi - lo) / 2;
                    if fits(Volume::dims_for(VolumeRes::Longest(mid), size)) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                (lo >= 1).then_some(VolumeRes::Longest(lo))
            }
            VolumeRes::Dims(d) => {
                let mut f = (available as f64 / need as f64).cbrt();
                let mut best = None;
                while f > 0.0 {
                    let e = d.map(|x| ((x as f64 * f).floor() as usize).clamp(1, x));
                    if fits(e) {
                        best = Some(VolumeRes::Dims(e));
                        break;
                    }
                    if e == [1, 1, 1] {
                        break;
                    }
                    f *= 0.99;
                }
                best
            }
        };
        let voxels = dims.iter().map(|&d| d as f64).product::<f64>();
        let have = format!(
            "this machine has {} available{}",
            human_bytes(available as f64),
            if measured {
                ""
            } else {
                " (assumed: /proc/meminfo could not be read)"
            }
        );
        let fit = match suggestion {
            Some(r) => format!("; --volume {r} would fit"),
            None => String::new(),
        };
        bail!(
            "--volume {res}: {}x{}x{} = {voxels:.1e} voxels need {} of memory ({} bytes each), \
             {have}{fit}",
            dims[0],
            dims[1],
            dims[2],
            human_bytes(need as f64),
            output::vti::bytes_per_voxel()
        );
    }
    if let Some(d) = dims.iter().find(|&&d| d > i32::MAX as usize) {
        bail!("--volume {res}: {d} voxels along one axis is more than a VTK image can index");
    }
    Ok(dims)
}

/// How long a run should take, from a short calibration on a few random cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Eta {
    /// Estimated seconds for the whole run.
    pub seconds: f64,
    /// Samples per second measured.
    pub rate: f64,
    /// Cells and samples per cell of the last calibration round.
    pub cells: usize,
    pub spp: u32,
    /// Time spent calibrating, all rounds.
    pub calibration_seconds: f64,
}

/// Seconds the calibration aims at: its last round runs at least this long (or the whole spp).
pub const CALIBRATION_SECONDS: f64 = 0.25;

/// Estimates the run time of `domain` at `opts.spp` by running the same kernel on the same threads
/// over random cells (128 per thread to start, so every thread has work), doubling the samples per
/// cell, then the cells, until a round takes [`CALIBRATION_SECONDS`] (or covers the whole run).
/// Its samples come from other streams and are thrown away; the run itself is unchanged.
pub fn estimate_time(
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<Eta> {
    let (w, h, d) = domain.dims();
    let total = w * h * d;
    let threads = if opts.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        opts.threads
    };
    let mut pick = Sampler::new(opts.seed, u64::MAX, u64::MAX);
    let mut subset = Subset {
        inner: domain,
        cells: Vec::new(),
    };
    let mut want = (128 * threads).min(total);
    let mut o = opts.clone();
    o.progress = false;
    o.batches = 1;
    o.seed = opts.seed ^ 0xCA11_B4A7_E000_0000;
    o.spp = 1;
    o.tile = None;
    let start = Instant::now();
    loop {
        while subset.cells.len() < want {
            let c = (pick.next_f64() * total as f64) as usize;
            subset.cells.push(c.min(total - 1));
        }
        let (_, stats) = run_domain(scene, &subset, params, &o)?;
        let whole = o.spp >= opts.spp && want >= total;
        if stats.seconds >= CALIBRATION_SECONDS || whole {
            let rate = stats.samples_per_second();
            let samples = total as f64 * opts.spp as f64;
            return Ok(Eta {
                seconds: if rate > 0.0 { samples / rate } else { 0.0 },
                rate,
                cells: subset.cells.len(),
                spp: o.spp,
                calibration_seconds: start.elapsed().as_secs_f64(),
            });
        }
        if o.spp < opts.spp {
            o.spp = o.spp.saturating_mul(2).min(opts.spp);
        } else {
            want = want.saturating_mul(2).min(total);
        }
    }
}

/// Runs FTPD over a volume with the kernel chosen for the scene; the field (`nx` × `ny` × `nz`
/// cells) comes back with its metadata filled in.
pub fn run_volume(
    scene: &Scene,
    volume: &Volume,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    let (mut field, stats) = run_domain(scene, volume, params, opts)?;
    describe_run(&mut field, scene, params, opts, "volume");
    let m = &mut field.meta;
    let (lo, hi) = (volume.origin, volume.max_corner());
    m.insert(
        "volume.box".into(),
        format!("{},{},{},{},{},{}", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z),
    );
    m.insert(
        "volume.dims".into(),
        format!("{},{},{}", volume.nx, volume.ny, volume.nz),
    );
    m.insert("volume.spacing".into(), fmt_vec(volume.spacing));
    Ok((field, stats))
}

/// Runs a volume job end to end: load, check memory, estimate the time, run, write the `.vti` (and
/// PNG previews of the middle z-slice), print a summary on stderr.
pub fn run_volume_job(job: &VolumeJob) -> anyhow::Result<Field> {
    if job.render.spp == 0 {
        bail!("--spp 0: at least one sample per cell is needed");
    }
    if extension(&job.output).as_deref() != Some("vti") {
        bail!(
            "-o {}: a volume is written as VTK ImageData; name the file .vti",
            job.output.display()
        );
    }
    check_writable(&job.output)?;
    let t_load = Instant::now();
    let scene = load_scene_with_lights(&job.scene, &job.point_lights)?;
    let params = job.estimator.resolve(&scene)?;
    let bbox = Volume::resolve_box(&scene.bounds, job.bbox)?;
    let (available, measured) = available_memory();
    let dims = check_volume_memory(job.res, bbox.max - bbox.min, available, measured)?;
    let volume = Volume::new(&bbox, dims)?;
    let say = |s: String| {
        if !job.quiet {
            eprintln!("{s}");
        }
    };
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    say(format!(
        "scene {}: {} triangles ({} degenerate dropped), {} lights, features: {} (loaded in {:.2} s)",
        job.scene.display(),
        scene.triangles.len(),
        scene.report.degenerate_dropped,
        scene.lights.lights.len(),
        scene.features,
        t_load.elapsed().as_secs_f64()
    ));
    say(format!(
        "volume {}x{}x{} voxels over [{}] .. [{}], spacing [{}], {} spp in {} batches, \
         weighting {}, T ∈ [{:.4}, {:.4}], θmax {}°; memory {} of {} available",
        volume.nx,
        volume.ny,
        volume.nz,
        fmt_vec(bbox.min),
        fmt_vec(bbox.max),
        fmt_vec(volume.spacing),
        job.render.spp,
        job.render.batches,
        params.weighting,
        params.t0,
        params.t1,
        job.estimator.angle_deg,
        human_bytes(volume_bytes(dims) as f64),
        human_bytes(available as f64),
    ));
    let eta = if job.quiet {
        None
    } else {
        let e = estimate_time(&scene, &volume, &params, &job.render)?;
        say(format!(
            "ETA {:.1} s ({:.3e} samples/s on {} random voxels × {} spp, calibrated in {:.2} s)",
            e.seconds, e.rate, e.cells, e.spp, e.calibration_seconds
        ));
        Some(e)
    };
    let (field, stats) = run_volume(&scene, &volume, &params, &job.render)?;
    let (rel_mean, rel_p95) = relative_error_summary(&field);
    say(format!(
        "done in {:.2} s{}: {:.3e} samples/s, {:.3e} rays/s; relative error mean {:.3}, p95 {:.3}; \
         {} pairs hit the bounce cap ({}), {} non-finite samples dropped",
        stats.seconds,
        eta.map(|e| format!(" (ETA was {:.1} s)", e.seconds))
            .unwrap_or_default(),
        stats.samples_per_second(),
        stats.rays_per_second(),
        rel_mean,
        rel_p95,
        stats.capped,
        params.max_bounces,
        stats.clamped
    ));
    if let Some(c) = cost_of_accuracy(
        field.total_samples(),
        stats.samples_per_second(),
        rel_p95,
        params.weighting,
    ) {
        say(c);
    }
    write_volume_outputs(
        &field,
        volume.vtk_origin(),
        volume.spacing,
        &job.output,
        job.png,
    )?;
    say(format!("wrote {}", job.output.display()));
    Ok(field)
}

/// One benchmark run: the kernel and raw Embree rays, on the same scene, slice, samples and
/// threads.
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub kernel: crate::kernel::KernelChoice,
    pub run: RunStats,
    pub raw_rays: u64,
    pub raw_seconds: f64,
}

impl BenchReport {
    pub fn raw_rays_per_second(&self) -> f64 {
        if self.raw_seconds > 0.0 {
            self.raw_rays as f64 / self.raw_seconds
        } else {
            0.0
        }
    }
    /// Kernel rays/s over raw rays/s.
    pub fn ray_ratio(&self) -> f64 {
        let raw = self.raw_rays_per_second();
        if raw > 0.0 {
            self.run.rays_per_second() / raw
        } else {
            0.0
        }
    }
}

/// Runs the FTPD kernel over `plane`, then replays through Embree alone (`rtcIntersect1` /
/// `rtcOccluded1`, nothing else) exactly the rays the kernel traced, recorded in a separate untimed
/// run, on the same number of threads. Each part runs `repeats` times, interleaved, and the fastest
/// time of each is kept (shared, noisy machines).
pub fn bench_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
    repeats: u32,
) -> anyhow::Result<BenchReport> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let rays = record_rays(scene, plane, params, opts, &pool)?;
    let accel = scene.accel();
    let (mut run, mut raw_seconds) = (None::<RunStats>, f64::INFINITY);
    for _ in 0..repeats.max(1) {
        let r = run_plane(scene, plane, params, opts)?.1;
        if run.as_ref().is_none_or(|a| r.seconds < a.seconds) {
            run = Some(r);
        }
        let start = Instant::now();
        let hits: u64 = pool.install(|| {
            rays.par_chunks(4096)
                .map(|chunk| {
                    let mut h = 0u64;
                    for r in chunk {
                        h += if r.shadow {
                            accel.occluded(r.o, r.d, 0.0, r.tfar) as u64
                        } else {
                            accel.intersect(r.o, r.d, 0.0, r.tfar).is_some() as u64
                        };
                    }
                    h
                })
                .sum()
        });
        std::hint::black_box(hits);
        raw_seconds = raw_seconds.min(start.elapsed().as_secs_f64());
    }
    Ok(BenchReport {
        kernel: ftpd::kernel_for(params),
        run: run.unwrap_or_default(),
        raw_rays: rays.len() as u64,
        raw_seconds,
    })
}

/// Every ray query of one run of the kernel over `plane` (the same random decisions, hence the
/// same rays, as the timed runs), gathered from the pool's threads.
fn record_rays(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
    pool: &rayon::ThreadPool,
) -> anyhow::Result<Vec<crate::transport::trace::LoggedRay>> {
    struct Recording<'a> {
        scene: &'a Scene,
        domain: &'a dyn Domain,
        params: &'a Params,
        opts: &'a RenderOptions,
        pool: &'a rayon::ThreadPool,
    }
    impl WithKernel for Recording<'_> {
        type Output = anyhow::Result<()>;
        fn run<K: Kernel>(self) -> anyhow::Result<()> {
            let (w, h, d) = self.domain.dims();
            let mut field = Field::new(w, h, d);
            render::run_in(self.pool, &mut field, self.opts, |cell, s: &mut Sampler| {
                let start = self.domain.start(self.scene, cell, s);
                ftpd::sample::<K>(self.scene, start, self.params, s)
            })?;
            Ok(())
        }
    }
    let mut o = opts.clone();
    o.progress = false;
    let on_surfaces = PlaneOnSurfaces(plane);
    let domain: &dyn Domain = if scene.surface_in_plane(plane.origin, plane.normal()) {
        &on_surfaces
    } else {
        plane
    };
    kernel::dispatch_recording(
        ftpd::kernel_for(params),
        Recording {
            scene,
            domain,
            params,
            opts: &o,
            pool,
        },
    )?;
    // Gather the logs of every worker of the pool.
    Ok(pool
        .broadcast(|_| crate::transport::trace::take_ray_log())
        .into_iter()
        .flatten()
        .collect())
}
