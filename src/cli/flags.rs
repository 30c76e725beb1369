//! Flags shared by runs and the analysis subcommands: the estimator's settings and lights
//! (runs, `converge`), the weighting, and the separatrix extraction's settings (runs with
//! `--separatrices`, `separatrices`).

use crate::analysis::separatrix::SepParams;
use crate::cli::parse::{parse_env, parse_point_light, parse_sky, parse_sun};
use crate::ftpd::Weighting;
use crate::run::EstimatorArgs;
use clap::{Args, ValueEnum};

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
    #[arg(long, value_name = "R,G,B", value_parser = parse_sky)]
    pub sky: Option<crate::scene::Light>,
    /// Add an environment map: a lat-long .exr or .hdr (+y up), its radiance × SCALE [default: 1],
    /// turned about +y by ROT_DEG degrees [default: 0].
    #[arg(long, value_name = "FILE[:SCALE[:ROT_DEG]]", allow_hyphen_values = true, value_parser = parse_env)]
    pub env: Option<crate::scene::Light>,
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

    /// The estimator settings with `weighting`.
    pub fn args(&self, weighting: Weighting) -> EstimatorArgs {
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

/// The direction weighting, as `--weight` names it.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum WeightArg {
    /// Weight each direction by the radiance passing the point along it (needs lights).
    Radiance,
    /// Every direction alike.
    Unweighted,
    /// Pairs start at a camera along pixel rays (camera images; the default there).
    Importance,
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

/// The separatrix extraction's settings, shared by runs (`--separatrices`) and `separatrices`.
#[derive(Args, Debug, Clone)]
pub struct SepFlags {
    /// Scale of the derivative-of-Gaussian filters, in cells (≥ 0.7) [default: the smallest at
    /// which a step of height τ is significant at Z in the median cell].
    #[arg(long, value_name = "CELLS", allow_negative_numbers = true)]
    pub sep_scale: Option<f64>,
    /// Significance Z: mark cells whose largest |∇²_ω σ| is Z standard errors from 0 (a test over
    /// all directions at once).
    #[arg(
        long,
        value_name = "Z",
        default_value_t = 3.0,
        allow_negative_numbers = true
    )]
    pub sep_threshold: f64,
    /// Strength threshold τ in units of σ (the scale-normalised |∇²_ω σ|; for lines, the height of
    /// a step of σ) [default: 0.1 × the median σ of the cells with σ > 0].
    #[arg(long, value_name = "TAU", allow_negative_numbers = true)]
    pub sep_tau: Option<f64>,
}

impl SepFlags {
    /// The settings, checked.
    pub fn params(&self) -> anyhow::Result<SepParams> {
        let p = SepParams {
            scale: self.sep_scale,
            z: self.sep_threshold,
            tau: self.sep_tau,
        };
        p.check()?;
        Ok(p)
    }

    /// Whether any setting differs from its default (they need `--separatrices` on a run).
    pub fn given(&self) -> bool {
        self.sep_scale.is_some() || self.sep_tau.is_some() || self.sep_threshold != 3.0
    }
}
