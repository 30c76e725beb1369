//! The progressive driver: passes one after another until a budget is reached or a stop is
//! requested, each pass sized by the schedule (or the adaptive allocation) and run over the grid
//! by [`super::pass`]. The guarantees are in the module documentation of [`crate::render`].

use super::allocate::{allocate, allocate_by};
use super::error_stats::field_error_stats;
use super::pass::{CHUNK, Counters, PassJob, PassSizes, run_pass};
use super::{InFlight, Progress, RenderOptions, RunError, RunStats, Schedule, StopReason};
use crate::field::Field;
use crate::ftpd::Sample;
use crate::rng::Sampler;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::time::Instant;

/// Process-wide stop request, set by the command line's SIGINT/SIGTERM handler and passed to the
/// driver as [`Hooks::stop`] (library users may pass a flag of their own instead).
pub static INTERRUPT: AtomicBool = AtomicBool::new(false);

/// Whether a stop request would be heard: set when a driver given a [`Hooks::stop`] flag starts
/// its passes, cleared by the caller before the set-up of its next run (scene loading, BVH build,
/// thread start, guide training), which checks no flag. The command line's signal handler reads
/// it: a signal that no driver would hear ends the process at once instead of being stored.
pub static LISTENING: AtomicBool = AtomicBool::new(false);

/// Called after every completed pass (checkpoints, convergence logs). `Err` aborts the run.
pub type AfterPass<'a> = dyn FnMut(&mut Field, &Progress, &RunStats) -> anyhow::Result<()> + 'a;

/// What the driver checks and calls besides the kernel.
#[derive(Default)]
pub struct Hooks<'a> {
    /// Stop between chunks once this is set.
    pub stop: Option<&'a AtomicBool>,
    pub after_pass: Option<&'a mut AfterPass<'a>>,
    /// Samples taken, added to as each chunk of cells finishes: a front end reads it from another
    /// thread to show progress.
    pub samples: Option<&'a AtomicU64>,
}

/// Runs `kernel(cell, sampler)` `opts.spp` times for every cell of `field`, adding to its sums, on
/// `pool` (its size overrides `opts.threads`).
pub fn run_in<K>(
    pool: &rayon::ThreadPool,
    field: &mut Field,
    opts: &RenderOptions,
    kernel: K,
) -> Result<RunStats, RunError>
where
    K: Fn(usize, &mut Sampler) -> Sample + Sync,
{
    let mut progress = Progress::default();
    run_progressive(pool, field, opts, &mut progress, Hooks::default(), kernel)
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
) -> Result<RunStats, RunError>
where
    K: Fn(usize, &mut Sampler) -> Sample + Sync,
{
    if hooks.stop.is_some() {
        LISTENING.store(true, std::sync::atomic::Ordering::SeqCst);
    }
    let mut run = Driver::new(field, opts, progress);
    let reason = loop {
        let pass = progress.passes;
        run.clock(progress);
        // Budgets are checked at pass boundaries; a pass interrupted part-way is finished first.
        if progress.inflight.is_none()
            && let Some(reason) = run.stop_before(pass, field, progress, hooks.stop)
        {
            break reason;
        }
        let t_pass = Instant::now();
        let units = run.allocation(pass, field, progress);
        let done_before = progress.inflight.as_ref().map(|f| f.done.clone());
        let ran = run.pass(
            pool,
            field,
            pass,
            units.as_deref(),
            done_before.as_deref(),
            &hooks,
            &kernel,
        );
        if ran.iter().all(|&r| r) {
            run.complete_pass(field, progress, t_pass);
            if let Some(f) = hooks.after_pass.as_mut() {
                let s = run.stats(progress, StopReason::Samples);
                f(field, progress, &s)?;
            }
        } else {
            progress.inflight = Some(run.cut_pass(field.cells.len(), &ran, done_before, units));
            break StopReason::Interrupted;
        }
    };
    run.clock(progress);
    run.bar.finish_and_clear();
    Ok(run.stats(progress, reason))
}

/// One invocation of the driver: what it was asked, the samples it has taken and what it counted.
struct Driver<'a> {
    opts: &'a RenderOptions,
    /// The cells sampled (a tile's, or all), and how many.
    active: Range<usize>,
    cells: u64,
    schedule: Schedule,
    /// Samples per cell of a full pass, the unit of adaptive allocation.
    unit: u32,
    /// Sample cap of the whole field (adaptive runs spend it in units, overshooting by < 1 unit).
    cap_total: Option<u64>,
    /// Samples in the active cells so far, those of a resumed field included.
    taken: u64,
    bar: ProgressBar,
    counters: Counters,
    start: Instant,
    /// Compute seconds of earlier invocations (a resumed run).
    elapsed0: f64,
    /// Duration of the last complete pass, which the time budget expects the next to take.
    last_pass: Option<f64>,
}

impl<'a> Driver<'a> {
    fn new(field: &Field, opts: &'a RenderOptions, progress: &Progress) -> Self {
        let active = opts.active_cells(field.width, field.height, field.depth);
        let cells = active.len() as u64;
        let schedule = Schedule::of(opts);
        let cap_total = opts.budget.cap_spp.then(|| cells * opts.spp.max(1) as u64);
        let taken: u64 = field.cells[active.clone()].iter().map(|c| c.n).sum();
        let bar = progress_bar(opts, cap_total);
        bar.set_position(taken.min(cap_total.unwrap_or(u64::MAX)));
        Driver {
            opts,
            active,
            cells,
            unit: schedule.unit(),
            schedule,
            cap_total,
            taken,
            bar,
            counters: Counters::default(),
            start: Instant::now(),
            elapsed0: progress.elapsed,
            last_pass: None,
        }
    }

    /// Brings `progress.elapsed` up to now.
    fn clock(&self, progress: &mut Progress) {
        progress.elapsed = self.elapsed0 + self.start.elapsed().as_secs_f64();
    }

    fn stats(&self, progress: &Progress, stop: StopReason) -> RunStats {
        let c = &self.counters;
        RunStats {
            samples: c.samples.load(Relaxed),
            rays: c.rays.load(Relaxed),
            capped: c.capped.load(Relaxed),
            clamped: c.clamped.load(Relaxed),
            seconds: self.start.elapsed().as_secs_f64(),
            passes: progress.passes,
            stop,
        }
    }

    /// Why the run stops before pass `pass`, if it does: a stop request, the pass limit, the
    /// sample cap, the target error (from the third pass on), or a time budget the next pass
    /// would overrun (checked in that order).
    fn stop_before(
        &self,
        pass: u32,
        field: &Field,
        progress: &Progress,
        stop: Option<&AtomicBool>,
    ) -> Option<StopReason> {
        let budget = &self.opts.budget;
        if stop.is_some_and(|s| s.load(Relaxed)) {
            return Some(StopReason::Interrupted);
        }
        if budget.max_passes.is_some_and(|m| pass >= m) {
            return Some(StopReason::PassLimit);
        }
        if self.schedule.uniform(pass) == 0 || self.cap_total.is_some_and(|c| self.taken >= c) {
            return Some(StopReason::Samples);
        }
        if let Some(target) = budget.target_error
            && pass >= 2
            && field_error_stats(field, self.active.clone()).p95 <= target
        {
            return Some(StopReason::TargetError);
        }
        if let Some(t) = budget.time {
            let t = t.as_secs_f64();
            let now = progress.elapsed;
            if now >= t || self.last_pass.is_some_and(|d| now + d > t) {
                return Some(StopReason::Time);
            }
        }
        None
    }

    /// The adaptive allocation of pass `pass` in units per cell, indexed over the whole field (the
    /// units are stored per cell in checkpoints): the interrupted pass's own, or from the third
    /// pass of an adaptive run on, [`allocate`] over the sums so far; `None` for a uniform pass.
    fn allocation(&self, pass: u32, field: &Field, progress: &Progress) -> Option<Vec<u32>> {
        match (&progress.inflight, self.opts.adaptive) {
            (Some(f), _) if f.units.is_some() => f.units.clone(),
            (_, Some(a)) if pass >= 2 => {
                let unit = self.unit as u64;
                let left = self
                    .cap_total
                    .map_or(self.cells, |c| c.saturating_sub(self.taken).div_ceil(unit));
                let mut units = vec![0; field.cells.len()];
                let active = self.active.clone();
                units[active.clone()].copy_from_slice(&match field.shift {
                    None => allocate(
                        &field.cells[active],
                        self.unit,
                        left.min(self.cells),
                        a.max_share,
                    ),
                    Some(_) => allocate_by(
                        &field.cells[active.clone()],
                        &field.values()[active],
                        self.unit,
                        left.min(self.cells),
                        a.max_share,
                    ),
                });
                Some(units)
            }
            _ => None,
        }
    }

    /// Runs pass `pass` (`units` from [`Driver::allocation`]) over the active cells not in
    /// `done`; returns per chunk whether it ran.
    #[allow(clippy::too_many_arguments)]
    fn pass<K>(
        &mut self,
        pool: &rayon::ThreadPool,
        field: &mut Field,
        pass: u32,
        units: Option<&[u32]>,
        done: Option<&[bool]>,
        hooks: &Hooks,
        kernel: &K,
    ) -> Vec<bool>
    where
        K: Fn(usize, &mut Sampler) -> Sample + Sync,
    {
        let sizes = match units {
            Some(units) => PassSizes::Units {
                unit: self.unit,
                units,
            },
            None => PassSizes::Uniform(self.schedule.uniform(pass)),
        };
        let before = self.counters.samples.load(Relaxed);
        let job = PassJob {
            seed: self.opts.seed,
            cells: self.active.clone(),
            pass,
            sizes,
            done,
            stop: hooks.stop,
            samples: hooks.samples,
        };
        let ran = run_pass(pool, field, &job, &self.counters, &self.bar, kernel);
        self.taken += self.counters.samples.load(Relaxed) - before;
        ran
    }

    /// Records a pass every cell completed (started at `t_pass`).
    fn complete_pass(&mut self, field: &Field, progress: &mut Progress, t_pass: Instant) {
        progress.passes += 1;
        progress.inflight = None;
        self.last_pass = Some(t_pass.elapsed().as_secs_f64());
        self.clock(progress);
        if self.opts.progress && !self.bar.is_hidden() {
            let e = field_error_stats(field, self.active.clone());
            self.bar.set_message(format!(
                "pass {}, relative error p95 {:.3}",
                progress.passes, e.p95
            ));
        }
    }

    /// A pass cut short by a stop request: which of the field's `n` cells completed it (those of
    /// the chunks that `ran`, and those `done_before`, in a resumed pass), and its allocation.
    fn cut_pass(
        &self,
        n: usize,
        ran: &[bool],
        done_before: Option<Vec<bool>>,
        units: Option<Vec<u32>>,
    ) -> InFlight {
        let active = &self.active;
        let done: Vec<bool> = (0..n)
            .map(|i| {
                (active.contains(&i) && ran[(i - active.start) / CHUNK])
                    || done_before.as_ref().is_some_and(|d| d[i])
            })
            .collect();
        InFlight { done, units }
    }
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
