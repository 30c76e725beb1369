//! The measured levels of one weighting and the lines fitted through them.

use super::compare::{Comparison, mean_stderr};
use crate::field::Field;
use crate::ftpd::Weighting;

/// One run of the sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub weighting: Weighting,
    pub spp: u32,
    pub seed: u64,
    /// Wall time of the estimate (not the scene load).
    pub seconds: f64,
    /// Rays traced (0 for runs of another build, whose outputs do not store it).
    pub rays: u64,
    pub samples: u64,
    /// Cells valid in both this run and the reference.
    pub cells: usize,
    /// RMSE of σ against the reference; `None` for the self-reference run itself.
    pub rmse: Option<f64>,
    /// The RMSE without the reference's own estimated noise ([`Comparison::net_rmse`]): the
    /// error the fit and the plot use.
    pub net_rmse: Option<f64>,
    /// Mean relative error |σ − σ_ref| / σ_ref; `None` for the self-reference run.
    pub mean_rel_err: Option<f64>,
    /// Mean estimated standard error of σ over the run's valid cells.
    pub mean_stderr: f64,
    /// This run is the (self-)reference of its curve.
    pub is_reference: bool,
}

impl Level {
    /// The level of `field`, with the `seconds`, `rays` and `samples` of its run, measured by
    /// `cmp` against its curve's reference; `None`: the field is that reference (a self-reference:
    /// no error, left out of the fit).
    pub fn new(
        weighting: Weighting,
        (spp, seed): (u32, u64),
        (seconds, rays, samples): (f64, u64, u64),
        field: &Field,
        cmp: Option<Comparison>,
    ) -> Level {
        let self_ref = cmp.is_none();
        let cmp = cmp.unwrap_or_else(|| Comparison {
            cells: field.valid().iter().filter(|v| **v).count(),
            ..Comparison::default()
        });
        Level {
            weighting,
            spp,
            seed,
            seconds,
            rays,
            samples,
            cells: cmp.cells,
            rmse: (!self_ref).then_some(cmp.rmse),
            net_rmse: (!self_ref).then_some(cmp.net_rmse()),
            mean_rel_err: (!self_ref).then_some(cmp.mean_rel),
            mean_stderr: mean_stderr(field),
            is_reference: self_ref,
        }
    }
}

/// Least-squares line y = intercept + slope·x.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    pub points: usize,
    pub slope: f64,
    /// Standard error of the slope (`None` with only two points).
    pub slope_se: Option<f64>,
    pub intercept: f64,
}

/// Ordinary least squares on (x, y); `None` with fewer than two points or no spread in x.
pub fn fit_line(pts: &[(f64, f64)]) -> Option<Fit> {
    let n = pts.len();
    if n < 2 {
        return None;
    }
    let nf = n as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / nf;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / nf;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    if !(sxx > 0.0) {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let slope_se = (n > 2).then(|| {
        let ssr: f64 = pts
            .iter()
            .map(|p| (p.1 - intercept - slope * p.0).powi(2))
            .sum();
        (ssr / (nf - 2.0) / sxx).sqrt()
    });
    Some(Fit {
        points: n,
        slope,
        slope_se,
        intercept,
    })
}

/// The levels of one weighting with their fits.
#[derive(Clone, Debug)]
pub struct Curve {
    pub weighting: Weighting,
    /// Measured with a baseline build of the tool (else with this one).
    pub baseline: bool,
    pub levels: Vec<Level>,
    /// ln RMSE against ln seconds.
    pub fit_time: Option<Fit>,
    /// ln RMSE against ln spp.
    pub fit_spp: Option<Fit>,
    /// Geometric mean of the time ratio between successive levels (2 when time ∝ samples).
    pub time_per_doubling: Option<f64>,
}

impl Curve {
    /// (seconds, RMSE) of the levels that enter the fit.
    pub fn fit_points(&self) -> Vec<(f64, f64)> {
        self.levels
            .iter()
            .filter_map(|l| Some((l.seconds, l.net_rmse?)))
            .filter(|(t, e)| *t > 0.0 && *e > 0.0)
            .collect()
    }
}

impl Curve {
    /// The curve of `levels` with its fits (see the module documentation); `baseline`: measured
    /// with a baseline build.
    pub fn new(weighting: Weighting, levels: Vec<Level>, baseline: bool) -> Curve {
        let mut curve = Curve {
            weighting,
            baseline,
            levels,
            fit_time: None,
            fit_spp: None,
            time_per_doubling: None,
        };
        let ln = |v: &[(f64, f64)]| -> Vec<(f64, f64)> {
            v.iter().map(|(x, y)| (x.ln(), y.ln())).collect()
        };
        curve.fit_time = fit_line(&ln(&curve.fit_points()));
        let by_spp: Vec<(f64, f64)> = curve
            .levels
            .iter()
            .filter_map(|l| Some((l.spp as f64, l.net_rmse?)))
            .filter(|(_, e)| *e > 0.0)
            .collect();
        curve.fit_spp = fit_line(&ln(&by_spp));
        let ratios: Vec<f64> = curve
            .levels
            .windows(2)
            .filter(|w| w[0].seconds > 0.0 && w[1].seconds > 0.0)
            .map(|w| (w[1].seconds / w[0].seconds).ln())
            .collect();
        if !ratios.is_empty() {
            curve.time_per_doubling =
                Some((ratios.iter().sum::<f64>() / ratios.len() as f64).exp());
        }
        curve
    }
}

impl Curve {
    /// The weighting, with "(baseline)" for a curve of the baseline binary.
    pub fn label(&self) -> String {
        if self.baseline {
            format!("{} (baseline)", self.weighting)
        } else {
            self.weighting.to_string()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fit_recovers_a_line() {
        let pts: Vec<(f64, f64)> = (0..5)
            .map(|k| {
                (
                    k as f64,
                    1.0 - 0.5 * k as f64 + if k % 2 == 0 { 0.01 } else { -0.01 },
                )
            })
            .collect();
        let f = fit_line(&pts).unwrap();
        assert!((f.slope + 0.5).abs() < 0.01, "{f:?}");
        assert!(f.slope_se.unwrap() < 0.01);
        assert!(fit_line(&pts[..1]).is_none());
        assert_eq!(fit_line(&pts[..2]).unwrap().slope_se, None);
    }
}
