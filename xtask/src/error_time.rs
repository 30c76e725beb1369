//! Error against time of several builds (`cargo xtask error-time`): the squared error of σ of
//! each build at a ladder of time budgets, against one cached independent reference, as a table,
//! a CSV and a log-log plot with a curve per build.
//!
//! It is `cargo xtask equal-time` at several budgets: the same reference (the same cache file and
//! seed), the same runs (a binary with `--time` and a seed of its own, its RMSE² of σ net of the
//! reference's noise, its compute and CPU seconds) and the same CSV columns; what it adds is the
//! ladder and the curves. Per round the budgets run in turn, every binary once at each budget
//! (A, B, C at 2.5 s, A, B, C at 5 s, ...), so a change of the machine's load hits the builds
//! alike; odd rounds walk the ladder downwards, so that a load that drifts during a round does not
//! fall on one end of every curve.
//!
//! The curves are the mean RMSE² of the runs at a budget (its square root on the plot) against
//! their mean CPU seconds (and, in a second plot, compute seconds); the slopes are least-squares
//! lines of ln RMSE against ln seconds over the budgets (−½ where the error falls as Monte Carlo
//! should).

use crate::equal_time::{
    Binary, Case, EqualTimeJob, RunResult, Slot, csv, label_of, measure_run, parse_binary, ratio,
    reference, slice_tag,
};
use anyhow::{Context, bail};
use clap::Args;
use ftpd3d::analysis::converge::{Fit, fit_line};
use ftpd3d::cli::args::WeightArg;
use ftpd3d::ftpd::Weighting;
use ftpd3d::output::plot::{Line, Series, write_loglog_png};
use ftpd3d::output::write_atomically;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// `cargo xtask error-time`: RMSE² of σ of several builds at a ladder of time budgets, rounds
/// interleaved, against one cached reference; a table, a CSV and log-log plots.
#[derive(Args, Debug, Clone)]
pub struct ErrorTimeArgs {
    /// A binary, as BIN or LABEL=BIN; repeatable, oldest first (the first is the one the
    /// efficiency ratios are over) [default: this tree's ftpd3d, built in release].
    #[arg(long, value_name = "[LABEL=]BIN")]
    binary: Vec<String>,
    /// The scene [default: the Cornell box].
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Axis-aligned slice plane.
    #[arg(long, value_name = "AXIS=VALUE", default_value = "z=0")]
    slice: String,
    /// Cells along the longer side.
    #[arg(long, default_value_t = 48)]
    res: usize,
    /// The weighting.
    #[arg(long = "weight", value_enum, default_value = "radiance")]
    weight: WeightArg,
    /// The ladder: time budgets (`--time` of the binaries) in seconds, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "2.5,5,10,20,40",
        value_name = "S,S,..."
    )]
    seconds: Vec<f64>,
    /// Rounds; each runs every binary once at every budget.
    #[arg(long, default_value_t = 3)]
    rounds: u32,
    /// The reference's time budget, seconds [default: equal-time's 16 × 10 s, whose cached
    /// reference it shares in the same work directory].
    #[arg(long, default_value_t = 160.0)]
    ref_seconds: f64,
    /// The binary that computes the reference [default: the last --binary].
    #[arg(long, value_name = "BIN")]
    reference_bin: Option<PathBuf>,
    /// Worker threads of every run [default: all cores].
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Directory for the cached reference, every run's EXR and error-time.csv [default:
    /// <target>/equal-time, the references of equal-time].
    #[arg(long, value_name = "DIR")]
    work_dir: Option<PathBuf>,
    /// The plot by CPU seconds (PNG); the plot by compute seconds goes beside it with
    /// `-compute` in its name [default: <work dir>/error-time.png].
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Run nothing: the table and the plots from the error-time.csv of an earlier run.
    #[arg(long, value_name = "CSV")]
    from_csv: Option<PathBuf>,
    /// Compute the reference again even when the work directory has it.
    #[arg(long)]
    fresh_reference: bool,
    /// No per-run lines.
    #[arg(short, long)]
    quiet: bool,
}

/// The runs of every binary at every budget of the ladder: `rounds` rounds, each every budget in
/// turn (upwards in even rounds, downwards in odd ones) and at each budget every binary in order.
/// Every run has a seed of its own: 1, 2, 3, ... in the order they run.
pub fn ladder(budgets: &[f64], rounds: u32, binaries: usize) -> Vec<Slot> {
    let mut slots = Vec::new();
    for round in 0..rounds {
        let order: Vec<f64> = if round % 2 == 0 {
            budgets.to_vec()
        } else {
            budgets.iter().rev().copied().collect()
        };
        for budget in order {
            for binary in 0..binaries {
                slots.push(Slot {
                    binary,
                    round,
                    seed: 1 + slots.len() as u64,
                    budget,
                });
            }
        }
    }
    slots
}

/// What the table and the plots are made from: the binaries' labels (the first is the one the
/// ratios are over) and every run.
#[derive(Clone, Debug)]
pub struct Measured {
    pub scene: String,
    pub weighting: String,
    pub labels: Vec<String>,
    pub runs: Vec<RunResult>,
}

/// The runs of one binary at one budget.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    pub binary: usize,
    pub budget: f64,
    pub runs: usize,
    pub spp: f64,
    pub compute: f64,
    pub cpu: Option<f64>,
    /// Mean of the runs' RMSE² net of the reference's noise.
    pub net_mse: f64,
}

impl Point {
    /// The RMSE of the point (None where the reference's noise took all of the squared error).
    pub fn rmse(&self) -> Option<f64> {
        (self.net_mse > 0.0).then(|| self.net_mse.sqrt())
    }
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (n, s) = v.fold((0usize, 0.0), |(n, s), x| (n + 1, s + x));
    if n > 0 { s / n as f64 } else { 0.0 }
}

/// The budgets of `runs`, ascending, each once.
fn budgets(runs: &[RunResult]) -> Vec<f64> {
    let mut b: Vec<f64> = runs.iter().map(|r| r.budget).collect();
    b.sort_by(f64::total_cmp);
    b.dedup();
    b
}

/// The runs of binary `j` at `budget`, by round.
fn runs_of(runs: &[RunResult], j: usize, budget: f64) -> Vec<&RunResult> {
    let mut v: Vec<&RunResult> = runs
        .iter()
        .filter(|r| r.binary == j && r.budget == budget)
        .collect();
    v.sort_by_key(|r| r.round);
    v
}

/// Per binary (in order) and budget (ascending) the means of its runs.
pub fn points(m: &Measured) -> Vec<Point> {
    let mut out = Vec::new();
    for j in 0..m.labels.len() {
        for b in budgets(&m.runs) {
            let runs = runs_of(&m.runs, j, b);
            if runs.is_empty() {
                continue;
            }
            let cpus: Option<Vec<f64>> = runs.iter().map(|r| r.cpu).collect();
            out.push(Point {
                binary: j,
                budget: b,
                runs: runs.len(),
                spp: mean(runs.iter().map(|r| r.spp)),
                compute: mean(runs.iter().map(|r| r.compute)),
                cpu: cpus.map(|c| mean(c.into_iter())),
                net_mse: mean(runs.iter().map(|r| r.net_mse)),
            });
        }
    }
    out
}

/// Least-squares line of ln RMSE against ln `t` over a binary's points (those with an RMSE and
/// a positive time).
pub fn slope(points: &[Point], j: usize, t: impl Fn(&Point) -> Option<f64>) -> Option<Fit> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.binary == j)
        .filter_map(|p| Some((t(p).filter(|t| *t > 0.0)?.ln(), p.rmse()?.ln())))
        .collect();
    fit_line(&pts)
}

fn fmt_fit(f: Option<Fit>) -> String {
    match f {
        None => "n/a".into(),
        Some(Fit {
            slope,
            slope_se: Some(se),
            ..
        }) => format!("{slope:.3} ± {se:.3}"),
        Some(f) => format!("{:.3}", f.slope),
    }
}

/// The report: a row per binary and budget (with the efficiency over the first binary at that
/// budget, pooled over the rounds: the ratio of the means of RMSE²·t), then the slopes.
pub fn table(m: &Measured) -> String {
    let pts = points(m);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} {}: RMSE² of σ net of the reference's noise; efficiency over {} at the same budget \
         (pooled over the rounds)\n",
        m.scene, m.weighting, m.labels[0]
    );
    s.push_str(
        "| binary | --time s | runs | spp | compute s | CPU s | RMSE² σ (net) | RMSE σ | efficiency by compute s | by CPU s |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for p in &pts {
        let base = runs_of(&m.runs, 0, p.budget);
        let own = runs_of(&m.runs, p.binary, p.budget);
        let by = |t: &dyn Fn(&RunResult) -> Option<f64>| -> String {
            if p.binary == 0 {
                return "1".into();
            }
            ratio(&base, &own, t).map_or("n/a".into(), |r| format!("{:.2}x", r.pooled))
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.0} | {:.2} | {} | {:.4e} | {} | {} | {} |",
            m.labels[p.binary],
            p.budget,
            p.runs,
            p.spp,
            p.compute,
            p.cpu.map_or("n/a".into(), |c| format!("{c:.2}")),
            p.net_mse,
            p.rmse().map_or("n/a".into(), |r| format!("{r:.4}")),
            by(&|r| Some(r.compute)),
            by(&|r| r.cpu),
        );
    }
    s.push_str("\n| binary | slope of ln RMSE vs ln compute s | vs ln CPU s |\n|---|---|---|\n");
    for (j, label) in m.labels.iter().enumerate() {
        let _ = writeln!(
            s,
            "| {label} | {} | {} |",
            fmt_fit(slope(&pts, j, |p| Some(p.compute))),
            fmt_fit(slope(&pts, j, |p| p.cpu)),
        );
    }
    s
}

/// Colours of the curves in the order of the binaries: the older builds grey and blue, the last
/// one red.
fn colour(j: usize, n: usize) -> (u8, u8, u8) {
    const OLDER: [(u8, u8, u8); 4] = [
        (110, 110, 110),
        (31, 119, 180),
        (44, 160, 44),
        (148, 103, 189),
    ];
    if j + 1 == n {
        (214, 39, 40)
    } else {
        OLDER[j % OLDER.len()]
    }
}

/// The series of a plot of RMSE against `t`: a curve per binary with its slope in the legend,
/// and a dashed line of slope −½ through the first binary's first point, for the eye.
pub fn series(m: &Measured, t: impl Fn(&Point) -> Option<f64> + Copy) -> Vec<Series> {
    let pts = points(m);
    let mut out: Vec<Series> = m
        .labels
        .iter()
        .enumerate()
        .map(|(j, label)| {
            let fit = slope(&pts, j, t);
            // By CPU seconds a loaded machine can give a larger budget fewer seconds: the line
            // joins the points in the order of their time.
            let mut points: Vec<(f64, f64)> = pts
                .iter()
                .filter(|p| p.binary == j)
                .filter_map(|p| Some((t(p)?, p.rmse()?)))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series {
                label: match fit {
                    Some(f) => format!("{label}: slope {:.2}", f.slope),
                    None => label.clone(),
                },
                points,
                color: colour(j, m.labels.len()),
                line: if j + 1 == m.labels.len() {
                    Line::Markers
                } else {
                    Line::Squares
                },
            }
        })
        .collect();
    let xs: Vec<f64> = out
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .collect();
    if let (Some(&(x0, y0)), Some(lo), Some(hi)) = (
        out.first().and_then(|s| s.points.first()),
        xs.iter().copied().reduce(f64::min),
        xs.iter().copied().reduce(f64::max),
    ) {
        let at = |x: f64| (x, y0 * (x / x0).powf(-0.5));
        out.push(Series {
            label: "slope -1/2".into(),
            points: vec![at(lo), at(hi)],
            color: (160, 160, 160),
            line: Line::Dashed,
        });
    }
    out
}

/// Writes the plot by CPU seconds to `path` and the plot by compute seconds beside it.
fn plot(m: &Measured, path: &Path) -> anyhow::Result<PathBuf> {
    let title = format!("{} {}: error against time", m.scene, m.weighting);
    write_loglog_png(
        path,
        (900, 600),
        &title,
        "CPU seconds per run",
        "RMSE of σ (net of the reference)",
        &series(m, |p| p.cpu),
    )?;
    let stem = path
        .file_stem()
        .map_or("error-time".into(), |s| s.to_string_lossy().into_owned());
    let compute = path.with_file_name(format!("{stem}-compute.png"));
    write_loglog_png(
        &compute,
        (900, 600),
        &title,
        "compute seconds per run",
        "RMSE of σ (net of the reference)",
        &series(m, |p| Some(p.compute)),
    )?;
    Ok(compute)
}

/// Reads the CSV of an earlier run (the columns of equal-time's, one scene and weighting).
pub fn parse_csv(text: &str) -> anyhow::Result<Measured> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().context("an empty CSV")?.split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .with_context(|| format!("the CSV has no column {name}"))
    };
    let [
        scene,
        weighting,
        binary,
        round,
        seed,
        budget,
        spp,
        compute,
        wall,
        cpu,
        mse,
        net,
    ] = [
        "scene",
        "weighting",
        "binary",
        "round",
        "seed",
        "budget_s",
        "spp",
        "compute_s",
        "wall_s",
        "cpu_s",
        "mse",
        "net_mse",
    ]
    .map(col);
    let (scene, weighting, binary, round, seed, budget) =
        (scene?, weighting?, binary?, round?, seed?, budget?);
    let (spp, compute, wall, cpu, mse, net) = (spp?, compute?, wall?, cpu?, mse?, net?);
    let mut m = Measured {
        scene: String::new(),
        weighting: String::new(),
        labels: Vec::new(),
        runs: Vec::new(),
    };
    for (i, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let v: Vec<&str> = line.split(',').collect();
        if v.len() != header.len() {
            bail!(
                "line {}: {} fields, the header has {}",
                i + 2,
                v.len(),
                header.len()
            );
        }
        let num = |k: usize| -> anyhow::Result<f64> {
            v[k].parse()
                .with_context(|| format!("line {}: {} is not a number: {}", i + 2, header[k], v[k]))
        };
        if m.labels.is_empty() {
            m.scene = v[scene].to_string();
            m.weighting = v[weighting].to_string();
        } else if v[scene] != m.scene || v[weighting] != m.weighting {
            bail!(
                "line {}: a second scene or weighting ({} {})",
                i + 2,
                v[scene],
                v[weighting]
            );
        }
        let j = match m.labels.iter().position(|l| l == v[binary]) {
            Some(j) => j,
            None => {
                m.labels.push(v[binary].to_string());
                m.labels.len() - 1
            }
        };
        m.runs.push(RunResult {
            binary: j,
            round: num(round)? as u32,
            seed: num(seed)? as u64,
            budget: num(budget)?,
            spp: num(spp)?,
            compute: num(compute)?,
            wall: num(wall)?,
            cpu: if v[cpu].is_empty() {
                None
            } else {
                Some(num(cpu)?)
            },
            mse: num(mse)?,
            net_mse: num(net)?,
        });
    }
    if m.runs.is_empty() {
        bail!("the CSV has no runs");
    }
    Ok(m)
}

/// Runs the ladder (or reads an earlier run's CSV), prints the table and writes the plots.
pub fn run(args: &ErrorTimeArgs) -> anyhow::Result<()> {
    let work_dir = match &args.work_dir {
        Some(d) => d.clone(),
        None => crate::target_dir()?.join("equal-time"),
    };
    let m = match &args.from_csv {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("--from-csv {}: cannot read it", path.display()))?;
            parse_csv(&text).with_context(|| format!("--from-csv {}", path.display()))?
        }
        None => measure(args, &work_dir)?,
    };
    let plot_path = args
        .plot
        .clone()
        .unwrap_or_else(|| work_dir.join("error-time.png"));
    if let Some(dir) = plot_path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create it", dir.display()))?;
    }
    let compute = plot(&m, &plot_path)?;
    print!("{}", table(&m));
    println!(
        "\nplots: {} (by CPU seconds), {} (by compute seconds)",
        plot_path.display(),
        compute.display()
    );
    Ok(())
}

/// Runs every slot of the ladder against the reference; writes error-time.csv.
fn measure(args: &ErrorTimeArgs, work_dir: &Path) -> anyhow::Result<Measured> {
    if args.seconds.is_empty() || args.seconds.iter().any(|s| !(*s > 0.0 && s.is_finite())) {
        bail!("--seconds: every budget must be a positive number of seconds");
    }
    if args.rounds == 0 || args.ref_seconds.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        bail!("--rounds and --ref-seconds must be positive");
    }
    let w = Weighting::from(args.weight);
    if w == Weighting::Importance {
        bail!("--weight importance needs a camera; error-time runs on slices");
    }
    let mut bins = Vec::new();
    for b in &args.binary {
        let b = parse_binary(b);
        crate::existing("--binary", &b.path)?;
        bins.push(b);
    }
    if bins.is_empty() {
        bins.push(Binary {
            label: "this tree".into(),
            path: crate::candidate(None)?,
        });
    }
    let reference_bin = match &args.reference_bin {
        Some(b) => crate::existing("--reference-bin", b)?,
        None => bins[bins.len() - 1].path.clone(),
    };
    let scene = args
        .scene
        .clone()
        .unwrap_or_else(|| crate::workspace_root().join("scenes/cornell_mirror.obj"));
    let scene = crate::existing("--scene", &scene)?;
    let stem = label_of(&scene.with_extension(""));
    let job = EqualTimeJob {
        baseline: bins[0].clone(),
        candidates: bins[1..].to_vec(),
        reference_bin,
        scenes: vec![scene.clone()],
        slice: args.slice.clone(),
        res: args.res,
        weightings: vec![w],
        seconds: 0,
        rounds: args.rounds,
        ref_factor: 0,
        threads: args.threads,
        work_dir: work_dir.to_path_buf(),
        fresh_references: args.fresh_reference,
    };
    let say = |s: &str| {
        if !args.quiet {
            eprintln!("{s}");
        }
    };
    let runs_dir = work_dir.join("runs");
    std::fs::create_dir_all(&runs_dir)
        .with_context(|| format!("{}: cannot create it", runs_dir.display()))?;
    let mut say_ref = say;
    let reference = reference(&job, &scene, &stem, w, args.ref_seconds, &mut say_ref)?;
    let load0 = crate::cost::load_average();
    let mut runs = Vec::new();
    for slot in ladder(&args.seconds, args.rounds, bins.len()) {
        let label = &bins[slot.binary].label;
        let out = runs_dir.join(format!(
            "{stem}_{}_{w}_r{}_{label}_t{}_round{}.exr",
            slice_tag(&job.slice),
            job.res,
            slot.budget,
            slot.round
        ));
        let r = measure_run(&job, &scene, w, &slot, &out, &reference)?;
        say(&format!(
            "round {} {:>6} s {:>14}: {:>7.0} spp, {:.2} s compute, {} CPU s, RMSE² {:.4e} (net {:.4e})",
            r.round,
            r.budget,
            label,
            r.spp,
            r.compute,
            r.cpu.map_or("n/a".into(), |c| format!("{c:.2}")),
            r.mse,
            r.net_mse
        ));
        runs.push(r);
    }
    let case = Case {
        scene: stem.clone(),
        weighting: w,
        reference,
        runs,
        load: (load0, crate::cost::load_average()),
    };
    say(&format!(
        "reference {}: {:.0} spp, mean squared standard error {:.4e}; load {} -> {}",
        case.reference.path.display(),
        case.reference.spp,
        case.reference.mean_var,
        case.load.0.map_or("n/a".into(), |l| format!("{l:.1}")),
        case.load.1.map_or("n/a".into(), |l| format!("{l:.1}")),
    ));
    let csv_path = work_dir.join("error-time.csv");
    let text = csv(&job, std::slice::from_ref(&case));
    write_atomically(&csv_path, |tmp| {
        std::fs::write(tmp, &text).with_context(|| format!("{}: cannot write", tmp.display()))
    })?;
    say(&format!("wrote {}", csv_path.display()));
    Ok(Measured {
        scene: stem,
        weighting: w.to_string(),
        labels: bins.into_iter().map(|b| b.label).collect(),
        runs: case.runs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use ftpd3d::analysis::converge::Comparison;

    #[test]
    fn the_ladder_interleaves_binaries_and_turns_every_other_round() {
        let s = ladder(&[2.5, 5.0, 10.0], 2, 2);
        let order: Vec<(u32, f64, usize)> =
            s.iter().map(|s| (s.round, s.budget, s.binary)).collect();
        assert_eq!(
            order,
            [
                (0, 2.5, 0),
                (0, 2.5, 1),
                (0, 5.0, 0),
                (0, 5.0, 1),
                (0, 10.0, 0),
                (0, 10.0, 1),
                (1, 10.0, 0),
                (1, 10.0, 1),
                (1, 5.0, 0),
                (1, 5.0, 1),
                (1, 2.5, 0),
                (1, 2.5, 1),
            ]
        );
        // Every run its own seed, none the reference's.
        let seeds: Vec<u64> = s.iter().map(|s| s.seed).collect();
        assert_eq!(seeds, (1..=12).collect::<Vec<u64>>());
        assert!(!seeds.contains(&crate::equal_time::REFERENCE_SEED));
    }

    #[test]
    fn budgets_become_time_flags_every_build_parses() {
        use crate::equal_time::time_flag;
        assert_eq!(time_flag(10.0), "10s");
        assert_eq!(time_flag(160.0), "160s");
        assert_eq!(time_flag(2.5), "2500ms");
        assert_eq!(time_flag(0.125), "125ms");
    }

    #[test]
    fn the_reference_noise_comes_out_of_the_squared_error() {
        use crate::equal_time::squared_errors;
        // RMSE 0.5 against a reference whose own variance is 0.05: 0.25 of which 0.05 is its.
        let c = Comparison {
            cells: 10,
            rmse: 0.5,
            mean_rel: 0.0,
            ref_var: 0.05,
        };
        let (mse, net) = squared_errors(&c);
        assert!((mse - 0.25).abs() < 1e-15 && (net - 0.2).abs() < 1e-15);
        // A run closer to the reference than the reference's noise: negative, not clamped, so
        // that the mean over runs stays unbiased; its point then has no RMSE to plot.
        let (_, net) = squared_errors(&Comparison { rmse: 0.1, ..c });
        assert!((net + 0.04).abs() < 1e-15);
        let p = Point {
            binary: 0,
            budget: 1.0,
            runs: 1,
            spp: 1.0,
            compute: 1.0,
            cpu: None,
            net_mse: net,
        };
        assert_eq!(p.rmse(), None);
    }

    fn run(binary: usize, round: u32, budget: f64, net_mse: f64, cpu: f64) -> RunResult {
        RunResult {
            binary,
            round,
            seed: 0,
            budget,
            spp: 100.0 * budget,
            compute: budget,
            wall: budget,
            cpu: Some(cpu),
            mse: net_mse + 0.01,
            net_mse,
        }
    }

    /// Two binaries, the second with a quarter of the first's squared error at every budget, both
    /// falling as Monte Carlo should (RMSE² ∝ 1/t); the second got 1.5x the CPU seconds.
    fn measured() -> Measured {
        let mut runs = Vec::new();
        for round in 0..2 {
            for b in [2.5, 5.0, 10.0, 20.0] {
                runs.push(run(0, round, b, 1.0 / b, 2.0 * b));
                runs.push(run(1, round, b, 0.25 / b, 3.0 * b));
            }
        }
        Measured {
            scene: "cornell_mirror".into(),
            weighting: "radiance".into(),
            labels: vec!["old".into(), "new".into()],
            runs,
        }
    }

    #[test]
    fn points_slopes_and_ratios_of_a_ladder() {
        let m = measured();
        let pts = points(&m);
        assert_eq!(pts.len(), 8);
        assert_eq!((pts[0].binary, pts[0].budget, pts[0].runs), (0, 2.5, 2));
        assert_eq!((pts[4].binary, pts[4].budget), (1, 2.5));
        for j in 0..2 {
            for fit in [
                slope(&pts, j, |p| Some(p.compute)),
                slope(&pts, j, |p| p.cpu),
            ] {
                let f = fit.unwrap();
                assert!((f.slope + 0.5).abs() < 1e-12, "{f:?}");
            }
        }
        let t = table(&m);
        // 4x by compute seconds, 4/1.5 by CPU seconds, at every budget.
        let row = t.lines().find(|l| l.starts_with("| new | 10 |")).unwrap();
        assert!(row.ends_with("| 4.00x | 2.67x |"), "{row}");
        assert!(
            t.contains("| new | -0.500 ± 0.000 | -0.500 ± 0.000 |"),
            "{t}"
        );
        // A curve per binary and the guide line; the last binary drawn with circles.
        let s = series(&m, |p| p.cpu);
        assert_eq!(s.len(), 3);
        assert_eq!(s[1].line, Line::Markers);
        assert_eq!(s[1].points.len(), 4);
        assert!(s[1].label.contains("slope -0.50"), "{}", s[1].label);
    }

    #[test]
    fn the_csv_reads_back_what_equal_time_writes() {
        let m = measured();
        // The CSV equal-time's report writes, from the same runs.
        let job = EqualTimeJob {
            baseline: Binary {
                label: "old".into(),
                path: "/bin/old".into(),
            },
            candidates: vec![Binary {
                label: "new".into(),
                path: "/bin/new".into(),
            }],
            reference_bin: "/bin/new".into(),
            scenes: vec![],
            slice: "z=0".into(),
            res: 8,
            weightings: vec![Weighting::Radiance],
            seconds: 0,
            rounds: 2,
            ref_factor: 0,
            threads: 1,
            work_dir: "/tmp".into(),
            fresh_references: false,
        };
        let case = Case {
            scene: m.scene.clone(),
            weighting: Weighting::Radiance,
            reference: crate::equal_time::Reference {
                path: "/tmp/ref.exr".into(),
                field: ftpd3d::field::Field::new(1, 1, 1),
                spp: 1000.0,
                compute: 160.0,
                cpu: None,
                mean_var: 0.01,
                cached: true,
            },
            runs: m.runs.clone(),
            load: (None, None),
        };
        let back = parse_csv(&csv(&job, &[case])).unwrap();
        assert_eq!(
            (back.scene.as_str(), back.weighting.as_str()),
            ("cornell_mirror", "radiance")
        );
        assert_eq!(back.labels, m.labels);
        assert_eq!(points(&back), points(&m));
        // Errors name the line.
        let bad = "scene,weighting,binary,round,seed,budget_s,spp,compute_s,wall_s,cpu_s,mse,net_mse\n\
                   c,radiance,old,0,1,2.5,x,2.5,2.5,,1,1\n";
        let e = parse_csv(bad).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("spp"), "{e}");
        assert!(parse_csv("scene,binary\n").is_err());
    }
}
