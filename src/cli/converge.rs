//! `ftpd3d converge`: error against time at doubling sample counts, as CSV and a log-log plot
//! ([`crate::analysis::converge`]).

use crate::analysis::converge::{self, ConvergeJob};
use crate::cli::flags::{EstimatorFlags, WeightArg};
use crate::cli::parse::parse_window;
use crate::cli::report;
use crate::ftpd::Weighting;
use crate::render::RenderOptions;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct ConvergeArgs {
    /// Scene file: .obj (with its .mtl), .gltf or .glb, or a sidecar .toml naming one.
    #[arg(long, value_name = "FILE", required = true)]
    pub scene: PathBuf,
    /// Axis-aligned slice plane, e.g. z=0, or a slice named in the scene file.
    #[arg(long, value_name = "AXIS=VALUE|NAME", required = true)]
    pub slice: String,
    /// Directory for converge.csv, converge_fit.csv, converge.png and the top runs' EXRs.
    #[arg(long, value_name = "DIR", required = true)]
    pub out_dir: PathBuf,
    /// Reference field (EXR of the same slice and parameters, many samples); without it, each
    /// weighting's highest-spp run is the reference.
    #[arg(long, value_name = "REF.exr")]
    pub reference: Option<PathBuf>,
    /// Part of the plane to cover, u0,v0,u1,v1.
    #[arg(long, value_name = "U0,V0,U1,V1", allow_hyphen_values = true, value_parser = parse_window)]
    pub window: Option<[f64; 4]>,
    /// Cells along the longer side [default: the reference's, else 64].
    #[arg(long)]
    pub res: Option<usize>,
    /// Samples per cell of the first run; each further run doubles them.
    #[arg(long, default_value_t = 4)]
    pub start_spp: u32,
    /// Largest samples per cell.
    #[arg(long, default_value_t = 256)]
    pub max_spp: u32,
    /// Weighting of a single curve [default: the reference's; else radiance and unweighted when
    /// the scene has lights, unweighted otherwise].
    #[arg(long = "weight", value_enum)]
    pub weight: Option<WeightArg>,
    /// Passes each run is split into (at most the run's spp).
    #[arg(long, default_value_t = RenderOptions::default().batches)]
    pub batches: u32,
    #[command(flatten)]
    pub estimator: EstimatorFlags,
    /// Seed of the first run; run k uses seed + k (every run independent).
    #[arg(long, default_value_t = RenderOptions::default().seed)]
    pub seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, default_value_t = RenderOptions::default().threads)]
    pub threads: usize,
    /// An older build of ftpd3d: run it and this binary, each as its own processes, at the same
    /// levels and draw both curves on one plot [reference: --reference, else the baseline's
    /// highest-spp run].
    #[arg(long, value_name = "BIN")]
    pub baseline: Option<PathBuf>,
    /// No per-run lines or summary.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs the report, then (unless quiet) prints each curve's fit and the files written.
pub fn run(args: &ConvergeArgs) -> anyhow::Result<()> {
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
