//! Lights seen through planar mirrors ("virtual lights"): light that reaches a point `x` by one
//! reflection in a planar perfect mirror comes from the mirror image of the light. Next-event
//! estimation cannot find it (the mirror is a Dirac delta), so without this only paths that happen
//! to hit the mirror and then the light carry it, rarely and with large weights.
//!
//! A virtual sample chooses a plane of the scene's [`Mirrors`](crate::scene::mirror::Mirrors) (in
//! proportion to its area), reflects `x` across it to `x'`, samples a light from `x'` as usual
//! (point `y`, direction `wi'`, density `p`), and reflects the direction back: `wi = reflect(wi')`.
//! Reflection is an isometry, so `p` is also the density of `wi` at `x` (per steradian, or per
//! radian in flatland), the distance to the image `y*` is the unfolded path length (a point light's
//! `I / d²` is right), and the segment `x' → y` meets the plane exactly where `x → y*` does. The
//! sample counts only when the ray from `x` towards `y*` first hits a triangle of that plane, and
//! the mirror point sees `y`. Both the densities with which this and BSDF sampling produce the path
//! `x → mirror → y` are known, so the two are combined by multiple importance sampling
//! (`crate::transport::walk`).

use crate::kernel::{Kernel, Space};
use crate::math::Rgb;
use crate::scene::Scene;
use crate::scene::material::Bsdf;
use crate::transport::trace;
use glam::DVec3;

/// A light sampled through a mirror plane, before the rays that check it.
#[derive(Clone, Copy, Debug)]
pub struct VirtualSample {
    /// Unit direction from the receiver towards the light's image (towards the mirror).
    pub wi: DVec3,
    /// The mirror plane (index into [`Mirrors::planes`](crate::scene::mirror::Mirrors::planes)).
    pub plane: usize,
    /// Distance from the receiver to the plane along `wi`.
    pub t_mirror: f64,
    /// The light's point (the shadow ray from the mirror goes there).
    pub target: DVec3,
    /// The unit normal of the emitter's surface at `target` ([`LightSample::surface`]).
    ///
    /// [`LightSample::surface`]: crate::transport::light::LightSample::surface
    pub surface: Option<DVec3>,
    /// Radiance arriving at the mirror from the light (before the mirror's reflectance).
    pub li: Rgb,
    /// Density of `wi`, including the choice of plane and light.
    pub pdf: f64,
    /// The light is a point, spot or sun without a disc: only this strategy finds its image.
    pub delta: bool,
}

/// Samples a light's image in a mirror plane as seen from `x`; `None` when the scene's space has no
/// planar mirror, no light is sampled, the light lies on the other side of the plane from `x`, or
/// the ray towards the image meets the plane outside its triangles' bounding box.
#[inline]
pub fn sample_virtual<D: Space>(
    scene: &Scene,
    sp: &D,
    x: DVec3,
    u_plane: f64,
    u_light: f64,
    u: (f64, f64),
) -> Option<VirtualSample> {
    let mirrors = D::mirrors(scene);
    let (k, p_plane) = mirrors.pick(u_plane)?;
    let plane = &mirrors.planes[k];
    let side = plane.distance(x);
    if side == 0.0 || !side.is_finite() {
        return None;
    }
    let xr = plane.reflect_point(x);
    let mut ls = D::lights(scene).sample(sp, xr, u_light, u)?;
    crate::transport::light::texture_light_sample(scene, &mut ls, xr);
    let wi = plane.reflect_dir(ls.wi);
    let dn = plane.normal.dot(wi);
    let t = -side / dn;
    // The ray must reach the plane before the image of the light (so the light is on x's side).
    if !(t > 0.0 && t < ls.dist && mirrors.may_hold(k, x + wi * t)) {
        return None;
    }
    let pdf = p_plane * ls.pdf;
    (pdf > 0.0 && pdf.is_finite()).then_some(VirtualSample {
        wi,
        plane: k,
        t_mirror: t,
        target: xr + ls.wi * ls.dist,
        surface: ls.surface,
        li: ls.li,
        pdf,
        delta: ls.delta,
    })
}

/// Traces a virtual sample from `x` (rays leave from `origin`, `x` pushed off its surface): the
/// radiance arriving at `x` along `−wi` through the mirror (its reflectance times the light's
/// radiance), or `None` when the ray from `x` does not first hit that mirror plane, or the mirror
/// point does not see the light. Counts the rays it traces in `rays`.
#[inline]
pub fn connect_virtual<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    origin: DVec3,
    vs: &VirtualSample,
    rays: &mut u32,
) -> Option<Rgb> {
    let mirrors = K::Space::mirrors(scene);
    *rays += 1;
    let reach = (vs.t_mirror + (origin - x).length()) * (1.0 + 1e-6) + 1e-6 * scene.extent();
    let hit = trace::intersect::<K>(scene, origin, vs.wi, reach)?;
    if mirrors.plane_of(hit.prim) != Some(vs.plane as u32) {
        return None;
    }
    let (own, _) = K::Space::scatter(scene, hit.material);
    let bsdf = scene.bsdf_at(&hit, own);
    let Bsdf::Mirror { ks, .. } = &*bsdf else {
        return None;
    };
    let out = mirrors.planes[vs.plane].reflect_dir(vs.wi);
    *rays += 1;
    let o = scene.spawn_origin_from(&hit, out, origin);
    trace::visible::<K>(scene, o, vs.target, vs.surface).then_some(*ks * vs.li)
}
