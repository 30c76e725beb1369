//! A field's errors against a reference, and the time each build needs for the same error.

use ftpd3d::analysis::converge::{Fit, compare, fit_line};
use ftpd3d::field::Field;

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
            let mut m = ftpd3d::ftpd::moments::Moments::default();
            for _ in 0..n {
                let d = if uniform() < rare { 15.0 } else { uniform() };
                m.add_sample(1.0, d, ftpd3d::math::Rgb::ONE);
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
        // 95th percentiles stuck at 1 until the last level (as radiance weighting gives while
        // most cells have not yet met a deflected pair): slopes near 0 would extrapolate the
        // baseline's last value to absurd times, and the fall is within the levels' scatter.
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
