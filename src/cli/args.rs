//! The command line's arguments as clap reads them: the main run's ([`RunArgs`], also the
//! benchmark's), the estimator's flags shared with `converge` ([`EstimatorFlags`]) and the
//! weightings. [`RunArgs::job`] (in [`super::job`]) turns them into a validated job.

// The fields' doc comments are clap's help text, where `<scene>` is plain text, not HTML.
#![allow(rustdoc::invalid_html_tags)]

use super::parse::{
    parse_cells, parse_duration, parse_env, parse_light_scale, parse_point_light, parse_size,
    parse_sky, parse_sun, parse_threads, parse_u64, parse_vec3, parse_volume, parse_window,
};
use super::sep_flags::SepFlags;
use crate::domain::slice::SliceSpec;
use crate::domain::{Tile, VolumeRes};
use crate::ftpd::Weighting;
use crate::params::EstimatorArgs;
use crate::render::RenderOptions;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::time::Duration;

/// `--version`: the tool's and the Embree it was built against.
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
pub struct Cli<C: Subcommand> {
    #[command(subcommand)]
    pub command: Option<C>,
    #[command(flatten)]
    pub run: RunArgs,
}

/// The estimator's flags, shared by runs and `converge`.
#[derive(Args, Debug, Clone)]
pub struct EstimatorFlags {
    /// Add an isotropic point light at x,y,z with radiant intensity r,g,b (per steradian); repeatable.
    #[arg(long, value_name = "X,Y,Z:R,G,B", allow_hyphen_values = true, value_parser = parse_point_light)]
    pub point_light: Vec<(glam::DVec3, glam::DVec3)>,
    /// Add the sun: the direction x,y,z towards it, the irradiance r,g,b it gives a surface facing
    /// it, and its angular diameter in degrees [default: 0.53; 0: a Dirac delta]; repeatable.
    #[arg(long, value_name = "X,Y,Z:R,G,B[:DIAM]", allow_hyphen_values = true, value_parser = parse_sun)]
    pub sun: Vec<crate::scene::Light>,
    /// Add a uniform sky: radiance r,g,b from every direction that leaves the scene.
    #[arg(long, value_name = "R,G,B", allow_hyphen_values = true, value_parser = parse_sky)]
    pub sky: Option<crate::scene::Light>,
    /// Add an environment map: a lat-long .exr or .hdr in Mitsuba 3's convention (+y up, u = 1/4
    /// looks along +x), its radiance × SCALE [default: 1], turned about +y from +x towards +z by
    /// ROT_DEG degrees [default: 0].
    #[arg(long, value_name = "FILE[:SCALE[:ROT_DEG]]", allow_hyphen_values = true, value_parser = parse_env)]
    pub env: Option<crate::scene::Light>,
    /// Scale a light of the scene file by FACTOR (0 switches it off): an emissive material by its
    /// name, another light as point1, spot1, sun1, sky1, env1 (its kind and number in the file),
    /// * for all; repeatable. `--explain` lists the names.
    #[arg(long, value_name = "NAME=FACTOR", allow_hyphen_values = true, value_parser = parse_light_scale)]
    pub light_scale: Vec<(String, f64)>,
    /// Shortest run length T, scene units [default: 0.1 × scene diagonal].
    #[arg(long, allow_negative_numbers = true)]
    pub t0: Option<f64>,
    /// Longest run length T, scene units [default: 0.5 × scene diagonal].
    #[arg(long, allow_negative_numbers = true)]
    pub t1: Option<f64>,
    /// Half-angle of the cone the second direction is drawn from, degrees (0 < angle < 90).
    #[arg(long, default_value_t = EstimatorArgs::default().angle_deg, allow_negative_numbers = true)]
    pub angle: f64,
    /// Cap on scattering events per walk, and per radiance path unless --radiance-bounces is given.
    #[arg(long, default_value_t = EstimatorArgs::default().max_bounces, allow_negative_numbers = true)]
    pub max_bounces: u32,
    /// Cap on scattering events per radiance path alone (radiance weighting, fluence, a camera's
    /// beauty image): paths of at most N + 1 segments from the point to the light; the walks keep
    /// --max-bounces [default: --max-bounces].
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub radiance_bounces: Option<u32>,
    /// Deflection pairs per sample, kA,kB,J,M: kA walks along the direction, J directions in
    /// its cone with kB walks each, every walk read at M run lengths (one in each of M equal parts
    /// of [t0, t1]); Δ is averaged over all kA·kB·J·M pairs. 1,1,1,1 is one pair per sample
    /// [default: 2,2,2,2 with radiance weighting, else 2,2,1,2].
    #[arg(long, value_name = "KA,KB,J,M", allow_hyphen_values = true)]
    pub pairs: Option<crate::ftpd::Design>,
    /// Guided radiance paths (radiance weighting, 3D): learn where light arrives from by training
    /// paths before the run and mix that guide with BSDF sampling (one-sample MIS); the
    /// expectation is unchanged.
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub guide: OnOff,
}

/// A setting that is on or off.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

impl EstimatorFlags {
    /// The lights given on the command line, in the order point lights, suns, sky.
    pub fn lights(&self) -> Vec<crate::scene::Light> {
        let points =
            self.point_light
                .iter()
                .map(|&(position, intensity)| crate::scene::Light::Point {
                    position,
                    intensity,
                });
        points
            .chain(self.sun.iter().cloned())
            .chain(self.sky.clone())
            .chain(self.env.clone())
            .collect()
    }

    /// The estimator settings of a run of `weighting`.
    pub fn args(&self, weighting: Weighting) -> EstimatorArgs {
        EstimatorArgs {
            weighting,
            t0: self.t0,
            t1: self.t1,
            angle_deg: self.angle,
            max_bounces: self.max_bounces,
            radiance_bounces: self.radiance_bounces,
            design: self.pairs,
            guide: self.guide == OnOff::On,
        }
    }
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum WeightArg {
    /// Weight each direction by the radiance passing the point along it (needs lights).
    Radiance,
    /// Every direction alike.
    Unweighted,
    /// Pairs start at a camera along pixel rays (camera images; the default there).
    Importance,
}

#[derive(Args, Debug, Clone)]
pub struct RunArgs {
    /// Scene file: .obj (with its .mtl), .gltf or .glb, or a sidecar .toml naming one.
    #[arg(long, value_name = "FILE")]
    pub scene: Option<PathBuf>,
    /// Axis-aligned slice plane, e.g. z=1.2 (x=c spans z,y; y=c spans x,z; z=c spans x,y), or a
    /// slice named in the scene file; repeatable (each slice is written to its own file).
    #[arg(long, value_name = "AXIS=VALUE|NAME")]
    pub slice: Vec<String>,
    /// Evenly spaced axis slices AXIS=FROM:TO:COUNT, e.g. z=0.2:2.0:10.
    #[arg(long, value_name = "AXIS=FROM:TO:COUNT", value_parser = parse_slices)]
    pub slices: Vec<SliceRange>,
    /// Arbitrary plane "origin=X,Y,Z normal=X,Y,Z [up=X,Y,Z] [size=W,H]" (quoted; keys may also be
    /// separated by ';'); repeatable.
    #[arg(long, value_name = "SPEC", allow_hyphen_values = true)]
    pub plane: Vec<crate::domain::slice::PlaneSpec>,
    /// A voxel grid instead of a slice, written as VTK ImageData (.vti): N voxels along the longest
    /// side of the box (the others by aspect), or NX,NY,NZ. Takes the budget, resume, checkpoint
    /// and tile flags as slices do (a tile is a slab of whole z layers).
    #[arg(long, value_name = "N|NX,NY,NZ", allow_hyphen_values = true, value_parser = parse_volume,
          conflicts_with_all = ["slice", "slices", "plane", "window", "res", "camera", "eye", "flatland"])]
    pub volume: Option<VolumeRes>,
    /// The box a volume covers [default: the scene bounds, flat sides padded].
    #[arg(long = "box", value_name = "XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX", allow_hyphen_values = true, value_parser = crate::domain::volume::parse_box)]
    pub bbox: Option<[f64; 6]>,
    /// Part of the plane to cover, in plane coordinates u0,v0,u1,v1 [default: the scene bounds].
    #[arg(long, value_name = "U0,V0,U1,V1", allow_hyphen_values = true, value_parser = parse_window)]
    pub window: Option<[f64; 4]>,
    /// Cells along the longer side of the slice.
    #[arg(long, default_value_t = crate::app::DEFAULT_RES, allow_negative_numbers = true,
          value_parser = parse_cells)]
    pub res: usize,
    /// Samples per cell (each takes the pairs of --pairs) [default: no cap; without --spp, --time and
    /// --target-error a run stops at --target-error 0.05 or after --time 60s, whichever comes
    /// first]. With --adaptive: the mean over cells.
    #[arg(long, allow_negative_numbers = true)]
    pub spp: Option<u32>,
    /// Passes --spp is split into when no --pass-spp is given (at most --spp).
    #[arg(long, default_value_t = RenderOptions::default().batches, allow_negative_numbers = true)]
    pub batches: u32,
    /// Time budget of the whole run, e.g. 90s, 10m, 1h30m: no pass starts that would end after it.
    #[arg(long, value_name = "DURATION", allow_hyphen_values = true, value_parser = parse_duration)]
    pub time: Option<Duration>,
    /// Stop when 95 % of the cells with σ > 0 have a relative standard error ≤ this (e.g. 0.05).
    #[arg(long, value_name = "REL", allow_negative_numbers = true)]
    pub target_error: Option<f64>,
    /// Samples per cell added by each pass (one batch) [default: spp/batches, or 8 without --spp].
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub pass_spp: Option<u32>,
    /// From the third pass on, give the samples of a pass to the cells with the largest error
    /// [default: on when the run stops at a target error (--target-error, or no budget given)].
    #[arg(long, conflicts_with = "uniform")]
    pub adaptive: bool,
    /// Every cell gets the same samples in every pass, also when the run stops at a target error.
    #[arg(long)]
    pub uniform: bool,
    /// Adaptive runs: at most this many times the uniform share per cell and pass [default: 4].
    #[arg(
        long,
        value_name = "K",
        conflicts_with = "uniform",
        allow_negative_numbers = true
    )]
    pub adaptive_cap: Option<u32>,
    /// Replay every sample at the cell's upper neighbours and reconstruct the field from the
    /// cells and their differences (screened Poisson, L2): smoother fields and gradients for the
    /// same time, errors that include the correlation between cells.
    #[arg(long)]
    pub gradient_domain: bool,
    /// --gradient-domain: weight α of each cell's own estimate against its differences [default: 0.5].
    #[arg(
        long,
        value_name = "ALPHA",
        requires = "gradient_domain",
        allow_negative_numbers = true
    )]
    pub gradient_alpha: Option<f64>,
    /// Write the field so far (marked partial, resumable) to the output every DURATION, at pass
    /// boundaries.
    #[arg(long, value_name = "DURATION", allow_hyphen_values = true, value_parser = parse_duration)]
    pub checkpoint_every: Option<Duration>,
    /// Continue the run saved in FILE (a partial or checkpointed output of the same command);
    /// writes to FILE unless -o says otherwise.
    #[arg(long, value_name = "FILE")]
    pub resume: Option<PathBuf>,
    /// Direction weighting.
    /// [default: radiance for slices, importance for camera images]
    #[arg(long = "weight", value_enum)]
    pub weight: Option<WeightArg>,
    /// Camera image instead of a slice: a camera of the scene file by name or index (the first
    /// when no value is given).
    #[arg(long, value_name = "NAME", num_args = 0..=1, default_missing_value = "", conflicts_with_all = ["slice", "slices", "plane"])]
    pub camera: Option<String>,
    /// Camera position (with --target) instead of a scene camera.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_vec3, conflicts_with_all = ["slice", "slices", "plane", "camera"], requires = "target")]
    pub eye: Option<glam::DVec3>,
    /// Point the camera looks at.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_vec3, requires = "eye")]
    pub target: Option<glam::DVec3>,
    /// Camera up vector [default: 0,1,0].
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = parse_vec3)]
    pub up: Option<glam::DVec3>,
    /// Vertical field of view of --eye cameras, degrees.
    #[arg(long, default_value_t = crate::app::DEFAULT_FOV_DEG, allow_negative_numbers = true)]
    pub fov: f64,
    /// Camera image size in pixels [default: 512,512].
    #[arg(long, value_name = "W,H", allow_hyphen_values = true, value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    #[command(flatten)]
    pub estimator: EstimatorFlags,
    /// Seed of the random streams (same seed, same result, on any number of threads).
    #[arg(long, default_value_t = RenderOptions::default().seed, allow_negative_numbers = true,
          value_parser = parse_u64)]
    pub seed: u64,
    /// Worker threads, at most 64 per core; 0: one per core [default: 0].
    #[arg(long, default_value_t = RenderOptions::default().threads, allow_negative_numbers = true,
          value_parser = parse_threads)]
    pub threads: usize,
    /// Compute only stripe I of N (grid rows from the bottom, a volume's z layers; from 0), with the
    /// same per-cell random streams as a full run; `merge` the N files afterwards.
    #[arg(long, value_name = "I/N", allow_hyphen_values = true)]
    pub tile: Option<Tile>,
    /// Output EXR, or .vti for a volume [default: out/<scene>_<slice>.exr, with _tile<I>of<N> for a
    /// tile; out/<scene>_volume.vti].
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Skip the PNG previews written next to the EXR (a volume's: its middle z-slice).
    #[arg(long)]
    pub no_png: bool,
    /// Flatland: confine every direction to the slice plane (2D light transport, as in the paper's
    /// 2D figures). The scene must be extruded along the slice normal; point-light intensities are
    /// per radian.
    #[arg(long)]
    pub flatland: bool,
    /// Extract separatrices from the finished field: `separatrix*` channels in the output and the
    /// files `<name>.sep.vtp`, `.sep.svg`, `.sep.png` beside it (see `ftpd3d separatrices`).
    #[arg(long)]
    pub separatrices: bool,
    #[command(flatten)]
    pub sep: SepFlags,
    /// Print the scene's feature set and the kernel a run would use, then stop.
    #[arg(long)]
    pub explain: bool,
    /// Refuse OBJ files that mainstream loaders read with a warning: faces of fewer than 3
    /// vertices, `usemtl`/`mtllib` without a name, unsupported statements, non-UTF-8 text.
    #[arg(long)]
    pub strict: bool,
    /// Let the scene file read files outside its own folder: buffer and image URIs, material
    /// libraries and maps, a sidecar's mesh and environment map that are absolute paths or
    /// `file:` URIs, climb out with `..` or lead elsewhere through a symbolic link. Without it
    /// such a scene is refused, naming the reference.
    #[arg(long)]
    pub allow_outside_uris: bool,
    /// No progress bar or summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    pub quiet: bool,
}

/// The slices of one `--slices` value.

#[derive(Clone, Debug)]
pub struct SliceRange(pub Vec<SliceSpec>);

fn parse_slices(s: &str) -> Result<SliceRange, String> {
    crate::domain::slice::parse_slice_range(s).map(SliceRange)
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
