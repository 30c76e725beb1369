//! Reports computed from fields and runs: convergence of error against time.
pub mod converge;
pub mod separatrix;
