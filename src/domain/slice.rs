//! Planar slices. A plane is an origin (the corner at u = v = 0), two orthonormal in-plane axes and
//! a size; its grid has `width` × `height` square-ish cells, each sampled at jittered points (the
//! field is box-filtered over the cell).
//!
//! Axis slices: `x=c` spans (u, v) = (z, y), `y=c` spans (x, z), `z=c` spans (x, y), so that y (up
//! in the shipped scenes) is vertical in images whenever the plane contains it.

use crate::scene::Aabb;
use anyhow::bail;
use glam::DVec3;
use std::fmt;
use std::str::FromStr;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
    /// (u, v) axes for a slice perpendicular to this axis.
    fn plane_axes(self) -> (DVec3, DVec3) {
        match self {
            Axis::X => (DVec3::Z, DVec3::Y),
            Axis::Y => (DVec3::X, DVec3::Z),
            Axis::Z => (DVec3::X, DVec3::Y),
        }
    }
}

/// `axis=value`, e.g. `z=1.2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SliceSpec {
    pub axis: Axis,
    pub value: f64,
}

impl FromStr for SliceSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (a, v) = s
            .split_once('=')
            .ok_or_else(|| format!("'{s}': expected AXIS=VALUE such as z=1.2"))?;
        let axis = match a.trim() {
            "x" | "X" => Axis::X,
            "y" | "Y" => Axis::Y,
            "z" | "Z" => Axis::Z,
            other => return Err(format!("'{s}': unknown axis '{other}' (use x, y or z)")),
        };
        let value: f64 = v
            .trim()
            .parse()
            .map_err(|_| format!("'{s}': '{v}' is not a number"))?;
        if !value.is_finite() {
            return Err(format!("'{s}': the value must be finite"));
        }
        Ok(SliceSpec { axis, value })
    }
}

impl fmt::Display for SliceSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = ["x", "y", "z"][self.axis.index()];
        write!(f, "{a}={}", self.value)
    }
}

/// A rectangle in 3D with a cell grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    pub origin: DVec3,
    pub u_axis: DVec3,
    pub v_axis: DVec3,
    pub size: (f64, f64),
    pub width: usize,
    pub height: usize,
    pub label: String,
}

impl Plane {
    /// An axis slice over the scene bounds (or `window` = (u0, v0, u1, v1) in plane coordinates),
    /// with `res` cells along the longer side.
    pub fn axis_slice(
        bounds: &Aabb,
        spec: SliceSpec,
        window: Option<[f64; 4]>,
        res: usize,
    ) -> anyhow::Result<Plane> {
        if bounds.is_empty() {
            bail!("--slice {spec}: the scene has no geometry to take bounds from; give --window");
        }
        let k = spec.axis.index();
        let (lo, hi) = (bounds.min[k], bounds.max[k]);
        if spec.value < lo || spec.value > hi {
            bail!(
                "--slice {spec}: outside the scene bounds, which span {lo} to {hi} along that axis"
            );
        }
        let (u, v) = spec.axis.plane_axes();
        let (u0, v0, u1, v1) = match window {
            Some([a, b, c, d]) => {
                if !(c > a && d > b) {
                    bail!(
                        "--window {a},{b},{c},{d}: needs u0 < u1 and v0 < v1 (an empty rectangle)"
                    );
                }
                (a, b, c, d)
            }
            None => {
                let (mut u0, mut v0) = (bounds.min.dot(u), bounds.min.dot(v));
                let (mut u1, mut v1) = (bounds.max.dot(u), bounds.max.dot(v));
                // A flat scene (e.g. a single plane) seen edge-on: give the flat direction half the
                // other's extent on each side, so the slice shows the space around it.
                let pad = 0.5 * (u1 - u0).max(v1 - v0).max(1e-9);
                if u1 - u0 <= 0.0 {
                    (u0, u1) = (u0 - pad, u1 + pad);
                }
                if v1 - v0 <= 0.0 {
                    (v0, v1) = (v0 - pad, v1 + pad);
                }
                (u0, v0, u1, v1)
            }
        };
        let mut n = DVec3::ZERO;
        n[k] = spec.value;
        let origin = n + u * u0 + v * v0;
        Plane::new(origin, u, v, (u1 - u0, v1 - v0), res, spec.to_string())
    }

    /// A plane with `res` cells on its longer side and square-ish cells.
    pub fn new(
        origin: DVec3,
        u_axis: DVec3,
        v_axis: DVec3,
        size: (f64, f64),
        res: usize,
        label: String,
    ) -> anyhow::Result<Plane> {
        if res == 0 {
            bail!("--res must be at least 1");
        }
        if !(size.0 > 0.0 && size.1 > 0.0 && size.0.is_finite() && size.1.is_finite()) {
            bail!("plane {label}: size {} x {} is empty", size.0, size.1);
        }
        let (width, height) = if size.0 >= size.1 {
            (
                res,
                ((res as f64 * size.1 / size.0).round() as usize).max(1),
            )
        } else {
            (
                ((res as f64 * size.0 / size.1).round() as usize).max(1),
                res,
            )
        };
        Ok(Plane {
            origin,
            u_axis,
            v_axis,
            size,
            width,
            height,
            label,
        })
    }

    pub fn cells(&self) -> usize {
        self.width * self.height
    }

    pub fn normal(&self) -> DVec3 {
        self.u_axis.cross(self.v_axis)
    }

    /// Point of cell `idx` (row-major from the bottom row) at offset `jitter` ∈ [0,1)² in the cell.
    #[inline]
    pub fn point(&self, idx: usize, jitter: (f64, f64)) -> DVec3 {
        let (i, j) = (idx % self.width, idx / self.width);
        let fu = (i as f64 + jitter.0) / self.width as f64;
        let fv = (j as f64 + jitter.1) / self.height as f64;
        self.origin + self.u_axis * (fu * self.size.0) + self.v_axis * (fv * self.size.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_slices() {
        assert_eq!(
            "z=1.2".parse::<SliceSpec>().unwrap(),
            SliceSpec {
                axis: Axis::Z,
                value: 1.2
            }
        );
        assert!(
            "w=1"
                .parse::<SliceSpec>()
                .unwrap_err()
                .contains("unknown axis")
        );
        assert!("z".parse::<SliceSpec>().is_err());
        assert!("z=abc".parse::<SliceSpec>().is_err());
    }

    #[test]
    fn slice_covers_bounds_with_aspect() {
        let b = Aabb {
            min: DVec3::new(-1.0, 0.0, -2.0),
            max: DVec3::new(1.0, 2.0, 2.0),
        };
        let p = Plane::axis_slice(&b, "x=0".parse().unwrap(), None, 100).unwrap();
        assert_eq!((p.width, p.height), (100, 50)); // u = z spans 4, v = y spans 2
        assert_eq!(p.point(0, (0.0, 0.0)), DVec3::new(0.0, 0.0, -2.0));
        let last = p.point(p.cells() - 1, (1.0, 1.0));
        assert!((last - DVec3::new(0.0, 2.0, 2.0)).length() < 1e-12);
        assert!(
            Plane::axis_slice(&b, "y=3".parse().unwrap(), None, 10)
                .unwrap_err()
                .to_string()
                .contains("outside")
        );
    }
}
