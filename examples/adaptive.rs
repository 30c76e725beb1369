//! Time to a target error, uniform against adaptive sampling, on two shipped scenes.
//!
//! ```sh
//! cargo run --release --example adaptive [-- TARGET RES]    # defaults: 0.1 48
//! ```
//!
//! For each scene (stair wall and Cornell box with mirror, slice z = 0, radiance weighting) and each
//! method, three runs with seeds 1, 2, 3 go until the 95th percentile of the estimated relative
//! standard error is at most TARGET (passes of 8 samples per cell). It prints the best and median
//! time, the samples, and two checks that the estimated error is honest for both methods, from the
//! differences between the independent runs (seeds): the 95th percentile over cells of
//! |σ₁ − σ₂| / (√2 σ̄), the error actually observed between two runs (1.96 × the true relative
//! error for a normal error), and the variance of z = (σ₁ − σ₂) / √(se₁² + se₂²), which is about 1
//! when the standard errors are right.

use ftpd3d::domain::Plane;
use ftpd3d::field::Field;
use ftpd3d::ftpd::Weighting;
use ftpd3d::params::EstimatorArgs;
use ftpd3d::render::{self, Adaptive, Budget, RenderOptions, error_stats, run_plane};
use ftpd3d::scene::load::load_scene;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let target: f64 = args.first().map_or(Ok(0.1), |a| a.parse())?;
    let res: usize = args.get(1).map_or(Ok(48), |a| a.parse())?;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    println!(
        "target: p95 relative error ≤ {target}; slice z=0, {res} cells on the long side; passes of 8 spp; \
         {} threads",
        rayon::current_num_threads()
    );
    for name in ["stair_wall.obj", "cornell_mirror.obj"] {
        let scene = load_scene(&root.join(name))?;
        let params = EstimatorArgs {
            weighting: Weighting::Radiance,
            t0: None,
            t1: None,
            angle_deg: 2.0,
            max_bounces: 32,
            radiance_bounces: None,
            ..Default::default()
        }
        .resolve(&scene)?;
        let plane = Plane::axis_slice(
            &scene.bounds,
            "z=0".parse().map_err(anyhow::Error::msg)?,
            None,
            res,
        )?;
        println!("\n{name} ({}x{} cells)", plane.width, plane.height);
        println!(
            "  {:<9} {:>8} {:>8} {:>7} {:>10} {:>7} {:>9} {:>8}",
            "method", "best s", "median s", "passes", "spp (mean)", "p95 est", "p95 seen", "var z"
        );
        let mut best = Vec::new();
        let mut adaptive_spp = 0.0;
        let mut adaptive_seen = 0.0;
        for adaptive in [false, true] {
            let mut runs: Vec<(f64, Field, u32)> = Vec::new();
            for seed in 1..=3 {
                let opts = RenderOptions {
                    spp: 8,
                    seed,
                    budget: Budget {
                        cap_spp: false,
                        target_error: Some(target),
                        ..Budget::default()
                    },
                    pass_spp: Some(8),
                    adaptive: adaptive.then(Adaptive::default),
                    ..RenderOptions::default()
                };
                let (field, stats) = run_plane(&scene, &plane, &params, &opts)?;
                assert_eq!(stats.stop, render::StopReason::TargetError);
                runs.push((stats.seconds, field, stats.passes));
            }
            let mut secs: Vec<f64> = runs.iter().map(|r| r.0).collect();
            secs.sort_by(f64::total_cmp);
            let (seen, varz) = honesty(&runs.iter().map(|r| &r.1).collect::<Vec<_>>());
            let spp: f64 = runs
                .iter()
                .map(|r| r.1.total_samples() as f64 / r.1.cells.len() as f64)
                .sum::<f64>()
                / 3.0;
            let passes: f64 = runs.iter().map(|r| r.2 as f64).sum::<f64>() / 3.0;
            let est: f64 = runs
                .iter()
                .map(|r| error_stats(&r.1.cells).p95)
                .sum::<f64>()
                / 3.0;
            println!(
                "  {:<9} {:>8.2} {:>8.2} {:>7.1} {:>10.1} {:>7.4} {:>9.4} {:>8.2}",
                if adaptive { "adaptive" } else { "uniform" },
                secs[0],
                secs[1],
                passes,
                spp,
                est,
                seen,
                varz
            );
            best.push(secs[0]);
            if adaptive {
                adaptive_spp = spp;
                adaptive_seen = seen;
            }
        }
        // Uniform runs with as many samples as the adaptive ones took: the error seen between
        // seeds at equal cost, which does not rely on the estimated errors.
        let spp = ((adaptive_spp / 8.0).round() as u32).max(1) * 8;
        let fields: Vec<Field> = (1..=3)
            .map(|seed| {
                let opts = RenderOptions {
                    spp,
                    seed,
                    pass_spp: Some(8),
                    ..RenderOptions::default()
                };
                run_plane(&scene, &plane, &params, &opts).map(|r| r.0)
            })
            .collect::<Result<_, _>>()?;
        let (seen, varz) = honesty(&fields.iter().collect::<Vec<_>>());
        println!(
            "  at equal samples ({spp} spp): p95 seen uniform {seen:.4} (var z {varz:.2}), adaptive {adaptive_seen:.4}"
        );
        println!(
            "  adaptive reaches the target in {:.0} % of the uniform time (best of 3: {:.2} s against {:.2} s)",
            100.0 * best[1] / best[0],
            best[1],
            best[0]
        );
    }
    println!(
        "\np95 est: the estimated 95th-percentile relative error at the stop (the target).\n\
         p95 seen: 95th percentile of |σ₁ − σ₂| / (√2 σ̄) between runs of different seeds, \
         ≈ 1.96 × the relative error where the error is normal;\n\
         var z: variance of (σ₁ − σ₂) / √(se₁² + se₂²), 1 when the estimated standard errors are right."
    );
    Ok(())
}

/// From independent runs: the 95th percentile over cells (and pairs of runs) of
/// |σ₁ − σ₂| / (√2 σ̄), and the variance of z = (σ₁ − σ₂) / √(se₁² + se₂²).
fn honesty(fields: &[&Field]) -> (f64, f64) {
    let mut seen = Vec::new();
    let (mut z2, mut nz) = (0.0, 0usize);
    for i in 0..fields.len() {
        for j in i + 1..fields.len() {
            let (a, b) = (fields[i].values(), fields[j].values());
            for (x, y) in a.iter().zip(&b) {
                if !(x.valid && y.valid && x.sigma > 0.0 && y.sigma > 0.0) {
                    continue;
                }
                let mean = 0.5 * (x.sigma + y.sigma);
                seen.push((x.sigma - y.sigma).abs() / (2f64.sqrt() * mean));
                let se = (x.stderr * x.stderr + y.stderr * y.stderr).sqrt();
                if se > 0.0 {
                    z2 += ((x.sigma - y.sigma) / se).powi(2);
                    nz += 1;
                }
            }
        }
    }
    seen.sort_by(f64::total_cmp);
    let p95 = seen
        .get(((0.95 * seen.len() as f64).ceil() as usize).saturating_sub(1))
        .copied()
        .unwrap_or(0.0);
    (p95, z2 / nz.max(1) as f64)
}
