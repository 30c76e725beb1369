//! How much a run samples, as a front end is given it (a sample cap, a time budget, a target error,
//! or none of them), turned into the driver's [`RenderOptions`] with the defaults that every front
//! end shares: the command line and any other caller of [`super::run_domain`] get the same passes
//! from the same request, so the same field.

use crate::domain::Tile;
use crate::render::{Adaptive, Budget, RenderOptions};
use std::time::Duration;

/// The budget of a run given no sample cap, time budget or target error: p95 relative error 0.05
/// or one minute, whichever comes first, so that a first run shows clean structure soon on a small
/// machine (what the README's first command reaches: `docs/performance.md#the-first-command`). A
/// time budget makes the number of passes depend on the machine: a sample cap gives a
/// reproducible run.
pub const DEFAULT_BUDGET: Budget = Budget {
    cap_spp: false,
    time: Some(Duration::from_secs(60)),
    target_error: Some(0.05),
    max_passes: None,
};

/// What a front end was told about sampling; `None` where nothing was said.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampling {
    /// Samples per cell (for adaptive runs, the mean over cells).
    pub spp: Option<u32>,
    /// Passes a sample cap is split into when no `pass_spp` is given.
    pub batches: u32,
    /// Samples per cell added by each pass.
    pub pass_spp: Option<u32>,
    pub time: Option<Duration>,
    pub target_error: Option<f64>,
    /// `Some(true)`: adaptive passes; `Some(false)`: uniform ones; `None`: the default
    /// ([`Sampling::is_adaptive`]).
    pub adaptive: Option<bool>,
    /// Adaptive runs: at most this many times the uniform share per cell and pass.
    pub adaptive_cap: Option<u32>,
    /// A gradient-domain run with this α ([`crate::gradient_domain`]).
    pub gradient_domain: Option<f64>,
    pub seed: u64,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    pub tile: Option<Tile>,
    /// Show the driver's progress bar on stderr (when it is a terminal).
    pub progress: bool,
}

impl Default for Sampling {
    /// Nothing said: the driver's defaults for batches, seed and threads, the [`DEFAULT_BUDGET`].
    fn default() -> Self {
        let d = RenderOptions::default();
        Sampling {
            spp: None,
            batches: d.batches,
            pass_spp: None,
            time: None,
            target_error: None,
            adaptive: None,
            adaptive_cap: None,
            gradient_domain: None,
            seed: d.seed,
            threads: d.threads,
            tile: None,
            progress: false,
        }
    }
}

impl Sampling {
    /// Whether passes after the second go where the error is largest: when asked, and by default
    /// for a run that stops at a target error (one given, or the default budget's), since that
    /// stop is a percentile of the relative error over cells and the allocation fills cells up to
    /// a common relative error. A run of a sample cap or a time budget alone stays uniform.
    pub fn is_adaptive(&self) -> bool {
        let target = self.target_error.is_some() || (self.spp.is_none() && self.time.is_none());
        self.adaptive.unwrap_or(target)
    }

    /// The driver's options: the budget given, or the [`DEFAULT_BUDGET`] when none is.
    pub fn render_options(&self) -> RenderOptions {
        let defaults = RenderOptions::default();
        let budget = if self.spp.is_none() && self.time.is_none() && self.target_error.is_none() {
            DEFAULT_BUDGET
        } else {
            Budget {
                cap_spp: self.spp.is_some(),
                time: self.time,
                target_error: self.target_error,
                max_passes: None,
            }
        };
        RenderOptions {
            spp: self.spp.unwrap_or(defaults.spp),
            batches: self.batches,
            seed: self.seed,
            threads: self.threads,
            progress: self.progress,
            budget,
            pass_spp: self.pass_spp,
            adaptive: self.is_adaptive().then_some(Adaptive {
                max_share: self.adaptive_cap.unwrap_or(Adaptive::default().max_share),
            }),
            tile: self.tile,
            gradient_domain: self.gradient_domain,
        }
    }
}
