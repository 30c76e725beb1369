//! Running the levels of a convergence report and measuring them against a reference.

use super::compare::compare;
use super::curve::{Curve, Level};
use super::{ConvergeError, ConvergeJob, Setup};
use crate::field::Field;
use crate::ftpd::Params;
use crate::render::run_plane;
use crate::render::{RenderOptions, RunStats};

/// Sample counts start, 2·start, …, up to max.
pub fn spp_levels(start: u32, max: u32) -> Result<Vec<u32>, ConvergeError> {
    if start == 0 {
        return Err(ConvergeError::NoSamples);
    }
    if max < start {
        return Err(ConvergeError::LevelsReversed { start, max });
    }
    let mut v = vec![start];
    while let Some(next) = v
        .last()
        .and_then(|s| s.checked_mul(2))
        .filter(|n| *n <= max)
    {
        v.push(next);
    }
    Ok(v)
}

/// Runs the levels of every weighting of `setup` and measures them (see the module
/// documentation); `say` gets one line per finished level. Returns the curves and each
/// weighting's top field.
pub fn measure(
    setup: &Setup,
    job: &ConvergeJob,
    mut say: impl FnMut(&str),
) -> anyhow::Result<(Vec<Curve>, Vec<Field>)> {
    let Some(&first) = setup.levels.first() else {
        return Err(ConvergeError::NoLevels.into());
    };
    let reference = setup.reference();
    let mut curves = Vec::new();
    let mut tops = Vec::new();
    for p in &setup.params {
        warm_up(setup, p, first, job)?;
        let (mut fields, runs) = run_levels(setup, p, job, &mut say)?;
        let top = fields.len() - 1;
        let mut out = Vec::new();
        for (k, ((spp, seed, stats), field)) in runs.into_iter().zip(&fields).enumerate() {
            let cmp = match reference {
                Some((_, r)) => Some(compare(field, r)),
                None if k == top => None,
                None => Some(compare(field, &fields[top])),
            };
            let run = (stats.seconds, stats.rays, stats.samples);
            out.push(Level::new(p.weighting, (spp, seed), run, field, cmp));
        }
        curves.push(Curve::new(p.weighting, out, false));
        tops.push(fields.pop().expect("at least one level"));
    }
    Ok((curves, tops))
}

/// Untimed warm-up with the first level's size: the first run of a process pays one-time costs
/// (thread start-up, first touches of the scene's memory) that are no part of the cost per
/// sample.
fn warm_up(setup: &Setup, p: &Params, first: u32, job: &ConvergeJob) -> anyhow::Result<()> {
    let warm = RenderOptions {
        spp: first,
        batches: 1,
        seed: job.seed.wrapping_sub(1),
        threads: job.threads,
        progress: false,
        ..Default::default()
    };
    run_plane(&setup.scene, &setup.plane, p, &warm)?;
    Ok(())
}

/// One weighting's levels, each a fresh run with its own seed, checked against the reference
/// when there is one: their fields and (spp, seed, run statistics).
#[allow(clippy::type_complexity)]
fn run_levels(
    setup: &Setup,
    p: &Params,
    job: &ConvergeJob,
    say: &mut impl FnMut(&str),
) -> anyhow::Result<(Vec<Field>, Vec<(u32, u64, RunStats)>)> {
    let mut fields = Vec::new();
    let mut runs = Vec::new();
    for (k, &spp) in setup.levels.iter().enumerate() {
        let opts = RenderOptions {
            spp,
            batches: job.batches.clamp(1, spp),
            seed: job.seed.wrapping_add(k as u64),
            threads: job.threads,
            progress: false,
            ..Default::default()
        };
        let (field, stats) = run_plane(&setup.scene, &setup.plane, p, &opts)?;
        if let Some((name, r)) = setup.reference() {
            crate::merge::check_same_run(name, r, "the converge run", &field)?;
        }
        say(&format!(
            "{:<10} {:>6} spp  seed {:<4} {:>8.3} s  {:.3e} rays",
            p.weighting.to_string(),
            spp,
            opts.seed,
            stats.seconds,
            stats.rays as f64
        ));
        runs.push((spp, opts.seed, stats));
        fields.push(field);
    }
    Ok((fields, runs))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn doubling_levels() {
        assert_eq!(spp_levels(4, 64).unwrap(), vec![4, 8, 16, 32, 64]);
        assert_eq!(spp_levels(3, 20).unwrap(), vec![3, 6, 12]);
        assert_eq!(spp_levels(5, 5).unwrap(), vec![5]);
        assert!(spp_levels(0, 8).is_err());
        assert!(spp_levels(8, 4).is_err());
    }
}
