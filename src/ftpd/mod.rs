//! The FTPD estimator: one sample at a point (paper sections 5.1-5.3 and 6.1, eqs. 9-14).
//!
//! 1. a direction ω with weight `w(x, ω) / p(ω)`: uniform on the sphere; for radiance weighting `w`
//!    is the radiance of the light passing `x` along ω, estimated by a path traced from `x` towards −ω;
//! 2. run lengths T in [t0, t1] and directions ω' uniform in the cone of half-angle θmax around ω;
//!    `r = tan(θ/2) / tan(θmax/2)` and the regulariser `s(r) = 3r² − 2r³` (section 5.1);
//! 3. independent walks of length T from x along ω and ω' with throughputs βA, βB;
//! 4. `Δ = s(r) (‖a − b‖ / (T ‖ω − ω'‖) − 1)` (eq. 9, both paths start at x);
//! 5. contribution `c = luminance(weight · βA · βB)`, accumulated as ΣP, ΣΔ, ΣΔ² (eq. 14).
//!
//! A sample takes the pairs of a [`Design`] ([`pairs`]): several walks along ω and along several
//! ω', each read at several run lengths, with c, cΔ and cΔ² averaged over every combination; one
//! pair ([`Design::SINGLE`]) is the estimator as the equations state it, and every design has its
//! expectation.
//!
//! In flatland (a kernel whose [`Space`] is the plane [`Params::flat`]) ω is uniform on the circle
//! of in-plane directions (density 1/2π), ω' is ω turned by an angle uniform in [−θmax, θmax], and
//! all densities are per radian ([`crate::transport::space`]).

pub mod design;
pub mod effects;
pub mod moments;
pub mod pairs;
pub mod reference;

pub use design::Design;
pub use pairs::Pair;

use crate::kernel::{Kernel, KernelChoice, Space};
use crate::math::{Rgb, luminance};
use crate::rng::Sampler;
use crate::scene::Scene;
use crate::scene::flat::Flatland;
use crate::transport::guide::Guide;
use crate::transport::trace;
use crate::transport::walk::{
    Guiding, RadianceStats, StartMis, radiance, radiance_guided, walk_counted,
};
use glam::DVec3;
use std::fmt;

/// How directions through a point are weighted (paper sections 5.3, 5.6, 5.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Weighting {
    /// w = radiance passing the point along ω.
    Radiance,
    /// w = 1: every potential light direction counts alike.
    Unweighted,
    /// Deflection pairs start along camera rays (camera domain only).
    Importance,
}

impl fmt::Display for Weighting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Weighting::Radiance => "radiance",
            Weighting::Unweighted => "unweighted",
            Weighting::Importance => "importance",
        })
    }
}

/// Parameters of the estimator, validated by the caller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Run-length interval [t0, t1] in scene units (0 ≤ t0 ≤ t1, t1 > 0).
    pub t0: f64,
    pub t1: f64,
    /// Half-angle θmax of the perturbation cone, radians, in (0, π/2).
    pub theta_max: f64,
    pub weighting: Weighting,
    /// Cap on scattering events per walk, and per radiance path unless `radiance_bounces` is set.
    pub max_bounces: u32,
    /// Cap on scattering events per radiance path alone (`None`: `max_bounces`); see
    /// [`Params::radiance_cap`].
    pub radiance_bounces: Option<u32>,
    /// Flatland runs only: the slice plane every direction is confined to. The scene must have been
    /// prepared for the same plane ([`Scene::prepare_flatland`]) and the kernel must be a flatland
    /// one (its [`Space`] the plane).
    pub flat: Option<Flatland>,
    /// The deflection pairs of one sample ([`Design`]), checked ([`Design::check`]).
    pub design: Design,
    /// Radiance paths are guided ([`crate::transport::guide`]): radiance weighting in 3D only.
    pub guide: bool,
}

impl Params {
    /// The most scattering events N a radiance path may have: the paths of the radiance weight, the
    /// fluence and the camera's beauty image have at most N + 1 segments from the point to the
    /// light (the paper's Fig. 5 limits them to 6 segments: N = 5). With the path's surface
    /// vertices v1, v2, … in order from the point, every strategy keeps to the same cap, so that
    /// MIS stays consistent: emission seen at v(k+1) (found by hitting it after k scattering
    /// events) and a light sampled at vk (next-event estimation, or a light's mirror image, whose
    /// mirror counts as one more scattering event) are both paths of k scattering events and
    /// k + 1 segments. So the last vertex that scatters, vN, still samples the lights (that
    /// connection is the path's (N+1)-th and last segment), and v(N+1) only adds the emission it
    /// shows; N = 0 keeps the light seen directly. The FTPD walks keep `max_bounces`.
    #[inline]
    pub fn radiance_cap(&self) -> u32 {
        self.radiance_bounces.unwrap_or(self.max_bounces)
    }

    /// `1 − cos θmax`, written so that tiny angles keep their precision.
    fn one_minus_cos_max(&self) -> f64 {
        2.0 * (0.5 * self.theta_max).sin().powi(2)
    }
}

/// `(1 − cos θmax, tan(θmax / 2))` of the perturbation cone: the same values as
/// [`Params::one_minus_cos_max`] and `(θmax / 2).tan()`, remembered per thread for the last θmax so
/// that a run does not evaluate `sin` and `tan` again for every sample (θmax is fixed for a run).
#[inline]
pub(crate) fn cone_constants(p: &Params) -> (f64, f64) {
    use std::cell::Cell;
    thread_local! {
        static LAST: Cell<(u64, f64, f64)> = const { Cell::new((u64::MAX, 0.0, 0.0)) };
    }
    let key = p.theta_max.to_bits();
    LAST.with(|c| {
        let (k, omc, tan_half) = c.get();
        if k == key {
            return (omc, tan_half);
        }
        let v = (p.one_minus_cos_max(), (0.5 * p.theta_max).tan());
        c.set((key, v.0, v.1));
        v
    })
}

/// The regulariser `s(r) = 3r² − 2r³` on r ∈ [0, 1] (section 5.1).
#[inline]
pub fn regulariser(r: f64) -> f64 {
    let r = r.clamp(0.0, 1.0);
    r * r * (3.0 - 2.0 * r)
}

/// Pairwise path deviation of two walks that start at the same point (eq. 9 with the regulariser).
/// `dist_ab` = ‖a − b‖, `t` the run length, `chord` = ‖ω − ω'‖, `r` the regulariser's argument.
#[inline]
pub fn pairwise_deviation(dist_ab: f64, t: f64, chord: f64, r: f64) -> f64 {
    let s = regulariser(r);
    let denom = t * chord;
    if s == 0.0 || !(denom > 0.0) || !denom.is_finite() {
        return 0.0;
    }
    let d = s * (dist_ab / denom - 1.0);
    if d.is_finite() { d } else { 0.0 }
}

/// One FTPD sample: the averages over its deflection pairs ([`Design`]) of the contribution c and
/// its products with Δ, one unit of the moments ([`moments::Moments::add_unit`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Sample {
    /// Mean over the pairs of c = luminance(weight · βA · βB) (0 for a pair with an absorbed walk).
    pub c: f64,
    /// Mean over the pairs of cΔ.
    pub cd: f64,
    /// Mean over the pairs of cΔ².
    pub cd2: f64,
    /// Direction weight w/p (RGB), for the fluence.
    pub weight: Rgb,
    pub rays: u32,
    /// Walks that reached the bounce cap.
    pub capped: u32,
    /// A non-finite intermediate was replaced by zero.
    pub clamped: bool,
}

/// One deflection pair traced on its own ([`pair_from`]): the reference estimator's sample.
#[derive(Clone, Copy, Debug, Default)]
pub struct SinglePair {
    /// Contribution c = luminance(weight · βA · βB) (0 when a walk was absorbed).
    pub c: f64,
    pub delta: f64,
    /// Direction weight w/p (RGB), for the fluence.
    pub weight: Rgb,
    pub rays: u32,
    /// Bounces of each walk, and whether a walk hit the bounce cap.
    pub bounces: (u32, u32),
    pub capped: bool,
    /// A non-finite intermediate was replaced by zero.
    pub clamped: bool,
}

/// Fraction of radiance-weighted samples whose direction is drawn uniformly; the others are drawn
/// towards the lights (when the scene has any).
pub const UNIFORM_FRACTION: f64 = 0.5;

/// In scenes with planar mirrors ([`crate::scene::mirror::Mirrors`]): the fractions of
/// radiance-weighted samples whose direction is drawn uniformly, towards the lights and towards the
/// lights' mirror images. Uniform directions alone reach the light that walls reflect, which
/// carries much of a box's radiance weight: they keep the share they have without mirrors, and
/// the images, a small part of the light, the least (chosen by efficiency, docs/performance.md).
pub const MIRROR_FRACTIONS: (f64, f64, f64) = (0.5, 0.35, 0.15);

/// A start direction ω with its weight `w(x, ω) / p(ω)` (RGB) for radiance weighting.
///
/// The radiance `L(x, ω)` of the light passing `x` along ω is split into parts, each estimated by
/// the strategies that can produce it, with the balance heuristic (one-sample MIS):
/// - directly visible emission of area lights: uniform directions (density α/4π) and light
///   sampling (density α_l·p_light(ω)) both produce it;
/// - in scenes with planar mirrors, light reflected once by such a mirror straight from a light:
///   uniform directions and the lights' mirror images (density α_v·p_virtual(ω),
///   `crate::transport::mirror`); images of point lights only by the latter;
/// - everything else that a path from `x` towards −ω collects (reflected light, including light of
///   point lights reflected by the first surface): uniform directions only;
/// - point lights seen directly: Dirac deltas in ω, produced by light sampling only.
#[inline]
pub fn radiance_direction<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    max_bounces: u32,
    s: &mut Sampler,
    rays: &mut u32,
) -> (DVec3, Rgb) {
    let nums = DirectionNumbers::draw(s);
    radiance_direction_from::<K>(scene, x, max_bounces, nums, None, s, rays)
}

/// The numbers that choose a radiance-weighted start direction: the strategy (and, rescaled, the
/// mirror plane), the light, and the point on it or the uniform direction.
#[derive(Clone, Copy, Debug)]
pub struct DirectionNumbers {
    pub strategy: f64,
    pub u_l: f64,
    pub u: (f64, f64),
}

impl DirectionNumbers {
    #[inline]
    pub fn draw(s: &mut Sampler) -> Self {
        let [strategy, u_l, u0, u1] = s.next_n();
        DirectionNumbers {
            strategy,
            u_l,
            u: (u0, u1),
        }
    }
}

/// [`radiance_direction`] from numbers drawn before (the sample's first ones, [`visit_at`]); the
/// radiance path draws from `s`, guided by `guide` when given
/// ([`crate::transport::guide`]).
#[inline]
pub fn radiance_direction_from<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    max_bounces: u32,
    nums: DirectionNumbers,
    guide: Option<&Guide>,
    s: &mut Sampler,
    rays: &mut u32,
) -> (DVec3, Rgb) {
    let sp = K::Space::of(scene);
    let lights = K::Space::lights(scene);
    // The images need a mirror that can still reflect (the first hit scatters below the cap).
    let virtual_lights =
        !lights.is_empty() && !K::Space::mirrors(scene).is_empty() && max_bounces >= 1;
    let (alpha, alpha_l, alpha_v) = if lights.is_empty() {
        (1.0, 0.0, 0.0)
    } else if virtual_lights {
        MIRROR_FRACTIONS
    } else {
        (UNIFORM_FRACTION, 1.0 - UNIFORM_FRACTION, 0.0)
    };
    // Densities per steradian, or per radian in flatland.
    let p_uniform = alpha * K::Space::PDF_UNIFORM;
    let mut st = RadianceStats::default();
    let DirectionNumbers { strategy, u_l, u } = nums;
    if strategy < alpha {
        let omega = sp.uniform(u);
        // Light passing x along ω arrives from −ω.
        let start = StartMis {
            pdf: p_uniform,
            virtual_fraction: alpha_v,
        };
        let guiding = Guiding {
            guide,
            visits: None,
        };
        let r = radiance_guided::<K>(scene, x, -omega, max_bounces, start, guiding, s, &mut st);
        *rays += st.rays;
        let direct = if r.escaped {
            // One balance-heuristic weight per distant light seen along −ω.
            let mut sum = Rgb::ZERO;
            lights.escaped::<K::Space>(-omega, |le, p_light| {
                sum += le / (p_uniform + alpha_l * p_light);
            });
            sum
        } else {
            r.direct / (p_uniform + alpha_l * r.direct_pdf)
        };
        return (omega, direct + r.rest / p_uniform);
    }
    if strategy >= alpha + alpha_l {
        // The strategy number, rescaled, chooses the mirror plane.
        let u_m = ((strategy - alpha - alpha_l) / alpha_v).clamp(0.0, 1.0 - f64::EPSILON);
        let Some(vs) = crate::transport::mirror::sample_virtual(scene, sp, x, u_m, u_l, u) else {
            return (sp.uniform(s.next_2d()), Rgb::ZERO);
        };
        let omega = -vs.wi;
        let Some(li) = crate::transport::mirror::connect_virtual::<K>(scene, x, x, &vs, rays)
        else {
            return (omega, Rgb::ZERO);
        };
        let weight = if vs.delta {
            li / (alpha_v * vs.pdf)
        } else {
            li / (p_uniform + alpha_v * vs.pdf)
        };
        return (omega, weight);
    }
    let Some(mut ls) = lights.sample(sp, x, u_l, u) else {
        // A light that faces away: this strategy contributes nothing here.
        return (sp.uniform(s.next_2d()), Rgb::ZERO);
    };
    crate::transport::light::texture_light_sample(scene, &mut ls, x);
    let omega = -ls.wi;
    *rays += 1;
    if !trace::visible::<K>(scene, x, x + ls.wi * ls.dist, ls.surface) {
        return (omega, Rgb::ZERO);
    }
    let weight = if ls.delta {
        ls.li / (alpha_l * ls.pdf)
    } else {
        ls.li / (p_uniform + alpha_l * ls.pdf)
    };
    (omega, weight)
}

/// Where a sample starts: what a domain gives the estimator for one cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Start {
    /// A point off every surface; the estimator draws the direction ([`sample_at`]).
    Point(DVec3),
    /// A camera: the pairs start at `eye` along `dir` ([`sample_camera`]).
    Eye { eye: DVec3, dir: DVec3 },
}

/// One sample from `start` with kernel `K` ([`sample_at`] or [`sample_camera`]).
#[inline]
pub fn sample<K: Kernel>(scene: &Scene, start: Start, p: &Params, s: &mut Sampler) -> Sample {
    visit::<K, _>(scene, start, p, None, s, &mut |_| {})
}

/// [`sample`] whose radiance paths are guided by `guide` ([`crate::transport::guide`]; 3D
/// kernels).
#[inline]
pub fn sample_guided<K: Kernel>(
    scene: &Scene,
    start: Start,
    p: &Params,
    guide: Option<&Guide>,
    s: &mut Sampler,
) -> Sample {
    visit::<K, _>(scene, start, p, guide, s, &mut |_| {})
}

/// [`sample_guided`], showing each of the sample's pairs to `visit` (tests look at single pairs).
#[inline]
pub fn visit<K: Kernel, V: FnMut(&Pair) + ?Sized>(
    scene: &Scene,
    start: Start,
    p: &Params,
    guide: Option<&Guide>,
    s: &mut Sampler,
    visit: &mut V,
) -> Sample {
    match start {
        Start::Point(x) => visit_at::<K, V>(scene, x, p, guide, s, visit),
        Start::Eye { eye, dir } => visit_camera::<K, V>(scene, eye, dir, p, s, visit),
    }
}

/// The kernel `p` needs: radiance estimates for radiance weighting and for the beauty image of
/// camera runs, flatland exactly when `p.flat` is set.
pub fn kernel_for(p: &Params) -> KernelChoice {
    KernelChoice {
        radiance: matches!(p.weighting, Weighting::Radiance | Weighting::Importance),
        flatland: p.flat.is_some(),
    }
}

/// One sample from a start point, with a kernel chosen at run time ([`sampler`]).
pub type SampleFn = fn(&Scene, Start, &Params, &mut Sampler) -> Sample;

/// [`sample`] for the kernel `k`, chosen once per run; with `record`, the kernel also logs every ray
/// it traces (the benchmark's replay, [`crate::kernel::Record`]).
pub fn sampler(k: KernelChoice, record: bool) -> SampleFn {
    use crate::kernel::{Plain3D, PlainFlat, Radiance3D, RadianceFlat, Record};
    match (k.radiance, k.flatland, record) {
        (true, false, false) => sample::<Radiance3D>,
        (false, false, false) => sample::<Plain3D>,
        (true, true, false) => sample::<RadianceFlat>,
        (false, true, false) => sample::<PlainFlat>,
        (true, false, true) => sample::<Record<Radiance3D>>,
        (false, false, true) => sample::<Record<Plain3D>>,
        (true, true, true) => sample::<Record<RadianceFlat>>,
        (false, true, true) => sample::<Record<PlainFlat>>,
    }
}

/// One sample at the point `x` with the kernel `p` needs ([`kernel_for`]), for callers that do not
/// choose a kernel themselves (tests, single points). `x` may lie on a surface: it starts on the
/// surface's front side ([`Scene::off_surfaces`]).
pub fn sample_point(scene: &Scene, x: DVec3, p: &Params, s: &mut Sampler) -> Sample {
    visit_point(scene, x, p, s, &mut |_| {})
}

/// [`sample_point`], showing each of the sample's pairs to `visit`.
pub fn visit_point(
    scene: &Scene,
    x: DVec3,
    p: &Params,
    s: &mut Sampler,
    visit: &mut dyn FnMut(&Pair),
) -> Sample {
    use crate::kernel::{Plain3D, PlainFlat, Radiance3D, RadianceFlat};
    let x = Start::Point(scene.off_surfaces(x));
    let k = kernel_for(p);
    match (k.radiance, k.flatland) {
        (true, false) => self::visit::<Radiance3D, _>(scene, x, p, None, s, visit),
        (false, false) => self::visit::<Plain3D, _>(scene, x, p, None, s, visit),
        (true, true) => self::visit::<RadianceFlat, _>(scene, x, p, None, s, visit),
        (false, true) => self::visit::<PlainFlat, _>(scene, x, p, None, s, visit),
    }
}

/// One FTPD sample at `x` with start direction drawn by the estimator (slice and volume domains),
/// with kernel `K`: radiance weighting needs `K::RADIANCE`, and `K` is a flatland kernel exactly
/// when `p.flat` is set (then `x` lies in that plane and the scene is prepared for it).
/// `x` must not lie on a surface (within the float error bound): domains whose points may, move
/// them first with [`Scene::off_surfaces`].
#[inline]
pub fn sample_at<K: Kernel>(scene: &Scene, x: DVec3, p: &Params, s: &mut Sampler) -> Sample {
    visit_at::<K, _>(scene, x, p, None, s, &mut |_| {})
}

/// [`sample_at`] with radiance paths guided by `guide`, showing each pair to `visit`.
///
/// The sample's numbers in the order of their importance, so that the first ones, which are the
/// dimensions of a scrambled Sobol' point ([`Sampler::begin_sample`]), go where stratifying pays
/// most: after the start point's (drawn by the domain), the direction's, then the run length's
/// and the cone direction's ([`pairs::Offsets`]); the radiance path and the walks draw after
/// them (the walks from streams of their own, [`Sampler::child`]).
#[inline]
pub fn visit_at<K: Kernel, V: FnMut(&Pair) + ?Sized>(
    scene: &Scene,
    x: DVec3,
    p: &Params,
    guide: Option<&Guide>,
    s: &mut Sampler,
    visit: &mut V,
) -> Sample {
    debug_assert!(K::RADIANCE || p.weighting != Weighting::Radiance);
    debug_assert_eq!(K::Space::DIMS == 2, p.flat.is_some());
    debug_assert!(p.flat.is_none() || p.flat == Some(scene.flat().plane));
    let radiance = K::RADIANCE && p.weighting == Weighting::Radiance;
    let nums = if radiance {
        DirectionNumbers::draw(s)
    } else {
        let [u0, u1] = s.next_n();
        DirectionNumbers {
            strategy: 0.0,
            u_l: 0.0,
            u: (u0, u1),
        }
    };
    let off = pairs::Offsets::draw(s);
    let key = s.fork_key();
    let mut rays = 0;
    let (omega, weight) = if radiance {
        radiance_direction_from::<K>(scene, x, p.radiance_cap(), nums, guide, s, &mut rays)
    } else {
        (K::Space::of(scene).uniform(nums.u), Rgb::ONE)
    };
    let mut out = pairs::pairs::<K, V>(scene, x, omega, weight, off, key, p, visit);
    out.rays += rays;
    out
}

/// One importance-weighted sample from a camera (paper section 5.7): the pairs start at the eye
/// along the pixel direction `omega` with weight 1; `weight` of the result carries the radiance
/// arriving along the same primary ray (a plain path-traced beauty image), not the pairs' weight.
#[inline]
pub fn sample_camera<K: Kernel>(
    scene: &Scene,
    eye: DVec3,
    omega: DVec3,
    p: &Params,
    s: &mut Sampler,
) -> Sample {
    visit_camera::<K, _>(scene, eye, omega, p, s, &mut |_| {})
}

/// [`sample_camera`], showing each pair to `visit`.
#[inline]
pub fn visit_camera<K: Kernel, V: FnMut(&Pair) + ?Sized>(
    scene: &Scene,
    eye: DVec3,
    omega: DVec3,
    p: &Params,
    s: &mut Sampler,
    visit: &mut V,
) -> Sample {
    let off = pairs::Offsets::draw(s);
    let key = s.fork_key();
    let mut out = pairs::pairs::<K, V>(scene, eye, omega, Rgb::ONE, off, key, p, visit);
    if K::RADIANCE {
        let mut st = RadianceStats::default();
        out.weight = radiance::<K>(scene, eye, omega, p.radiance_cap(), s, &mut st).total();
        out.rays += st.rays;
    } else {
        out.weight = Rgb::ZERO;
    }
    out
}

/// One deflection pair for a given start point, direction ω, run length, the two numbers that
/// place ω' in the cone, and weight, both walks drawing from `s` ([`walk_counted`]): the plain
/// pair the reference estimator ([`reference`]) is built from.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn pair_from<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    omega: DVec3,
    t: f64,
    u_cone: (f64, f64),
    weight: Rgb,
    p: &Params,
    s: &mut Sampler,
) -> SinglePair {
    let mut out = SinglePair {
        weight,
        ..Default::default()
    };
    let (one_minus_cos_max, tan_half_max) = cone_constants(p);
    let (omega2, chord, r) =
        K::Space::of(scene).perturb(omega, p.theta_max, one_minus_cos_max, tan_half_max, u_cone);
    if luminance(weight) <= 0.0 {
        // No light passes here in this direction: the pair carries no weight; skip tracing it.
        return out;
    }
    let (a, rays_a) = walk_counted::<K>(scene, x, omega, t, p.max_bounces, s);
    let (b, rays_b) = walk_counted::<K>(scene, x, omega2, t, p.max_bounces, s);
    out.rays += rays_a + rays_b;
    let (Some(a), Some(b)) = (a, b) else {
        return out;
    };
    out.bounces = (a.bounces, b.bounces);
    out.capped = a.capped || b.capped;
    let c = luminance(weight * a.beta * b.beta);
    if !c.is_finite() {
        out.clamped = true;
        return out;
    }
    out.c = c.max(0.0);
    // Two straight walks: Δ is exactly 0 (empty space).
    out.delta = if a.bounces == 0 && b.bounces == 0 {
        0.0
    } else {
        pairwise_deviation((a.end - b.end).length(), t, chord, r)
    };
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regulariser_is_smoothstep() {
        assert_eq!(regulariser(0.0), 0.0);
        assert_eq!(regulariser(1.0), 1.0);
        assert_eq!(regulariser(0.5), 0.5);
        assert_eq!(regulariser(2.0), 1.0);
    }

    #[test]
    fn perturbation_stays_in_the_cone_and_r_in_unit_interval() {
        let mut s = Sampler::new(9, 0, 0);
        for theta_max in [1e-6, 0.01, 0.3, 1.0, 1.5] {
            let omc = 2.0 * (0.5f64 * theta_max).sin().powi(2);
            let thm = (0.5f64 * theta_max).tan();
            for _ in 0..2000 {
                let w = crate::transport::sampling::sample_uniform_sphere(s.next_2d());
                let (w2, chord, r) =
                    crate::kernel::Sphere.perturb(w, theta_max, omc, thm, s.next_2d());
                assert!((0.0..=1.0 + 1e-12).contains(&r), "r = {r}");
                assert!((w2.length() - 1.0).abs() < 1e-12);
                let ang = w.cross(w2).length().atan2(w.dot(w2));
                assert!(ang <= theta_max * (1.0 + 1e-9) + 1e-15);
                // chord equals ‖ω − ω'‖ to rounding (relative to the angle).
                assert!(((w - w2).length() - chord).abs() <= 1e-9 * chord.max(1e-300) + 1e-15);
            }
        }
    }

    #[test]
    fn deviation_zero_for_straight_pairs_and_guarded() {
        assert_eq!(pairwise_deviation(0.2, 2.0, 0.1, 0.7), 0.0);
        assert_eq!(pairwise_deviation(1.0, 2.0, 0.0, 0.0), 0.0);
        assert_eq!(pairwise_deviation(1.0, 0.0, 0.1, 0.5), 0.0);
        assert!((pairwise_deviation(0.4, 2.0, 0.1, 1.0) - 1.0).abs() < 1e-15);
    }
}
