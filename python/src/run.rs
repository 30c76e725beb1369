//! A run with the GIL released: the domain's passes run on a worker thread while the calling
//! thread wakes every few tens of milliseconds to run Python's signal handlers (Ctrl-C raises
//! `KeyboardInterrupt` there) and report progress. A `KeyboardInterrupt`, or an exception from
//! the progress callback, stops the run between chunks of cells and is raised once the worker
//! has stopped; nothing is written.

use ftpd3d::app::{DomainRun, JobDomain, Start, run_domain};
use ftpd3d::ftpd::Params;
use ftpd3d::render::{Hooks, RenderOptions};
use ftpd3d::run_info::RunInfo;
use ftpd3d::scene::Scene;
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::time::Duration;

/// How often the calling thread looks at signals and progress.
const POLL: Duration = Duration::from_millis(40);

/// Where progress goes: nowhere, a callable `f(done, total)`, or a tqdm bar.
pub enum Report {
    None,
    Callback(Py<PyAny>),
    Bar(Py<PyAny>),
}

impl Report {
    /// `progress` as given: `None` (a tqdm bar if tqdm is installed), `False` (nothing), `True`
    /// (tqdm, which must be installed) or a callable.
    pub fn new(
        py: Python<'_>,
        progress: Option<&Bound<'_, PyAny>>,
        total: Option<u64>,
        what: &str,
    ) -> PyResult<Report> {
        let bar = |required: bool| -> PyResult<Report> {
            match py.import("tqdm") {
                Ok(tqdm) => {
                    let kw = pyo3::types::PyDict::new(py);
                    kw.set_item("total", total)?;
                    kw.set_item("unit", "sample")?;
                    kw.set_item("unit_scale", true)?;
                    kw.set_item("desc", what)?;
                    Ok(Report::Bar(
                        tqdm.getattr("tqdm")?.call((), Some(&kw))?.unbind(),
                    ))
                }
                Err(e) if required && e.is_instance_of::<pyo3::exceptions::PyImportError>(py) => {
                    Err(pyo3::exceptions::PyModuleNotFoundError::new_err(format!(
                        "progress=True shows a tqdm progress bar, but tqdm cannot be imported \
                         ({e}): pip install tqdm, or pass progress=False or a callable \
                         f(done, total)"
                    )))
                }
                Err(e) if required => Err(e),
                Err(_) => Ok(Report::None),
            }
        };
        match progress {
            None => bar(false),
            Some(p) if p.is_none() => bar(false),
            Some(p) if p.is_instance_of::<pyo3::types::PyBool>() => {
                if p.is_truthy()? {
                    bar(true)
                } else {
                    Ok(Report::None)
                }
            }
            Some(p) if p.is_callable() => Ok(Report::Callback(p.clone().unbind())),
            Some(p) => Err(crate::errors::param(format!(
                "progress={}: expected None, True, False or a callable f(done, total)",
                p.repr()?
            ))),
        }
    }

    fn show(&self, py: Python<'_>, done: u64, shown: &mut u64, total: Option<u64>) -> PyResult<()> {
        match self {
            Report::None => {}
            Report::Callback(f) => {
                if done != *shown {
                    f.call1(py, (done, total))?;
                }
            }
            Report::Bar(b) => {
                if done > *shown {
                    b.call_method1(py, "update", (done - *shown,))?;
                }
            }
        }
        *shown = done;
        Ok(())
    }

    fn close(&self, py: Python<'_>) {
        if let Report::Bar(b) = self {
            // A bar that fails to close must not hide the run's own result.
            let _ = b.call_method0(py, "close");
        }
    }
}

/// Everything a domain's run takes.
pub struct RunInput<'a> {
    pub scene: &'a Scene,
    pub domain: &'a JobDomain,
    pub params: &'a Params,
    pub opts: &'a RenderOptions,
    pub info: RunInfo,
}

/// Runs `input` to its field with the GIL released, reporting progress (of `total` samples when
/// the run has a sample cap) and stopping on Ctrl-C or a failing callback.
pub fn run(
    py: Python<'_>,
    input: RunInput<'_>,
    report: &Report,
    total: Option<u64>,
) -> PyResult<DomainRun> {
    let stop = AtomicBool::new(false);
    let samples = AtomicU64::new(0);
    let (result, raised) = py.detach(|| {
        std::thread::scope(|s| {
            let worker = s.spawn(|| {
                let hooks = Hooks {
                    stop: Some(&stop),
                    after_pass: None,
                    samples: Some(&samples),
                };
                let RunInput {
                    scene,
                    domain,
                    params,
                    opts,
                    info,
                } = input;
                crate::errors::no_panic(|| {
                    run_domain(scene, domain, params, opts, info, Start::Fresh, hooks)
                })
            });
            let mut shown = 0;
            let mut raised: Option<PyErr> = None;
            while !worker.is_finished() {
                std::thread::sleep(POLL);
                if raised.is_some() {
                    continue;
                }
                let checked = Python::attach(|py| {
                    py.check_signals()?;
                    report.show(py, samples.load(Relaxed), &mut shown, total)
                });
                if let Err(e) = checked {
                    stop.store(true, Relaxed);
                    raised = Some(e);
                }
            }
            let result = worker.join();
            if raised.is_none() {
                let last =
                    Python::attach(|py| report.show(py, samples.load(Relaxed), &mut shown, total));
                raised = last.err();
            }
            (result, raised)
        })
    });
    report.close(py);
    if let Some(e) = raised {
        return Err(e);
    }
    match result {
        Ok(r) => r.map_err(crate::errors::to_py),
        Err(_) => Err(crate::errors::raise(
            crate::errors::Kind::Run,
            "the run's worker thread panicked",
            None,
        )),
    }
}
