//! The command line: parses arguments (clap) into a validated job, runs it, reports errors.

use clap::{Args, Parser, Subcommand, ValueEnum};
use ftpd3d::app::{self, CameraArg, DomainArg, EstimatorArgs, Job};
use ftpd3d::ftpd::Weighting;
use ftpd3d::render::{Adaptive, Budget, RenderOptions, StopReason};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (Embree ",
    env!("FTPD3D_EMBREE_VERSION"),
    ")"
);

/// Finite-Time Path Deflection (FTPD) fields of 3D scenes, by path-space Monte Carlo through Embree.
///
/// Example: ftpd3d --scene scenes/cornell_mirror.obj --slice z=0 --res 256 --spp 64
#[derive(Parser, Debug)]
#[command(name = "ftpd3d", version = VERSION, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Kernel rays/s against raw Embree rays/s on the same scene, rays and threads.
    Bench(RunArgs),
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum WeightArg {
    /// Weight each direction by the radiance passing the point along it (needs lights).
    Radiance,
    /// Every direction alike.
    Unweighted,
    /// Pairs start at a camera along pixel rays (camera images; the default there).
    Importance,
}

#[derive(Args, Debug, Clone)]
struct RunArgs {
    /// Scene file: .obj (with its .mtl), .gltf or .glb, or a sidecar .toml naming one.
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Axis-aligned slice plane, e.g. z=1.2 (x=c spans z,y; y=c spans x,z; z=c spans x,y).
    #[arg(long, value_name = "AXIS=VALUE|NAME")]
    slice: Option<String>,
    /// Add an isotropic point light at x,y,z with radiant intensity r,g,b (per steradian); repeatable.
    #[arg(long, value_name = "X,Y,Z:R,G,B", value_parser = app::parse_point_light)]
    point_light: Vec<(glam::DVec3, glam::DVec3)>,
    /// Part of the plane to cover, in plane coordinates u0,v0,u1,v1 [default: the scene bounds].
    #[arg(long, value_name = "U0,V0,U1,V1", value_parser = parse_window)]
    window: Option<[f64; 4]>,
    /// Cells along the longer side of the slice.
    #[arg(long, default_value_t = 256)]
    res: usize,
    /// Samples (deflection pairs) per cell [default: 64, or no cap when --time or --target-error
    /// is given]. With --adaptive: the mean over cells.
    #[arg(long)]
    spp: Option<u32>,
    /// Independent batches (passes) --spp is split into when no --pass-spp is given (at most --spp).
    #[arg(long, default_value_t = 8)]
    batches: u32,
    /// Time budget of the whole run, e.g. 90s, 10m, 1h30m: no pass starts that would end after it.
    #[arg(long, value_name = "DURATION", value_parser = app::parse_duration)]
    time: Option<Duration>,
    /// Stop when 95 % of the cells with σ > 0 have a relative standard error ≤ this (e.g. 0.05).
    #[arg(long, value_name = "REL")]
    target_error: Option<f64>,
    /// Samples per cell added by each pass (one batch) [default: spp/batches, or 8 without --spp].
    #[arg(long, value_name = "N")]
    pass_spp: Option<u32>,
    /// From the third pass on, give the samples of a pass to the cells with the largest error.
    #[arg(long)]
    adaptive: bool,
    /// With --adaptive: at most this many times the uniform share per cell and pass.
    #[arg(long, value_name = "K", default_value_t = 4, requires = "adaptive")]
    adaptive_cap: u32,
    /// Write the field so far (marked partial, resumable) to the output every DURATION, at pass
    /// boundaries.
    #[arg(long, value_name = "DURATION", value_parser = app::parse_duration)]
    checkpoint_every: Option<Duration>,
    /// Continue the run saved in FILE (a partial or checkpointed output of the same command);
    /// writes to FILE unless -o says otherwise.
    #[arg(long, value_name = "FILE")]
    resume: Option<PathBuf>,
    /// Direction weighting.
    /// [default: radiance for slices, importance for camera images]
    #[arg(long = "weight", value_enum)]
    weight: Option<WeightArg>,
    /// Camera image instead of a slice: a camera of the scene file by name or index (the first
    /// when no value is given).
    #[arg(long, value_name = "NAME", num_args = 0..=1, default_missing_value = "", conflicts_with = "slice")]
    camera: Option<String>,
    /// Camera position (with --target) instead of a scene camera.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, conflicts_with_all = ["slice", "camera"], requires = "target")]
    eye: Option<glam::DVec3>,
    /// Point the camera looks at.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, requires = "eye")]
    target: Option<glam::DVec3>,
    /// Camera up vector.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, default_value = "0,1,0")]
    up: glam::DVec3,
    /// Vertical field of view of --eye cameras, degrees.
    #[arg(long, default_value_t = 40.0)]
    fov: f64,
    /// Camera image size in pixels.
    #[arg(long, value_name = "W,H", value_parser = parse_size, default_value = "512,512")]
    size: (usize, usize),
    /// Shortest run length T, scene units [default: 0.1 × scene diagonal].
    #[arg(long, allow_negative_numbers = true)]
    t0: Option<f64>,
    /// Longest run length T, scene units [default: 0.5 × scene diagonal].
    #[arg(long, allow_negative_numbers = true)]
    t1: Option<f64>,
    /// Half-angle of the cone the second direction is drawn from, degrees (0 < angle < 90).
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    angle: f64,
    /// Cap on scattering events per walk and per radiance path.
    #[arg(long, default_value_t = 32)]
    max_bounces: u32,
    /// Seed of the random streams (same seed, same result, on any number of threads).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Output EXR [default: out/<scene>_<slice>.exr].
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Skip the PNG preview written next to the EXR.
    #[arg(long)]
    no_png: bool,
    /// Print the scene's feature set and the kernel a run would use, then stop.
    #[arg(long)]
    explain: bool,
    /// No progress bar or summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    quiet: bool,
}

fn parse_vec3(s: &str) -> Result<glam::DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{t}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok(glam::DVec3::new(*a, *b, *c)),
        [_, _, _] => Err("values must be finite".into()),
        _ => Err(format!(
            "expected 3 comma-separated numbers x,y,z, got {}",
            v.len()
        )),
    }
}

fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let (w, h) = s
        .split_once(',')
        .ok_or_else(|| format!("'{s}': expected W,H such as 640,480"))?;
    let p = |t: &str| {
        t.trim()
            .parse::<usize>()
            .map_err(|_| format!("'{t}' is not a whole number"))
    };
    Ok((p(w)?, p(h)?))
}

fn parse_window(s: &str) -> Result<[f64; 4], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{t}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [a, b, c, d] if v.iter().all(|x| x.is_finite()) => Ok([*a, *b, *c, *d]),
        [_, _, _, _] => Err("values must be finite".into()),
        _ => Err(format!(
            "expected 4 comma-separated numbers u0,v0,u1,v1, got {}",
            v.len()
        )),
    }
}

impl RunArgs {
    fn job(&self) -> anyhow::Result<Job> {
        let scene = self
            .scene
            .clone()
            .ok_or_else(|| anyhow::anyhow!("--scene FILE is required (try --help)"))?;
        let stem = scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        let camera = match (&self.camera, self.eye, self.target) {
            (_, Some(eye), Some(target)) => Some(CameraArg::Explicit {
                eye,
                target,
                up: self.up,
                fov_deg: self.fov,
            }),
            (Some(name), _, _) => Some(CameraArg::Scene((!name.is_empty()).then(|| name.clone()))),
            _ => None,
        };
        let (domain, default_out, default_weight) = match camera {
            Some(camera) => (
                DomainArg::Camera {
                    camera,
                    size: self.size,
                },
                format!("{stem}_camera.exr"),
                WeightArg::Importance,
            ),
            None => {
                let slice = self.slice.clone().ok_or_else(|| {
                    anyhow::anyhow!("--slice AXIS=VALUE (e.g. --slice z=0) or --camera is required")
                })?;
                let out = format!("{stem}_{}.exr", slice.replace(['=', '/', ' '], ""));
                (
                    DomainArg::Slice {
                        slice,
                        window: self.window,
                        res: self.res,
                    },
                    out,
                    WeightArg::Radiance,
                )
            }
        };
        let weight = self.weight.unwrap_or(default_weight);
        let camera_run = matches!(domain, DomainArg::Camera { .. });
        if camera_run != matches!(weight, WeightArg::Importance) {
            anyhow::bail!(if camera_run {
                "--weight: camera images are importance-weighted (pairs start along the pixel rays)"
            } else {
                "--weight importance needs a camera: give --camera [NAME] or --eye/--target"
            });
        }
        Ok(Job {
            scene,
            domain,
            point_lights: self.point_light.clone(),
            estimator: EstimatorArgs {
                weighting: match weight {
                    WeightArg::Radiance => Weighting::Radiance,
                    WeightArg::Unweighted => Weighting::Unweighted,
                    WeightArg::Importance => Weighting::Importance,
                },
                t0: self.t0,
                t1: self.t1,
                angle_deg: self.angle,
                max_bounces: self.max_bounces,
            },
            render: RenderOptions {
                spp: self.spp.unwrap_or(64),
                batches: self.batches,
                seed: self.seed,
                threads: self.threads,
                progress: !self.quiet,
                budget: Budget {
                    cap_spp: self.spp.is_some()
                        || (self.time.is_none() && self.target_error.is_none()),
                    time: self.time,
                    target_error: self.target_error,
                    max_passes: None,
                },
                pass_spp: self.pass_spp,
                adaptive: self.adaptive.then_some(Adaptive {
                    max_share: self.adaptive_cap,
                }),
            },
            output: self
                .output
                .clone()
                .or_else(|| self.resume.clone())
                .unwrap_or_else(|| PathBuf::from("out").join(default_out)),
            png: !self.no_png,
            quiet: self.quiet,
            checkpoint_every: self.checkpoint_every,
            resume: self.resume.clone(),
            command: Some(command_without_resume()),
        })
    }
}

fn bench(args: &RunArgs) -> anyhow::Result<()> {
    let job = args.job()?;
    let scene = app::load_job_scene(&job)?;
    let params = job.estimator.resolve(&scene)?;
    let DomainArg::Slice { slice, window, res } = &job.domain else {
        anyhow::bail!("bench runs on a slice: give --slice");
    };
    let slice = app::resolve_slice(slice, &scene)?;
    let plane = ftpd3d::domain::Plane::axis_slice(&scene.bounds, slice, *window, *res)?;
    let mut opts = job.render.clone();
    opts.progress = false;
    let r = app::bench_plane(&scene, &plane, &params, &opts, 3)?;
    let threads = if opts.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        opts.threads
    };
    let line = |name: &str, s: &ftpd3d::render::RunStats| {
        println!(
            "{name:<20} {:>11} rays in {:>7.3} s = {:.3e} rays/s, {:.3e} samples/s",
            s.rays,
            s.seconds,
            s.rays_per_second(),
            s.samples_per_second()
        )
    };
    println!("scene                {}", job.scene.display());
    println!("features             {}", scene.features);
    println!(
        "slice                {} ({}x{}), {} spp, weighting {}, {} threads, best of 3",
        plane.label, plane.width, plane.height, opts.spp, params.weighting, threads
    );
    println!("specialised kernel   {}", r.kernel);
    line("specialised", &r.specialised);
    line("all-features", &r.all_features);
    println!(
        "raw rtcIntersect1    {:>11} rays in {:>7.3} s = {:.3e} rays/s",
        r.raw_rays,
        r.raw_seconds,
        r.raw_rays_per_second()
    );
    println!("kernel/raw rays/s    {:.3}", r.ray_ratio());
    println!("specialised/all samples/s {:.3}", r.specialisation_gain());
    Ok(())
}

fn explain(args: &RunArgs) -> anyhow::Result<()> {
    let scene_path = args
        .scene
        .clone()
        .ok_or_else(|| anyhow::anyhow!("--scene FILE is required"))?;
    let mut a = args.clone();
    if a.camera.is_none() && a.eye.is_none() {
        a.slice.get_or_insert_with(|| "z=0".into());
    }
    let job = a.job()?;
    let scene = app::load_job_scene(&job)?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    println!("scene      {}", scene_path.display());
    println!(
        "geometry   {} triangles ({} degenerate dropped), bounds {:?} .. {:?}, shading normals: {}",
        scene.triangles.len(),
        scene.report.degenerate_dropped,
        scene.bounds.min.to_array(),
        scene.bounds.max.to_array(),
        if scene.normals.is_empty() {
            "no"
        } else {
            "yes"
        }
    );
    println!("materials  {}", scene.materials.len());
    for m in &scene.materials {
        let emits = if m.emission == ftpd3d::math::Rgb::ZERO {
            String::new()
        } else {
            format!(", emits {:?}", m.emission.to_array())
        };
        println!("  {:<20} {:?}{emits}", m.name, m.bsdf);
    }
    let (area, point) = scene
        .lights
        .lights
        .iter()
        .fold((0, 0), |(a, p), l| match l {
            ftpd3d::scene::Light::Triangle { .. } => (a + 1, p),
            ftpd3d::scene::Light::Point { .. } => (a, p + 1),
        });
    println!(
        "lights     {area} emissive triangles, {point} point lights, total power {:.4}",
        scene.lights.total_power()
    );
    println!("cameras    {}", scene.cameras.len());
    if !scene.named_slices.is_empty() {
        let names: Vec<_> = scene
            .named_slices
            .iter()
            .map(|(n, p)| format!("{n} ({p})"))
            .collect();
        println!("slices     {}", names.join(", "));
    }
    println!("features   {}", scene.features);
    println!("weighting  {}", job.estimator.weighting);
    match job.estimator.resolve(&scene) {
        Ok(params) => println!("kernel     {}", app::kernel_choice(&scene, &params, true)),
        Err(e) => println!("kernel     (none: {e:#})"),
    }
    Ok(())
}

/// This process's command line without `--resume FILE`, quoted for a shell.
fn command_without_resume() -> String {
    let mut out = Vec::new();
    let mut args = std::env::args();
    if let Some(a0) = args.next() {
        out.push(app::shell_quote(&a0));
    }
    while let Some(a) = args.next() {
        if a == "--resume" {
            args.next();
        } else if !a.starts_with("--resume=") {
            out.push(app::shell_quote(&a));
        }
    }
    out.join(" ")
}

/// Exit status of a run stopped by SIGINT/SIGTERM/SIGHUP after writing its partial result
/// (128 + SIGINT, as shells report an interrupted command).
const EXIT_INTERRUPTED: u8 = 130;

/// First SIGINT/SIGTERM/SIGHUP: ask the driver to stop after the chunks in flight (the run then
/// writes its partial result). Second: remove the temporary files being written and exit at once.
fn install_signal_handler() {
    static SIGNALS: AtomicU32 = AtomicU32::new(0);
    let r = ctrlc::set_handler(|| {
        if SIGNALS.fetch_add(1, Ordering::SeqCst) == 0 {
            ftpd3d::render::INTERRUPT.store(true, Ordering::SeqCst);
            eprintln!(
                "\nstopping after the cells in flight, then writing the partial result \
                 (signal again to quit at once without writing)"
            );
        } else {
            ftpd3d::output::remove_temporaries();
            eprintln!("\nquit without writing");
            std::process::exit(EXIT_INTERRUPTED as i32);
        }
    });
    if let Err(e) = r {
        eprintln!("warning: no signal handler ({e}): an interrupted run will not save its work");
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Some(Command::Bench(args)) => bench(args).map(|()| None),
        None if cli.run.explain => explain(&cli.run).map(|()| None),
        None => cli.run.job().and_then(|job| {
            install_signal_handler();
            app::run_job(&job).map(|o| Some(o.stats.stop))
        }),
    };
    let result = result.map(|stop| match stop {
        Some(StopReason::Interrupted) => ExitCode::from(EXIT_INTERRUPTED),
        _ => ExitCode::SUCCESS,
    });
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
