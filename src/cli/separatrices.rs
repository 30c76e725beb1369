//! `ftpd3d separatrices`: separatrices of a finished or merged field, without recomputing it
//! ([`crate::analysis::separatrix::rerun`]).

use crate::cli::sep_flags::SepFlags;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct SeparatricesArgs {
    /// A field (.exr) or volume (.vti) written by ftpd3d or by merge.
    #[arg(value_name = "FIELD.exr|FIELD.vti")]
    pub input: PathBuf,
    /// Output, .exr or .vti as the input [default: <input name>_sep.<ext> beside it].
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub sep: SepFlags,
    /// Skip the PNG previews of the field (the separatrix overlay is still written).
    #[arg(long)]
    pub no_png: bool,
    /// No summary (errors and warnings still go to stderr).
    #[arg(short, long)]
    pub quiet: bool,
}

/// Extracts and writes, then (unless quiet) prints the summary and the files written.
pub fn run(args: &SeparatricesArgs) -> anyhow::Result<()> {
    let params = args.sep.params()?;
    let out = crate::analysis::separatrix::rerun(
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
