//! How long a run will take, from a short calibration of the same kernel on the same threads.

use super::{Budget, RenderOptions, RunError, run_domain};
use crate::domain::{Domain, Subset};
use crate::ftpd::Params;
use crate::rng::Sampler;
use crate::scene::Scene;
use std::time::Instant;

/// How long a run should take, from a short calibration on a few random cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Eta {
    /// Estimated seconds for the whole run.
    pub seconds: f64,
    /// Samples per second measured.
    pub rate: f64,
    /// Cells and samples per cell of the last calibration round.
    pub cells: usize,
    pub spp: u32,
    /// Time spent calibrating, all rounds.
    pub calibration_seconds: f64,
}

/// Seconds the calibration aims at: its last round runs at least this long (or the whole spp).
pub const CALIBRATION_SECONDS: f64 = 0.25;

/// Estimates the run time of `domain` at `opts.spp` by running the same kernel on the same threads
/// over random cells (128 per thread to start, so every thread has work), doubling the samples per
/// cell, then the cells, until a round takes [`CALIBRATION_SECONDS`] (or covers the whole run).
/// Its samples come from other streams and are thrown away; the run itself is unchanged.
pub fn estimate_time(
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
) -> Result<Eta, RunError> {
    let (w, h, d) = domain.dims();
    let total = w * h * d;
    let threads = opts.thread_count();
    let mut pick = Sampler::new(opts.seed, u64::MAX, u64::MAX);
    let mut subset = Subset {
        inner: domain,
        cells: Vec::new(),
    };
    let mut want = (128 * threads).min(total);
    let mut o = opts.clone();
    o.progress = false;
    o.batches = 1;
    o.seed = opts.seed ^ 0xCA11_B4A7_E000_0000;
    o.spp = 1;
    o.tile = None;
    o.budget = Budget::default();
    o.pass_spp = None;
    o.adaptive = None;
    let start = Instant::now();
    loop {
        while subset.cells.len() < want {
            let c = (pick.next_f64() * total as f64) as usize;
            subset.cells.push(c.min(total - 1));
        }
        let (_, stats) = run_domain(scene, &subset, params, &o)?;
        let whole = o.spp >= opts.spp && want >= total;
        if stats.seconds >= CALIBRATION_SECONDS || whole {
            let rate = stats.samples_per_second();
            let samples = total as f64 * opts.spp as f64;
            return Ok(Eta {
                seconds: if rate > 0.0 { samples / rate } else { 0.0 },
                rate,
                cells: subset.cells.len(),
                spp: o.spp,
                calibration_seconds: start.elapsed().as_secs_f64(),
            });
        }
        if o.spp < opts.spp {
            o.spp = o.spp.saturating_mul(2).min(opts.spp);
        } else {
            want = want.saturating_mul(2).min(total);
        }
    }
}
