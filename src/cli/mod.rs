//! What the command line needs besides clap: value parsers, report formatting, the benchmark and
//! `--explain`. Below [`crate::app`] (which prints its reports through [`report`]); imports nothing
//! of it.

pub mod bench;
pub mod explain;
pub mod parse;
pub mod report;
