//! Records the Embree version that `embree-sys` found (through its `links = "embree"` metadata) so
//! that `ftpd3d --version` and every output can name it, and passes the API cfg (`embree3`/`embree4`)
//! on to this crate's `accel` module.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");
    let version = std::env::var("DEP_EMBREE_VERSION").unwrap_or_else(|_| "unknown".into());
    let major = std::env::var("DEP_EMBREE_MAJOR").unwrap_or_else(|_| "3".into());
    println!("cargo:rustc-env=FTPD3D_EMBREE_VERSION={version}");
    println!("cargo:rustc-cfg=embree{major}");
    println!("cargo:rerun-if-env-changed=DEP_EMBREE_VERSION");
}
