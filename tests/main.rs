//! One integration-test binary (as ripgrep does): each capability is a module.
mod bad_input;
mod bsdf;
mod cli;
mod converge;
mod driver;
mod flat;
mod ftpd;
mod geometry;
mod gltf;
mod layers;
mod merge;
mod mis;
mod pinned;
mod stability;
mod support;
mod valid;
mod volume;
