//! Ray queries on a committed scene: closest hit and occlusion, safe to run from any thread. Rays
//! are checked before Embree sees them, and the structs Embree writes have spare room after them
//! (see [`Spare`]).

use super::Accel;
use embree_sys as sys;
use glam::{Vec3, Vec3A};

/// One hit returned by [`Accel::intersect`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawHit {
    /// Ray parameter of the hit (the ray direction need not be unit).
    pub t: f32,
    /// Index of the triangle in the buffer given to [`Accel::new`] (for a hit on an instance, its
    /// prototype's triangle, in prototype space).
    pub prim: u32,
    /// The instance hit ([`NO_INSTANCE`](super::NO_INSTANCE) for world-space triangles).
    pub inst: u32,
    /// Barycentric coordinates of the hit: p = (1-u-v) v0 + u v1 + v v2.
    pub u: f32,
    pub v: f32,
}

impl Accel {
    /// Closest hit along `o + t d` for t in (tnear, tfar), or `None`.
    /// A ray with non-finite origin or direction, or an empty interval, hits nothing (Embree builds
    /// with assertions abort the process on such rays).
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<RawHit> {
        if !ray_is_valid(o, d, tnear, tfar) {
            return None;
        }
        let mut buf = Spare {
            value: sys::RTCRayHit {
                ray: make_ray(o, d, tnear, tfar),
                hit: sys::RTCHit::default(),
            },
            spare: [0; SPARE_WORDS],
        };
        let rh = &mut buf.value;
        rh.hit.geomID = sys::RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID = sys::RTC_INVALID_GEOMETRY_ID;
        for id in rh.hit.instID.iter_mut() {
            *id = sys::RTC_INVALID_GEOMETRY_ID;
        }
        #[cfg(embree3)]
        {
            let mut ctx = context();
            // SAFETY: the scene is committed and immutable; ctx and rh are valid, properly aligned
            // (bindgen keeps RTCRayHit's 16-byte alignment) and live for the call, with spare
            // zeroed room after rh (see `Spare`).
            unsafe { sys::rtcIntersect1(self.scene, &mut ctx, rh) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: as above; a null argument struct selects Embree 4's default query arguments.
            unsafe { sys::rtcIntersect1(self.scene, rh, std::ptr::null_mut()) };
        }
        if rh.hit.geomID == sys::RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        let (inst, prim) = self.resolve(rh.hit.instID[0], rh.hit.geomID, rh.hit.primID);
        Some(RawHit {
            t: rh.ray.tfar,
            prim,
            inst,
            u: rh.hit.u,
            v: rh.hit.v,
        })
    }

    /// True when anything lies along `o + t d` for t in (tnear, tfar).
    #[inline]
    pub fn occluded(&self, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> bool {
        if !ray_is_valid(o, d, tnear, tfar) {
            return false;
        }
        let mut ray = make_ray(o, d, tnear, tfar);
        #[cfg(embree3)]
        {
            let mut ctx = context();
            // SAFETY: as in `intersect`.
            unsafe { sys::rtcOccluded1(self.scene, &mut ctx, &mut ray) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: as in `intersect`.
            unsafe { sys::rtcOccluded1(self.scene, &mut ray, std::ptr::null_mut()) };
        }
        // Embree sets tfar to -inf on a hit.
        ray.tfar < 0.0
    }
}

impl Accel {
    /// Up to four closest-hit queries traced together by Embree's packet traversal
    /// (`rtcIntersect4`): lane i is `rays[i]` (origin, direction, tfar; tnear 0) when it is `Some`
    /// and valid. For measuring whether packets pay over [`Accel::intersect`]; the kernel does not
    /// use it.
    pub fn intersect4(&self, rays: &[Option<(Vec3, Vec3, f32)>; 4]) -> [Option<RawHit>; 4] {
        #[repr(C, align(16))]
        struct Valid([i32; 4]);
        let mut valid = Valid([0; 4]);
        let mut buf = Spare {
            value: sys::RTCRayHit4::default(),
            spare: [0; SPARE_WORDS],
        };
        let rh = &mut buf.value;
        for (i, r) in rays.iter().enumerate() {
            rh.hit.geomID[i] = sys::RTC_INVALID_GEOMETRY_ID;
            rh.hit.primID[i] = sys::RTC_INVALID_GEOMETRY_ID;
            for id in rh.hit.instID.iter_mut() {
                id[i] = sys::RTC_INVALID_GEOMETRY_ID;
            }
            let Some((o, d, tfar)) = *r else { continue };
            if !ray_ok(o, d, 0.0, tfar) {
                continue;
            }
            let ray = make_ray(o, d, 0.0, tfar);
            let q = &mut rh.ray;
            (q.org_x[i], q.org_y[i], q.org_z[i]) = (ray.org_x, ray.org_y, ray.org_z);
            (q.dir_x[i], q.dir_y[i], q.dir_z[i]) = (ray.dir_x, ray.dir_y, ray.dir_z);
            (q.tnear[i], q.tfar[i], q.time[i]) = (ray.tnear, ray.tfar, ray.time);
            (q.mask[i], q.id[i], q.flags[i]) = (ray.mask, ray.id, ray.flags);
            valid.0[i] = -1;
        }
        #[cfg(embree3)]
        {
            let mut ctx = context();
            // SAFETY: the scene is committed and immutable; `valid` (16-byte aligned, four lanes),
            // ctx and rh (RTCRayHit4, 16-byte aligned, with zeroed spare room after it for the
            // instance-array words, see `Spare`) are valid and live for the call.
            unsafe { sys::rtcIntersect4(valid.0.as_ptr(), self.scene, &mut ctx, rh) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: as above; a null argument struct selects Embree 4's default query arguments.
            unsafe { sys::rtcIntersect4(valid.0.as_ptr(), self.scene, rh, std::ptr::null_mut()) };
        }
        std::array::from_fn(|i| {
            (valid.0[i] != 0 && rh.hit.geomID[i] != sys::RTC_INVALID_GEOMETRY_ID).then(|| {
                let (inst, prim) =
                    self.resolve(rh.hit.instID[0][i], rh.hit.geomID[i], rh.hit.primID[i]);
                RawHit {
                    t: rh.ray.tfar[i],
                    prim,
                    inst,
                    u: rh.hit.u[i],
                    v: rh.hit.v[i],
                }
            })
        })
    }
}

/// Zeroed words after a struct handed to Embree.
pub(super) const SPARE_WORDS: usize = 8;

/// A struct Embree reads or writes, followed by zeroed spare room. `RTCRayHit` and
/// `RTCPointQueryContext` grow by one word per instance level when Embree is built with instance
/// arrays (`RTC_GEOMETRY_INSTANCE_ARRAY`: `instPrimID` after `instID`), and nothing in the library
/// tells whether it was: Debian's 4.3 has them, and the 4.4 library the Embree 4 CI stage uses has
/// them while its configuration header says it has not. Bindings from such a header make the
/// library write `hit.instPrimID` past the end of the struct (onto the stack) and read the point
/// query's `instStackSize` from beyond it. The spare room takes the write and reads as zero, so the
/// layout of either build is safe; the fields this code reads come before the ones that move.
#[repr(C)]
pub(super) struct Spare<T> {
    value: T,
    spare: [u32; SPARE_WORDS],
}

/// What Embree accepts: finite origin and direction, 0 ≤ tnear ≤ tfar (tfar may be +inf).
#[inline]
fn ray_is_valid(o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> bool {
    let ok = ray_ok(o, d, tnear, tfar);
    debug_assert!(ok, "invalid ray o={o} d={d} [{tnear}, {tfar}]");
    ok
}

/// [`ray_is_valid`] without its debug assertion.
#[inline]
fn ray_ok(o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> bool {
    // Finite exactly where x · 0 = 0 (∞ · 0 and NaN · 0 are NaN): one vector test for the six
    // coordinates, cheaper on every ray than an `is_finite` test of each.
    let finite = (Vec3A::from(o) * 0.0 + Vec3A::from(d) * 0.0)
        .cmpeq(Vec3A::ZERO)
        .all();
    finite && d != Vec3::ZERO && tnear >= 0.0 && tnear <= tfar
}

/// A ray with all mask bits set (Embree 4 geometries default to mask 1) and no motion blur time.
#[inline]
fn make_ray(o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> sys::RTCRay {
    sys::RTCRay {
        org_x: o.x,
        org_y: o.y,
        org_z: o.z,
        tnear,
        dir_x: d.x,
        dir_y: d.y,
        dir_z: d.z,
        time: 0.0,
        tfar,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

/// Embree 3's `rtcInitIntersectContext`, which is header-inline: incoherent rays, no filter, no
/// instance on the stack.
#[cfg(embree3)]
#[inline]
fn context() -> sys::RTCIntersectContext {
    let mut ctx = sys::RTCIntersectContext {
        flags: sys::RTCIntersectContextFlags_RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        filter: None,
        ..Default::default()
    };
    for id in ctx.instID.iter_mut() {
        *id = sys::RTC_INVALID_GEOMETRY_ID;
    }
    ctx
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::SharedArray;

    #[test]
    fn ray_validity_is_finite_coordinates_nonzero_direction_and_an_interval() {
        let (o, d) = (Vec3::new(1.0, -2.0, 3.0), Vec3::new(0.0, -0.0, 1.0));
        assert!(ray_ok(o, d, 0.0, f32::INFINITY));
        assert!(ray_ok(
            Vec3::splat(f32::MAX),
            Vec3::splat(-f32::MAX),
            0.0,
            1.0
        ));
        for bad in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            for k in 0..3 {
                let mut v = Vec3::ONE;
                v[k] = bad;
                assert!(!ray_ok(v, d, 0.0, 1.0), "origin {v}");
                assert!(!ray_ok(o, v, 0.0, 1.0), "direction {v}");
            }
        }
        assert!(!ray_ok(o, Vec3::ZERO, 0.0, 1.0));
        assert!(!ray_ok(o, d, -1.0, 1.0));
        assert!(!ray_ok(o, d, 2.0, 1.0));
    }

    fn one_triangle() -> Accel {
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        Accel::new(
            &SharedArray::new(p.to_vec()),
            &SharedArray::new(vec![[0, 1, 2]]),
        )
        .expect("scene builds")
    }

    #[test]
    fn ray_hits_triangle_at_analytic_t() {
        let a = one_triangle();
        // From (0.25, 0.25, 2) straight down: t = 2, barycentrics u = 0.25 (v1), v = 0.25 (v2).
        let h = a
            .intersect(
                Vec3::new(0.25, 0.25, 2.0),
                Vec3::new(0.0, 0.0, -1.0),
                0.0,
                f32::INFINITY,
            )
            .unwrap();
        assert_eq!(h.prim, 0);
        assert!((h.t - 2.0).abs() < 1e-6, "t = {}", h.t);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.25).abs() < 1e-6);
        // A slanted ray: from (0.1, 0.2, 3) towards (0.1, 0.2, 0) + (0.3, 0.3, 0): t = 1 with d unnormalised.
        let d = Vec3::new(0.3, 0.3, -3.0);
        let h = a
            .intersect(Vec3::new(0.1, 0.2, 3.0), d, 0.0, f32::INFINITY)
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!(a.occluded(
            Vec3::new(0.25, 0.25, 2.0),
            Vec3::new(0.0, 0.0, -1.0),
            0.0,
            3.0
        ));
        assert!(
            !a.occluded(
                Vec3::new(0.25, 0.25, 2.0),
                Vec3::new(0.0, 0.0, -1.0),
                0.0,
                1.5
            ),
            "tfar before the hit"
        );
    }

    #[test]
    fn misses_miss() {
        let a = one_triangle();
        assert_eq!(
            a.intersect(
                Vec3::new(0.8, 0.8, 2.0),
                Vec3::new(0.0, 0.0, -1.0),
                0.0,
                f32::INFINITY
            ),
            None
        );
        assert_eq!(
            a.intersect(
                Vec3::new(0.25, 0.25, 2.0),
                Vec3::new(0.0, 0.0, 1.0),
                0.0,
                f32::INFINITY
            ),
            None
        );
        assert!(!a.occluded(
            Vec3::new(0.8, 0.8, 2.0),
            Vec3::new(0.0, 0.0, -1.0),
            0.0,
            f32::INFINITY
        ));
        let empty = Accel::new(&SharedArray::default(), &SharedArray::default()).unwrap();
        assert_eq!(
            empty.intersect(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY),
            None
        );
    }

    #[test]
    fn queries_from_many_threads() {
        let a = one_triangle();
        let hits: usize = std::thread::scope(|s| {
            let hs: Vec<_> = (0..4)
                .map(|_| {
                    s.spawn(|| {
                        (0..1000)
                            .filter(|i| {
                                let x = (*i as f32 + 0.5) / 1000.0;
                                a.intersect(Vec3::new(x, 0.1, 1.0), -Vec3::Z, 0.0, 10.0)
                                    .is_some()
                            })
                            .count()
                    })
                })
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).sum()
        });
        assert_eq!(hits, 4 * 900, "x < 0.9 hits for y = 0.1");
    }
}
