//! The command line: parses arguments (clap) into a validated job, runs it, reports errors.

use clap::{Args, Parser, Subcommand, ValueEnum};
use ftpd3d::analysis::converge::{self, ConvergeJob};
use ftpd3d::analysis::separatrix::SepParams;
use ftpd3d::app::{self, CameraArg, DomainArg, Job};
use ftpd3d::cli::parse::{
    parse_duration, parse_env, parse_point_light, parse_size, parse_sky, parse_sun, parse_vec3,
    parse_volume, parse_window,
};
use ftpd3d::cli::{bench, explain, report};
use ftpd3d::domain::slice::SliceArg;
use ftpd3d::domain::{Tile, VolumeRes};
use ftpd3d::ftpd::Weighting;
use ftpd3d::render::{Adaptive, Budget, RenderOptions, StopReason};
use ftpd3d::run::EstimatorArgs;
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

// Parsed once per process: the size difference between variants does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand, Debug)]
enum Command {
    /// Kernel rays/s against raw Embree rays/s on the same scene, rays and threads.
    Bench(RunArgs),
    /// Add fields (.exr) or volumes (.vti) of the same run computed with other seeds or over other
    /// tiles, exactly.
    ///
    /// Example: ftpd3d merge part_*.exr -o all.exr
    Merge(MergeArgs),
    /// Error against time at doubling sample counts, as CSV and a log-log plot.
    ///
    /// Example: ftpd3d converge --scene scenes/cornell_mirror.obj --slice z=0 --out-dir out/conv
    Converge(ConvergeArgs),
    /// Extract separatrices (eq. 13 of the paper, with a significance threshold) from a finished or
    /// merged field, without recomputing it: the field again with the `separatrix*` channels, and
    /// beside it `<name>.sep.vtp` (lines in scene coordinates, or a volume's surface) and, for 2D
    /// fields, `<name>.sep.svg` and `<name>.sep.png`.
    ///
    /// Example: ftpd3d separatrices out/cornell_mirror_z0.exr --sep-scale 2 -o out/sep.exr
    Separatrices(SeparatricesArgs),
    /// Time to the same error as a baseline build, per scene and weighting (a Markdown table).
    ///
    /// Example: ftpd3d efficiency --baseline /path/to/old/ftpd3d --scene scenes/cornell_mirror.obj
    Efficiency(EfficiencyArgs),
}

/// The separatrix extraction's settings, shared by runs (`--separatrices`) and `separatrices`.
#[derive(Args, Debug, Clone)]
struct SepFlags {
    /// Scale of the derivative-of-Gaussian filters, in cells (≥ 0.7) [default: the smallest at
    /// which a step of height τ is significant at Z in the median cell].
    #[arg(long, value_name = "CELLS", allow_negative_numbers = true)]
    sep_scale: Option<f64>,
    /// Significance Z: mark cells whose largest |∇²_ω σ| is Z standard errors from 0 (a test over
    /// all directions at once).
    #[arg(
        long,
        value_name = "Z",
        default_value_t = 3.0,
        allow_negative_numbers = true
    )]
    sep_threshold: f64,
    /// Strength threshold τ in units of σ (the scale-normalised |∇²_ω σ|; for lines, the height of
    /// a step of σ) [default: 0.1 × the median σ of the cells with σ > 0].
    #[arg(long, value_name = "TAU", allow_negative_numbers = true)]
    sep_tau: Option<f64>,
}

impl SepFlags {
    fn params(&self) -> anyhow::Result<SepParams> {
        let p = SepParams {
            scale: self.sep_scale,
            z: self.sep_threshold,
            tau: self.sep_tau,
        };
        p.check()?;
        Ok(p)
    }

    fn given(&self) -> bool {
        self.sep_scale.is_some() || self.sep_tau.is_some() || self.sep_threshold != 3.0
    }
}

#[derive(Args, Debug, Clone)]
struct SeparatricesArgs {
    /// A field (.exr) or volume (.vti) written by ftpd3d or by merge.
    #[arg(value_name = "FIELD.exr|FIELD.vti")]
    input: PathBuf,
    /// Output, .exr or .vti as the input [default: <input name>_sep.<ext> beside it].
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    #[command(flatten)]
    sep: SepFlags,
    /// Skip the PNG previews of the field (the separatrix overlay is still written).
    #[arg(long)]
    no_png: bool,
    /// No summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args, Debug, Clone)]
struct EfficiencyArgs {
    /// The baseline binary (an older build of this tool).
    #[arg(long, value_name = "BIN", required = true)]
    baseline: PathBuf,
    /// The candidate binary [default: this one].
    #[arg(long, value_name = "BIN")]
    candidate: Option<PathBuf>,
    /// Scene files; repeatable.
    #[arg(long, value_name = "FILE", required = true)]
    scene: Vec<PathBuf>,
    /// Axis-aligned slice plane of every scene.
    #[arg(long, value_name = "AXIS=VALUE", default_value = "z=0")]
    slice: String,
    /// Cells along the longer side.
    #[arg(long, default_value_t = 64)]
    res: usize,
    /// Weightings to compare; repeatable [default: radiance and unweighted].
    #[arg(long = "weight", value_enum)]
    weight: Vec<WeightArg>,
    /// Samples per cell of the first level; each further level doubles them.
    #[arg(long, default_value_t = 4)]
    start_spp: u32,
    /// Largest samples per cell.
    #[arg(long, default_value_t = 64)]
    max_spp: u32,
    /// The reference (baseline, another seed) has this many times --max-spp.
    #[arg(long, default_value_t = 32)]
    ref_factor: u32,
    /// Worker threads of every run [default: all cores].
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Directory for every run's EXR and efficiency.csv.
    #[arg(long, value_name = "DIR", default_value = "out/efficiency")]
    work_dir: PathBuf,
    /// Reuse references already in the work directory.
    #[arg(long)]
    keep_references: bool,
    /// No per-run lines.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args, Debug, Clone)]
struct MergeArgs {
    /// EXR fields or VTI volumes written by ftpd3d (or by an earlier merge), all of one kind,
    /// added in the order given.
    #[arg(required = true, value_name = "FILE.exr|FILE.vti")]
    inputs: Vec<PathBuf>,
    /// Output, .exr or .vti as the inputs (PNG previews are written next to it).
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    /// Skip the PNG previews.
    #[arg(long)]
    no_png: bool,
    /// No summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args, Debug, Clone)]
struct ConvergeArgs {
    /// Scene file: .obj (with its .mtl), .gltf or .glb, or a sidecar .toml naming one.
    #[arg(long, value_name = "FILE", required = true)]
    scene: PathBuf,
    /// Axis-aligned slice plane, e.g. z=0, or a slice named in the scene file.
    #[arg(long, value_name = "AXIS=VALUE|NAME", required = true)]
    slice: String,
    /// Directory for converge.csv, converge_fit.csv, converge.png and the top runs' EXRs.
    #[arg(long, value_name = "DIR", required = true)]
    out_dir: PathBuf,
    /// Reference field (EXR of the same slice and parameters, many samples); without it, each
    /// weighting's highest-spp run is the reference.
    #[arg(long, value_name = "REF.exr")]
    reference: Option<PathBuf>,
    /// Part of the plane to cover, u0,v0,u1,v1.
    #[arg(long, value_name = "U0,V0,U1,V1", allow_hyphen_values = true, value_parser = parse_window)]
    window: Option<[f64; 4]>,
    /// Cells along the longer side [default: the reference's, else 64].
    #[arg(long)]
    res: Option<usize>,
    /// Samples per cell of the first run; each further run doubles them.
    #[arg(long, default_value_t = 4)]
    start_spp: u32,
    /// Largest samples per cell.
    #[arg(long, default_value_t = 256)]
    max_spp: u32,
    /// Weighting of a single curve [default: the reference's; else radiance and unweighted when
    /// the scene has lights, unweighted otherwise].
    #[arg(long = "weight", value_enum)]
    weight: Option<WeightArg>,
    /// Passes each run is split into (at most the run's spp).
    #[arg(long, default_value_t = RenderOptions::default().batches)]
    batches: u32,
    #[command(flatten)]
    estimator: EstimatorFlags,
    /// Seed of the first run; run k uses seed + k (every run independent).
    #[arg(long, default_value_t = RenderOptions::default().seed)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, default_value_t = RenderOptions::default().threads)]
    threads: usize,
    /// An older build of ftpd3d: run it and this binary, each as its own processes, at the same
    /// levels and draw both curves on one plot [reference: --reference, else the baseline's
    /// highest-spp run].
    #[arg(long, value_name = "BIN")]
    baseline: Option<PathBuf>,
    /// No per-run lines or summary.
    #[arg(short, long)]
    quiet: bool,
}

/// The estimator's flags, shared by runs and `converge`.
#[derive(Args, Debug, Clone)]
struct EstimatorFlags {
    /// Add an isotropic point light at x,y,z with radiant intensity r,g,b (per steradian); repeatable.
    #[arg(long, value_name = "X,Y,Z:R,G,B", allow_hyphen_values = true, value_parser = parse_point_light)]
    point_light: Vec<(glam::DVec3, glam::DVec3)>,
    /// Add the sun: the direction x,y,z towards it, the irradiance r,g,b it gives a surface facing
    /// it, and its angular diameter in degrees [default: 0.53; 0: a Dirac delta]; repeatable.
    #[arg(long, value_name = "X,Y,Z:R,G,B[:DIAM]", allow_hyphen_values = true, value_parser = parse_sun)]
    sun: Vec<ftpd3d::scene::Light>,
    /// Add a uniform sky: radiance r,g,b from every direction that leaves the scene.
    #[arg(long, value_name = "R,G,B", value_parser = parse_sky)]
    sky: Option<ftpd3d::scene::Light>,
    /// Add an environment map: a lat-long .exr or .hdr (+y up), its radiance × SCALE [default: 1],
    /// turned about +y by ROT_DEG degrees [default: 0].
    #[arg(long, value_name = "FILE[:SCALE[:ROT_DEG]]", allow_hyphen_values = true, value_parser = parse_env)]
    env: Option<ftpd3d::scene::Light>,
    /// Shortest run length T, scene units [default: 0.1 × scene diagonal].
    #[arg(long, allow_negative_numbers = true)]
    t0: Option<f64>,
    /// Longest run length T, scene units [default: 0.5 × scene diagonal].
    #[arg(long, allow_negative_numbers = true)]
    t1: Option<f64>,
    /// Half-angle of the cone the second direction is drawn from, degrees (0 < angle < 90).
    #[arg(long, default_value_t = EstimatorArgs::default().angle_deg, allow_negative_numbers = true)]
    angle: f64,
    /// Cap on scattering events per walk, and per radiance path unless --radiance-bounces is given.
    #[arg(long, default_value_t = EstimatorArgs::default().max_bounces, allow_negative_numbers = true)]
    max_bounces: u32,
    /// Cap on scattering events per radiance path alone (radiance weighting, fluence, a camera's
    /// beauty image): paths of at most N + 1 segments from the point to the light; the walks keep
    /// --max-bounces [default: --max-bounces].
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    radiance_bounces: Option<u32>,
}

impl EstimatorFlags {
    /// The lights given on the command line, in the order point lights, suns, sky.
    fn lights(&self) -> Vec<ftpd3d::scene::Light> {
        let points =
            self.point_light
                .iter()
                .map(|&(position, intensity)| ftpd3d::scene::Light::Point {
                    position,
                    intensity,
                });
        points
            .chain(self.sun.iter().cloned())
            .chain(self.sky.clone())
            .chain(self.env.clone())
            .collect()
    }

    fn args(&self, weighting: Weighting) -> EstimatorArgs {
        EstimatorArgs {
            weighting,
            t0: self.t0,
            t1: self.t1,
            angle_deg: self.angle,
            max_bounces: self.max_bounces,
            radiance_bounces: self.radiance_bounces,
        }
    }
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
    /// Axis-aligned slice plane, e.g. z=1.2 (x=c spans z,y; y=c spans x,z; z=c spans x,y), or a
    /// slice named in the scene file; repeatable (each slice is written to its own file).
    #[arg(long, value_name = "AXIS=VALUE|NAME")]
    slice: Vec<String>,
    /// Evenly spaced axis slices AXIS=FROM:TO:COUNT, e.g. z=0.2:2.0:10.
    #[arg(long, value_name = "AXIS=FROM:TO:COUNT", value_parser = parse_slices)]
    slices: Vec<SliceRange>,
    /// Arbitrary plane "origin=X,Y,Z normal=X,Y,Z [up=X,Y,Z] [size=W,H]" (quoted; keys may also be
    /// separated by ';'); repeatable.
    #[arg(long, value_name = "SPEC", allow_hyphen_values = true)]
    plane: Vec<ftpd3d::domain::slice::PlaneSpec>,
    /// A voxel grid instead of a slice, written as VTK ImageData (.vti): N voxels along the longest
    /// side of the box (the others by aspect), or NX,NY,NZ. Takes the budget, resume, checkpoint
    /// and tile flags as slices do (a tile is a slab of whole z layers).
    #[arg(long, value_name = "N|NX,NY,NZ", value_parser = parse_volume,
          conflicts_with_all = ["slice", "slices", "plane", "window", "res", "camera", "eye", "flatland"])]
    volume: Option<VolumeRes>,
    /// The box a volume covers [default: the scene bounds, flat sides padded].
    #[arg(long = "box", value_name = "XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX", allow_hyphen_values = true, value_parser = ftpd3d::domain::volume::parse_box)]
    bbox: Option<[f64; 6]>,
    /// Part of the plane to cover, in plane coordinates u0,v0,u1,v1 [default: the scene bounds].
    #[arg(long, value_name = "U0,V0,U1,V1", allow_hyphen_values = true, value_parser = parse_window)]
    window: Option<[f64; 4]>,
    /// Cells along the longer side of the slice.
    #[arg(long, default_value_t = 256)]
    res: usize,
    /// Samples (deflection pairs) per cell [default: no cap; without --spp, --time and
    /// --target-error a run stops at --target-error 0.05 or after --time 60s, whichever comes
    /// first]. With --adaptive: the mean over cells.
    #[arg(long)]
    spp: Option<u32>,
    /// Passes --spp is split into when no --pass-spp is given (at most --spp).
    #[arg(long, default_value_t = RenderOptions::default().batches)]
    batches: u32,
    /// Time budget of the whole run, e.g. 90s, 10m, 1h30m: no pass starts that would end after it.
    #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
    time: Option<Duration>,
    /// Stop when 95 % of the cells with σ > 0 have a relative standard error ≤ this (e.g. 0.05).
    #[arg(long, value_name = "REL")]
    target_error: Option<f64>,
    /// Samples per cell added by each pass (one batch) [default: spp/batches, or 8 without --spp].
    #[arg(long, value_name = "N")]
    pass_spp: Option<u32>,
    /// From the third pass on, give the samples of a pass to the cells with the largest error
    /// [default: on when the run stops at a target error (--target-error, or no budget given)].
    #[arg(long, conflicts_with = "uniform")]
    adaptive: bool,
    /// Every cell gets the same samples in every pass, also when the run stops at a target error.
    #[arg(long)]
    uniform: bool,
    /// Adaptive runs: at most this many times the uniform share per cell and pass [default: 4].
    #[arg(long, value_name = "K", conflicts_with = "uniform")]
    adaptive_cap: Option<u32>,
    /// Write the field so far (marked partial, resumable) to the output every DURATION, at pass
    /// boundaries.
    #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
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
    #[arg(long, value_name = "NAME", num_args = 0..=1, default_missing_value = "", conflicts_with_all = ["slice", "slices", "plane"])]
    camera: Option<String>,
    /// Camera position (with --target) instead of a scene camera.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_vec3, conflicts_with_all = ["slice", "slices", "plane", "camera"], requires = "target")]
    eye: Option<glam::DVec3>,
    /// Point the camera looks at.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_vec3, requires = "eye")]
    target: Option<glam::DVec3>,
    /// Camera up vector.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_vec3, default_value = "0,1,0")]
    up: glam::DVec3,
    /// Vertical field of view of --eye cameras, degrees.
    #[arg(long, default_value_t = 40.0)]
    fov: f64,
    /// Camera image size in pixels.
    #[arg(long, value_name = "W,H", value_parser = parse_size, default_value = "512,512")]
    size: (usize, usize),
    #[command(flatten)]
    estimator: EstimatorFlags,
    /// Seed of the random streams (same seed, same result, on any number of threads).
    #[arg(long, default_value_t = RenderOptions::default().seed)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, default_value_t = RenderOptions::default().threads)]
    threads: usize,
    /// Compute only stripe I of N (grid rows from the bottom, a volume's z layers; from 0), with the
    /// same per-cell random streams as a full run; `merge` the N files afterwards.
    #[arg(long, value_name = "I/N")]
    tile: Option<Tile>,
    /// Output EXR, or .vti for a volume [default: out/<scene>_<slice>.exr, with _tile<I>of<N> for a
    /// tile; out/<scene>_volume.vti].
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Skip the PNG previews written next to the EXR (a volume's: its middle z-slice).
    #[arg(long)]
    no_png: bool,
    /// Flatland: confine every direction to the slice plane (2D light transport, as in the paper's
    /// 2D figures). The scene must be extruded along the slice normal; point-light intensities are
    /// per radian.
    #[arg(long)]
    flatland: bool,
    /// Extract separatrices from the finished field: `separatrix*` channels in the output and the
    /// files `<name>.sep.vtp`, `.sep.svg`, `.sep.png` beside it (see `ftpd3d separatrices`).
    #[arg(long)]
    separatrices: bool,
    #[command(flatten)]
    sep: SepFlags,
    /// Print the scene's feature set and the kernel a run would use, then stop.
    #[arg(long)]
    explain: bool,
    /// Refuse OBJ files that mainstream loaders read with a warning: faces of fewer than 3
    /// vertices, `usemtl`/`mtllib` without a name, unsupported statements, non-UTF-8 text.
    #[arg(long)]
    strict: bool,
    /// No progress bar or summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    quiet: bool,
}

/// The slices of one `--slices` value.
#[derive(Clone, Debug)]
struct SliceRange(Vec<ftpd3d::domain::slice::SliceSpec>);

fn parse_slices(s: &str) -> Result<SliceRange, String> {
    ftpd3d::domain::slice::parse_slice_range(s).map(SliceRange)
}

impl From<WeightArg> for Weighting {
    fn from(w: WeightArg) -> Weighting {
        match w {
            WeightArg::Radiance => Weighting::Radiance,
            WeightArg::Unweighted => Weighting::Unweighted,
            WeightArg::Importance => Weighting::Importance,
        }
    }
}

impl RunArgs {
    fn scene(&self) -> anyhow::Result<PathBuf> {
        self.scene
            .clone()
            .ok_or_else(|| anyhow::anyhow!("--scene FILE is required (try --help)"))
    }

    fn job(&self) -> anyhow::Result<Job> {
        if let Some(b) = self.bbox
            && self.volume.is_none()
        {
            anyhow::bail!(
                "--box {}: a box bounds a volume; add --volume N (slices take --window)",
                b.map(|x| x.to_string()).join(",")
            );
        }
        let scene = self.scene()?;
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
        let (domain, default_out, default_weight) = match (camera, self.volume) {
            (_, Some(res)) => (
                DomainArg::Volume {
                    res,
                    bbox: self.bbox,
                },
                format!("{stem}_volume.vti"),
                WeightArg::Radiance,
            ),
            (Some(camera), None) => (
                DomainArg::Camera {
                    camera,
                    size: self.size,
                },
                format!("{stem}_camera.exr"),
                WeightArg::Importance,
            ),
            (None, None) => {
                let mut slices: Vec<SliceArg> =
                    self.slice.iter().cloned().map(SliceArg::Axis).collect();
                slices.extend(
                    self.slices
                        .iter()
                        .flat_map(|r| &r.0)
                        .map(|s| SliceArg::Axis(s.to_string())),
                );
                slices.extend(self.plane.iter().copied().map(SliceArg::Plane));
                let out = match slices.as_slice() {
                    [] => anyhow::bail!(
                        "--slice AXIS=VALUE (e.g. --slice z=0), --slices, --plane or --camera is required"
                    ),
                    [one] => format!("{stem}_{}.exr", one.file_label(0)),
                    _ => format!("{stem}.exr"),
                };
                (
                    DomainArg::Slice {
                        slices,
                        window: self.window,
                        res: self.res,
                    },
                    out,
                    WeightArg::Radiance,
                )
            }
        };
        let default_out = match (self.tile, default_out.rsplit_once('.')) {
            (Some(t), Some((name, ext))) => format!("{name}{}.{ext}", t.suffix()),
            _ => default_out,
        };
        let weight = self.weight.unwrap_or(default_weight);
        let camera_run = matches!(domain, DomainArg::Camera { .. });
        if camera_run != matches!(weight, WeightArg::Importance) {
            anyhow::bail!(match domain {
                DomainArg::Camera { .. } => {
                    "--weight: camera images are importance-weighted (pairs start along the pixel rays)"
                }
                DomainArg::Volume { .. } => {
                    "--weight importance needs a camera; volumes take radiance or unweighted"
                }
                DomainArg::Slice { .. } => {
                    "--weight importance needs a camera: give --camera [NAME] or --eye/--target"
                }
            });
        }
        self.check_adaptive_cap()?;
        Ok(Job {
            scene,
            domain,
            lights: self.estimator.lights(),
            estimator: self.estimator.args(weight.into()),
            render: self.render(),
            output: self
                .output
                .clone()
                .or_else(|| self.resume.clone())
                .unwrap_or_else(|| PathBuf::from("out").join(default_out)),
            png: !self.no_png,
            quiet: self.quiet,
            flatland: self.flatland,
            checkpoint_every: self.checkpoint_every,
            resume: self.resume.clone(),
            command: Some(command_without_resume()),
            separatrices: self.separatrices()?,
            load: ftpd3d::scene::LoadOptions {
                strict: self.strict,
            },
        })
    }

    /// --adaptive-cap on a run that is not adaptive is refused rather than ignored.
    fn check_adaptive_cap(&self) -> anyhow::Result<()> {
        if self.adaptive_cap.is_some() && !self.adaptive_sampling() {
            anyhow::bail!(
                "--adaptive-cap applies to adaptive runs: add --adaptive (runs of --spp or --time \
                 alone are uniform)"
            );
        }
        Ok(())
    }

    fn separatrices(&self) -> anyhow::Result<Option<SepParams>> {
        if !self.separatrices {
            if self.sep.given() {
                anyhow::bail!("--sep-scale, --sep-threshold and --sep-tau need --separatrices");
            }
            return Ok(None);
        }
        self.sep.params().map(Some)
    }

    /// Whether passes after the second go where the error is largest: asked for by --adaptive, and
    /// the default of a run that stops at a target error (--target-error, or the default budget),
    /// since that stop is a percentile of the relative error over cells and the allocation fills
    /// cells up to a common relative error; --uniform turns it off. A run of --spp or --time alone
    /// stays uniform.
    fn adaptive_sampling(&self) -> bool {
        let target = self.target_error.is_some() || (self.spp.is_none() && self.time.is_none());
        self.adaptive || (target && !self.uniform)
    }

    fn render(&self) -> RenderOptions {
        RenderOptions {
            spp: self.spp.unwrap_or(RenderOptions::default().spp),
            batches: self.batches,
            seed: self.seed,
            threads: self.threads,
            progress: !self.quiet,
            budget: if self.spp.is_none() && self.time.is_none() && self.target_error.is_none() {
                DEFAULT_BUDGET
            } else {
                Budget {
                    cap_spp: self.spp.is_some(),
                    time: self.time,
                    target_error: self.target_error,
                    max_passes: None,
                }
            },
            pass_spp: self.pass_spp,
            adaptive: self.adaptive_sampling().then_some(Adaptive {
                max_share: self.adaptive_cap.unwrap_or(Adaptive::default().max_share),
            }),
            tile: self.tile,
        }
    }
}

/// The budget of a run given no --spp, --time or --target-error: p95 relative error 0.05 or one
/// minute, whichever comes first (the README's first command shows clean structure within a
/// minute on two cores; the README gives the error it reaches). A time budget makes the number of
/// passes depend on the machine: `--spp N` gives a reproducible run.
const DEFAULT_BUDGET: Budget = Budget {
    cap_spp: false,
    time: Some(Duration::from_secs(60)),
    target_error: Some(0.05),
    max_passes: None,
};

fn bench(args: &RunArgs) -> anyhow::Result<()> {
    if args.volume.is_some() {
        anyhow::bail!("bench runs on a slice: use --slice instead of --volume");
    }
    let job = args.job()?;
    let DomainArg::Slice {
        slices,
        window,
        res,
    } = &job.domain
    else {
        anyhow::bail!("bench runs on a slice: give --slice");
    };
    let Some(slice) = slices.first() else {
        anyhow::bail!("bench runs on a slice: give --slice");
    };
    bench::bench(
        &mut std::io::stdout().lock(),
        &job.scene,
        &job.lights,
        &job.estimator,
        (slice, *window, *res),
        job.flatland,
        &job.render,
        &job.load,
    )
}

fn explain(args: &RunArgs) -> anyhow::Result<()> {
    let mut a = args.clone();
    if a.camera.is_none() && a.eye.is_none() && a.slice.is_empty() && a.volume.is_none() {
        a.slice.push("z=0".into());
    }
    let job = a.job()?;
    let flatland = match &job.domain {
        DomainArg::Slice {
            slices,
            window,
            res,
        } if job.flatland => match slices.first() {
            Some(s) => Some((s, *window, *res)),
            None => anyhow::bail!("--flatland needs a slice"),
        },
        _ => None,
    };
    explain::explain(
        &mut std::io::stdout().lock(),
        &job.scene,
        &job.lights,
        &job.estimator,
        flatland,
        &job.load,
    )?;
    if let Some(sp) = &job.separatrices {
        use std::io::Write as _;
        let or_default =
            |v: Option<f64>, d: &str| v.map_or_else(|| d.to_string(), |x| x.to_string());
        writeln!(
            std::io::stdout().lock(),
            "separatrices  after the run: eq. 13 by derivative-of-Gaussian filters, scale {}, \
             τ {}, Z {} (Scheffé over directions); jump and ridge lines",
            sp.scale
                .map_or_else(|| "from the noise".to_string(), |s| format!("{s} cells")),
            or_default(sp.tau, "0.1 × median σ > 0"),
            sp.z
        )?;
    }
    Ok(())
}

fn merge(args: &MergeArgs) -> anyhow::Result<()> {
    let merged = ftpd3d::merge::merge_files(&args.inputs, &args.output, !args.no_png)?;
    for w in &merged.warnings {
        eprintln!("warning: {w}");
    }
    if !args.quiet {
        eprintln!(
            "{}",
            report::merge_summary(args.inputs.len(), &merged.field)
        );
        eprintln!("wrote {}", args.output.display());
    }
    Ok(())
}

fn converge(args: &ConvergeArgs) -> anyhow::Result<()> {
    let weighting = args.weight.map(Weighting::from);
    let job = ConvergeJob {
        scene: args.scene.clone(),
        lights: args.estimator.lights(),
        slice: args.slice.clone(),
        window: args.window,
        res: args.res,
        reference: args.reference.clone(),
        out_dir: args.out_dir.clone(),
        weighting,
        estimator: args
            .estimator
            .args(weighting.unwrap_or(Weighting::Unweighted)),
        start_spp: args.start_spp,
        max_spp: args.max_spp,
        batches: args.batches,
        seed: args.seed,
        threads: args.threads,
        quiet: args.quiet,
        baseline: args.baseline.clone(),
        forward_args: estimator_flags_as_given(),
    };
    if let Some(b) = &args.baseline
        && !b.is_file()
    {
        anyhow::bail!("--baseline {}: no such file", b.display());
    }
    let conv = converge::run_converge(&job)?;
    if !args.quiet {
        for c in &conv.curves {
            println!("{}", report::converge_line(c));
        }
        println!(
            "wrote {}/converge.csv, converge_fit.csv, converge.png",
            args.out_dir.display()
        );
    }
    Ok(())
}

/// The estimator and light flags of this process's command line ([`EstimatorFlags`]) with their
/// values, as given: what `converge --baseline` passes on to both binaries.
fn estimator_flags_as_given() -> Vec<String> {
    const FLAGS: [&str; 9] = [
        "--point-light",
        "--sun",
        "--sky",
        "--env",
        "--t0",
        "--t1",
        "--angle",
        "--max-bounces",
        "--radiance-bounces",
    ];
    let mut out = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let name = a.split('=').next().unwrap_or_default();
        if !FLAGS.contains(&name) {
            continue;
        }
        if a.contains('=') {
            out.push(a);
        } else if let Some(v) = args.next() {
            out.push(format!("{a}={v}"));
        }
    }
    out
}

fn separatrices(args: &SeparatricesArgs) -> anyhow::Result<()> {
    let params = args.sep.params()?;
    let out = ftpd3d::analysis::separatrix::rerun(
        &args.input,
        args.output.as_deref(),
        &params,
        !args.no_png,
    )?;
    if !args.quiet {
        eprintln!("{}", out.summary);
        let files: Vec<String> = out.files.iter().map(|p| p.display().to_string()).collect();
        eprintln!("wrote {}", files.join(", "));
    }
    Ok(())
}

fn efficiency(args: &EfficiencyArgs) -> anyhow::Result<()> {
    use ftpd3d::analysis::efficiency::{EfficiencyJob, run_efficiency, table};
    let candidate = match &args.candidate {
        Some(c) => c.clone(),
        None => std::env::current_exe()?,
    };
    let mut weightings: Vec<Weighting> = args.weight.iter().map(|w| Weighting::from(*w)).collect();
    if weightings.is_empty() {
        weightings = vec![Weighting::Radiance, Weighting::Unweighted];
    }
    if weightings.contains(&Weighting::Importance) {
        anyhow::bail!("--weight importance needs a camera; efficiency runs on slices");
    }
    let job = EfficiencyJob {
        baseline: args.baseline.clone(),
        candidate,
        scenes: args.scene.clone(),
        slice: args.slice.clone(),
        res: args.res,
        weightings,
        start_spp: args.start_spp,
        max_spp: args.max_spp,
        ref_factor: args.ref_factor,
        threads: args.threads,
        work_dir: args.work_dir.clone(),
        keep_references: args.keep_references,
    };
    let quiet = args.quiet;
    let rows = run_efficiency(&job, |s| {
        if !quiet {
            eprintln!("{s}");
        }
    })?;
    print!("{}", table(&rows));
    Ok(())
}

/// This process's command line without `--resume FILE`, quoted for a shell.
fn command_without_resume() -> String {
    let mut out = Vec::new();
    let mut args = std::env::args();
    if let Some(a0) = args.next() {
        out.push(report::shell_quote(&a0));
    }
    while let Some(a) = args.next() {
        if a == "--resume" {
            args.next();
        } else if !a.starts_with("--resume=") {
            out.push(report::shell_quote(&a));
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
        Some(Command::Merge(args)) => merge(args).map(|()| None),
        Some(Command::Converge(args)) => converge(args).map(|()| None),
        Some(Command::Separatrices(args)) => separatrices(args).map(|()| None),
        Some(Command::Efficiency(args)) => efficiency(args).map(|()| None),
        None if cli.run.explain => explain(&cli.run).map(|()| None),
        None => cli.run.job().and_then(|job| {
            install_signal_handler();
            app::run_job(&job).map(|o| o.last().map(|o| o.stats.stop))
        }),
    };
    let result = result.map(|stop| match stop {
        Some(StopReason::Interrupted) => ExitCode::from(EXIT_INTERRUPTED),
        _ => ExitCode::SUCCESS,
    });
    match result {
        Ok(code) => code,
        // A closed pipe (`ftpd3d --explain | head`) is not an error of ours.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {}", ftpd3d::cli::errors::message(&e));
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn command_line_definition_is_consistent() {
        Cli::command().debug_assert();
    }
}
