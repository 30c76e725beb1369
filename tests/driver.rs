//! The driver's budgets, resume and interruption: a time budget ends within one pass of it, a target
//! error stops the run as soon as it is reached, a resumed run is bit-identical to an uninterrupted
//! one (also from a pass interrupted part-way, also adaptive), adaptive sampling lowers the error at
//! equal samples without moving the estimate, and SIGINT leaves a valid, resumable partial file.

use crate::support::{scene_path, temp_dir, z_limit};
use ftpd3d::app;
use ftpd3d::domain::Plane;
use ftpd3d::domain::slice::SliceSpec;
use ftpd3d::field::Field;
use ftpd3d::ftpd::{Params, Weighting};
use ftpd3d::params::EstimatorArgs;
use ftpd3d::render::{
    self, Adaptive, Budget, Hooks, Progress, RenderOptions, RunStats, StopReason,
};
use ftpd3d::run_info::{DomainKind, RunInfo};
use ftpd3d::scene::Scene;
use ftpd3d::scene::load::load_scene;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

pub(crate) struct Setup {
    pub(crate) scene: Scene,
    pub(crate) plane: Plane,
    pub(crate) params: Params,
}

/// The Cornell box with a mirror, slice z = 0 at `res` cells, radiance weighting, default
/// parameters: a scene whose error varies strongly over the slice (mirror, light, shadows).
pub(crate) fn cornell(res: usize) -> Setup {
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let params = EstimatorArgs {
        weighting: Weighting::Radiance,
        t0: None,
        t1: None,
        angle_deg: 2.0,
        max_bounces: 32,
        radiance_bounces: None,
        design: Default::default(),
        guide: false,
    }
    .resolve(&scene)
    .unwrap();
    let spec: SliceSpec = "z=0".parse().unwrap();
    let plane = Plane::axis_slice(&scene.bounds, spec, None, res).unwrap();
    Setup {
        scene,
        plane,
        params,
    }
}

fn opts(seed: u64) -> RenderOptions {
    RenderOptions {
        seed,
        threads: 2,
        ..Default::default()
    }
}

fn pool() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap()
}

impl Setup {
    /// The description `run_job` gives a run (what a resume is checked against).
    pub(crate) fn info(&self, o: &RenderOptions) -> RunInfo {
        RunInfo {
            plane: Some(render::plane_info(&self.plane)),
            ..render::describe_run(&self.scene, &self.params, o, DomainKind::Slice)
        }
    }

    /// A new field so described (keeping its replayed neighbours' sums in a gradient-domain run,
    /// as the command line's fresh fields do).
    pub(crate) fn field(&self, o: &RenderOptions) -> Field {
        let mut f = Field::new(self.plane.width, self.plane.height, 1);
        if let Some(alpha) = o.gradient_domain {
            f = f.with_shift(alpha);
        }
        f.set_info(&self.info(o));
        f
    }

    fn run(
        &self,
        field: &mut Field,
        progress: &mut Progress,
        o: &RenderOptions,
        hooks: Hooks,
    ) -> RunStats {
        render::run_domain_progressive(
            &pool(),
            &self.scene,
            &self.plane,
            &self.params,
            o,
            field,
            progress,
            hooks,
        )
        .unwrap()
    }

    fn fresh_run(&self, o: &RenderOptions) -> (Field, RunStats) {
        let mut f = self.field(o);
        let s = self.run(&mut f, &mut Progress::default(), o, Hooks::default());
        (f, s)
    }
}

fn assert_valid(field: &Field) {
    for (i, v) in field.values().iter().enumerate() {
        assert!(
            v.sigma.is_finite() && v.stderr.is_finite() && v.mean.is_finite(),
            "cell {i}: {v:?}"
        );
    }
}

/// Every sum of every cell, as bits.
fn bits(field: &Field) -> Vec<[u64; 28]> {
    field.cells.iter().map(|m| m.bit_pattern()).collect()
}

#[test]
fn time_budget_ends_within_one_pass_of_it() {
    let s = cornell(64);
    let mut o = opts(1);
    o.budget = Budget {
        cap_spp: false,
        time: Some(Duration::from_secs(2)),
        ..Budget::default()
    };
    o.pass_spp = Some(4);
    // Record when each pass ends, to know how long passes take in this very run.
    let start = Instant::now();
    let mut ends = vec![0.0];
    let mut record = |_: &mut Field, _: &Progress, _: &RunStats| {
        ends.push(start.elapsed().as_secs_f64());
        Ok(())
    };
    let mut field = s.field(&o);
    let mut progress = Progress::default();
    let taken = std::sync::atomic::AtomicU64::new(0);
    let stats = s.run(
        &mut field,
        &mut progress,
        &o,
        Hooks {
            stop: None,
            after_pass: Some(&mut record),
            samples: Some(&taken),
        },
    );
    // The caller's count saw every sample the run took.
    assert_eq!(taken.into_inner(), stats.samples);
    let longest = ends.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
    assert_eq!(stats.stop, StopReason::Time);
    assert!(stats.passes >= 1);
    // The driver stops when the time used plus the last pass would exceed the budget, so it ends
    // before the budget by less than one pass, or after it by less than one pass when a pass
    // took longer than the one before. 10 ms cover the offset between the two clocks.
    assert!(
        (stats.seconds - 2.0).abs() <= longest + 0.01,
        "ended at {:.3} s; longest pass {longest:.3} s; passes {}",
        stats.seconds,
        stats.passes
    );
    assert_valid(&field);
    let n0 = field.cells[0].n;
    assert_eq!(n0, 4 * stats.passes as u64);
    assert!(field.cells.iter().all(|c| c.n == n0), "passes are whole");
    assert!(progress.inflight.is_none());
}

#[test]
fn target_error_stops_as_soon_as_it_is_reached() {
    let s = cornell(24);
    let target = 0.1;
    let mut o = opts(2);
    o.budget = Budget {
        cap_spp: false,
        target_error: Some(target),
        ..Budget::default()
    };
    o.pass_spp = Some(8);
    let mut p95 = Vec::new();
    let mut record = |f: &mut Field, _: &Progress, _: &RunStats| {
        p95.push(render::error_stats(&f.cells).p95);
        Ok(())
    };
    let mut field = s.field(&o);
    let stats = s.run(
        &mut field,
        &mut Progress::default(),
        &o,
        Hooks {
            stop: None,
            after_pass: Some(&mut record),
            samples: None,
        },
    );
    assert_eq!(stats.stop, StopReason::TargetError);
    let e = render::error_stats(&field.cells);
    assert!(e.p95 <= target, "{e:?}");
    assert_eq!(e.unestimated, 0);
    assert!(e.cells > 100, "{e:?}");
    // Not one pass later than needed: the pass before the last was still above the target.
    assert_eq!(p95.len(), stats.passes as usize);
    assert!(p95.len() >= 3, "{p95:?}");
    assert!(p95[p95.len() - 2] > target, "{p95:?}");
    assert_eq!(*p95.last().unwrap(), e.p95);
    assert_valid(&field);
}

/// Runs the all-features kernel over the slice through [`render::run_progressive`]; with `trip`,
/// sets `stop` from inside the kernel at its `trip`-th call (an interruption in mid-pass).
fn drive<'a>(
    s: &Setup,
    field: &mut Field,
    progress: &mut Progress,
    o: &RenderOptions,
    stop: Option<&'a AtomicBool>,
    trip: Option<u64>,
    after_pass: Option<&'a mut render::AfterPass<'a>>,
) -> RunStats {
    let calls = AtomicU64::new(0);
    render::run_progressive(
        &pool(),
        field,
        o,
        progress,
        Hooks {
            stop,
            after_pass,
            samples: None,
        },
        |cell, smp: &mut ftpd3d::rng::Sampler| {
            if let (Some(flag), Some(t)) = (stop, trip)
                && calls.fetch_add(1, Ordering::Relaxed) + 1 == t
            {
                flag.store(true, Ordering::Relaxed);
            }
            let x = s.plane.point(cell, smp.next_2d());
            ftpd3d::ftpd::sample_point(&s.scene, x, &s.params, smp)
        },
    )
    .unwrap()
}

/// Runs `o` to completion, and again stopped after `stop_after` passes (or, with `mid_pass`, a
/// quarter into pass `stop_after`), written to an EXR, read back and resumed; returns both fields
/// and the resumed run's progress.
fn interrupted_and_resumed(
    s: &Setup,
    o: &RenderOptions,
    stop_after: u32,
    mid_pass: bool,
    dir: &std::path::Path,
) -> (Field, Field, Progress) {
    // Uninterrupted, recording the samples after each pass.
    let mut whole = s.field(o);
    let mut cumul = vec![0u64];
    let mut record = |f: &mut Field, _: &Progress, _: &RunStats| {
        cumul.push(f.total_samples());
        Ok(())
    };
    let ws = drive(
        s,
        &mut whole,
        &mut Progress::default(),
        o,
        None,
        None,
        Some(&mut record),
    );
    assert!(ws.stop.is_complete());
    assert!(cumul.len() > stop_after as usize + 1, "{cumul:?}");
    // Interrupted.
    let mut field = s.field(o);
    let mut progress = Progress::default();
    let stop = AtomicBool::new(false);
    let st = if mid_pass {
        let p = stop_after as usize;
        let trip = cumul[p] + (cumul[p + 1] - cumul[p]) / 4;
        drive(
            s,
            &mut field,
            &mut progress,
            o,
            Some(&stop),
            Some(trip),
            None,
        )
    } else {
        let mut first = o.clone();
        first.budget.max_passes = Some(stop_after);
        drive(s, &mut field, &mut progress, &first, None, None, None)
    };
    assert_eq!(progress.passes, stop_after);
    if mid_pass {
        assert_eq!(st.stop, StopReason::Interrupted);
        let f = progress.inflight.as_ref().expect("a pass cut part-way");
        let done = f.done.iter().filter(|&&d| d).count();
        assert!(
            done > 0 && done < f.done.len(),
            "{done} of {}",
            f.done.len()
        );
    } else {
        assert_eq!(st.stop, StopReason::PassLimit);
    }
    // Written, read back, resumed.
    let path = dir.join("partial.exr");
    app::mark_progress(
        &mut field,
        &mut s.info(o),
        &progress,
        o,
        true,
        Some(st.stop),
    );
    app::write_progress(&field, &progress, &path, false).unwrap();
    let fresh = s.field(o);
    let (mut back, mut p) = app::read_progress(&path).unwrap();
    app::check_resume(&path, &back, &s.info(o), (field.width, field.height, 1)).unwrap();
    assert_eq!(bits(&back), bits(&field), "the EXR keeps the sums exactly");
    assert_eq!(p.passes, progress.passes);
    assert_eq!(p.inflight, progress.inflight);
    back.meta = fresh.meta;
    let rs = drive(s, &mut back, &mut p, o, None, None, None);
    assert!(rs.stop.is_complete());
    assert_eq!(rs.passes, ws.passes);
    (whole, back, p)
}

#[test]
fn resumed_run_is_bit_identical_to_an_uninterrupted_one() {
    let dir = temp_dir("driver", "resume");
    let s = cornell(16);
    // 32 spp split into 4 passes; stopped after 2.
    let mut o = opts(3);
    o.spp = 32;
    o.batches = 4;
    let (whole, resumed, p) = interrupted_and_resumed(&s, &o, 2, false, &dir);
    assert_eq!(p.passes, 4);
    assert_eq!(bits(&resumed), bits(&whole));
    assert!(whole.cells.iter().all(|c| c.n == 32 && c.batches <= 4));
    // Cut in the middle of pass 1 (chunks in flight finish, the rest of the pass is skipped).
    let s = cornell(24);
    let (whole, resumed, _) = interrupted_and_resumed(&s, &o, 1, true, &dir);
    assert_eq!(bits(&resumed), bits(&whole));
    // Adaptive, cut in the middle of pass 3, whose allocation depends on passes 0-2.
    let mut a = opts(6);
    a.spp = 48;
    a.pass_spp = Some(8);
    a.adaptive = Some(Adaptive::default());
    let (whole, resumed, p) = interrupted_and_resumed(&s, &a, 3, true, &dir);
    assert_eq!(bits(&resumed), bits(&whole));
    assert!(p.passes >= 6);
    let n: Vec<u64> = whole.cells.iter().map(|c| c.n).collect();
    assert!(
        n.iter().min() < n.iter().max(),
        "adaptive passes are uneven"
    );
}

#[test]
fn resume_refuses_another_seed_or_run_length_naming_the_key() {
    let dir = temp_dir("driver", "refuse");
    let s = cornell(8);
    let mut o = opts(4);
    o.spp = 8;
    o.batches = 2;
    o.budget.max_passes = Some(1);
    let (mut field, _) = s.fresh_run(&o);
    let progress = Progress {
        passes: 1,
        ..Progress::default()
    };
    let path = dir.join("part.exr");
    app::mark_progress(&mut field, &mut s.info(&o), &progress, &o, true, None);
    app::write_progress(&field, &progress, &path, false).unwrap();
    let (back, _) = app::read_progress(&path).unwrap();
    let dims = (field.width, field.height, 1);
    app::check_resume(&path, &back, &s.info(&o), dims).unwrap();
    // Another seed.
    let mut other = o.clone();
    other.seed = 5;
    let e = app::check_resume(&path, &back, &s.info(&other), dims).unwrap_err();
    let msg = format!("{e:#}");
    assert!(
        msg.contains("seed differs") && msg.contains("4") && msg.contains("5"),
        "{msg}"
    );
    // Another t1.
    let t1 = Setup {
        params: Params {
            t1: s.params.t1 * 0.5,
            ..s.params
        },
        scene: load_scene(&scene_path("cornell_mirror.obj")).unwrap(),
        plane: s.plane.clone(),
    };
    let e = app::check_resume(&path, &back, &t1.info(&o), dims).unwrap_err();
    assert!(format!("{e:#}").contains("t1 differs"), "{e:#}");
    // Another schedule.
    let mut sched = o.clone();
    sched.pass_spp = Some(3);
    let e = app::check_resume(&path, &back, &s.info(&sched), dims).unwrap_err();
    assert!(format!("{e:#}").contains("schedule differs"), "{e:#}");
    // Another light: a point light given on the command line changes what the samples estimate.
    let mut lit = s.info(&o);
    lit.point_lights = vec![(glam::DVec3::Y, glam::DVec3::ONE)];
    let e = app::check_resume(&path, &back, &lit, dims).unwrap_err();
    assert!(format!("{e:#}").contains("point_lights differs"), "{e:#}");
    // Through the command line.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .args([
            "--scene",
            scene_path("cornell_mirror.obj").to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "8",
            "--spp",
            "8",
            "--batches",
            "2",
            "--seed",
            "7",
            "--quiet",
            "--resume",
            path.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("seed differs"), "{err}");
}

/// The mean σ over the valid cells of `field`, with its standard error from the cells' own
/// (cells are independent).
fn mean_sigma(field: &Field) -> (f64, f64) {
    let v: Vec<_> = field.values().into_iter().filter(|v| v.valid).collect();
    let n = v.len() as f64;
    let mean = v.iter().map(|v| v.sigma).sum::<f64>() / n;
    let se = v.iter().map(|v| v.stderr * v.stderr).sum::<f64>().sqrt() / n;
    (mean, se)
}

#[test]
fn adaptive_lowers_the_error_at_equal_samples_and_keeps_the_estimate() {
    // Cornell box z = 0: the relative error varies a lot over the slice (mirror, light, corners).
    let s = cornell(32);
    let run = |seed: u64, spp: u32, adaptive: bool| {
        let mut o = opts(seed);
        o.spp = spp;
        o.pass_spp = Some(8);
        o.adaptive = adaptive.then(Adaptive::default);
        let (f, st) = s.fresh_run(&o);
        assert_eq!(st.stop, StopReason::Samples);
        f
    };
    let seeds = [1, 2, 3, 4];
    let uniform: Vec<Field> = seeds.iter().map(|&k| run(k, 192, false)).collect();
    let adaptive: Vec<Field> = seeds.iter().map(|&k| run(k, 192, true)).collect();
    let cells = uniform[0].cells.len() as u64;
    for (u, a) in uniform.iter().zip(&adaptive) {
        assert_eq!(u.total_samples(), 192 * cells);
        // Adaptive spends the same budget, in whole units of 8 samples.
        assert!(
            a.total_samples().abs_diff(192 * cells) < 8,
            "{}",
            a.total_samples()
        );
        assert_valid(a);
    }
    let mean_sd = |x: &[f64]| {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        let sd = (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (x.len() - 1) as f64).sqrt();
        (m, sd)
    };
    // The 95th percentile of the relative error: lower for every seed, and the gap between the
    // means exceeds three times the seed-to-seed spread of either method.
    let p95 = |fs: &[Field]| -> Vec<f64> {
        fs.iter()
            .map(|f| render::error_stats(&f.cells).p95)
            .collect()
    };
    let (pu, pa) = (p95(&uniform), p95(&adaptive));
    let ((mu, su), (ma, sa)) = (mean_sd(&pu), mean_sd(&pa));
    println!("p95 relative error: uniform {pu:?}, adaptive {pa:?}");
    let worst_adaptive = pa.iter().copied().fold(0.0, f64::max);
    let best_uniform = pu.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        worst_adaptive < best_uniform && mu - ma > 3.0 * (su + sa),
        "p95 relative error: uniform {pu:?}, adaptive {pa:?}"
    );
    // The estimate: the mean of σ over the cells stays where uniform runs put it. σ is a
    // nonlinear function of ratios of sums and is biased low at small sample counts in any run
    // (the mean over cells rises from 16.0 at 16 spp to 16.5 at 192 and 16.6 at 768); adaptive
    // runs give their easy cells fewer samples and their hard cells more, so their bias lies
    // between that of uniform runs of the same samples and of 4× as many (their means differ by
    // some 3 standard errors of the seeds' spread, so equality with either would be a matter of
    // seeds). The adaptive mean must lie in that interval, widened by k standard errors: those of
    // the means over the 4 seeds, from the cells' own standard errors (the cells are independent;
    // the per-cell errors are at most 1.15× too small at these sample counts, a z variance under
    // 1.32 (`radiance_stderr_z_variance_in_range`), so they are taken 1.2× larger). The interval
    // is then 16.29 to 16.80: adaptive passes that moved σ by 2 % (0.33) fall outside.
    let sig = |fs: &[Field]| -> (f64, f64) {
        let (m, v) = fs
            .iter()
            .map(mean_sigma)
            .fold((0.0, 0.0), |(m, v), (mi, si)| (m + mi, v + si * si));
        let n = fs.len() as f64;
        (m / n, 1.2 * v.sqrt() / n)
    };
    let reference: Vec<Field> = seeds.iter().map(|&k| run(k, 768, false)).collect();
    let ((mu, su), (ma, sa), (mr, sr)) = (sig(&uniform), sig(&adaptive), sig(&reference));
    let k = z_limit(2);
    println!(
        "mean σ over cells: uniform 192 spp {mu:.4} ± {su:.4}, adaptive 192 spp {ma:.4} ± {sa:.4}, \
         uniform 768 spp {mr:.4} ± {sr:.4}"
    );
    assert!(
        ma >= mu - k * su.hypot(sa) && ma <= mr + k * sr.hypot(sa),
        "mean σ over cells: adaptive 192 spp {ma:.4} ± {sa:.4} outside uniform 192 spp {mu:.4} ± \
         {su:.4} to 768 spp {mr:.4} ± {sr:.4}, widened by {k:.2} standard errors"
    );
}

/// Samples asked for by the SIGINT test: far more than it can take before the signal.
const SIGINT_SPP: u64 = 1_000_000;

#[test]
fn sigint_writes_a_valid_resumable_partial_file() {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};
    let dir = temp_dir("driver", "sigint");
    let out = dir.join("run.exr");
    let scene = scene_path("cornell_mirror.obj");
    let base = [
        "--scene",
        scene.to_str().unwrap(),
        "--slice",
        "z=0",
        "--res",
        "48",
        "--pass-spp",
        "4",
        "--threads",
        "2",
        "--no-png",
        "-o",
        out.to_str().unwrap(),
    ];
    let spp = SIGINT_SPP.to_string();
    let mut child = Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .args(base)
        .args(["--spp", &spp])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for the run to start (it prints its budget), then let it take some passes.
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut text = String::new();
    while !text.contains("budget") {
        let mut line = String::new();
        assert!(
            err.read_line(&mut line).unwrap() > 0,
            "no start line: {text}"
        );
        text += &line;
    }
    std::thread::sleep(Duration::from_millis(1500));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let t = Instant::now();
    let status = child.wait().unwrap();
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut err, &mut rest).unwrap();
    text += &rest;
    assert!(t.elapsed() < Duration::from_secs(30), "slow to stop");
    // Exit status 130 (documented): stopped by a signal, partial result written.
    assert_eq!(status.code(), Some(130), "{text}");
    assert!(
        text.contains("interrupted") && text.contains("to resume:"),
        "{text}"
    );
    assert!(text.contains("--resume"), "{text}");
    let f = ftpd3d::output::exr::read_exr(&out).unwrap();
    assert_eq!(f.meta["partial"], "true");
    assert_eq!(f.meta["stop"], "interrupted");
    let samples = f.total_samples();
    assert!(
        samples > 0 && samples < SIGINT_SPP * f.cells.len() as u64,
        "{samples}"
    );
    assert_valid(&f);
    // No temporary file left.
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
    // The partial file resumes (finishing a pass cut part-way, if any), here up to a small cap.
    let passes: u32 = f.meta["passes"].parse().unwrap();
    let cap = ((passes + 2) * 4).to_string();
    let r = Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .args(base)
        .args(["--spp", &cap, "--quiet", "--resume", out.to_str().unwrap()])
        .output()
        .unwrap();
    let msg = String::from_utf8_lossy(&r.stderr);
    // A different --spp with --pass-spp is a different budget, not a different schedule.
    assert!(r.status.success(), "{msg}");
    let g = ftpd3d::output::exr::read_exr(&out).unwrap();
    assert_eq!(g.meta["partial"], "false", "{:?}", g.meta);
    assert_eq!(g.meta["pass.inflight"], "false");
    assert_eq!(g.meta["passes"], (passes + 2).to_string());
    assert!(g.cells.iter().all(|c| c.n == (passes as u64 + 2) * 4));
}

/// z-scores of a run against an independent run of 16 times the samples, over the cells valid in
/// both: (mean, variance, standard error of the variance from the z's fourth moment). Every pass
/// gives each cell `pass_spp` samples, taken in groups of 8 that are each one scrambled Sobol'
/// sequence (unweighted runs) and each one independent unit of the standard error.
fn zscores_against_16x(s: &Setup, spp: u32, pass_spp: u32) -> (f64, f64, f64) {
    let run = |seed, spp| {
        let mut o = opts(seed);
        o.spp = spp;
        o.pass_spp = Some(pass_spp);
        s.fresh_run(&o).0
    };
    let (a, r) = (run(1, spp), run(2, 16 * spp));
    let z: Vec<f64> = a
        .values()
        .iter()
        .zip(r.values().iter())
        .filter(|(x, y)| x.valid && y.valid && x.stderr > 0.0)
        .map(|(x, y)| (x.sigma - y.sigma) / x.stderr.hypot(y.stderr))
        .collect();
    let n = z.len() as f64;
    assert!(n > 0.7 * a.cells.len() as f64, "{n} cells");
    let m = z.iter().sum::<f64>() / n;
    let v = z.iter().map(|q| (q - m).powi(2)).sum::<f64>() / (n - 1.0);
    let m4 = z.iter().map(|q| (q - m).powi(4)).sum::<f64>() / n;
    (m, v, ((m4 - v * v) / n).max(0.0).sqrt())
}

/// The range issue 13 asks of the z variance: the standard error neither much optimistic nor
/// much pessimistic.
const Z_VAR_RANGE: std::ops::RangeInclusive<f64> = 0.8..=1.25;

/// Asserts that the z variance `v ± se` is not outside [`Z_VAR_RANGE`] by more than `k` of its
/// standard errors. The measured variances lie in the range or near its upper end (1.04 to 1.32,
/// ± 0.06 to 0.09), so a judgement of `v` alone would fail for an unlucky seed (one in six at
/// 1.16 ± 0.09); judged so, an estimator whose z variance is in the range fails with probability
/// under Q(k) whatever the seeds.
fn assert_z_variance_in_range(what: &str, (v, se): (f64, f64), k: f64) {
    let (lo, hi) = (*Z_VAR_RANGE.start(), *Z_VAR_RANGE.end());
    println!("{what}: z variance {v:.3} ± {se:.3}");
    assert!(
        v + k * se >= lo && v - k * se <= hi,
        "{what}: z variance {v} ± {se} lies outside {Z_VAR_RANGE:?} by more than {k:.2} standard \
         errors"
    );
}

/// The per-cell standard error predicts the error against a 16× reference (Cornell box, z = 0,
/// 32² cells, independent seeds), with the QMC sampler (unweighted) and passes of 8 samples (the
/// default's 64 spp in 8 passes): the z variance lies in [`Z_VAR_RANGE`] (1.16 ± 0.09 measured on
/// 24² cells). With longer passes see `qmc_stderr_z_variance_with_64_point_sequences`, with
/// radiance weighting `radiance_stderr_z_variance_in_range`.
#[test]
fn stderr_predicts_the_error_against_a_16x_reference() {
    let (m, v, se) = unweighted_zscores(8);
    println!("unweighted, 128 spp, 8 per pass: z mean {m:.3}");
    assert_z_variance_in_range("unweighted, 8 per pass", (v, se), z_limit(1));
}

/// [`zscores_against_16x`] of the Cornell box's 32² unweighted cells at 128 spp in passes of
/// `pass_spp` (8 or 64), computed once for the tests that judge them.
fn unweighted_zscores(pass_spp: u32) -> (f64, f64, f64) {
    use std::sync::OnceLock;
    static BY_8: OnceLock<(f64, f64, f64)> = OnceLock::new();
    static BY_64: OnceLock<(f64, f64, f64)> = OnceLock::new();
    let cell = match pass_spp {
        8 => &BY_8,
        64 => &BY_64,
        _ => unreachable!("passes of 8 or 64 samples"),
    };
    *cell.get_or_init(|| {
        let mut s = cornell(32);
        s.params.weighting = Weighting::Unweighted;
        zscores_against_16x(&s, 128, pass_spp)
    })
}

/// The QMC sampler with passes of 64 samples: each pass of a cell is 8 groups of 8 points, each
/// group its own scrambled Sobol' sequence and one independent unit of the standard error. The z
/// variance lies in [`Z_VAR_RANGE`] and equals that of passes of 8 samples within their standard
/// errors (three quantities judged together). This is what catches the error bars of a pass
/// taken as one sequence of 64 points with every sample a unit: they were about 1.2× too wide
/// (z variance 0.68 ± 0.05 against 1.18 ± 0.09 on 24² cells; 32² cells make that difference about
/// six standard errors), the points of one sequence being stratified against each other, not
/// independent.
#[test]
fn qmc_stderr_z_variance_with_64_point_sequences() {
    let k = z_limit(3);
    let (_, v64, se64) = unweighted_zscores(64);
    let (_, v8, se8) = unweighted_zscores(8);
    assert_z_variance_in_range("unweighted, 64 per pass", (v64, se64), k);
    assert_z_variance_in_range("unweighted, 8 per pass", (v8, se8), k);
    let se = se64.hypot(se8);
    println!(
        "64 against 8 per pass: {:+.3} ± {se:.3} ({:+.2} se)",
        v64 - v8,
        (v64 - v8) / se
    );
    assert!(
        (v64 - v8).abs() <= k * se,
        "z variance with 64 per pass {v64} ± {se64}, with 8 per pass {v8} ± {se8}"
    );
}

/// Radiance-weighted, the contributions are heavy-tailed (rare paths carry 100× the mean), so a
/// cell's error estimate rests on few effective samples; the skewness correction of the standard
/// error ([`ftpd3d::ftpd::moments::Moments::stderr`]) keeps the z variance near 1: 1.18 ± 0.09 at
/// 128 spp and 1.06 ± 0.07 at 512 on these 24² cells (per-sample, without the correction, 1.42 and
/// 1.15: error bars too narrow at few samples; on 32² cells, with the correction, 1.32 ± 0.09 and
/// 1.15 ± 0.06: the range's upper end is within the noise of one grid). Judged together (four
/// quantities): the z variance is in [`Z_VAR_RANGE`] at 128 and at 512 spp, it does not grow with
/// the samples, and the error is not overestimated at 512 spp (the variance is not below 1).
#[test]
fn radiance_stderr_z_variance_in_range() {
    let mut s = cornell(24);
    s.params.weighting = Weighting::Radiance;
    let k = z_limit(4);
    let (m1, v1, se1) = zscores_against_16x(&s, 128, 8);
    let (m2, v2, se2) = zscores_against_16x(&s, 512, 8);
    println!("radiance: z mean {m1:.3} at 128 spp, {m2:.3} at 512");
    assert_z_variance_in_range("radiance, 128 spp", (v1, se1), k);
    assert_z_variance_in_range("radiance, 512 spp", (v2, se2), k);
    assert!(
        v2 - v1 <= k * se1.hypot(se2),
        "the z variance grows with the samples: {v1} ± {se1} → {v2} ± {se2}"
    );
    assert!(v2 + k * se2 >= 1.0, "{v2} ± {se2}");
}
