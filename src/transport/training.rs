//! Training of the guide of guided radiance ([`crate::transport::guide`]): radiance paths from
//! points of the scene's bounds, each vertex recording what the path gathered through the
//! direction it left by, folded into the guide's histograms in a fixed order.

use crate::kernel::{Kernel, Space};
use crate::math::luminance;
use crate::rng::{Sampler, mix64};
use crate::scene::Scene;
use crate::transport::guide::{BINS, Guide, bin_of};
use crate::transport::walk::{Guiding, RadianceStats, StartMis, Visit, radiance_guided};
use glam::DVec3;
use rayon::prelude::*;

/// Training paths per iteration, each iteration drawing with the guide of the ones before.
pub const TRAIN_PATHS: [u32; 2] = [1 << 16, 1 << 17];

/// Training paths per parallel chunk (each chunk its own stream).
const TRAIN_CHUNK: u32 = 1024;

/// Distinguishes the training streams from the run's (seed, pass, cell) streams.
const TRAIN_STREAM: u64 = 0x6775_6964_6520_7472;

/// Trains the guide for radiance paths of at most `cap` scattering events in `scene` (3D kernels
/// only), on `pool`, from the training streams of `seed` ([`TRAIN_PATHS`]). The same guide on any
/// thread count.
pub fn train<K: Kernel>(scene: &Scene, cap: u32, seed: u64, pool: &rayon::ThreadPool) -> Guide {
    debug_assert_eq!(K::Space::DIMS, 3);
    let grid = Guide::grid(scene);
    let n = grid.cells();
    let mut sums = vec![0.0; n * BINS];
    let mut counts = vec![0u32; n];
    let mut guide: Option<Guide> = None;
    for (iteration, &paths) in TRAIN_PATHS.iter().enumerate() {
        let chunks = paths.div_ceil(TRAIN_CHUNK);
        let prev = guide.as_ref();
        let records: Vec<Vec<(u32, u32, f64)>> = pool.install(|| {
            (0..chunks)
                .into_par_iter()
                .map(|chunk| {
                    let mut s =
                        Sampler::new(mix64(seed ^ TRAIN_STREAM), iteration as u64, chunk as u64);
                    train_chunk::<K>(scene, &grid, prev, cap, TRAIN_CHUNK, &mut s)
                })
                .collect()
        });
        // Folded in chunk order: the sums do not depend on which thread ran which chunk.
        for (cell, bin, v) in records.into_iter().flatten() {
            sums[cell as usize * BINS + bin as usize] += v;
            counts[cell as usize] += 1;
        }
        guide = Some(grid.clone().with_sums(&sums, &counts));
    }
    guide.unwrap_or(grid)
}

/// `paths` training paths from points uniform in the scene's bounds along uniform directions,
/// drawing with `prev` where it guides; their records (grid cell, bin, L / p).
fn train_chunk<K: Kernel>(
    scene: &Scene,
    grid: &Guide,
    prev: Option<&Guide>,
    cap: u32,
    paths: u32,
    s: &mut Sampler,
) -> Vec<(u32, u32, f64)> {
    let b = &scene.bounds;
    let sp = K::Space::of(scene);
    let mut out = Vec::new();
    let mut visits: Vec<Visit> = Vec::new();
    for _ in 0..paths {
        let u = DVec3::new(s.next_f64(), s.next_f64(), s.next_f64());
        let x = scene.off_surfaces(b.min + (b.max - b.min) * u);
        let look = sp.uniform(s.next_2d());
        visits.clear();
        let mut st = RadianceStats::default();
        let guiding = Guiding {
            guide: prev,
            visits: Some(&mut visits),
        };
        let r = radiance_guided::<K>(
            scene,
            x,
            look,
            cap,
            StartMis::default(),
            guiding,
            s,
            &mut st,
        );
        let total = luminance(r.rest);
        for v in &visits {
            let Some(cell) = grid.cell_of(v.p) else {
                continue;
            };
            // What the path gathered through the vertex's direction per unit throughput reaching
            // it, f |cos| L / p (L the radiance arriving along it, p its density), without the
            // emission it found at the next vertex, which light sampling reaches better: the
            // guide follows the light that next-event estimation misses, cosine and albedo
            // included, so that a cell of one surface puts no density below it.
            let later = total - luminance(v.gathered) - luminance(v.found);
            let value = later / v.throughput;
            if value.is_finite() && value >= 0.0 {
                out.push((cell as u32, bin_of(v.wi) as u32, value));
            }
        }
    }
    out
}
