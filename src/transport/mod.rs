//! Light transport: sampling warps, scattering models, and the random walks built from them.
pub mod bsdf;
pub mod deflection;
pub mod guide;
pub mod light;
pub mod mirror;
pub mod sampling;
pub mod space;
pub mod trace;
pub mod training;
pub mod walk;
