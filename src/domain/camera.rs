//! Camera images: deflection pairs start at the eye along jittered pixel directions (importance
//! weighting, paper section 5.7). Pixel (i, j) counts from the bottom-left, like slice cells.

use super::DomainError;
use crate::scene::Camera;
use glam::DVec3;

/// A pinhole camera with an image size.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraView {
    pub camera: Camera,
    pub width: usize,
    pub height: usize,
    right: DVec3,
    up: DVec3,
    /// tan(fov_y / 2).
    tan_half: f64,
}

impl CameraView {
    pub fn new(camera: Camera, width: usize, height: usize) -> Result<CameraView, DomainError> {
        if width == 0 || height == 0 {
            return Err(DomainError::EmptyImage {
                w: width,
                h: height,
            });
        }
        if !(camera.fov_y > 0.0 && camera.fov_y < std::f64::consts::PI) {
            return Err(DomainError::FieldOfView {
                name: camera.name.clone(),
                fov_deg: camera.fov_y.to_degrees(),
            });
        }
        let Some(right) = camera.forward.cross(camera.up).try_normalize() else {
            return Err(DomainError::UpAlongView {
                name: camera.name.clone(),
            });
        };
        let up = right.cross(camera.forward);
        Ok(CameraView {
            tan_half: (0.5 * camera.fov_y).tan(),
            camera,
            width,
            height,
            right,
            up,
        })
    }

    pub fn cells(&self) -> usize {
        self.width * self.height
    }

    /// Unit direction through pixel `idx` at offset `jitter` ∈ [0,1)² inside it.
    #[inline]
    pub fn direction(&self, idx: usize, jitter: (f64, f64)) -> DVec3 {
        let (i, j) = (idx % self.width, idx / self.width);
        let aspect = self.width as f64 / self.height as f64;
        let x = (2.0 * (i as f64 + jitter.0) / self.width as f64 - 1.0) * self.tan_half * aspect;
        let y = (2.0 * (j as f64 + jitter.1) / self.height as f64 - 1.0) * self.tan_half;
        (self.camera.forward + self.right * x + self.up * y).normalize()
    }

    /// Unit direction through the image position (`fx`, `fy`) ∈ [0, 1]² (from the bottom-left
    /// corner; (0.5, 0.5) is the centre, along the view).
    pub fn direction_at(&self, fx: f64, fy: f64) -> DVec3 {
        let aspect = self.width as f64 / self.height as f64;
        let x = (2.0 * fx - 1.0) * self.tan_half * aspect;
        let y = (2.0 * fy - 1.0) * self.tan_half;
        (self.camera.forward + self.right * x + self.up * y).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_forward_and_corners_span_the_fov() {
        let cam = Camera {
            name: "c".into(),
            eye: DVec3::ZERO,
            forward: -DVec3::Z,
            up: DVec3::Y,
            fov_y: 90f64.to_radians(),
            aspect: None,
        };
        let v = CameraView::new(cam, 3, 3).unwrap();
        assert!((v.direction(4, (0.5, 0.5)) - -DVec3::Z).length() < 1e-12);
        // Top edge of the image at 45° up; right edge at 45° right (square image).
        let top = v.direction(7, (0.5, 1.0));
        assert!((top.y.atan2(-top.z).to_degrees() - 45.0).abs() < 1e-9);
        let right = v.direction(5, (1.0, 0.5));
        assert!((right.x.atan2(-right.z).to_degrees() - 45.0).abs() < 1e-9);
    }
}
