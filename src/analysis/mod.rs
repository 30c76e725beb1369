//! Reports computed from fields and runs: separatrices of a finished field, and the convergence
//! of error against time.
pub mod converge;
pub mod separatrix;
