//! The driver: runs the per-cell kernel over a grid of cells in progressive passes, in parallel
//! (rayon), with deterministic streams keyed by (seed, pass, cell), so the result is bit-identical
//! for any thread count. Each pass is one independent batch for the standard error.
//!
//! # Passes and budgets
//!
//! A run is a sequence of passes. Pass `p` adds samples to cells from the stream
//! `Sampler::new(seed, p, cell)` and folds them into the cell's sums as complete batches
//! ([`Moments::add_batch`]), so after any pass the field is consistent and can be finalised, written
//! and resumed. How many samples a pass gives each cell is the [`Schedule`]; when to stop is the
//! [`Budget`]: a sample cap (`spp` per cell), a time budget, a target error, or a pass limit
//! (library only), whichever is reached first, checked at pass boundaries. An interruption
//! ([`Hooks::stop`], set by the signal handler) is checked between chunks of cells: the chunks in
//! flight finish, the rest of the pass is skipped, and [`Progress::inflight`] records which cells
//! completed that pass, so that a resumed run can finish exactly those that did not.
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

use crate::domain::Tile;
use crate::field::Field;
use crate::ftpd::Sample;
use crate::ftpd::moments::{GroupSums, Moments};
use crate::rng::{QMC_GROUP, Sampler};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::fmt;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::time::{Duration, Instant};

/// Process-wide stop request, set by the command line's SIGINT/SIGTERM handler and passed to the
/// driver as [`Hooks::stop`] (library users may pass a flag of their own instead).
pub static INTERRUPT: AtomicBool = AtomicBool::new(false);

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
    /// [`ErrorStats`]); checked after every pass from the second on.
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

/// Adaptive sampling settings (see [`allocate`]).
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

/// Samples per cell and pass when neither a sample cap nor `pass_spp` says.
pub const DEFAULT_PASS_SPP: u32 = 8;

/// Why a run stopped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StopReason {
    /// The sample cap (`--spp`) is reached.
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
    /// Pairs with a walk that reached the bounce cap.
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

/// Cells per parallel work item: large enough to amortise scheduling, small enough to balance.
pub const CHUNK: usize = 64;

/// Samples per cell in pass `pass` of `batches` (spreads the remainder over the first passes).
pub fn samples_in_pass(spp: u32, batches: u32, pass: u32) -> u32 {
    spp / batches + u32::from(pass < spp % batches)
}

/// How many samples each cell gets in each pass (before adaptive allocation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// `spp` split into `batches` passes, the remainder over the first ones: the behaviour of a run
    /// given only `--spp` (and `--batches`).
    Split { spp: u32, batches: u32 },
    /// `per_pass` samples per cell and pass; with a cap, the last pass is cut to reach it exactly.
    Every { per_pass: u32, cap: Option<u32> },
}

impl Schedule {
    /// The schedule `opts` asks for.
    pub fn of(opts: &RenderOptions) -> Schedule {
        let spp = opts.spp.max(1);
        let batches = opts.batches.clamp(1, spp);
        let cap = opts.budget.cap_spp.then_some(spp);
        match (opts.pass_spp, cap) {
            (Some(p), cap) => Schedule::Every {
                per_pass: p.max(1),
                cap,
            },
            (None, Some(spp)) if opts.adaptive.is_none() => Schedule::Split { spp, batches },
            (None, Some(spp)) => Schedule::Every {
                per_pass: (spp / batches).max(1),
                cap: Some(spp),
            },
            (None, None) => Schedule::Every {
                per_pass: DEFAULT_PASS_SPP,
                cap: None,
            },
        }
    }

    /// Samples per cell in (uniform) pass `pass`; 0 once the cap is reached.
    pub fn uniform(&self, pass: u32) -> u32 {
        match *self {
            Schedule::Split { spp, batches } if pass < batches => {
                samples_in_pass(spp, batches, pass)
            }
            Schedule::Split { .. } => 0,
            Schedule::Every {
                per_pass,
                cap: None,
            } => per_pass,
            Schedule::Every {
                per_pass,
                cap: Some(c),
            } => c
                .saturating_sub(per_pass.saturating_mul(pass))
                .min(per_pass),
        }
    }

    /// The samples per cell of a full pass (the unit of adaptive allocation).
    pub fn unit(&self) -> u32 {
        match *self {
            Schedule::Split { .. } => self.uniform(0),
            Schedule::Every { per_pass, .. } => per_pass,
        }
    }

    /// What fixes the pass sizes, as recorded in a field's metadata (`schedule`): a run resumes only
    /// with the same schedule. The cap of `Every` is a budget, not part of it.
    pub fn key(&self) -> String {
        match *self {
            Schedule::Split { spp, batches } => format!("{spp} spp in {batches} passes"),
            Schedule::Every { per_pass, .. } => format!("{per_pass} spp per pass"),
        }
    }
}

/// Where a run stands: what a partial field must record for a run to resume from it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Progress {
    /// Passes every cell has completed.
    pub passes: u32,
    /// The pass `passes`, if it was interrupted part-way.
    pub inflight: Option<InFlight>,
    /// Compute seconds spent by earlier invocations and this one so far.
    pub elapsed: f64,
}

/// A pass interrupted part-way.
#[derive(Clone, Debug, PartialEq)]
pub struct InFlight {
    /// Per cell: whether it completed the pass.
    pub done: Vec<bool>,
    /// Adaptive passes: the allocation (units of [`Schedule::unit`] samples) of every cell, which
    /// depends on the sums before the pass and cannot be recomputed afterwards.
    pub units: Option<Vec<u32>>,
}

/// Called after every completed pass (checkpoints, convergence logs). `Err` aborts the run.
pub type AfterPass<'a> = dyn FnMut(&mut Field, &Progress, &RunStats) -> anyhow::Result<()> + 'a;

/// What the driver checks and calls besides the kernel.
#[derive(Default)]
pub struct Hooks<'a> {
    /// Stop between chunks once this is set.
    pub stop: Option<&'a AtomicBool>,
    pub after_pass: Option<&'a mut AfterPass<'a>>,
}

/// Relative standard error over a field (stderr / σ per cell).
///
/// The cells counted are those with a defined σ > 0. A cell among them with fewer than two batches
/// has no error estimate yet and counts as infinitely uncertain, so a target error is never met
/// on cells that have not been measured. `p95` is the nearest-rank 95th percentile: at least 95 %
/// of the counted cells have a relative error ≤ `p95`, so `p95 ≤ target` means that 95 % of the
/// cells reached the target. The mean is over cells with an estimate. A field without such cells
/// (empty space, no light) has `p95 = 0`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    pub mean: f64,
    pub p95: f64,
    /// Cells with a defined σ > 0.
    pub cells: usize,
    /// Of those, cells without an error estimate: fewer than two batches, or none by
    /// [`Moments::has_estimate`] (e.g. the weight in effectively one unit).
    pub unestimated: usize,
}

/// Relative error of one cell: `Some(stderr/σ)` (∞ without an estimate), `None` when the cell is
/// not counted (σ undefined or 0).
fn cell_relerr(m: &Moments) -> Option<f64> {
    let v = m.finalize();
    if !(v.valid && v.sigma > 0.0) {
        return None;
    }
    if m.batches < 2 || !v.estimated {
        return Some(f64::INFINITY);
    }
    let r = v.stderr / v.sigma;
    Some(if r.is_finite() { r } else { f64::INFINITY })
}

pub fn error_stats(cells: &[Moments]) -> ErrorStats {
    let mut rel: Vec<f64> = cells.par_iter().filter_map(cell_relerr).collect();
    let n = rel.len();
    if n == 0 {
        return ErrorStats::default();
    }
    let finite: Vec<f64> = rel.iter().copied().filter(|r| r.is_finite()).collect();
    let mean = if finite.is_empty() {
        0.0
    } else {
        finite.iter().sum::<f64>() / finite.len() as f64
    };
    let rank = (0.95 * n as f64).ceil() as usize;
    let k = rank.clamp(1, n) - 1;
    let (_, p95, _) = rel.select_nth_unstable_by(k, f64::total_cmp);
    ErrorStats {
        mean,
        p95: *p95,
        cells: n,
        unestimated: n - finite.len(),
    }
}

/// Adaptive allocation of one pass: how many units (of the schedule's per-pass samples; each unit
/// is one independent batch) each cell gets, `budget` units in all, at most `max_share` per cell.
///
/// A cell with an error estimate (σ > 0 defined, at least two batches) has relative error r after
/// n samples; its per-sample relative variance is estimated as a² = r²·n (r ≈ a/√n), shrunk
/// towards the median over cells with a pseudo-count of one batch, (k·a² + med)/(k + 1) for k
/// batches, so that a cell whose few batches happened to agree is not starved on that evidence
/// alone. A cell whose σ is exactly 0 so far has a² = 0 before shrinking. The pass then fills the
/// cells up to a common error level λ (water-filling): a cell gets the samples it lacks to reach
/// a²/(n + m) = λ, clamped to [0, max_share] units, with λ chosen so that the units add up to the
/// budget. Cells without an estimate (no defined σ yet, fewer than two batches, or none by
/// [`Moments::has_estimate`], e.g. the weight in effectively one unit) get the uniform share, one
/// unit. Shares are rounded by cumulative rounding, so the total is the budget.
///
/// What this does to the estimate. The allocation of pass p is a function of the sums after passes
/// < p only, never of pass p's samples, and pass p's samples come from the stream keyed
/// (seed, p, cell) whatever the allocation; the allocation only decides how many of them are
/// drawn. Each sample added is therefore, given the past, an independent draw from the cell's
/// sampling distribution, and the cell's sums stay plain sums of such draws: E[Σc] = E[n]·E[c], and
/// likewise for ΣcΔ and ΣcΔ² (Wald's identity), so sums still merge and resume exactly, and every
/// normalised quantity (σ, S0/n, fluence) converges to the same limit as in a uniform run. What
/// is not exact at finite n is the normalisation: n depends on the earlier samples' values (a cell
/// whose first passes looked noisy, e.g. because of one large contribution, gets more samples,
/// which dilute that contribution), so S/n is not an unbiased mean, and σ, a nonlinear function of
/// ratios of sums, is biased at finite n in any run. Both biases shrink as the samples grow; the
/// driver tests compare the mean of σ over a slice with that of a uniform run of four times the
/// samples. Each unit is a batch of the same size as a uniform pass's, taken in groups of
/// [`QMC_GROUP`] samples (one scrambled sequence each) like a uniform pass, and the standard error
/// comes from sums over those groups, so it does not depend on how many units a cell gets.
pub fn allocate(cells: &[Moments], unit: u32, budget: u64, max_share: u32) -> Vec<u32> {
    let unit = unit.max(1) as f64;
    let kmax = max_share.max(1) as f64;
    // (a², n, k) of cells with an estimate; None: uniform share.
    let est: Vec<Option<(f64, f64, f64)>> = cells
        .par_iter()
        .map(|m| {
            let v = m.finalize();
            if !v.valid || m.batches < 2 || !v.estimated {
                return None;
            }
            let r = if v.sigma > 0.0 {
                v.stderr / v.sigma
            } else {
                0.0
            };
            let a2 = r * r * m.n as f64;
            a2.is_finite().then_some((a2, m.n as f64, m.batches as f64))
        })
        .collect();
    let mut out = vec![0u32; cells.len()];
    let mut budget = budget;
    // Uniform share for cells without an estimate, in cell order while the budget lasts.
    for (o, e) in out.iter_mut().zip(&est) {
        if e.is_none() && budget > 0 {
            *o = 1;
            budget -= 1;
        }
    }
    let mut a2s: Vec<f64> = est.iter().flatten().map(|e| e.0).collect();
    if a2s.is_empty() || budget == 0 {
        return out;
    }
    let mid = a2s.len() / 2;
    let med = *a2s.select_nth_unstable_by(mid, f64::total_cmp).1;
    let shrunk: Vec<(usize, f64, f64)> = est
        .iter()
        .enumerate()
        .filter_map(|(i, e)| e.map(|(a2, n, k)| (i, (k * a2 + med) / (k + 1.0), n)))
        .collect();
    let share = |lambda: f64| -> f64 {
        shrunk
            .par_iter()
            .map(|&(_, a2, n)| ((a2 / lambda - n) / unit).clamp(0.0, kmax))
            .sum()
    };
    let b = budget as f64;
    let lambda = if kmax * shrunk.len() as f64 <= b {
        0.0 // every cell at its cap
    } else {
        // Σ share is non-increasing in λ: bisect on log λ between a level every cell has reached
        // (share 0) and one where all are capped.
        let hi0 = shrunk
            .iter()
            .map(|&(_, a2, n)| a2 / n.max(1.0))
            .fold(0.0, f64::max);
        if !(hi0 > 0.0) {
            return out; // no cell has any error left to reduce
        }
        let (mut lo, mut hi) = (hi0 * 1e-12, hi0);
        for _ in 0..100 {
            let mid = (lo * hi).sqrt();
            if share(mid) > b {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi / lo < 1.0 + 1e-9 {
                break;
            }
        }
        hi
    };
    let x: Vec<f64> = shrunk
        .iter()
        .map(|&(_, a2, n)| {
            if lambda > 0.0 {
                ((a2 / lambda - n) / unit).clamp(0.0, kmax)
            } else {
                kmax
            }
        })
        .collect();
    let total: f64 = x.iter().sum();
    if !(total > 0.0) {
        return out;
    }
    let scale = b.min(total) / total;
    let (mut acc, mut prev) = (0.0f64, 0u64);
    for (&(i, _, _), xi) in shrunk.iter().zip(&x) {
        acc += xi * scale;
        let now = (acc.round() as u64).min(budget);
        out[i] = ((now - prev) as u32).min(max_share.max(1));
        prev = now;
    }
    out
}

/// Runs `kernel(cell, sampler)` `opts.spp` times for every cell of `field`, adding to its sums, on
/// `pool` (its size overrides `opts.threads`).
pub fn run_in<K>(
    pool: &rayon::ThreadPool,
    field: &mut Field,
    opts: &RenderOptions,
    kernel: K,
) -> anyhow::Result<RunStats>
where
    K: Fn(usize, &mut Sampler) -> Sample + Sync,
{
    let mut progress = Progress::default();
    run_progressive(pool, field, opts, &mut progress, Hooks::default(), kernel)
}

/// Per-cell sample counts of one pass.
enum PassSizes<'a> {
    /// Every cell gets one batch of this many samples.
    Uniform(u32),
    /// Cell i gets `units[i]` batches of `unit` samples.
    Units { unit: u32, units: &'a [u32] },
}

/// Counters shared by the workers of a pass.
#[derive(Default)]
struct Counters {
    rays: AtomicU64,
    capped: AtomicU64,
    clamped: AtomicU64,
    samples: AtomicU64,
}

/// One pass to run: its index, the cells it covers, per-cell sizes, the cells that already
/// completed it (resumed runs) and the stop flag checked between chunks. Per-cell vectors are
/// indexed over the whole field.
struct PassJob<'a> {
    seed: u64,
    cells: std::ops::Range<usize>,
    pass: u32,
    sizes: PassSizes<'a>,
    done: Option<&'a [bool]>,
    stop: Option<&'a AtomicBool>,
}

/// Runs one pass over the cells not yet `done`; returns per chunk whether it ran (false: skipped
/// after a stop request).
fn run_pass<K>(
    pool: &rayon::ThreadPool,
    field: &mut Field,
    job: &PassJob,
    counters: &Counters,
    bar: &ProgressBar,
    kernel: &K,
) -> Vec<bool>
where
    K: Fn(usize, &mut Sampler) -> Sample + Sync,
{
    let PassJob {
        seed,
        ref cells,
        pass,
        ref sizes,
        done,
        stop,
    } = *job;
    let first = cells.start;
    pool.install(|| {
        field.cells[cells.clone()]
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(ci, chunk)| {
                if stop.is_some_and(|s| s.load(Relaxed)) {
                    return false;
                }
                let (mut r, mut cap, mut cl, mut n) = (0u64, 0u64, 0u64, 0u64);
                for (k, cell) in chunk.iter_mut().enumerate() {
                    let idx = first + ci * CHUNK + k;
                    if done.is_some_and(|d| d[idx]) {
                        continue;
                    }
                    let (batches, spp) = match sizes {
                        PassSizes::Uniform(s) => (1, *s),
                        PassSizes::Units { unit, units } => (units[idx], *unit),
                    };
                    if batches == 0 || spp == 0 {
                        continue;
                    }
                    let mut s = Sampler::new(seed, pass as u64, idx as u64);
                    // Groups of QMC_GROUP samples (the last of a batch may be shorter), numbered
                    // over the pass: each is its own scrambled sequence and one independent unit
                    // of the standard error.
                    let mut group = 0;
                    for _ in 0..batches {
                        let mut b = Moments::default();
                        let mut sums = GroupSums::default();
                        for i in 0..spp {
                            let k = i % QMC_GROUP;
                            s.begin_sample(group, k);
                            let smp = kernel(idx, &mut s);
                            r += smp.rays as u64;
                            cap += smp.capped as u64;
                            cl += smp.clamped as u64;
                            sums.add(b.add_to_sums(smp.c, smp.delta, smp.weight));
                            if k + 1 == QMC_GROUP || i + 1 == spp {
                                b.add_group(&sums);
                                sums = GroupSums::default();
                                group += 1;
                            }
                        }
                        cell.add_batch(&b);
                    }
                    n += batches as u64 * spp as u64;
                }
                counters.rays.fetch_add(r, Relaxed);
                counters.capped.fetch_add(cap, Relaxed);
                counters.clamped.fetch_add(cl, Relaxed);
                counters.samples.fetch_add(n, Relaxed);
                bar.inc(n);
                true
            })
            .collect()
    })
}

fn progress_bar(opts: &RenderOptions, total: Option<u64>) -> ProgressBar {
    if !(opts.progress && std::io::stderr().is_terminal()) {
        return ProgressBar::hidden();
    }
    match total {
        Some(t) => {
            let b = ProgressBar::new(t);
            b.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {percent:>3}% {per_sec} samples, ETA {eta} {msg}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            b
        }
        None => {
            let b = ProgressBar::new_spinner();
            b.set_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} {spinner} {human_pos} samples, {per_sec} {msg}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            b
        }
    }
}

/// Runs passes over `field` from where `progress` stands until a budget in `opts` is reached or a
/// stop is requested, and updates `progress`. `field` holds the sums of the passes `progress`
/// describes (none for a new run). See the module documentation for the guarantees.
pub fn run_progressive<K>(
    pool: &rayon::ThreadPool,
    field: &mut Field,
    opts: &RenderOptions,
    progress: &mut Progress,
    mut hooks: Hooks,
    kernel: K,
) -> anyhow::Result<RunStats>
where
    K: Fn(usize, &mut Sampler) -> Sample + Sync,
{
    let active = opts.active_cells(field.width, field.height, field.depth);
    let cells = active.len() as u64;
    let schedule = Schedule::of(opts);
    let unit = schedule.unit();
    let budget = &opts.budget;
    // Sample cap of the whole field (adaptive runs spend it in units, overshooting by < 1 unit).
    let cap_total = budget.cap_spp.then(|| cells * opts.spp.max(1) as u64);
    let mut taken: u64 = field.cells[active.clone()].iter().map(|c| c.n).sum();
    let bar = progress_bar(opts, cap_total);
    bar.set_position(taken.min(cap_total.unwrap_or(u64::MAX)));
    let counters = Counters::default();
    let start = Instant::now();
    let elapsed0 = progress.elapsed;
    let mut last_pass: Option<f64> = None;
    let stats_now = |progress: &Progress, stop: StopReason| RunStats {
        samples: counters.samples.load(Relaxed),
        rays: counters.rays.load(Relaxed),
        capped: counters.capped.load(Relaxed),
        clamped: counters.clamped.load(Relaxed),
        seconds: start.elapsed().as_secs_f64(),
        passes: progress.passes,
        stop,
    };
    let stop_requested = || hooks.stop.is_some_and(|s| s.load(Relaxed));
    let reason = loop {
        let pass = progress.passes;
        progress.elapsed = elapsed0 + start.elapsed().as_secs_f64();
        // Budgets are checked at pass boundaries; a pass interrupted part-way is finished first.
        if progress.inflight.is_none() {
            if stop_requested() {
                break StopReason::Interrupted;
            }
            if budget.max_passes.is_some_and(|m| pass >= m) {
                break StopReason::PassLimit;
            }
            if schedule.uniform(pass) == 0 || cap_total.is_some_and(|c| taken >= c) {
                break StopReason::Samples;
            }
            if let Some(target) = budget.target_error
                && pass >= 2
                && error_stats(&field.cells[active.clone()]).p95 <= target
            {
                break StopReason::TargetError;
            }
            if let Some(t) = budget.time {
                let t = t.as_secs_f64();
                if progress.elapsed >= t || last_pass.is_some_and(|d| progress.elapsed + d > t) {
                    break StopReason::Time;
                }
            }
        }
        let t_pass = Instant::now();
        let adaptive_units: Option<Vec<u32>> = match (&progress.inflight, opts.adaptive) {
            (Some(f), _) if f.units.is_some() => f.units.clone(),
            (_, Some(a)) if pass >= 2 => {
                let left =
                    cap_total.map_or(cells, |c| c.saturating_sub(taken).div_ceil(unit as u64));
                // Indexed over the whole field (the units are stored per cell in checkpoints).
                let mut units = vec![0; field.cells.len()];
                units[active.clone()].copy_from_slice(&allocate(
                    &field.cells[active.clone()],
                    unit,
                    left.min(cells),
                    a.max_share,
                ));
                Some(units)
            }
            _ => None,
        };
        let sizes = match &adaptive_units {
            Some(units) => PassSizes::Units { unit, units },
            None => PassSizes::Uniform(schedule.uniform(pass)),
        };
        let before = counters.samples.load(Relaxed);
        let done_before = progress.inflight.as_ref().map(|f| f.done.clone());
        let job = PassJob {
            seed: opts.seed,
            cells: active.clone(),
            pass,
            sizes,
            done: done_before.as_deref(),
            stop: hooks.stop,
        };
        let ran = run_pass(pool, field, &job, &counters, &bar, &kernel);
        taken += counters.samples.load(Relaxed) - before;
        if ran.iter().all(|&r| r) {
            progress.passes += 1;
            progress.inflight = None;
            last_pass = Some(t_pass.elapsed().as_secs_f64());
            progress.elapsed = elapsed0 + start.elapsed().as_secs_f64();
            if opts.progress && !bar.is_hidden() {
                let e = error_stats(&field.cells[active.clone()]);
                bar.set_message(format!(
                    "pass {}, relative error p95 {:.3}",
                    progress.passes, e.p95
                ));
            }
            if let Some(f) = hooks.after_pass.as_mut() {
                let s = stats_now(progress, StopReason::Samples);
                f(field, progress, &s)?;
            }
        } else {
            let n = field.cells.len();
            let done: Vec<bool> = (0..n)
                .map(|i| {
                    (active.contains(&i) && ran[(i - active.start) / CHUNK])
                        || done_before.as_ref().is_some_and(|d| d[i])
                })
                .collect();
            progress.inflight = Some(InFlight {
                done,
                units: adaptive_units,
            });
            break StopReason::Interrupted;
        }
    };
    progress.elapsed = elapsed0 + start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    Ok(stats_now(progress, reason))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rgb;

    #[test]
    fn pass_sizes_sum_to_spp() {
        for spp in [1, 7, 64, 1000] {
            for b in [1, 3, 8] {
                let b = b.min(spp);
                assert_eq!((0..b).map(|p| samples_in_pass(spp, b, p)).sum::<u32>(), spp);
            }
        }
    }

    #[test]
    fn schedules() {
        let o = RenderOptions::default();
        assert_eq!(
            Schedule::of(&o),
            Schedule::Split {
                spp: 64,
                batches: 8
            }
        );
        let mut t = o.clone();
        t.budget.cap_spp = false;
        assert_eq!(
            Schedule::of(&t),
            Schedule::Every {
                per_pass: DEFAULT_PASS_SPP,
                cap: None
            }
        );
        let mut p = o.clone();
        p.pass_spp = Some(10);
        let s = Schedule::of(&p);
        let sizes: Vec<u32> = (0..8).map(|i| s.uniform(i)).collect();
        assert_eq!(sizes, [10, 10, 10, 10, 10, 10, 4, 0]);
        let mut a = o.clone();
        a.adaptive = Some(Adaptive::default());
        assert_eq!(
            Schedule::of(&a),
            Schedule::Every {
                per_pass: 8,
                cap: Some(64)
            }
        );
    }

    /// A cell whose batches give σ values `sig` (unit weights, Δ chosen so σ = 2|Δ| for one
    /// sample per batch... here: batches of 2 samples Δ = ±d give m1 = 0, m2 = d², σ = 2d).
    fn cell(sig: &[f64]) -> Moments {
        let mut m = Moments::default();
        for &s in sig {
            let mut b = Moments::default();
            b.add_sample(1.0, s / 2.0, Rgb::ZERO);
            b.add_sample(1.0, -s / 2.0, Rgb::ZERO);
            m.add_batch(&b);
        }
        m
    }

    #[test]
    fn error_stats_percentile_and_unestimated() {
        let mut cells: Vec<Moments> = (0..19).map(|_| cell(&[1.0, 1.0])).collect();
        cells.push(cell(&[1.0])); // σ > 0, one batch: no estimate
        cells.push(Moments::default()); // invalid: not counted
        let e = error_stats(&cells);
        assert_eq!(e.cells, 20);
        assert_eq!(e.unestimated, 1);
        // 19 of 20 cells (95 %) have relative error 0: the 95th percentile is 0.
        assert_eq!(e.p95, 0.0);
        cells.push(cell(&[1.0]));
        // Now 19 of 21 < 95 %: the percentile is an unestimated cell.
        assert_eq!(error_stats(&cells).p95, f64::INFINITY);
        // Two batches, but weight in the second only (radiance found once): no estimate either.
        let mut w = Moments::default();
        let mut dark = Moments::default();
        dark.add_sample(0.0, 0.5, Rgb::ZERO);
        w.add_batch(&dark);
        let mut lit = Moments::default();
        let mut g = crate::ftpd::moments::GroupSums::default();
        g.add(lit.add_to_sums(1.0, 0.5, Rgb::ZERO));
        g.add(lit.add_to_sums(1.0, -0.5, Rgb::ZERO));
        lit.add_group(&g);
        w.add_batch(&lit);
        assert_eq!((w.batches, w.groups), (2, 2));
        assert!(w.finalize().sigma > 0.0 && !w.has_estimate());
        let e = error_stats(&[cell(&[1.0, 1.0]), w]);
        assert_eq!((e.cells, e.unestimated), (2, 1));
    }

    #[test]
    fn allocation_spends_the_budget_where_the_error_is() {
        // 10 noisy cells, 10 quiet ones, 2 without an estimate.
        let mut cells: Vec<Moments> = (0..10).map(|_| cell(&[1.0, 3.0])).collect();
        cells.extend((0..10).map(|_| cell(&[1.0, 1.01])));
        cells.push(cell(&[1.0]));
        cells.push(Moments::default());
        let u = allocate(&cells, 2, 22, 4);
        assert_eq!(u.iter().map(|&x| x as u64).sum::<u64>(), 22, "{u:?}");
        assert!(u.iter().all(|&x| x <= 4));
        assert_eq!(&u[20..], &[1, 1]);
        let noisy: u32 = u[..10].iter().sum();
        let quiet: u32 = u[10..20].iter().sum();
        assert!(noisy > 2 * quiet, "{u:?}");
        // Deterministic.
        assert_eq!(u, allocate(&cells, 2, 22, 4));
        // A budget larger than all caps: everyone capped.
        let all = allocate(&cells, 2, 1000, 4);
        assert!(all[..20].iter().all(|&x| x == 4), "{all:?}");
    }
}
