//! Light sampling: one light is chosen in proportion to its power, then a point on it uniformly by
//! area (by length in flatland); densities are converted to solid angle (angle) at the receiving
//! point (`sample_x` next to `pdf_x`). The lights themselves are scene data ([`crate::scene::light`]).

use crate::kernel::Space;
use crate::math::Rgb;
use crate::scene::light::{Light, Lights, Shape};
use glam::DVec3;

/// A sampled connection from a receiving point to a light.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the receiver to the light point.
    pub wi: DVec3,
    /// Distance to the light point (the shadow ray stops just short of it).
    pub dist: f64,
    /// The unit normal of the emitter's surface at the light point (area lights; `None` for lights
    /// that are not surfaces): the shadow ray ends off that surface ([`crate::scene::Scene::shadow_ray`]).
    pub surface: Option<DVec3>,
    /// Radiance arriving along `-wi` (area light) or `I / d²` (point light).
    pub li: Rgb,
    /// Solid-angle density including the light choice; for a point light the choice probability.
    pub pdf: f64,
    /// Point lights can only be reached by light sampling.
    pub delta: bool,
    /// The scene triangle of an area light's point ([`NO_EMITTER`] for other lights), so that an
    /// emission texture can be read there ([`texture_light_sample`]).
    pub emitter: u32,
}

/// [`LightSample::emitter`] of a light that is not a triangle.
pub const NO_EMITTER: u32 = u32::MAX;

/// A light sample taken from `x` on an emitter with an emission texture gets the texel's radiance
/// at its point; other samples, and scenes without emission textures, are left as they are. The
/// light was chosen and its point drawn in proportion to the material's constant emission, which
/// stays a valid density: only the radiance changes.
#[inline(always)]
pub fn texture_light_sample(scene: &crate::scene::Scene, ls: &mut LightSample, x: DVec3) {
    if scene.features.emission_textures
        && ls.emitter != NO_EMITTER
        && let Some(l) = scene.emission_at(ls.emitter, x + ls.wi * ls.dist)
    {
        ls.li = l;
    }
}

/// `dist^(dims−1)`: how densities per unit of an emitter's measure (area in 3D, length in
/// flatland) turn into densities per solid angle (per angle), and how a point light's intensity
/// falls off. `d2` is the squared distance and `dist` its square root.
#[inline]
fn falloff(d2: f64, dist: f64, dims: i32) -> f64 {
    if dims == 3 { d2 } else { dist }
}

/// The connection from `x` to the point `y` of an emitter (unit `normal`, emitting radiance
/// `emission` from its front side) chosen with probability `p_choice` and then uniformly on its
/// `measure` (area in 3D, length in flatland; `dims` = 3 or 2): the density is converted to solid
/// angle (angle) by `dist^(dims−1) / cos θ_light`. `None` from behind.
#[inline]
pub(crate) fn connect_emitter(
    x: DVec3,
    y: DVec3,
    normal: DVec3,
    p_choice: f64,
    measure: f64,
    emission: Rgb,
    dims: i32,
) -> Option<LightSample> {
    let to = y - x;
    let d2 = to.length_squared();
    let dist = d2.sqrt();
    if !(dist > 0.0) {
        return None;
    }
    let wi = to / dist;
    let cos_l = -wi.dot(normal);
    if cos_l <= 0.0 {
        return None;
    }
    let pdf = p_choice * falloff(d2, dist, dims) / (measure * cos_l);
    pdf.is_finite().then_some(LightSample {
        wi,
        dist,
        surface: Some(normal),
        li: emission,
        pdf,
        delta: false,
        emitter: NO_EMITTER,
    })
}

/// The density with which [`connect_emitter`] picks the point `y` of that emitter from `x`; 0 from
/// behind.
#[inline]
pub(crate) fn emitter_pdf(
    x: DVec3,
    y: DVec3,
    normal: DVec3,
    p_choice: f64,
    measure: f64,
    dims: i32,
) -> f64 {
    let to = y - x;
    let d2 = to.length_squared();
    let dist = d2.sqrt();
    let cos_l = -to.dot(normal) / dist;
    if !(cos_l > 0.0) {
        return 0.0;
    }
    p_choice * falloff(d2, dist, dims) / (measure * cos_l)
}

/// glTF's spot falloff (`KHR_lights_punctual`): with `cd` the cosine between the spot's axis and
/// the direction to the receiver, `t = clamp((cd − cos_outer) / max(0.001, cos_inner − cos_outer),
/// 0, 1)` and the intensity scales by t².
#[inline]
pub fn spot_falloff(cd: f64, cos_inner: f64, cos_outer: f64) -> f64 {
    let scale = 1.0 / (cos_inner - cos_outer).max(0.001);
    let t = ((cd - cos_outer) * scale).clamp(0.0, 1.0);
    t * t
}

/// The connection from `x` to an isotropic point light of radiant intensity `intensity` (per
/// steradian in 3D, per radian in flatland) chosen with probability `p_choice`: what arrives is
/// `I / dist^(dims−1)`, and only light sampling finds it (`delta`).
#[inline]
pub(crate) fn connect_point(
    x: DVec3,
    position: DVec3,
    intensity: Rgb,
    p_choice: f64,
    dims: i32,
) -> Option<LightSample> {
    let to = position - x;
    let d2 = to.length_squared();
    let dist = d2.sqrt();
    if !(dist > 0.0) {
        return None;
    }
    Some(LightSample {
        wi: to / dist,
        dist,
        surface: None,
        li: intensity / falloff(d2, dist, dims),
        pdf: p_choice,
        delta: true,
        emitter: NO_EMITTER,
    })
}

/// Light sampling, written once for every space: `D::point_on` draws the point on an emitter's
/// shape, `D::DIMS` converts densities and falls off.
impl<S: Shape> Lights<S> {
    /// Samples a light point as seen from `x` in the space `D` (whose emitters have shape `S`).
    /// `None` when there are no lights or the point faces away (back of a one-sided emitter).
    #[inline(always)]
    pub fn sample<D: Space<Shape = S>>(
        &self,
        sp: &D,
        x: DVec3,
        u_light: f64,
        u: (f64, f64),
    ) -> Option<LightSample> {
        let (i, p_choice) = self.choice.pick(u_light)?;
        match &self.lights[i] {
            Light::Area {
                prim,
                shape,
                normal,
                measure,
                emission,
            } => connect_emitter(
                x,
                D::point_on(shape, u),
                *normal,
                p_choice,
                *measure,
                *emission,
                D::DIMS,
            )
            .map(|ls| LightSample {
                emitter: *prim,
                ..ls
            }),
            Light::Point {
                position,
                intensity,
            } => connect_point(x, *position, *intensity, p_choice, D::DIMS),
            Light::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
            } => {
                let mut ls = connect_point(x, *position, *intensity, p_choice, D::DIMS)?;
                ls.li *= spot_falloff(-ls.wi.dot(*direction), *cos_inner, *cos_outer);
                Some(ls)
            }
            Light::Distant {
                direction,
                irradiance,
                half_angle,
                radiance,
                measure,
                ..
            } => {
                let dist = self.beyond(x);
                if *half_angle > 0.0 {
                    Some(LightSample {
                        wi: sp.cone(*direction, *half_angle, u),
                        dist,
                        surface: None,
                        li: *radiance,
                        pdf: p_choice / measure,
                        delta: false,
                        emitter: NO_EMITTER,
                    })
                } else {
                    Some(LightSample {
                        wi: *direction,
                        dist,
                        surface: None,
                        li: *irradiance,
                        pdf: p_choice,
                        delta: true,
                        emitter: NO_EMITTER,
                    })
                }
            }
            Light::Sky { radiance } => Some(LightSample {
                wi: sp.uniform(u),
                dist: self.beyond(x),
                surface: None,
                li: *radiance,
                pdf: p_choice * D::PDF_UNIFORM,
                delta: false,
                emitter: NO_EMITTER,
            }),
            Light::Env(env) => {
                let (wi, pdf) = D::env_sample(env, u)?;
                Some(LightSample {
                    wi,
                    dist: self.beyond(x),
                    surface: None,
                    li: env.map.radiance(wi),
                    pdf: p_choice * pdf,
                    delta: false,
                    emitter: NO_EMITTER,
                })
            }
        }
    }

    /// The radiance that a ray leaving the scene along `d` collects from each light it sees
    /// ([`Light::is_infinite`]: the sky, a sun with a disc), each with the density with which
    /// [`sample`](Self::sample) picks `d` for that light: `f(radiance, density)` per light.
    #[inline]
    pub fn escaped<D: Space<Shape = S>>(&self, d: DVec3, mut f: impl FnMut(Rgb, f64)) {
        for &i in &self.infinite {
            let p = self.choice.prob(i as usize);
            match &self.lights[i as usize] {
                Light::Sky { radiance } => f(*radiance, p * D::PDF_UNIFORM),
                Light::Distant {
                    direction,
                    cos_max,
                    radiance,
                    measure,
                    ..
                } if d.dot(*direction) >= *cos_max => f(*radiance, p / measure),
                Light::Env(env) => f(env.map.radiance(d), p * D::env_pdf(env, d)),
                _ => {}
            }
        }
    }

    /// Whether rays leaving the scene see any light ([`escaped`](Self::escaped) finds some).
    #[inline(always)]
    pub fn has_infinite(&self) -> bool {
        !self.infinite.is_empty()
    }

    /// Density (per steradian, or radian) with which [`sample`](Self::sample) picks the point `y`
    /// of triangle `prim`'s emitter as seen from `x`; 0 when `prim` is not an emitter.
    #[inline]
    pub fn pdf_hit<D: Space<Shape = S>>(&self, x: DVec3, prim: u32, y: DVec3) -> f64 {
        let Some(&li) = self.light_of_prim.get(prim as usize) else {
            return 0.0;
        };
        if li == u32::MAX {
            return 0.0;
        }
        let Light::Area {
            normal, measure, ..
        } = &self.lights[li as usize]
        else {
            return 0.0;
        };
        emitter_pdf(
            x,
            y,
            *normal,
            self.choice.prob(li as usize),
            *measure,
            D::DIMS,
        )
    }
}
