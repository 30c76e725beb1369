//! The two kinds of paths an FTPD sample traces:
//! - [`walk`]: a fixed-run-length random walk (paper section 5.1): from a start point along a
//!   direction for a Euclidean length T, scattering at every hit; a walk that leaves the scene goes on
//!   straight, and its end point lies on the last segment at the remaining distance.
//! - [`radiance`]: a path tracer with next-event estimation and multiple importance sampling (power
//!   heuristic) that estimates the radiance arriving at a point from a direction, used as the
//!   radiance weight.
//!
//! Both are written once over the kernel's space of directions ([`Space`]: 3D, or the flatland
//! plane with its angle measure and in-plane directions).

use crate::kernel::{Kernel, Space};
use crate::math::{Rgb, luminance};
use crate::rng::Sampler;
use crate::scene::Scene;
use crate::transport::bsdf::Mode;
use crate::transport::trace;
use glam::DVec3;

/// Where a walk ended and what it carried.
#[derive(Clone, Copy, Debug)]
pub struct WalkEnd {
    pub end: DVec3,
    /// Product of `f |cos| / pdf` over the scattering events.
    pub beta: Rgb,
    pub bounces: u32,
    /// The walk reached the bounce cap before using up its length; it ends at the last hit.
    pub capped: bool,
}

/// A walk of Euclidean length `t` from `x` along unit `dir`. `None` when the walk is absorbed
/// (zero throughput: it carries no weight).
#[inline]
pub fn walk<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    dir: DVec3,
    t: f64,
    max_bounces: u32,
    s: &mut Sampler,
) -> Option<WalkEnd> {
    walk_counted::<K>(scene, x, dir, t, max_bounces, s).0
}

/// [`walk`] with the number of rays traced, also for walks that were absorbed (whose
/// [`WalkEnd`] is not returned), so that ray counts match the ray queries made.
#[inline]
pub fn walk_counted<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    dir: DVec3,
    t: f64,
    max_bounces: u32,
    s: &mut Sampler,
) -> (Option<WalkEnd>, u32) {
    // `base` is the true start of the current segment (x, then surface points); `origin` the same
    // point pushed off the surface for the ray query. Lengths are measured from `base`, so the
    // offsets never change the geometry of the walk.
    let sp = K::Space::of(scene);
    let mut base = x;
    let mut origin = x;
    let mut d = dir;
    let mut remaining = t;
    let mut beta = Rgb::ONE;
    let mut rays = 0;
    let mut bounces = 0;
    loop {
        rays += 1;
        let Some(hit) =
            trace::intersect::<K>(scene, origin, d, remaining + (origin - base).length())
        else {
            let end = WalkEnd {
                end: base + d * remaining,
                beta,
                bounces,
                capped: false,
            };
            return (Some(end), rays);
        };
        remaining -= (hit.p - base).dot(d);
        if remaining <= 0.0 {
            let end = WalkEnd {
                end: hit.p,
                beta,
                bounces,
                capped: false,
            };
            return (Some(end), rays);
        }
        if bounces >= max_bounces {
            let end = WalkEnd {
                end: hit.p,
                beta,
                bounces,
                capped: true,
            };
            return (Some(end), rays);
        }
        let u_lobe = s.next_f64();
        let u = s.next_2d();
        let (bsdf, lobe) = K::Space::scatter(scene, hit.material);
        // Written out at both sites: a helper returning the textured model through an `Option`
        // slot was measurably slower per sample.
        let textured;
        let (bsdf, lobe) = match scene.textured_bsdf(&hit) {
            Some(b) => {
                textured = (K::Space::textured_lobe(&b, lobe), b);
                (&textured.1, &textured.0)
            }
            None => (bsdf, lobe),
        };
        let sampled = bsdf.sample_in(sp, lobe, -d, hit.ng, hit.ns, u_lobe, u, s, Mode::Importance);
        let Some(bs) = sampled else {
            return (None, rays);
        };
        beta *= bs.weight;
        if beta == Rgb::ZERO {
            return (None, rays);
        }
        bounces += 1;
        origin = scene.spawn_origin_from(&hit, bs.wi, origin);
        d = bs.wi;
        base = hit.p;
    }
}

/// Scattering events a radiance path makes before Russian roulette may end it (Mitsuba's
/// `rr_depth`): earlier roulette ended paths that still carried much of the estimate.
pub const ROULETTE_DEPTH: u32 = 5;

/// Russian roulette from the [`ROULETTE_DEPTH`]th scattering event on: continues with probability
/// q = min(max component of β·`eta_scale`, 0.95), dividing β by q (unbiased for any q > 0); false
/// when the path ends, or carries nothing. `eta_scale` is the product of etap^(d−1) over the
/// refractions so far ([`crate::transport::bsdf::BsdfSample::etap`]): it cancels the radiance
/// factors 1/η^(d−1) that β holds, which are undone when the path leaves the dielectric again,
/// so that paths inside glass are not ended for a factor they will get back (pbrt-v4's
/// `etaScale`).
#[inline]
pub fn survives(beta: &mut Rgb, eta_scale: f64, depth: u32, s: &mut Sampler) -> bool {
    if depth >= ROULETTE_DEPTH {
        let q = (beta.max_element() * eta_scale).min(0.95);
        if !(q > 0.0) || s.next_f64() >= q {
            return false;
        }
        *beta /= q;
    }
    luminance(*beta) > 0.0
}

/// Statistics of a radiance estimate.
#[derive(Clone, Copy, Debug, Default)]
pub struct RadianceStats {
    pub rays: u32,
}

/// Power heuristic (β = 2) for two strategies with densities `a` (the one used) and `b`.
#[inline]
fn power_heuristic(a: f64, b: f64) -> f64 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && (a2 + b2).is_finite() {
        a2 / (a2 + b2)
    } else {
        1.0
    }
}

/// A radiance estimate split by what can also be reached by sampling the lights from the start
/// point: the emission of the first surface seen, or of the sky and sun when the start ray leaves
/// the scene (`direct`, with the solid-angle density `direct_pdf` with which light sampling at the
/// start point picks that surface point) and everything else (`rest`: light reflected by the first
/// surface and beyond).
#[derive(Clone, Copy, Debug, Default)]
pub struct Radiance {
    pub direct: Rgb,
    pub direct_pdf: f64,
    pub rest: Rgb,
    /// The start ray left the scene: `direct` is what the sky and sun discs give along it, and
    /// each of them has its own light-sampling density (see `Lights::escaped`), not
    /// `direct_pdf`.
    pub escaped: bool,
}

impl Radiance {
    pub fn total(&self) -> Rgb {
        self.direct + self.rest
    }
}

/// How the start direction of a radiance path was chosen, for the multiple-importance weights of
/// light that reaches the start point by one reflection in a planar mirror, which the caller also
/// samples directly (`crate::transport::mirror`).
#[derive(Clone, Copy, Debug, Default)]
pub struct StartMis {
    /// Density with which the caller drew the start direction (per steradian, or radian).
    pub pdf: f64,
    /// The probability with which the caller samples the lights' mirror images instead (0: it
    /// does not, and such light counts in full).
    pub virtual_fraction: f64,
}

/// Balance (`balance`) or power heuristic for two strategies with densities `a` (the one used) and
/// `b`.
#[inline]
fn heuristic(a: f64, b: f64, balance: bool) -> f64 {
    if balance {
        if a + b > 0.0 && (a + b).is_finite() {
            a / (a + b)
        } else {
            1.0
        }
    } else {
        power_heuristic(a, b)
    }
}

/// The last non-specular vertex of a radiance path before a planar mirror, for the weight of light
/// it reaches through the mirror (whose direct sampling is its virtual-light estimate).
#[derive(Clone, Copy, Debug)]
struct MirrorMis {
    /// The vertex, and after the mirror its image in the mirror plane.
    p: DVec3,
    /// The density with which the path left the vertex.
    pdf: f64,
    /// The probability of the virtual-light strategy there (times the plane's, after the mirror).
    scale: f64,
    /// One-sample balance heuristic (the start point) or the power heuristic (path vertices).
    balance: bool,
}

/// Estimates the radiance arriving at `x` from the direction `look` (unit), i.e. the radiance of the
/// light that passes `x` travelling along `-look`.
/// Paths have at most `max_bounces` scattering events; Russian roulette from the
/// [`ROULETTE_DEPTH`]th on ([`survives`]).
#[inline]
pub fn radiance<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    look: DVec3,
    max_bounces: u32,
    s: &mut Sampler,
    st: &mut RadianceStats,
) -> Radiance {
    radiance_mis::<K>(scene, x, look, max_bounces, StartMis::default(), s, st)
}

/// [`radiance`] for a caller that draws the start direction with density `start.pdf` and also
/// samples the lights' images in planar mirrors from `x` (with probability
/// `start.virtual_fraction`): light reaching `x` by one reflection in a planar mirror is weighted by
/// the balance heuristic against that strategy.
///
/// In scenes with planar mirrors, every non-specular vertex also samples the lights' mirror images
/// (`crate::transport::mirror`), combined with the BSDF-sampled paths that reach a light through
/// the mirror by the power heuristic.
#[inline]
pub fn radiance_mis<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    look: DVec3,
    max_bounces: u32,
    start: StartMis,
    s: &mut Sampler,
    st: &mut RadianceStats,
) -> Radiance {
    let sp = K::Space::of(scene);
    let lights = K::Space::lights(scene);
    let lights_empty = lights.is_empty();
    let mut out = Radiance::default();
    let mut l = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    let mut origin = x;
    let mut d = look;
    let mut prev_p = x;
    let mut prev_pdf = 0.0;
    let mut prev_delta = true; // the start direction is given, like a camera ray
    let mut eta_scale = 1.0;
    let mut depth = 0;
    let mirrors = K::Space::mirrors(scene);
    let has_mirrors = !mirrors.is_empty() && !lights_empty;
    // The last non-specular vertex (before a mirror) and, once the path has reflected in a planar
    // mirror from there, its image (`through`).
    let mut before: Option<MirrorMis> =
        (has_mirrors && start.virtual_fraction > 0.0).then_some(MirrorMis {
            p: x,
            pdf: start.pdf,
            scale: start.virtual_fraction,
            balance: true,
        });
    let mut through: Option<MirrorMis> = None;
    loop {
        st.rays += 1;
        let Some(hit) = trace::intersect::<K>(scene, origin, d, f64::INFINITY) else {
            // Leaving the scene: the sky and a sun disc, if there are any.
            if lights.has_infinite() {
                if depth == 0 {
                    // The start direction's own MIS is its caller's (`escaped` again, per light).
                    lights.escaped::<K::Space>(d, |le, _| out.direct += le);
                    out.escaped = true;
                } else {
                    lights.escaped::<K::Space>(d, |le, p_light| {
                        let w = if let Some(m) = through {
                            heuristic(m.pdf, m.scale * p_light, m.balance)
                        } else if prev_delta {
                            1.0
                        } else {
                            power_heuristic(prev_pdf, p_light)
                        };
                        l += beta * le * w;
                    });
                }
            }
            break;
        };
        if depth == 0 {
            let le = scene.emitted(&hit, -d);
            if le != Rgb::ZERO {
                out.direct = le;
                out.direct_pdf = lights.pdf_hit::<K::Space>(x, hit.prim, hit.p);
            }
        } else {
            let le = scene.emitted(&hit, -d);
            if le != Rgb::ZERO {
                let w = if let Some(m) = through {
                    let p_light = lights.pdf_hit::<K::Space>(m.p, hit.prim, hit.p);
                    heuristic(m.pdf, m.scale * p_light, m.balance)
                } else if prev_delta {
                    1.0
                } else {
                    let p_light = lights.pdf_hit::<K::Space>(prev_p, hit.prim, hit.p);
                    power_heuristic(prev_pdf, p_light)
                };
                l += beta * le * w;
            }
        }
        if depth >= max_bounces {
            break;
        }
        let (bsdf, lobe) = K::Space::scatter(scene, hit.material);
        // Written out at both sites: a helper returning the textured model through an `Option`
        // slot was measurably slower per sample.
        let textured;
        let (bsdf, lobe) = match scene.textured_bsdf(&hit) {
            Some(b) => {
                textured = (K::Space::textured_lobe(&b, lobe), b);
                (&textured.1, &textured.0)
            }
            None => (bsdf, lobe),
        };
        let wo = -d;
        // Next-event estimation on surfaces with a non-delta lobe.
        if !bsdf.is_delta() && !lights_empty {
            let u_l = s.next_f64();
            let u = s.next_2d();
            if let Some(mut ls) = lights.sample(sp, hit.p, u_l, u) {
                crate::transport::light::texture_light_sample(scene, &mut ls, hit.p);
                let f = bsdf.eval_in::<K::Space>(lobe, wo, ls.wi, hit.ng, hit.ns, Mode::Radiance);
                if f != Rgb::ZERO {
                    st.rays += 1;
                    let o = scene.spawn_origin_from(&hit, ls.wi, origin);
                    if trace::visible::<K>(scene, o, hit.p + ls.wi * ls.dist) {
                        let w = if ls.delta {
                            1.0
                        } else {
                            let p_bsdf = bsdf.pdf_in::<K::Space>(lobe, wo, ls.wi, hit.ng, hit.ns);
                            power_heuristic(ls.pdf, p_bsdf)
                        };
                        l += beta * f * ls.li * (w / ls.pdf);
                    }
                }
            }
        }
        // The lights' images in planar mirrors, where the path could still reach them by BSDF
        // sampling (the mirror point scatters only below the bounce cap).
        if has_mirrors && !bsdf.is_delta() && depth + 1 < max_bounces {
            let u_m = s.next_f64();
            let u_l = s.next_f64();
            let u = s.next_2d();
            if let Some(vs) =
                crate::transport::mirror::sample_virtual(scene, sp, hit.p, u_m, u_l, u)
            {
                let f = bsdf.eval_in::<K::Space>(lobe, wo, vs.wi, hit.ng, hit.ns, Mode::Radiance);
                if f != Rgb::ZERO {
                    let o = scene.spawn_origin_from(&hit, vs.wi, origin);
                    if let Some(li) = crate::transport::mirror::connect_virtual::<K>(
                        scene,
                        hit.p,
                        o,
                        &vs,
                        &mut st.rays,
                    ) {
                        let w = if vs.delta {
                            1.0
                        } else {
                            let p_bsdf = bsdf.pdf_in::<K::Space>(lobe, wo, vs.wi, hit.ng, hit.ns);
                            power_heuristic(vs.pdf, p_bsdf)
                        };
                        l += beta * f * li * (w / vs.pdf);
                    }
                }
            }
        }
        let u_lobe = s.next_f64();
        let u = s.next_2d();
        let sampled = bsdf.sample_in(sp, lobe, wo, hit.ng, hit.ns, u_lobe, u, s, Mode::Radiance);
        let Some(bs) = sampled else {
            break;
        };
        if has_mirrors {
            // Through a planar mirror from the last non-specular vertex: the next light found is
            // also found by that vertex's virtual-light sample.
            through = match (before, bs.delta, mirrors.plane_of(hit.prim)) {
                (Some(m), true, Some(k)) => Some(MirrorMis {
                    p: mirrors.planes[k as usize].reflect_point(m.p),
                    scale: m.scale * mirrors.prob(k as usize),
                    ..m
                }),
                _ => None,
            };
            before = (!bs.delta).then_some(MirrorMis {
                p: hit.p,
                pdf: bs.pdf,
                scale: 1.0,
                balance: false,
            });
        }
        beta *= bs.weight;
        if bs.etap != 1.0 {
            eta_scale *= bs.etap.powi(K::Space::DIMS - 1);
        }
        depth += 1;
        if !survives(&mut beta, eta_scale, depth, s) {
            break;
        }
        origin = scene.spawn_origin_from(&hit, bs.wi, origin);
        prev_p = hit.p;
        prev_pdf = bs.pdf;
        prev_delta = bs.delta;
        d = bs.wi;
    }
    out.rest = l;
    out
}
