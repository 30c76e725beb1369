//! Runs of one domain with the kernel its parameters need: the layer between the driver
//! ([`crate::render`]) and a job ([`crate::app`]). Estimator settings as given (with scene-relative
//! defaults) resolve to [`Params`]; a plane, camera image or volume runs to a [`Field`] whose
//! metadata describes the run; a short calibration estimates how long a run will take.

use crate::domain::volume::Volume;
use crate::domain::{CameraView, Domain, Plane, PlaneDomain, Subset};
use crate::field::Field;
use crate::ftpd::{self, Params, Weighting};
use crate::render::{self, Hooks, Progress, RenderOptions, RunStats, Schedule};
use crate::rng::Sampler;
pub use crate::run_info::fmt_vec;
use crate::run_info::{CameraInfo, CellCount, DomainKind, PlaneInfo, RunInfo, VolumeInfo};
use crate::scene::flat::Flatland;
use crate::scene::{self, Scene};
use anyhow::bail;
use std::time::{Duration, Instant};

/// Estimator settings as the user gave them; `None` means "relative to the scene" (see [`resolve`]).
#[derive(Clone, Debug)]
pub struct EstimatorArgs {
    pub weighting: Weighting,
    pub t0: Option<f64>,
    pub t1: Option<f64>,
    /// Perturbation half-angle in degrees.
    pub angle_deg: f64,
    pub max_bounces: u32,
    /// Cap on scattering events of radiance paths alone (`None`: `max_bounces`).
    pub radiance_bounces: Option<u32>,
}

impl Default for EstimatorArgs {
    /// Radiance weighting, run lengths relative to the scene, a 2° cone, 32 bounces.
    fn default() -> Self {
        EstimatorArgs {
            weighting: Weighting::Radiance,
            t0: None,
            t1: None,
            angle_deg: 2.0,
            max_bounces: 32,
            radiance_bounces: None,
        }
    }
}

/// Default run-length window as fractions of the scene diagonal D: T ∈ [0.1 D, 0.5 D].
pub const DEFAULT_T0_OF_DIAGONAL: f64 = 0.1;
pub const DEFAULT_T1_OF_DIAGONAL: f64 = 0.5;

/// Estimator settings that cannot run, as typed values; the command line names its flags in the
/// message (`cli::errors`), other callers their own.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("the shortest run length t0 = {t0} must be finite and ≥ 0")]
    RunLengthNegative { t0: f64 },
    #[error("the longest run length t1 = {t1} must be finite and > 0")]
    RunLengthNotPositive { t1: f64 },
    #[error("t0 = {t0} is larger than t1 = {t1}: the run-length interval [t0, t1] is empty")]
    RunLengthsEmpty { t0: f64, t1: f64 },
    #[error("the perturbation half-angle {angle_deg}° must lie strictly between 0 and 90 degrees")]
    AngleOutOfRange { angle_deg: f64 },
    /// Radiance weighting in a scene without lights.
    #[error("radiance weighting: {scene} has no lights ({ways})")]
    NoLights { scene: String, ways: &'static str },
    /// A cap on radiance paths for a run that traces none (unweighted).
    #[error(
        "a radiance-path cap of {bounces} scattering events for a {weighting} run, which traces no radiance paths"
    )]
    RadianceCapUnused { bounces: u32, weighting: Weighting },
    /// Flatland radiance weighting, and no light meets the plane.
    #[error("flatland radiance weighting: no light of {scene} meets the slice plane {plane}")]
    NoLightInPlane { scene: String, plane: String },
}

impl EstimatorArgs {
    /// Checks the values and fills scene-relative defaults.
    pub fn resolve(&self, scene: &Scene) -> Result<Params, ParamError> {
        self.resolve_with_extent(scene, scene.extent())
    }

    /// [`resolve`](Self::resolve) with run-length defaults relative to the length `d` instead of the
    /// scene diagonal (flatland uses the diagonal of the scene's cross-section).
    pub fn resolve_with_extent(&self, scene: &Scene, d: f64) -> Result<Params, ParamError> {
        self.resolve_from(scene, 0.0, d)
    }

    /// [`resolve`](Self::resolve) for a camera at `eye`: the default run lengths start where the
    /// scene starts, `dist + [0.1 D, 0.5 D]` with `dist` the distance from the eye to the scene's
    /// bounds, so that pairs from a camera outside the scene reach it (walks that end in empty
    /// space are never deflected).
    pub fn resolve_for_camera(
        &self,
        scene: &Scene,
        eye: glam::DVec3,
    ) -> Result<Params, ParamError> {
        self.resolve_from(scene, scene.bounds.distance(eye), scene.extent())
    }

    /// [`resolve`](Self::resolve) for a slice: the default run lengths start where the scene starts
    /// as seen from the slice, `dist + [0.1 D, 0.5 D]` with `dist` the distance between the
    /// slice's rectangle and the scene's bounds ([`Plane::distance_to_box`]): 0 when they overlap
    /// (every default slice, whose rectangle covers the bounds), so only a window or plane placed
    /// away from the scene moves them.
    pub fn resolve_for_plane(&self, scene: &Scene, plane: &Plane) -> Result<Params, ParamError> {
        self.resolve_from(scene, plane_offset(scene, plane), scene.extent())
    }

    /// [`resolve`](Self::resolve) for a volume over `bbox`: `dist + [0.1 D, 0.5 D]` with `dist`
    /// the distance between the box and the scene's bounds (0 when they overlap, as the default
    /// box, the bounds themselves, does).
    pub fn resolve_for_box(&self, scene: &Scene, bbox: &scene::Aabb) -> Result<Params, ParamError> {
        self.resolve_from(scene, box_offset(&scene.bounds, bbox), scene.extent())
    }

    /// Defaults `offset + [0.1 d, 0.5 d]`.
    fn resolve_from(&self, scene: &Scene, offset: f64, d: f64) -> Result<Params, ParamError> {
        let t0 = self.t0.unwrap_or(offset + DEFAULT_T0_OF_DIAGONAL * d);
        let t1 = self
            .t1
            .unwrap_or(offset + DEFAULT_T1_OF_DIAGONAL * d)
            .max(if self.t1.is_none() { t0 } else { 0.0 });
        if !t0.is_finite() || t0 < 0.0 {
            return Err(ParamError::RunLengthNegative { t0 });
        }
        if !t1.is_finite() || t1 <= 0.0 {
            return Err(ParamError::RunLengthNotPositive { t1 });
        }
        if t0 > t1 {
            return Err(ParamError::RunLengthsEmpty { t0, t1 });
        }
        if !(self.angle_deg > 0.0 && self.angle_deg < 90.0) {
            return Err(ParamError::AngleOutOfRange {
                angle_deg: self.angle_deg,
            });
        }
        if let Some(bounces) = self.radiance_bounces
            && self.weighting == Weighting::Unweighted
        {
            return Err(ParamError::RadianceCapUnused {
                bounces,
                weighting: self.weighting,
            });
        }
        if self.weighting == Weighting::Radiance && scene.lights.is_empty() {
            return Err(ParamError::NoLights {
                scene: scene.source.display().to_string(),
                ways: ways_to_light(scene),
            });
        }
        Ok(Params {
            t0,
            t1,
            theta_max: self.angle_deg.to_radians(),
            weighting: self.weighting,
            max_bounces: self.max_bounces,
            radiance_bounces: self.radiance_bounces,
            flat: None,
        })
    }
}

/// Where a slice's default run lengths start: the distance between its rectangle and the scene's
/// bounds, 0 for a scene without bounds and for distances below 1e-9 of the scene's size (a
/// rectangle touching the bounds overlaps them).
pub fn plane_offset(scene: &Scene, plane: &Plane) -> f64 {
    if scene.bounds.is_empty() {
        return 0.0;
    }
    let d = plane.distance_to_box(&scene.bounds);
    if d > 1e-9 * scene.extent() { d } else { 0.0 }
}

/// The distance between two boxes (0 when they overlap).
pub fn box_offset(bounds: &scene::Aabb, bbox: &scene::Aabb) -> f64 {
    if bounds.is_empty() {
        return 0.0;
    }
    let gap = (bounds.min - bbox.max)
        .max(bbox.min - bounds.max)
        .max(glam::DVec3::ZERO);
    gap.length()
}

/// What would have made a light in the scene's own format, for messages about a scene without.
pub fn ways_to_light(scene: &Scene) -> &'static str {
    let ext = scene
        .source
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("gltf" | "glb") => {
            "no emissive material (emissiveFactor) and no KHR_lights_punctual light"
        }
        Some("toml") => {
            "no emissive material in its mesh (Ke in the .mtl, emissiveFactor in glTF) and no \
             [[point_light]], [[spot_light]], [[sun]], [sky] or [environment] in the scene file"
        }
        _ => "no emissive material: Ke in the .mtl",
    }
}

/// Diagonal of the bounds projected onto the plane of `fl` (the size of a flatland scene).
pub fn flat_extent(bounds: &scene::Aabb, fl: &Flatland) -> f64 {
    if bounds.is_empty() {
        return 1.0;
    }
    let (mut lo, mut hi) = (
        glam::DVec2::splat(f64::INFINITY),
        glam::DVec2::splat(f64::NEG_INFINITY),
    );
    for c in bounds.corners() {
        let q = glam::DVec2::new(c.dot(fl.e1), c.dot(fl.e2));
        lo = lo.min(q);
        hi = hi.max(q);
    }
    let d = (hi - lo).length();
    if d > 0.0 && d.is_finite() { d } else { 1.0 }
}

/// Sets up a flatland run on `plane`: validates and prepares the scene
/// ([`Scene::prepare_flatland`]), resolves the estimator settings with run-length defaults relative
/// to the cross-section's diagonal (starting, as for any slice, at the distance from the plane's
/// rectangle to the scene, [`plane_offset`]), and returns them with [`Params::flat`] set.
pub fn prepare_flatland(
    scene: &mut Scene,
    plane: &Plane,
    args: &EstimatorArgs,
) -> anyhow::Result<Params> {
    let fl = plane.flatland();
    scene.prepare_flatland(fl, &plane.label)?;
    let mut params = args.resolve_from(
        scene,
        plane_offset(scene, plane),
        flat_extent(&scene.bounds, &fl),
    )?;
    if params.weighting == Weighting::Radiance && scene.flat().lights.is_empty() {
        return Err(ParamError::NoLightInPlane {
            scene: scene.source.display().to_string(),
            plane: plane.label.clone(),
        }
        .into());
    }
    params.flat = Some(fl);
    Ok(params)
}

/// The description of a run of `domain` (files store it as attributes, see [`crate::run_info`]);
/// the caller places it (plane, camera or volume) and adds what only it knows (command-line point
/// lights).
pub fn describe_run(
    scene: &Scene,
    params: &Params,
    opts: &RenderOptions,
    domain: DomainKind,
) -> RunInfo {
    RunInfo {
        tool: Some(format!("ftpd3d {}", env!("CARGO_PKG_VERSION"))),
        embree: Some(crate::embree_version().into()),
        scene: Some(scene.source.display().to_string()),
        domain: Some(domain),
        weighting: Some(params.weighting),
        t0: Some(params.t0),
        t1: Some(params.t1),
        angle_deg: Some(params.theta_max.to_degrees()),
        max_bounces: Some(params.max_bounces),
        radiance_bounces: Some(params.radiance_cap()),
        seed: Some(opts.seed),
        spp: Some(if opts.budget.cap_spp {
            CellCount::Each(opts.spp as u64)
        } else {
            CellCount::Uncapped
        }),
        batches: Some(CellCount::Each(opts.batches as u64)),
        schedule: Some(Schedule::of(opts).key()),
        adaptive: Some(match opts.adaptive {
            Some(a) => format!("max {}x", a.max_share),
            None => "off".into(),
        }),
        budget_time: Some(opts.budget.time.map_or_else(|| "none".into(), fmt_duration)),
        budget_target_error: Some(
            opts.budget
                .target_error
                .map_or_else(|| "none".into(), |t| t.to_string()),
        ),
        features: Some(scene.features.to_string()),
        flatland: params.flat.is_some(),
        kernel: Some(ftpd::kernel_for(params).to_string()),
        tiles: opts.tile.into_iter().collect(),
        ..RunInfo::default()
    }
}

/// Runs FTPD over a plane (the whole grid, or the stripe `opts.tile`); the field comes back with
/// its metadata filled in. A plane with a surface lying in it (a slice through a wall) starts its
/// points on the surfaces' front sides ([`PlaneDomain`]).
pub fn run_plane(
    scene: &Scene,
    plane: &Plane,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    check_flatland(scene, plane, params)?;
    let (mut field, stats) = run_domain(scene, &PlaneDomain::new(plane, scene), params, opts)?;
    field.set_info(&RunInfo {
        plane: Some(plane_info(plane)),
        ..describe_run(scene, params, opts, DomainKind::Slice)
    });
    Ok((field, stats))
}

/// Runs FTPD over any domain (the whole grid, or the stripe `opts.tile`) with the kernel `params`
/// needs ([`ftpd::kernel_for`]); the field comes back without a description ([`describe_run`]).
pub fn run_domain(
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    let (w, h, d) = domain.dims();
    let mut field = Field::new(w, h, d);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()?;
    let stats = run_domain_progressive(
        &pool,
        scene,
        domain,
        params,
        opts,
        &mut field,
        &mut Progress::default(),
        Hooks::default(),
    )?;
    Ok((field, stats))
}

/// Runs passes over `field` (new, or resumed at `progress`) with the kernel `params` needs until a
/// budget of `opts` is reached or `hooks.stop` is set; see [`render::run_progressive`].
#[allow(clippy::too_many_arguments)]
pub fn run_domain_progressive(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
    field: &mut Field,
    progress: &mut Progress,
    hooks: Hooks,
) -> anyhow::Result<RunStats> {
    let dims = domain.dims();
    if (field.width, field.height, field.depth) != dims {
        bail!(
            "the field is {}x{}x{} cells, the domain {}x{}x{}",
            field.width,
            field.height,
            field.depth,
            dims.0,
            dims.1,
            dims.2
        );
    }
    // Chosen once per run; the per-sample call inside is monomorphic (inlined into the driver's
    // loop), unlike a call through `ftpd::sampler`'s function pointer, which costs about 1 % more
    // instructions per sample on the cheapest scenes.
    use crate::kernel::{Plain3D, PlainFlat, Radiance3D, RadianceFlat};
    let k = ftpd::kernel_for(params);
    let drive: Drive = match (k.radiance, k.flatland) {
        (true, false) => drive::<Radiance3D>,
        (false, false) => drive::<Plain3D>,
        (true, true) => drive::<RadianceFlat>,
        (false, true) => drive::<PlainFlat>,
    };
    drive(pool, scene, domain, params, opts, field, progress, hooks)
}

type Drive = fn(
    &rayon::ThreadPool,
    &Scene,
    &dyn Domain,
    &Params,
    &RenderOptions,
    &mut Field,
    &mut Progress,
    Hooks,
) -> anyhow::Result<RunStats>;

/// [`run_domain_progressive`] with kernel `K`.
#[allow(clippy::too_many_arguments)]
fn drive<K: crate::kernel::Kernel>(
    pool: &rayon::ThreadPool,
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
    field: &mut Field,
    progress: &mut Progress,
    hooks: Hooks,
) -> anyhow::Result<RunStats> {
    render::run_progressive(
        pool,
        field,
        opts,
        progress,
        hooks,
        |cell, s: &mut Sampler| {
            ftpd::before_start(params, s);
            ftpd::sample::<K>(scene, domain.start(scene, cell, s), params, s)
        },
    )
}

/// A flatland run needs a flatland kernel, a scene prepared for its plane, and a domain in it.
pub fn check_flatland(scene: &Scene, plane: &Plane, params: &Params) -> anyhow::Result<()> {
    match params.flat {
        None => Ok(()),
        Some(fl) => {
            let prepared = scene.flat.as_ref().map(|f| f.plane);
            if prepared != Some(fl) {
                bail!(
                    "flatland run on {}: the scene was not prepared for this plane \
                     (Scene::prepare_flatland)",
                    plane.label
                );
            }
            let tol = 1e-9 * scene.extent().max(plane.origin.abs().max_element());
            if plane.normal().cross(fl.normal).length() > 1e-12
                || fl.distance(plane.origin).abs() > tol
            {
                bail!(
                    "flatland run: the domain {} does not lie in the flatland plane",
                    plane.label
                );
            }
            Ok(())
        }
    }
}

/// Where a slice lies, for its description.
pub fn plane_info(plane: &Plane) -> PlaneInfo {
    PlaneInfo {
        label: plane.label.clone(),
        origin: plane.origin,
        u: plane.u_axis,
        v: plane.v_axis,
        size: plane.size,
    }
}

/// Where a camera image is taken from, for its description.
pub fn camera_info(view: &CameraView) -> CameraInfo {
    let c = &view.camera;
    CameraInfo {
        name: c.name.clone(),
        eye: c.eye,
        forward: c.forward,
        up: c.up,
        fov_y_deg: c.fov_y.to_degrees(),
    }
}

/// `1h02m03s`, `4m05s`, `12.3s`: a duration as `cli::parse::parse_duration` reads it back (in
/// run metadata and reports).
pub fn fmt_duration(d: Duration) -> String {
    let secs = d.as_secs_f64();
    if secs < 60.0 {
        return format!("{}s", (secs * 1000.0).round() / 1000.0);
    }
    let s = d.as_secs();
    let (h, m, sec) = (s / 3600, s / 60 % 60, s % 60);
    if h > 0 {
        format!("{h}h{m:02}m{sec:02}s")
    } else {
        format!("{m}m{sec:02}s")
    }
}

/// Importance-weighted FTPD over a camera image (the whole image, or the stripe `opts.tile`), with
/// its beauty image (`radiance.R/G/B`).
pub fn run_camera(
    scene: &Scene,
    view: &CameraView,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<(Field, RunStats)> {
    let (mut field, stats) = run_domain(scene, view, params, opts)?;
    field.set_info(&RunInfo {
        camera: Some(camera_info(view)),
        ..describe_run(scene, params, opts, DomainKind::Camera)
    });
    Ok((field, stats))
}

/// How long a run should take, from a short calibration on a few random cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Eta {
    /// Estimated seconds for the whole run.
    pub seconds: f64,
    /// Samples per second measured.
    pub rate: f64,
    /// Cells and samples per cell of the last calibration round.
    pub cells: usize,
    pub spp: u32,
    /// Time spent calibrating, all rounds.
    pub calibration_seconds: f64,
}

/// Seconds the calibration aims at: its last round runs at least this long (or the whole spp).
pub const CALIBRATION_SECONDS: f64 = 0.25;

/// Estimates the run time of `domain` at `opts.spp` by running the same kernel on the same threads
/// over random cells (128 per thread to start, so every thread has work), doubling the samples per
/// cell, then the cells, until a round takes [`CALIBRATION_SECONDS`] (or covers the whole run).
/// Its samples come from other streams and are thrown away; the run itself is unchanged.
pub fn estimate_time(
    scene: &Scene,
    domain: &dyn Domain,
    params: &Params,
    opts: &RenderOptions,
) -> anyhow::Result<Eta> {
    let (w, h, d) = domain.dims();
    let total = w * h * d;
    let threads = opts.thread_count();
    let mut pick = Sampler::new(opts.seed, u64::MAX, u64::MAX);
    let mut subset = Subset {
        inner: domain,
        cells: Vec::new(),
    };
    let mut want = (128 * threads).min(total);
    let mut o = opts.clone();
    o.progress = false;
    o.batches = 1;
    o.seed = opts.seed ^ 0xCA11_B4A7_E000_0000;
    o.spp = 1;
    o.tile = None;
    o.budget = render::Budget::default();
    o.pass_spp = None;
    o.adaptive = None;
    let start = Instant::now();
    loop {
        while subset.cells.len() < want {
            let c = (pick.next_f64() * total as f64) as usize;
            subset.cells.push(c.min(total - 1));
        }
        let (_, stats) = run_domain(scene, &subset, params, &o)?;
        let whole = o.spp >= opts.spp && want >= total;
        if stats.seconds >= CALIBRATION_SECONDS || whole {
            let rate = stats.samples_per_second();
            let samples = total as f64 * opts.spp as f64;
            return Ok(Eta {
                seconds: if rate > 0.0 { samples / rate } else { 0.0 },
                rate,
                cells: subset.cells.len(),
                spp: o.spp,
                calibration_seconds: start.elapsed().as_secs_f64(),
            });
        }
        if o.spp < opts.spp {
            o.spp = o.spp.saturating_mul(2).min(opts.spp);
        } else {
            want = want.saturating_mul(2).min(total);
        }
    }
}

/// Where a volume lies, for its description.
pub fn volume_info(volume: &Volume) -> VolumeInfo {
    VolumeInfo {
        min: volume.origin,
        max: volume.max_corner(),
        dims: volume.dims(),
        spacing: volume.spacing,
    }
}
