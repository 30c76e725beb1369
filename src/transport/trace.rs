//! Ray queries as a kernel makes them: 3D or in the flatland plane ([`Space::intersect`]), and
//! logged for the benchmark's replay when the kernel records ([`Kernel::RECORD`]); other kernels
//! compile the logging out.

use crate::kernel::{Kernel, Space};
use crate::scene::{Hit, Scene};
use glam::{DVec3, Vec3};

/// Closest hit along `o + t d` for t in (0, tmax) ([`Scene::intersect`], or
/// [`Scene::intersect_in_plane`] in flatland).
#[inline]
pub fn intersect<K: Kernel>(scene: &Scene, o: DVec3, d: DVec3, tmax: f64) -> Option<Hit> {
    if K::RECORD {
        log_ray(o, d, tmax, false);
    }
    K::Space::intersect(scene, o, d, tmax)
}

/// [`Scene::visible`].
#[inline]
pub fn visible<K: Kernel>(scene: &Scene, o: DVec3, target: DVec3, surface: Option<DVec3>) -> bool {
    let Some((d, tmax)) = scene.shadow_ray(o, target, surface) else {
        return false;
    };
    if K::RECORD && tmax > 0.0 {
        log_ray(o, d, tmax, true);
    }
    !scene.occluded(o, d, tmax)
}

/// A ray query as the kernel made it (benchmarks replay these through Embree alone).
#[derive(Clone, Copy, Debug)]
pub struct LoggedRay {
    pub o: Vec3,
    pub d: Vec3,
    pub tfar: f32,
    /// An occlusion (shadow) query rather than a closest-hit query.
    pub shadow: bool,
}

thread_local! {
    static RAY_LOG: std::cell::RefCell<Vec<LoggedRay>> = const { std::cell::RefCell::new(Vec::new()) };
}

fn log_ray(o: DVec3, d: DVec3, tmax: f64, shadow: bool) {
    let r = LoggedRay {
        o: o.as_vec3(),
        d: d.as_vec3(),
        tfar: tmax.min(f32::MAX as f64) as f32,
        shadow,
    };
    RAY_LOG.with(|l| l.borrow_mut().push(r));
}

/// Takes this thread's log of rays traced by a recording kernel ([`crate::kernel::Record`]).
pub fn take_ray_log() -> Vec<LoggedRay> {
    RAY_LOG.with(|l| std::mem::take(&mut *l.borrow_mut()))
}
