//! One integration-test binary (as ripgrep does): each capability is a module.
mod bsdf;
mod cli;
mod converge;
mod driver;
mod flat;
mod ftpd;
mod geometry;
mod gltf;
mod merge;
mod mis;
mod valid;
mod volume;
