//! The validated job and what the command line runs: load, estimate, write, summarise.
//! `main.rs` parses arguments into a [`SliceJob`]; everything here returns errors, never panics.

use crate::domain::Plane;
use crate::domain::slice::SliceSpec;
use crate::field::Field;
use crate::ftpd::{self, Params, Weighting};
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
        if self.weighting == Weighting::Importance {
            bail!(
                "--weight importance needs a camera domain, which is not available yet; use radiance or unweighted"
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

/// A slice run, validated enough to start (the rest is checked against the loaded scene).
#[derive(Clone, Debug)]
pub struct SliceJob {
    pub scene: PathBuf,
    pub slice: SliceSpec,
    pub window: Option<[f64; 4]>,
    pub res: usize,
    pub estimator: EstimatorArgs,
    pub render: RenderOptions,
    pub output: PathBuf,
    pub png: bool,
    pub quiet: bool,
}

/// Largest accepted `--res`.
pub const MAX_RES: usize = 16384;

/// Loads a scene by its extension.
pub fn load_scene(path: &Path) -> anyhow::Result<Scene> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("obj") => scene::obj::load(path),
        Some("gltf" | "glb") => scene::gltf::load(path),
        Some(other) => bail!(
            "{}: unsupported scene format '.{other}' (supported: .obj, .gltf, .glb)",
            path.display()
        ),
        None => bail!(
            "{}: no file extension; expected a .obj, .gltf or .glb scene",
            path.display()
        ),
    }
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

/// Runs FTPD over a plane; the field comes back with its metadata filled in.
pub fn run_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    let mut field = Field::new(plane.width, plane.height, 1);
    let stats = render::run(&mut field, opts, |cell, s: &mut Sampler| {
        let x = plane.point(cell, s.next_2d());
        ftpd::sample_at(scene, x, params, s)
    })?;
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

/// Runs a slice job end to end: load, estimate, write EXR (and PNG), print a summary on stderr.
pub fn run_slice_job(job: &SliceJob) -> anyhow::Result<Field> {
    if job.res == 0 || job.res > MAX_RES {
        bail!("--res {}: must be between 1 and {MAX_RES}", job.res);
    }
    if job.render.spp == 0 {
        bail!("--spp 0: at least one sample per cell is needed");
    }
    check_writable(&job.output)?;
    let t_load = Instant::now();
    let scene = load_scene(&job.scene)?;
    let params = job.estimator.resolve(&scene)?;
    let plane = Plane::axis_slice(&scene.bounds, job.slice, job.window, job.res)?;
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
        "slice {} → {}x{} cells, {} spp in {} batches, weighting {}, T ∈ [{:.4}, {:.4}], θmax {}°",
        plane.label,
        plane.width,
        plane.height,
        job.render.spp,
        job.render.batches,
        params.weighting,
        params.t0,
        params.t1,
        job.estimator.angle_deg
    ));
    let (field, stats) = run_plane(&scene, &plane, &params, &job.render)?;
    let (rel_mean, rel_p95) = relative_error_summary(&field);
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
    write_outputs(&field, &job.output, job.png)?;
    say(format!("wrote {}", job.output.display()));
    Ok(field)
}

/// Writes the EXR and, when asked, a PNG preview next to it.
pub fn write_outputs(field: &Field, path: &Path, png: bool) -> anyhow::Result<()> {
    output::exr::write_exr(path, field, &[])?;
    let _ = png;
    Ok(())
}

/// Kernel rays/s against raw Embree rays/s on the same scene, rays and thread count.
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub kernel: RunStats,
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
    pub fn ratio(&self) -> f64 {
        let raw = self.raw_rays_per_second();
        if raw > 0.0 {
            self.kernel.rays_per_second() / raw
        } else {
            0.0
        }
    }
}

/// Runs the FTPD kernel over `plane`, then traces as many plain closest-hit rays through Embree
/// (`rtcIntersect1` and nothing else: origins jittered in the same cells, uniform directions, the
/// same maximum distance t1) on the same number of threads, and reports both rates.
pub fn bench_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<BenchReport> {
    use crate::transport::sampling::sample_uniform_sphere;
    use rayon::prelude::*;
    let (_, kernel) = run_plane(scene, plane, params, opts)?;
    let cells = plane.cells() as u64;
    let per_cell = kernel.rays.div_ceil(cells.max(1));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let accel = scene.accel();
    let tmax = params.t1 as f32;
    let start = Instant::now();
    let hits: u64 = pool.install(|| {
        (0..cells as usize)
            .into_par_iter()
            .with_min_len(64)
            .map(|cell| {
                let cell = cell as u64;
                let mut s = Sampler::new(opts.seed ^ 0xbe7c4, 0, cell);
                let mut h = 0u64;
                for _ in 0..per_cell {
                    let o = plane.point(cell as usize, s.next_2d()).as_vec3();
                    let d = sample_uniform_sphere(s.next_2d()).as_vec3();
                    h += accel.intersect(o, d, 0.0, tmax).is_some() as u64;
                }
                h
            })
            .sum()
    });
    let raw_seconds = start.elapsed().as_secs_f64();
    std::hint::black_box(hits);
    Ok(BenchReport {
        kernel,
        raw_rays: per_cell * cells,
        raw_seconds,
    })
}
