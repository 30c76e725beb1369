//! One pass over the cells: the grid cut into chunks of [`CHUNK`] cells run in parallel, each cell
//! drawing its pass's samples from its own stream and folding them into its sums as whole batches.

use crate::field::Field;
use crate::ftpd::Sample;
use crate::ftpd::moments::{GroupSums, Moments};
use crate::gradient_domain::{Replayed, Shift, neighbour, phase};
use crate::rng::{QMC_GROUP, Sampler};
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};

/// Cells per parallel work item: large enough to amortise scheduling, small enough that the
/// threads finish a pass together (cells differ in cost several times over, near edges and lights).
pub const CHUNK: usize = 16;

/// Per-cell sample counts of one pass.
pub(super) enum PassSizes<'a> {
    /// Every cell gets one batch of this many samples.
    Uniform(u32),
    /// Cell i gets `units[i]` batches of `unit` samples.
    Units { unit: u32, units: &'a [u32] },
}

/// Counters shared by the workers of a pass.
#[derive(Default)]
pub(super) struct Counters {
    pub(super) rays: AtomicU64,
    pub(super) capped: AtomicU64,
    pub(super) clamped: AtomicU64,
    pub(super) samples: AtomicU64,
}

/// One pass to run: its index, the cells it covers, per-cell sizes, the cells that already
/// completed it (resumed runs), the stop flag checked between chunks and the caller's sample
/// count. Per-cell vectors are indexed over the whole field.
pub(super) struct PassJob<'a> {
    pub(super) seed: u64,
    pub(super) cells: std::ops::Range<usize>,
    pub(super) pass: u32,
    pub(super) sizes: PassSizes<'a>,
    pub(super) done: Option<&'a [bool]>,
    pub(super) stop: Option<&'a AtomicBool>,
    /// The caller's count of samples taken ([`super::Hooks::samples`]).
    pub(super) samples: Option<&'a AtomicU64>,
}

/// Runs one pass over the cells not yet `done`; returns per chunk whether it ran (false: skipped
/// after a stop request).
pub(super) fn run_pass<K>(
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
        samples,
    } = *job;
    let first = cells.start;
    let dims = field.dims();
    // A gradient-domain run replays every sample at the cell's upper neighbours
    // ([`crate::gradient_domain`]) and keeps their sums per replicate beside the cell's own.
    let layout = field
        .shift
        .as_ref()
        .map(|s| (s.stride(), s.block(), s.axes));
    let stride = layout.map_or(1, |l| l.0);
    let mut none = Vec::new();
    let shift_data: &mut [f64] = match field.shift.as_mut() {
        Some(s) => &mut s.data[cells.start * stride..cells.end * stride],
        None => {
            none.resize(cells.len(), 0.0);
            &mut none
        }
    };
    let field_cells = &mut field.cells[cells.clone()];
    pool.install(|| {
        field_cells
            .par_chunks_mut(CHUNK)
            .zip(shift_data.par_chunks_mut(CHUNK * stride))
            .enumerate()
            // Every chunk its own stealable job. Rayon's default cuts the chunks into a few runs
            // per thread (about four in all on two threads) and runs each run whole once taken,
            // so a thread whose runs were cheap sat idle until the other finished: 9-14 % of
            // the two cores' time on the Cornell box at 48² (docs/performance.md).
            .with_max_len(1)
            .map(|(ci, (chunk, shifts))| {
                if stop.is_some_and(|s| s.load(Relaxed)) {
                    return false;
                }
                let (mut r, mut cap, mut cl, mut n) = (0u64, 0u64, 0u64, 0u64);
                for (k_cell, cell) in chunk.iter_mut().enumerate() {
                    let idx = first + ci * CHUNK + k_cell;
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
                    let groups_before = cell.groups;
                    let phase = phase(dims, idx);
                    let neighbours: [Option<usize>; 3] =
                        std::array::from_fn(|a| neighbour(dims, idx, a));
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
                            let replay = layout.map(|_| s.clone());
                            let smp = kernel(idx, &mut s);
                            r += smp.rays as u64;
                            cap += u64::from(smp.capped);
                            cl += smp.clamped as u64;
                            if let (Some((stride, block, axes)), Some(replay)) = (layout, replay) {
                                let mut rec = Replayed {
                                    base: GroupSums {
                                        c: smp.c,
                                        a: smp.cd,
                                        b: smp.cd2,
                                    },
                                    ..Replayed::default()
                                };
                                for (a, nb) in neighbours.iter().enumerate().take(axes) {
                                    let Some(nb) = *nb else { continue };
                                    let sh = kernel(nb, &mut replay.clone());
                                    r += sh.rays as u64;
                                    cap += u64::from(sh.capped);
                                    cl += sh.clamped as u64;
                                    rec.shifted[a] = GroupSums {
                                        c: sh.c,
                                        a: sh.cd,
                                        b: sh.cd2,
                                    };
                                }
                                let rep = Shift::replicate(phase, groups_before, group);
                                Shift::add(
                                    &mut shifts[k_cell * stride..(k_cell + 1) * stride],
                                    block,
                                    rep,
                                    axes,
                                    &rec,
                                );
                            }
                            sums.add(b.add_unit_to_sums(smp.c, smp.cd, smp.cd2, smp.weight));
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
                if let Some(s) = samples {
                    s.fetch_add(n, Relaxed);
                }
                bar.inc(n);
                true
            })
            .collect()
    })
}
