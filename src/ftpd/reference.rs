//! A slow, plainly correct reference for radiance-weighted FTPD, kept to validate the production
//! estimator ([`super::sample_at`]), which mixes uniform and light-directed directions with MIS.
//!
//! Here every sample takes ω uniformly and estimates `L(x, ω)` with a path tracer that finds area
//! lights only by hitting them (no light sampling for them, so no MIS to get wrong), and point
//! lights by explicit connections at the path's surface vertices (they cannot be hit). The light
//! of point lights seen directly from `x` is a Dirac delta in ω; each point light adds, in every
//! sample, its own deflection pair along its exact direction with weight `I / d² · V`.

use super::{Params, pair_from};
use crate::kernel::Plain3D;
use crate::math::Rgb;
use crate::rng::Sampler;
use crate::scene::{Light, Scene};
use crate::transport::bsdf::Mode;
use crate::transport::sampling::sample_uniform_sphere;
use glam::DVec3;

/// One reference sample: several (c, Δ, weight) terms whose sums estimate the moments.
pub fn sample_reference(
    scene: &Scene,
    x: DVec3,
    p: &Params,
    s: &mut Sampler,
) -> Vec<(f64, f64, Rgb)> {
    let t = p.t0 + (p.t1 - p.t0) * s.next_f64();
    let omega = sample_uniform_sphere(s.next_2d());
    let l = radiance_plain(scene, x, -omega, p.max_bounces, s);
    let mut out = Vec::new();
    let smp = pair_from::<Plain3D>(scene, x, omega, t, l * (4.0 * std::f64::consts::PI), p, s);
    out.push((smp.c, smp.delta, smp.weight));
    for light in &scene.lights.lights {
        if let Light::Point {
            position,
            intensity,
        } = light
        {
            let to = *position - x;
            let d = to.length();
            let wi = to / d;
            let visible = scene.visible(x, *position);
            let w = if visible {
                *intensity / (d * d)
            } else {
                Rgb::ZERO
            };
            let smp = pair_from::<Plain3D>(scene, x, -wi, t, w, p, s);
            out.push((smp.c, smp.delta, smp.weight));
        }
    }
    out
}

/// Radiance arriving at `x` from `look`: BSDF sampling only, emission counted when hit, point
/// lights connected explicitly at surface vertices. Russian roulette after three bounces.
pub fn radiance_plain(
    scene: &Scene,
    x: DVec3,
    look: DVec3,
    max_bounces: u32,
    s: &mut Sampler,
) -> Rgb {
    let mut l = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    let mut origin = x;
    let mut d = look;
    for depth in 0..=max_bounces {
        let Some(hit) = scene.intersect(origin, d, f64::INFINITY) else {
            break;
        };
        l += beta * scene.emitted(&hit, -d);
        if depth == max_bounces {
            break;
        }
        let bsdf = &scene.material(&hit).bsdf;
        for light in &scene.lights.lights {
            if let Light::Point {
                position,
                intensity,
            } = light
            {
                let to = *position - hit.p;
                let dist = to.length();
                let wi = to / dist;
                let f = bsdf.eval(-d, wi, hit.ng, hit.ns, Mode::Radiance);
                if f != Rgb::ZERO && scene.visible(hit.spawn_origin(wi), *position) {
                    l += beta * f * *intensity / (dist * dist);
                }
            }
        }
        let Some(bs) = bsdf.sample(
            -d,
            hit.ng,
            hit.ns,
            s.next_f64(),
            s.next_2d(),
            Mode::Radiance,
        ) else {
            break;
        };
        beta *= bs.weight;
        if !crate::transport::walk::survives(&mut beta, depth + 1, s) {
            break;
        }
        d = bs.wi;
        origin = hit.spawn_origin(d);
    }
    l
}
