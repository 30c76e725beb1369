//! The command line as a library: its arguments ([`args`], clap), their validation into a job
//! ([`job`], which runs it through [`crate::app`]), value parsers ([`parse`]), the benchmark
//! ([`bench`](mod@bench)), `--explain` ([`explain`]), report lines ([`report`]), signals
//! ([`signals`]), the live view's flags and state ([`view`]) and the error messages that name the flags ([`errors`]). Flag names appear only
//! here, in `src/main.rs` and in [`crate::app`]. Only the live view (`crate::view`) imports it.

pub mod analysis_errors;
pub mod args;
pub mod bench;
pub mod converge;
pub mod errors;
pub mod explain;
pub mod job;
pub mod merge;
pub mod parse;
pub mod report;
pub mod sep_flags;
pub mod separatrices;
pub mod signals;
pub mod view;
