//! Cut-outs (alpha): the test that decides per candidate hit whether a cut-out triangle is absent
//! there, the key stochastic coverage hashes, and Embree's filter callback that applies it.

use super::SharedArray;
use embree_sys as sys;

/// Decides whether a candidate hit on a cut-out triangle is rejected (the ray goes on): the
/// triangle's index among the cut-out ones and the candidate ([`CutRay`]: the ray, whose hash
/// only stochastic coverage draws). Where on the triangle the candidate lies is the test's to
/// compute from the ray and the triangle: Embree's own (u, v) of the candidate differ in their
/// last bits with the instruction set Embree picks at run time (SSE, AVX2, AVX-512), and a
/// coverage read there made the same run give other bits on another machine. Must not panic.
pub type CutTest = dyn Fn(u32, &CutRay) -> bool + Send + Sync;

/// The ray (origin, direction, as Embree holds them) and the triangle of a candidate hit on a
/// cut-out triangle: the key of the number in [0, 1) that stochastic coverage compares with α.
/// It is hashed only when asked for ([`CutRay::xi`]), so that deterministic cuts (glTF `MASK`)
/// cost no hash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CutRay {
    words: [u32; 7],
}

impl CutRay {
    /// The ray's origin and direction and the triangle's index (in the buffer given to
    /// [`Accel::with_cutouts`](super::Accel::with_cutouts)).
    pub fn new(origin: [f32; 3], dir: [f32; 3], triangle: u32) -> CutRay {
        CutRay {
            words: [
                origin[0].to_bits(),
                origin[1].to_bits(),
                origin[2].to_bits(),
                dir[0].to_bits(),
                dir[1].to_bits(),
                dir[2].to_bits(),
                triangle,
            ],
        }
    }

    /// The ray's origin, as Embree holds it (the f32 origin the query was made with).
    #[inline]
    pub fn origin(&self) -> [f32; 3] {
        [0, 1, 2].map(|k| f32::from_bits(self.words[k]))
    }

    /// The ray's direction, as Embree holds it.
    #[inline]
    pub fn dir(&self) -> [f32; 3] {
        [3, 4, 5].map(|k| f32::from_bits(self.words[k]))
    }

    /// A number in [0, 1) hashed from the ray and the triangle: the same for the same candidate.
    #[inline]
    pub fn xi(&self) -> f64 {
        crate::rng::hash_unit(&self.words)
    }
}

/// The two geometries' triangles and numbers, and the cut-out test.
pub(super) struct Cutouts {
    /// The index arrays Embree reads for geometries 0 and 1 (kept alive here).
    pub(super) indices: [SharedArray<[u32; 3]>; 2],
    /// Index (in the buffer given to [`Accel::with_cutouts`](super::Accel::with_cutouts)) of
    /// geometry 0's triangle `primID`.
    pub(super) opaque: Vec<u32>,
    /// Likewise for geometry 1, the cut-out triangles.
    pub(super) cut: Vec<u32>,
    /// Until set ([`Accel::set_cut_test`](super::Accel::set_cut_test)) the cut-out triangles are
    /// opaque.
    pub(super) test: Option<Box<CutTest>>,
}

impl Cutouts {
    #[inline]
    pub(super) fn global(&self, geom: u32, prim: u32) -> u32 {
        let map = if geom == 0 { &self.opaque } else { &self.cut };
        map.get(prim as usize).copied().unwrap_or(prim)
    }
}

/// Embree's intersection and occlusion filter of the cut-out geometry: rejects the candidate hits
/// the test says are cut out. Reads the ray and hit in Embree's SOA layout for `N` rays
/// (`RTCRayN_*` / `RTCHitN_*` in rtcore_ray.h: field k of ray i at word k·N + i).
pub(super) unsafe extern "C" fn cutout_filter(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments for the duration of the call; the geometry's user
    // data is the `Cutouts` box owned by the `Accel` whose scene is being queried (it outlives
    // every query, and nothing mutates it while queries run: `set_cut_test` takes `&mut Accel`).
    let (args, cut) = unsafe { (&*args, &*((*args).geometryUserPtr as *const Cutouts)) };
    let Some(test) = cut.test.as_deref() else {
        return;
    };
    let n = args.N as usize;
    let (ray, hit) = (args.ray as *const f32, args.hit as *const f32);
    for i in 0..n {
        // SAFETY: `valid` has N entries, the ray N × 12 words and the hit N × (7 + instance
        // levels) words; the indices below stay within the first 7 fields of each. Only the
        // ray and the primitive are read: the hit's u, v, t and Ng depend on Embree's ISA.
        unsafe {
            if *args.valid.add(i) == 0 {
                continue;
            }
            let word = |p: *const f32, k: usize| *p.add(k * n + i);
            let prim = word(hit, 5).to_bits();
            let global = cut.cut.get(prim as usize).copied().unwrap_or(u32::MAX);
            let candidate = CutRay::new(
                [word(ray, 0), word(ray, 1), word(ray, 2)],
                [word(ray, 4), word(ray, 5), word(ray, 6)],
                global,
            );
            if test(prim, &candidate) {
                *args.valid.add(i) = 0;
            }
        }
    }
}
