//! The report of a convergence run: its levels and fits as CSV, and the log-log plot.

use super::curve::Curve;
use crate::ftpd::Weighting;
use crate::output::plot::{self, Line, Series};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The whole report.
#[derive(Clone, Debug)]
pub struct Report {
    pub curves: Vec<Curve>,
    /// The reference file, or `None` for self-references.
    pub reference: Option<PathBuf>,
    pub plane: String,
    pub grid: (usize, usize),
    pub scene: PathBuf,
    /// The baseline build whose curves are among `curves`.
    pub baseline: Option<PathBuf>,
}

/// The `binary` column: `baseline` or `this`.
fn binary_name(c: &Curve) -> &'static str {
    if c.baseline { "baseline" } else { "this" }
}

/// The levels as CSV: one row per run.
pub fn csv(report: &Report) -> String {
    let mut s = String::from(
        "weighting,spp,seed,seconds,rays,samples,cells,rmse,net_rmse,mean_rel_err,mean_stderr,reference,in_fit,binary\n",
    );
    let reference = match &report.reference {
        Some(p) => p.display().to_string().replace(',', ";"),
        None => String::new(),
    };
    for c in &report.curves {
        let top = c.levels.last().map_or(0, |l| l.spp);
        for l in &c.levels {
            let opt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.6e}"));
            let what = if report.reference.is_some() {
                reference.clone()
            } else if l.is_reference {
                "self-reference (this run; error excluded)".to_string()
            } else if report.baseline.is_some() && !c.baseline {
                format!("baseline's {top} spp run")
            } else {
                format!("self-reference ({top} spp run)")
            };
            let _ = writeln!(
                s,
                "{},{},{},{:.6},{},{},{},{},{},{},{:.6e},{},{},{}",
                l.weighting,
                l.spp,
                l.seed,
                l.seconds,
                l.rays,
                l.samples,
                l.cells,
                opt(l.rmse),
                opt(l.net_rmse),
                opt(l.mean_rel_err),
                l.mean_stderr,
                what,
                u8::from(l.net_rmse.is_some_and(|e| e > 0.0) && l.seconds > 0.0),
                binary_name(c)
            );
        }
    }
    s
}

/// The fits as CSV: one row per weighting.
pub fn fit_csv(report: &Report) -> String {
    let mut s = String::from(
        "weighting,points,slope_time,slope_time_se,slope_spp,slope_spp_se,time_per_doubling,reference,binary\n",
    );
    let reference = match &report.reference {
        Some(p) => p.display().to_string().replace(',', ";"),
        None if report.baseline.is_some() => "the baseline's highest spp run".into(),
        None => "self-reference (highest spp run)".into(),
    };
    for c in &report.curves {
        let f = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:.4}"));
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{}",
            c.weighting,
            c.fit_time.map_or(0, |f| f.points),
            f(c.fit_time.map(|f| f.slope)),
            f(c.fit_time.and_then(|f| f.slope_se)),
            f(c.fit_spp.map(|f| f.slope)),
            f(c.fit_spp.and_then(|f| f.slope_se)),
            f(c.time_per_doubling),
            reference,
            binary_name(c)
        );
    }
    s
}

const COLORS: [(u8, u8, u8); 3] = [(200, 60, 40), (40, 90, 200), (30, 150, 70)];

/// `c` mixed with white: lighter lines of the same hue.
fn lighter(c: (u8, u8, u8)) -> (u8, u8, u8) {
    (c.0 / 2 + 110, c.1 / 2 + 110, c.2 / 2 + 110)
}

/// The log-log plot: RMSE against seconds per weighting (markers), its fitted line (dashed), the
/// mean estimated standard error (thin), and a t^−½ line through the first curve. With a
/// baseline, each weighting's baseline curve is drawn in the same hue, darker, with square
/// markers, its slope in the legend.
pub fn plot(report: &Report, path: &Path, size: (u32, u32)) -> anyhow::Result<()> {
    let mut series = Vec::new();
    let (mut t_lo, mut t_hi) = (f64::INFINITY, 0.0f64);
    let mut hues: Vec<Weighting> = Vec::new();
    for c in &report.curves {
        if !hues.contains(&c.weighting) {
            hues.push(c.weighting);
        }
        let k = hues.iter().position(|w| *w == c.weighting).unwrap_or(0);
        let hue = COLORS[k % COLORS.len()];
        let color = if c.baseline {
            (hue.0 / 2, hue.1 / 2, hue.2 / 2)
        } else {
            hue
        };
        let pts = c.fit_points();
        for (t, _) in &pts {
            t_lo = t_lo.min(*t);
            t_hi = t_hi.max(*t);
        }
        let fit = c.fit_time.map_or(String::new(), |f| match f.slope_se {
            Some(se) => format!(", slope {:.2} ± {:.2}", f.slope, se),
            None => format!(", slope {:.2}", f.slope),
        });
        series.push(Series {
            label: format!("{} RMSE{fit}", c.label()),
            points: pts.clone(),
            color,
            line: if c.baseline {
                Line::Squares
            } else {
                Line::Markers
            },
        });
        if let (Some(f), Some(a), Some(b)) = (c.fit_time, pts.first(), pts.last()) {
            let line = |t: f64| (t, (f.intercept + f.slope * t.ln()).exp());
            series.push(Series {
                label: format!("{} fit", c.label()),
                points: vec![line(a.0), line(b.0)],
                color,
                line: Line::Dashed,
            });
        }
        if c.baseline {
            // One estimated-error line per weighting (this binary's) keeps the plot readable.
            continue;
        }
        series.push(Series {
            label: format!("{} mean est. stderr", c.label()),
            points: c
                .levels
                .iter()
                .filter(|l| !l.is_reference)
                .map(|l| (l.seconds, l.mean_stderr))
                .collect(),
            color: lighter(color),
            line: Line::Thin,
        });
    }
    if let Some(c) = report.curves.first() {
        let pts = c.fit_points();
        if !pts.is_empty() && t_hi > t_lo {
            // ln e = a − ½ ln t through the first curve's points (least squares with fixed slope).
            let a = pts.iter().map(|(t, e)| e.ln() + 0.5 * t.ln()).sum::<f64>() / pts.len() as f64;
            let at = |t: f64| (t, (a - 0.5 * t.ln()).exp());
            series.push(Series {
                label: "t^-1/2".into(),
                points: vec![at(t_lo), at(t_hi)],
                color: (90, 90, 90),
                line: Line::Dashed,
            });
        }
    }
    let reference = match &report.reference {
        Some(p) => format!(
            "reference {}",
            p.file_name().map_or(p.as_os_str(), |n| n).to_string_lossy()
        ),
        None if report.baseline.is_some() => "reference: baseline's highest spp run".into(),
        None => "self-reference: highest spp run".into(),
    };
    let scene = report
        .scene
        .file_name()
        .map_or(report.scene.as_os_str(), |n| n)
        .to_string_lossy()
        .into_owned();
    Ok(plot::write_loglog_png(
        path,
        size,
        &format!(
            "{scene} {} ({}x{}), {reference}",
            report.plane, report.grid.0, report.grid.1
        ),
        "wall time (s)",
        "error of FTPD σ",
        &series,
    )?)
}
