//! Lights a front end adds to those of the scene file (a point light, a sun, a uniform sky, an
//! environment map), built from their values; a value that cannot make a light is a typed
//! [`LightError`], which each front end words with the name of what set it.

use crate::math::is_finite3;
use crate::scene::env::{EnvMap, Environment};
use crate::scene::{DEFAULT_SUN_DIAMETER_DEG, ImageError, Light};
use glam::DVec3;
use std::path::Path;

/// A light's value that cannot make a light.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LightError {
    #[error("values must be finite")]
    NotFinite,
    #[error("intensity must be ≥ 0")]
    Intensity,
    #[error("the direction must be finite and not zero")]
    Direction,
    #[error("irradiance must be ≥ 0")]
    Irradiance,
    #[error("the angular diameter must be a number of degrees in [0, 180)")]
    Diameter,
    #[error("radiance must be ≥ 0")]
    Radiance,
}

/// An isotropic point light at `position` with radiant `intensity` (per steradian; per radian in
/// flatland).
pub fn point_light(position: DVec3, intensity: DVec3) -> Result<Light, LightError> {
    if !(is_finite3(position) && is_finite3(intensity)) {
        return Err(LightError::NotFinite);
    }
    if intensity.min_element() < 0.0 {
        return Err(LightError::Intensity);
    }
    Ok(Light::Point {
        position,
        intensity,
    })
}

/// The sun: `direction` towards it (any length), the `irradiance` it gives a surface facing it,
/// and its angular diameter in degrees (`None`: [`DEFAULT_SUN_DIAMETER_DEG`]; 0: a Dirac delta in
/// direction).
pub fn sun(
    direction: DVec3,
    irradiance: DVec3,
    diameter_deg: Option<f64>,
) -> Result<Light, LightError> {
    let Some(direction) = direction.try_normalize() else {
        return Err(LightError::Direction);
    };
    if !is_finite3(irradiance) {
        return Err(LightError::NotFinite);
    }
    if irradiance.min_element() < 0.0 {
        return Err(LightError::Irradiance);
    }
    let diameter = diameter_deg.unwrap_or(DEFAULT_SUN_DIAMETER_DEG);
    if !(0.0..180.0).contains(&diameter) {
        return Err(LightError::Diameter);
    }
    Ok(Light::distant(
        direction,
        irradiance,
        0.5 * diameter.to_radians(),
    ))
}

/// A uniform sky: `radiance` from every direction that leaves the scene.
pub fn sky(radiance: DVec3) -> Result<Light, LightError> {
    if !is_finite3(radiance) {
        return Err(LightError::NotFinite);
    }
    if radiance.min_element() < 0.0 {
        return Err(LightError::Radiance);
    }
    Ok(Light::Sky { radiance })
}

/// An environment map: a lat-long `.exr` or `.hdr` (+y up), its radiance × `scale`, turned about
/// +y by `rotation_deg` degrees.
pub fn environment(path: &Path, scale: f64, rotation_deg: f64) -> Result<Light, ImageError> {
    let map = EnvMap::load(path, scale, rotation_deg)?;
    Ok(Light::Env(Environment::new(map)))
}
