//! Deflection-pair designs ([`Design`]): a sample of any design (kA walks along ω, J cone
//! directions with kB walks each, every walk read at M run lengths, Δ averaged over all
//! combinations) estimates the expectations of the single pair of eqs. 9-14. Checked against the
//! plain reference estimator, between designs, and on the command line (threads, resume, refusals).

use crate::support::{
    Run, agrees_with_reference, assert_consistent, assert_resume_keeps, ftpd3d, point_estimate,
    push_z_scores, run_on_1_and_2_threads, scene_path, small_slice, temp_dir,
};
use ftpd3d::ftpd::{Design, Params, Weighting, visit_point};
use ftpd3d::rng::Sampler;
use ftpd3d::scene::Scene;
use ftpd3d::scene::load::load_scene;
use glam::DVec3;

/// All pairs of two walks along ω, three cone directions with two walks each, four run lengths
/// (2·2·3·4 = 48 pairs from 8 walks): every part of a design other than one.
const ALL_PAIRS: Design = Design::new(2, 2, 3, 4);

fn params(weighting: Weighting, design: Design) -> Params {
    Params {
        t0: 0.3,
        t1: 1.2,
        theta_max: 0.2,
        weighting,
        max_bounces: 12,
        radiance_bounces: None,
        flat: None,
        design,
        guide: false,
    }
}

fn cornell_with_point_light() -> Scene {
    let mut scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    scene.add_point_light(DVec3::new(0.5, 1.2, 0.3), DVec3::splat(2.0));
    scene
}

/// Radiance weighting with one pair per sample and with all pairs of [`ALL_PAIRS`] against the
/// reference estimator (uniform directions, no light sampling, one pair per sample): m1, m2, σ
/// and the fluence within the limits of [`agrees_with_reference`] (4 standard errors of 16
/// batches each, 4e-4 false failures per comparison, 16 comparisons per design).
#[test]
fn single_and_all_pairs_match_the_reference_estimator() {
    let scene = cornell_with_point_light();
    let points = [DVec3::new(0.2, 1.0, 0.0), DVec3::new(-0.6, 0.4, 0.5)];
    for (k, design) in [Design::SINGLE, ALL_PAIRS].into_iter().enumerate() {
        let p = params(Weighting::Radiance, design);
        let seeds = (300 + 10 * k as u64, 400 + 10 * k as u64);
        agrees_with_reference(&scene, &points, &p, 4000, seeds, &format!("pairs {design}"));
    }
}

/// Independent estimates of σ (and, radiance-weighted, of the fluence) with one pair per sample
/// and with each of two all-pairs designs agree at points of the Cornell box and the stair wall,
/// unweighted and radiance-weighted; judged together by [`assert_consistent`] (false failures at
/// most 1e-3 whatever the seeds).
#[test]
fn designs_agree_with_one_pair_per_sample() {
    let cornell = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let stair = load_scene(&scene_path("stair_wall.obj")).unwrap();
    let mut zs = Vec::new();
    for (name, scene) in [("cornell", &cornell), ("stair", &stair)] {
        let lo = scene.bounds.min;
        let size = scene.bounds.max - lo;
        let points = [DVec3::new(0.3, 0.6, 0.5), DVec3::new(0.7, 0.3, 0.4)]
            .map(|f| scene.off_surfaces(lo + size * f));
        for weighting in [Weighting::Unweighted, Weighting::Radiance] {
            for (i, at) in points.iter().enumerate() {
                let single = params(weighting, Design::SINGLE);
                let key = (weighting as u64) * 8 + i as u64;
                let base = point_estimate(scene, *at, &single, Sampler::new(61, key, 0), 6000);
                for (k, design) in [ALL_PAIRS, Design::default_for(weighting)]
                    .into_iter()
                    .enumerate()
                {
                    let s = Sampler::new(62 + k as u64, key, 0);
                    let est = point_estimate(scene, *at, &params(weighting, design), s, 6000);
                    let label = format!("{name} {weighting:?} {i} {design} against 1,1,1,1");
                    push_z_scores(&mut zs, &label, weighting, est, base);
                }
            }
        }
    }
    assert_consistent("designs against one pair", &zs);
}

/// A sample's combinations are its design's: kA·kB·J·M of them, the run lengths one in each of
/// the M strata of [t0, t1], and the sample's (c, cΔ, cΔ²) their averages.
#[test]
fn a_sample_averages_every_combination_of_its_design() {
    let scene = load_scene(&scene_path("cornell_mirror.obj")).unwrap();
    let p = params(Weighting::Unweighted, ALL_PAIRS);
    let mut s = Sampler::new(5, 0, 0);
    for _ in 0..200 {
        let mut seen = Vec::new();
        let smp = visit_point(&scene, DVec3::new(0.1, 1.0, 0.2), &p, &mut s, &mut |pair| {
            seen.push(*pair)
        });
        assert_eq!(seen.len() as u32, ALL_PAIRS.pairs());
        let n = seen.len() as f64;
        let mean = |f: &dyn Fn(&ftpd3d::ftpd::Pair) -> f64| seen.iter().map(f).sum::<f64>() / n;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()));
        assert!(close(smp.c, mean(&|q| q.c)), "{smp:?}");
        assert!(close(smp.cd, mean(&|q| q.c * q.delta)), "{smp:?}");
        assert!(
            close(smp.cd2, mean(&|q| q.c * q.delta * q.delta)),
            "{smp:?}"
        );
        // Each run length lies in its own stratum; every stratum holds one.
        let m = ALL_PAIRS.lengths as usize;
        let mut strata = vec![0; m];
        for q in &seen {
            let f = (q.t - p.t0) / (p.t1 - p.t0) * m as f64;
            assert!((0.0..m as f64).contains(&f), "T = {}", q.t);
            strata[f as usize] += 1;
        }
        let each = seen.len() / m;
        assert!(strata.iter().all(|&c| c == each), "{strata:?}");
    }
}

/// The command line's `--pairs`: results bit-identical on 1 and 2 threads, a resumed run equal
/// to the same run in one go, a resume with another design refused with the flag named, the
/// design in `--explain`, and designs out of range refused.
#[test]
fn pairs_flag_runs_resumes_and_refuses() {
    let dir = temp_dir("pairs", "flag");
    let scene = scene_path("stair_wall.obj");
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let run = |extra: &[&str]| -> Run { small_slice(&scene, extra) };
    let cells = |name: &str| ftpd3d::output::exr::read_exr(&dir.join(name)).unwrap();
    run_on_1_and_2_threads(
        run,
        &["--pairs", "2,1,3,4"],
        [&out("t1.exr"), &out("t2.exr")],
    );
    let (t1, t2) = (cells("t1.exr"), cells("t2.exr"));
    assert_eq!(t1.cells, t2.cells, "bit-identical on 1 and 2 threads");
    assert_eq!(t1.meta["pairs"], "2,1,3,4");
    // The default design differs from it: other sums.
    let r = run(&["--spp", "8", "-o", &out("default.exr")]);
    assert!(r.ok, "{}", r.err);
    assert_eq!(cells("default.exr").meta["pairs"], "2,2,2,2");
    assert_ne!(cells("default.exr").cells, t1.cells);
    // 4 samples, resumed to 8: the 8-sample run, bit for bit.
    let resumed = out("resumed.exr");
    let read = || cells("resumed.exr").cells;
    assert_resume_keeps(
        run,
        &["--pairs", "2,1,3,4"],
        "pairs",
        &resumed,
        read,
        &t1.cells,
    );
    for bad in ["1,0,1,1", "1,1,1,65", "17,1,1,1"] {
        let r = run(&["--pairs", bad, "--spp", "1", "-o", &out("bad.exr")]);
        assert!(!r.ok && r.err.contains("--pairs"), "{bad}: {}", r.err);
        assert!(!r.err.contains("panicked"), "{bad}: {}", r.err);
    }
    // --explain says what a sample takes.
    let r = ftpd3d(&[
        "--scene",
        scene.to_str().unwrap(),
        "--explain",
        "--pairs",
        "2,1,3,4",
    ]);
    assert!(r.ok, "{}", r.err);
    let line = r
        .out
        .lines()
        .find(|l| l.starts_with("pairs "))
        .unwrap_or_default();
    assert!(
        line.contains("2,1,3,4 per sample") && line.ends_with("24 pairs from 5 walks"),
        "{}",
        r.out
    );
    for bad in ["1,1,2", "1,1,2,x"] {
        let r = run(&["--pairs", bad, "--spp", "1", "-o", &out("bad.exr")]);
        assert!(!r.ok && r.err.contains("--pairs"), "{bad}: {}", r.err);
    }
}
