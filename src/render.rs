//! The driver: runs the per-cell kernel over a grid of cells in passes, in parallel (rayon), with
//! deterministic streams keyed by (seed, pass, cell), so the result is bit-identical for any thread
//! count. Each pass is one independent batch for the standard error.

use crate::field::Field;
use crate::ftpd::Sample;
use crate::ftpd::moments::Moments;
use crate::rng::Sampler;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::time::Instant;

/// How many samples, in how many batches, on how many threads.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// Samples per cell.
    pub spp: u32,
    /// Independent batches (passes); at most `spp`.
    pub batches: u32,
    pub seed: u64,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    /// Show a progress bar on stderr (only when stderr is a terminal).
    pub progress: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            spp: 64,
            batches: 8,
            seed: 1,
            threads: 0,
            progress: false,
        }
    }
}

/// What a run did, for the summary and the benchmarks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunStats {
    pub samples: u64,
    pub rays: u64,
    /// Pairs with a walk that reached the bounce cap.
    pub capped: u64,
    /// Samples whose contribution was not finite and was dropped.
    pub clamped: u64,
    pub seconds: f64,
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
const CHUNK: usize = 64;

/// Samples per cell in pass `pass` of `batches` (spreads the remainder over the first passes).
pub fn samples_in_pass(spp: u32, batches: u32, pass: u32) -> u32 {
    spp / batches + u32::from(pass < spp % batches)
}

/// Runs `kernel(cell, sampler)` `opts.spp` times for every cell of `field`, adding to its sums.
pub fn run<K>(field: &mut Field, opts: &RenderOptions, kernel: K) -> anyhow::Result<RunStats>
where
    K: Fn(usize, &mut Sampler) -> Sample + Sync,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    run_in(&pool, field, opts, kernel)
}

/// [`run`] on a given thread pool (its size overrides `opts.threads`).
pub fn run_in<K>(
    pool: &rayon::ThreadPool,
    field: &mut Field,
    opts: &RenderOptions,
    kernel: K,
) -> anyhow::Result<RunStats>
where
    K: Fn(usize, &mut Sampler) -> Sample + Sync,
{
    let batches = opts.batches.clamp(1, opts.spp.max(1));
    let total = field.cells.len() as u64 * opts.spp as u64;
    let bar = if opts.progress && std::io::stderr().is_terminal() {
        let b = ProgressBar::new(total);
        b.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {percent:>3}% {per_sec} samples, ETA {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    let (rays, capped, clamped, samples) = (
        AtomicU64::new(0),
        AtomicU64::new(0),
        AtomicU64::new(0),
        AtomicU64::new(0),
    );
    let start = Instant::now();
    for pass in 0..batches {
        let spp = samples_in_pass(opts.spp, batches, pass);
        pool.install(|| {
            field
                .cells
                .par_chunks_mut(CHUNK)
                .enumerate()
                .for_each(|(ci, chunk)| {
                    let (mut r, mut cap, mut cl) = (0u64, 0u64, 0u64);
                    for (k, cell) in chunk.iter_mut().enumerate() {
                        let idx = ci * CHUNK + k;
                        let mut s = Sampler::new(opts.seed, pass as u64, idx as u64);
                        let mut b = Moments::default();
                        for _ in 0..spp {
                            let smp = kernel(idx, &mut s);
                            r += smp.rays as u64;
                            cap += smp.capped as u64;
                            cl += smp.clamped as u64;
                            b.add_sample(smp.c, smp.delta, smp.weight);
                        }
                        cell.add_batch(&b);
                    }
                    rays.fetch_add(r, Relaxed);
                    capped.fetch_add(cap, Relaxed);
                    clamped.fetch_add(cl, Relaxed);
                    let n = chunk.len() as u64 * spp as u64;
                    samples.fetch_add(n, Relaxed);
                    bar.inc(n);
                });
        });
    }
    bar.finish_and_clear();
    Ok(RunStats {
        samples: samples.into_inner(),
        rays: rays.into_inner(),
        capped: capped.into_inner(),
        clamped: clamped.into_inner(),
        seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_sizes_sum_to_spp() {
        for spp in [1, 7, 64, 1000] {
            for b in [1, 3, 8] {
                let b = b.min(spp);
                assert_eq!((0..b).map(|p| samples_in_pass(spp, b, p)).sum::<u32>(), spp);
            }
        }
    }
}
