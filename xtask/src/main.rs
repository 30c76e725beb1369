//! Developer tooling of ftpd3d, kept out of the user binary: comparisons of one build of the tool
//! with another, each run as its own processes on the same plain command lines.
//!
//! ```text
//! cargo xtask efficiency --baseline OLD/ftpd3d --scene scenes/cornell_mirror.obj [flags]
//! cargo xtask converge --baseline OLD/ftpd3d --scene scenes/cornell_mirror.obj --slice z=0 \
//!     --out-dir out/conv [the flags of ftpd3d converge]
//! cargo xtask equal-time --baseline OLD/ftpd3d [--candidate LABEL=BIN ...] [flags]
//! cargo xtask error-time --binary OLD=OLD/ftpd3d --binary NEW=NEW/ftpd3d [--seconds 2.5,5,10]
//! cargo xtask first-command [--tree DIR]
//! ```
//!
//! The candidate is this tree's `ftpd3d`, built in release first, unless `--candidate BIN` names
//! another. `scripts/efficiency.sh` builds a baseline from git and runs the first.

mod binary;
mod converge;
mod cost;
mod efficiency;
mod equal_time;
mod error_time;
mod first_command;

use anyhow::{Context, bail};
use clap::{Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Comparisons of ftpd3d builds (developer tooling).
#[derive(Parser, Debug)]
#[command(name = "xtask", bin_name = "cargo xtask")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per process: the size difference between variants does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand, Debug)]
enum Command {
    /// Time to the same error as a baseline build, per scene and weighting (a Markdown table).
    ///
    /// Example: cargo xtask efficiency --baseline /path/to/old/ftpd3d --scene scenes/cornell_mirror.obj
    Efficiency(efficiency::EfficiencyArgs),
    /// The convergence report of `ftpd3d converge` with a baseline build's curves beside this
    /// tree's, both run as their own processes.
    ///
    /// Example: cargo xtask converge --baseline /path/to/old/ftpd3d --scene scenes/cornell_mirror.obj
    /// --slice z=0 --out-dir out/conv
    Converge(converge::ConvergeBaselineArgs),
    /// Squared error of σ at the same time budget, a baseline build against candidates, rounds
    /// interleaved, against a cached independent reference: efficiency ratios by compute and by
    /// CPU seconds.
    ///
    /// Example: cargo xtask equal-time --baseline /path/to/old/ftpd3d --scene
    /// scenes/cornell_mirror.obj --weight radiance
    EqualTime(equal_time::EqualTimeArgs),
    /// Error against time: RMSE² of σ of several builds at a ladder of time budgets, rounds
    /// interleaved, against equal-time's cached reference; a table, a CSV and log-log plots.
    ///
    /// Example: cargo xtask error-time --binary old=/path/to/old/ftpd3d --binary
    /// new=target/release/ftpd3d --plot docs/img/error_time_cornell.png
    ErrorTime(error_time::ErrorTimeArgs),
    /// Runs the README's first command as written, timed, and measures its σ against a cached
    /// reference: the 95th percentile of the relative error, reported and actual.
    ///
    /// Example: cargo xtask first-command
    #[command(name = "first-command")]
    First(first_command::FirstCommandArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Efficiency(args) => efficiency::run(args),
        Command::Converge(args) => converge::run(args),
        Command::EqualTime(args) => equal_time::run(args),
        Command::ErrorTime(args) => error_time::run(args),
        Command::First(args) => first_command::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", ftpd3d::cli::errors::message(&e));
            ExitCode::FAILURE
        }
    }
}

/// `path`, refused with `flag` named when it is not a file.
fn existing(flag: &str, path: &Path) -> anyhow::Result<PathBuf> {
    if !path.is_file() {
        bail!("{flag} {}: no such file", path.display());
    }
    Ok(path.to_path_buf())
}

/// The workspace root (where this xtask was built from).
fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The target directory this program runs from (`cargo xtask` runs it from `<target>/release/`).
fn target_dir() -> anyhow::Result<PathBuf> {
    let exe = std::env::current_exe().context("cannot find this program's path")?;
    exe.parent()
        .and_then(Path::parent)
        .map(Path::to_path_buf)
        .context("this program does not run from a target directory")
}

/// The candidate binary: `given`, or else this tree's `ftpd3d`, built in release into the target
/// directory this program runs from (`cargo xtask` runs it from `<target>/release/`).
fn candidate(given: Option<&Path>) -> anyhow::Result<PathBuf> {
    if let Some(c) = given {
        return existing("--candidate", c);
    }
    let manifest = workspace_root().join("Cargo.toml");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = std::process::Command::new(&cargo)
        .args([
            "build",
            "--release",
            "--quiet",
            "-p",
            "ftpd3d",
            "--bin",
            "ftpd3d",
        ])
        .arg("--manifest-path")
        .arg(&manifest)
        .status()
        .with_context(|| format!("{}: cannot start it", cargo.to_string_lossy()))?;
    if !status.success() {
        bail!("building this tree's ftpd3d failed ({status}); or give --candidate BIN");
    }
    let bin = target_dir()?.join("release").join("ftpd3d");
    if !bin.is_file() {
        bail!(
            "{}: no ftpd3d after the build (another target directory?); give --candidate BIN",
            bin.display()
        );
    }
    Ok(bin)
}
