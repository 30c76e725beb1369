//! One integration-test binary (as ripgrep does): each capability is a module.
mod bad_input;
mod bsdf;
mod cli;
mod ftpd;
mod geometry;
mod gltf;
mod mis;
mod stability;
mod valid;
