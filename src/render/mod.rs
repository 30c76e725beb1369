//! The driver: runs the per-cell kernel over a grid of cells in progressive passes, in parallel
//! (rayon), with deterministic streams keyed by (seed, pass, cell), so the result is bit-identical
//! for any thread count. Each pass is one independent batch for the standard error.
//!
//! # Passes and budgets
//!
//! A run is a sequence of passes. Pass `p` adds samples to cells from the stream
//! `Sampler::new(seed, p, cell)` and folds them into the cell's sums as complete batches
//! ([`Moments::add_batch`](crate::ftpd::moments::Moments::add_batch)), so after any pass the field
//! is consistent and can be finalised, written and resumed. How many samples a pass gives each
//! cell is the [`Schedule`]; when to stop is the [`Budget`]: a sample cap (`spp` per cell), a time
//! budget, a target error, or a pass limit, whichever is reached first, checked at pass
//! boundaries. An interruption ([`Hooks::stop`], set by the signal handler) is checked between
//! chunks of cells: the chunks in flight finish, the rest of the pass is skipped, and
//! [`Progress::inflight`] records which cells completed that pass, so that a resumed run can
//! finish exactly those that did not.
//!
//! # Reproducibility
//!
//! The sums of a cell are added in pass order, each pass's batches in a fixed order, and pass `p`
//! always draws from the stream keyed (seed, p, cell). The pass sizes and the adaptive allocation
//! depend only on the schedule and on the sums of completed passes. A run resumed from a partial
//! field (same seed, schedule and parameters) therefore performs the same additions in the same
//! order as an uninterrupted one, and ends with bit-identical sums.
//!
//! # Adaptive sampling
//!
//! See [`allocate`]: from pass 2 on, each pass distributes its sample budget (the uniform share
//! times the number of cells) over the cells by their estimated error.
//!
//! # The rooms
//!
//! What a run is asked and reports (`options`), how samples are cut into passes and where a run
//! stands (`schedule`), the relative error over a field (`error_stats`), adaptive allocation
//! (`allocate`), one pass over the cells in chunks (`pass`), the progressive loop (`progressive`);
//! built on them, runs of a domain with the kernel their parameters need (`runs`), their
//! description (`describe`) and a short calibration of how long a run will take (`eta`).

mod allocate;
mod describe;
mod error_stats;
mod eta;
mod options;
mod pass;
mod progressive;
mod runs;
mod schedule;

pub use allocate::allocate;
pub use describe::{camera_info, describe_run, plane_info, volume_info};
pub use error_stats::{ErrorStats, error_stats, field_error_stats};
pub use eta::{CALIBRATION_SECONDS, Eta, estimate_time};
pub use options::{Adaptive, Budget, RenderOptions, RunStats, StopReason};
pub use pass::CHUNK;
pub use progressive::{AfterPass, Hooks, INTERRUPT, LISTENING, run_in, run_progressive};
pub use runs::{check_flatland, run_camera, run_domain, run_domain_progressive, run_plane};
pub use schedule::{DEFAULT_PASS_SPP, InFlight, Progress, Schedule, samples_in_pass};

/// A run that cannot start or was aborted, as a typed value.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The field to add to has another grid than the domain.
    #[error(
        "the field is {}x{}x{} cells, the domain {}x{}x{}",
        field.0, field.1, field.2, domain.0, domain.1, domain.2
    )]
    FieldSize {
        field: (usize, usize, usize),
        domain: (usize, usize, usize),
    },
    #[error(
        "flatland run on {plane}: the scene was not prepared for this plane \
         (Scene::prepare_flatland)"
    )]
    FlatlandNotPrepared { plane: String },
    #[error("flatland run: the domain {plane} does not lie in the flatland plane")]
    FlatlandOffPlane { plane: String },
    /// The worker threads could not be started.
    #[error(transparent)]
    Threads(#[from] rayon::ThreadPoolBuildError),
    /// The caller's [`Hooks::after_pass`] failed (a checkpoint that could not be written).
    #[error(transparent)]
    AfterPass(#[from] anyhow::Error),
}
