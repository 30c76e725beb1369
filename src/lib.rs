//! ftpd3d: Finite-Time Path Deflection (FTPD) fields of 3D scenes by path-space Monte Carlo
//! integration through Embree, after the paper "Visualization of Coherent Structures of Light
//! Transport", Computer Graphics Forum 34(3), 2015 (sections 5 and 6).
//!
//! Modules import one way (checked by `tests/layers.rs`), lowest first:
//!
//! - [`math`], [`rng`]: vectors, colours, keyed random streams;
//! - [`accel`]: Embree, the one room with `unsafe`;
//! - [`scene`]: the scene as data (geometry, materials, lights, cameras, flatland preparation);
//! - [`kernel`]: the four compile-time kernels and the space of directions;
//! - [`transport`]: walks, BSDFs and lights, written once for 3D and flatland;
//! - [`ftpd`]: one sample of the estimator and the moments it adds to;
//! - [`gradient_domain`]: neighbours' differences from replayed samples, and the field
//!   reconstructed from them;
//! - [`domain`]: where samples start (slices, planes, volumes, camera images, tiles);
//! - [`params`]: estimator settings as given, resolved against a scene and a domain;
//! - [`run_info`], [`field`]: a run's typed description and the field of sums it describes;
//! - [`render`]: the driver (passes, budgets, adaptive allocation, interruption) and the runs of a
//!   domain built on it, with their description and time estimate;
//! - [`output`]: the writers and readers (EXR, VTI, VTP, PNG, CSV); [`merge`]: fields added;
//! - [`analysis`]: gradient, separatrices, convergence reports;
//! - [`app`]: validated jobs, run to fields and files ([`app::run_domain`] computes a resolved
//!   domain's field without printing or writing);
//! - [`cli`]: the command line (arguments, job validation, messages that name the flags); the
//!   binary `src/main.rs` is a thin caller of it;
//! - `view` (the default cargo feature `view`): `ftpd3d view`, the live view in a web page, on
//!   top of [`cli`]'s parsers and [`app`]'s runs.
//!
//! Flag names appear only in `src/main.rs`, [`cli`] and [`app`]; the library's errors are typed
//! and [`cli::errors`] words them for the command line. `docs/architecture.md` describes the
//! pipeline and the rooms.

// `!(x > 0.0)` is how this crate rejects NaN along with non-positive values; keep that idiom.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod analysis;
pub mod app;
pub mod cli;
pub mod domain;
pub mod field;
pub mod ftpd;
pub mod gradient_domain;
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
#[cfg(feature = "view")]
pub mod view;

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
