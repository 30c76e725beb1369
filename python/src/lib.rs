//! The native part of the Python module `ftpd3d` (`ftpd3d._native`): the library's own API
//! (scene loading, [`ftpd3d::app::run_domain`], the writers' channels and the readers), not a
//! wrapper around the binary. The package `python/ftpd3d/` re-exports it with the exception
//! classes, type stubs and documentation.

mod errors;
mod keywords;
mod options;
mod result;
mod run;
mod scene;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::Scene>()?;
    m.add_class::<result::Field>()?;
    m.add_function(wrap_pyfunction!(result::read, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
