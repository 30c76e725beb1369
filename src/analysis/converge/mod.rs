//! Convergence report: error against time on log-log axes, so that a user sees what one more
//! digit of accuracy costs before paying for it.
//!
//! The slice is computed at doubling sample counts `start, 2·start, …, ≤ max`. **Seed policy:
//! every level is a fresh, independent run** with its own seed (the first seed + level index), not
//! a continuation of the previous level. Independent levels have independent errors, so the points
//! of the curve are honest samples of the error at that cost, and the top level can serve as a
//! reference for the others without sharing their samples (a nested top level would contain the
//! lower levels' samples and make their errors look smaller than they are). The price is that the
//! levels together take about twice the time of the top level alone.
//!
//! Error of a level: against a reference field when one is given, else against the highest-sample
//! level of the same weighting (a **self-reference**: its own row has no error and is left out of
//! the fit; the others' errors then include the reference's own noise, which flattens the top
//! of the curve slightly, by √(1 + n/N) for n samples against the reference's N). Over the cells
//! valid in both: the root mean square of σ − σ_ref, and the mean of |σ − σ_ref| / σ_ref (cells
//! with σ_ref > 0). The mean of the run's own estimated standard error (batches) is reported too,
//! to show whether it tracks the measured error.
//!
//! Before each curve, one untimed warm-up run of the first level's size absorbs one-time costs.
//!
//! The same report can hold the curves of another build of the tool (`Curve::baseline`, drawn
//! darker on the plot, `baseline` in the CSVs' `binary` column): the developer tooling (`cargo
//! xtask converge`) measures an older build and this one that way.
//!
//! The fit is ordinary least squares of ln(RMSE) against ln(wall seconds) (and against ln(spp)),
//! with the slope's standard error. Monte Carlo converges as t^−½ once the time is proportional
//! to the samples; fixed costs per run make small runs look cheaper than they are.

mod compare;
mod curve;
mod measure;
mod report;

pub use compare::{Comparison, compare, mean_stderr};
pub use curve::{Curve, Fit, Level, fit_line};
pub use measure::{measure, spp_levels};
pub use report::{Report, csv, fit_csv, plot};

use crate::domain::{MAX_RES, Plane};
use crate::field::Field;
use crate::ftpd::{Params, Weighting};
use crate::output::{check_writable, write_atomically, write_outputs};
use crate::params::EstimatorArgs;
use crate::scene::Scene;
use crate::scene::load::load_scene_with;
use anyhow::Context;
use std::path::PathBuf;

/// What to run.
#[derive(Clone, Debug)]
pub struct ConvergeJob {
    pub scene: PathBuf,
    pub lights: Vec<crate::scene::Light>,
    pub slice: String,
    pub window: Option<[f64; 4]>,
    /// Cells along the longer side; `None`: the reference's, or 64.
    pub res: Option<usize>,
    pub reference: Option<PathBuf>,
    pub out_dir: PathBuf,
    /// `None`: the reference's weighting; without a reference, radiance and unweighted when the
    /// scene has lights, else unweighted.
    pub weighting: Option<Weighting>,
    /// Estimator settings (its weighting is replaced per curve).
    pub estimator: EstimatorArgs,
    pub start_spp: u32,
    pub max_spp: u32,
    pub batches: u32,
    pub seed: u64,
    pub threads: usize,
    pub quiet: bool,
    /// How the scene file is read (whether it may read files outside its folder).
    pub load: crate::scene::LoadOptions,
}

/// Cells along the longer side of a convergence run without a reference or a resolution.
pub const DEFAULT_RES: usize = 64;

/// What a convergence report refuses, in its own terms (the command line names its flags:
/// `crate::cli::analysis_errors`).
#[derive(Debug, thiserror::Error)]
pub enum ConvergeError {
    #[error("the first level needs at least one sample per cell (it has 0)")]
    NoSamples,
    #[error("the largest sample count {max} is smaller than the first level's {start}")]
    LevelsReversed { start: u32, max: u32 },
    /// Without a reference field the top level is the reference, so two levels leave one to fit.
    #[error(
        "a self-referenced report needs at least 3 levels (start, 2x, 4x): raise the largest \
         sample count {max} to {needed} or give a reference field"
    )]
    TooFewLevels { max: u32, needed: u32 },
    #[error("resolution {res}: must be between 1 and {max} cells")]
    Resolution { res: usize, max: usize },
    #[error("output directory {}: cannot create it", .dir.display())]
    CreateDir {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("reference field {}: no such file", .path.display())]
    NoReference { path: PathBuf },
    #[error("reference field")]
    ReadReference {
        path: PathBuf,
        source: anyhow::Error,
    },
    #[error(
        "reference field: weighting {} cannot be compared on a slice",
        .weighting.map_or("(none)".into(), |w| w.to_string())
    )]
    ReferenceWeighting { weighting: Option<Weighting> },
    #[error("importance weighting needs a camera; a convergence report runs on a slice")]
    ImportanceOnSlice,
    #[error("converge: no sample counts to run")]
    NoLevels,
}

/// A convergence run made ready: its levels, the reference, the scene, the plane and the
/// estimator of each weighting, all checked.
pub struct Setup {
    pub levels: Vec<u32>,
    /// The reference field with its name for messages.
    pub reference: Option<(String, Field)>,
    pub scene: Scene,
    pub plane: Plane,
    pub weightings: Vec<Weighting>,
    /// One per weighting.
    pub params: Vec<Params>,
}

impl Setup {
    /// Checks `job`, creates its output directory, reads its reference, loads the scene (its
    /// warnings go to stderr) and resolves the plane and each weighting's estimator.
    pub fn prepare(job: &ConvergeJob) -> anyhow::Result<Setup> {
        let levels = check_levels(job)?;
        std::fs::create_dir_all(&job.out_dir).map_err(|source| ConvergeError::CreateDir {
            dir: job.out_dir.clone(),
            source,
        })?;
        check_writable(&job.out_dir.join("converge.csv"))?;
        let reference = read_reference(job)?;
        let scene = load_scene_with(&job.scene, &job.lights, &job.load)?;
        for w in &scene.report.warnings {
            eprintln!("warning: {w}");
        }
        let res = job.res.unwrap_or_else(|| {
            reference
                .as_ref()
                .map_or(DEFAULT_RES, |(_, r)| r.width.max(r.height))
        });
        let spec = crate::domain::slice::resolve_slice(&job.slice, &scene)?;
        let plane = Plane::axis_slice(&scene.bounds, spec, job.window, res)?;
        let weightings = weightings(job, reference.as_ref(), &scene)?;
        let params = weightings
            .iter()
            .map(|w| {
                let mut e = job.estimator.clone();
                e.weighting = *w;
                e.resolve_for_plane(&scene, &plane)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Setup {
            levels,
            reference,
            scene,
            plane,
            weightings,
            params,
        })
    }

    /// The reference field with its name.
    pub fn reference(&self) -> Option<(&str, &Field)> {
        self.reference.as_ref().map(|(n, f)| (n.as_str(), f))
    }

    /// The line that opens the report: scene, slice, grid, levels, weightings and reference
    /// (`self_reference` says what stands in for a missing reference field).
    pub fn summary(&self, job: &ConvergeJob, self_reference: &str) -> String {
        format!(
            "converge: {} slice {} ({}x{} cells), spp {:?}, weighting {}, {}",
            job.scene.display(),
            self.plane.label,
            self.plane.width,
            self.plane.height,
            self.levels,
            self.weightings
                .iter()
                .map(Weighting::to_string)
                .collect::<Vec<_>>()
                .join(" and "),
            match &job.reference {
                Some(p) => format!("reference {}", p.display()),
                None => self_reference.to_string(),
            }
        )
    }

    /// The report of `curves`, of which those of `baseline` (a build) are marked as such.
    pub fn report(
        &self,
        job: &ConvergeJob,
        curves: Vec<Curve>,
        baseline: Option<PathBuf>,
    ) -> Report {
        Report {
            curves,
            reference: job.reference.clone(),
            plane: self.plane.label.clone(),
            grid: (self.plane.width, self.plane.height),
            scene: job.scene.clone(),
            baseline,
        }
    }
}

/// The sample counts of `job`, checked against what a report needs.
fn check_levels(job: &ConvergeJob) -> Result<Vec<u32>, ConvergeError> {
    let levels = spp_levels(job.start_spp, job.max_spp)?;
    if job.reference.is_none() && levels.len() < 3 {
        return Err(ConvergeError::TooFewLevels {
            max: job.max_spp,
            needed: job.start_spp.saturating_mul(4),
        });
    }
    if let Some(r) = job.res
        && (r == 0 || r > MAX_RES)
    {
        return Err(ConvergeError::Resolution {
            res: r,
            max: MAX_RES,
        });
    }
    Ok(levels)
}

/// The reference field of `job`, named by its path.
fn read_reference(job: &ConvergeJob) -> Result<Option<(String, Field)>, ConvergeError> {
    let Some(p) = &job.reference else {
        return Ok(None);
    };
    if !p.exists() {
        return Err(ConvergeError::NoReference { path: p.clone() });
    }
    let field = crate::output::exr::read_exr(p).map_err(|source| ConvergeError::ReadReference {
        path: p.clone(),
        source: source.into(),
    })?;
    Ok(Some((p.display().to_string(), field)))
}

/// The weightings of the curves: the job's, else the reference's, else radiance and unweighted
/// when the scene has lights (unweighted alone otherwise).
fn weightings(
    job: &ConvergeJob,
    reference: Option<&(String, Field)>,
    scene: &Scene,
) -> anyhow::Result<Vec<Weighting>> {
    let weightings: Vec<Weighting> = match (job.weighting, reference) {
        (Some(w), _) => vec![w],
        (None, Some((name, r))) => match r.info(name)?.weighting {
            Some(w @ (Weighting::Radiance | Weighting::Unweighted)) => vec![w],
            weighting => return Err(ConvergeError::ReferenceWeighting { weighting }.into()),
        },
        (None, None) if scene.lights.is_empty() => vec![Weighting::Unweighted],
        (None, None) => vec![Weighting::Radiance, Weighting::Unweighted],
    };
    if weightings.contains(&Weighting::Importance) {
        return Err(ConvergeError::ImportanceOnSlice.into());
    }
    Ok(weightings)
}

/// Runs a [`ConvergeJob`] end to end: runs, `converge.csv`, `converge_fit.csv`, `converge.png`,
/// and the top run of each weighting (of this binary) as `<weighting>_spp<N>.exr` in the output
/// directory.
pub fn run_converge(job: &ConvergeJob) -> anyhow::Result<Report> {
    let setup = Setup::prepare(job)?;
    let quiet = job.quiet;
    let say = |s: &str| {
        if !quiet {
            eprintln!("{s}");
        }
    };
    say(&setup.summary(job, "self-reference (highest spp)"));
    let (curves, tops) = measure(&setup, job, say)?;
    let report = setup.report(job, curves, None);
    write_report(job, &report, &tops)?;
    Ok(report)
}

/// Writes `converge.csv`, `converge_fit.csv` and `converge.png` of `report` to the job's output
/// directory, and the top fields (`tops`, one per curve of this build) as
/// `<weighting>_spp<N>.exr`.
pub fn write_report(job: &ConvergeJob, report: &Report, tops: &[Field]) -> anyhow::Result<()> {
    for (name, text) in [
        ("converge.csv", csv(report)),
        ("converge_fit.csv", fit_csv(report)),
    ] {
        write_atomically(&job.out_dir.join(name), |tmp| {
            std::fs::write(tmp, &text).with_context(|| format!("{}: cannot write", tmp.display()))
        })?;
    }
    plot(report, &job.out_dir.join("converge.png"), (800, 560))?;
    for (c, f) in report.curves.iter().filter(|c| !c.baseline).zip(tops) {
        let top = c.levels.last().map_or(0, |l| l.spp);
        write_outputs(
            f,
            &job.out_dir.join(format!("{}_spp{top}.exr", c.weighting)),
            false,
        )?;
    }
    Ok(())
}
