//! The validated job and what the command line runs: load, estimate, write, summarise.
//! `main.rs` parses arguments into a [`Job`] (slices, planes, camera images and volumes alike);
//! everything here returns errors, never panics.

mod memory;
mod progress;

pub use memory::{FALLBACK_MEMORY_BYTES, available_memory, check_volume_memory, volume_bytes};
use progress::grid_text;
pub use progress::{
    RESUME_KEYS, check_resume, mark_progress, read_progress, write_progress, write_progress_with,
    write_volume_progress, write_volume_progress_with,
};

use crate::analysis::separatrix::{self, SepParams};
use crate::cli::report::{fmt_duration, human_bytes, scene_line, shell_quote, summary};
use crate::domain::slice::{SliceArg, resolve_plane};
use crate::domain::volume::Volume;
use crate::domain::{CameraView, Domain, MAX_RES, Plane, PlaneDomain, VolumeRes};
use crate::field::Field;
use crate::ftpd::Params;
use crate::output::check_writable;
use crate::render::{self, ErrorStats, Hooks, Progress, RenderOptions, RunStats, Schedule};
use crate::run::{
    EstimatorArgs, camera_info, check_flatland, describe_run, estimate_time, fmt_vec, plane_info,
    prepare_flatland, run_domain_progressive, volume_info,
};
use crate::run_info::{DomainKind, RunInfo};
use crate::scene::load::{LoadOptions, extension, load_scene_with};
use crate::scene::{self, Scene};
use anyhow::{Context, bail};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

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
    /// A voxel grid, written as `.vti`: `res` voxels (`--volume`) over `bbox`
    /// (`--box xmin,ymin,zmin,xmax,ymax,zmax`; `None` = the scene bounds, flat sides padded).
    Volume {
        res: VolumeRes,
        bbox: Option<[f64; 6]>,
    },
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
    /// Lights from the command line (`--point-light`, `--sun`, `--sky`).
    pub lights: Vec<crate::scene::Light>,
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
    /// Extract separatrices from the finished field (`--separatrices`): extra channels in the
    /// output and the side files of [`crate::analysis::separatrix::side_paths`].
    pub separatrices: Option<SepParams>,
    /// How the scene file is read (strict loading or not).
    pub load: LoadOptions,
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
    Ok(CameraView::new(camera, size.0, size.1)?)
}

/// What [`run_job`] did.
#[derive(Clone, Debug)]
pub struct RunOutcome {
    pub field: Field,
    pub stats: RunStats,
    pub error: ErrorStats,
    pub progress: Progress,
}

/// The domain of a job, resolved against its scene.
enum JobDomain {
    Plane(Plane),
    Camera(CameraView),
    Volume(Volume),
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
        DomainArg::Volume { .. } if job.flatland => {
            bail!("--flatland works on slices (the plane confines the directions), not volumes")
        }
        DomainArg::Volume { .. } if extension(&job.output).as_deref() != Some("vti") => {
            bail!(
                "-o {}: a volume is written as VTK ImageData; name the file .vti",
                job.output.display()
            )
        }
        _ => {}
    }
    if let Some(r) = &job.resume
        && !r.is_file()
    {
        bail!("--resume {}: no such file", r.display());
    }
    if matches!(
        job.domain,
        DomainArg::Camera { .. } | DomainArg::Volume { .. }
    ) {
        check_writable(&job.output)?;
    }
    let t_load = Instant::now();
    let mut scene = load_scene_with(&job.scene, &job.lights, &job.load)?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    say(job, scene_line(&job.scene, &scene, t_load.elapsed()));
    // Every plane and output is resolved and checked before the first one runs.
    let mut domains = Vec::new();
    match &job.domain {
        DomainArg::Slice {
            slices,
            window,
            res,
        } => {
            for (k, arg) in slices.iter().enumerate() {
                let plane = resolve_plane(arg, &scene, *window, *res)?;
                let out = slice_output(&job.output, arg, k, slices.len());
                check_writable(&out)?;
                if !job.flatland {
                    job.estimator.resolve_for_plane(&scene, &plane)?;
                }
                domains.push((JobDomain::Plane(plane), out));
            }
        }
        DomainArg::Camera { camera, size } => {
            if scene.lights.is_empty() {
                eprintln!(
                    "warning: {} has no lights ({}): the beauty image (radiance.R/G/B) will be \
                     black; add one with --point-light X,Y,Z:R,G,B, --sun X,Y,Z:R,G,B, --sky \
                     R,G,B or --env FILE",
                    job.scene.display(),
                    crate::run::ways_to_light(&scene)
                );
            }
            domains.push((
                JobDomain::Camera(resolve_camera(camera, &scene, *size)?),
                job.output.clone(),
            ));
        }
        DomainArg::Volume { res, bbox } => {
            let bbox = Volume::resolve_box(&scene.bounds, *bbox)?;
            job.estimator.resolve_for_box(&scene, &bbox)?;
            // Refused before anything is allocated (the resumed file included).
            let (available, measured) = available_memory();
            let dims = check_volume_memory(*res, bbox.max - bbox.min, available, measured)?;
            let volume = Volume::new(&bbox, dims)?;
            say(
                job,
                format!(
                    "volume {}x{}x{} voxels over [{}] .. [{}], spacing [{}]; memory {} of {} \
                     available",
                    volume.nx,
                    volume.ny,
                    volume.nz,
                    fmt_vec(bbox.min),
                    fmt_vec(bbox.max),
                    fmt_vec(volume.spacing),
                    human_bytes(volume_bytes(dims) as f64),
                    human_bytes(available as f64),
                ),
            );
            domains.push((JobDomain::Volume(volume), job.output.clone()));
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
            JobDomain::Plane(plane) => job.estimator.resolve_for_plane(&scene, plane)?,
            JobDomain::Camera(view) => job.estimator.resolve_for_camera(&scene, view.camera.eye)?,
            JobDomain::Volume(v) => job.estimator.resolve_for_box(
                &scene,
                &scene::Aabb {
                    min: v.origin,
                    max: v.max_corner(),
                },
            )?,
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

/// The command-line sun and sky (environment map) in their flags' syntax, for the run's
/// description: they are part of the scene, and merging refuses fields computed with others.
fn describe_cli_sun_and_sky(job: &Job) -> (Option<String>, Option<String>) {
    use crate::scene::Light;
    let (mut suns, mut skies) = (Vec::new(), Vec::new());
    for l in &job.lights {
        match l {
            Light::Distant {
                direction,
                irradiance,
                half_angle,
                ..
            } => suns.push(format!(
                "{}:{}:{}",
                fmt_vec(*direction),
                fmt_vec(*irradiance),
                (2.0 * half_angle).to_degrees()
            )),
            Light::Sky { radiance } => skies.push(fmt_vec(*radiance)),
            Light::Env(env) => skies.push(format!(
                "{}:{}:{}",
                env.map.source,
                env.map.scale,
                env.map.rotation.to_degrees()
            )),
            Light::Area { .. } | Light::Point { .. } | Light::Spot { .. } => {}
        }
    }
    let joined = |v: Vec<String>| (!v.is_empty()).then(|| v.join(";"));
    (joined(suns), joined(skies))
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
        JobDomain::Plane(p) => (format!("slice {}", p.label), DomainKind::Slice),
        JobDomain::Camera(v) => (format!("camera '{}'", v.camera.name), DomainKind::Camera),
        JobDomain::Volume(_) => ("volume".to_string(), DomainKind::Volume),
    };
    let plane_domain;
    let dom: &dyn Domain = match domain {
        JobDomain::Plane(p) => {
            plane_domain = PlaneDomain::new(p, scene);
            &plane_domain
        }
        JobDomain::Camera(v) => v,
        JobDomain::Volume(v) => v,
    };
    let (w, h, d) = dom.dims();
    // What a tile splits: a 2D grid's rows, a volume's z layers (see `Tile::cells`).
    let (rows, row_name) = if d > 1 { (d, "z layers") } else { (h, "rows") };
    let write_with = |f: &Field, p: &Progress, png: bool, more| match domain {
        JobDomain::Volume(v) => write_volume_progress_with(f, p, v, output, png, more),
        _ => write_progress_with(f, p, output, png, more),
    };
    let write = |f: &Field, p: &Progress, png: bool| write_with(f, p, png, Vec::new());
    if let JobDomain::Plane(p) = domain {
        check_flatland(scene, p, params)?;
    }
    // The run's description; the command-line lights are part of the scene (merge refuses
    // fields computed with other lights).
    let (sun, sky) = describe_cli_sun_and_sky(job);
    let mut info = RunInfo {
        plane: match domain {
            JobDomain::Plane(p) => Some(plane_info(p)),
            _ => None,
        },
        camera: match domain {
            JobDomain::Camera(v) => Some(camera_info(v)),
            _ => None,
        },
        volume: match domain {
            JobDomain::Volume(v) => Some(volume_info(v)),
            _ => None,
        },
        point_lights: job
            .lights
            .iter()
            .filter_map(|l| match l {
                crate::scene::Light::Point {
                    position,
                    intensity,
                } => Some((*position, *intensity)),
                _ => None,
            })
            .collect(),
        sun: sun.clone(),
        sky: sky.clone(),
        ..describe_run(scene, params, opts, kind)
    };
    let (mut field, mut progress) = match &job.resume {
        None => {
            let mut fresh = Field::new(w, h, d);
            fresh.set_info(&info);
            (fresh, Progress::default())
        }
        Some(path) => {
            let (mut f, p) = read_progress(path)?;
            check_resume(path, &f, &info, (w, h, d))?;
            f.set_info(&info);
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
        Some(t) if t.rows(rows).is_empty() => {
            eprintln!(
                "warning: --tile {t}: the grid has {rows} {row_name}, fewer than {} tiles; this \
                 tile is empty",
                t.count
            );
            String::new()
        }
        Some(t) => {
            let r = t.rows(rows);
            format!(", tile {t} ({row_name} {}..{})", r.start, r.end)
        }
        None => String::new(),
    };
    say(
        job,
        format!(
            "{name} → {} {}{tile_note}, budget {}, passes: {}{}, weighting {}, T ∈ [{:.4}, {:.4}], θmax {}°",
            grid_text((w, h, d)),
            if d > 1 { "voxels" } else { "cells" },
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
    if let JobDomain::Volume(v) = domain
        && !job.quiet
        && opts.budget.cap_spp
    {
        // How long the samples still to take (this tile's, after those resumed) should last.
        let e = estimate_time(scene, v, params, opts)?;
        let cells = opts.active_cells(w, h, d).len();
        let left = (cells as u64 * opts.spp as u64).saturating_sub(field.total_samples());
        say(
            job,
            format!(
                "ETA {:.1} s ({:.3e} samples/s on {} random voxels × {} spp, calibrated in {:.2} s)",
                if e.rate > 0.0 {
                    left as f64 / e.rate
                } else {
                    0.0
                },
                e.rate,
                e.cells,
                e.spp,
                e.calibration_seconds
            ),
        );
    }
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
        mark_progress(f, &mut info, p, opts, true, None);
        write(f, p, false)?;
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
    // Pairs carried weight, yet none was deflected: Δ is exactly 0 only for two straight walks.
    if field.cells.iter().any(|c| c.s0 > 0.0)
        && field.cells.iter().all(|c| c.s1 == 0.0 && c.s2 == 0.0)
    {
        eprintln!(
            "warning: no pair was deflected: every walk ran straight for its whole run length \
             (T in [{:.4}, {:.4}]) without reaching any geometry, so σ is 0 everywhere; give \
             longer run lengths with --t0/--t1 (the scene's diagonal is {:.4})",
            params.t0,
            params.t1,
            scene.extent()
        );
    }
    let partial = !stats.stop.is_complete();
    mark_progress(
        &mut field,
        &mut info,
        &progress,
        opts,
        partial,
        Some(stats.stop),
    );
    say(job, summary(&field, &stats, &error, params));
    // Separatrices of the field as written (a partial field's too: they say what it shows so far).
    let separatrices = match &job.separatrices {
        Some(sp) => {
            let (sep, placement) = separatrix::of_field(&field, &output.display().to_string(), sp)?;
            say(job, sep.summary());
            Some((sep, placement))
        }
        None => None,
    };
    write_with(
        &field,
        &progress,
        job.png,
        separatrices
            .as_ref()
            .map_or_else(Vec::new, |(s, _)| s.arrays()),
    )?;
    if let Some((sep, placement)) = &separatrices {
        separatrix::write_side_files(output, &field, sep, placement)?;
        let files: Vec<String> = separatrix::side_paths(output, sep.dims[2] > 1)
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        say(job, format!("wrote {}", files.join(", ")));
    }
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
