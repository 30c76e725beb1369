//! The command line: parses arguments (clap) into a validated job, runs it, reports errors.

use clap::{Args, Parser, Subcommand, ValueEnum};
use ftpd3d::app::{self, EstimatorArgs, SliceJob};
use ftpd3d::domain::slice::SliceSpec;
use ftpd3d::ftpd::Weighting;
use ftpd3d::render::RenderOptions;
use std::path::PathBuf;
use std::process::ExitCode;

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
}

#[derive(Args, Debug, Clone)]
struct RunArgs {
    /// Scene file (.obj with its .mtl, .gltf or .glb).
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Axis-aligned slice plane, e.g. z=1.2 (x=c spans z,y; y=c spans x,z; z=c spans x,y).
    #[arg(long, value_name = "AXIS=VALUE")]
    slice: Option<SliceSpec>,
    /// Part of the plane to cover, in plane coordinates u0,v0,u1,v1 [default: the scene bounds].
    #[arg(long, value_name = "U0,V0,U1,V1", value_parser = parse_window)]
    window: Option<[f64; 4]>,
    /// Cells along the longer side of the slice.
    #[arg(long, default_value_t = 256)]
    res: usize,
    /// Samples (deflection pairs) per cell.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Independent batches for the standard error (at most --spp).
    #[arg(long, default_value_t = 8)]
    batches: u32,
    /// Direction weighting.
    #[arg(long = "weight", value_enum, default_value = "radiance")]
    weight: WeightArg,
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
    /// No progress bar or summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    quiet: bool,
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
    fn job(&self) -> anyhow::Result<SliceJob> {
        let scene = self
            .scene
            .clone()
            .ok_or_else(|| anyhow::anyhow!("--scene FILE is required (try --help)"))?;
        let slice = self
            .slice
            .ok_or_else(|| anyhow::anyhow!("--slice AXIS=VALUE is required, e.g. --slice z=0"))?;
        let output = self.output.clone().unwrap_or_else(|| {
            let stem = scene
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scene".into());
            PathBuf::from("out").join(format!("{stem}_{}.exr", slice.to_string().replace('=', "")))
        });
        Ok(SliceJob {
            scene,
            slice,
            window: self.window,
            res: self.res,
            estimator: EstimatorArgs {
                weighting: match self.weight {
                    WeightArg::Radiance => Weighting::Radiance,
                    WeightArg::Unweighted => Weighting::Unweighted,
                },
                t0: self.t0,
                t1: self.t1,
                angle_deg: self.angle,
                max_bounces: self.max_bounces,
            },
            render: RenderOptions {
                spp: self.spp,
                batches: self.batches,
                seed: self.seed,
                threads: self.threads,
                progress: !self.quiet,
            },
            output,
            png: !self.no_png,
            quiet: self.quiet,
        })
    }
}

fn bench(args: &RunArgs) -> anyhow::Result<()> {
    let job = args.job()?;
    let scene = app::load_scene(&job.scene)?;
    let params = job.estimator.resolve(&scene)?;
    let plane = ftpd3d::domain::Plane::axis_slice(&scene.bounds, job.slice, job.window, job.res)?;
    let mut opts = job.render.clone();
    opts.progress = false;
    let r = app::bench_plane(&scene, &plane, &params, &opts)?;
    let threads = if opts.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        opts.threads
    };
    println!("scene            {}", job.scene.display());
    println!("features         {}", scene.features);
    println!(
        "slice            {} ({}x{}), {} spp, weighting {}, {} threads",
        plane.label, plane.width, plane.height, opts.spp, params.weighting, threads
    );
    println!(
        "kernel           {:>12} rays in {:>8.3} s = {:.3e} rays/s ({:.3e} samples/s)",
        r.kernel.rays,
        r.kernel.seconds,
        r.kernel.rays_per_second(),
        r.kernel.samples_per_second()
    );
    println!(
        "raw rtcIntersect1 {:>11} rays in {:>8.3} s = {:.3e} rays/s",
        r.raw_rays,
        r.raw_seconds,
        r.raw_rays_per_second()
    );
    println!("ratio            {:.3}", r.ratio());
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Some(Command::Bench(args)) => bench(args),
        None => cli
            .run
            .job()
            .and_then(|job| app::run_slice_job(&job).map(|_| ())),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
