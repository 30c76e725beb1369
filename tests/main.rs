//! One integration-test binary (as ripgrep does): each capability is a module.
mod bsdf;
mod cli;
mod driver;
mod ftpd;
mod geometry;
mod gltf;
mod mis;
mod valid;
