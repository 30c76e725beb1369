//! The validated job and what the command line runs: load, estimate, write, summarise.
//! `main.rs` parses arguments into a [`Job`]; everything here returns errors, never panics.

use crate::domain::slice::SliceSpec;
use crate::domain::{CameraView, Domain, Plane, PlaneOnSurfaces};
use crate::field::Field;
use crate::ftpd::{self, Params, Weighting};
use crate::kernel::{self, Kernel, KernelChoice, WithKernel};
use crate::output;
use crate::render::{self, RenderOptions, RunStats};
use crate::rng::Sampler;
use crate::scene::{self, Scene};
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use std::time::Instant;

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
        let d = scene.extent();
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
        })
    }
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
    pub render: RenderOptions,
    pub output: PathBuf,
    pub png: bool,
    pub quiet: bool,
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

/// Fails early when `path`'s directory cannot take a new file (before hours of work).
pub fn check_writable(path: &Path) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir).with_context(|| {
        format!(
            "-o {}: cannot create directory {}",
            path.display(),
            dir.display()
        )
    })?;
    if path.is_dir() {
        bail!("-o {}: is a directory", path.display());
    }
    let probe = output::temp_path(path);
    std::fs::write(&probe, b"").with_context(|| {
        format!(
            "-o {}: directory {} is not writable",
            path.display(),
            dir.display()
        )
    })?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
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
    m.insert("spp".into(), opts.spp.to_string());
    m.insert("batches".into(), opts.batches.to_string());
    m.insert("features".into(), scene.features.to_string());
}

/// The kernel for a scene and parameters: specialised to the scene's features, or every effect.
pub fn kernel_choice(scene: &Scene, params: &Params, specialise: bool) -> KernelChoice {
    if specialise {
        KernelChoice::new(&scene.features, !scene.normals.is_empty(), params.weighting)
    } else {
        KernelChoice::all(params.weighting)
    }
}

/// Runs FTPD over a plane with the kernel chosen for the scene; the field comes back with its
/// metadata filled in.
pub fn run_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    run_plane_with(
        scene,
        plane,
        params,
        opts,
        kernel_choice(scene, params, true),
    )
}

/// Runs FTPD over any domain with the given kernel (which must cover the scene's features).
pub fn run_domain_with<D: Domain>(
    scene: &Scene,
    domain: &D,
    params: &Params,
    opts: &RenderOptions,
    kernel: KernelChoice,
) -> anyhow::Result<(Field, RunStats)> {
    struct DomainRun<'a, D> {
        scene: &'a Scene,
        domain: &'a D,
        params: &'a Params,
        opts: &'a RenderOptions,
    }
    impl<D: Domain> WithKernel for DomainRun<'_, D> {
        type Output = anyhow::Result<(Field, RunStats)>;
        fn run<K: Kernel>(self) -> Self::Output {
            let DomainRun {
                scene,
                domain,
                params,
                opts,
            } = self;
            let (w, h, d) = domain.dims();
            let mut field = Field::new(w, h, d);
            let stats = render::run(&mut field, opts, |cell, s: &mut Sampler| {
                domain.sample::<K>(scene, cell, params, s)
            })?;
            Ok((field, stats))
        }
    }
    let (mut field, stats) = kernel::dispatch(
        kernel,
        DomainRun {
            scene,
            domain,
            params,
            opts,
        },
    )?;
    field.meta.insert("kernel".into(), kernel.to_string());
    Ok((field, stats))
}

/// [`run_plane`] with a given kernel (which must cover the scene's features).
pub fn run_plane_with(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
    kernel: KernelChoice,
) -> anyhow::Result<(Field, RunStats)> {
    let (mut field, stats) = if scene.surface_in_plane(plane.origin, plane.normal()) {
        run_domain_with(scene, &PlaneOnSurfaces(plane), params, opts, kernel)?
    } else {
        run_domain_with(scene, plane, params, opts, kernel)?
    };
    describe_run(&mut field, scene, params, opts, "slice");
    let m = &mut field.meta;
    m.insert("plane".into(), plane.label.clone());
    m.insert("plane.origin".into(), fmt_vec(plane.origin));
    m.insert("plane.u".into(), fmt_vec(plane.u_axis));
    m.insert("plane.v".into(), fmt_vec(plane.v_axis));
    m.insert(
        "plane.size".into(),
        format!("{},{}", plane.size.0, plane.size.1),
    );
    Ok((field, stats))
}

fn fmt_vec(v: glam::DVec3) -> String {
    format!("{},{},{}", v.x, v.y, v.z)
}

/// Mean and 95th percentile of the relative standard error over valid cells with σ > 0.
pub fn relative_error_summary(field: &Field) -> (f64, f64) {
    let mut rel: Vec<f64> = field
        .values()
        .iter()
        .filter(|v| v.valid && v.sigma > 0.0)
        .map(|v| v.stderr / v.sigma)
        .filter(|r| r.is_finite())
        .collect();
    if rel.is_empty() {
        return (0.0, 0.0);
    }
    rel.sort_by(f64::total_cmp);
    let mean = rel.iter().sum::<f64>() / rel.len() as f64;
    let p95 = rel[((rel.len() as f64 * 0.95) as usize).min(rel.len() - 1)];
    (mean, p95)
}

/// Loads the job's scene and adds its command-line point lights.
pub fn load_job_scene(job: &Job) -> anyhow::Result<Scene> {
    let mut scene = load_scene(&job.scene)?;
    for (p, i) in &job.point_lights {
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

/// Runs a job end to end: load, estimate, write EXR (and PNG) per plane or camera, print a summary
/// on stderr. Every output location is checked before any work.
pub fn run_job(job: &Job) -> anyhow::Result<Vec<Field>> {
    if job.render.spp == 0 {
        bail!("--spp 0: at least one sample per cell is needed");
    }
    match &job.domain {
        DomainArg::Slice { res, .. } if *res == 0 || *res > MAX_RES => {
            bail!("--res {res}: must be between 1 and {MAX_RES}")
        }
        DomainArg::Camera { size: (w, h), .. }
            if *w == 0 || *h == 0 || *w > MAX_RES || *h > MAX_RES =>
        {
            bail!("--size {w},{h}: each side must be between 1 and {MAX_RES}")
        }
        _ => {}
    }
    if matches!(job.domain, DomainArg::Camera { .. }) {
        check_writable(&job.output)?;
    }
    let t_load = Instant::now();
    let scene = load_job_scene(job)?;
    let params = job.estimator.resolve(&scene)?;
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
    let describe = |what: String, w: usize, h: usize| {
        format!(
            "{what} → {w}x{h} cells, {} spp in {} batches, weighting {}, T ∈ [{:.4}, {:.4}], θmax {}°",
            job.render.spp,
            job.render.batches,
            params.weighting,
            params.t0,
            params.t1,
            job.estimator.angle_deg
        )
    };
    let report = |field: &Field, stats: &RunStats| {
        let (rel_mean, rel_p95) = relative_error_summary(field);
        say(format!(
            "done in {:.2} s: {:.3e} samples/s, {:.3e} rays/s; relative error mean {:.3}, p95 {:.3}; \
             {} pairs hit the bounce cap ({}), {} non-finite samples dropped",
            stats.seconds,
            stats.samples_per_second(),
            stats.rays_per_second(),
            rel_mean,
            rel_p95,
            stats.capped,
            params.max_bounces,
            stats.clamped
        ));
    };
    let (field, stats) = match &job.domain {
        DomainArg::Slice {
            slices,
            window,
            res,
        } => {
            let mut planes = Vec::with_capacity(slices.len());
            for (k, arg) in slices.iter().enumerate() {
                let plane = match arg {
                    SliceArg::Axis(a) => {
                        Plane::axis_slice(&scene.bounds, resolve_slice(a, &scene)?, *window, *res)?
                    }
                    SliceArg::Plane(spec) => Plane::from_spec(&scene.bounds, spec, *res)?,
                };
                let out = slice_output(&job.output, arg, k, slices.len());
                check_writable(&out)?;
                planes.push((plane, out));
            }
            let mut fields = Vec::with_capacity(planes.len());
            for (plane, out) in &planes {
                say(describe(
                    format!("slice {}", plane.label),
                    plane.width,
                    plane.height,
                ));
                let (field, stats) = run_plane(&scene, plane, &params, &job.render)?;
                report(&field, &stats);
                write_outputs(&field, out, job.png)?;
                say(format!("wrote {}", out.display()));
                fields.push(field);
            }
            return Ok(fields);
        }
        DomainArg::Camera { camera, size } => {
            let view = resolve_camera(camera, &scene, *size)?;
            say(describe(
                format!("camera '{}'", view.camera.name),
                view.width,
                view.height,
            ));
            run_camera(&scene, &view, &params, &job.render)?
        }
    };
    report(&field, &stats);
    write_outputs(&field, &job.output, job.png)?;
    say(format!("wrote {}", job.output.display()));
    Ok(vec![field])
}

/// Importance-weighted FTPD over a camera image, with its beauty image (`radiance.R/G/B`).
pub fn run_camera(
    scene: &Scene,
    view: &CameraView,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    let (mut field, stats) = run_domain_with(
        scene,
        view,
        params,
        opts,
        kernel_choice(scene, params, true),
    )?;
    describe_run(&mut field, scene, params, opts, "camera");
    let c = &view.camera;
    let m = &mut field.meta;
    m.insert("camera".into(), c.name.clone());
    m.insert("camera.eye".into(), fmt_vec(c.eye));
    m.insert("camera.forward".into(), fmt_vec(c.forward));
    m.insert("camera.up".into(), fmt_vec(c.up));
    m.insert(
        "camera.fov_y_deg".into(),
        format!("{}", c.fov_y.to_degrees()),
    );
    Ok((field, stats))
}

/// Writes the EXR (with the Sobel gradient of σ as `grad.x`/`grad.y`, per cell) and, when asked,
/// PNG previews next to it: `<name>.png` (σ, equalised CIELAB map) and `<name>.grad.png` (gradient
/// direction as hue, magnitude as lightness).
pub fn write_outputs(field: &Field, path: &Path, png: bool) -> anyhow::Result<()> {
    let sigma = field.sigma();
    let valid = field.valid();
    let (w, h) = (field.width, field.height);
    let (gx, gy) = output::png::sobel(&sigma, &valid, w, h);
    output::exr::write_exr(path, field, &[("grad.x", gx), ("grad.y", gy)])?;
    if png {
        output::png::write_field_preview(&path.with_extension("png"), &sigma, &valid, w, h)?;
        output::png::write_gradient_preview(
            &path.with_extension("grad.png"),
            &sigma,
            &valid,
            w,
            h,
        )?;
    }
    Ok(())
}

/// One benchmark run: the specialised kernel, the all-features kernel and raw Embree rays, on the
/// same scene, slice, samples and threads.
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub kernel: KernelChoice,
    pub specialised: RunStats,
    pub all_features: RunStats,
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
    /// Specialised kernel rays/s over raw rays/s.
    pub fn ray_ratio(&self) -> f64 {
        let raw = self.raw_rays_per_second();
        if raw > 0.0 {
            self.specialised.rays_per_second() / raw
        } else {
            0.0
        }
    }
    /// Specialised over all-features samples/s.
    pub fn specialisation_gain(&self) -> f64 {
        let all = self.all_features.samples_per_second();
        if all > 0.0 {
            self.specialised.samples_per_second() / all
        } else {
            0.0
        }
    }
}

/// Runs the specialised FTPD kernel over `plane`, then the all-features kernel on the same samples,
/// then replays through Embree alone (`rtcIntersect1` / `rtcOccluded1`, nothing else) exactly the
/// rays the kernel traced, recorded in a separate untimed run, on the same number of threads. Each
/// part runs `repeats` times, interleaved, and the fastest time of each is kept (shared, noisy
/// machines).
pub fn bench_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
    repeats: u32,
) -> anyhow::Result<BenchReport> {
    use rayon::prelude::*;
    let kernel = kernel_choice(scene, params, true);
    let fastest = |a: Option<RunStats>, b: RunStats| match a {
        Some(a) if a.seconds <= b.seconds => Some(a),
        _ => Some(b),
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let rays = record_rays(scene, plane, params, opts, &pool)?;
    let accel = scene.accel();
    let (mut spec, mut all, mut raw_seconds) = (None, None, f64::INFINITY);
    for _ in 0..repeats.max(1) {
        spec = fastest(spec, run_plane_with(scene, plane, params, opts, kernel)?.1);
        let all_kernel = kernel_choice(scene, params, false);
        all = fastest(
            all,
            run_plane_with(scene, plane, params, opts, all_kernel)?.1,
        );
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
        kernel,
        specialised: spec.unwrap_or_default(),
        all_features: all.unwrap_or_default(),
        raw_rays: rays.len() as u64,
        raw_seconds,
    })
}

/// Every ray query of one run of the all-features kernel (which makes the same random decisions,
/// hence the same rays, as the specialised one), gathered from the pool's threads.
fn record_rays(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
    pool: &rayon::ThreadPool,
) -> anyhow::Result<Vec<scene::LoggedRay>> {
    use crate::kernel::{AllButRadiance, AllFeatures, Record};
    let mut field = Field::new(plane.width, plane.height, 1);
    let mut o = opts.clone();
    o.progress = false;
    let radiance = params.weighting == Weighting::Radiance;
    let on_surfaces = scene.surface_in_plane(plane.origin, plane.normal());
    render::run_in(pool, &mut field, &o, |cell, s: &mut Sampler| {
        let x = plane.point(cell, s.next_2d());
        let x = if on_surfaces {
            scene.off_surfaces(x)
        } else {
            x
        };
        if radiance {
            ftpd::sample_at_k::<Record<AllFeatures>>(scene, x, params, s)
        } else {
            ftpd::sample_at_k::<Record<AllButRadiance>>(scene, x, params, s)
        }
    })?;
    // Gather the logs of every worker of the pool.
    Ok(pool
        .broadcast(|_| scene::take_ray_log())
        .into_iter()
        .flatten()
        .collect())
}
