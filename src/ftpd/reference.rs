//! A slow, plainly correct reference for radiance-weighted FTPD, kept to validate the production
//! estimator ([`super::sample_at`]), which mixes uniform and light-directed directions with MIS.
//!
//! Here every sample takes ω uniformly and estimates `L(x, ω)` with a path tracer that finds area
//! lights, the sky, environment maps and sun discs only by hitting them or by leaving the scene
//! (no light sampling for them, so no MIS to get wrong), and lights that cannot be hit (point and
//! spot lights, a sun without a disc) by explicit connections at the path's surface vertices. The
//! light of those seen directly from `x` is a Dirac delta in ω; each adds, in every sample, its own
//! deflection pair along its exact direction with its weight (`I / d² · V`, or `E · V`).

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
    let l = radiance_plain(scene, x, -omega, p.radiance_cap(), s);
    let mut out = Vec::new();
    let smp = pair_from::<Plain3D>(
        scene,
        x,
        omega,
        t,
        s.next_2d(),
        l * (4.0 * std::f64::consts::PI),
        p,
        s,
    );
    out.push((smp.c, smp.delta, smp.weight));
    for light in &scene.lights.lights {
        if let Some((wi, w)) = delta_light(scene, light, x, x) {
            let smp = pair_from::<Plain3D>(scene, x, -wi, t, s.next_2d(), w, p, s);
            out.push((smp.c, smp.delta, smp.weight));
        }
        if p.radiance_cap() >= 1 {
            for (wi, w) in delta_light_mirrored(scene, light, x, |_| x) {
                let smp = pair_from::<Plain3D>(scene, x, -wi, t, s.next_2d(), w, p, s);
                out.push((smp.c, smp.delta, smp.weight));
            }
        }
    }
    out
}

/// The images of a light that only a connection can find (see [`delta_light`]) in each planar
/// mirror of the scene, seen from `x` (rays along `wi` leave from `origin(wi)`): the unit direction towards the
/// image and what arrives through the mirror, when the ray towards the image first hits a mirror
/// triangle in that plane and the mirror point sees the light. Every plane is tried (no sampling),
/// and the mirror's reflectance is read from the material hit.
fn delta_light_mirrored(
    scene: &Scene,
    light: &Light,
    x: DVec3,
    origin: impl Fn(DVec3) -> DVec3,
) -> Vec<(DVec3, Rgb)> {
    let mut out = Vec::new();
    for (k, plane) in scene.mirrors.planes.iter().enumerate() {
        let n = plane.normal;
        let side = n.dot(x) - plane.offset;
        if side == 0.0 {
            continue;
        }
        let image = x - n * (2.0 * side);
        // What the light sends to the image point, without the shadow test.
        let Some((wi_image, arriving, target)) = delta_light_parts(scene, light, image) else {
            continue;
        };
        let wi = wi_image - n * (2.0 * n.dot(wi_image));
        let t_plane = -side / n.dot(wi);
        if !(t_plane > 0.0) || (target - image).length() <= t_plane {
            continue;
        }
        let Some(hit) = scene.intersect(origin(wi), wi, f64::INFINITY) else {
            continue;
        };
        if scene.mirrors.plane_of(hit.prim) != Some(k as u32) {
            continue;
        }
        let bsdf = scene.bsdf_at(&hit, &scene.material(&hit).bsdf);
        let crate::scene::material::Bsdf::Mirror { ks, .. } = &*bsdf else {
            continue;
        };
        if scene.visible(hit.spawn_origin(wi_image), target, None) {
            out.push((wi, ks * arriving));
        }
    }
    out
}

/// A light that only a connection can find (point, spot, sun without a disc), seen from `x`
/// (shadow rays leave from `origin`): the unit direction towards it and what arrives, `I / d²` with
/// the spot's falloff or the sun's irradiance, 0 when occluded; `None` for the other kinds.
fn delta_light(scene: &Scene, light: &Light, x: DVec3, origin: DVec3) -> Option<(DVec3, Rgb)> {
    let (wi, arriving, target) = delta_light_parts(scene, light, x)?;
    let visible = scene.visible(origin, target, None);
    Some((wi, if visible { arriving } else { Rgb::ZERO }))
}

/// The direction from `x` towards a light that only a connection can find, what arrives if
/// nothing blocks it, and the shadow ray's target; `None` for the other kinds.
fn delta_light_parts(scene: &Scene, light: &Light, x: DVec3) -> Option<(DVec3, Rgb, DVec3)> {
    Some(match light {
        Light::Point {
            position,
            intensity,
        } => {
            let to = *position - x;
            let d2 = to.length_squared();
            (to / d2.sqrt(), *intensity / d2, *position)
        }
        Light::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
        } => {
            let to = *position - x;
            let d2 = to.length_squared();
            let wi = to / d2.sqrt();
            // glTF's falloff, written out again here.
            let t = ((-wi.dot(*direction) - cos_outer) / (cos_inner - cos_outer).max(0.001))
                .clamp(0.0, 1.0);
            (wi, *intensity * (t * t) / d2, *position)
        }
        Light::Distant {
            direction,
            irradiance,
            half_angle,
            ..
        } if *half_angle == 0.0 => (
            *direction,
            *irradiance,
            x + *direction * scene.lights.beyond(x),
        ),
        _ => return None,
    })
}

/// What a ray leaving the scene along the unit `d` sees: the sky, environment maps, sun discs.
fn escaped(scene: &Scene, d: DVec3) -> Rgb {
    let mut l = Rgb::ZERO;
    for light in &scene.lights.lights {
        match light {
            Light::Sky { radiance } => l += *radiance,
            Light::Env(env) => l += env.map.radiance(d),
            Light::Distant {
                direction,
                half_angle,
                cos_max,
                radiance,
                ..
            } if *half_angle > 0.0 && d.dot(*direction) >= *cos_max => l += *radiance,
            _ => {}
        }
    }
    l
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
            l += beta * escaped(scene, d);
            break;
        };
        l += beta * scene.emitted(&hit, -d);
        if depth == max_bounces {
            break;
        }
        let bsdf = scene.bsdf_at(&hit, &scene.material(&hit).bsdf);
        for light in &scene.lights.lights {
            // The shadow ray leaves on the side the light lies.
            let towards = match light {
                Light::Point { position, .. } | Light::Spot { position, .. } => *position - hit.p,
                Light::Distant { direction, .. } => *direction,
                _ => continue,
            };
            let o = hit.spawn_origin(towards);
            if let Some((wi, arriving)) = delta_light(scene, light, hit.p, o) {
                let f = bsdf.eval(-d, wi, hit.ng, hit.ns, Mode::Radiance);
                l += beta * f * arriving;
            }
            // Through planar mirrors, where the mirror point can still scatter.
            if depth + 1 < max_bounces {
                let through = delta_light_mirrored(scene, light, hit.p, |wi| hit.spawn_origin(wi));
                for (wi, arriving) in through {
                    let f = bsdf.eval(-d, wi, hit.ng, hit.ns, Mode::Radiance);
                    l += beta * f * arriving;
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
        // Roulette on β as it is (no η scale): unbiased all the same, and one thing fewer that
        // this estimator shares with the one it checks.
        if !crate::transport::walk::survives(&mut beta, 1.0, depth + 1, s) {
            break;
        }
        d = bs.wi;
        origin = hit.spawn_origin(d);
    }
    l
}
