//! ftpd3d: Finite-Time Path Deflection (FTPD) fields of 3D scenes by path-space Monte Carlo
//! integration through Embree, after Zirr, Ament and Dachsbacher, "Visualization of Coherent
//! Structures of Light Transport", Computer Graphics Forum 34(3), 2015 (sections 5 and 6).
//!
//! Data flows one way: [`scene`] (load) → [`accel`] (Embree) → [`domain`] (where samples start) →
//! [`ftpd`] (one sample, moments) → [`render`] (parallel passes) → [`output`] (EXR, PNG).

pub mod accel;
pub mod math;
pub mod output;
pub mod rng;
pub mod transport;

/// Tool version and the Embree version it was built against, e.g. `0.1.0 (Embree 3.13.5)`.
pub fn version_string() -> String {
    format!(
        "{} (Embree {})",
        env!("CARGO_PKG_VERSION"),
        env!("FTPD3D_EMBREE_VERSION")
    )
}
