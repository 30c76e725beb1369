//! Variance, time and efficiency of deflection-pair designs (`--pairs kA,kB,J,M`) against one
//! pair per sample, from the standard errors a run computes.
//!
//! ```sh
//! cargo run --release --example pairs_design [-- RES SPP ROUNDS [RADIANCE [UNWEIGHTED [SCENES]]]]
//! ```
//!
//! Defaults: 32 256 3; RADIANCE and UNWEIGHTED are the designs of each weighting separated by
//! `;` (`1,1,1,1;2,2,1,8`; 1,1,1,1 is always run first, as the base; an empty list skips the
//! weighting), SCENES the shipped scenes separated by `,` (`cornell_mirror.obj,stair_wall.obj`).
//!
//! For each scene (Cornell box with mirror, stair wall; slice z = 0) and weighting (radiance,
//! unweighted), every design runs the same slice with the same samples per cell, in `ROUNDS`
//! rounds (each round its own seed, the designs in a rotated order, so that a change of the
//! machine's load hits all alike). Per design: V = Σ over cells of n · se² (the per-sample
//! variance of σ, summed over the cells every design resolves; se from the independent
//! scrambled-Sobol' groups of 8 samples, so it includes what stratification gains), the process
//! CPU seconds per sample and the rays per sample. Printed against 1,1,1,1: the variance ratio
//! V₁/V, the time ratio t/t₁, the efficiency (V₁ t₁)/(V t), the factor by which the design needs
//! less time for the same error, and the same with rays for time (which the machine's load does
//! not change).

use ftpd3d::domain::Plane;
use ftpd3d::field::Field;
use ftpd3d::ftpd::{Design, Weighting};
use ftpd3d::params::EstimatorArgs;
use ftpd3d::render::{RenderOptions, run_plane};
use ftpd3d::scene::load::load_scene;
use std::path::Path;

/// User + system CPU seconds of this process so far (from /proc; 0 where it is absent).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which may hold spaces) start after its closing parenthesis.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok()).unwrap_or(0.0);
    // utime and stime are fields 14 and 15 of stat(5), 12 and 13 after the state.
    (ticks(11) + ticks(12)) / 100.0
}

#[derive(Default, Clone)]
struct Acc {
    /// Σ n·se² per cell, summed over rounds.
    v: Vec<f64>,
    cpu: f64,
    samples: u64,
    rays: u64,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let res: usize = args.first().map_or(Ok(32), |a| a.parse())?;
    let spp: u32 = args.get(1).map_or(Ok(256), |a| a.parse())?;
    let rounds: u64 = args.get(2).map_or(Ok(3), |a| a.parse())?;
    let designs_of = |i: usize, default: &str| -> anyhow::Result<Vec<Design>> {
        let text = args.get(i).map_or(default, String::as_str);
        let mut out = vec![Design::SINGLE];
        for d in text.split(';').filter(|t| !t.trim().is_empty()) {
            let d: Design = d.parse().map_err(anyhow::Error::msg)?;
            if d != Design::SINGLE {
                out.push(d);
            }
        }
        Ok(out)
    };
    let radiance = designs_of(3, "1,1,1,8;1,1,2,8;2,2,1,2;2,2,1,4;2,2,1,8;2,2,2,4")?;
    let unweighted = designs_of(4, "1,1,1,4;1,1,1,8;2,2,1,2;2,2,1,4;2,2,1,8;2,2,2,4")?;
    let skip = |i: usize| args.get(i).is_some_and(|t| t.trim().is_empty());
    let scenes: Vec<String> = args
        .get(5)
        .map_or("cornell_mirror.obj,stair_wall.obj", String::as_str)
        .split(',')
        .map(str::to_string)
        .collect();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    println!(
        "slice z=0, {res} cells on the long side, {spp} spp, {rounds} rounds, {} threads",
        rayon::current_num_threads()
    );
    println!(
        "| scene | weighting | design | variance ratio | time ratio | efficiency | rays/sample | efficiency by rays |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for name in &scenes {
        let scene = load_scene(&root.join(name))?;
        let plane = Plane::axis_slice(
            &scene.bounds,
            "z=0".parse().map_err(anyhow::Error::msg)?,
            None,
            res,
        )?;
        for weighting in [Weighting::Radiance, Weighting::Unweighted] {
            let (designs, arg) = match weighting {
                Weighting::Radiance => (&radiance, 3),
                _ => (&unweighted, 4),
            };
            if skip(arg) {
                continue;
            }
            let mut acc = vec![Acc::default(); designs.len()];
            for round in 0..rounds {
                for k in 0..designs.len() {
                    let i = (k + round as usize) % designs.len();
                    let params = EstimatorArgs {
                        weighting,
                        design: Some(designs[i]),
                        guide: false,
                        ..EstimatorArgs::default()
                    }
                    .resolve(&scene)?;
                    let opts = RenderOptions {
                        spp,
                        seed: 1000 + round,
                        ..RenderOptions::default()
                    };
                    let before = cpu_seconds();
                    let (field, stats) = run_plane(&scene, &plane, &params, &opts)?;
                    let a = &mut acc[i];
                    a.cpu += cpu_seconds() - before;
                    a.samples += stats.samples;
                    a.rays += stats.rays;
                    add_variances(&mut a.v, &field);
                }
            }
            // Cells every design resolved in every round (se > 0).
            let cells = acc[0].v.len();
            let both: Vec<usize> = (0..cells)
                .filter(|&c| acc.iter().all(|a| a.v[c] > 0.0))
                .collect();
            let total = |a: &Acc| both.iter().map(|&c| a.v[c]).sum::<f64>();
            let per_sample = |a: &Acc| a.cpu / a.samples as f64;
            let rays = |a: &Acc| a.rays as f64 / a.samples as f64;
            let (v1, t1, r1) = (total(&acc[0]), per_sample(&acc[0]), rays(&acc[0]));
            for (design, a) in designs.iter().zip(&acc) {
                let (vr, tr) = (v1 / total(a), per_sample(a) / t1);
                println!(
                    "| {} | {weighting} | {design} | {vr:.2} | {tr:.2} | {:.2} | {:.1} | {:.2} |",
                    name.trim_end_matches(".obj"),
                    vr / tr,
                    rays(a),
                    vr * r1 / rays(a)
                );
            }
            eprintln!(
                "{name} {weighting}: {} of {cells} cells resolved by every design",
                both.len()
            );
        }
    }
    Ok(())
}

/// Adds n · se² of each cell of `field` (0 where a cell has no standard error).
fn add_variances(v: &mut Vec<f64>, field: &Field) {
    v.resize(field.cells.len(), 0.0);
    for (acc, c) in v.iter_mut().zip(&field.cells) {
        let cv = c.finalize();
        let x = if cv.valid && cv.estimated {
            c.n as f64 * cv.stderr * cv.stderr
        } else {
            f64::NAN
        };
        // A cell unresolved in any round is left out of every design's sum.
        *acc += if x > 0.0 { x } else { f64::NEG_INFINITY };
    }
}
