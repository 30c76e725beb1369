//! The only module with `unsafe` Embree calls: a process-wide device, a committed triangle scene that
//! owns its Embree handles (RAII), and thread-safe `intersect` / `occluded` queries.
//!
//! Embree 3 and 4 share this code; the build script of `embree-sys` detects the header's major version
//! and the top-level build script turns it into the cfg `embree3` or `embree4`. Differences handled:
//! - Embree 3's queries take an `RTCIntersectContext`, initialised by a header-inline function that
//!   bindgen cannot see: it is initialised here in Rust (flags, no filter, invalid instance ids).
//! - Embree 4's queries take optional argument structs: passing null selects the defaults.
//!
//! Object lifecycle: a device is created once per process (its TBB thread pool is process-wide); a
//! scene is created, given one triangle geometry that reads the scene's own vertex and index arrays
//! in place (`rtcSetSharedGeometryBuffer`: no copies), committed, and released on drop. A scene
//! with cut-outs (alpha) has two geometries over the same vertex array: the opaque triangles, and
//! the cut-out ones with Embree's intersection and occlusion filter functions. The arrays
//! are [`SharedArray`]s: immutable, padded as Embree requires, and kept alive by the [`Accel`]
//! (a reference count) for as long as Embree may read them. After commit the scene is immutable
//! and queries may run on any thread.

use embree_sys as sys;
use glam::{Vec3, Vec3A};
use std::cell::RefCell;
use std::ffi::{CStr, c_char, c_void};
use std::sync::{Arc, OnceLock};

/// Zeroed elements after the end of a [`SharedArray`]: Embree reads vertices with 16-byte loads,
/// so the last one must be followed by at least 4 readable bytes; two elements (24 bytes for a
/// vertex, 24 for a triangle's indices) cover 16 bytes past the end whatever the element.
const SHARED_PAD: usize = 2;

// The layouts Embree is told (RTC_FORMAT_FLOAT3 and RTC_FORMAT_UINT3, stride 12).
const _: () = assert!(std::mem::size_of::<Vec3>() == 12 && std::mem::align_of::<Vec3>() == 4);
const _: () = assert!(std::mem::size_of::<[u32; 3]>() == 12);

/// An array that Embree reads in place (a shared geometry buffer): immutable (it derefs to a
/// slice and offers no way to change it), followed by [`SHARED_PAD`] zeroed elements that Embree
/// may read, and reference-counted, so that the [`Accel`] reading it keeps it alive. Cloning
/// shares the array.
pub struct SharedArray<T: Copy + Default>(Arc<Vec<T>>);

impl<T: Copy + Default> SharedArray<T> {
    /// Takes `v` over; its spare capacity is grown by the padding if needed (a reallocation that
    /// moves pages rather than copying them, for large arrays), which is zeroed.
    pub fn new(mut v: Vec<T>) -> Self {
        v.shrink_to(v.len() + SHARED_PAD);
        v.reserve_exact(SHARED_PAD);
        for p in &mut v.spare_capacity_mut()[..SHARED_PAD] {
            p.write(T::default());
        }
        SharedArray(Arc::new(v))
    }

    /// The elements and the padding after them, for Embree.
    fn padded_ptr(&self) -> *const T {
        self.0.as_ptr()
    }
}

impl<T: Copy + Default> Clone for SharedArray<T> {
    fn clone(&self) -> Self {
        SharedArray(Arc::clone(&self.0))
    }
}

impl<T: Copy + Default> std::ops::Deref for SharedArray<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.0
    }
}

impl<T: Copy + Default + std::fmt::Debug> std::fmt::Debug for SharedArray<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.0.iter()).finish()
    }
}

impl<T: Copy + Default> Default for SharedArray<T> {
    fn default() -> Self {
        SharedArray::new(Vec::new())
    }
}

/// Errors reported by Embree, through its error callback or its error code.
#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("Embree error {code} during {during}: {message}")]
    Embree {
        code: u32,
        during: &'static str,
        message: String,
    },
    #[error("Embree device could not be created: {0}")]
    Device(String),
    #[error("scene too large for Embree: {0} triangles, {1} vertices (limit 2^32-1)")]
    TooLarge(usize, usize),
}

thread_local! {
    /// The message of the last error Embree reported on this thread (Embree calls the error callback
    /// on the thread of the failing API call). Read and cleared after every checked call.
    static LAST_ERROR: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Error callback: never unwinds into C, only records the message.
unsafe extern "C" fn error_callback(_user: *mut c_void, code: sys::RTCError, msg: *const c_char) {
    let text = if msg.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated string that lives for the duration of the callback.
        unsafe { CStr::from_ptr(msg) }
            .to_string_lossy()
            .into_owned()
    };
    let _ = LAST_ERROR.try_with(|slot| {
        if let Ok(mut slot) = slot.try_borrow_mut() {
            *slot = Some(format!("{text} (code {code})"));
        }
    });
}

/// Bytes Embree has allocated and not freed (BVH, geometry buffers, build scratch), and the most
/// it has held at once, counted by its memory monitor: what the loading benchmark subtracts from
/// the process's resident memory to see the rest.
static EMBREE_BYTES: std::sync::atomic::AtomicI64 = std::sync::atomic::AtomicI64::new(0);
static EMBREE_PEAK: std::sync::atomic::AtomicI64 = std::sync::atomic::AtomicI64::new(0);

/// Memory monitor: accumulates Embree's allocations (positive) and frees (negative); never
/// refuses one, never unwinds into C.
unsafe extern "C" fn memory_monitor(_user: *mut c_void, bytes: isize, _post: bool) -> bool {
    use std::sync::atomic::Ordering::Relaxed;
    let now = EMBREE_BYTES.fetch_add(bytes as i64, Relaxed) + bytes as i64;
    EMBREE_PEAK.fetch_max(now, Relaxed);
    true
}

/// Embree's memory now and at its peak, in bytes (see [`EMBREE_BYTES`]).
pub fn embree_memory() -> (u64, u64) {
    use std::sync::atomic::Ordering::Relaxed;
    (
        EMBREE_BYTES.load(Relaxed).max(0) as u64,
        EMBREE_PEAK.load(Relaxed).max(0) as u64,
    )
}

struct Device(sys::RTCDevice);

// SAFETY: an Embree device is thread-safe by contract (its API may be called from any thread); the
// handle is only released at process exit, never while shared.
unsafe impl Send for Device {}
// SAFETY: as above; `&Device` only hands out the raw handle to thread-safe Embree calls.
unsafe impl Sync for Device {}

static DEVICE: OnceLock<Result<Device, String>> = OnceLock::new();

fn device() -> Result<sys::RTCDevice, AccelError> {
    let dev = DEVICE.get_or_init(|| {
        // SAFETY: a null config string selects Embree's defaults.
        let raw = unsafe { sys::rtcNewDevice(std::ptr::null()) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError accepts null and then reports the device-creation error.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(format!("rtcNewDevice failed with code {code}"));
        }
        // SAFETY: raw is a live device; the callback is a plain function that never unwinds.
        unsafe { sys::rtcSetDeviceErrorFunction(raw, Some(error_callback), std::ptr::null_mut()) };
        // SAFETY: as above; the monitor only updates atomics and may run on any thread.
        unsafe {
            sys::rtcSetDeviceMemoryMonitorFunction(raw, Some(memory_monitor), std::ptr::null_mut())
        };
        Ok(Device(raw))
    });
    match dev {
        Ok(d) => Ok(d.0),
        Err(e) => Err(AccelError::Device(e.clone())),
    }
}

/// Checks the device's error code and the callback slot after an Embree call.
fn check(dev: sys::RTCDevice, during: &'static str) -> Result<(), AccelError> {
    // SAFETY: dev is the live process-wide device.
    let code = unsafe { sys::rtcGetDeviceError(dev) };
    let message = LAST_ERROR.with(|s| s.borrow_mut().take());
    if code != sys::RTCError_RTC_ERROR_NONE {
        return Err(AccelError::Embree {
            code,
            during,
            message: message.unwrap_or_default(),
        });
    }
    Ok(())
}

/// Gives `scene` a triangle geometry with id `id` that reads `triangles` over `positions` in
/// place; with `filter_data`, the cut-out filters and that pointer as the geometry's user data (a
/// live [`Cutouts`] the caller keeps alive).
fn attach(
    dev: sys::RTCDevice,
    scene: sys::RTCScene,
    id: u32,
    positions: &SharedArray<Vec3>,
    triangles: &SharedArray<[u32; 3]>,
    filter_data: Option<*mut c_void>,
) -> Result<(), AccelError> {
    // SAFETY: dev is live; the geometry is released after being attached (the scene keeps a
    // reference), or below on error.
    let geom = unsafe { sys::rtcNewGeometry(dev, sys::RTCGeometryType_RTC_GEOMETRY_TYPE_TRIANGLE) };
    check(dev, "rtcNewGeometry")?;
    // SAFETY: geom is live. The arrays are Vec3 (three f32, 12 bytes, `glam`'s layout without
    // SIMD alignment) and [u32; 3] (12 bytes), 4-byte aligned as Embree requires, of exactly the
    // item counts given, followed by SHARED_PAD zeroed elements (24 bytes), so Embree's 16-byte
    // loads of the last vertex stay inside the allocation. They are never changed (`SharedArray`
    // has no mutable access) and outlive the Embree scene: the caller's `Accel` holds a reference
    // to each (the index arrays of cut-out scenes through its `Cutouts`) and releases the scene
    // before dropping them (on error too, since the `Accel` is dropped then).
    unsafe {
        sys::rtcSetSharedGeometryBuffer(
            geom,
            sys::RTCBufferType_RTC_BUFFER_TYPE_VERTEX,
            0,
            sys::RTCFormat_RTC_FORMAT_FLOAT3,
            positions.padded_ptr() as *const c_void,
            0,
            12,
            positions.len(),
        );
        sys::rtcSetSharedGeometryBuffer(
            geom,
            sys::RTCBufferType_RTC_BUFFER_TYPE_INDEX,
            0,
            sys::RTCFormat_RTC_FORMAT_UINT3,
            triangles.padded_ptr() as *const c_void,
            0,
            12,
            triangles.len(),
        );
    }
    if let Err(e) = check(dev, "shared geometry buffers") {
        // SAFETY: geom is live and not yet attached.
        unsafe { sys::rtcReleaseGeometry(geom) };
        return Err(e);
    }
    if let Some(user) = filter_data {
        // SAFETY: geom is live; `user` points to a `Cutouts` that the caller keeps alive and
        // unmoved as long as the scene exists, which is what `cutout_filter` reads.
        unsafe {
            sys::rtcSetGeometryUserData(geom, user);
            sys::rtcSetGeometryIntersectFilterFunction(geom, Some(cutout_filter));
            sys::rtcSetGeometryOccludedFilterFunction(geom, Some(cutout_filter));
        }
    }
    // SAFETY: geom and scene are live; after attaching, the scene holds its own reference, so
    // releasing ours is the documented pattern.
    unsafe {
        sys::rtcCommitGeometry(geom);
        sys::rtcAttachGeometryByID(scene, geom, id);
        sys::rtcReleaseGeometry(geom);
    }
    check(dev, "geometry commit")
}

/// One hit returned by [`Accel::intersect`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawHit {
    /// Ray parameter of the hit (the ray direction need not be unit).
    pub t: f32,
    /// Index of the triangle in the buffer given to [`Accel::new`].
    pub prim: u32,
    /// Barycentric coordinates of the hit: p = (1-u-v) v0 + u v1 + v v2.
    pub u: f32,
    pub v: f32,
}

/// A committed Embree scene of triangles; immutable and shareable across threads. It holds the
/// vertex and index arrays Embree reads (shared buffers), so they live at least as long as the
/// Embree scene: `Drop` releases the scene first, then the fields (the arrays) are dropped.
pub struct Accel {
    scene: sys::RTCScene,
    shared_positions: SharedArray<Vec3>,
    shared_triangles: SharedArray<[u32; 3]>,
    /// With cut-outs: geometry 0 holds the opaque triangles, geometry 1 those that may be cut
    /// out, with the filter functions; `None` (one geometry of all triangles, no filter) otherwise.
    /// Boxed, so that the address Embree holds as the geometry's user data stays put; dropped after
    /// the scene (`Drop` releases the scene before the fields go).
    cutouts: Option<Box<Cutouts>>,
}

/// Decides whether a candidate hit on a cut-out triangle is rejected (the ray goes on): the
/// triangle's index among the cut-out ones, the hit's barycentric (u, v), and the candidate
/// ([`CutRay`]), whose hash only stochastic coverage draws. Must not panic.
pub type CutTest = dyn Fn(u32, [f32; 2], &CutRay) -> bool + Send + Sync;

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
    /// [`Accel::with_cutouts`]).
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

    /// A number in [0, 1) hashed from the ray and the triangle: the same for the same candidate.
    #[inline]
    pub fn xi(&self) -> f64 {
        crate::rng::hash_unit(&self.words)
    }
}

/// The two geometries' triangles and numbers, and the cut-out test.
struct Cutouts {
    /// The index arrays Embree reads for geometries 0 and 1 (kept alive here).
    indices: [SharedArray<[u32; 3]>; 2],
    /// Index (in the buffer given to [`Accel::with_cutouts`]) of geometry 0's triangle `primID`.
    opaque: Vec<u32>,
    /// Likewise for geometry 1, the cut-out triangles.
    cut: Vec<u32>,
    /// Until set ([`Accel::set_cut_test`]) the cut-out triangles are opaque.
    test: Option<Box<CutTest>>,
}

impl Cutouts {
    #[inline]
    fn global(&self, geom: u32, prim: u32) -> u32 {
        let map = if geom == 0 { &self.opaque } else { &self.cut };
        map.get(prim as usize).copied().unwrap_or(prim)
    }
}

/// Embree's intersection and occlusion filter of the cut-out geometry: rejects the candidate hits
/// the test says are cut out. Reads the ray and hit in Embree's SOA layout for `N` rays
/// (`RTCRayN_*` / `RTCHitN_*` in rtcore_ray.h: field k of ray i at word k·N + i).
unsafe extern "C" fn cutout_filter(args: *const sys::RTCFilterFunctionNArguments) {
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
        // levels) words; the indices below stay within the first 7 fields of each.
        unsafe {
            if *args.valid.add(i) == 0 {
                continue;
            }
            let word = |p: *const f32, k: usize| *p.add(k * n + i);
            let prim = word(hit, 5).to_bits();
            let bary = [word(hit, 3), word(hit, 4)];
            let global = cut.cut.get(prim as usize).copied().unwrap_or(u32::MAX);
            let candidate = CutRay::new(
                [word(ray, 0), word(ray, 1), word(ray, 2)],
                [word(ray, 4), word(ray, 5), word(ray, 6)],
                global,
            );
            if test(prim, bary, &candidate) {
                *args.valid.add(i) = 0;
            }
        }
    }
}

// SAFETY: a committed Embree scene is read-only; Embree documents rtcIntersect1/rtcOccluded1 as safe
// to call concurrently from many threads on the same committed scene.
unsafe impl Send for Accel {}
// SAFETY: as above; no method mutates the scene after commit.
unsafe impl Sync for Accel {}

impl Drop for Accel {
    fn drop(&mut self) {
        // SAFETY: self.scene is a live scene handle owned by this value and released exactly once.
        unsafe { sys::rtcReleaseScene(self.scene) };
    }
}

impl Accel {
    /// Builds and commits a scene of `triangles` over `positions`. Embree reads both arrays in
    /// place, for as long as the scene exists: the `Accel` keeps a reference to each. Triangles
    /// must index valid vertices (the scene loader guarantees it and drops degenerate ones).
    pub fn new(
        positions: &SharedArray<Vec3>,
        triangles: &SharedArray<[u32; 3]>,
    ) -> Result<Accel, AccelError> {
        Accel::with_cutouts(positions, triangles, &[])
    }

    /// As [`Accel::new`], with the triangles whose indices are in `cutout` (strictly increasing)
    /// in a geometry of their own that has Embree's intersection and occlusion filters, so that
    /// rays pass through them where [`Accel::set_cut_test`] says; the other triangles' geometry
    /// has no filter and costs what it did. Hits and point queries report indices into
    /// `triangles` either way. With cut-outs, each geometry reads an index array of its own.
    pub fn with_cutouts(
        positions: &SharedArray<Vec3>,
        triangles: &SharedArray<[u32; 3]>,
        cutout: &[u32],
    ) -> Result<Accel, AccelError> {
        if triangles.len() >= u32::MAX as usize || positions.len() >= u32::MAX as usize {
            return Err(AccelError::TooLarge(triangles.len(), positions.len()));
        }
        debug_assert!(
            triangles
                .iter()
                .flatten()
                .all(|&i| (i as usize) < positions.len())
        );
        debug_assert!(cutout.windows(2).all(|w| w[0] < w[1]));
        debug_assert!(cutout.iter().all(|&i| (i as usize) < triangles.len()));
        let dev = device()?;
        // SAFETY: dev is a live device; the scene is released by Drop (or below on error).
        let scene = unsafe { sys::rtcNewScene(dev) };
        check(dev, "rtcNewScene")?;
        let mut accel = Accel {
            scene,
            shared_positions: positions.clone(),
            shared_triangles: triangles.clone(),
            cutouts: None,
        };
        // SAFETY: scene is live. Robust mode avoids optimisations that can let rays slip through
        // shared edges and vertices, which the FTPD walks cross often.
        unsafe {
            sys::rtcSetSceneFlags(scene, sys::RTCSceneFlags_RTC_SCENE_FLAG_ROBUST);
            sys::rtcSetSceneBuildQuality(scene, sys::RTCBuildQuality_RTC_BUILD_QUALITY_HIGH);
        }
        if cutout.is_empty() {
            if !triangles.is_empty() {
                attach(
                    dev,
                    scene,
                    0,
                    &accel.shared_positions,
                    &accel.shared_triangles,
                    None,
                )?;
            }
        } else {
            let mut is_cut = vec![false; triangles.len()];
            for &i in cutout {
                is_cut[i as usize] = true;
            }
            let opaque: Vec<u32> = (0..triangles.len() as u32)
                .filter(|&i| !is_cut[i as usize])
                .collect();
            let pick = |ids: &[u32]| {
                SharedArray::new(ids.iter().map(|&i| triangles[i as usize]).collect())
            };
            let cuts = Box::new(Cutouts {
                indices: [pick(&opaque), pick(cutout)],
                opaque,
                cut: cutout.to_vec(),
                test: None,
            });
            let user = &*cuts as *const Cutouts as *mut c_void;
            let [opaque_tris, cut_tris] = cuts.indices.clone();
            accel.cutouts = Some(cuts);
            if !opaque_tris.is_empty() {
                attach(dev, scene, 0, &accel.shared_positions, &opaque_tris, None)?;
            }
            attach(
                dev,
                scene,
                1,
                &accel.shared_positions,
                &cut_tris,
                Some(user),
            )?;
        }
        // SAFETY: scene is live and fully described.
        unsafe { sys::rtcCommitScene(scene) };
        check(dev, "rtcCommitScene")?;
        Ok(accel)
    }

    /// Sets the test that decides, per candidate hit, whether a cut-out triangle is absent there
    /// (see [`CutTest`]); no effect on a scene built without cut-outs.
    pub fn set_cut_test(&mut self, test: Box<CutTest>) {
        if let Some(c) = self.cutouts.as_mut() {
            c.test = Some(test);
        }
    }

    /// True when the scene was built with cut-out triangles.
    pub fn has_cutouts(&self) -> bool {
        self.cutouts.is_some()
    }

    /// The index into the triangles given at build time of triangle `prim` of geometry `geom`.
    #[inline]
    fn global(&self, geom: u32, prim: u32) -> u32 {
        match &self.cutouts {
            None => prim,
            Some(c) => c.global(geom, prim),
        }
    }

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
        (rh.hit.geomID != sys::RTC_INVALID_GEOMETRY_ID).then(|| RawHit {
            t: rh.ray.tfar,
            prim: self.global(rh.hit.geomID, rh.hit.primID),
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

/// Most triangles one [`Accel::triangles_near`] query reports.
pub const MAX_NEAR: usize = 64;

/// Triangles reported by a point query, in the order Embree found them.
#[derive(Clone, Copy, Debug)]
pub struct Near {
    prims: [u32; MAX_NEAR],
    /// The geometry of each (0, or 1 for cut-out triangles), until mapped to triangle indices.
    geoms: [u32; MAX_NEAR],
    len: usize,
}

impl Near {
    pub fn prims(&self) -> &[u32] {
        &self.prims[..self.len]
    }
}

/// Point-query callback: records the primitive (up to [`MAX_NEAR`]) and never shrinks the query
/// radius. Plain stores only, so it cannot unwind into Embree.
unsafe extern "C" fn collect_near(args: *mut sys::RTCPointQueryFunctionArguments) -> bool {
    // SAFETY: Embree passes valid arguments for the duration of the call; their `userPtr` is the
    // `Near` that `triangles_near` handed to rtcPointQuery, live and used by nobody else meanwhile.
    let (prim, geom, near) = unsafe {
        (
            (*args).primID,
            (*args).geomID,
            &mut *((*args).userPtr as *mut Near),
        )
    };
    if near.len < MAX_NEAR {
        near.prims[near.len] = prim;
        near.geoms[near.len] = geom;
        near.len += 1;
    }
    false
}

impl Accel {
    /// The triangles whose bounding boxes come within `radius` of `p` (a superset of the triangles
    /// within `radius`; at most [`MAX_NEAR`] of them). Nothing for a non-finite point or radius.
    pub fn triangles_near(&self, p: Vec3, radius: f32) -> Near {
        let mut near = Near {
            prims: [0; MAX_NEAR],
            geoms: [0; MAX_NEAR],
            len: 0,
        };
        if !(p.is_finite() && radius.is_finite() && radius >= 0.0) {
            return near;
        }
        let mut query = sys::RTCPointQuery {
            x: p.x,
            y: p.y,
            z: p.z,
            time: 0.0,
            radius,
        };
        // Embree's header-inline rtcInitPointQueryContext: no instance on the stack. Every byte
        // is zeroed first, the struct's tail padding and the spare words after it included: a
        // library built with instance arrays reads `instStackSize` one word later than a header
        // without them says, i.e. from what is padding here, and must read 0 there too.
        let mut buf = std::mem::MaybeUninit::<Spare<sys::RTCPointQueryContext>>::zeroed();
        let ctx: *mut sys::RTCPointQueryContext = buf.as_mut_ptr().cast();
        // SAFETY: `ctx` points into `buf`, which is live, aligned for the struct and all zero; all
        // zero bytes are a valid RTCPointQueryContext (floats and u32s only), and the fields are
        // written in place, so no typed copy drops the zeroed padding.
        unsafe {
            (*ctx).instStackSize = 0;
            for id in (*ctx).instID.iter_mut() {
                *id = sys::RTC_INVALID_GEOMETRY_ID;
            }
        }
        // SAFETY: the scene is committed and immutable (point queries may run concurrently like
        // ray queries); query and ctx are valid, 16-byte aligned (bindgen keeps the alignment) and
        // live for the call; the callback only writes to `near`, which outlives the call.
        unsafe {
            sys::rtcPointQuery(
                self.scene,
                &mut query,
                ctx,
                Some(collect_near),
                &mut near as *mut Near as *mut c_void,
            )
        };
        if self.cutouts.is_some() {
            for k in 0..near.len {
                near.prims[k] = self.global(near.geoms[k], near.prims[k]);
            }
        }
        near
    }
}

/// Zeroed words after a struct handed to Embree.
const SPARE_WORDS: usize = 8;

/// A struct Embree reads or writes, followed by zeroed spare room. `RTCRayHit` and
/// `RTCPointQueryContext` grow by one word per instance level when Embree is built with instance
/// arrays (`RTC_GEOMETRY_INSTANCE_ARRAY`: `instPrimID` after `instID`), and nothing in the library
/// tells whether it was: Debian's 4.3 has them, and the 4.4 library the Embree 4 CI stage uses has
/// them while its configuration header says it has not. Bindings from such a header make the
/// library write `hit.instPrimID` past the end of the struct (onto the stack) and read the point
/// query's `instStackSize` from beyond it. The spare room takes the write and reads as zero, so the
/// layout of either build is safe; the fields this code reads come before the ones that move.
#[repr(C)]
struct Spare<T> {
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

/// An empty vector with room for `capacity` elements, whose buffer the operating system is asked
/// to back with transparent huge pages (Linux `madvise(MADV_HUGEPAGE)`; a plain vector elsewhere and
/// below 2 MiB). For per-triangle records read at random on every hit: on a scene of millions of
/// triangles each hit otherwise misses the TLB as well as the cache. Fill it before reading it;
/// the advice only changes how the kernel backs the pages, never what they hold, and where huge
/// pages are disabled it has no effect.
pub fn vec_with_huge_pages<T>(capacity: usize) -> Vec<T> {
    let mut v: Vec<T> = Vec::with_capacity(capacity);
    #[cfg(target_os = "linux")]
    {
        const HUGE_PAGE: usize = 2 << 20;
        let bytes = v.capacity().saturating_mul(std::mem::size_of::<T>());
        // SAFETY: sysconf has no preconditions.
        let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
        if bytes >= HUGE_PAGE && page > 0 {
            let page = page as usize;
            let start = v.as_mut_ptr() as usize;
            let (lo, hi) = (start.next_multiple_of(page), (start + bytes) / page * page);
            if hi > lo {
                // SAFETY: [lo, hi) are whole pages inside the vector's own allocation, which nothing
                // has read or written yet; MADV_HUGEPAGE is advice about the backing of those pages
                // and leaves their contents and the mapping's permissions as they are. A failure
                // (huge pages disabled) is harmless and ignored.
                let _ = unsafe { libc::madvise(lo as *mut c_void, hi - lo, libc::MADV_HUGEPAGE) };
            }
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn huge_page_vectors_hold_what_is_put_in_them() {
        // Below, at and well above the 2 MiB threshold, and an odd element size, so that the
        // advised range starts and ends inside pages.
        for n in [
            0usize,
            1,
            1000,
            (2 << 20) / 8,
            (2 << 20) / 8 + 12_345,
            3_000_001,
        ] {
            let mut v: Vec<u64> = vec_with_huge_pages(n);
            assert!(v.capacity() >= n);
            v.extend((0..n as u64).map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15)));
            assert!(
                v.iter()
                    .enumerate()
                    .all(|(i, &x)| x == (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
            );
        }
        let mut w: Vec<[u8; 13]> = vec_with_huge_pages(400_000);
        w.extend((0..400_000u32).map(|i| [(i % 251) as u8; 13]));
        assert!(w.iter().enumerate().all(|(i, x)| x[12] == (i % 251) as u8));
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
