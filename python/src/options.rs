//! Keyword arguments as the library takes them: lights, sampling, estimator settings, domains.
//! Values that cannot run raise `ParameterError` naming the keyword; the library's own checks
//! (run lengths, planes, cameras) raise theirs in the library's terms.

use crate::errors::param;
use ftpd3d::analysis::separatrix::SepParams;
use ftpd3d::app::{self, Sampling};
use ftpd3d::domain::Tile;
use ftpd3d::domain::slice::{PlaneSpec, SliceArg};
use ftpd3d::ftpd::{Design, Weighting};
use ftpd3d::params::EstimatorArgs;
use ftpd3d::scene::Light;
use glam::DVec3;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::time::Duration;

/// The whole number `value` of keyword `name` as the library's type: a negative or too large one
/// is a `ParameterError` (a ValueError) naming the keyword, rather than an OverflowError.
pub fn count<T: TryFrom<i64>>(name: &str, value: i64) -> PyResult<T> {
    T::try_from(value).map_err(|_| {
        param(format!(
            "{name}={value}: expected a whole number ≥ 0 that fits the count"
        ))
    })
}

/// [`count`] of an optional value.
pub fn count_opt<T: TryFrom<i64>>(name: &str, value: Option<i64>) -> PyResult<Option<T>> {
    value.map(|v| count(name, v)).transpose()
}

/// A triple of numbers.
pub type Vec3 = (f64, f64, f64);

pub fn dvec(v: Vec3) -> DVec3 {
    DVec3::new(v.0, v.1, v.2)
}

/// The lights added to the scene file's, in the command line's order: point lights, suns, sky,
/// environment map.
pub struct LightArgs {
    pub point_lights: Vec<(Vec3, Vec3)>,
    pub suns: Vec<(Vec3, Vec3, Option<f64>)>,
    pub sky: Option<Vec3>,
    pub env: Option<(PathBuf, f64, f64)>,
}

impl LightArgs {
    pub fn lights(&self) -> PyResult<Vec<Light>> {
        let mut out = Vec::new();
        for (k, &(p, i)) in self.point_lights.iter().enumerate() {
            let l = app::point_light(dvec(p), dvec(i))
                .map_err(|e| param(format!("point light {k} at {p:?}: {e}")))?;
            out.push(l);
        }
        for (k, &(d, e, diam)) in self.suns.iter().enumerate() {
            let l = app::sun(dvec(d), dvec(e), diam)
                .map_err(|err| param(format!("sun {k} towards {d:?}: {err}")))?;
            out.push(l);
        }
        if let Some(r) = self.sky {
            out.push(app::sky(dvec(r)).map_err(|e| param(format!("sky {r:?}: {e}")))?);
        }
        if let Some((file, scale, rot)) = &self.env {
            if !(scale.is_finite() && *scale >= 0.0 && rot.is_finite()) {
                return Err(param(format!(
                    "env_scale={scale}, env_rotation={rot}: the scale must be finite and ≥ 0, \
                     the rotation finite"
                )));
            }
            let l = app::environment(file, *scale, *rot)
                .map_err(|e| crate::errors::to_py(anyhow::Error::new(e)))?;
            out.push(l);
        }
        Ok(out)
    }
}

/// `"radiance"`, `"unweighted"` or `"importance"`.
pub fn weighting(name: &str) -> PyResult<Weighting> {
    match name {
        "radiance" => Ok(Weighting::Radiance),
        "unweighted" => Ok(Weighting::Unweighted),
        "importance" => Ok(Weighting::Importance),
        _ => Err(param(format!(
            "weighting={name:?}: expected \"radiance\", \"unweighted\" or \"importance\""
        ))),
    }
}

/// The estimator settings of one run.
pub struct Estimator {
    pub weighting: Weighting,
    pub t0: Option<f64>,
    pub t1: Option<f64>,
    pub angle: f64,
    pub max_bounces: u32,
    pub radiance_bounces: Option<u32>,
    /// The deflection pairs of a sample (`None`: the weighting's).
    pub design: Option<Design>,
    /// Guided radiance paths.
    pub guide: bool,
}

impl Estimator {
    pub fn args(&self) -> EstimatorArgs {
        EstimatorArgs {
            weighting: self.weighting,
            t0: self.t0,
            t1: self.t1,
            angle_deg: self.angle,
            max_bounces: self.max_bounces,
            radiance_bounces: self.radiance_bounces,
            design: self.design,
            guide: self.guide,
        }
    }
}

/// How much one run samples, as given.
pub struct SamplingArgs {
    pub spp: Option<i64>,
    pub time: Option<f64>,
    pub target_error: Option<f64>,
    pub batches: i64,
    pub pass_spp: Option<i64>,
    pub adaptive: Option<bool>,
    pub adaptive_cap: Option<i64>,
    pub gradient_domain: bool,
    pub gradient_alpha: Option<f64>,
    pub seed: i64,
    pub threads: i64,
    pub tile: Option<String>,
}

impl SamplingArgs {
    /// The sampling request, refused where it could never start or never end (the command line
    /// refuses the same values).
    pub fn sampling(&self) -> PyResult<Sampling> {
        let spp: Option<u32> = count_opt("spp", self.spp)?;
        let batches: u32 = count("batches", self.batches)?;
        let pass_spp: Option<u32> = count_opt("pass_spp", self.pass_spp)?;
        let adaptive_cap: Option<u32> = count_opt("adaptive_cap", self.adaptive_cap)?;
        let seed: u64 = count("seed", self.seed)?;
        let threads: usize = count("threads", self.threads)?;
        if spp == Some(0) {
            return Err(param("spp=0: at least one sample per cell is needed"));
        }
        if pass_spp == Some(0) {
            return Err(param(
                "pass_spp=0: a pass needs at least one sample per cell",
            ));
        }
        if batches == 0 {
            return Err(param("batches=0: a run needs at least one pass"));
        }
        if let Some(t) = self.target_error
            && !(t > 0.0 && t.is_finite())
        {
            return Err(param(format!(
                "target_error={t}: must be a finite relative error > 0 (e.g. 0.05)"
            )));
        }
        let time = match self.time {
            None => None,
            Some(t) if t > 0.0 && t.is_finite() => Some(Duration::from_secs_f64(t)),
            Some(t) => {
                return Err(param(format!(
                    "time={t}: the time budget must be a positive number of seconds"
                )));
            }
        };
        if adaptive_cap == Some(0) {
            return Err(param(
                "adaptive_cap=0: a cell must be allowed at least the uniform share",
            ));
        }
        if let Some(a) = self.gradient_alpha {
            if !self.gradient_domain {
                return Err(param(
                    "gradient_alpha applies to gradient-domain runs: add gradient_domain=True",
                ));
            }
            if !(a > 0.0 && a.is_finite()) {
                return Err(param(format!(
                    "gradient_alpha={a}: the weight of a cell's own estimate must be a number > 0"
                )));
            }
        }
        let tile = match &self.tile {
            None => None,
            Some(t) => Some(
                t.parse::<Tile>()
                    .map_err(|e| param(format!("tile={t:?}: {e}")))?,
            ),
        };
        let sampling = Sampling {
            spp,
            batches,
            pass_spp,
            time,
            target_error: self.target_error,
            adaptive: self.adaptive,
            adaptive_cap,
            gradient_domain: self.gradient_domain.then(|| {
                self.gradient_alpha
                    .unwrap_or(ftpd3d::gradient_domain::DEFAULT_ALPHA)
            }),
            seed,
            threads,
            tile,
            progress: false,
        };
        if adaptive_cap.is_some() && !sampling.is_adaptive() {
            return Err(param(
                "adaptive_cap applies to adaptive runs: add adaptive=True (runs of spp or time \
                 alone are uniform)",
            ));
        }
        Ok(sampling)
    }
}

/// A slice as text: `"z=0"`, a slice named in the scene file, or a plane
/// `"origin=X,Y,Z normal=X,Y,Z [up=X,Y,Z] [size=W,H]"`.
pub fn slice_arg(text: &str) -> PyResult<SliceArg> {
    if text.contains("normal=") || text.contains("origin=") {
        let spec = text
            .parse::<PlaneSpec>()
            .map_err(|e| param(format!("slice {e}")))?;
        return Ok(SliceArg::Plane(spec));
    }
    if text.trim().is_empty() {
        return Err(param(
            "slice=\"\": expected AXIS=VALUE (e.g. \"z=0\"), a slice named in the scene file, or \
             \"origin=X,Y,Z normal=X,Y,Z\"",
        ));
    }
    Ok(SliceArg::Axis(text.to_string()))
}

/// The separatrix extraction's settings, checked.
pub fn sep_params(threshold: f64, scale: Option<f64>, tau: Option<f64>) -> PyResult<SepParams> {
    let p = SepParams {
        scale,
        z: threshold,
        tau,
    };
    p.check().map_err(|e| crate::errors::to_py(e.into()))?;
    Ok(p)
}
