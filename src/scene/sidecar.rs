//! The sidecar scene file (TOML): what an OBJ cannot say. Unknown keys are errors.
//!
//! ```toml
//! mesh = "cornell_mirror.obj"     # OBJ or glTF, relative to this file (required)
//!
//! [[point_light]]                 # isotropic point light
//! position = [0.0, 1.5, 0.0]
//! intensity = [5.0, 5.0, 5.0]     # radiant intensity (per steradian), RGB, scene units
//!
//! [[spot_light]]                  # glTF's spot: full inside inner_deg, none outside outer_deg
//! position = [0.0, 1.9, 0.0]
//! direction = [0.0, -1.0, 0.0]
//! intensity = [5.0, 5.0, 5.0]     # radiant intensity on the axis (per steradian)
//! inner_deg = 20.0                # optional, default 0
//! outer_deg = 30.0                # optional, default 45
//!
//! [[sun]]                         # light from beyond the scene
//! direction = [0.3, 1.0, 0.2]     # towards the sun
//! irradiance = [3.0, 3.0, 3.0]    # on a surface facing it
//! diameter_deg = 0.53             # optional, default 0.53; 0: a Dirac delta
//!
//! [sky]                           # uniform sky
//! radiance = [0.2, 0.3, 0.5]
//!
//! [environment]                   # lat-long HDR map (.exr or .hdr), Mitsuba 3's convention
//! file = "sky.hdr"                # relative to this file
//! scale = 1.0                     # optional
//! rotation_deg = 0.0              # optional: a turn about +y
//!
//! [[camera]]
//! name = "front"
//! eye = [0.0, 1.0, 3.5]
//! target = [0.0, 1.0, 0.0]
//! up = [0.0, 1.0, 0.0]            # optional, default +y
//! fov = 40.0                      # vertical field of view, degrees
//!
//! [[slice]]
//! name = "middle"                 # a run names the slice by it
//! plane = "z=0"
//! ```

use crate::scene::env::{EnvMap, Environment};
use crate::scene::error::{CameraError, LoadError};
use crate::scene::files::{Outside, Reach};
use crate::scene::light::{DEFAULT_SUN_DIAMETER_DEG, Light};
use crate::scene::model::{Camera, Scene};
use glam::DVec3;
use serde::Deserialize;
use std::path::Path;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sidecar {
    pub mesh: String,
    #[serde(default)]
    pub point_light: Vec<PointLightSpec>,
    #[serde(default)]
    pub spot_light: Vec<SpotLightSpec>,
    #[serde(default)]
    pub sun: Vec<SunSpec>,
    pub sky: Option<SkySpec>,
    pub environment: Option<EnvironmentSpec>,
    #[serde(default)]
    pub camera: Vec<CameraSpec>,
    #[serde(default)]
    pub slice: Vec<SliceSpecEntry>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightSpec {
    pub position: [f64; 3],
    pub intensity: [f64; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLightSpec {
    pub position: [f64; 3],
    pub direction: [f64; 3],
    pub intensity: [f64; 3],
    pub inner_deg: Option<f64>,
    pub outer_deg: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SunSpec {
    pub direction: [f64; 3],
    pub irradiance: [f64; 3],
    pub diameter_deg: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkySpec {
    pub radiance: [f64; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnvironmentSpec {
    pub file: String,
    pub scale: Option<f64>,
    pub rotation_deg: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub name: Option<String>,
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub up: Option<[f64; 3]>,
    pub fov: f64,
}

#[derive(Debug, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct SliceSpecEntry {
    pub name: String,
    pub plane: String,
}

/// Reads and validates a sidecar file.
pub fn read(path: &Path) -> Result<Sidecar, LoadError> {
    let text = std::fs::read_to_string(path).map_err(|source| LoadError::Unreadable {
        file: path.to_path_buf(),
        source,
    })?;
    let sc: Sidecar = toml::from_str(&text).map_err(|e| malformed(path, e.to_string()))?;
    validate(&sc, path)?;
    Ok(sc)
}

/// File `name`, which scene file `file` gives as its `what`, lies outside the folder it may read.
pub fn outside(file: &Path, what: &str, name: &str, o: Outside) -> LoadError {
    LoadError::Outside {
        file: file.to_path_buf(),
        what: what.to_string(),
        name: name.to_string(),
        folder: o.folder,
        why: o.why,
    }
}

/// A sidecar's content that cannot be used: `what` says why.
fn malformed(file: &Path, what: String) -> LoadError {
    LoadError::Malformed {
        file: file.to_path_buf(),
        line: None,
        what,
    }
}

/// Checks the values of every table: finite positions and directions, non-negative radiometric
/// values, angles in range, cameras that define a view.
fn validate(sc: &Sidecar, file: &Path) -> Result<(), LoadError> {
    for (i, l) in sc.point_light.iter().enumerate() {
        if !l.position.iter().chain(&l.intensity).all(|v| v.is_finite())
            || l.intensity.iter().any(|v| *v < 0.0)
        {
            return Err(malformed(
                file,
                format!(
                    "point_light #{}: position must be finite and intensity finite and ≥ 0",
                    i + 1
                ),
            ));
        }
    }
    let rgb_ok = |v: &[f64; 3]| v.iter().all(|x| x.is_finite() && *x >= 0.0);
    let dir_ok = |v: &[f64; 3]| DVec3::from(*v).try_normalize().is_some();
    for (i, l) in sc.spot_light.iter().enumerate() {
        let (inner, outer) = (l.inner_deg.unwrap_or(0.0), l.outer_deg.unwrap_or(45.0));
        let valid = l.position.iter().all(|v| v.is_finite())
            && dir_ok(&l.direction)
            && rgb_ok(&l.intensity)
            && 0.0 <= inner
            && inner < outer
            && outer <= 90.0;
        if !valid {
            return Err(malformed(
                file,
                format!(
                    "spot_light #{}: position must be finite, direction finite and not zero, \
                     intensity finite and ≥ 0, and 0 ≤ inner_deg < outer_deg ≤ 90",
                    i + 1
                ),
            ));
        }
    }
    for (i, l) in sc.sun.iter().enumerate() {
        let d = l.diameter_deg.unwrap_or(DEFAULT_SUN_DIAMETER_DEG);
        if !dir_ok(&l.direction) || !rgb_ok(&l.irradiance) || !(0.0..180.0).contains(&d) {
            return Err(malformed(
                file,
                format!(
                    "sun #{}: direction must be finite and not zero, irradiance finite and ≥ 0, \
                     and 0 ≤ diameter_deg < 180",
                    i + 1
                ),
            ));
        }
    }
    if let Some(sky) = &sc.sky
        && !rgb_ok(&sky.radiance)
    {
        return Err(malformed(
            file,
            "sky: radiance must be finite and ≥ 0".into(),
        ));
    }
    for (i, c) in sc.camera.iter().enumerate() {
        if !(c.fov > 0.0 && c.fov < 180.0) {
            return Err(malformed(
                file,
                format!(
                    "camera #{}: fov {} must lie between 0 and 180 degrees",
                    i + 1,
                    c.fov
                ),
            ));
        }
        camera_of(c).map_err(|source| LoadError::Camera {
            sidecar: file.to_path_buf(),
            index: i + 1,
            source,
        })?;
    }
    Ok(())
}

/// A camera from eye/target/up; errors when they do not define a view.
pub fn camera_of(c: &CameraSpec) -> Result<Camera, CameraError> {
    let eye = DVec3::from(c.eye);
    let forward = (DVec3::from(c.target) - eye)
        .try_normalize()
        .ok_or(CameraError::TargetAtEye)?;
    let up0 = DVec3::from(c.up.unwrap_or([0.0, 1.0, 0.0]));
    let right = forward
        .cross(up0)
        .try_normalize()
        .ok_or(CameraError::UpAlongView)?;
    Ok(Camera {
        name: c.name.clone().unwrap_or_else(|| "camera".into()),
        eye,
        forward,
        up: right.cross(forward),
        fov_y: c.fov.to_radians(),
        aspect: None,
    })
}

/// Applies a sidecar's lights and cameras to a loaded scene; `path` is the sidecar's own (files
/// it names are relative to it, and read within `reach`).
pub fn apply(sc: &Sidecar, path: &Path, reach: &Reach, scene: &mut Scene) -> Result<(), LoadError> {
    for l in &sc.point_light {
        scene.add_point_light(DVec3::from(l.position), DVec3::from(l.intensity));
    }
    for l in &sc.spot_light {
        scene.add_light(Light::Spot {
            position: DVec3::from(l.position),
            direction: DVec3::from(l.direction).normalize(),
            intensity: DVec3::from(l.intensity),
            cos_inner: l.inner_deg.unwrap_or(0.0).to_radians().cos(),
            cos_outer: l.outer_deg.unwrap_or(45.0).to_radians().cos(),
        });
    }
    for l in &sc.sun {
        let d = l.diameter_deg.unwrap_or(DEFAULT_SUN_DIAMETER_DEG);
        scene.add_light(Light::distant(
            DVec3::from(l.direction).normalize(),
            DVec3::from(l.irradiance),
            0.5 * d.to_radians(),
        ));
    }
    if let Some(sky) = &sc.sky {
        scene.add_light(Light::Sky {
            radiance: DVec3::from(sky.radiance),
        });
    }
    if let Some(env) = &sc.environment {
        let dir = path.parent().unwrap_or(Path::new(""));
        let file = reach
            .resolve(dir, &env.file)
            .map_err(|o| outside(path, "[environment] file", &env.file, o))?;
        let map = EnvMap::load(
            &file,
            env.scale.unwrap_or(1.0),
            env.rotation_deg.unwrap_or(0.0),
        )
        .map_err(|source| LoadError::Environment {
            sidecar: path.to_path_buf(),
            source,
        })?;
        scene.report.warnings.extend(map.notes.iter().cloned());
        scene.add_light(Light::Env(Environment::new(map)));
    }
    for (i, c) in sc.camera.iter().enumerate() {
        let camera = camera_of(c).map_err(|source| LoadError::Camera {
            sidecar: path.to_path_buf(),
            index: i + 1,
            source,
        })?;
        scene.cameras.push(camera);
    }
    Ok(())
}
