//! Efficiency at equal time against a baseline build (`cargo xtask equal-time`).
//!
//! Per scene and weighting:
//! 1. an **independent reference**, computed once and cached: the reference binary (by default
//!    the first candidate) with a seed no round uses and `ref_factor` × the rounds' time budget,
//!    so about that many times the samples of one round's run; its own noise (the mean of its
//!    squared standard errors) is stated and taken out of every run's squared error;
//! 2. `rounds` rounds, each running the baseline and then every candidate once (A, B, A, B ...,
//!    so a change of the machine's load hits all alike) with the same time budget (`--time`) and
//!    a seed of its own;
//! 3. per run, the mean squared error of σ against the reference over the cells valid in both,
//!    net of the reference's noise (RMSE²);
//! 4. per round, the efficiency (1 / (variance · time)) of a candidate over the baseline's:
//!    RMSE²·t of the baseline over RMSE²·t of the candidate, with t the compute seconds each run
//!    stored (equal to the budget up to the last pass), and again with t its CPU seconds
//!    (user + system), which show how much of a shared machine each run got. Reported as the
//!    geometric mean over rounds with the rounds' range, and pooled (the ratio of the means).

mod report;

pub use report::{csv, ratio, table};

use crate::binary::run_costed;
use crate::cost::load_average;
use anyhow::{Context, bail};
use clap::Args;
use ftpd3d::analysis::converge::{Comparison, compare};
use ftpd3d::cli::args::WeightArg;
use ftpd3d::field::Field;
use ftpd3d::ftpd::Weighting;
use ftpd3d::output::write_atomically;
use std::path::{Path, PathBuf};

/// `cargo xtask equal-time`: RMSE² of σ at the same time budget, a baseline build against one or
/// more candidates, rounds interleaved (a Markdown table).
#[derive(Args, Debug, Clone)]
pub struct EqualTimeArgs {
    /// The baseline binary (an older build of ftpd3d, e.g. of 8ae9f4f).
    #[arg(long, value_name = "BIN", required = true)]
    baseline: PathBuf,
    /// A candidate binary, as BIN or LABEL=BIN; repeatable [default: this tree's ftpd3d, built
    /// in release, labelled with its commit].
    #[arg(long, value_name = "[LABEL=]BIN")]
    candidate: Vec<String>,
    /// Scene files; repeatable [default: the Cornell box and the stair wall].
    #[arg(long, value_name = "FILE")]
    scene: Vec<PathBuf>,
    /// Axis-aligned slice plane of every scene.
    #[arg(long, value_name = "AXIS=VALUE", default_value = "z=0")]
    slice: String,
    /// Cells along the longer side.
    #[arg(long, default_value_t = 48)]
    res: usize,
    /// Weightings; repeatable [default: radiance and unweighted].
    #[arg(long = "weight", value_enum)]
    weight: Vec<WeightArg>,
    /// Time budget of every run (`--time` of the binaries), seconds.
    #[arg(long, default_value_t = 10)]
    seconds: u32,
    /// Rounds; each runs the baseline and every candidate once.
    #[arg(long, default_value_t = 4)]
    rounds: u32,
    /// The reference's time budget is this many times --seconds.
    #[arg(long, default_value_t = 16)]
    ref_factor: u32,
    /// The binary that computes references [default: the first candidate].
    #[arg(long, value_name = "BIN")]
    reference_bin: Option<PathBuf>,
    /// Worker threads of every run [default: all cores].
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Directory for the cached references, every run's EXR and equal-time.csv [default:
    /// <target>/equal-time].
    #[arg(long, value_name = "DIR")]
    work_dir: Option<PathBuf>,
    /// Compute the references again even when the work directory has them.
    #[arg(long)]
    fresh_references: bool,
    /// No per-run lines.
    #[arg(short, long)]
    quiet: bool,
}

/// A binary of a comparison and its label in the table.
#[derive(Clone, Debug)]
pub struct Binary {
    pub label: String,
    pub path: PathBuf,
}

/// What [`run_equal_time`] measures.
#[derive(Clone, Debug)]
pub struct EqualTimeJob {
    pub baseline: Binary,
    pub candidates: Vec<Binary>,
    pub reference_bin: PathBuf,
    pub scenes: Vec<PathBuf>,
    pub slice: String,
    pub res: usize,
    pub weightings: Vec<Weighting>,
    pub seconds: u32,
    pub rounds: u32,
    pub ref_factor: u32,
    pub threads: usize,
    pub work_dir: PathBuf,
    pub fresh_references: bool,
}

/// Seed of the references: no round uses it (rounds use 1, 2, ...).
pub const REFERENCE_SEED: u64 = 1_000_003;

/// `LABEL=BIN` or `BIN` (labelled with its file name).
pub(crate) fn parse_binary(s: &str) -> Binary {
    match s.split_once('=') {
        Some((label, path)) if !label.is_empty() && !label.contains('/') => Binary {
            label: label.to_string(),
            path: PathBuf::from(path),
        },
        _ => Binary {
            label: label_of(Path::new(s)),
            path: PathBuf::from(s),
        },
    }
}

pub(crate) fn label_of(path: &Path) -> String {
    path.file_name()
        .map_or("binary".into(), |n| n.to_string_lossy().into_owned())
}

/// This tree's commit (short), the label of its build.
fn this_commit() -> String {
    std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .current_dir(crate::workspace_root())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map_or("this tree".into(), |s| s.trim().to_string())
}

/// Runs the comparison and prints its table.
pub fn run(args: &EqualTimeArgs) -> anyhow::Result<()> {
    let mut weightings: Vec<Weighting> = args.weight.iter().map(|w| Weighting::from(*w)).collect();
    if weightings.is_empty() {
        weightings = vec![Weighting::Radiance, Weighting::Unweighted];
    }
    if weightings.contains(&Weighting::Importance) {
        bail!("--weight importance needs a camera; equal-time runs on slices");
    }
    if args.rounds == 0 || args.seconds == 0 || args.ref_factor == 0 {
        bail!("--rounds, --seconds and --ref-factor must be at least 1");
    }
    let baseline = Binary {
        label: label_of(&args.baseline),
        path: crate::existing("--baseline", &args.baseline)?,
    };
    let mut candidates = Vec::new();
    for c in &args.candidate {
        let b = parse_binary(c);
        crate::existing("--candidate", &b.path)?;
        candidates.push(b);
    }
    if candidates.is_empty() {
        candidates.push(Binary {
            label: this_commit(),
            path: crate::candidate(None)?,
        });
    }
    let reference_bin = match &args.reference_bin {
        Some(b) => crate::existing("--reference-bin", b)?,
        None => candidates[0].path.clone(),
    };
    let scenes = if args.scene.is_empty() {
        ["cornell_mirror.obj", "stair_wall.obj"]
            .iter()
            .map(|s| crate::workspace_root().join("scenes").join(s))
            .collect()
    } else {
        args.scene.clone()
    };
    let work_dir = match &args.work_dir {
        Some(d) => d.clone(),
        None => crate::target_dir()?.join("equal-time"),
    };
    let job = EqualTimeJob {
        baseline,
        candidates,
        reference_bin,
        scenes,
        slice: args.slice.clone(),
        res: args.res,
        weightings,
        seconds: args.seconds,
        rounds: args.rounds,
        ref_factor: args.ref_factor,
        threads: args.threads,
        work_dir,
        fresh_references: args.fresh_references,
    };
    let quiet = args.quiet;
    let cases = run_equal_time(&job, |s| {
        if !quiet {
            eprintln!("{s}");
        }
    })?;
    print!("{}", table(&job, &cases));
    Ok(())
}

/// The independent reference of one scene and weighting.
#[derive(Clone, Debug)]
pub struct Reference {
    pub path: PathBuf,
    pub field: Field,
    /// Samples per cell.
    pub spp: f64,
    /// Compute seconds it stored.
    pub compute: f64,
    /// Its CPU seconds, when computed by this invocation.
    pub cpu: Option<f64>,
    /// Mean of its squared standard errors over its valid cells.
    pub mean_var: f64,
    pub cached: bool,
}

/// Which run: a binary of the job, its round, seed and time budget.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slot {
    /// Index into the job's binaries: 0 the baseline, 1.. the candidates.
    pub binary: usize,
    pub round: u32,
    pub seed: u64,
    /// `--time` of the run, seconds.
    pub budget: f64,
}

/// One run of one binary in one round.
#[derive(Clone, Debug)]
pub struct RunResult {
    /// Index into the job's binaries: 0 the baseline, 1.. the candidates.
    pub binary: usize,
    pub round: u32,
    pub seed: u64,
    /// `--time` of the run, seconds.
    pub budget: f64,
    /// Samples per cell.
    pub spp: f64,
    /// Compute seconds the run stored.
    pub compute: f64,
    pub wall: f64,
    pub cpu: Option<f64>,
    /// Mean squared error of σ against the reference over the cells valid in both.
    pub mse: f64,
    /// `mse` less the reference's mean squared standard error over the same cells.
    pub net_mse: f64,
}

/// Everything measured on one scene and weighting.
#[derive(Clone, Debug)]
pub struct Case {
    pub scene: String,
    pub weighting: Weighting,
    pub reference: Reference,
    pub runs: Vec<RunResult>,
    /// The one-minute load average before the first and after the last round.
    pub load: (Option<f64>, Option<f64>),
}

impl EqualTimeJob {
    /// The baseline and then every candidate.
    pub fn binaries(&self) -> Vec<&Binary> {
        std::iter::once(&self.baseline)
            .chain(&self.candidates)
            .collect()
    }

    /// The flags every run of a scene and weighting shares (a budget and the output come after).
    pub(crate) fn slice_args(&self, scene: &Path, w: Weighting, seed: u64) -> Vec<String> {
        let mut a: Vec<String> = vec!["--scene".into(), scene.display().to_string()];
        for (flag, value) in [
            ("--slice", self.slice.clone()),
            ("--res", self.res.to_string()),
            ("--weight", w.to_string()),
            ("--seed", seed.to_string()),
            ("--threads", self.threads.to_string()),
        ] {
            a.push(flag.into());
            a.push(value);
        }
        a
    }
}

/// Runs every scene and weighting of `job` (see the module documentation); `say` gets one line
/// per finished run. Writes `equal-time.csv` (every run) to the work directory.
pub fn run_equal_time(job: &EqualTimeJob, mut say: impl FnMut(&str)) -> anyhow::Result<Vec<Case>> {
    let runs_dir = job.work_dir.join("runs");
    std::fs::create_dir_all(&runs_dir)
        .with_context(|| format!("{}: cannot create it", runs_dir.display()))?;
    let mut cases = Vec::new();
    for scene in &job.scenes {
        if !scene.is_file() {
            bail!("--scene {}: no such file", scene.display());
        }
        let stem = scene
            .file_stem()
            .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        for &w in &job.weightings {
            let ref_seconds = f64::from(job.seconds) * f64::from(job.ref_factor);
            let reference = reference(job, scene, &stem, w, ref_seconds, &mut say)?;
            let load0 = load_average();
            let mut runs = Vec::new();
            let bins = job.binaries();
            for round in 0..job.rounds {
                for (j, bin) in bins.iter().enumerate() {
                    let seed = 1 + u64::from(round) * bins.len() as u64 + j as u64;
                    let out = runs_dir.join(format!(
                        "{stem}_{}_{w}_r{}_{}_round{round}.exr",
                        slice_tag(&job.slice),
                        job.res,
                        bin.label
                    ));
                    let slot = Slot {
                        binary: j,
                        round,
                        seed,
                        budget: f64::from(job.seconds),
                    };
                    let r = measure_run(job, scene, w, &slot, &out, &reference)?;
                    say(&format!(
                        "{stem} {w} round {round} {:>12}: {:>7.0} spp, {:.2} s compute, {:.2} s wall, \
                         {} CPU s, RMSE² {:.4e} (net of the reference {:.4e})",
                        bin.label,
                        r.spp,
                        r.compute,
                        r.wall,
                        r.cpu.map_or("n/a".into(), |c| format!("{c:.2}")),
                        r.mse,
                        r.net_mse
                    ));
                    runs.push(r);
                }
            }
            cases.push(Case {
                scene: stem.clone(),
                weighting: w,
                reference,
                runs,
                load: (load0, load_average()),
            });
        }
    }
    let csv_path = job.work_dir.join("equal-time.csv");
    write_atomically(&csv_path, |tmp| {
        std::fs::write(tmp, csv(job, &cases))
            .with_context(|| format!("{}: cannot write", tmp.display()))
    })?;
    Ok(cases)
}

/// `--time` of `seconds`: whole seconds as `10s` (what every build parses), else milliseconds.
pub fn time_flag(seconds: f64) -> String {
    if seconds.fract() == 0.0 {
        format!("{seconds:.0}s")
    } else {
        format!("{:.0}ms", seconds * 1000.0)
    }
}

/// The squared error of a run and the same net of the reference's noise: the mean of
/// (σ − σ_ref)² over the cells valid in both, less the mean of the reference's squared standard
/// errors over those cells (its expected share, as the two are independent). The net figure can
/// fall below zero when the reference is the noisier; it is kept so, not clamped, so that means
/// over runs stay unbiased.
pub fn squared_errors(c: &Comparison) -> (f64, f64) {
    let mse = c.rmse * c.rmse;
    (mse, mse - c.ref_var)
}

/// Runs binary `slot.binary` of `job` on `scene` and `w` with the slot's seed and `--time`,
/// writing its EXR to `out`, and measures it against `reference`.
pub(crate) fn measure_run(
    job: &EqualTimeJob,
    scene: &Path,
    w: Weighting,
    slot: &Slot,
    out: &Path,
    reference: &Reference,
) -> anyhow::Result<RunResult> {
    let bin = job.binaries()[slot.binary];
    let mut args = job.slice_args(scene, w, slot.seed);
    args.extend(["--time".into(), time_flag(slot.budget)]);
    let (field, cost) = run_costed(&bin.path, &args, out)?;
    let (mse, net_mse) = squared_errors(&compare(&field, &reference.field));
    Ok(RunResult {
        binary: slot.binary,
        round: slot.round,
        seed: slot.seed,
        budget: slot.budget,
        spp: samples_per_cell(&field),
        compute: crate::binary::seconds(&field, out)?,
        wall: cost.wall,
        cpu: cost.cpu,
        mse,
        net_mse,
    })
}

/// `z=0` as a file-name part (`z0`).
pub(crate) fn slice_tag(slice: &str) -> String {
    slice
        .chars()
        .filter(|c| c.is_ascii_alphanumeric() || *c == '.' || *c == '-')
        .collect()
}

/// Samples per cell of a field (all its samples over its cells).
pub fn samples_per_cell(field: &Field) -> f64 {
    field.total_samples() as f64 / field.cells.len().max(1) as f64
}

/// Mean squared standard error over the valid cells of a field.
fn mean_var(field: &Field) -> f64 {
    let (n, s) = field
        .values()
        .iter()
        .filter(|v| v.valid)
        .fold((0usize, 0.0f64), |(n, s), v| {
            (n + 1, s + v.stderr * v.stderr)
        });
    if n > 0 { s / n as f64 } else { 0.0 }
}

/// The cached or newly computed reference of one scene and weighting, of `ref_seconds` of
/// `--time` (its file name carries them, so references of other budgets do not mix).
pub(crate) fn reference(
    job: &EqualTimeJob,
    scene: &Path,
    stem: &str,
    w: Weighting,
    ref_seconds: f64,
    say: &mut impl FnMut(&str),
) -> anyhow::Result<Reference> {
    let path = job.work_dir.join(format!(
        "ref_{stem}_{}_{w}_r{}_{ref_seconds}s.exr",
        slice_tag(&job.slice),
        job.res
    ));
    let (field, cpu, cached) = if path.is_file() && !job.fresh_references {
        let f = ftpd3d::output::exr::read_exr(&path).with_context(|| path.display().to_string())?;
        (f, None, true)
    } else {
        let mut args = job.slice_args(scene, w, REFERENCE_SEED);
        args.extend(["--time".into(), time_flag(ref_seconds)]);
        let (f, cost) = run_costed(&job.reference_bin, &args, &path)?;
        let note = format!(
            "{} {} --quiet --no-png -o {}\nCPU seconds {}\n",
            job.reference_bin.display(),
            args.join(" "),
            path.display(),
            cost.cpu.map_or("n/a".into(), |c| format!("{c:.2}"))
        );
        let note_path = path.with_extension("txt");
        std::fs::write(&note_path, note)
            .with_context(|| format!("{}: cannot write", note_path.display()))?;
        (f, cost.cpu, false)
    };
    let r = Reference {
        spp: samples_per_cell(&field),
        compute: crate::binary::seconds(&field, &path)?,
        mean_var: mean_var(&field),
        path,
        field,
        cpu,
        cached,
    };
    say(&format!(
        "{stem} {w}: reference {} ({:.0} spp, {:.1} s compute{}), mean squared standard error {:.4e}",
        if r.cached { "cached" } else { "computed" },
        r.spp,
        r.compute,
        r.cpu.map_or(String::new(), |c| format!(", {c:.1} CPU s")),
        r.mean_var
    ));
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binaries_with_and_without_labels() {
        let b = parse_binary("lean=/work/bin/ftpd3d-lean");
        assert_eq!(
            (b.label.as_str(), b.path.as_path()),
            ("lean", Path::new("/work/bin/ftpd3d-lean"))
        );
        let b = parse_binary("/work/bin/ftpd3d-8ae9f4f");
        assert_eq!(b.label, "ftpd3d-8ae9f4f");
        // A '=' inside a path is part of the path.
        let b = parse_binary("/tmp/a=b/ftpd3d");
        assert_eq!(
            (b.label.as_str(), b.path.as_path()),
            ("ftpd3d", Path::new("/tmp/a=b/ftpd3d"))
        );
        assert_eq!(slice_tag("z=0"), "z0");
        assert_eq!(slice_tag("x=-0.5"), "x-0.5");
    }
}
