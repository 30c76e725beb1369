//! The equal-time report: per binary its runs' means, per candidate its efficiency over the
//! baseline's, as a Markdown table and as CSV.

use super::{Case, EqualTimeJob, RunResult};
use std::fmt::Write as _;

/// One binary's runs on one case, and (for a candidate) its efficiency over the baseline.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    pub runs: usize,
    pub spp: f64,
    pub compute: f64,
    pub wall: f64,
    pub cpu: Option<f64>,
    /// Mean over the runs of the squared error net of the reference's noise.
    pub net_mse: f64,
    /// Efficiency over the baseline by compute seconds: geometric mean over the rounds, the
    /// rounds' smallest and largest, and pooled (ratio of the means of RMSE²·t).
    pub ratio: Option<Ratio>,
    /// The same by CPU seconds.
    pub cpu_ratio: Option<Ratio>,
}

/// An efficiency ratio over rounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ratio {
    pub geo_mean: f64,
    pub min: f64,
    pub max: f64,
    pub pooled: f64,
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (n, s) = v.fold((0usize, 0.0), |(n, s), x| (n + 1, s + x));
    if n > 0 { s / n as f64 } else { 0.0 }
}

/// The ratio over rounds of the baseline's cost (RMSE² · `t`) to the candidate's, from runs
/// paired by round; `None` when a cost is not positive or not known.
pub fn ratio(
    base: &[&RunResult],
    cand: &[&RunResult],
    t: impl Fn(&RunResult) -> Option<f64>,
) -> Option<Ratio> {
    let cost = |r: &RunResult| {
        let c = r.net_mse * t(r)?;
        (c > 0.0 && c.is_finite()).then_some(c)
    };
    let mut per_round = Vec::new();
    let (mut sb, mut sc) = (0.0, 0.0);
    for (b, c) in base.iter().zip(cand) {
        let (cb, cc) = (cost(b)?, cost(c)?);
        per_round.push(cb / cc);
        sb += cb;
        sc += cc;
    }
    if per_round.is_empty() {
        return None;
    }
    let geo = mean(per_round.iter().map(|r| r.ln())).exp();
    Some(Ratio {
        geo_mean: geo,
        min: per_round.iter().copied().fold(f64::INFINITY, f64::min),
        max: per_round.iter().copied().fold(0.0, f64::max),
        pooled: sb / sc,
    })
}

/// Per binary of `job` (baseline first) its summary on `case`.
pub fn summarize(job: &EqualTimeJob, case: &Case) -> Vec<Summary> {
    let of = |j: usize| -> Vec<&RunResult> { case.runs.iter().filter(|r| r.binary == j).collect() };
    let base = of(0);
    (0..job.binaries().len())
        .map(|j| {
            let runs = of(j);
            let cpus: Option<Vec<f64>> = runs.iter().map(|r| r.cpu).collect();
            let (ratio, cpu_ratio) = if j == 0 {
                (None, None)
            } else {
                (
                    ratio(&base, &runs, |r| Some(r.compute)),
                    ratio(&base, &runs, |r| r.cpu),
                )
            };
            Summary {
                runs: runs.len(),
                spp: mean(runs.iter().map(|r| r.spp)),
                compute: mean(runs.iter().map(|r| r.compute)),
                wall: mean(runs.iter().map(|r| r.wall)),
                cpu: cpus.map(|c| mean(c.into_iter())),
                net_mse: mean(runs.iter().map(|r| r.net_mse)),
                ratio,
                cpu_ratio,
            }
        })
        .collect()
}

fn fmt_ratio(r: Option<Ratio>, range: bool) -> String {
    match r {
        None => "n/a".into(),
        Some(r) if range => format!("{:.2}x ({:.2}-{:.2})", r.geo_mean, r.min, r.max),
        Some(r) => format!("{:.2}x", r.pooled),
    }
}

/// The report: per case the reference, then a row per binary.
pub fn table(job: &EqualTimeJob, cases: &[Case]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} rounds of --time {}s per binary, {}² cells, slice {}; baseline {}\n",
        job.rounds, job.seconds, job.res, job.slice, job.baseline.label
    );
    s.push_str(
        "| scene | weighting | binary | spp | compute s | CPU s | RMSE² σ (net) | efficiency (rounds' range) | pooled | by CPU s |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    let bins = job.binaries();
    for case in cases {
        for (j, sum) in summarize(job, case).iter().enumerate() {
            let (ratio, pooled, cpu) = if j == 0 {
                ("1".into(), "1".into(), "1".into())
            } else {
                (
                    fmt_ratio(sum.ratio, true),
                    fmt_ratio(sum.ratio, false),
                    fmt_ratio(sum.cpu_ratio, true),
                )
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.0} | {:.2} | {} | {:.4e} | {ratio} | {pooled} | {cpu} |",
                case.scene,
                case.weighting,
                bins[j].label,
                sum.spp,
                sum.compute,
                sum.cpu.map_or("n/a".into(), |c| format!("{c:.2}")),
                sum.net_mse,
            );
        }
    }
    s.push('\n');
    for case in cases {
        let r = &case.reference;
        let base = summarize(job, case);
        let share = |j: usize| {
            let m = base[j].net_mse;
            if m > 0.0 {
                format!("{:.1} %", 100.0 * r.mean_var / m)
            } else {
                "n/a".into()
            }
        };
        let _ = writeln!(
            s,
            "- {} {}: reference {} ({:.0} spp, {:.1} s, seed {}), mean squared standard error \
             {:.3e} (taken out; {} of the baseline's RMSE², {} of the first candidate's); load {} -> {}",
            case.scene,
            case.weighting,
            r.path.display(),
            r.spp,
            r.compute,
            super::REFERENCE_SEED,
            r.mean_var,
            share(0),
            if base.len() > 1 {
                share(1)
            } else {
                "n/a".into()
            },
            case.load.0.map_or("n/a".into(), |l| format!("{l:.1}")),
            case.load.1.map_or("n/a".into(), |l| format!("{l:.1}")),
        );
    }
    s
}

/// Every run as CSV.
pub fn csv(job: &EqualTimeJob, cases: &[Case]) -> String {
    let bins = job.binaries();
    let mut s = String::from(
        "scene,weighting,binary,round,seed,budget_s,spp,compute_s,wall_s,cpu_s,mse,net_mse,ref_spp,ref_mean_var\n",
    );
    for c in cases {
        for r in &c.runs {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                c.scene,
                c.weighting,
                bins[r.binary].label,
                r.round,
                r.seed,
                r.budget,
                r.spp,
                r.compute,
                r.wall,
                r.cpu.map_or(String::new(), |v| v.to_string()),
                r.mse,
                r.net_mse,
                c.reference.spp,
                c.reference.mean_var
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(binary: usize, round: u32, net_mse: f64, compute: f64, cpu: f64) -> RunResult {
        RunResult {
            binary,
            round,
            seed: 0,
            budget: 10.0,
            spp: 0.0,
            compute,
            wall: compute,
            cpu: Some(cpu),
            mse: net_mse,
            net_mse,
        }
    }

    #[test]
    fn efficiency_is_the_ratio_of_error_times_time() {
        // Round 0: the baseline has 3x the squared error at the same time; round 1: 2x the
        // error, but the candidate ran 10 % longer. By CPU seconds the candidate got half the
        // CPU in round 1, which doubles its efficiency there.
        let base = [run(0, 0, 3.0, 10.0, 20.0), run(0, 1, 2.0, 10.0, 20.0)];
        let cand = [run(1, 0, 1.0, 10.0, 20.0), run(1, 1, 1.0, 11.0, 10.0)];
        let b: Vec<&RunResult> = base.iter().collect();
        let c: Vec<&RunResult> = cand.iter().collect();
        let r = ratio(&b, &c, |r| Some(r.compute)).unwrap();
        let r1 = 2.0 / 1.1;
        assert!(
            (r.min - r1).abs() < 1e-12 && (r.max - 3.0).abs() < 1e-12,
            "{r:?}"
        );
        assert!((r.geo_mean - (3.0 * r1).sqrt()).abs() < 1e-12, "{r:?}");
        assert!((r.pooled - 50.0 / 21.0).abs() < 1e-12, "{r:?}");
        let by_cpu = ratio(&b, &c, |r| r.cpu).unwrap();
        assert!((by_cpu.max - 4.0).abs() < 1e-12, "{by_cpu:?}");
        // A squared error the reference's noise cancels gives no ratio rather than infinity.
        let zero = [run(1, 0, 0.0, 10.0, 20.0), run(1, 1, 1.0, 10.0, 20.0)];
        let z: Vec<&RunResult> = zero.iter().collect();
        assert_eq!(ratio(&b, &z, |r| Some(r.compute)), None);
    }
}
