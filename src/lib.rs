//! ftpd3d: Finite-Time Path Deflection (FTPD) fields of 3D scenes by path-space Monte Carlo
//! integration through Embree, after the paper "Visualization of Coherent Structures of Light
//! Transport", Computer Graphics Forum 34(3), 2015 (sections 5 and 6).
//!
//! Modules import one way (checked by `tests/layers.rs`): [`math`], [`rng`] → [`accel`] (Embree) →
//! [`scene`] (data: geometry, materials, lights, flatland preparation) → [`kernel`] (the four
//! compile-time kernels, the space of directions) → [`transport`] (walks, BSDFs and lights, written
//! once for 3D and flatland) → [`ftpd`] (one sample, moments) → [`domain`] (where samples start)
//! → [`render`], [`run`] (the driver and the runs built on it) → [`field`] (with [`run_info`], the
//! run's typed description), [`output`], [`merge`],
//! [`analysis`] → [`app`], [`cli`] (jobs and the command line). The README's Architecture section has a paragraph per module.

// `!(x > 0.0)` is how this crate rejects NaN along with non-positive values; keep that idiom.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod analysis;
pub mod app;
pub mod cli;
pub mod domain;
pub mod field;
pub mod ftpd;
pub mod kernel;
pub mod math;
pub mod merge;
pub mod output;
pub mod params;
pub mod render;
pub mod rng;
pub mod run_info;
pub mod scene;
pub mod transport;

/// Tool version and the Embree version it was built against, e.g. `0.1.0 (Embree 3.13.5)`.
pub fn version_string() -> String {
    format!(
        "{} (Embree {})",
        env!("CARGO_PKG_VERSION"),
        embree_version()
    )
}

/// The Embree version found at build time.
pub fn embree_version() -> &'static str {
    env!("FTPD3D_EMBREE_VERSION")
}
