//! The command line, thin: clap parses the arguments ([`ftpd3d::cli::args`]), the subcommand or
//! the main run turns them into a job and runs it, and errors print in the command line's words
//! ([`ftpd3d::cli::errors`]). The main run, `bench` and `--explain` live in [`ftpd3d::cli`]; the
//! analysis subcommands follow.

use clap::{Parser, Subcommand};
use ftpd3d::cli::args::{Cli, RunArgs};
use ftpd3d::cli::converge::ConvergeArgs;
use ftpd3d::cli::merge::MergeArgs;
use ftpd3d::cli::separatrices::SeparatricesArgs;
use ftpd3d::cli::{self, bench, errors, explain};
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
    /// A live view in a web page on 127.0.0.1: the field of a slice refined pass by pass, the
    /// slice and the run flags changed from the page, what it shows saved as the command line
    /// would write it. Takes every run flag; prints the page's URL (with its token) first.
    ///
    /// Example: ftpd3d view --scene scenes/cornell_mirror.obj --slice z=0 --res 64
    #[cfg(feature = "view")]
    View(ftpd3d::cli::view::ViewArgs),
}

fn main() -> ExitCode {
    let cli = Cli::<Command>::parse();
    let result = match &cli.command {
        Some(Command::Bench(args)) => bench::command(args).map(|()| None),
        Some(Command::Merge(args)) => cli::merge::run(args).map(|()| None),
        Some(Command::Converge(args)) => cli::converge::run(args).map(|()| None),
        Some(Command::Separatrices(args)) => cli::separatrices::run(args).map(|()| None),
        #[cfg(feature = "view")]
        Some(Command::View(args)) => {
            let raw: Vec<String> = std::env::args()
                .skip_while(|a| a != "view")
                .skip(1)
                .collect();
            ftpd3d::view::serve(args, &raw).map(|()| None)
        }
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
