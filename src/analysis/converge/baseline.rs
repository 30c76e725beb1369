//! Convergence of this build against a baseline build, each run as its own processes.

use super::curve::{Curve, Level};
use super::measure::{Comparison, compare, mean_stderr};
use super::{ConvergeJob, Setup};
use crate::field::Field;
use anyhow::{Context, bail};
use std::path::Path;

/// With `--baseline`: the levels of the baseline binary and of this one, each run as a separate
/// process with the same plain command line ([`crate::analysis::binary`]), interleaved level by
/// level (baseline, then this) so that a change of the machine's load hits both alike. Times are
/// the compute seconds each process stores in its output.
///
/// Seeds: the baseline's level k uses `seed + k`, this binary's `seed + n + k` for n levels, so
/// that no run of one binary shares a seed (and so random streams) with a run of the other.
/// Reference: `--reference` when given; else the baseline's highest-spp run, which is the
/// self-reference of the baseline curve (its own row is left out) and the reference of every
/// level of this binary, so that a bias of the newer estimator cannot hide in its reference.
/// Returns the curves (per weighting: baseline, then this) and this binary's top field per
/// weighting.
pub(super) fn measure_binaries(
    job: &ConvergeJob,
    baseline: &Path,
    setup: &Setup,
    mut say: impl FnMut(&str),
) -> anyhow::Result<(Vec<Curve>, Vec<Field>)> {
    let (plane, weightings, reference, levels) = (
        &setup.plane,
        &setup.weightings,
        setup.reference(),
        &setup.levels,
    );
    use crate::analysis::binary::{SliceRun, run_slice, seconds};
    let this = std::env::current_exe().context("converge: cannot find this binary")?;
    let runs_dir = job.out_dir.join("runs");
    std::fs::create_dir_all(&runs_dir)
        .with_context(|| format!("{}: cannot create it", runs_dir.display()))?;
    let n = levels.len() as u64;
    let res = plane.width.max(plane.height);
    let mut curves = Vec::new();
    let mut tops = Vec::new();
    for &w in weightings {
        let run = |spp: u32, seed: u64| SliceRun {
            scene: &job.scene,
            slice: &job.slice,
            res,
            window: job.window,
            weighting: w,
            spp,
            batches: job.batches.clamp(1, spp),
            seed,
            threads: job.threads,
            extra: &job.forward_args,
        };
        // Untimed warm-up of each binary (file cache, first process start).
        for (tag, bin) in [("baseline", baseline), ("this", this.as_path())] {
            let out = runs_dir.join(format!("warmup_{tag}_{w}.exr"));
            run_slice(bin, &run(levels[0], job.seed.wrapping_sub(1)), &out)?;
            let _ = std::fs::remove_file(&out);
        }
        let mut fields: [Vec<(u32, u64, f64, Field)>; 2] = [Vec::new(), Vec::new()];
        for (k, &spp) in levels.iter().enumerate() {
            for (b, (tag, bin, seed)) in [
                ("baseline", baseline, job.seed.wrapping_add(k as u64)),
                ("this", this.as_path(), job.seed.wrapping_add(n + k as u64)),
            ]
            .into_iter()
            .enumerate()
            {
                let out = runs_dir.join(format!("{tag}_{w}_spp{spp}.exr"));
                let field = run_slice(bin, &run(spp, seed), &out)?;
                let name = out.display().to_string();
                match (b, reference, fields[0].first()) {
                    (1, Some((rn, r)), _) => crate::merge::check_same_run(rn, r, &name, &field)?,
                    (_, _, Some(f)) if (f.3.width, f.3.height) != (field.width, field.height) => {
                        bail!(
                            "{name}: {}x{} cells, the baseline wrote {}x{}",
                            field.width,
                            field.height,
                            f.3.width,
                            f.3.height
                        )
                    }
                    _ => {}
                }
                let secs = seconds(&field, &out)?;
                say(&format!(
                    "{:<10} {tag:<8} {spp:>6} spp  seed {seed:<4} {secs:>8.3} s",
                    w.to_string()
                ));
                fields[b].push((spp, seed, secs, field));
            }
        }
        let top = levels.len() - 1;
        let base_top = &fields[0][top].3;
        for (b, lv) in fields.iter().enumerate() {
            let mut out = Vec::new();
            for (k, (spp, seed, secs, field)) in lv.iter().enumerate() {
                let self_ref = reference.is_none() && b == 0 && k == top;
                let cmp = match reference {
                    Some((_, r)) => compare(field, r),
                    None if self_ref => Comparison {
                        cells: field.valid().iter().filter(|v| **v).count(),
                        ..Comparison::default()
                    },
                    None => compare(field, base_top),
                };
                out.push(Level {
                    weighting: w,
                    spp: *spp,
                    seed: *seed,
                    seconds: *secs,
                    // Runs do not store their ray count.
                    rays: 0,
                    samples: field.info("converge run")?.samples.unwrap_or(0),
                    cells: cmp.cells,
                    rmse: (!self_ref).then_some(cmp.rmse),
                    net_rmse: (!self_ref).then_some(cmp.net_rmse()),
                    mean_rel_err: (!self_ref).then_some(cmp.mean_rel),
                    mean_stderr: mean_stderr(field),
                    is_reference: self_ref,
                });
            }
            curves.push(Curve::new(w, out, b == 0));
        }
        let [_, mut this_fields] = fields;
        tops.push(this_fields.pop().expect("at least one level").3);
    }
    Ok((curves, tops))
}
