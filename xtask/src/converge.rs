//! `cargo xtask converge --baseline BIN`: the convergence report of `ftpd3d converge` with the
//! curves of an older build beside this tree's, both run as their own processes.
//!
//! Both binaries run every level as separate processes on the same scene, slice, grid and
//! estimator flags, against one reference; the CSVs gain a row per baseline level and fit
//! (`binary` = `baseline`), the plot a darker curve per weighting with its own slope, and every
//! run's EXR stays in `runs/` of the output directory.

use crate::binary::{SliceRun, run_slice, seconds};
use anyhow::{Context, bail};
use clap::Args;
use ftpd3d::analysis::converge::{ConvergeJob, Curve, Level, Setup, compare, write_report};
use ftpd3d::cli::converge::{ConvergeArgs, print_report};
use ftpd3d::field::Field;
use ftpd3d::ftpd::Weighting;
use std::path::{Path, PathBuf};

#[derive(Args, Debug, Clone)]
pub struct ConvergeBaselineArgs {
    /// An older build of ftpd3d: run it and the candidate, each as its own processes, at the same
    /// levels and draw both curves on one plot [reference: --reference, else the baseline's
    /// highest-spp run].
    #[arg(long, value_name = "BIN", required = true)]
    baseline: PathBuf,
    /// The candidate binary [default: this tree's ftpd3d, built in release].
    #[arg(long, value_name = "BIN")]
    candidate: Option<PathBuf>,
    #[command(flatten)]
    converge: ConvergeArgs,
}

/// The two builds of a comparison.
struct Builds<'a> {
    baseline: &'a Path,
    candidate: &'a Path,
}

/// Runs both builds' levels, writes the report as `ftpd3d converge` does and prints it.
pub fn run(args: &ConvergeBaselineArgs) -> anyhow::Result<()> {
    let baseline = crate::existing("--baseline", &args.baseline)?;
    let job = args.converge.job();
    let setup = Setup::prepare(&job)?;
    let candidate = crate::candidate(args.candidate.as_deref())?;
    let quiet = job.quiet;
    let say = |s: &str| {
        if !quiet {
            eprintln!("{s}");
        }
    };
    say(&setup.summary(&job, "reference: the baseline's highest spp run"));
    let builds = Builds {
        baseline: &baseline,
        candidate: &candidate,
    };
    let (curves, tops) = measure_builds(&job, &builds, &setup, &estimator_flags_as_given(), say)?;
    let report = setup.report(&job, curves, Some(baseline.clone()));
    write_report(&job, &report, &tops)?;
    print_report(&args.converge, &report);
    Ok(())
}

/// The levels of the baseline and of the candidate, each run as a separate process with the same
/// plain command line ([`crate::binary`], `forward`: the estimator flags as given), interleaved
/// level by level (baseline, then candidate) so that a change of the machine's load hits both
/// alike. Times are the compute seconds each process stores in its output.
///
/// Seeds: the baseline's level k uses `seed + k`, the candidate's `seed + n + k` for n levels, so
/// that no run of one binary shares a seed (and so random streams) with a run of the other.
/// Reference: `--reference` when given; else the baseline's highest-spp run, which is the
/// self-reference of the baseline curve (its own row is left out) and the reference of every
/// level of the candidate, so that a bias of the newer estimator cannot hide in its reference.
/// Returns the curves (per weighting: baseline, then candidate) and the candidate's top field
/// per weighting.
fn measure_builds(
    job: &ConvergeJob,
    builds: &Builds,
    setup: &Setup,
    forward: &[String],
    mut say: impl FnMut(&str),
) -> anyhow::Result<(Vec<Curve>, Vec<Field>)> {
    let runs_dir = job.out_dir.join("runs");
    std::fs::create_dir_all(&runs_dir)
        .with_context(|| format!("{}: cannot create it", runs_dir.display()))?;
    let res = setup.plane.width.max(setup.plane.height);
    let mut curves = Vec::new();
    let mut tops = Vec::new();
    for &w in &setup.weightings {
        let run = |spp: u32, seed: u64| SliceRun {
            scene: &job.scene,
            slice: &job.slice,
            res,
            window: job.window,
            weighting: w,
            spp,
            batches: job.batches.clamp(1, spp),
            seed,
            threads: job.threads,
            extra: forward,
        };
        // Untimed warm-up of each binary (file cache, first process start).
        for (tag, bin) in [("baseline", builds.baseline), ("this", builds.candidate)] {
            let out = runs_dir.join(format!("warmup_{tag}_{w}.exr"));
            run_slice(bin, &run(setup.levels[0], job.seed.wrapping_sub(1)), &out)?;
            let _ = std::fs::remove_file(&out);
        }
        let fields = run_levels(job, builds, setup, w, &run, &mut say)?;
        let [base, mut this] = measured(w, fields, setup.reference())?;
        curves.push(base.0);
        curves.push(this.0);
        tops.push(this.1.pop().expect("at least one level"));
    }
    Ok((curves, tops))
}

/// One level's run: spp, seed, compute seconds and the field.
type LevelRun = (u32, u64, f64, Field);

/// Every level of both builds for weighting `w`: [baseline, candidate].
fn run_levels<'a>(
    job: &ConvergeJob,
    builds: &Builds,
    setup: &Setup,
    w: Weighting,
    run: &impl Fn(u32, u64) -> SliceRun<'a>,
    say: &mut impl FnMut(&str),
) -> anyhow::Result<[Vec<LevelRun>; 2]> {
    let runs_dir = job.out_dir.join("runs");
    let n = setup.levels.len() as u64;
    let reference = setup.reference();
    let mut fields: [Vec<LevelRun>; 2] = [Vec::new(), Vec::new()];
    for (k, &spp) in setup.levels.iter().enumerate() {
        for (b, (tag, bin, seed)) in [
            ("baseline", builds.baseline, job.seed.wrapping_add(k as u64)),
            (
                "this",
                builds.candidate,
                job.seed.wrapping_add(n + k as u64),
            ),
        ]
        .into_iter()
        .enumerate()
        {
            let out = runs_dir.join(format!("{tag}_{w}_spp{spp}.exr"));
            let field = run_slice(bin, &run(spp, seed), &out)?;
            let name = out.display().to_string();
            match (b, reference, fields[0].first()) {
                (1, Some((rn, r)), _) => ftpd3d::merge::check_same_run(rn, r, &name, &field)?,
                (_, _, Some(f)) if (f.3.width, f.3.height) != (field.width, field.height) => {
                    bail!(
                        "{name}: {}x{} cells, the baseline wrote {}x{}",
                        field.width,
                        field.height,
                        f.3.width,
                        f.3.height
                    )
                }
                _ => {}
            }
            let secs = seconds(&field, &out)?;
            say(&format!(
                "{:<10} {tag:<8} {spp:>6} spp  seed {seed:<4} {secs:>8.3} s",
                w.to_string()
            ));
            fields[b].push((spp, seed, secs, field));
        }
    }
    Ok(fields)
}

/// The curves of both builds (see [`measure_builds`] for the reference), each with its fields.
fn measured(
    w: Weighting,
    fields: [Vec<LevelRun>; 2],
    reference: Option<(&str, &Field)>,
) -> anyhow::Result<[(Curve, Vec<Field>); 2]> {
    let top = fields[0].len() - 1;
    let mut levels: [Vec<Level>; 2] = [Vec::new(), Vec::new()];
    for (b, lv) in fields.iter().enumerate() {
        let base_top = &fields[0][top].3;
        for (k, (spp, seed, secs, field)) in lv.iter().enumerate() {
            let cmp = match reference {
                Some((_, r)) => Some(compare(field, r)),
                None if b == 0 && k == top => None,
                None => Some(compare(field, base_top)),
            };
            // Runs do not store their ray count.
            let samples = field.info("converge run")?.samples.unwrap_or(0);
            let run = (*secs, 0, samples);
            levels[b].push(Level::new(w, (*spp, *seed), run, field, cmp));
        }
    }
    let [base_levels, this_levels] = levels;
    let [base_fields, this_fields] = fields.map(|lv| lv.into_iter().map(|l| l.3).collect());
    Ok([
        (Curve::new(w, base_levels, true), base_fields),
        (Curve::new(w, this_levels, false), this_fields),
    ])
}

/// The estimator and light flags of this process's command line (`EstimatorFlags` of
/// `ftpd3d::cli::args`) with their values, as given: what both binaries are passed.
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
