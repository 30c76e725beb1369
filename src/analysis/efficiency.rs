//! Efficiency against a baseline build (`ftpd3d efficiency`): the time each estimator needs to reach
//! the same error, measured on the same slices.
//!
//! Both estimators run as separate processes of their own binaries (the baseline is any older
//! build of this tool, the candidate normally this binary), with the same plain command line, so
//! that nothing of one leaks into the other. Per scene and weighting:
//! 1. an **independent reference**: the baseline's estimator with a seed no level uses and
//!    `ref_factor` × the largest level's samples per cell;
//! 2. each binary at doubling sample counts, every level with its own seed (as `converge`);
//! 3. per level, over the cells valid in both the level and the reference: the RMSE of σ with the
//!    reference's own estimated noise taken out ([`Comparison::net_rmse`]), the 95th percentile
//!    of |σ − σ_ref| / σ_ref over the cells with σ_ref > 0, and the variance of the z-scores
//!    (σ − σ_ref) / sqrt(se² + se_ref²), which is 1 when the standard errors are honest;
//! 4. per binary, least squares of ln(error) against ln(spp) gives the samples it needs for the
//!    baseline's error at its largest level, and its seconds per sample (pooled over its levels)
//!    turn them into time; their ratio is the speed-up at equal error (efficiency = 1 /
//!    (variance · time), so for slopes of −½ it is the ratio of the efficiencies). The slopes
//!    shown are those of ln(error) against ln(seconds).
//!
//! Times are the compute seconds the binaries store in their outputs (the scene load is left
//! out). On a shared machine they are noisy: compare ratios from one run.

use crate::analysis::binary::{SliceRun, run_slice, seconds};
use crate::analysis::converge::{Fit, compare, fit_line};
use crate::field::Field;
use crate::ftpd::Weighting;
use crate::output::write_atomically;
use anyhow::{Context, bail};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A field against a reference over the cells valid in both.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Errors {
    pub cells: usize,
    /// RMSE of σ without the reference's own estimated noise.
    pub net_rmse: f64,
    /// 95th percentile of |σ − σ_ref| / σ_ref over the cells with σ_ref > 0.
    pub p95_rel: f64,
    /// Variance of (σ − σ_ref) / sqrt(se² + se_ref²) over the cells where both have an error
    /// estimate (a standard error of 0 is none: see `Moments::has_estimate`).
    pub z_var: f64,
    /// The same over the cells the reference resolves: relative standard error ≤
    /// [`RESOLVED`]. Where the reference's own error is larger, its rare contributions (met by
    /// some runs and not others) make z-scores that judge the reference as much as the field.
    pub z_var_resolved: f64,
    /// How many cells `z_var_resolved` is over.
    pub resolved: usize,
}

/// The reference's relative standard error up to which [`Errors::z_var_resolved`] counts a cell.
pub const RESOLVED: f64 = 0.05;

/// Sample variance (n − 1) of the values whose (n, Σz, Σz²) are given; 0 below two values.
fn variance((n, s, s2): (usize, f64, f64)) -> f64 {
    if n > 1 {
        let m = s / n as f64;
        (s2 - n as f64 * m * m) / (n - 1) as f64
    } else {
        0.0
    }
}

/// The `q` quantile (0..=1) of `v` by nearest rank; 0 for an empty slice.
pub fn quantile(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    v[k]
}

/// Errors of `field` against `reference` (see the module documentation).
pub fn errors(field: &Field, reference: &Field) -> Errors {
    let c = compare(field, reference);
    let (a, b) = (field.values(), reference.values());
    let mut rel = Vec::new();
    let (mut all, mut resolved) = ((0usize, 0.0f64, 0.0f64), (0usize, 0.0f64, 0.0f64));
    for (x, r) in a.iter().zip(&b) {
        if !(x.valid && r.valid) {
            continue;
        }
        if r.sigma > 0.0 {
            rel.push((x.sigma - r.sigma).abs() / r.sigma);
        }
        if x.stderr > 0.0 && r.stderr > 0.0 {
            let se = (x.stderr * x.stderr + r.stderr * r.stderr).sqrt();
            let z = (x.sigma - r.sigma) / se;
            let add = |(n, s, s2): &mut (usize, f64, f64)| {
                *n += 1;
                *s += z;
                *s2 += z * z;
            };
            add(&mut all);
            if r.sigma > 0.0 && r.stderr <= RESOLVED * r.sigma {
                add(&mut resolved);
            }
        }
    }
    Errors {
        cells: c.cells,
        net_rmse: c.net_rmse(),
        p95_rel: quantile(&mut rel, 0.95),
        z_var: variance(all),
        z_var_resolved: variance(resolved),
        resolved: resolved.0,
    }
}

/// One level of one binary: samples per cell, compute seconds and its errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Level {
    pub spp: u32,
    pub seconds: f64,
    pub errors: Errors,
}

/// Least squares of ln(error) against ln(seconds) over the levels with a positive error.
pub fn fit_time(levels: &[Level], err: impl Fn(&Errors) -> f64) -> Option<Fit> {
    let pts: Vec<(f64, f64)> = levels
        .iter()
        .filter(|l| err(&l.errors) > 0.0 && l.seconds > 0.0)
        .map(|l| (l.seconds.ln(), err(&l.errors).ln()))
        .collect();
    fit_line(&pts)
}

/// Two-sided 95 % quantile of Student's t with `df` degrees of freedom (1.96 beyond 30).
pub fn t95(df: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => T[df - 1],
        _ => 1.96,
    }
}

/// Where the line `fit` reaches `target` (its ln-ln extrapolation); `None` for a line that does
/// not fall, or whose fall is not significant: with three or more levels the slope must lie below
/// zero by its 95 % confidence half-width (Student's t over the levels' scatter). An error that
/// barely moves over the levels (e.g. a 95th percentile stuck near 1 while most cells have not yet
/// seen a deflected pair) would otherwise extrapolate to absurd times.
pub fn time_to(fit: &Fit, target: f64) -> Option<f64> {
    let half_width = fit
        .slope_se
        .map_or(0.0, |se| t95(fit.points.saturating_sub(2)) * se);
    (fit.slope + half_width < 0.0 && target > 0.0)
        .then(|| ((target.ln() - fit.intercept) / fit.slope).exp())
}

/// The comparison of one error measure between the baseline and the candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Speedup {
    /// The baseline's error at its largest level (the error both are timed to).
    pub target: f64,
    pub base_seconds: Option<f64>,
    pub new_seconds: Option<f64>,
    pub base_slope: Option<f64>,
    pub new_slope: Option<f64>,
}

impl Speedup {
    /// Baseline seconds over candidate seconds at the same error.
    pub fn ratio(&self) -> Option<f64> {
        Some(self.base_seconds? / self.new_seconds?)
    }
}

/// Seconds per sample per cell, pooled over the levels (Σ seconds / Σ spp): less noisy than any
/// one level's time on a shared machine.
pub fn seconds_per_spp(levels: &[Level]) -> Option<f64> {
    let (t, n) = levels.iter().fold((0.0, 0.0), |(t, n), l| {
        (t + l.seconds, n + f64::from(l.spp))
    });
    (t > 0.0 && n > 0.0).then_some(t / n)
}

/// Samples per cell at which the ln-ln line of error against spp reaches `target`.
fn spp_to(levels: &[Level], err: impl Fn(&Errors) -> f64, target: f64) -> Option<f64> {
    let pts: Vec<(f64, f64)> = levels
        .iter()
        .filter(|l| err(&l.errors) > 0.0)
        .map(|l| (f64::from(l.spp).ln(), err(&l.errors).ln()))
        .collect();
    time_to(&fit_line(&pts)?, target)
}

/// Times both to the baseline's error at its largest level, measured by `err`: the samples each
/// needs for it (from its line of ln error against ln spp, which does not depend on the machine's
/// load) times its pooled seconds per sample ([`seconds_per_spp`]). The slopes are those of ln
/// error against ln seconds.
pub fn speedup(base: &[Level], new: &[Level], err: impl Fn(&Errors) -> f64 + Copy) -> Speedup {
    let target = base.last().map_or(0.0, |l| err(&l.errors));
    let secs = |lv: &[Level]| Some(spp_to(lv, err, target)? * seconds_per_spp(lv)?);
    Speedup {
        target,
        base_seconds: secs(base),
        new_seconds: secs(new),
        base_slope: fit_time(base, err).map(|f| f.slope),
        new_slope: fit_time(new, err).map(|f| f.slope),
    }
}

/// What [`run_efficiency`] measures.
#[derive(Clone, Debug)]
pub struct EfficiencyJob {
    /// The baseline binary (e.g. a build of 8ae9f4f) and the candidate binary.
    pub baseline: PathBuf,
    pub candidate: PathBuf,
    pub scenes: Vec<PathBuf>,
    pub slice: String,
    pub res: usize,
    pub weightings: Vec<Weighting>,
    pub start_spp: u32,
    pub max_spp: u32,
    /// The reference has this many times the largest level's samples.
    pub ref_factor: u32,
    pub threads: usize,
    /// Outputs of every run, reused when present (`--keep`), and `efficiency.csv`.
    pub work_dir: PathBuf,
    /// Reuse references already in `work_dir` (they depend only on scene, weighting, res, spp).
    pub keep_references: bool,
}

/// One row of the report: a scene and weighting, both binaries' levels and the speed-ups.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub weighting: Weighting,
    pub base: Vec<Level>,
    pub new: Vec<Level>,
    pub rmse: Speedup,
    pub p95: Speedup,
}

/// Seed of the reference runs: no level uses it (levels use 1, 2, ...).
pub const REFERENCE_SEED: u64 = 1_000_003;

/// Runs `bin` on one slice and reads its output back.
fn run_binary(
    bin: &Path,
    job: &EfficiencyJob,
    scene: &Path,
    weighting: Weighting,
    spp: u32,
    seed: u64,
    out: &Path,
) -> anyhow::Result<Field> {
    let run = SliceRun {
        scene,
        slice: &job.slice,
        res: job.res,
        window: None,
        weighting,
        spp,
        batches: spp.min(16),
        seed,
        threads: job.threads,
        extra: &[],
    };
    run_slice(bin, &run, out)
}

/// Runs every scene and weighting of `job` (see the module documentation); `say` gets one line
/// per finished run.
pub fn run_efficiency(job: &EfficiencyJob, mut say: impl FnMut(&str)) -> anyhow::Result<Vec<Row>> {
    let levels = crate::analysis::converge::spp_levels(job.start_spp, job.max_spp)?;
    if levels.len() < 2 {
        bail!("efficiency: at least two sample counts are needed to fit a slope");
    }
    std::fs::create_dir_all(&job.work_dir)
        .with_context(|| format!("{}: cannot create it", job.work_dir.display()))?;
    let mut rows = Vec::new();
    for scene in &job.scenes {
        let stem = scene
            .file_stem()
            .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        for &w in &job.weightings {
            let ref_spp = job.max_spp.saturating_mul(job.ref_factor);
            let ref_path = job
                .work_dir
                .join(format!("{stem}_{w}_r{}_ref{ref_spp}.exr", job.res));
            let reference = if job.keep_references && ref_path.exists() {
                crate::output::exr::read_exr(&ref_path)?
            } else {
                let f = run_binary(
                    &job.baseline,
                    job,
                    scene,
                    w,
                    ref_spp,
                    REFERENCE_SEED,
                    &ref_path,
                )?;
                say(&format!(
                    "{stem} {w}: reference {ref_spp} spp in {:.1} s",
                    seconds(&f, &ref_path)?
                ));
                f
            };
            // Levels interleaved (baseline, candidate, next level): a change of the machine's
            // load during the run hits both alike.
            let (mut base, mut new) = (Vec::new(), Vec::new());
            for (k, &spp) in levels.iter().enumerate() {
                for (tag, bin, v) in [
                    ("base", &job.baseline, &mut base),
                    ("new", &job.candidate, &mut new),
                ] {
                    let out = job.work_dir.join(format!("{stem}_{w}_{tag}_spp{spp}.exr"));
                    let f = run_binary(bin, job, scene, w, spp, 1 + k as u64, &out)?;
                    let l = Level {
                        spp,
                        seconds: seconds(&f, &out)?,
                        errors: errors(&f, &reference),
                    };
                    say(&format!(
                        "{stem} {w} {tag:>4} {spp:>5} spp {:>8.3} s  rmse {:.4e}  p95 rel {:.4}  z var {:.2} \
                         ({:.2} over the {} cells the reference resolves)",
                        l.seconds,
                        l.errors.net_rmse,
                        l.errors.p95_rel,
                        l.errors.z_var,
                        l.errors.z_var_resolved,
                        l.errors.resolved
                    ));
                    v.push(l);
                }
            }
            rows.push(Row {
                scene: stem.clone(),
                weighting: w,
                rmse: speedup(&base, &new, |e| e.net_rmse),
                p95: speedup(&base, &new, |e| e.p95_rel),
                base,
                new,
            });
        }
    }
    let mut csv = String::from(
        "scene,weighting,binary,spp,seconds,net_rmse,p95_rel,z_var,cells,z_var_resolved,resolved_cells\n",
    );
    for r in &rows {
        for (tag, lv) in [("base", &r.base), ("new", &r.new)] {
            for l in lv {
                let _ = writeln!(
                    csv,
                    "{},{},{tag},{},{},{},{},{},{},{},{}",
                    r.scene,
                    r.weighting,
                    l.spp,
                    l.seconds,
                    l.errors.net_rmse,
                    l.errors.p95_rel,
                    l.errors.z_var,
                    l.errors.cells,
                    l.errors.z_var_resolved,
                    l.errors.resolved
                );
            }
        }
    }
    write_atomically(&job.work_dir.join("efficiency.csv"), |tmp| {
        std::fs::write(tmp, &csv).with_context(|| format!("{}: cannot write", tmp.display()))
    })?;
    Ok(rows)
}

/// The report as a Markdown table: per scene, weighting and error measure, the seconds each
/// binary needs for the baseline's error at its largest level, their ratio, the slopes of ln error
/// against ln seconds, and the z variance of each binary's largest level, over all cells and (in
/// brackets) over the cells the reference resolves.
pub fn table(rows: &[Row]) -> String {
    let f = |v: Option<f64>, p: usize| v.map_or("n/a".to_string(), |x| format!("{x:.p$}"));
    let mut s = String::from(
        "| scene | weighting | error | target | base s | new s | speed-up | base slope | new slope | z var base (resolved) | z var new (resolved) |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let zvar = |lv: &[Level]| {
        lv.last().map_or("n/a".to_string(), |l| {
            format!("{:.2} ({:.2})", l.errors.z_var, l.errors.z_var_resolved)
        })
    };
    for r in rows {
        for (name, sp) in [("RMSE σ", &r.rmse), ("p95 rel", &r.p95)] {
            let _ = writeln!(
                s,
                "| {} | {} | {name} | {:.3e} | {} | {} | {} | {} | {} | {} | {} |",
                r.scene,
                r.weighting,
                sp.target,
                f(sp.base_seconds, 2),
                f(sp.new_seconds, 2),
                sp.ratio().map_or("n/a".to_string(), |r| format!("{r:.2}x")),
                f(sp.base_slope, 2),
                f(sp.new_slope, 2),
                zvar(&r.base),
                zvar(&r.new),
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantile_by_nearest_rank() {
        let mut v: Vec<f64> = (1..=100).rev().map(f64::from).collect();
        assert_eq!(quantile(&mut v, 0.95), 95.0);
        assert_eq!(quantile(&mut [3.0], 0.95), 3.0);
        assert_eq!(quantile(&mut [], 0.95), 0.0);
    }

    #[test]
    fn resolved_z_variance_leaves_out_what_the_reference_has_not_met() {
        // Cells 0..200 draw Δ uniform on [0, 1]; the reference takes 8192 samples there (relative
        // error about 1 %). Cells 200..400 draw, in 1 of 100 samples, a rare deflection of 15
        // instead, which carries most of E[Δ²]; the reference takes 16 samples there (relative
        // error ≥ 10 %), and most of its cells never meet the rare value. The field takes 512
        // samples everywhere.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut cell = |n: usize, rare: f64| {
            let mut m = crate::ftpd::moments::Moments::default();
            for _ in 0..n {
                let d = if uniform() < rare { 15.0 } else { uniform() };
                m.add_sample(1.0, d, crate::math::Rgb::ONE);
            }
            m
        };
        let (mut field, mut reference) = (Field::new(400, 1, 1), Field::new(400, 1, 1));
        for i in 0..400 {
            let (rare, n_ref) = if i < 200 { (0.0, 8192) } else { (0.01, 16) };
            field.cells[i] = cell(512, rare);
            reference.cells[i] = cell(n_ref, rare);
        }
        let e = errors(&field, &reference);
        let resolved = reference
            .values()
            .iter()
            .filter(|r| r.valid && r.sigma > 0.0 && r.stderr <= RESOLVED * r.sigma)
            .count();
        assert_eq!(e.resolved, resolved);
        assert_eq!(resolved, 200, "{e:?}");
        // Where the reference resolves σ, the z-scores have unit variance within three of its
        // standard errors (√(2/n) for normal z); over all cells the unresolved half inflates it.
        let tol = 3.0 * (2.0 / resolved as f64).sqrt();
        assert!((e.z_var_resolved - 1.0).abs() < tol, "{e:?}");
        assert!(e.z_var > 1.0 + tol, "{e:?}");
    }

    #[test]
    fn speedup_of_two_parallel_lines_is_their_time_ratio() {
        // Both cost 0.01 s per spp; the candidate's error is half the baseline's at every spp,
        // so it needs a quarter of the samples, and of the time, for the same error.
        let lv = |spp: u32, e: f64| Level {
            spp,
            seconds: 0.01 * f64::from(spp),
            errors: Errors {
                net_rmse: e / f64::from(spp).sqrt(),
                ..Default::default()
            },
        };
        let base: Vec<Level> = [4, 8, 16, 32].iter().map(|&n| lv(n, 2.0)).collect();
        let new: Vec<Level> = [4, 8, 16].iter().map(|&n| lv(n, 1.0)).collect();
        let s = speedup(&base, &new, |e| e.net_rmse);
        assert!((s.ratio().unwrap() - 4.0).abs() < 1e-9, "{s:?}");
        assert!((s.base_seconds.unwrap() - 0.32).abs() < 1e-9, "{s:?}");
        assert!((s.base_slope.unwrap() + 0.5).abs() < 1e-12);
    }

    #[test]
    fn an_error_that_barely_falls_gives_no_time() {
        // The stair wall's radiance-weighted 95th percentiles of `efficiency.sh --long` (128²,
        // 16..512 spp): 1 until the last level. Their fitted slopes (about −0.01 and −0.003)
        // extrapolated the baseline's 0.951 to 2·10⁶ s; the fall is within the levels' scatter.
        let spp = [16, 32, 64, 128, 256, 512];
        let lv = |p95: &[f64]| -> Vec<Level> {
            spp.iter()
                .zip(p95)
                .map(|(&n, &e)| Level {
                    spp: n,
                    seconds: 0.007 * f64::from(n),
                    errors: Errors {
                        p95_rel: e,
                        ..Default::default()
                    },
                })
                .collect()
        };
        let base = lv(&[1.0, 1.0, 1.0, 1.0, 1.0, 0.9514359910296352]);
        let new = lv(&[1.0, 1.0, 1.0, 1.0, 1.0, 0.9847834382088951]);
        let s = speedup(&base, &new, |e| e.p95_rel);
        assert_eq!(
            (s.base_seconds, s.new_seconds, s.ratio()),
            (None, None, None),
            "{s:?}"
        );
        // A line with the same scatter about a real fall keeps its time.
        let noisy = lv(&[0.5, 0.36, 0.24, 0.18, 0.12, 0.09]);
        assert!(speedup(&noisy, &noisy, |e| e.p95_rel).ratio().is_some());
        assert_eq!(t95(0), f64::INFINITY);
        assert_eq!(t95(4), 2.776);
        assert_eq!(t95(100), 1.96);
    }
}
