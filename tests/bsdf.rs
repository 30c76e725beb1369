//! BSDF validation: sampling densities, energy, reciprocity, Fresnel.
//!
//! How the checks are made, so that no tolerance is a constant picked until the tests pass:
//!
//! * **Quadrature.** Densities and albedos are integrated by a deterministic rule written here,
//!   independently of the code under test: spherical coordinates (θ, φ) around an axis chosen per
//!   case (the Phong lobe axis for glossy lobes, the shading normal otherwise), θ split into panels
//!   that resolve the lobe width 1/√n, and the sphere split *exactly* along every plane where the
//!   integrand may jump or kink (geometric horizon, shading horizon, the Phong lobe's own
//!   hemisphere): for each φ the allowed θ range of a piece is computed in closed form, and the φ
//!   cells are split at every azimuth where that structure changes (located by bisection). So the
//!   integrand is smooth on every θ panel and every φ part, and both are integrated by m-point
//!   Gauss–Legendre (error O(h^2m)). Every integral is computed twice, coarse and with cells and
//!   nodes doubled; the finer value's error is then far below the coarser's (at most a quarter
//!   of it even for a rule as slow as O(h²)), so |I_c − I_f| ≥ 3 |E_f| and the tests allow
//!   |I_c − I_f| (three times the error estimate) plus a rounding floor.
//!   `quadrature_reproduces_closed_forms` shows that bound holding on integrals known in closed
//!   form, and every test also requires the bound to be small (so a wrong normalisation cannot
//!   hide in it).
//! * **Chi-square.** Sampling is compared with the density by Pearson's test on the same bins:
//!   expected counts come from the quadrature, bins expecting fewer than 5 samples are pooled (and
//!   the pool is also checked with an exact Poisson tail, so samples where the density is ~0 fail),
//!   and the threshold is the (1 − α) quantile of χ²(dof) by the Wilson–Hilferty approximation with
//!   α = 1e-4 per case (`support::chi2_test`). The quadrature error of the expected counts is
//!   checked to move the statistic by a negligible amount (triangle-inequality bound there).
//! * **Monte Carlo means** are compared within 4 standard errors computed from the sample variance
//!   (a false failure with probability 6.3e-5 per mean compared).
//! * **Closed-form identities** (Fresnel, Snell, mirror, reciprocity) are checked to a few ulps
//!   scaled by the condition number of the quantity compared.
//!
//! All random numbers come from fixed seeds, so a run is reproducible.

use crate::support::{
    binomial_lower_tail, binomial_upper_tail, chi2_quantile, chi2_test, gauss_legendre,
    mean_and_se, normal_quantile, normal_upper_tail, poisson_upper_tail, student_t_upper_tail,
    z_limit,
};
use ftpd3d::math::*;
use ftpd3d::rng::Sampler;
use ftpd3d::transport::bsdf::*;
use ftpd3d::transport::sampling::*;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

const EPS: f64 = f64::EPSILON;
const SEED: u64 = 0x5eed_b5df;
/// Samples per chi-square case and per furnace (Monte Carlo mean) case.
const N_SAMPLES: usize = 100_000;
const N_FURNACE: usize = 40_000;
/// Monte Carlo means must agree within this many standard errors.
const N_SE: f64 = 4.0;
/// φ bins of the sphere grid; φ cells per bin and Gauss–Legendre nodes per φ part and θ panel,
/// at the coarse level (the fine level doubles both).
const N_PHI: usize = 12;
const SUB: usize = 2;
const M: usize = 8;

// ------------------------------------------------------------------------------------------------
// Spherical quadrature

/// An orthonormal frame built by Gram–Schmidt (independent of `math::Frame`).
#[derive(Clone, Copy, Debug)]
struct TestFrame {
    x: DVec3,
    y: DVec3,
    z: DVec3,
}

impl TestFrame {
    fn around(z: DVec3) -> Self {
        let z = z.normalize();
        let helper = if z.x.abs() < 0.5 { DVec3::X } else { DVec3::Y };
        let x = (helper - z * z.dot(helper)).normalize();
        TestFrame {
            x,
            y: z.cross(x),
            z,
        }
    }
    fn to_local(self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }
    fn to_world(self, v: DVec3) -> DVec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
    fn dir(&self, sin_t: f64, cos_t: f64, sin_p: f64, cos_p: f64) -> DVec3 {
        self.x * (sin_t * cos_p) + self.y * (sin_t * sin_p) + self.z * cos_t
    }
    /// (θ, φ) with θ ∈ [0, π], φ ∈ [0, 2π).
    fn angles(&self, w: DVec3) -> (f64, f64) {
        let l = self.to_local(w);
        let theta = l.x.hypot(l.y).atan2(l.z);
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += TAU;
        }
        (theta, phi)
    }
}

/// Bins in (θ, φ) around an axis: θ edges (first 0, last π) times `n_phi` equal φ sectors.
struct Grid {
    frame: TestFrame,
    theta: Vec<f64>,
    n_phi: usize,
}

impl Grid {
    fn new(axis: DVec3, theta: Vec<f64>) -> Self {
        assert!(theta[0] == 0.0 && *theta.last().unwrap() == PI);
        assert!(theta.windows(2).all(|w| w[0] < w[1]));
        Grid {
            frame: TestFrame::around(axis),
            theta,
            n_phi: N_PHI,
        }
    }

    fn n_bins(&self) -> usize {
        (self.theta.len() - 1) * self.n_phi
    }

    fn bin(&self, w: DVec3) -> usize {
        let (t, p) = self.frame.angles(w);
        let i = self
            .theta
            .partition_point(|&b| b <= t)
            .clamp(1, self.theta.len() - 1)
            - 1;
        let j = ((p / TAU * self.n_phi as f64) as usize).min(self.n_phi - 1);
        i * self.n_phi + j
    }

    /// For every sign pattern of the cuts, the θ-interval of that piece at azimuth φ: each cut
    /// c (signed) keeps ω·c = cosθ c_z + sinθ (c_x cosφ + c_y sinφ) = R cos(θ − δ) > 0, an arc of
    /// length π centred on δ; unwrapping δ into [−π/2, 3π/2] makes its overlap with the meridian
    /// θ ∈ [0, π] the single interval [δ − π/2, δ + π/2]. Also returns which bound is active at
    /// each end (0: the pole, i + 1: cut i), so that kinks in φ can be located.
    fn pieces(&self, local: &[DVec3], phi: f64) -> Vec<(f64, f64, u8, u8)> {
        let (sp, cp) = phi.sin_cos();
        (0..(1usize << local.len()))
            .map(|pattern| {
                let (mut lo, mut hi, mut lo_by, mut hi_by) = (0.0f64, PI, 0u8, 0u8);
                for (i, c) in local.iter().enumerate() {
                    let s = if (pattern >> i) & 1 == 1 { -1.0 } else { 1.0 };
                    let mut delta = (s * (c.x * cp + c.y * sp)).atan2(s * c.z);
                    if delta < -FRAC_PI_2 {
                        delta += TAU;
                    }
                    if delta - FRAC_PI_2 > lo {
                        (lo, lo_by) = (delta - FRAC_PI_2, i as u8 + 1);
                    }
                    if delta + FRAC_PI_2 < hi {
                        (hi, hi_by) = (delta + FRAC_PI_2, i as u8 + 1);
                    }
                }
                (lo, hi, lo_by, hi_by)
            })
            .collect()
    }

    /// What decides the shape of the θ-integrals at φ: active bounds, empty pieces, and where the
    /// bounds lie among the bin edges. Between changes of this, every bin's integral is smooth in φ.
    fn structure(&self, local: &[DVec3], phi: f64) -> Vec<u8> {
        let mut v = Vec::new();
        for (lo, hi, lo_by, hi_by) in self.pieces(local, phi) {
            if hi <= lo {
                v.push(255);
                continue;
            }
            v.extend([lo_by, hi_by]);
            for &t in &self.theta[1..self.theta.len() - 1] {
                v.push((t > lo) as u8 + 2 * (t < hi) as u8);
            }
        }
        v
    }

    /// Splits [a, b] at every change of `structure` found by recursive bisection.
    fn split(&self, local: &[DVec3], a: f64, b: f64, sa: &[u8], sb: &[u8], out: &mut Vec<f64>) {
        if sa == sb {
            return;
        }
        if b - a < 1e-14 {
            out.push(0.5 * (a + b));
            return;
        }
        let mid = 0.5 * (a + b);
        let sm = self.structure(local, mid);
        self.split(local, a, mid, sa, &sm, out);
        self.split(local, mid, b, &sm, sb, out);
    }

    /// Per-bin integrals of `f` over the sphere, split along the planes `cuts` (through the
    /// origin, unit normals) into convex pieces (one per sign pattern), whose θ-extent at a given
    /// φ is a single interval. φ: `sub` cells per bin, each further split where the integrand's
    /// structure changes (so it is smooth on each part), `m`-point Gauss–Legendre on each part.
    /// θ: `m`-point Gauss–Legendre per panel (bin ∩ piece).
    fn integrate<const K: usize>(
        &self,
        cuts: &[DVec3],
        sub: usize,
        m: usize,
        f: &dyn Fn(DVec3) -> [f64; K],
    ) -> Vec<[f64; K]> {
        let local: Vec<DVec3> = cuts.iter().map(|c| self.frame.to_local(*c)).collect();
        let gl = gauss_legendre(m);
        let mut out = vec![[0.0; K]; self.n_bins()];
        // Nodes of whole (unclipped) θ panels, the common case: (sin θ, cos θ, weight).
        let whole: Vec<Vec<(f64, f64, f64)>> = self
            .theta
            .windows(2)
            .map(|e| {
                let (tmid, thalf) = (0.5 * (e[0] + e[1]), 0.5 * (e[1] - e[0]));
                gl.iter()
                    .map(|&(x, w)| {
                        let (st, ct) = (tmid + thalf * x).sin_cos();
                        (st, ct, w * thalf)
                    })
                    .collect()
            })
            .collect();
        let mut nodes = Vec::with_capacity(m);
        let n_cells = self.n_phi * sub;
        let dphi = TAU / n_cells as f64;
        for cell in 0..n_cells {
            let j = cell / sub;
            let (a, b) = (cell as f64 * dphi, (cell + 1) as f64 * dphi);
            let mut edges = vec![a];
            let (sa, sb) = (self.structure(&local, a), self.structure(&local, b));
            self.split(&local, a, b, &sa, &sb, &mut edges);
            edges.push(b);
            for part in edges.windows(2) {
                let (pmid, phalf) = (0.5 * (part[0] + part[1]), 0.5 * (part[1] - part[0]));
                for &(xp, wp) in &gl {
                    let phi = pmid + phalf * xp;
                    let (sp, cp) = phi.sin_cos();
                    let wphi = wp * phalf;
                    for (lo, hi, _, _) in self.pieces(&local, phi) {
                        if hi <= lo {
                            continue;
                        }
                        for i in 0..self.theta.len() - 1 {
                            let (ta, tb) = (lo.max(self.theta[i]), hi.min(self.theta[i + 1]));
                            if tb <= ta {
                                continue;
                            }
                            let panel = if ta == self.theta[i] && tb == self.theta[i + 1] {
                                &whole[i]
                            } else {
                                let (tmid, thalf) = (0.5 * (ta + tb), 0.5 * (tb - ta));
                                nodes.clear();
                                nodes.extend(gl.iter().map(|&(x, w)| {
                                    let (st, ct) = (tmid + thalf * x).sin_cos();
                                    (st, ct, w * thalf)
                                }));
                                &nodes
                            };
                            let acc = &mut out[i * self.n_phi + j];
                            for &(st, ct, wt) in panel {
                                let v = f(self.frame.dir(st, ct, sp, cp));
                                let jac = st * wt * wphi;
                                for k in 0..K {
                                    acc[k] += v[k] * jac;
                                }
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

/// θ edges resolving a lobe of angular width `w` around the axis (w ≥ 1: no lobe).
fn theta_edges(w: f64) -> Vec<f64> {
    let mut e = vec![0.0];
    if w < 1.0 {
        for k in [
            0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0,
        ] {
            if k * w < PI {
                e.push(k * w);
            }
        }
        let last = *e.last().unwrap();
        e.extend((1..12).map(|k| k as f64 * PI / 12.0).filter(|&t| t > last));
    } else {
        e.extend((1..24).map(|k| k as f64 * PI / 24.0));
    }
    e.push(PI);
    e
}

/// θ edges for a cone of half-angle `theta_max` around the axis.
fn cone_edges(theta_max: f64) -> Vec<f64> {
    let mut e: Vec<f64> = (0..=8).map(|k| k as f64 / 8.0 * theta_max).collect();
    e.extend(
        (1..12)
            .map(|k| k as f64 * PI / 12.0)
            .filter(|&t| t > theta_max),
    );
    e.push(PI);
    e
}

/// Integrals at two resolutions, with error bounds (see the module doc).
struct Integral<const K: usize> {
    bins: Vec<[f64; K]>,
    bin_err: Vec<[f64; K]>,
    total: [f64; K],
    err: [f64; K],
}

/// Rounding floor: naive summation of n ≤ 4e6 terms of one sign has relative error ≤ n ε < 1e-9.
const ROUND: f64 = 1e-9;

fn integrate<const K: usize>(
    grid: &Grid,
    cuts: &[DVec3],
    f: &dyn Fn(DVec3) -> [f64; K],
) -> Integral<K> {
    // Cuts that coincide (e.g. ns = ng) would only make empty pieces.
    let mut uniq: Vec<DVec3> = Vec::new();
    for c in cuts {
        let c = c.normalize();
        if uniq.iter().all(|u| (u.dot(c)).abs() < 1.0 - 1e-12) {
            uniq.push(c);
        }
    }
    let coarse = grid.integrate(&uniq, SUB, M, f);
    let fine = grid.integrate(&uniq, 2 * SUB, 2 * M, f);
    let mut total = [0.0; K];
    let mut total_coarse = [0.0; K];
    let mut bin_err = vec![[0.0; K]; fine.len()];
    for (b, (c, f)) in coarse.iter().zip(&fine).enumerate() {
        for k in 0..K {
            total[k] += f[k];
            total_coarse[k] += c[k];
            bin_err[b][k] = (c[k] - f[k]).abs() + ROUND * f[k].abs();
        }
    }
    let err = std::array::from_fn(|k| (total_coarse[k] - total[k]).abs() + ROUND * total[k].abs());
    Integral {
        bins: fine,
        bin_err,
        total,
        err,
    }
}

/// The quadrature's error bound must be sharp enough that a wrong normalisation cannot hide in it.
const SHARP: f64 = 1e-5;

// ------------------------------------------------------------------------------------------------
// Cases

/// Rec. 709 luminance, as documented for the lobe choice (written here independently).
fn lum(c: Rgb) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

fn grey(v: f64) -> Rgb {
    Rgb::splat(v)
}

/// A geometric normal away from the coordinate axes, so that no test relies on a special frame.
fn normal() -> DVec3 {
    DVec3::new(0.2, -0.3, 0.93).normalize()
}

/// Unit direction at polar cosine `cos_t` from `n`, azimuth `az` in a frame around `n`.
fn direction(n: DVec3, cos_t: f64, az: f64) -> DVec3 {
    let f = TestFrame::around(n);
    let s = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    f.dir(s, cos_t, az.sin(), az.cos()).normalize()
}

/// Mirror image of `w` about the unit normal `n` (test-side).
fn mirror_of(w: DVec3, n: DVec3) -> DVec3 {
    2.0 * w.dot(n) * n - w
}

#[derive(Clone, Debug)]
struct Case {
    label: String,
    bsdf: Bsdf,
    wo: DVec3,
    ng: DVec3,
    ns: DVec3,
}

impl Case {
    fn new(bsdf: Bsdf, cos_o: f64, tilt: f64, back: bool) -> Self {
        let ng = normal();
        let ns = direction(ng, tilt.cos(), 2.2);
        let wo = direction(if back { -ng } else { ng }, cos_o, 0.4);
        assert!((wo.dot(ng) < 0.0) == back);
        let label = format!("{bsdf:?} cosθo={cos_o} tilt={tilt} back={back}");
        Case {
            label,
            bsdf,
            wo,
            ng,
            ns,
        }
    }

    fn side(&self) -> f64 {
        if self.wo.dot(self.ng) >= 0.0 {
            1.0
        } else {
            -1.0
        }
    }
    fn ngo(&self) -> DVec3 {
        self.ng * self.side()
    }
    fn nso(&self) -> DVec3 {
        self.ns * self.side()
    }
    fn exponent(&self) -> Option<f64> {
        match self.bsdf {
            Bsdf::Glossy { exponent, .. } => Some(exponent),
            _ => None,
        }
    }
    /// Direction of the Phong lobe (and of the mirror lobe).
    fn mirror_dir(&self) -> DVec3 {
        mirror_of(self.wo, self.nso())
    }
    fn grid(&self) -> Grid {
        match self.exponent() {
            Some(n) => Grid::new(self.mirror_dir(), theta_edges(1.0 / n.sqrt())),
            None => Grid::new(self.nso(), theta_edges(1.0)),
        }
    }
    /// Planes along which the integrands may jump or kink.
    fn cuts(&self) -> Vec<DVec3> {
        let mut c = vec![self.ng, self.ns];
        if self.exponent().is_some() {
            c.push(self.mirror_dir());
        }
        c
    }
    /// Probability of the diffuse lobe, per the documented rule (luminance of the albedos).
    fn diffuse_probability(&self) -> f64 {
        match &self.bsdf {
            Bsdf::Diffuse { .. } => 1.0,
            Bsdf::Glossy { kd, ks, .. } | Bsdf::Mirror { kd, ks } => {
                lum(*kd) / (lum(*kd) + lum(*ks))
            }
            _ => 0.0,
        }
    }
    /// Cosine-weighted mass of the shading hemisphere above the geometric horizon: the shading
    /// hemisphere projects to the unit disk, the geometric horizon to half an ellipse of semi-axes
    /// 1 and cos β, so the part cut off has area π(1 − cos β)/2 of π.
    fn diffuse_mass(&self) -> f64 {
        (1.0 + self.ng.dot(self.ns)) / 2.0
    }
    /// Bracket on ∫ pdf dω over the sphere. The Phong lobe loses at most its mass beyond the
    /// angle γ from its axis to the nearest horizon, which is cos^(n+1) γ (its θ-CDF is
    /// 1 − cos^(n+1) θ).
    fn pdf_mass_bounds(&self) -> (f64, f64) {
        let pd = self.diffuse_probability();
        let d = pd * self.diffuse_mass();
        match self.exponent() {
            None => (d, d),
            Some(n) => {
                let r = self.mirror_dir();
                let gamma = r
                    .dot(self.ngo())
                    .min(r.dot(self.nso()))
                    .clamp(-1.0, 1.0)
                    .asin();
                let lost = if gamma > 0.0 {
                    gamma.cos().powf(n + 1.0)
                } else {
                    1.0
                };
                (d + (1.0 - pd) * (1.0 - lost), d + (1.0 - pd))
            }
        }
    }
}

fn glossy(kd: f64, ks: f64, exponent: f64) -> Bsdf {
    Bsdf::Glossy {
        kd: grey(kd),
        ks: grey(ks),
        exponent,
    }
}

/// Cases for the density and furnace tests of one BSDF family.
fn cases(family: &str) -> Vec<Case> {
    let mut v = Vec::new();
    match family {
        "diffuse" => {
            let b = Bsdf::Diffuse { kd: grey(1.0) };
            for cos_o in [1.0, 0.5, 0.02] {
                v.push(Case::new(b.clone(), cos_o, 0.0, false));
            }
            v.push(Case::new(b.clone(), 0.5, 0.0, true));
            v.push(Case::new(b.clone(), 0.5, 0.25, false));
            v.push(Case::new(b.clone(), 0.3, 0.25, true));
            v.push(Case::new(b.clone(), 0.02, 0.25, false)); // wo below the shading horizon
        }
        "mirror" => {
            let b = Bsdf::Mirror {
                kd: grey(0.4),
                ks: grey(0.6),
            };
            for cos_o in [1.0, 0.7, 0.2, 0.02] {
                v.push(Case::new(b.clone(), cos_o, 0.0, false));
            }
            v.push(Case::new(b.clone(), 0.5, 0.0, true));
            v.push(Case::new(b.clone(), 0.7, 0.25, false));
            v.push(Case::new(b.clone(), 0.2, 0.25, true));
            v.push(Case::new(b.clone(), 0.02, 0.25, false)); // wo below the shading horizon
        }
        _ => {
            let n: f64 = family.parse().expect("glossy exponent");
            for (kd, ks) in [(0.0, 1.0), (0.3, 0.7)] {
                let b = glossy(kd, ks, n);
                for cos_o in [1.0, 0.7, 0.2, 0.02] {
                    v.push(Case::new(b.clone(), cos_o, 0.0, false));
                }
                v.push(Case::new(b.clone(), 0.7, 0.25, false));
                v.push(Case::new(b.clone(), 0.2, 0.25, false));
            }
            v.push(Case::new(glossy(0.0, 1.0, n), 0.5, 0.0, true));
            v.push(Case::new(glossy(0.3, 0.7, n), 0.6, 0.25, true));
            // wo below the shading horizon (but above the geometric one).
            v.push(Case::new(glossy(0.3, 0.7, n), 0.02, 0.25, false));
        }
    }
    v
}

// ------------------------------------------------------------------------------------------------
// Test drivers

/// Relative closeness in ulps-scaled units.
fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + f64::MIN_POSITIVE
}

/// Test 1 for one BSDF case: normalisation of `pdf`, `sample` against `pdf` (chi-square), and
/// `weight == eval / pdf`, `sample.pdf == pdf` for every non-delta sample.
fn check_density_and_sampling(case: &Case, stream: u64) {
    let (wo, ng, ns) = (case.wo, case.ng, case.ns);
    let grid = case.grid();
    let q = integrate(&grid, &case.cuts(), &|w| [case.bsdf.pdf(wo, w, ng, ns)]);
    let (total, err) = (q.total[0], q.err[0]);
    let (lo, hi) = case.pdf_mass_bounds();
    assert!(
        err < SHARP,
        "{}: quadrature error bound {err:e}",
        case.label
    );
    assert!(
        total >= lo - err && total <= hi + err,
        "{}: ∫pdf = {total} ± {err:.1e}, expected in [{lo}, {hi}]",
        case.label
    );

    let n = N_SAMPLES;
    let mut counts = vec![0.0; grid.n_bins() + 1];
    let mut s = Sampler::new(SEED, 1, stream);
    for _ in 0..n {
        let (ul, u) = (s.next_f64(), s.next_2d());
        match case.bsdf.sample(wo, ng, ns, ul, u, Mode::Importance) {
            Some(smp) if !smp.delta => {
                let wi = smp.wi;
                assert!((wi.length() - 1.0).abs() < 8.0 * EPS, "{}", case.label);
                let p = case.bsdf.pdf(wo, wi, ng, ns);
                let f = case.bsdf.eval(wo, wi, ng, ns, Mode::Importance);
                assert!(
                    p > 0.0 && close(smp.pdf, p, 8.0 * EPS),
                    "{}: sample.pdf {} vs pdf {p} at {wi}",
                    case.label,
                    smp.pdf
                );
                for k in 0..3 {
                    assert!(
                        close(smp.weight[k], f[k] / p, 8.0 * EPS),
                        "{}: weight {} vs eval/pdf {} at {wi}",
                        case.label,
                        smp.weight,
                        f / p
                    );
                }
                counts[grid.bin(wi)] += 1.0;
            }
            _ => *counts.last_mut().unwrap() += 1.0,
        }
    }
    let nf = n as f64;
    let mut expected: Vec<f64> = q.bins.iter().map(|b| b[0] * nf).collect();
    let mut expected_err: Vec<f64> = q.bin_err.iter().map(|b| b[0] * nf).collect();
    // Delta lobes and failed samples: whatever the non-delta density does not account for.
    expected.push((nf * (1.0 - total)).max(0.0));
    expected_err.push(nf * err);
    chi2_test(&case.label, &counts, &expected, &expected_err);
}

/// Test 2 for one (white) BSDF case: the albedo by quadrature and the Monte Carlo mean of the
/// sample weights. Returns (albedo, its error bound).
fn check_furnace(case: &Case, stream: u64) -> (f64, f64) {
    let (wo, ng, ns) = (case.wo, case.ng, case.ns);
    let q = integrate(&case.grid(), &case.cuts(), &|w| {
        let f = case.bsdf.eval(wo, w, ng, ns, Mode::Importance);
        [f.x, f.y, f.z]
    });
    let (albedo, err) = (q.total[0], q.err[0]);
    assert!(
        err < SHARP,
        "{}: quadrature error bound {err:e}",
        case.label
    );
    for k in 1..3 {
        assert!(close(q.total[k], albedo, 1e-14), "white BSDF, grey albedo");
    }
    assert!(
        albedo <= 1.0 + err,
        "{}: albedo {albedo} ± {err:.1e} > 1",
        case.label
    );
    // The mirror lobe adds ks when its direction is above both horizons.
    let delta = match &case.bsdf {
        Bsdf::Mirror { ks, .. } if case.mirror_dir().dot(case.ngo()) > 0.0 => ks.x,
        _ => 0.0,
    };

    let n = N_FURNACE;
    let mut s = Sampler::new(SEED, 2, stream);
    let (mut sum, mut sum2) = (0.0, 0.0);
    for _ in 0..n {
        let (ul, u) = (s.next_f64(), s.next_2d());
        if let Some(smp) = case.bsdf.sample(wo, ng, ns, ul, u, Mode::Importance) {
            let w = smp.weight.x;
            assert!(w.is_finite() && w >= 0.0, "{}: weight {w}", case.label);
            sum += w;
            sum2 += w * w;
        }
    }
    let (mean, se) = mean_and_se(sum, sum2, n);
    // Plus the rounding bound of naive summation (n ε relative).
    let tol_mc = N_SE * se + n as f64 * EPS * mean.abs();
    assert!(
        mean <= 1.0 + tol_mc,
        "{}: E[weight] = {mean} ± {se:.1e} > 1",
        case.label
    );
    assert!(
        (mean - (albedo + delta)).abs() <= tol_mc + err,
        "{}: E[weight] = {mean} ± {se:.1e}, albedo {albedo} ± {err:.1e} + delta {delta}",
        case.label
    );
    (albedo, err)
}

fn run_density_family(family: &str, pass: u64) {
    for (i, c) in cases(family).iter().enumerate() {
        check_density_and_sampling(c, pass * 1000 + i as u64);
    }
}

// ------------------------------------------------------------------------------------------------
// The statistics and the quadrature themselves

#[test]
fn statistics_helpers_match_tables() {
    // Φ⁻¹ from tables (12 decimals): the tail at the tabulated z must be 1 − p within the Simpson
    // bound plus the table's rounding, and Φ(Φ⁻¹(p)) = p within that plus the bisection's step.
    for (p, z) in [
        (0.975, 1.959_963_984_540f64),
        (0.999, 3.090_232_306_168),
        (1.0 - 1e-4, 3.719_016_485_456),
        (0.5, 0.0),
        (0.01, -2.326_347_874_041),
    ] {
        let dens = (-0.5 * z * z).exp() / TAU.sqrt();
        let tol = 1e-11 + dens * 5e-13;
        let q = normal_upper_tail(z);
        assert!((q - (1.0 - p)).abs() <= tol, "Q({z}) = {q}");
        let zq = normal_quantile(p);
        assert!(
            (normal_upper_tail(zq) - (1.0 - p)).abs() <= tol + 1e-15,
            "Φ⁻¹({p}) = {zq}"
        );
    }
    // χ² quantiles (regularised incomplete gamma, computed with mpmath); Wilson–Hilferty is
    // within 0.4 % at α = 1e-4 for dof ≥ 30 (on the high side), better as dof grows.
    for (k, alpha, x) in [
        (30.0, 1e-4, 67.632_630),
        (100.0, 1e-4, 161.318_657),
        (300.0, 1e-4, 399.755_936),
        (50.0, 0.05, 67.504_807),
    ] {
        assert!(
            (chi2_quantile(k, alpha) / x - 1.0).abs() < 5e-3,
            "χ² quantile k={k}"
        );
    }
    assert!((poisson_upper_tail(2.0, 1) - (1.0 - (-2.0f64).exp())).abs() < 1e-15);
    // Binomial tails in closed form, and at a large n against the Poisson limit.
    let p0 = 0.9f64.powi(10);
    assert!((binomial_lower_tail(10, 0.1, 0) - p0).abs() < 1e-14);
    assert!((binomial_upper_tail(10, 0.1, 1) - (1.0 - p0)).abs() < 1e-14);
    let (b, q) = (
        binomial_upper_tail(100_000, 2e-5, 5),
        poisson_upper_tail(2.0, 5),
    );
    assert!((b / q - 1.0).abs() < 1e-3, "{b} vs {q}");
    // Student's t from tables: P(T₃₀ ≥ 3.385) = 0.001, P(T₄ ≥ 4.604) = 0.005, P(T₁₀ ≥ 2.228) =
    // 0.025 (to the tables' 4 digits).
    for (t, dof, tail) in [
        (3.385, 30.0, 1e-3),
        (4.604, 4.0, 5e-3),
        (2.228, 10.0, 0.025),
    ] {
        let got = student_t_upper_tail(t, dof);
        assert!((got / tail - 1.0).abs() < 2e-3, "t {t}, {dof} dof: {got}");
    }
    // The tolerances: Φ⁻¹(1 − 5e-5) and Φ⁻¹(1 − 5e-6).
    assert!((z_limit(1) - 3.890_591_886).abs() < 1e-6);
    assert!((z_limit(10) - 4.417_173_414).abs() < 1e-6);
}

#[test]
fn quadrature_reproduces_closed_forms() {
    let ng = normal();
    let ns = direction(ng, 0.25f64.cos(), 2.2);
    let a = direction(ng, 0.3, 1.0);
    let check = |what: &str, q: &Integral<1>, exact: f64| {
        let (v, e) = (q.total[0], q.err[0]);
        assert!(e < SHARP, "{what}: error bound {e:e}");
        assert!(
            (v - exact).abs() <= e,
            "{what}: {v} vs {exact} (bound {e:e})"
        );
    };
    // Area of the sphere, cut in four pieces.
    let g = Grid::new(a, theta_edges(1.0));
    check(
        "area",
        &integrate(&g, &[ng, ns], &|_| [1.0 / (4.0 * PI)]),
        1.0,
    );
    // Cosine lobe around ns clipped by the plane of ng (integrated around another axis).
    check(
        "clipped cosine",
        &integrate(&g, &[ng, ns], &|w| {
            [if w.dot(ng) > 0.0 {
                w.dot(ns).max(0.0) / PI
            } else {
                0.0
            }]
        }),
        (1.0 + ng.dot(ns)) / 2.0,
    );
    // Phong lobes around a, unclipped, at the sharpest exponent tested.
    for n in [1.0, 10.0, 200.0, 10000.0] {
        let g = Grid::new(a, theta_edges(1.0 / f64::sqrt(n)));
        check(
            "phong",
            &integrate(&g, &[a], &|w| [(n + 1.0) / TAU * w.dot(a).max(0.0).powf(n)]),
            1.0,
        );
    }
    // n = 1 lobe around a clipped by the plane of ng: the clipped-cosine formula again.
    let g = Grid::new(a, theta_edges(1.0));
    check(
        "clipped n=1",
        &integrate(&g, &[a, ng], &|w| {
            [if w.dot(ng) > 0.0 {
                w.dot(a).max(0.0) / PI
            } else {
                0.0
            }]
        }),
        (1.0 + ng.dot(a)) / 2.0,
    );
}

// ------------------------------------------------------------------------------------------------
// 1. Warps: densities integrate to 1 and samples follow them

fn check_warp(
    label: &str,
    grid: &Grid,
    cuts: &[DVec3],
    pdf: &dyn Fn(DVec3) -> f64,
    sample: &mut dyn FnMut(&mut Sampler) -> DVec3,
    stream: u64,
) {
    let q = integrate(grid, cuts, &|w| [pdf(w)]);
    assert!(q.err[0] < SHARP, "{label}: error bound {:e}", q.err[0]);
    assert!(
        (q.total[0] - 1.0).abs() <= q.err[0],
        "{label}: ∫pdf = {} ± {:.1e}",
        q.total[0],
        q.err[0]
    );
    let n = N_SAMPLES;
    let mut counts = vec![0.0; grid.n_bins()];
    let mut s = Sampler::new(SEED, 3, stream);
    for _ in 0..n {
        let w = sample(&mut s);
        assert!(
            (w.length() - 1.0).abs() < 8.0 * EPS,
            "{label}: |w| = {}",
            w.length()
        );
        assert!(pdf(w) > 0.0, "{label}: sample {w} where the density is 0");
        counts[grid.bin(w)] += 1.0;
    }
    let nf = n as f64;
    let expected: Vec<f64> = q.bins.iter().map(|b| b[0] * nf).collect();
    let expected_err: Vec<f64> = q.bin_err.iter().map(|b| b[0] * nf).collect();
    chi2_test(label, &counts, &expected, &expected_err);
}

#[test]
fn warp_uniform_sphere() {
    check_warp(
        "uniform sphere",
        &Grid::new(DVec3::Z, theta_edges(1.0)),
        &[],
        &|_| pdf_uniform_sphere(),
        &mut |s| sample_uniform_sphere(s.next_2d()),
        0,
    );
}

#[test]
fn warp_cosine_hemisphere() {
    check_warp(
        "cosine hemisphere",
        &Grid::new(DVec3::Z, theta_edges(1.0)),
        &[DVec3::Z],
        &|w| pdf_cosine_hemisphere(w.z),
        &mut |s| sample_cosine_hemisphere(s.next_2d()),
        1,
    );
}

#[test]
fn warp_uniform_cone() {
    for (i, cos_max) in [0.9f64, 0.0, -0.6].into_iter().enumerate() {
        let omc = 1.0 - cos_max;
        check_warp(
            &format!("cone cos_max={cos_max}"),
            &Grid::new(DVec3::Z, cone_edges(cos_max.acos())),
            &[],
            &|w| {
                if w.z >= cos_max {
                    pdf_uniform_cone(omc)
                } else {
                    0.0
                }
            },
            &mut |s| sample_uniform_cone(s.next_2d(), cos_max),
            10 + i as u64,
        );
    }
    // Tiny cones through the 1 − cos form; the indicator uses the angle, exact at this scale.
    for (i, theta_max) in [1e-3f64, 1e-6].into_iter().enumerate() {
        let omc = 2.0 * (theta_max / 2.0).sin().powi(2);
        let frame = TestFrame::around(DVec3::Z);
        check_warp(
            &format!("cone θmax={theta_max}"),
            &Grid::new(DVec3::Z, cone_edges(theta_max)),
            &[],
            &|w| {
                if frame.angles(w).0 <= theta_max * (1.0 + 1e-12) {
                    pdf_uniform_cone(omc)
                } else {
                    0.0
                }
            },
            &mut |s| sample_uniform_cone_1mc(s.next_2d(), omc),
            20 + i as u64,
        );
    }
}

#[test]
fn warp_phong_lobe() {
    for (i, n) in [1.0f64, 10.0, 200.0, 10000.0].into_iter().enumerate() {
        check_warp(
            &format!("phong lobe n={n}"),
            &Grid::new(DVec3::Z, theta_edges(1.0 / n.sqrt())),
            &[DVec3::Z],
            &|w| pdf_phong_lobe(w.z, n),
            &mut |s| sample_phong_lobe(s.next_2d(), n),
            30 + i as u64,
        );
    }
}

#[test]
fn warp_uniform_triangle() {
    // k² congruent sub-triangles of the reference triangle, each expecting N/k² samples.
    let k = 8usize;
    let n = N_SAMPLES;
    let mut counts = vec![0.0; k * k];
    let mut s = Sampler::new(SEED, 3, 40);
    for _ in 0..n {
        let (b0, b1, b2) = sample_uniform_triangle(s.next_2d());
        assert!(
            b0 >= 0.0 && b1 >= 0.0 && b2 >= -4.0 * EPS,
            "({b0}, {b1}, {b2})"
        );
        assert!((b0 + b1 + b2 - 1.0).abs() <= 4.0 * EPS);
        let (x, y) = (b1 * k as f64, b2 * k as f64);
        let (i, j) = (
            (x.floor() as usize).min(k - 1),
            (y.floor() as usize).min(k - 1),
        );
        // Row j holds 2(k − j) − 1 triangles: upright ones at i, inverted ones after them.
        let upper = (x - i as f64) + (y - j as f64) > 1.0;
        let row_start: usize = (0..j).map(|r| 2 * (k - r) - 1).sum();
        let idx = row_start + 2 * i + upper as usize;
        counts[idx.min(k * k - 1)] += 1.0;
    }
    let e = n as f64 / (k * k) as f64;
    chi2_test(
        "uniform triangle",
        &counts,
        &vec![e; k * k],
        &vec![0.0; k * k],
    );
}

#[test]
fn warp_uniform_circle() {
    use ftpd3d::kernel::{Flatland, Space};
    let bins = 64;
    assert!((Flatland::PDF_UNIFORM * TAU - 1.0).abs() <= 2.0 * EPS);
    // The flatland space's uniform direction, in the plane z = 0.
    let pl = Flatland::new(DVec3::ZERO, DVec3::X, DVec3::Y);
    let n = N_SAMPLES;
    let mut counts = vec![0.0; bins];
    let mut s = Sampler::new(SEED, 3, 50);
    for _ in 0..n {
        let w = pl.uniform(s.next_2d());
        assert!(w.z == 0.0 && (w.length() - 1.0).abs() < 4.0 * EPS);
        let phi = w.y.atan2(w.x).rem_euclid(TAU);
        counts[((phi / TAU * bins as f64) as usize).min(bins - 1)] += 1.0;
    }
    let e = n as f64 * Flatland::PDF_UNIFORM * TAU / bins as f64;
    chi2_test("uniform circle", &counts, &vec![e; bins], &vec![0.0; bins]);
}

// ------------------------------------------------------------------------------------------------
// 1. BSDFs: pdf normalisation, sample vs pdf, weight = eval/pdf

#[test]
fn diffuse_pdf_integrates_and_matches_sampling() {
    run_density_family("diffuse", 1);
}

#[test]
fn mirror_diffuse_part_pdf_integrates_and_matches_sampling() {
    run_density_family("mirror", 2);
}

#[test]
fn glossy_pdf_integrates_and_matches_sampling_n1() {
    run_density_family("1", 3);
}

#[test]
fn glossy_pdf_integrates_and_matches_sampling_n10() {
    run_density_family("10", 4);
}

#[test]
fn glossy_pdf_integrates_and_matches_sampling_n200() {
    run_density_family("200", 5);
}

#[test]
fn glossy_pdf_integrates_and_matches_sampling_n10000() {
    run_density_family("10000", 6);
}

// ------------------------------------------------------------------------------------------------
// 2. White furnace

#[test]
fn white_furnace_diffuse() {
    for (i, c) in cases("diffuse").iter().enumerate() {
        let (albedo, err) = check_furnace(c, 100 + i as u64);
        // Lambertian: all of the cosine lobe above the geometric horizon is kept.
        let exact = c.diffuse_mass();
        assert!(
            (albedo - exact).abs() <= err,
            "{}: albedo {albedo} vs {exact}",
            c.label
        );
    }
}

#[test]
fn white_furnace_mirror() {
    for (i, c) in cases("mirror").iter().enumerate() {
        let (albedo, err) = check_furnace(c, 200 + i as u64);
        let exact = 0.4 * c.diffuse_mass();
        assert!(
            (albedo - exact).abs() <= err,
            "{}: albedo {albedo} vs {exact}",
            c.label
        );
    }
}

#[test]
fn white_furnace_glossy() {
    for (j, n) in ["1", "10", "200", "10000"].into_iter().enumerate() {
        for (i, c) in cases(n).iter().enumerate() {
            let (albedo, err) = check_furnace(c, 300 + 100 * j as u64 + i as u64);
            // At normal incidence the normalised Phong lobe lies entirely above the horizon and
            // ∫ (n+2)/2π cos^n θ cos θ dω = 1, so a white mixture has albedo exactly 1.
            if c.ns == c.ng && (c.wo.dot(c.ng) - 1.0).abs() < 1e-12 {
                assert!(
                    (albedo - 1.0).abs() <= err,
                    "{}: albedo {albedo} ± {err:.1e} at normal incidence",
                    c.label
                );
            }
        }
    }
}

#[test]
fn lambertian_weight_is_exactly_its_albedo() {
    let ng = normal();
    let b = Bsdf::Diffuse {
        kd: Rgb::new(0.8, 0.5, 0.2),
    };
    let mut s = Sampler::new(SEED, 4, 0);
    for cos_o in [1.0, 0.5, 0.02, -0.3] {
        let wo = direction(ng, cos_o, 0.7);
        for _ in 0..1000 {
            let smp = b
                .sample(wo, ng, ng, s.next_f64(), s.next_2d(), Mode::Importance)
                .expect("ns = ng: a cosine sample is always above the horizon");
            assert_eq!(smp.weight, Rgb::new(0.8, 0.5, 0.2));
            assert!(
                smp.wi.dot(ng) * wo.dot(ng) > 0.0,
                "two-sided: same side as wo"
            );
        }
    }
}

// ------------------------------------------------------------------------------------------------
// 3. Reciprocity

#[test]
fn reciprocity_of_diffuse_and_glossy() {
    let ng = normal();
    let mut s = Sampler::new(SEED, 5, 0);
    // (BSDF, Phong exponent, ks)
    let bsdfs = [
        (Bsdf::Diffuse { kd: grey(0.7) }, 0.0f64, 0.0f64),
        (glossy(0.0, 1.0, 1.0), 1.0, 1.0),
        (glossy(0.3, 0.7, 10.0), 10.0, 0.7),
        (glossy(0.0, 0.9, 200.0), 200.0, 0.9),
        (glossy(0.2, 0.8, 10000.0), 10000.0, 0.8),
    ];
    for tilt in [0.0, 0.25] {
        let ns = direction(ng, f64::cos(tilt), 2.2);
        for (b, n, ks) in &bsdfs {
            let mut nonzero = 0;
            for i in 0..20_000 {
                let wo = sample_uniform_sphere(s.next_2d());
                let nso = if wo.dot(ng) >= 0.0 { ns } else { -ns };
                let r = mirror_of(wo, nso);
                // Half the pairs near the mirror direction, so the sharp lobes are exercised.
                let wi = if i % 2 == 0 {
                    sample_uniform_sphere(s.next_2d())
                } else {
                    let cos_max = (1.0 - 4.0 / n.max(1.0)).max(-1.0);
                    TestFrame::around(r).to_world(sample_uniform_cone(s.next_2d(), cos_max))
                };
                // With shading normals the two directions must also agree on the shading side
                // (see the report: the BSDF is not reciprocal otherwise).
                let same = |w: DVec3| (w.dot(ng) > 0.0) == (w.dot(ns) > 0.0);
                if !same(wo) || !same(wi) {
                    continue;
                }
                // f(wo,wi)|cos θi| |cos θo| both ways: no division, so no amplified rounding.
                let f1 = b.eval(wo, wi, ng, ns, Mode::Importance).x * wo.dot(ns).abs();
                let f2 = b.eval(wi, wo, ng, ns, Mode::Importance).x * wi.dot(ns).abs();
                if f1 > 0.0 {
                    nonzero += 1;
                }
                // cos α = r·wi is rounded differently each way (≤ 16 ε absolute); the Phong term
                // moves by its derivative ks (n+2)/2π n cos^(n−1) α times that. The rest is a few
                // rounded products (16 ε relative).
                // Cosines scale both sides equally. Below the normal range (cos^n α underflows
                // for the sharp lobes) precision is absolute: 2^-1074 times factors < 1e4, far
                // below f64::MIN_POSITIVE.
                // Here f cos θi cos θo = ks (n+1)/2π cos^n α · min(cos θi, cos θo).
                let cos_a = r.dot(wi).abs();
                let dspec = if *n > 0.0 {
                    ks * (n + 1.0) / TAU * n * cos_a.powf(n - 1.0)
                } else {
                    0.0
                };
                let cc = wo.dot(ns).abs().min(wi.dot(ns).abs());
                let tol = 16.0 * EPS * (f1.max(f2) + dspec * cc) + f64::MIN_POSITIVE;
                assert!(
                    (f1 - f2).abs() <= tol,
                    "{b:?}: f(wo,wi) = {f1}, f(wi,wo) = {f2} (wo {wo}, wi {wi})"
                );
            }
            assert!(nonzero > 1000, "{b:?}: too few non-zero pairs ({nonzero})");
        }
    }
}

// ------------------------------------------------------------------------------------------------
// 4. Fresnel and the smooth dielectric

/// Fresnel reflectances (Rs, Rp) from the angle forms of Fresnel's equations for light going from
/// index n1 into n2 at incidence θi; `None` past the critical angle.
fn fresnel_angle_form(theta_i: f64, n1: f64, n2: f64) -> Option<(f64, f64)> {
    let st = n1 / n2 * theta_i.sin();
    if st >= 1.0 {
        return None;
    }
    if theta_i == 0.0 {
        let r = ((n1 - n2) / (n1 + n2)).powi(2);
        return Some((r, r));
    }
    let theta_t = st.asin();
    let rs = ((theta_i - theta_t).sin() / (theta_i + theta_t).sin()).powi(2);
    let rp = ((theta_i - theta_t).tan() / (theta_i + theta_t).tan()).powi(2);
    Some((rs, rp))
}

const ETAS: [f64; 6] = [1.33, 1.5, 2.4, 1.0 / 1.33, 1.0 / 1.5, 1.0 / 2.4];

#[test]
fn fresnel_normal_incidence() {
    for eta in ETAS {
        let exact = ((eta - 1.0) / (eta + 1.0)).powi(2);
        let f = fresnel_dielectric(1.0, eta);
        assert!(close(f, exact, 8.0 * EPS), "η={eta}: {f} vs {exact}");
    }
    assert_eq!(
        fresnel_dielectric(1.0, 1.0),
        0.0,
        "index matched: no reflection"
    );
}

#[test]
fn fresnel_brewster_angle() {
    for eta in ETAS {
        // tan θB = η: θi + θt = π/2, the p-polarised part vanishes and
        // Rs = sin²(θi − θt)/sin²(θi + θt) = cos²(2θB) = ((η² − 1)/(η² + 1))².
        let theta_b = eta.atan();
        let rs = ((eta * eta - 1.0) / (eta * eta + 1.0)).powi(2);
        // s formula written directly: (cos θi − η cos θt)/(cos θi + η cos θt).
        let (ci, si) = (theta_b.cos(), theta_b.sin());
        let ct = (1.0 - si * si / (eta * eta)).sqrt();
        let rs_direct = ((ci - eta * ct) / (ci + eta * ct)).powi(2);
        assert!(close(rs, rs_direct, 1e-13), "η={eta}: {rs} vs {rs_direct}");
        let f = fresnel_dielectric(ci, eta);
        // cos θB carries a rounding error of ε, moving F by |dF/dcos| ε; F is O(Rs) and its
        // derivative is O(1) here, so compare to 1e-13 of the value.
        assert!(
            close(f, rs / 2.0, 1e-13),
            "η={eta}: F(θB) = {f}, Rs/2 = {}",
            rs / 2.0
        );
    }
}

#[test]
fn fresnel_matches_angle_form_of_fresnel_equations() {
    for eta in ETAS {
        for k in 0..=1000 {
            let theta = k as f64 / 1000.0 * FRAC_PI_2;
            let f = fresnel_dielectric(theta.cos(), eta);
            match fresnel_angle_form(theta, 1.0, eta) {
                Some((rs, rp)) => {
                    let exact = (rs + rp) / 2.0;
                    // The two forms differ by how rounding enters near θ = 0 (0/0 in the angle
                    // form) and θ = π/2: allow 1e-12 relative, away from exact grazing.
                    if k < 1000 {
                        assert!(close(f, exact, 1e-11), "η={eta} θ={theta}: {f} vs {exact}");
                    }
                }
                None => assert_eq!(f, 1.0, "η={eta} θ={theta}: past the critical angle"),
            }
        }
    }
}

#[test]
fn fresnel_total_internal_reflection() {
    for ior in [1.33f64, 1.5, 2.4] {
        let eta = 1.0 / ior; // glass to air
        let theta_c = eta.asin();
        for k in 1..=100 {
            let theta = theta_c + (FRAC_PI_2 - theta_c) * k as f64 / 100.0;
            assert_eq!(
                fresnel_dielectric(theta.cos(), eta),
                1.0,
                "TIR at θ={theta}"
            );
        }
        assert_eq!(fresnel_dielectric((theta_c + 1e-9).cos(), eta), 1.0);
        // Approaching the critical angle from below, 1 − F ≈ K √δ with
        // K = 2 (η + 1/η) √(2 / (η cos θc)) (first order in cos θt ≈ √(2 cos θc δ / η)):
        // the relative deviation from K must shrink as δ → 0.
        let kk = 2.0 * (eta + 1.0 / eta) * (2.0 / (eta * theta_c.cos())).sqrt();
        let dev = |delta: f64| {
            let f = fresnel_dielectric((theta_c - delta).cos(), eta);
            assert!(f < 1.0);
            ((1.0 - f) / delta.sqrt() / kk - 1.0).abs()
        };
        let (d6, d8, d10) = (dev(1e-6), dev(1e-8), dev(1e-10));
        assert!(
            d10 < d8 && d8 < d6 && d6 < 1e-2,
            "ior={ior}: deviations {d6:e} {d8:e} {d10:e}"
        );
    }
}

#[test]
fn fresnel_monotone_and_continuous_to_grazing() {
    for eta in ETAS {
        let mut prev = fresnel_dielectric(1.0, eta);
        for k in 1..=10_000 {
            let theta = k as f64 / 10_000.0 * FRAC_PI_2;
            let f = fresnel_dielectric(theta.cos(), eta);
            assert!((0.0..=1.0).contains(&f));
            assert!(
                f >= prev - 4.0 * EPS,
                "η={eta}: F drops at θ={theta}: {prev} → {f}"
            );
            prev = f;
        }
        assert_eq!(fresnel_dielectric(0.0, eta), 1.0, "η={eta}: grazing");
        if eta > 1.0 {
            // Towards grazing 1 − F ≈ K cos θi with K = 2 (η + 1/η) / √(1 − 1/η²).
            let kk = 2.0 * (eta + 1.0 / eta) / (1.0 - 1.0 / (eta * eta)).sqrt();
            let dev = |c: f64| ((1.0 - fresnel_dielectric(c, eta)) / c / kk - 1.0).abs();
            let (d2, d4, d6) = (dev(1e-2), dev(1e-4), dev(1e-6));
            assert!(
                d6 < d4 && d4 < d2 && d2 < 0.1,
                "η={eta}: deviations {d2:e} {d4:e} {d6:e}"
            );
        }
    }
}

/// One dielectric configuration: sample many times and check every sample.
fn check_dielectric(ior: f64, theta: f64, front: bool, tilt: f64, stream: u64) {
    let ng = normal();
    let ns = direction(ng, tilt.cos(), 2.2);
    let side = if front { 1.0 } else { -1.0 };
    let n_w = ns * side; // shading normal on wo's side
    let wo = {
        let t = TestFrame::around(n_w);
        t.dir(theta.sin(), theta.cos(), 0.3f64.sin(), 0.3f64.cos())
    };
    let label = format!("ior={ior} θ={theta} front={front} tilt={tilt}");
    let (eta1, eta2) = if front { (1.0, ior) } else { (ior, 1.0) };
    let fres = fresnel_angle_form(theta, eta1, eta2).map_or(1.0, |(rs, rp)| (rs + rp) / 2.0);
    let tint = Rgb::new(0.9, 0.8, 0.7);
    let white = Bsdf::Dielectric {
        ior,
        tint: Rgb::ONE,
    };
    let tinted = Bsdf::Dielectric { ior, tint };
    assert!(white.is_delta());
    let n = 20_000;
    let (mut reflected, mut valid) = (0usize, 0usize);
    let mut s = Sampler::new(SEED, 6, stream);
    for _ in 0..n {
        let (ul, u) = (s.next_f64(), s.next_2d());
        let Some(smp) = white.sample(wo, ng, ns, ul, u, Mode::Importance) else {
            assert!(tilt > 0.0, "{label}: ns = ng never fails");
            continue;
        };
        valid += 1;
        let wi = smp.wi;
        assert!(smp.delta && smp.pdf == 0.0, "{label}");
        assert_eq!(smp.weight, Rgb::ONE, "{label}: white importance weight");
        assert!((wi.length() - 1.0).abs() < 8.0 * EPS);
        assert_eq!(white.eval(wo, wi, ng, ns, Mode::Importance), Rgb::ZERO);
        assert_eq!(white.pdf(wo, wi, ng, ns), 0.0);
        let rad = white.sample(wo, ng, ns, ul, u, Mode::Radiance).unwrap();
        let tin = tinted.sample(wo, ng, ns, ul, u, Mode::Importance).unwrap();
        assert_eq!(rad.wi, wi);
        if wi.dot(ng) * side > 0.0 {
            reflected += 1;
            // Angle preserved, in the plane of wo and n: wi + wo ∥ n.
            assert!((wi.dot(n_w) - wo.dot(n_w)).abs() <= 8.0 * EPS, "{label}");
            assert!((wi + wo).cross(n_w).length() <= 16.0 * EPS, "{label}");
            assert_eq!(rad.weight, Rgb::ONE);
            assert_eq!(tin.weight, Rgb::ONE, "reflection is not tinted");
        } else {
            // Snell: η1 sin θ1 = η2 sin θ2, on the far side, tangential parts opposed.
            let (s1, s2) = (wo.cross(n_w).length(), wi.cross(n_w).length());
            assert!(
                (eta1 * s1 - eta2 * s2).abs() <= 16.0 * EPS * ior,
                "{label}: {eta1}·{s1} vs {eta2}·{s2}"
            );
            assert!(wi.dot(n_w) < 0.0);
            let (to, ti) = (wo - wo.dot(n_w) * n_w, wi - wi.dot(n_w) * n_w);
            assert!(
                (ti + to * (eta1 / eta2)).length() <= 16.0 * EPS * ior,
                "{label}"
            );
            // Radiance is scaled by (η1/η2)² = 1/η² across the interface.
            let scale = (eta1 / eta2).powi(2);
            for k in 0..3 {
                assert!(
                    close(rad.weight[k], scale, 4.0 * EPS),
                    "{label}: {}",
                    rad.weight
                );
            }
            assert_eq!(tin.weight, tint);
        }
    }
    // Reflection is chosen with probability F: a binomial proportion.
    if tilt == 0.0 {
        assert_eq!(valid, n);
        let frac = reflected as f64 / n as f64;
        let se = (fres * (1.0 - fres) / n as f64).sqrt();
        assert!(
            (frac - fres).abs() <= N_SE * se,
            "{label}: reflected {frac}, F = {fres} ± {se:.1e}"
        );
    }
}

#[test]
fn dielectric_sampling_snell_reflection_and_energy() {
    let mut stream = 0;
    for ior in [1.33, 1.5, 2.4] {
        for front in [true, false] {
            for theta in [0.0, 0.3, 0.7, 1.0, 1.3, 1.55] {
                check_dielectric(ior, theta, front, 0.0, stream);
                stream += 1;
            }
        }
        for front in [true, false] {
            check_dielectric(ior, 0.5, front, 0.1, stream);
            stream += 1;
        }
    }
}

#[test]
fn dielectric_total_internal_reflection_from_inside() {
    let ng = normal();
    for ior in [1.33, 1.5, 2.4] {
        let b = Bsdf::Dielectric {
            ior,
            tint: Rgb::ONE,
        };
        let theta_c = (1.0 / ior).asin();
        for theta in [theta_c + 1e-6, (theta_c + FRAC_PI_2) / 2.0, 1.55] {
            let wo = -direction(ng, theta.cos(), 0.9);
            for ul in [0.0, 0.5, 1.0 - 1e-16] {
                let smp = b
                    .sample(wo, ng, ng, ul, (0.3, 0.6), Mode::Radiance)
                    .unwrap();
                assert!(smp.wi.dot(ng) < 0.0, "stays inside");
                assert_eq!(smp.weight, Rgb::ONE);
                assert!((smp.wi.dot(ng) - wo.dot(ng)).abs() <= 8.0 * EPS);
            }
        }
    }
}

// ------------------------------------------------------------------------------------------------
// 5. Mirror

#[test]
fn mirror_reflects_exactly_with_weight_ks() {
    let ng = normal();
    let ks = Rgb::new(0.9, 0.6, 0.3);
    let b = Bsdf::Mirror { kd: Rgb::ZERO, ks };
    assert!(b.is_delta());
    let mut s = Sampler::new(SEED, 7, 0);
    for cos_o in [1.0, 0.7, 0.2, 0.02, 1e-4, -0.5, -0.02] {
        for az in [0.0, 1.0, 4.0] {
            let wo = direction(ng, cos_o, az);
            let n = if cos_o >= 0.0 { ng } else { -ng };
            for _ in 0..100 {
                let smp = b
                    .sample(wo, ng, ng, s.next_f64(), s.next_2d(), Mode::Importance)
                    .expect("mirror");
                let wi = smp.wi;
                assert!(smp.delta && smp.pdf == 0.0);
                assert_eq!(smp.weight, ks, "pure mirror weight is ks");
                // Characterisation of the mirror direction: unit, same angle to n on the same
                // side, and wi + wo along n.
                assert!((wi.length() - 1.0).abs() <= 8.0 * EPS);
                assert!((wi.dot(n) - wo.dot(n)).abs() <= 8.0 * EPS, "{wi} {wo}");
                assert!((wi + wo).cross(n).length() <= 16.0 * EPS, "{wi} {wo}");
                assert_eq!(b.eval(wo, wi, ng, ng, Mode::Importance), Rgb::ZERO);
                assert_eq!(b.pdf(wo, wi, ng, ng), 0.0);
            }
        }
    }
}

#[test]
fn mirror_mixture_chooses_lobes_by_luminance() {
    let ng = normal();
    let (kd, ks) = (Rgb::new(0.5, 0.2, 0.1), Rgb::new(0.3, 0.3, 0.4));
    let b = Bsdf::Mirror { kd, ks };
    assert!(!b.is_delta());
    let pd = lum(kd) / (lum(kd) + lum(ks));
    let wo = direction(ng, 0.6, 1.3);
    let n = 50_000;
    let mut s = Sampler::new(SEED, 7, 1);
    let mut specular = 0;
    for _ in 0..n {
        let smp = b
            .sample(wo, ng, ng, s.next_f64(), s.next_2d(), Mode::Importance)
            .expect("ns = ng");
        if smp.delta {
            specular += 1;
            assert!((smp.wi - mirror_of(wo, ng)).length() <= 8.0 * EPS);
            for k in 0..3 {
                assert!(close(smp.weight[k], ks[k] / (1.0 - pd), 8.0 * EPS));
            }
        }
    }
    let frac = specular as f64 / n as f64;
    let se = (pd * (1.0 - pd) / n as f64).sqrt();
    assert!(
        (frac - (1.0 - pd)).abs() <= N_SE * se,
        "{frac} vs {}",
        1.0 - pd
    );
}

#[test]
fn delta_flags_and_black() {
    assert!(Bsdf::Black.is_delta());
    assert!(!Bsdf::Diffuse { kd: grey(0.5) }.is_delta());
    assert!(!glossy(0.0, 1.0, 10.0).is_delta());
    let (ng, wo) = (normal(), direction(normal(), 0.5, 0.0));
    assert!(
        Bsdf::Black
            .sample(wo, ng, ng, 0.5, (0.5, 0.5), Mode::Radiance)
            .is_none()
    );
    assert_eq!(Bsdf::Black.eval(wo, ng, ng, ng, Mode::Radiance), Rgb::ZERO);
    assert_eq!(Bsdf::Black.pdf(wo, ng, ng, ng), 0.0);
}
