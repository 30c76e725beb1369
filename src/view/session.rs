//! The view's run: one worker thread computes the field of the current state in passes
//! ([`app::run_domain`], the command line's own), publishing a snapshot of the field after every
//! complete pass. A new state bumps the generation and sets the cancel flag, which the driver
//! checks between chunks of cells: the pass in flight is dropped (a partial pass is never
//! published) and the worker starts the new state on a fresh field.

use crate::app::{self, DomainArg, Job, JobDomain, Start};
use crate::cli::view::{Pair, state_args};
use crate::field::Field;
use crate::ftpd::Params;
use crate::render::{ErrorStats, Hooks, Progress, RunStats, field_error_stats};
use crate::scene::Scene;
use crate::scene::light::FileLight;
use crate::scene::load::load_scene_with;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::Instant;

/// What the server and the worker share.
pub struct Shared {
    pub inner: Mutex<Inner>,
    /// Wakes the worker when the state changes (or the view quits).
    pub wake: Condvar,
    /// Set when the state changes or the view quits: the run in flight stops between chunks.
    pub cancel: AtomicBool,
    /// Samples taken so far by the current generation's run (the driver adds to it per chunk).
    pub samples: AtomicU64,
    pub quit: AtomicBool,
    /// The command line's flags that a URL cannot change (scene, output, strict loading).
    pub fixed: Vec<Pair>,
}

/// The current state and what its run has shown so far.
pub struct Inner {
    /// Bumped at every change of state.
    pub generation: u64,
    /// The run flags of the current state, merged over the command line's.
    pub state: Vec<Pair>,
    /// The run's scene warnings (as the command line prints them).
    pub warnings: Vec<String>,
    /// The scene file's lights by name, with the current state's scales (kept across changes of
    /// state until the next scene is loaded, so the page's controls stay put).
    pub lights: Vec<FileLight>,
    /// Why the current state cannot run (a flag's value, the scene file), as the command line
    /// says it.
    pub error: Option<String>,
    /// The field after the last complete pass of the current generation (or none yet).
    pub snapshot: Option<Arc<Snapshot>>,
    /// Why the current generation's run stopped; `None` while it runs.
    pub stopped: Option<String>,
    /// When the current generation began.
    pub since: Instant,
}

/// A generation's resolved run: what [`Snapshot`]s and saving need besides the field.
pub struct Prepared {
    pub job: Job,
    pub scene: Scene,
    pub domain: JobDomain,
    pub params: Params,
    /// The state it was prepared from.
    pub state: Vec<Pair>,
}

/// The field after a complete pass, with where its run stands.
pub struct Snapshot {
    pub generation: u64,
    pub field: Field,
    pub progress: Progress,
    pub error: ErrorStats,
    pub run: Arc<Prepared>,
}

impl Shared {
    pub fn new(fixed: Vec<Pair>, state: Vec<Pair>) -> Shared {
        Shared {
            inner: Mutex::new(Inner {
                generation: 1,
                state,
                warnings: Vec::new(),
                lights: Vec::new(),
                error: None,
                snapshot: None,
                stopped: None,
                since: Instant::now(),
            }),
            wake: Condvar::new(),
            cancel: AtomicBool::new(false),
            samples: AtomicU64::new(0),
            quit: AtomicBool::new(false),
            fixed,
        }
    }

    pub fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Makes `state` current (unless it is already): bumps the generation and cancels the run in
    /// flight. Returns the generation.
    pub fn set_state(&self, state: Vec<Pair>) -> u64 {
        let mut g = self.lock();
        if g.state != state {
            g.generation += 1;
            g.state = state;
            g.warnings.clear();
            g.error = None;
            g.snapshot = None;
            g.stopped = None;
            g.since = Instant::now();
            self.cancel.store(true, Ordering::SeqCst);
            self.wake.notify_all();
        }
        g.generation
    }

    /// Stops the worker for good.
    pub fn quit(&self) {
        let _g = self.lock();
        self.quit.store(true, Ordering::SeqCst);
        self.cancel.store(true, Ordering::SeqCst);
        self.wake.notify_all();
    }
}

/// The worker: runs each new state until its budget, a change of state or quitting.
pub fn worker(shared: Arc<Shared>) {
    let mut done = 0;
    loop {
        let (generation, state) = {
            let mut g = shared.lock();
            while g.generation == done && !shared.quit.load(Ordering::SeqCst) {
                g = shared.wake.wait(g).unwrap_or_else(|e| e.into_inner());
            }
            if shared.quit.load(Ordering::SeqCst) {
                return;
            }
            // Under the lock: a change after this point sets the flag again.
            shared.cancel.store(false, Ordering::SeqCst);
            shared.samples.store(0, Ordering::SeqCst);
            (g.generation, g.state.clone())
        };
        done = generation;
        let stopped = match prepare(&shared, generation, state) {
            Ok(run) => run_generation(&shared, generation, Arc::new(run)),
            Err(e) => Err(e),
        };
        let mut g = shared.lock();
        if g.generation == generation {
            match stopped {
                Ok(why) => g.stopped = Some(why),
                Err(e) => {
                    g.error = Some(format!("{e:#}"));
                    g.stopped = Some("error".into());
                }
            }
        }
    }
}

/// The state's job, scene, domain and estimator settings, resolved as the command line resolves
/// them (its parser, its checks, its loader); the scene's warnings go to the page.
fn prepare(shared: &Shared, generation: u64, state: Vec<Pair>) -> anyhow::Result<Prepared> {
    let args = state_args(&shared.fixed, &state).map_err(anyhow::Error::msg)?;
    let mut job = args.job()?;
    job.quiet = true;
    job.render.progress = false;
    job.checkpoint_every = None;
    app::check_job_to_run(&job)?;
    let mut scene = load_scene_with(&job.scene, &job.lights, &job.load)?;
    {
        let mut g = shared.lock();
        if g.generation == generation {
            g.warnings = scene
                .report
                .warnings
                .iter()
                .map(|w| w.to_string())
                .collect();
            g.lights = scene.file_lights.clone();
        }
    }
    let domain = match &job.domain {
        DomainArg::Slice {
            slices,
            window,
            res,
        } => {
            let [arg] = slices.as_slice() else {
                anyhow::bail!(
                    "the view shows one slice at a time; this state has {}",
                    slices.len()
                );
            };
            JobDomain::Plane(crate::domain::slice::resolve_plane(
                arg, &scene, *window, *res,
            )?)
        }
        DomainArg::Camera { camera, size } => {
            JobDomain::Camera(app::resolve_camera(camera, &scene, *size)?)
        }
        DomainArg::Volume { .. } => {
            anyhow::bail!("the view shows slices and camera images, not volumes")
        }
    };
    let params = domain.params(&mut scene, &job.estimator, job.flatland)?;
    Ok(Prepared {
        job,
        scene,
        domain,
        params,
        state,
    })
}

/// Runs one generation's passes, publishing each complete pass; returns why it stopped.
fn run_generation(shared: &Shared, generation: u64, run: Arc<Prepared>) -> anyhow::Result<String> {
    let info = app::describe_domain(
        &run.scene,
        &run.domain,
        &run.params,
        &run.job.render,
        &run.job.lights,
    );
    let mut publish = |f: &mut Field, p: &Progress, _: &RunStats| -> anyhow::Result<()> {
        let snap = Snapshot {
            generation,
            field: f.clone(),
            progress: p.clone(),
            error: field_error_stats(f, 0..f.cells.len()),
            run: run.clone(),
        };
        let mut g = shared.lock();
        if g.generation == generation {
            g.snapshot = Some(Arc::new(snap));
        }
        Ok(())
    };
    let hooks = Hooks {
        stop: Some(&shared.cancel),
        after_pass: Some(&mut publish),
        samples: Some(&shared.samples),
    };
    let done = app::run_domain(
        &run.scene,
        &run.domain,
        &run.params,
        &run.job.render,
        info,
        Start::Fresh,
        hooks,
    )?;
    Ok(done.stats.stop.to_string())
}
