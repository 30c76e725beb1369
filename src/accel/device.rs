//! The process-wide Embree device (its TBB thread pool is process-wide), its error callback,
//! whose message is turned into an [`AccelError`] after each checked call (never unwinding into
//! C), and its memory monitor.

use embree_sys as sys;
use std::cell::RefCell;
use std::ffi::{CStr, c_char, c_void};
use std::sync::OnceLock;

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

/// Embree's memory now and at its peak, in bytes (see `EMBREE_BYTES`).
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

/// The environment variable whose value, if set, is Embree's device configuration string
/// (`rtcNewDevice`'s, e.g. `isa=sse4.2` or `threads=1,isa=avx2`): how the tests run one scene
/// under two of Embree's instruction sets and compare the outputs ([`embree_config`]).
pub const EMBREE_CONFIG_VAR: &str = "FTPD3D_EMBREE_CONFIG";

/// The configuration string the device is created with: [`EMBREE_CONFIG_VAR`]'s value, or none
/// (Embree's defaults: the widest instruction set the CPU and the library both have).
pub fn embree_config() -> Option<String> {
    std::env::var(EMBREE_CONFIG_VAR)
        .ok()
        .filter(|c| !c.trim().is_empty())
}

pub(super) fn device() -> Result<sys::RTCDevice, AccelError> {
    let dev = DEVICE.get_or_init(|| {
        let config = embree_config();
        let c_config = match config.as_deref().map(std::ffi::CString::new) {
            None => None,
            Some(Ok(c)) => Some(c),
            Some(Err(_)) => return Err(format!("{EMBREE_CONFIG_VAR} holds a NUL byte")),
        };
        let ptr = c_config.as_ref().map_or(std::ptr::null(), |c| c.as_ptr());
        // SAFETY: `ptr` is null (Embree's defaults) or a NUL-terminated string that outlives the
        // call (Embree parses it during the call and keeps no pointer to it).
        let raw = unsafe { sys::rtcNewDevice(ptr) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError accepts null and then reports the device-creation error.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(match config {
                Some(c) => format!(
                    "rtcNewDevice failed with code {code} for {EMBREE_CONFIG_VAR}='{c}' \
                     (an instruction set this CPU or this Embree lacks?)"
                ),
                None => format!("rtcNewDevice failed with code {code}"),
            });
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
pub(super) fn check(dev: sys::RTCDevice, during: &'static str) -> Result<(), AccelError> {
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
