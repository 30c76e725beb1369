//! Efficiency against a baseline build (`cargo xtask efficiency`): the time each estimator needs to
//! reach the same error, measured on the same slices.
//!
//! Both estimators run as separate processes of their own binaries (the baseline is any older
//! build of the tool, the candidate normally this tree's), with the same plain command line, so
//! that nothing of one leaks into the other. Per scene and weighting:
//! 1. an **independent reference**: the baseline's estimator with a seed no level uses and
//!    `ref_factor` × the largest level's samples per cell;
//! 2. each binary at doubling sample counts, every level with its own seed (as `converge`);
//! 3. per level, over the cells valid in both the level and the reference: the RMSE of σ with the
//!    reference's own estimated noise taken out ([`Comparison::net_rmse`]), the 95th percentile
//!    of |σ − σ_ref| / σ_ref over the cells with σ_ref > 0, and the variance of the z-scores
//!    (σ − σ_ref) / sqrt(se² + se_ref²), which is 1 when the standard errors are honest;
//! 4. per binary, least squares of ln(error) against ln(spp) gives the samples it needs for the
//!    baseline's error at its largest level, and its seconds per sample (pooled over its levels)
//!    turn them into time; their ratio is the speed-up at equal error (efficiency = 1 /
//!    (variance · time), so for slopes of −½ it is the ratio of the efficiencies). The slopes
//!    shown are those of ln(error) against ln(seconds).
//!
//! Times are the compute seconds the binaries store in their outputs (the scene load is left
//! out). On a shared machine they are noisy: compare ratios from one run.

mod measure;
mod table;

pub use measure::quantile;
use measure::{Level, Speedup, errors, speedup};
pub use table::table;

use crate::binary::{SliceRun, run_slice, seconds};
use anyhow::{Context, bail};
use clap::Args;
use ftpd3d::analysis::converge::spp_levels;
use ftpd3d::cli::args::WeightArg;
use ftpd3d::field::Field;
use ftpd3d::ftpd::Weighting;
use ftpd3d::output::write_atomically;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// `cargo xtask efficiency`: time to the same error as a baseline build, per scene and weighting
/// (a Markdown table).
#[derive(Args, Debug, Clone)]
pub struct EfficiencyArgs {
    /// The baseline binary (an older build of ftpd3d).
    #[arg(long, value_name = "BIN", required = true)]
    baseline: PathBuf,
    /// The candidate binary [default: this tree's ftpd3d, built in release].
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

/// Runs the comparison and prints its table.
pub fn run(args: &EfficiencyArgs) -> anyhow::Result<()> {
    let mut weightings: Vec<Weighting> = args.weight.iter().map(|w| Weighting::from(*w)).collect();
    if weightings.is_empty() {
        weightings = vec![Weighting::Radiance, Weighting::Unweighted];
    }
    if weightings.contains(&Weighting::Importance) {
        bail!("--weight importance needs a camera; efficiency runs on slices");
    }
    let baseline = crate::existing("--baseline", &args.baseline)?;
    let candidate = crate::candidate(args.candidate.as_deref())?;
    let job = EfficiencyJob {
        baseline,
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

/// What [`run_efficiency`] measures.
#[derive(Clone, Debug)]
pub struct EfficiencyJob {
    /// The baseline binary (e.g. a build of 8ae9f4f) and the candidate binary.
    pub baseline: PathBuf,
    pub candidate: PathBuf,
    pub scenes: Vec<PathBuf>,
    pub slice: String,
    pub res: usize,
    pub weightings: Vec<Weighting>,
    pub start_spp: u32,
    pub max_spp: u32,
    /// The reference has this many times the largest level's samples.
    pub ref_factor: u32,
    pub threads: usize,
    /// Outputs of every run and `efficiency.csv`.
    pub work_dir: PathBuf,
    /// Reuse references already in `work_dir` (they depend only on scene, weighting, res, spp).
    pub keep_references: bool,
}

/// One row of the report: a scene and weighting, both binaries' levels and the speed-ups.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub weighting: Weighting,
    pub base: Vec<Level>,
    pub new: Vec<Level>,
    pub rmse: Speedup,
    pub p95: Speedup,
}

/// Seed of the reference runs: no level uses it (levels use 1, 2, ...).
pub const REFERENCE_SEED: u64 = 1_000_003;

/// Runs `bin` on one slice and reads its output back.
fn run_binary(
    bin: &Path,
    job: &EfficiencyJob,
    scene: &Path,
    weighting: Weighting,
    spp: u32,
    seed: u64,
    out: &Path,
) -> anyhow::Result<Field> {
    let run = SliceRun {
        scene,
        slice: &job.slice,
        res: job.res,
        window: None,
        weighting,
        spp,
        batches: spp.min(16),
        seed,
        threads: job.threads,
        extra: &[],
    };
    run_slice(bin, &run, out)
}

/// Runs every scene and weighting of `job` (see the module documentation); `say` gets one line
/// per finished run.
pub fn run_efficiency(job: &EfficiencyJob, mut say: impl FnMut(&str)) -> anyhow::Result<Vec<Row>> {
    let levels = spp_levels(job.start_spp, job.max_spp)?;
    if levels.len() < 2 {
        bail!("efficiency: at least two sample counts are needed to fit a slope");
    }
    std::fs::create_dir_all(&job.work_dir)
        .with_context(|| format!("{}: cannot create it", job.work_dir.display()))?;
    let mut rows = Vec::new();
    for scene in &job.scenes {
        let stem = scene
            .file_stem()
            .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        for &w in &job.weightings {
            let case = Case {
                job,
                scene,
                stem: &stem,
                weighting: w,
            };
            let reference = case.reference(&mut say)?;
            let (base, new) = case.levels(&levels, &reference, &mut say)?;
            rows.push(Row {
                scene: stem.clone(),
                weighting: w,
                rmse: speedup(&base, &new, |e| e.net_rmse),
                p95: speedup(&base, &new, |e| e.p95_rel),
                base,
                new,
            });
        }
    }
    write_atomically(&job.work_dir.join("efficiency.csv"), |tmp| {
        std::fs::write(tmp, csv(&rows)).with_context(|| format!("{}: cannot write", tmp.display()))
    })?;
    Ok(rows)
}

/// One scene and weighting of a job.
struct Case<'a> {
    job: &'a EfficiencyJob,
    scene: &'a Path,
    stem: &'a str,
    weighting: Weighting,
}

impl Case<'_> {
    /// The independent reference: the baseline with a seed no level uses and `ref_factor` × the
    /// largest level's samples (reused from the work directory when asked to).
    fn reference(&self, say: &mut impl FnMut(&str)) -> anyhow::Result<Field> {
        let (job, stem, w) = (self.job, self.stem, self.weighting);
        let ref_spp = job.max_spp.saturating_mul(job.ref_factor);
        let ref_path = job
            .work_dir
            .join(format!("{stem}_{w}_r{}_ref{ref_spp}.exr", job.res));
        if job.keep_references && ref_path.exists() {
            return Ok(ftpd3d::output::exr::read_exr(&ref_path)?);
        }
        let f = run_binary(
            &job.baseline,
            job,
            self.scene,
            w,
            ref_spp,
            REFERENCE_SEED,
            &ref_path,
        )?;
        say(&format!(
            "{stem} {w}: reference {ref_spp} spp in {:.1} s",
            seconds(&f, &ref_path)?
        ));
        Ok(f)
    }

    /// Both binaries at every level, measured against `reference`: (baseline, candidate).
    /// Levels are interleaved (baseline, candidate, next level) so that a change of the
    /// machine's load during the run hits both alike.
    fn levels(
        &self,
        levels: &[u32],
        reference: &Field,
        say: &mut impl FnMut(&str),
    ) -> anyhow::Result<(Vec<Level>, Vec<Level>)> {
        let (job, stem, w) = (self.job, self.stem, self.weighting);
        let (mut base, mut new) = (Vec::new(), Vec::new());
        for (k, &spp) in levels.iter().enumerate() {
            for (tag, bin, v) in [
                ("base", &job.baseline, &mut base),
                ("new", &job.candidate, &mut new),
            ] {
                let out = job.work_dir.join(format!("{stem}_{w}_{tag}_spp{spp}.exr"));
                let f = run_binary(bin, job, self.scene, w, spp, 1 + k as u64, &out)?;
                let l = Level {
                    spp,
                    seconds: seconds(&f, &out)?,
                    errors: errors(&f, reference),
                };
                say(&format!(
                    "{stem} {w} {tag:>4} {spp:>5} spp {:>8.3} s  rmse {:.4e}  p95 rel {:.4}  z var {:.2} \
                     ({:.2} over the {} cells the reference resolves)",
                    l.seconds,
                    l.errors.net_rmse,
                    l.errors.p95_rel,
                    l.errors.z_var,
                    l.errors.z_var_resolved,
                    l.errors.resolved
                ));
                v.push(l);
            }
        }
        Ok((base, new))
    }
}

/// Every level of every row as CSV.
fn csv(rows: &[Row]) -> String {
    let mut csv = String::from(
        "scene,weighting,binary,spp,seconds,net_rmse,p95_rel,z_var,cells,z_var_resolved,resolved_cells\n",
    );
    for r in rows {
        for (tag, lv) in [("base", &r.base), ("new", &r.new)] {
            for l in lv {
                let _ = writeln!(
                    csv,
                    "{},{},{tag},{},{},{},{},{},{},{},{}",
                    r.scene,
                    r.weighting,
                    l.spp,
                    l.seconds,
                    l.errors.net_rmse,
                    l.errors.p95_rel,
                    l.errors.z_var,
                    l.errors.cells,
                    l.errors.z_var_resolved,
                    l.errors.resolved
                );
            }
        }
    }
    csv
}
