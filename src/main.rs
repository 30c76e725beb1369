//! The command line, thin: clap parses the arguments ([`ftpd3d::cli::args`]), the subcommand or
//! the main run turns them into a job and runs it, and errors print in the command line's words
//! ([`ftpd3d::cli::errors`]). The main run, `bench` and `--explain` live in [`ftpd3d::cli`]; the
//! analysis subcommands follow.

use clap::{Args, Parser, Subcommand};
use ftpd3d::analysis::converge::{self, ConvergeJob};
use ftpd3d::cli::args::{Cli, EstimatorFlags, RunArgs, WeightArg};
use ftpd3d::cli::parse::parse_window;
use ftpd3d::cli::sep_flags::SepFlags;
use ftpd3d::cli::{bench, errors, explain, report};
use ftpd3d::ftpd::Weighting;
use ftpd3d::render::RenderOptions;
use std::path::PathBuf;
use std::process::ExitCode;

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

fn main() -> ExitCode {
    let cli = Cli::<Command>::parse();
    let run = match &cli.command {
        Some(Command::Bench(args)) => args,
        _ => &cli.run,
    };
    ftpd3d::scene::load::set_strict(run.strict);
    let result = match &cli.command {
        Some(Command::Bench(args)) => bench::command(args).map(|()| None),
        Some(Command::Merge(args)) => merge(args).map(|()| None),
        Some(Command::Converge(args)) => converge(args).map(|()| None),
        Some(Command::Separatrices(args)) => separatrices(args).map(|()| None),
        Some(Command::Efficiency(args)) => efficiency(args).map(|()| None),
        None if cli.run.explain => explain::command(&cli.run).map(|()| None),
        None => ftpd3d::cli::job::run(&cli.run),
    };
    errors::exit_code(result)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn command_line_definition_is_consistent() {
        Cli::<Command>::command().debug_assert();
    }
}
