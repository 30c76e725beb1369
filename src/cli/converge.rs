//! `ftpd3d converge`: error against time at doubling sample counts, as CSV and a log-log plot
//! ([`crate::analysis::converge`]).

use crate::analysis::converge::{self, ConvergeJob};
use crate::cli::args::{EstimatorFlags, WeightArg};
use crate::cli::parse::{parse_cells, parse_threads, parse_u64, parse_window};
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
    #[arg(long, allow_negative_numbers = true, value_parser = parse_cells)]
    pub res: Option<usize>,
    /// Samples per cell of the first run; each further run doubles them.
    #[arg(long, default_value_t = 4, allow_negative_numbers = true)]
    pub start_spp: u32,
    /// Largest samples per cell.
    #[arg(long, default_value_t = 256, allow_negative_numbers = true)]
    pub max_spp: u32,
    /// Weighting of a single curve [default: the reference's; else radiance and unweighted when
    /// the scene has lights, unweighted otherwise].
    #[arg(long = "weight", value_enum)]
    pub weight: Option<WeightArg>,
    /// Passes each run is split into (at most the run's spp).
    #[arg(long, default_value_t = RenderOptions::default().batches, allow_negative_numbers = true)]
    pub batches: u32,
    #[command(flatten)]
    pub estimator: EstimatorFlags,
    /// Seed of the first run; run k uses seed + k (every run independent).
    #[arg(long, default_value_t = RenderOptions::default().seed, allow_negative_numbers = true,
          value_parser = parse_u64)]
    pub seed: u64,
    /// Worker threads, at most 64 per core; 0: one per core [default: 0].
    #[arg(long, default_value_t = RenderOptions::default().threads, allow_negative_numbers = true,
          value_parser = parse_threads)]
    pub threads: usize,
    /// No per-run lines or summary.
    #[arg(short, long)]
    pub quiet: bool,
    /// Let the scene file read files outside its own folder (as the main command's flag).
    #[arg(long)]
    pub allow_outside_uris: bool,
}

impl ConvergeArgs {
    /// The library's job for these arguments.
    pub fn job(&self) -> ConvergeJob {
        let weighting = self.weight.map(Weighting::from);
        ConvergeJob {
            scene: self.scene.clone(),
            lights: self.estimator.lights(),
            slice: self.slice.clone(),
            window: self.window,
            res: self.res,
            reference: self.reference.clone(),
            out_dir: self.out_dir.clone(),
            weighting,
            estimator: self
                .estimator
                .args(weighting.unwrap_or(Weighting::Unweighted)),
            start_spp: self.start_spp,
            max_spp: self.max_spp,
            batches: self.batches,
            seed: self.seed,
            threads: self.threads,
            load: crate::scene::LoadOptions {
                allow_outside_uris: self.allow_outside_uris,
                light_scale: self.estimator.light_scale.clone(),
                ..Default::default()
            },
            quiet: self.quiet,
        }
    }
}

/// Runs the report, then (unless quiet) prints it ([`print_report`]).
pub fn run(args: &ConvergeArgs) -> anyhow::Result<()> {
    let conv = converge::run_converge(&args.job())?;
    print_report(args, &conv);
    Ok(())
}

/// Unless quiet: each curve's fit and the files written.
pub fn print_report(args: &ConvergeArgs, conv: &converge::Report) {
    if !args.quiet {
        for c in &conv.curves {
            println!("{}", report::converge_line(c));
        }
        println!(
            "wrote {}/converge.csv, converge_fit.csv, converge.png",
            args.out_dir.display()
        );
    }
}
