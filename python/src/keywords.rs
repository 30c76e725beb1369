//! The keywords every run takes (sampling, estimator, separatrices, progress), read once from a
//! method's `**options` rather than repeated in each method's parameter list: `slice`,
//! `flatland`, `camera` and `volume` take the same ones with the same defaults, and a new one is
//! added here alone. Each method's `text_signature` still lists them, so `help()` and editors show
//! every keyword with its default (a test holds those defaults equal to what a run uses).

use crate::errors::param;
use crate::options::{self, Estimator, SamplingArgs};
use ftpd3d::analysis::separatrix::SepParams;
use ftpd3d::ftpd::Design;
use ftpd3d::params::EstimatorArgs;
use ftpd3d::render::RenderOptions;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The deflection pairs of a sample: `(kA, kB, J, M)` or the text `"kA,kB,J,M"`.
#[derive(FromPyObject)]
enum Pairs {
    Tuple(i64, i64, i64, i64),
    Text(String),
}

impl Pairs {
    fn design(self) -> PyResult<Design> {
        let bad = |why: String| param(format!("pairs: {why}"));
        match self {
            Pairs::Text(s) => s.parse::<Design>().map_err(bad),
            Pairs::Tuple(a, b, j, m) => {
                let n = |x: i64| {
                    u32::try_from(x).map_err(|_| bad(format!("{x} is not a whole number ≥ 0")))
                };
                Ok(Design::new(n(a)?, n(b)?, n(j)?, n(m)?))
            }
        }
    }
}

/// A run's keywords other than its domain's, as given.
pub struct RunKeywords<'py> {
    pub est: Estimator,
    pub sampling: SamplingArgs,
    pub sep: Option<SepParams>,
    pub progress: Option<Bound<'py, PyAny>>,
}

/// The keyword arguments left to read, with the method's name for the messages Python itself
/// would give (an unknown keyword, a value of the wrong type: `TypeError`).
struct Taker<'a, 'py> {
    left: Bound<'py, PyDict>,
    method: &'a str,
}

impl<'py> Taker<'_, 'py> {
    /// The value of `name`, or `default` when it is not given.
    fn get<T: for<'a> FromPyObject<'a, 'py>>(&self, name: &str, default: T) -> PyResult<T> {
        match self.left.get_item(name)? {
            None => Ok(default),
            Some(v) => {
                self.left.del_item(name)?;
                v.extract::<T>().map_err(|e| {
                    let e: PyErr = e.into();
                    PyTypeError::new_err(format!("{}() argument '{name}': {e}", self.method))
                })
            }
        }
    }

    /// Refuses keywords no run takes.
    fn finish(self) -> PyResult<()> {
        match self.left.keys().iter().next() {
            None => Ok(()),
            Some(k) => Err(PyTypeError::new_err(format!(
                "{}() got an unexpected keyword argument {}",
                self.method,
                k.repr()?
            ))),
        }
    }
}

impl<'py> RunKeywords<'py> {
    /// Reads `options` (the method's `**options`) with the defaults the command line uses;
    /// `weighting` is the method's own default.
    pub fn new(
        py: Python<'py>,
        method: &str,
        options: Option<&Bound<'py, PyDict>>,
        weighting: &str,
    ) -> PyResult<Self> {
        let left = match options {
            Some(d) => d.copy()?,
            None => PyDict::new(py),
        };
        let k = Taker { left, method };
        let est_default = EstimatorArgs::default();
        let run_default = RenderOptions::default();
        let est = Estimator {
            weighting: options::weighting(&k.get("weighting", weighting.to_string())?)?,
            t0: k.get("t0", None)?,
            t1: k.get("t1", None)?,
            angle: k.get("angle", est_default.angle_deg)?,
            max_bounces: options::count(
                "max_bounces",
                k.get("max_bounces", est_default.max_bounces as i64)?,
            )?,
            radiance_bounces: options::count_opt(
                "radiance_bounces",
                k.get::<Option<i64>>("radiance_bounces", None)?,
            )?,
            design: k
                .get::<Option<Pairs>>("pairs", None)?
                .map(Pairs::design)
                .transpose()?,
            guide: k.get("guide", est_default.guide)?,
        };
        let sampling = SamplingArgs {
            spp: k.get("spp", None)?,
            time: k.get("time", None)?,
            target_error: k.get("target_error", None)?,
            batches: k.get("batches", run_default.batches as i64)?,
            pass_spp: k.get("pass_spp", None)?,
            adaptive: k.get("adaptive", None)?,
            adaptive_cap: k.get("adaptive_cap", None)?,
            gradient_domain: k.get("gradient_domain", false)?,
            gradient_alpha: k.get("gradient_alpha", None)?,
            seed: k.get("seed", run_default.seed as i64)?,
            threads: k.get("threads", 0)?,
            tile: k.get("tile", None)?,
        };
        let separatrices: bool = k.get("separatrices", false)?;
        let threshold = k.get("sep_threshold", SepParams::default().z)?;
        let scale = k.get("sep_scale", None)?;
        let tau = k.get("sep_tau", None)?;
        let sep = separatrices
            .then(|| options::sep_params(threshold, scale, tau))
            .transpose()?;
        let progress: Option<Bound<'py, PyAny>> = k.get("progress", None)?;
        k.finish()?;
        Ok(RunKeywords {
            est,
            sampling,
            sep,
            progress,
        })
    }
}
