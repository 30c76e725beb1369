//! Estimates of the FTPD moments at single points, and their z-scores against an independent
//! estimate of the same expectations (another scene that must give the same field, or the plain
//! reference estimator).

use ftpd3d::ftpd::moments::Moments;
use ftpd3d::ftpd::{Params, Weighting, sample_point};
use ftpd3d::rng::Sampler;
use ftpd3d::scene::Scene;
use glam::DVec3;

/// The estimator's parameters most tests take: run lengths [`t0`, `t1`], cone half-angle
/// `theta_max`, `max_bounces` for walks and radiance paths, 3D, the weighting's default design,
/// no guiding.
pub fn params(t0: f64, t1: f64, theta_max: f64, weighting: Weighting, max_bounces: u32) -> Params {
    Params {
        t0,
        t1,
        theta_max,
        weighting,
        max_bounces,
        radiance_bounces: None,
        flat: None,
        design: ftpd3d::ftpd::Design::default_for(weighting),
        guide: false,
    }
}

/// σ, its standard error, the mean luminance of the weight (the fluence for radiance weighting)
/// and its standard error, from `n` samples at `at` drawn with `s`.
pub fn point_estimate(
    scene: &Scene,
    at: DVec3,
    p: &Params,
    mut s: Sampler,
    n: usize,
) -> (f64, f64, f64, f64) {
    let mut m = Moments::default();
    let (mut f, mut f2) = (0.0, 0.0);
    for _ in 0..n {
        let smp = sample_point(scene, at, p, &mut s);
        m.add_unit(smp.c, smp.cd, smp.cd2, smp.weight);
        let w = ftpd3d::math::luminance(smp.weight);
        f += w;
        f2 += w * w;
    }
    let v = m.finalize();
    let mean = f / n as f64;
    let se = ((f2 / n as f64 - mean * mean).max(0.0) / (n as f64 - 1.0).max(1.0)).sqrt();
    (v.sigma, v.stderr, mean, se)
}

/// Appends the z-scores of two independent point estimates (`point_estimate`) of the same
/// quantities: σ always, the fluence too under radiance weighting.
pub fn push_z_scores(
    out: &mut Vec<(String, f64)>,
    name: &str,
    weighting: Weighting,
    a: (f64, f64, f64, f64),
    b: (f64, f64, f64, f64),
) {
    let z = |x: f64, sx: f64, y: f64, sy: f64| {
        let se = (sx * sx + sy * sy).sqrt();
        if se > 0.0 { (x - y) / se } else { 0.0 }
    };
    out.push((format!("σ {name}"), z(a.0, a.1, b.0, b.1)));
    if weighting == Weighting::Radiance {
        out.push((format!("fluence {name}"), z(a.2, a.3, b.2, b.3)));
    }
}

/// The z-scores ([`push_z_scores`]) of two scenes that must give the same field, at each of
/// `points`, unweighted and radiance-weighted (`params` of each weighting), from `n` samples per
/// point and scene; scene k's stream at point i is keyed (`seed` + k, i, weighting), so the two
/// estimates are independent. Judge them with [`crate::support::assert_consistent`].
pub fn z_scores_of_two_scenes(
    scenes: [&Scene; 2],
    points: &[DVec3],
    params: impl Fn(Weighting) -> Params,
    seed: u64,
    n: usize,
) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for weighting in [Weighting::Unweighted, Weighting::Radiance] {
        let p = params(weighting);
        for (i, at) in points.iter().enumerate() {
            let est = |k: u64| {
                let s = Sampler::new(seed + k, i as u64, weighting as u64);
                point_estimate(scenes[k as usize], *at, &p, s, n)
            };
            let name = format!("{weighting:?} at {:.2},{:.2},{:.2}", at.x, at.y, at.z);
            push_z_scores(&mut out, &name, weighting, est(0), est(1));
        }
    }
    out
}

/// Batches per estimate in [`agrees_with_reference`].
const BATCHES: u64 = 16;

/// (m1, m2, σ, fluence) of the merged batches, each with its standard error from the spread of
/// the batches.
fn batch_estimate(per_batch: impl Fn(u64) -> Moments) -> [(f64, f64); 4] {
    let bs: Vec<Moments> = (0..BATCHES).map(per_batch).collect();
    let stats = |f: &dyn Fn(&Moments) -> f64| -> (f64, f64) {
        let mut total = Moments::default();
        for b in &bs {
            total.merge(b);
        }
        let v: Vec<f64> = bs.iter().map(f).collect();
        (f(&total), crate::support::mean_and_se_of(&v).1)
    };
    [
        stats(&|m| m.s1 / m.s0),
        stats(&|m| m.s2 / m.s0),
        stats(&|m| m.sigma().unwrap_or(0.0)),
        stats(&|m| ftpd3d::math::luminance(m.fluence) / m.n as f64),
    ]
}

/// At each of `points`, the production estimator and the plain reference estimator
/// (`ftpd::reference`; streams keyed by `seeds` + the point's index, `n` samples in each of 16
/// batches) agree on m1, m2, σ and the fluence within 4 standard errors of their difference (each
/// from the spread of 16 batches, so the z-score is close to Student's t with about 30 degrees of
/// freedom: 4e-4 false failures per comparison).
pub fn agrees_with_reference(
    scene: &Scene,
    points: &[DVec3],
    p: &Params,
    n: usize,
    seeds: (u64, u64),
    label: &str,
) {
    for (k, x) in points.iter().enumerate() {
        let fast = batch_estimate(|b| {
            let mut s = Sampler::new(seeds.0 + k as u64, b, 0);
            let mut m = Moments::default();
            for _ in 0..n {
                let smp = sample_point(scene, *x, p, &mut s);
                m.add_unit(smp.c, smp.cd, smp.cd2, smp.weight);
            }
            m
        });
        let slow = batch_estimate(|b| {
            let mut s = Sampler::new(seeds.1 + k as u64, b, 0);
            let mut m = Moments::default();
            for _ in 0..n {
                let terms = ftpd3d::ftpd::reference::sample_reference(scene, *x, p, &mut s);
                // One sample's terms are summed into one observation.
                let (c, cd, cd2, w) = terms
                    .iter()
                    .fold((0.0, 0.0, 0.0, ftpd3d::math::Rgb::ZERO), |a, t| {
                        (a.0 + t.0, a.1 + t.0 * t.1, a.2 + t.0 * t.1 * t.1, a.3 + t.2)
                    });
                m.s0 += c;
                m.s1 += cd;
                m.s2 += cd2;
                m.n += 1;
                m.fluence += w;
            }
            m
        });
        for (name, (a, b)) in ["m1", "m2", "sigma", "fluence"]
            .iter()
            .zip(fast.iter().zip(&slow))
        {
            let se = (a.1 * a.1 + b.1 * b.1).sqrt();
            let z = (a.0 - b.0) / se;
            eprintln!(
                "{label} {k} {name}: MIS {:.5} ± {:.5}, reference {:.5} ± {:.5}, z = {z:.2}",
                a.0, a.1, b.0, b.1
            );
            assert!(
                z.abs() < 4.0,
                "{label} {k} {name}: MIS {a:?} vs reference {b:?} (z = {z:.2})"
            );
        }
    }
}
