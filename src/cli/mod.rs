//! What the command line needs besides clap: value parsers, report formatting, error messages
//! that name the flags, the benchmark and `--explain`. Below [`crate::app`] (which prints its reports through [`report`]); imports nothing
//! of it.

pub mod analysis_errors;
pub mod bench;
pub mod converge;
pub mod errors;
pub mod explain;
pub mod flags;
pub mod merge;
pub mod parse;
pub mod report;
pub mod separatrices;
