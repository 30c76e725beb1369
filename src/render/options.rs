//! What a run is asked and what it reports: how many samples on how many threads
//! ([`RenderOptions`]), when to stop ([`Budget`], [`StopReason`]), whether later passes go where
//! the error is ([`Adaptive`]), and what a run did ([`RunStats`]).

use crate::domain::Tile;
use std::fmt;
use std::time::Duration;

/// When to stop, besides the sample cap `RenderOptions::spp` (whichever comes first).
#[derive(Clone, Debug, PartialEq)]
pub struct Budget {
    /// Stop at `RenderOptions::spp` samples per cell (for adaptive runs: `spp × cells` samples in
    /// all). False when only a time or error budget was given: no sample cap.
    pub cap_spp: bool,
    /// Compute time of the whole run (resumed runs count the time of earlier invocations). A pass
    /// starts only if the time used plus the duration of the previous pass stays within it, so a
    /// run ends before the budget, not after (the first pass always runs).
    pub time: Option<Duration>,
    /// Stop when the 95th percentile of the relative standard error is at most this (see
    /// [`ErrorStats`](super::ErrorStats)); checked after every pass from the second on.
    pub target_error: Option<f64>,
    /// Stop after this many passes in all (library use: tests, simulated interruptions).
    pub max_passes: Option<u32>,
}

impl Default for Budget {
    fn default() -> Self {
        Budget {
            cap_spp: true,
            time: None,
            target_error: None,
            max_passes: None,
        }
    }
}

/// Adaptive sampling settings (see [`allocate`](super::allocate)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    /// A cell gets at most this many times the uniform share of a pass.
    pub max_share: u32,
}

impl Default for Adaptive {
    fn default() -> Self {
        Adaptive { max_share: 4 }
    }
}

/// How many samples, in how many passes, on how many threads, until when.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Samples per cell (the cap; see [`Budget::cap_spp`]).
    pub spp: u32,
    /// Independent batches (passes) the cap is split into when no `pass_spp` is given; at most
    /// `spp`.
    pub batches: u32,
    pub seed: u64,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    /// Show a progress bar on stderr (only when stderr is a terminal).
    pub progress: bool,
    pub budget: Budget,
    /// Samples per cell and pass [default: spp / batches, or 8 without a sample cap].
    pub pass_spp: Option<u32>,
    /// Put the samples of later passes where the error is largest.
    pub adaptive: Option<Adaptive>,
    /// Sample only this stripe of the grid ([`Tile::cells`]); the other cells stay empty and are
    /// never visited, so tiles merge by addition into the full run.
    pub tile: Option<Tile>,
    /// A gradient-domain run with this α: a fresh field keeps its replayed neighbours' sums
    /// ([`crate::gradient_domain`]).
    pub gradient_domain: Option<f64>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            spp: 64,
            batches: 8,
            seed: 1,
            threads: 0,
            progress: false,
            budget: Budget::default(),
            pass_spp: None,
            adaptive: None,
            tile: None,
            gradient_domain: None,
        }
    }
}

impl RenderOptions {
    /// The cells of a `width` × `height` × `depth` grid that a run samples: the stripe `tile`, or
    /// every cell.
    pub fn active_cells(
        &self,
        width: usize,
        height: usize,
        depth: usize,
    ) -> std::ops::Range<usize> {
        match self.tile {
            Some(t) => t.cells(width, height, depth),
            None => 0..width * height * depth,
        }
    }

    /// The worker threads a run uses: `threads`, or every core for 0.
    pub fn thread_count(&self) -> usize {
        if self.threads == 0 {
            std::thread::available_parallelism().map_or(1, |n| n.get())
        } else {
            self.threads
        }
    }
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StopReason {
    /// The sample cap ([`RenderOptions::spp`] per cell) is reached.
    #[default]
    Samples,
    /// The next pass would not fit in the time budget.
    Time,
    /// The 95th-percentile relative error is at most the target.
    TargetError,
    /// A stop was requested (SIGINT/SIGTERM).
    Interrupted,
    /// The pass limit of [`Budget::max_passes`].
    PassLimit,
}

impl StopReason {
    /// Whether the run did what it was asked (a budget was reached), as opposed to being cut short.
    pub fn is_complete(self) -> bool {
        !matches!(self, StopReason::Interrupted | StopReason::PassLimit)
    }
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopReason::Samples => "sample budget reached",
            StopReason::Time => "time budget reached",
            StopReason::TargetError => "target error reached",
            StopReason::Interrupted => "interrupted",
            StopReason::PassLimit => "pass limit reached",
        })
    }
}

/// What a run did, for the summary and the benchmarks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunStats {
    /// Samples taken in this invocation (a resumed run does not count the file's).
    pub samples: u64,
    pub rays: u64,
    /// Walks that reached the bounce cap before their longest run length.
    pub capped: u64,
    /// Samples whose contribution was not finite and was dropped.
    pub clamped: u64,
    pub seconds: f64,
    /// Passes completed by every cell, in all (including those of a resumed file).
    pub passes: u32,
    pub stop: StopReason,
}

impl RunStats {
    pub fn rays_per_second(&self) -> f64 {
        if self.seconds > 0.0 {
            self.rays as f64 / self.seconds
        } else {
            0.0
        }
    }
    pub fn samples_per_second(&self) -> f64 {
        if self.seconds > 0.0 {
            self.samples as f64 / self.seconds
        } else {
            0.0
        }
    }
}
