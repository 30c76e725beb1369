//! Estimator settings as a caller gives them ([`EstimatorArgs`], with run lengths relative to the
//! scene when not given) and their resolution against a scene and the domain a run covers into the
//! estimator's [`Params`] (paper sections 5-6): run-length window, perturbation cone, bounce caps,
//! weighting, and for flatland runs the prepared plane. Settings that cannot run are
//! [`ParamError`]s.

use crate::domain::offset::{box_offset, camera_offset, flat_extent, plane_offset};
use crate::domain::{CameraView, Plane};
use crate::ftpd::design::DesignError;
use crate::ftpd::{Design, Params, Weighting};
use crate::scene::{self, Scene};

/// Estimator settings as a caller gives them; `None` means "relative to the scene" (see
/// [`EstimatorArgs::resolve`]).
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
    /// The deflection pairs of a sample (`None`: the weighting's, [`Design::default_for`]).
    pub design: Option<Design>,
    /// Guide the radiance paths ([`crate::transport::guide`]; radiance weighting in 3D only).
    pub guide: bool,
}

impl Default for EstimatorArgs {
    /// Radiance weighting, run lengths relative to the scene, a 2° cone, 32 bounces, the
    /// weighting's deflection pairs.
    fn default() -> Self {
        EstimatorArgs {
            weighting: Weighting::Radiance,
            t0: None,
            t1: None,
            angle_deg: 2.0,
            max_bounces: 32,
            radiance_bounces: None,
            design: None,
            guide: false,
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
    /// A design of deflection pairs out of range.
    #[error("deflection pairs per sample: {0}")]
    Design(#[from] DesignError),
    /// Guided radiance paths for a run that traces none, or in flatland.
    #[error("guided radiance paths need radiance weighting in 3D; this run is {what}")]
    GuideUnused { what: String },
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

    /// [`resolve`](Self::resolve) for a camera `view`: the default run lengths start where the
    /// scene starts as the camera sees it, `dist + [0.1 D, 0.5 D]` with `dist` the distance from
    /// the eye to the nearest surface in view ([`camera_offset`]), so that pairs from a camera
    /// outside the scene, or inside a room, reach its surfaces (walks that end in empty space are
    /// never deflected).
    pub fn resolve_for_camera(
        &self,
        scene: &Scene,
        view: &CameraView,
    ) -> Result<Params, ParamError> {
        self.resolve_from(scene, camera_offset(scene, view), scene.extent())
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
        if self.guide && self.weighting != Weighting::Radiance {
            return Err(ParamError::GuideUnused {
                what: format!("{} weighted", self.weighting),
            });
        }
        let design = self
            .design
            .unwrap_or_else(|| Design::default_for(self.weighting));
        design.check()?;
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
            design,
            guide: self.guide,
        })
    }
}

/// What would have made a light in the scene's own format, for messages about a scene without.
pub fn ways_to_light(scene: &Scene) -> &'static str {
    if scene.file_lights.iter().any(|f| f.scale == 0.0) {
        return "the run switched its lights off";
    }
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

/// Sets up a flatland run on `plane`: validates and prepares the scene
/// ([`Scene::prepare_flatland`]), resolves the estimator settings with run-length defaults relative
/// to the cross-section's diagonal (starting, as for any slice, at the distance from the plane's
/// rectangle to the scene, [`plane_offset`]), and returns them with [`Params::flat`] set.
pub fn prepare_flatland(
    scene: &mut Scene,
    plane: &Plane,
    args: &EstimatorArgs,
) -> anyhow::Result<Params> {
    if args.guide {
        return Err(ParamError::GuideUnused {
            what: "flatland".into(),
        }
        .into());
    }
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
