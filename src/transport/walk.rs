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
use crate::scene::light::Lights;
use crate::scene::material::Bsdf;
use crate::scene::mirror::Mirrors;
use crate::scene::{Hit, Scene};
use crate::transport::bsdf::{BsdfSample, Mode};
use crate::transport::guide::{Guide, GuideAt, guidable};
use crate::transport::{light, mirror, trace};
use glam::DVec3;
use std::cell::Cell;

/// The scattering model at `hit` and its Phong lobe's constants, for kernel `$K`: the material's,
/// or the model its textures give there, which then lives in `$slot`, a local the caller declares
/// (`let textured;`). A macro, not a function: returning the textured model through an `Option`
/// slot of the caller was measurably slower per sample than this local.
macro_rules! bsdf_at {
    ($K:ident, $scene:expr, $hit:expr, $slot:ident) => {{
        let (bsdf, lobe) = $K::Space::scatter($scene, $hit.material);
        match $scene.textured_bsdf($hit) {
            Some(b) => {
                $slot = ($K::Space::textured_lobe(&b, lobe), b);
                (&$slot.1, &$slot.0)
            }
            None => (bsdf, lobe),
        }
    }};
}

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
#[inline(always)]
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
        let textured;
        let (bsdf, lobe) = bsdf_at!(K, scene, &hit, textured);
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
    radiance_guided::<K>(scene, x, look, max_bounces, start, Guiding::NONE, s, st)
}

/// A scattering vertex of a radiance path as guide training reads it ([`Guiding::visits`]).
#[derive(Clone, Copy, Debug)]
pub struct Visit {
    pub p: DVec3,
    /// The direction the path left along, and its (mixture) density.
    pub wi: DVec3,
    pub pdf: f64,
    /// Luminance of the throughput that reached the vertex (before its weight f |cos| / pdf).
    pub throughput: f64,
    /// What the path had gathered up to leaving the vertex ([`Radiance::rest`] so far): all it
    /// gathers after comes along `wi`.
    pub gathered: Rgb,
    /// Of that later light, the emission the path found at its next vertex (or the sky it
    /// escaped to), which light sampling at this vertex also reaches.
    pub found: Rgb,
}

/// How a radiance path is guided ([`crate::transport::guide`]), and where it logs its vertices for
/// training.
pub struct Guiding<'a> {
    pub guide: Option<&'a Guide>,
    pub visits: Option<&'a mut Vec<Visit>>,
}

impl Guiding<'_> {
    /// Plain BSDF sampling, nothing logged.
    pub const NONE: Guiding<'static> = Guiding {
        guide: None,
        visits: None,
    };

    /// The path found light `l` by its last sampled direction: the last vertex's `found`.
    #[inline(always)]
    fn found_light(&mut self, l: Rgb) {
        if let Some(v) = self.visits.as_deref_mut().and_then(|log| log.last_mut()) {
            v.found += l;
        }
    }
}

/// [`radiance_mis`] drawing directions at its vertices from the one-sample MIS mixture of the
/// BSDF and `guiding.guide` where that has a guide (no other number is drawn where it has none),
/// and logging its vertices to `guiding.visits`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn radiance_guided<K: Kernel>(
    scene: &Scene,
    x: DVec3,
    look: DVec3,
    max_bounces: u32,
    start: StartMis,
    mut guiding: Guiding<'_>,
    s: &mut Sampler,
    st: &mut RadianceStats,
) -> Radiance {
    let view = SceneView::<K>::of(scene);
    let mut out = Radiance::default();
    let mut path = PathState::start(x, view.has_mirrors, start);
    let mut origin = x;
    let mut d = look;
    loop {
        st.rays += 1;
        let before = path.l;
        let Some(hit) = trace::intersect::<K>(scene, origin, d, f64::INFINITY) else {
            path.escaped::<K>(&view, d, &mut out);
            guiding.found_light(path.l - before);
            break;
        };
        path.emission::<K>(&view, x, &hit, d, &mut out);
        guiding.found_light(path.l - before);
        if path.depth >= max_bounces {
            break;
        }
        let textured;
        let (bsdf, lobe) = bsdf_at!(K, scene, &hit, textured);
        let wo = -d;
        let v = Vertex {
            hit: &hit,
            bsdf,
            lobe,
            wo,
            origin,
            guide: guiding
                .guide
                .filter(|_| guidable(bsdf))
                .and_then(|g| g.at(hit.p)),
            near_edge: Cell::new(0),
        };
        // Next-event estimation on surfaces with a non-delta lobe.
        if !bsdf.is_delta() && !view.lights.is_empty() {
            path.next_event::<K>(&view, &v, s, st);
        }
        // The lights' images in planar mirrors, where the path could still reach them by BSDF
        // sampling (the mirror point scatters only below the bounce cap).
        if view.has_mirrors && !bsdf.is_delta() && path.depth + 1 < max_bounces {
            path.mirror_images::<K>(&view, &v, s, st);
        }
        let sampled = match v.guide {
            None => {
                let u_lobe = s.next_f64();
                let u = s.next_2d();
                bsdf.sample_in(
                    view.sp,
                    lobe,
                    wo,
                    hit.ng,
                    hit.ns,
                    u_lobe,
                    u,
                    s,
                    Mode::Radiance,
                )
            }
            Some(g) => sample_guided::<K>(view.sp, &v, g, s),
        };
        let Some(bs) = sampled else {
            break;
        };
        if let Some(log) = guiding.visits.as_deref_mut() {
            log.push(Visit {
                p: hit.p,
                wi: bs.wi,
                pdf: bs.pdf,
                throughput: luminance(path.beta),
                gathered: path.l,
                found: Rgb::ZERO,
            });
        }
        if view.has_mirrors {
            path.note_mirror(view.mirrors, &hit, &bs);
        }
        if !path.scatter::<K>(&hit, &bs, s) {
            break;
        }
        origin = v.spawn(scene, bs.wi);
        d = bs.wi;
    }
    out.rest = path.l;
    out
}

/// What every vertex of a radiance path reads: the scene as kernel `K`'s space sees it.
struct SceneView<'a, K: Kernel> {
    scene: &'a Scene,
    sp: &'a K::Space,
    lights: &'a Lights<<K::Space as Space>::Shape>,
    mirrors: &'a Mirrors,
    /// The scene has planar mirrors and lights to see in them.
    has_mirrors: bool,
}

impl<'a, K: Kernel> SceneView<'a, K> {
    #[inline(always)]
    fn of(scene: &'a Scene) -> Self {
        let lights = K::Space::lights(scene);
        let mirrors = K::Space::mirrors(scene);
        SceneView {
            scene,
            sp: K::Space::of(scene),
            lights,
            mirrors,
            has_mirrors: !mirrors.is_empty() && !lights.is_empty(),
        }
    }
}

/// A scattering vertex of a radiance path: the hit, its scattering model (with the lobe's
/// constants `L`), the direction back along the path, and the origin of the ray that found it
/// (rays that leave the hit are offset from it: [`Vertex::spawn`]).
struct Vertex<'a, L> {
    hit: &'a Hit,
    bsdf: &'a Bsdf,
    lobe: &'a L,
    wo: DVec3,
    origin: DVec3,
    /// The guide at the hit, where the path mixes it with BSDF sampling.
    guide: Option<GuideAt<'a>>,
    /// [`Scene::near_edge`] of the hit once a ray left it (0 unknown, 1 false, 2 true): the
    /// vertex's rays (next event, mirror image, next segment) share one test.
    near_edge: Cell<u8>,
}

impl<L> Vertex<'_, L> {
    /// Where a ray leaving the vertex along `dir` starts ([`Scene::spawn_origin_from`]).
    #[inline(always)]
    fn spawn(&self, scene: &Scene, dir: DVec3) -> DVec3 {
        let near = match self.near_edge.get() {
            0 => {
                let near = scene.near_edge(self.hit);
                self.near_edge.set(1 + u8::from(near));
                near
            }
            k => k == 2,
        };
        scene.spawn_origin_at(self.hit, near, dir, self.origin)
    }
}

/// A direction at `v` from the one-sample MIS mixture of its BSDF (a model without a Dirac lobe,
/// [`guidable`]) and the guide `g`: the first number picks the strategy, and the sample's density
/// and weight are the mixture's (`pdf` = α p_guide + (1 − α) p_bsdf, `weight` = f |cos| / pdf).
#[inline(always)]
fn sample_guided<K: Kernel>(
    sp: &K::Space,
    v: &Vertex<'_, <K::Space as Space>::Lobe>,
    g: GuideAt<'_>,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let hit = v.hit;
    let pick = s.next_f64();
    let u_lobe = s.next_f64();
    let u = s.next_2d();
    let (wi, f, p_bsdf) = if pick < crate::transport::guide::GUIDE_FRACTION {
        let wi = g.sample(u);
        let f = v
            .bsdf
            .eval_in::<K::Space>(v.lobe, v.wo, wi, hit.ng, hit.ns, Mode::Radiance);
        let p_bsdf = v.bsdf.pdf_in::<K::Space>(v.lobe, v.wo, wi, hit.ng, hit.ns);
        (wi, f, p_bsdf)
    } else {
        let bs = v.bsdf.sample_in(
            sp,
            v.lobe,
            v.wo,
            hit.ng,
            hit.ns,
            u_lobe,
            u,
            s,
            Mode::Radiance,
        )?;
        (bs.wi, bs.weight * bs.pdf, bs.pdf)
    };
    let pdf = g.mixture(g.pdf(wi), p_bsdf);
    if f == Rgb::ZERO || !(pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wi,
        weight: f / pdf,
        pdf,
        delta: false,
        etap: 1.0,
    })
}

/// A radiance path between two of its vertices: what it has gathered and carries, and what the
/// multiple-importance weight of the next light it finds needs.
struct PathState {
    /// Radiance gathered so far, but for the emission the start ray sees ([`Radiance::direct`]).
    l: Rgb,
    /// Throughput.
    beta: Rgb,
    /// The last vertex, the density with which the path left it, and whether by a delta lobe
    /// (light found next then counts in full).
    prev_p: DVec3,
    prev_pdf: f64,
    prev_delta: bool,
    /// The last non-specular vertex (before a mirror) and, once the path has reflected in a
    /// planar mirror from there, its image (`through`).
    before: Option<MirrorMis>,
    through: Option<MirrorMis>,
    /// The product of etap^(d−1) over the refractions so far ([`survives`]).
    eta_scale: f64,
    /// Scattering events so far.
    depth: u32,
}

impl PathState {
    /// A path from `x`, whose start direction the caller drew as `start` says.
    #[inline(always)]
    fn start(x: DVec3, has_mirrors: bool, start: StartMis) -> Self {
        PathState {
            l: Rgb::ZERO,
            beta: Rgb::ONE,
            prev_p: x,
            prev_pdf: 0.0,
            prev_delta: true, // the start direction is given, like a camera ray
            before: (has_mirrors && start.virtual_fraction > 0.0).then_some(MirrorMis {
                p: x,
                pdf: start.pdf,
                scale: start.virtual_fraction,
                balance: true,
            }),
            through: None,
            eta_scale: 1.0,
            depth: 0,
        }
    }

    /// The weight of light the path finds by BSDF sampling (an emitter hit, or the sky and sun
    /// when it leaves the scene) against sampling that light from the last vertex, or from its
    /// image in the mirror the path reflected in; `p_light` is the light-sampling density from a
    /// point.
    #[inline(always)]
    fn found_light_weight(&self, p_light: impl Fn(DVec3) -> f64) -> f64 {
        if let Some(m) = self.through {
            heuristic(m.pdf, m.scale * p_light(m.p), m.balance)
        } else if self.prev_delta {
            1.0
        } else {
            power_heuristic(self.prev_pdf, p_light(self.prev_p))
        }
    }

    /// Leaving the scene along `d`: the sky and a sun disc, if there are any.
    #[inline(always)]
    fn escaped<K: Kernel>(&mut self, view: &SceneView<'_, K>, d: DVec3, out: &mut Radiance) {
        if !view.lights.has_infinite() {
            return;
        }
        if self.depth == 0 {
            // The start direction's own MIS is its caller's (`escaped` again, per light).
            view.lights.escaped::<K::Space>(d, |le, _| out.direct += le);
            out.escaped = true;
        } else {
            view.lights.escaped::<K::Space>(d, |le, p_light| {
                let w = self.found_light_weight(|_| p_light);
                self.l += self.beta * le * w;
            });
        }
    }

    /// The emission `hit` shows back along `d`: the start ray's goes to `out.direct` with the
    /// density with which light sampling from `x` picks that point, later ones are weighted.
    #[inline(always)]
    fn emission<K: Kernel>(
        &mut self,
        view: &SceneView<'_, K>,
        x: DVec3,
        hit: &Hit,
        d: DVec3,
        out: &mut Radiance,
    ) {
        let le = view.scene.emitted(hit, -d);
        if le == Rgb::ZERO {
            return;
        }
        if self.depth == 0 {
            out.direct = le;
            out.direct_pdf = view.lights.pdf_hit::<K::Space>(x, hit.prim, hit.p);
        } else {
            let w = self
                .found_light_weight(|from| view.lights.pdf_hit::<K::Space>(from, hit.prim, hit.p));
            self.l += self.beta * le * w;
        }
    }

    /// Next-event estimation at `v`: a light sample, weighted against BSDF sampling.
    #[inline(always)]
    fn next_event<K: Kernel>(
        &mut self,
        view: &SceneView<'_, K>,
        v: &Vertex<'_, <K::Space as Space>::Lobe>,
        s: &mut Sampler,
        st: &mut RadianceStats,
    ) {
        let (hit, bsdf) = (v.hit, v.bsdf);
        let u_l = s.next_f64();
        let u = s.next_2d();
        let Some(mut ls) = view.lights.sample(view.sp, hit.p, u_l, u) else {
            return;
        };
        light::texture_light_sample(view.scene, &mut ls, hit.p);
        let f = bsdf.eval_in::<K::Space>(v.lobe, v.wo, ls.wi, hit.ng, hit.ns, Mode::Radiance);
        if f == Rgb::ZERO {
            return;
        }
        st.rays += 1;
        let o = v.spawn(view.scene, ls.wi);
        if !trace::visible::<K>(view.scene, o, hit.p + ls.wi * ls.dist, ls.surface) {
            return;
        }
        self.add_sampled_light::<K>(v, f, ls.li, ls.wi, ls.pdf, ls.delta);
    }

    /// A sample of the lights' images in the planar mirrors from `v`
    /// ([`crate::transport::mirror`]), weighted against BSDF sampling.
    #[inline(always)]
    fn mirror_images<K: Kernel>(
        &mut self,
        view: &SceneView<'_, K>,
        v: &Vertex<'_, <K::Space as Space>::Lobe>,
        s: &mut Sampler,
        st: &mut RadianceStats,
    ) {
        let (hit, bsdf) = (v.hit, v.bsdf);
        let u_m = s.next_f64();
        let u_l = s.next_f64();
        let u = s.next_2d();
        let Some(vs) = mirror::sample_virtual(view.scene, view.sp, hit.p, u_m, u_l, u) else {
            return;
        };
        let f = bsdf.eval_in::<K::Space>(v.lobe, v.wo, vs.wi, hit.ng, hit.ns, Mode::Radiance);
        if f == Rgb::ZERO {
            return;
        }
        let o = v.spawn(view.scene, vs.wi);
        let Some(li) = mirror::connect_virtual::<K>(view.scene, hit.p, o, &vs, &mut st.rays) else {
            return;
        };
        self.add_sampled_light::<K>(v, f, li, vs.wi, vs.pdf, vs.delta);
    }

    /// Adds light `li` that reaches `v` from `wi` through the BSDF value `f`, found by a
    /// light-sampling strategy of density `pdf` (a Dirac delta when `delta`: BSDF sampling cannot
    /// find it, and it counts in full), weighted against BSDF sampling by the power heuristic.
    #[inline(always)]
    fn add_sampled_light<K: Kernel>(
        &mut self,
        v: &Vertex<'_, <K::Space as Space>::Lobe>,
        f: Rgb,
        li: Rgb,
        wi: DVec3,
        pdf: f64,
        delta: bool,
    ) {
        let w = if delta {
            1.0
        } else {
            let p_bsdf = v
                .bsdf
                .pdf_in::<K::Space>(v.lobe, v.wo, wi, v.hit.ng, v.hit.ns);
            // Where the path mixes in its guide, what it draws has the mixture's density.
            let p_path = match v.guide {
                Some(g) => g.mixture(g.pdf(wi), p_bsdf),
                None => p_bsdf,
            };
            power_heuristic(pdf, p_path)
        };
        self.l += self.beta * f * li * (w / pdf);
    }

    /// In scenes with planar mirrors: after the path left `hit` as `bs` says, the vertex whose
    /// virtual-light sample also finds the next light. Through a planar mirror from the last
    /// non-specular vertex, that vertex's image; otherwise none.
    #[inline(always)]
    fn note_mirror(&mut self, mirrors: &Mirrors, hit: &Hit, bs: &BsdfSample) {
        self.through = match (self.before, bs.delta, mirrors.plane_of(hit.prim)) {
            (Some(m), true, Some(k)) => Some(MirrorMis {
                p: mirrors.planes[k as usize].reflect_point(m.p),
                scale: m.scale * mirrors.prob(k as usize),
                ..m
            }),
            _ => None,
        };
        self.before = (!bs.delta).then_some(MirrorMis {
            p: hit.p,
            pdf: bs.pdf,
            scale: 1.0,
            balance: false,
        });
    }

    /// The path scatters at `hit` as `bs` says; false when Russian roulette ends it
    /// ([`survives`]).
    #[inline(always)]
    fn scatter<K: Kernel>(&mut self, hit: &Hit, bs: &BsdfSample, s: &mut Sampler) -> bool {
        self.beta *= bs.weight;
        if bs.etap != 1.0 {
            self.eta_scale *= bs.etap.powi(K::Space::DIMS - 1);
        }
        self.depth += 1;
        if !survives(&mut self.beta, self.eta_scale, self.depth, s) {
            return false;
        }
        self.prev_p = hit.p;
        self.prev_pdf = bs.pdf;
        self.prev_delta = bs.delta;
        true
    }
}
