//! Convergence report (`ftpd3d converge`): error against time on log-log axes, so that a user sees
//! what one more digit of accuracy costs before paying for it.
//!
//! The slice is computed at doubling sample counts `start, 2·start, …, ≤ max`. **Seed policy:
//! every level is a fresh, independent run** with its own seed (`--seed` + level index), not a
//! continuation of the previous level. Independent levels have independent errors, so the points
//! of the curve are honest samples of the error at that cost, and the top level can serve as a
//! reference for the others without sharing their samples (a nested top level would contain the
//! lower levels' samples and make their errors look smaller than they are). The price is that the
//! levels together take about twice the time of the top level alone.
//!
//! Error of a level: against `--reference REF.exr` when given, else against the highest-sample
//! level of the same weighting (a **self-reference**: its own row has no error and is left out of
//! the fit; the others' errors then include the reference's own noise, which flattens the top
//! of the curve slightly, by √(1 + n/N) for n samples against the reference's N). Over the cells
//! valid in both: the root mean square of σ − σ_ref, and the mean of |σ − σ_ref| / σ_ref (cells
//! with σ_ref > 0). The mean of the run's own estimated standard error (batches) is reported too,
//! to show whether it tracks the measured error.
//!
//! Before each curve, one untimed warm-up run of the first level's size absorbs one-time costs.
//!
//! **`--baseline BIN`** (an older build of this tool, e.g. 8ae9f4f) draws the old and the new
//! estimator on one plot: both binaries run every level as separate processes on the same scene,
//! slice, grid and estimator flags, against one reference (see [`measure_binaries`]); the CSVs
//! gain a row per baseline level and fit (`binary` = `baseline`), the plot a darker curve per
//! weighting with its own slope, and every run's EXR stays in `runs/` of the output directory.
//!
//! The fit is ordinary least squares of ln(RMSE) against ln(wall seconds) (and against ln(spp)),
//! with the slope's standard error. Monte Carlo converges as t^−½ once the time is proportional
//! to the samples; fixed costs per run make small runs look cheaper than they are.

use crate::domain::{MAX_RES, Plane};
use crate::field::Field;
use crate::ftpd::{Params, Weighting};
use crate::output::plot::{self, Line, Series};
use crate::output::{check_writable, write_atomically, write_outputs};
use crate::render::RenderOptions;
use crate::run::{EstimatorArgs, run_plane};
use crate::scene::Scene;
use crate::scene::load::load_scene_with_lights;
use anyhow::{Context, bail};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What to run.
#[derive(Clone, Debug)]
pub struct ConvergeJob {
    pub scene: PathBuf,
    pub lights: Vec<crate::scene::Light>,
    pub slice: String,
    pub window: Option<[f64; 4]>,
    /// Cells along the longer side; `None`: the reference's, or 64.
    pub res: Option<usize>,
    pub reference: Option<PathBuf>,
    pub out_dir: PathBuf,
    /// `None`: the reference's weighting; without a reference, radiance and unweighted when the
    /// scene has lights, else unweighted.
    pub weighting: Option<Weighting>,
    /// Estimator settings (its weighting is replaced per curve).
    pub estimator: EstimatorArgs,
    pub start_spp: u32,
    pub max_spp: u32,
    pub batches: u32,
    pub seed: u64,
    pub threads: usize,
    pub quiet: bool,
    /// An older build of this tool: its curves are measured too, and drawn on the same plot
    /// (see [`measure_binaries`]).
    pub baseline: Option<PathBuf>,
    /// The estimator and light flags as given, passed on to both binaries with `--baseline`.
    pub forward_args: Vec<String>,
}

/// Default `--res` of a convergence run without a reference.
pub const DEFAULT_RES: usize = 64;

/// One run of the sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub weighting: Weighting,
    pub spp: u32,
    pub seed: u64,
    /// Wall time of the estimate (not the scene load).
    pub seconds: f64,
    /// Rays traced (0 for runs of `--baseline` mode, whose outputs do not store it).
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
    /// Measured with the `--baseline` binary (else with this one).
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

/// The whole report.
#[derive(Clone, Debug)]
pub struct Report {
    pub curves: Vec<Curve>,
    /// The reference file, or `None` for self-references.
    pub reference: Option<PathBuf>,
    pub plane: String,
    pub grid: (usize, usize),
    pub scene: PathBuf,
    /// The `--baseline` binary whose curves are among `curves`.
    pub baseline: Option<PathBuf>,
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

/// Sample counts start, 2·start, …, up to max.
pub fn spp_levels(start: u32, max: u32) -> anyhow::Result<Vec<u32>> {
    if start == 0 {
        bail!("--start-spp 0: at least one sample per cell is needed");
    }
    if max < start {
        bail!("--max-spp {max} is smaller than --start-spp {start}");
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

/// A run against a reference over the cells valid in both.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Comparison {
    pub cells: usize,
    /// Root mean square of σ − σ_ref.
    pub rmse: f64,
    /// Mean of |σ − σ_ref| / σ_ref over the cells with σ_ref > 0.
    pub mean_rel: f64,
    /// Mean of the reference's own estimated variance (stderr²): its share of rmse².
    pub ref_var: f64,
}

impl Comparison {
    /// The RMSE with the reference's own noise taken out: sqrt(max(0, rmse² − ref_var)).
    pub fn net_rmse(&self) -> f64 {
        (self.rmse * self.rmse - self.ref_var).max(0.0).sqrt()
    }
}

/// Compares `field` with `reference` over the cells valid in both.
pub fn compare(field: &Field, reference: &Field) -> Comparison {
    let (a, b) = (field.values(), reference.values());
    let (mut n, mut sq, mut var) = (0usize, 0.0f64, 0.0f64);
    let (mut nr, mut rel) = (0usize, 0.0f64);
    for (x, r) in a.iter().zip(&b) {
        if x.valid && r.valid {
            n += 1;
            sq += (x.sigma - r.sigma).powi(2);
            var += r.stderr * r.stderr;
            if r.sigma > 0.0 {
                nr += 1;
                rel += (x.sigma - r.sigma).abs() / r.sigma;
            }
        }
    }
    let nf = n.max(1) as f64;
    Comparison {
        cells: n,
        rmse: (sq / nf).sqrt(),
        mean_rel: if nr > 0 { rel / nr as f64 } else { 0.0 },
        ref_var: var / nf,
    }
}

/// Mean estimated standard error of σ over the valid cells.
pub fn mean_stderr(field: &Field) -> f64 {
    let (n, s) = field
        .values()
        .iter()
        .filter(|v| v.valid)
        .fold((0usize, 0.0), |(n, s), v| (n + 1, s + v.stderr));
    if n > 0 { s / n as f64 } else { 0.0 }
}

/// The curve of `levels` with its fits (see the module documentation).
fn curve_of(weighting: Weighting, levels: Vec<Level>, baseline: bool) -> Curve {
    let mut curve = Curve {
        weighting,
        baseline,
        levels,
        fit_time: None,
        fit_spp: None,
        time_per_doubling: None,
    };
    let ln =
        |v: &[(f64, f64)]| -> Vec<(f64, f64)> { v.iter().map(|(x, y)| (x.ln(), y.ln())).collect() };
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
        curve.time_per_doubling = Some((ratios.iter().sum::<f64>() / ratios.len() as f64).exp());
    }
    curve
}

/// Runs the levels of every weighting and measures them (see the module documentation).
/// `reference` is a named field of the same run; `say` gets one line per finished level.
pub fn measure(
    scene: &Scene,
    plane: &Plane,
    params: &[Params],
    reference: Option<(&str, &Field)>,
    levels: &[u32],
    job: &ConvergeJob,
    mut say: impl FnMut(&str),
) -> anyhow::Result<(Vec<Curve>, Vec<Field>)> {
    let Some(&first) = levels.first() else {
        bail!("converge: no sample counts to run");
    };
    let mut curves = Vec::new();
    let mut tops = Vec::new();
    for p in params {
        // Untimed warm-up with the first level's size: the first run of a process pays one-time
        // costs (thread start-up, first touches of the scene's memory) that are no part of the
        // cost per sample.
        let warm = RenderOptions {
            spp: first,
            batches: 1,
            seed: job.seed.wrapping_sub(1),
            threads: job.threads,
            progress: false,
            ..Default::default()
        };
        run_plane(scene, plane, p, &warm)?;
        let mut fields = Vec::new();
        let mut runs = Vec::new();
        for (k, &spp) in levels.iter().enumerate() {
            let opts = RenderOptions {
                spp,
                batches: job.batches.clamp(1, spp),
                seed: job.seed.wrapping_add(k as u64),
                threads: job.threads,
                progress: false,
                ..Default::default()
            };
            let (field, stats) = run_plane(scene, plane, p, &opts)?;
            if let Some((name, r)) = reference {
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
        let top = fields.len() - 1;
        let mut out = Vec::new();
        for (k, ((spp, seed, stats), field)) in runs.into_iter().zip(&fields).enumerate() {
            let self_ref = reference.is_none() && k == top;
            let cmp = match reference {
                Some((_, r)) => compare(field, r),
                None if self_ref => Comparison {
                    cells: field.valid().iter().filter(|v| **v).count(),
                    ..Comparison::default()
                },
                None => compare(field, &fields[top]),
            };
            out.push(Level {
                weighting: p.weighting,
                spp,
                seed,
                seconds: stats.seconds,
                rays: stats.rays,
                samples: stats.samples,
                cells: cmp.cells,
                rmse: (!self_ref).then_some(cmp.rmse),
                net_rmse: (!self_ref).then_some(cmp.net_rmse()),
                mean_rel_err: (!self_ref).then_some(cmp.mean_rel),
                mean_stderr: mean_stderr(field),
                is_reference: self_ref,
            });
        }
        curves.push(curve_of(p.weighting, out, false));
        tops.push(fields.pop().expect("at least one level"));
    }
    Ok((curves, tops))
}

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
fn measure_binaries(
    job: &ConvergeJob,
    baseline: &Path,
    plane: &Plane,
    weightings: &[Weighting],
    reference: Option<(&str, &Field)>,
    levels: &[u32],
    mut say: impl FnMut(&str),
) -> anyhow::Result<(Vec<Curve>, Vec<Field>)> {
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
            curves.push(curve_of(w, out, b == 0));
        }
        let [_, mut this_fields] = fields;
        tops.push(this_fields.pop().expect("at least one level").3);
    }
    Ok((curves, tops))
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

/// Runs a [`ConvergeJob`] end to end: runs, `converge.csv`, `converge_fit.csv`, `converge.png`,
/// and the top run of each weighting (of this binary) as `<weighting>_spp<N>.exr` in the output
/// directory.
pub fn run_converge(job: &ConvergeJob) -> anyhow::Result<Report> {
    let levels = spp_levels(job.start_spp, job.max_spp)?;
    if job.reference.is_none() && levels.len() < 3 {
        bail!(
            "--max-spp {}: a self-referenced report needs at least 3 levels (start, 2x, 4x); \
             raise --max-spp to {} or give --reference",
            job.max_spp,
            job.start_spp.saturating_mul(4)
        );
    }
    if let Some(r) = job.res
        && (r == 0 || r > MAX_RES)
    {
        bail!("--res {r}: must be between 1 and {MAX_RES}");
    }
    std::fs::create_dir_all(&job.out_dir)
        .with_context(|| format!("--out-dir {}: cannot create it", job.out_dir.display()))?;
    check_writable(&job.out_dir.join("converge.csv"))?;
    let reference = match &job.reference {
        Some(p) => {
            if !p.exists() {
                bail!("--reference {}: no such file", p.display());
            }
            Some(crate::output::exr::read_exr(p).with_context(|| "--reference")?)
        }
        None => None,
    };
    let scene = load_scene_with_lights(&job.scene, &job.lights)?;
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    let res = job.res.unwrap_or_else(|| {
        reference
            .as_ref()
            .map_or(DEFAULT_RES, |r| r.width.max(r.height))
    });
    let spec = crate::domain::slice::resolve_slice(&job.slice, &scene)?;
    let plane = Plane::axis_slice(&scene.bounds, spec, job.window, res)?;
    let weightings: Vec<Weighting> = match (job.weighting, &reference) {
        (Some(w), _) => vec![w],
        (None, Some(r)) => match r.info("--reference")?.weighting {
            Some(w @ (Weighting::Radiance | Weighting::Unweighted)) => vec![w],
            other => bail!(
                "--reference: weighting {} cannot be compared on a slice",
                other.map_or("(none)".into(), |w| w.to_string())
            ),
        },
        (None, None) if scene.lights.is_empty() => vec![Weighting::Unweighted],
        (None, None) => vec![Weighting::Radiance, Weighting::Unweighted],
    };
    if weightings.contains(&Weighting::Importance) {
        bail!("--weight importance needs a camera; converge runs on a slice");
    }
    let params = weightings
        .iter()
        .map(|w| {
            let mut e = job.estimator.clone();
            e.weighting = *w;
            e.resolve_for_plane(&scene, &plane)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let quiet = job.quiet;
    let say = |s: &str| {
        if !quiet {
            eprintln!("{s}");
        }
    };
    say(&format!(
        "converge: {} slice {} ({}x{} cells), spp {:?}, weighting {}, {}",
        job.scene.display(),
        plane.label,
        plane.width,
        plane.height,
        levels,
        weightings
            .iter()
            .map(Weighting::to_string)
            .collect::<Vec<_>>()
            .join(" and "),
        match (&job.reference, &job.baseline) {
            (Some(p), _) => format!("reference {}", p.display()),
            (None, Some(_)) => "reference: the baseline's highest spp run".into(),
            (None, None) => "self-reference (highest spp)".into(),
        }
    ));
    let ref_name = job
        .reference
        .as_ref()
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    let (curves, tops) = match &job.baseline {
        Some(b) => measure_binaries(
            job,
            b,
            &plane,
            &weightings,
            reference.as_ref().map(|r| (ref_name.as_str(), r)),
            &levels,
            say,
        )?,
        None => measure(
            &scene,
            &plane,
            &params,
            reference.as_ref().map(|r| (ref_name.as_str(), r)),
            &levels,
            job,
            say,
        )?,
    };
    let report = Report {
        curves,
        reference: job.reference.clone(),
        plane: plane.label.clone(),
        grid: (plane.width, plane.height),
        scene: job.scene.clone(),
        baseline: job.baseline.clone(),
    };
    for (name, text) in [
        ("converge.csv", csv(&report)),
        ("converge_fit.csv", fit_csv(&report)),
    ] {
        write_atomically(&job.out_dir.join(name), |tmp| {
            std::fs::write(tmp, &text).with_context(|| format!("{}: cannot write", tmp.display()))
        })?;
    }
    plot(&report, &job.out_dir.join("converge.png"), (800, 560))?;
    for (c, f) in report.curves.iter().filter(|c| !c.baseline).zip(&tops) {
        let top = c.levels.last().map_or(0, |l| l.spp);
        write_outputs(
            f,
            &job.out_dir.join(format!("{}_spp{top}.exr", c.weighting)),
            false,
        )?;
    }
    Ok(report)
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
