//! Scaffolding the test modules share, one module per concern; everything is re-exported here, so a
//! test names it `crate::support::…`:
//!
//! - [`files`]: a fresh temporary directory per test, and the EXR and VTI files as independent
//!   readers (the exr crate, vtkio) see them;
//! - [`bin`]: runs of the `ftpd3d` binary, and tests that need a tool outside Rust (Python
//!   packages, a Slurm cluster): skipped with a reason on a developer's machine, failed in CI;
//! - [`scenes`]: the shipped scenes and scenes built in code;
//! - [`estimates`]: FTPD moments at single points and their z-scores against an independent
//!   estimate;
//! - [`stats`]: the statistics every Monte Carlo test judges by: standard errors, normal and χ²
//!   tails, and the number of standard errors a test allows for its stated false-failure
//!   probability;
//! - [`quadrature`]: Gauss–Legendre rules for the references that are integrals.

pub mod bin;
pub mod estimates;
pub mod files;
pub mod quadrature;
pub mod scenes;
pub mod stats;

pub use bin::*;
pub use estimates::*;
pub use files::*;
pub use quadrature::*;
pub use scenes::*;
pub use stats::*;
