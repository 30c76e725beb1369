//! The benchmark (`ftpd3d bench`): kernel rays/s against raw Embree rays/s on the same scene, rays
//! and threads.

use super::args::RunArgs;
use crate::app::DomainArg;
use crate::domain::{Domain, Plane, PlaneDomain};
use crate::field::Field;
use crate::ftpd::{self, Params};
use crate::render::{self, RenderOptions, RunStats, run_plane};
use crate::rng::Sampler;
use crate::scene::Scene;
use std::time::Instant;

/// One benchmark run: the kernel and raw Embree rays, on the same scene, slice, samples and
/// threads.
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub kernel: crate::kernel::KernelChoice,
    pub run: RunStats,
    pub raw_rays: u64,
    pub raw_seconds: f64,
}

impl BenchReport {
    pub fn raw_rays_per_second(&self) -> f64 {
        if self.raw_seconds > 0.0 {
            self.raw_rays as f64 / self.raw_seconds
        } else {
            0.0
        }
    }
    /// Kernel rays/s over raw rays/s.
    pub fn ray_ratio(&self) -> f64 {
        let raw = self.raw_rays_per_second();
        if raw > 0.0 {
            self.run.rays_per_second() / raw
        } else {
            0.0
        }
    }
}

/// Runs the FTPD kernel over `plane`, then replays through Embree alone (`rtcIntersect1` /
/// `rtcOccluded1`, nothing else) exactly the rays the kernel traced, recorded in a separate untimed
/// run, on the same number of threads. Each part runs `repeats` times, interleaved, and the fastest
/// time of each is kept (shared, noisy machines).
pub fn bench_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
    repeats: u32,
) -> anyhow::Result<BenchReport> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let rays = record_rays(scene, plane, params, opts, &pool)?;
    let accel = scene.accel();
    let (mut run, mut raw_seconds) = (None::<RunStats>, f64::INFINITY);
    for _ in 0..repeats.max(1) {
        let r = run_plane(scene, plane, params, opts)?.1;
        if run.as_ref().is_none_or(|a| r.seconds < a.seconds) {
            run = Some(r);
        }
        let start = Instant::now();
        let hits: u64 = pool.install(|| {
            // Balanced as the kernel's passes are (render::pass), so that neither side of the
            // ratio waits for the other's slowest run of chunks.
            rays.par_chunks(4096)
                .with_max_len(1)
                .map(|chunk| {
                    let mut h = 0u64;
                    for r in chunk {
                        h += if r.shadow {
                            accel.occluded(r.o, r.d, 0.0, r.tfar) as u64
                        } else {
                            accel.intersect(r.o, r.d, 0.0, r.tfar).is_some() as u64
                        };
                    }
                    h
                })
                .sum()
        });
        std::hint::black_box(hits);
        raw_seconds = raw_seconds.min(start.elapsed().as_secs_f64());
    }
    Ok(BenchReport {
        kernel: ftpd::kernel_for(params),
        run: run.unwrap_or_default(),
        raw_rays: rays.len() as u64,
        raw_seconds,
    })
}

/// Every ray query of one run of the kernel over `plane` (the same random decisions, hence the
/// same rays, as the timed runs), gathered from the pool's threads.
fn record_rays(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
    pool: &rayon::ThreadPool,
) -> anyhow::Result<Vec<crate::transport::trace::LoggedRay>> {
    let mut o = opts.clone();
    o.progress = false;
    let domain = PlaneDomain::new(plane, scene);
    let (w, h, d) = domain.dims();
    let mut field = Field::new(w, h, d);
    let sample = ftpd::sampler(ftpd::kernel_for(params), true);
    render::run_in(pool, &mut field, &o, |cell, s: &mut Sampler| {
        sample(scene, domain.start(scene, cell, s), params, s)
    })?;
    // Gather the logs of every worker of the pool.
    Ok(pool
        .broadcast(|_| crate::transport::trace::take_ray_log())
        .into_iter()
        .flatten()
        .collect())
}

/// `ftpd3d bench`: loads the scene, resolves the first slice of the run (a flatland one when
/// `flatland`; the scene file read as `load` says), runs [`bench_plane`] three times and writes
/// the report to `out`.
#[allow(clippy::too_many_arguments)]
pub fn bench(
    out: &mut impl std::io::Write,
    path: &std::path::Path,
    lights: &[crate::scene::Light],
    estimator: &crate::params::EstimatorArgs,
    (slice, window, res): (&crate::domain::slice::SliceArg, Option<[f64; 4]>, usize),
    flatland: bool,
    opts: &RenderOptions,
    load: &crate::scene::LoadOptions,
) -> anyhow::Result<()> {
    let mut scene = crate::scene::load::load_scene_with(path, lights, load)?;
    let plane = crate::domain::slice::resolve_plane(slice, &scene, window, res)?;
    let params = if flatland {
        crate::params::prepare_flatland(&mut scene, &plane, estimator)?
    } else {
        estimator.resolve_for_plane(&scene, &plane)?
    };
    let mut opts = opts.clone();
    opts.progress = false;
    let r = bench_plane(&scene, &plane, &params, &opts, 3)?;
    let line = |name: &str, s: &RunStats| {
        format!(
            "{name:<20} {:>11} rays in {:>7.3} s = {:.3e} rays/s, {:.3e} samples/s",
            s.rays,
            s.seconds,
            s.rays_per_second(),
            s.samples_per_second()
        )
    };
    writeln!(out, "scene                {}", path.display())?;
    writeln!(out, "features             {}", scene.features)?;
    writeln!(
        out,
        "slice                {} ({}x{}), {} spp, weighting {}, {} threads, best of 3",
        plane.label,
        plane.width,
        plane.height,
        opts.spp,
        params.weighting,
        opts.thread_count()
    )?;
    writeln!(out, "{}", line(&r.kernel.to_string(), &r.run))?;
    writeln!(
        out,
        "raw rtcIntersect1    {:>11} rays in {:>7.3} s = {:.3e} rays/s",
        r.raw_rays,
        r.raw_seconds,
        r.raw_rays_per_second()
    )?;
    writeln!(out, "kernel/raw rays/s    {:.3}", r.ray_ratio())?;
    Ok(())
}

/// `ftpd3d bench`: the benchmark on the first slice of the run `args` describe.
pub fn command(args: &RunArgs) -> anyhow::Result<()> {
    if args.volume.is_some() {
        anyhow::bail!("bench runs on a slice: use --slice instead of --volume");
    }
    let job = args.job()?;
    let DomainArg::Slice {
        slices,
        window,
        res,
    } = &job.domain
    else {
        anyhow::bail!("bench runs on a slice: give --slice");
    };
    let Some(slice) = slices.first() else {
        anyhow::bail!("bench runs on a slice: give --slice");
    };
    bench(
        &mut std::io::stdout().lock(),
        &job.scene,
        &job.lights,
        &job.estimator,
        (slice, *window, *res),
        job.flatland,
        &job.render,
        &job.load,
    )
}

/// What [`packet_replay`] measured.
#[derive(Clone, Copy, Debug, Default)]
pub struct PacketReplay {
    /// Closest-hit rays of the run, replayed.
    pub rays: u64,
    /// Fastest time to trace them one by one (`rtcIntersect1`) and in packets of four consecutive
    /// rays (`rtcIntersect4`), on the calling thread.
    pub single_seconds: f64,
    pub packet_seconds: f64,
    /// Rays whose packet hit differs from the single-ray hit in any bit (t, triangle,
    /// barycentrics).
    pub differing: u64,
}

/// Replays the closest-hit rays a run of the kernel over `plane` traces, one by one and in
/// packets of four consecutive rays (those of one sample's walks and radiance path lie next to
/// each other in the log), `repeats` times interleaved: whether packet traversal would pay for
/// these rays, and whether it finds the same hits to the bit.
pub fn packet_replay(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
    repeats: u32,
) -> anyhow::Result<PacketReplay> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let rays: Vec<_> = record_rays(scene, plane, params, opts, &pool)?
        .into_iter()
        .filter(|r| !r.shadow)
        .collect();
    let accel = scene.accel();
    let single = |rays: &[crate::transport::trace::LoggedRay]| {
        rays.iter()
            .map(|r| accel.intersect(r.o, r.d, 0.0, r.tfar))
            .collect::<Vec<_>>()
    };
    let packets = |rays: &[crate::transport::trace::LoggedRay]| {
        let mut out = Vec::with_capacity(rays.len());
        for chunk in rays.chunks(4) {
            let lanes = std::array::from_fn(|i| chunk.get(i).map(|r| (r.o, r.d, r.tfar)));
            out.extend_from_slice(&accel.intersect4(&lanes)[..chunk.len()]);
        }
        out
    };
    let mut report = PacketReplay {
        rays: rays.len() as u64,
        single_seconds: f64::INFINITY,
        packet_seconds: f64::INFINITY,
        differing: 0,
    };
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        let a = std::hint::black_box(single(&rays));
        report.single_seconds = report.single_seconds.min(start.elapsed().as_secs_f64());
        let start = Instant::now();
        let b = std::hint::black_box(packets(&rays));
        report.packet_seconds = report.packet_seconds.min(start.elapsed().as_secs_f64());
        report.differing = a.iter().zip(&b).filter(|(x, y)| !same_hit(x, y)).count() as u64;
    }
    Ok(report)
}

/// The same hit to the bit (or both none).
fn same_hit(a: &Option<crate::accel::RawHit>, b: &Option<crate::accel::RawHit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            a.prim == b.prim
                && a.t.to_bits() == b.t.to_bits()
                && a.u.to_bits() == b.u.to_bits()
                && a.v.to_bits() == b.v.to_bits()
        }
        _ => false,
    }
}
