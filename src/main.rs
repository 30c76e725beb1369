//! The command line: parses arguments (clap) into a validated job, runs it, reports errors.

use clap::{Args, Parser, Subcommand, ValueEnum};
use ftpd3d::app::{self, EstimatorArgs, SliceJob, VolumeJob};
use ftpd3d::domain::VolumeRes;
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
///
/// Volume: ftpd3d --scene scenes/cornell_mirror.obj --volume 64 --spp 32 (writes a .vti for ParaView)
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
    /// Scene file (.obj with its .mtl).
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Axis-aligned slice plane, e.g. z=1.2 (x=c spans z,y; y=c spans x,z; z=c spans x,y).
    #[arg(long, value_name = "AXIS=VALUE|NAME")]
    slice: Option<String>,
    /// A voxel grid instead of a slice, written as VTK ImageData (.vti): N voxels along the longest
    /// side of the box (the others by aspect), or NX,NY,NZ.
    #[arg(long, value_name = "N|NX,NY,NZ", value_parser = parse_volume,
          conflicts_with_all = ["slice", "window", "res"])]
    volume: Option<VolumeRes>,
    /// The box a volume covers [default: the scene bounds, flat sides padded].
    #[arg(long = "box", value_name = "XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX", allow_hyphen_values = true, value_parser = ftpd3d::domain::volume::parse_box)]
    bbox: Option<[f64; 6]>,
    /// Add an isotropic point light at x,y,z with radiant intensity r,g,b (per steradian); repeatable.
    #[arg(long, value_name = "X,Y,Z:R,G,B", value_parser = app::parse_point_light)]
    point_light: Vec<(glam::DVec3, glam::DVec3)>,
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
    /// Output EXR, or .vti for a volume [default: out/<scene>_<slice>.exr, out/<scene>_volume.vti].
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Skip the PNG previews written next to the EXR (a volume's: its middle z-slice).
    #[arg(long)]
    no_png: bool,
    /// Print the scene's feature set and the kernel a run would use, then stop.
    #[arg(long)]
    explain: bool,
    /// No progress bar or summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    quiet: bool,
}

fn parse_volume(s: &str) -> Result<VolumeRes, String> {
    s.parse()
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
    fn scene(&self) -> anyhow::Result<PathBuf> {
        self.scene
            .clone()
            .ok_or_else(|| anyhow::anyhow!("--scene FILE is required (try --help)"))
    }

    /// `out/<scene stem>_<suffix>` unless `-o` was given.
    fn output_or(&self, scene: &std::path::Path, suffix: &str) -> PathBuf {
        self.output.clone().unwrap_or_else(|| {
            let stem = scene
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scene".into());
            PathBuf::from("out").join(format!("{stem}_{suffix}"))
        })
    }

    fn job(&self) -> anyhow::Result<SliceJob> {
        if let Some(b) = self.bbox {
            anyhow::bail!(
                "--box {}: a box bounds a volume; add --volume N (slices take --window)",
                b.map(|x| x.to_string()).join(",")
            );
        }
        let scene = self.scene()?;
        let slice = self.slice.clone().ok_or_else(|| {
            anyhow::anyhow!(
                "--slice AXIS=VALUE (e.g. --slice z=0) or --volume N (e.g. --volume 64) is required"
            )
        })?;
        let output = self.output_or(
            &scene,
            &format!("{}.exr", slice.replace(['=', '/', ' '], "")),
        );
        Ok(SliceJob {
            scene,
            slice,
            point_lights: self.point_light.clone(),
            window: self.window,
            res: self.res,
            estimator: self.estimator(),
            render: self.render(),
            output,
            png: !self.no_png,
            quiet: self.quiet,
        })
    }

    fn volume_job(&self, res: VolumeRes) -> anyhow::Result<VolumeJob> {
        let scene = self.scene()?;
        let output = self.output_or(&scene, "volume.vti");
        Ok(VolumeJob {
            scene,
            point_lights: self.point_light.clone(),
            res,
            bbox: self.bbox,
            estimator: self.estimator(),
            render: self.render(),
            output,
            png: !self.no_png,
            quiet: self.quiet,
        })
    }

    fn estimator(&self) -> EstimatorArgs {
        EstimatorArgs {
            weighting: match self.weight {
                WeightArg::Radiance => Weighting::Radiance,
                WeightArg::Unweighted => Weighting::Unweighted,
            },
            t0: self.t0,
            t1: self.t1,
            angle_deg: self.angle,
            max_bounces: self.max_bounces,
        }
    }

    fn render(&self) -> RenderOptions {
        RenderOptions {
            spp: self.spp,
            batches: self.batches,
            seed: self.seed,
            threads: self.threads,
            progress: !self.quiet,
        }
    }
}

fn bench(args: &RunArgs) -> anyhow::Result<()> {
    if args.volume.is_some() {
        anyhow::bail!("bench runs on a slice: use --slice instead of --volume");
    }
    let job = args.job()?;
    let scene = app::load_job_scene(&job)?;
    let params = job.estimator.resolve(&scene)?;
    let slice = app::resolve_slice(&job.slice, &scene)?;
    let plane = ftpd3d::domain::Plane::axis_slice(&scene.bounds, slice, job.window, job.res)?;
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
    a.slice.get_or_insert_with(|| "z=0".into());
    a.bbox = None;
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

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Some(Command::Bench(args)) => bench(args),
        None if cli.run.explain => explain(&cli.run),
        None => match cli.run.volume {
            Some(res) => cli
                .run
                .volume_job(res)
                .and_then(|job| app::run_volume_job(&job).map(|_| ())),
            None => cli
                .run
                .job()
                .and_then(|job| app::run_slice_job(&job).map(|_| ())),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
