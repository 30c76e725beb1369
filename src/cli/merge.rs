//! `ftpd3d merge`: adds fields or volumes of the same run computed with other seeds or over other
//! tiles ([`crate::merge`]).

use crate::cli::report;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// EXR fields or VTI volumes written by ftpd3d (or by an earlier merge), all of one kind,
    /// added in the order given.
    #[arg(required = true, value_name = "FILE.exr|FILE.vti")]
    pub inputs: Vec<PathBuf>,
    /// Output, .exr or .vti as the inputs (PNG previews are written next to it).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Skip the PNG previews.
    #[arg(long)]
    pub no_png: bool,
    /// No summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    pub quiet: bool,
}

/// Merges, prints the warnings and (unless quiet) the summary.
pub fn run(args: &MergeArgs) -> anyhow::Result<()> {
    let merged = crate::merge::merge_files(&args.inputs, &args.output, !args.no_png)?;
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
