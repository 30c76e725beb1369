//! Reports computed from fields and runs: convergence of error against time, efficiency against a
//! baseline build.
pub mod binary;
pub mod converge;
pub mod efficiency;
pub mod separatrix;
