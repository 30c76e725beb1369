//! Planar slices. A plane is an origin (the corner at u = v = 0), two orthonormal in-plane axes and
//! a size; its grid has `width` × `height` square-ish cells, each sampled at jittered points (the
//! field is box-filtered over the cell).
//!
//! Axis slices: `x=c` spans (u, v) = (z, y), `y=c` spans (x, z), `z=c` spans (x, y), so that y (up
//! in the shipped scenes) is vertical in images whenever the plane contains it.

use super::DomainError;
use crate::scene::flat::Flatland;
use crate::scene::{Aabb, Scene};
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

/// How far, in f32 ulps of the scene's magnitude, an axis slice may lie outside the scene's bounds
/// and still be taken: the bounds hold f32 coordinates, so a slice at the decimal coordinate of a
/// flat model (`z=2.3` for vertices at z = 2.3f32) lies a fraction of an ulp away from them.
const SLICE_TOLERANCE_ULPS: f64 = 8.0;

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
    ) -> Result<Plane, DomainError> {
        if bounds.is_empty() {
            return Err(DomainError::SliceWithoutBounds {
                slice: spec.to_string(),
            });
        }
        let k = spec.axis.index();
        let (lo, hi) = (bounds.min[k], bounds.max[k]);
        // The bounds are f32 coordinates: `z=2.3` names the f32 plane 2.2999999523…, so a slice is
        // outside only beyond their rounding (a few ulps of the scene's magnitude).
        let magnitude = bounds.min.abs().max(bounds.max.abs()).max_element();
        let tol = SLICE_TOLERANCE_ULPS * f32::EPSILON as f64 * magnitude.max(bounds.diagonal());
        if spec.value < lo - tol || spec.value > hi + tol {
            return Err(DomainError::SliceOutsideBounds {
                slice: spec.to_string(),
                lo,
                hi,
            });
        }
        let (u, v) = spec.axis.plane_axes();
        let (u0, v0, u1, v1) = match window {
            Some([a, b, c, d]) => {
                if !(c > a && d > b) {
                    return Err(DomainError::EmptyWindow {
                        window: [a, b, c, d],
                    });
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
    ) -> Result<Plane, DomainError> {
        if res == 0 {
            return Err(DomainError::NoCells);
        }
        if !(size.0 > 0.0 && size.1 > 0.0 && size.0.is_finite() && size.1.is_finite()) {
            return Err(DomainError::EmptyPlane {
                label,
                w: size.0,
                h: size.1,
            });
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

    /// The plane of this slice, for a flatland run.
    pub fn flatland(&self) -> Flatland {
        Flatland::new(self.origin, self.u_axis, self.v_axis)
    }

    /// The distance between the plane's rectangle and the box `b` (0 when they meet). An axis
    /// slice's rectangle is itself an axis-aligned box, and two such boxes are apart by the length
    /// of their per-axis gaps (exact, and exactly 0 when they overlap). Otherwise the closest
    /// points of two disjoint convex polytopes lie on a vertex and a face or on two edges, so the
    /// least of the rectangle's edges against the box and the box's edges against the rectangle is
    /// the distance; each is convex along its edge and found by golden-section search (to about
    /// 1e-12 of the edge's length).
    pub fn distance_to_box(&self, b: &Aabb) -> f64 {
        let (s0, s1) = self.size;
        let corners = [
            self.origin,
            self.origin + self.u_axis * s0,
            self.origin + self.u_axis * s0 + self.v_axis * s1,
            self.origin + self.v_axis * s1,
        ];
        let axis_aligned = |a: DVec3| a.to_array().iter().filter(|x| **x != 0.0).count() == 1;
        if axis_aligned(self.u_axis) && axis_aligned(self.v_axis) {
            let (lo, hi) = corners
                .iter()
                .fold((corners[0], corners[0]), |(lo, hi), c| {
                    (lo.min(*c), hi.max(*c))
                });
            return (b.min - hi).max(lo - b.max).max(DVec3::ZERO).length();
        }
        let to_rect = |p: DVec3| {
            let d = p - self.origin;
            let (a, c) = (
                d.dot(self.u_axis).clamp(0.0, s0),
                d.dot(self.v_axis).clamp(0.0, s1),
            );
            (p - (self.origin + self.u_axis * a + self.v_axis * c)).length()
        };
        let box_corner = |k: usize| {
            DVec3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            )
        };
        let mut best = f64::INFINITY;
        for k in 0..4 {
            let (p, q) = (corners[k], corners[(k + 1) % 4]);
            best = best.min(min_along(p, q, &|x| b.distance(x)));
        }
        for k in 0..8 {
            for bit in [1, 2, 4] {
                if k & bit == 0 {
                    best = best.min(min_along(box_corner(k), box_corner(k | bit), &to_rect));
                }
            }
        }
        best
    }

    /// Point of cell `idx` (row-major from the bottom row) at offset `jitter` ∈ [0,1)² in the cell.
    #[inline]
    pub fn point(&self, idx: usize, jitter: (f64, f64)) -> DVec3 {
        let (i, j) = (idx % self.width, idx / self.width);
        let fu = (index_f64(i) + jitter.0) / index_f64(self.width);
        let fv = (index_f64(j) + jitter.1) / index_f64(self.height);
        self.origin + self.u_axis * (fu * self.size.0) + self.v_axis * (fv * self.size.1)
    }
}

/// `n as f64` (the same value for every `n`), converted from 32 bits where `n` fits them, as every
/// grid index of a domain does: the conversion of a 64-bit unsigned integer takes five SSE2
/// instructions, that of a 32-bit one a single one, and a cell's point converts four per sample.
#[inline(always)]
fn index_f64(n: usize) -> f64 {
    match u32::try_from(n) {
        Ok(m) => f64::from(m),
        Err(_) => n as f64,
    }
}

/// The least of the convex function `f` on the segment from `p` to `q`: golden-section search.
fn min_along(p: DVec3, q: DVec3, f: &dyn Fn(DVec3) -> f64) -> f64 {
    let at = |t: f64| f(p + (q - p) * t);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (at(c), at(d));
    for _ in 0..60 {
        if fc <= fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = at(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = at(d);
        }
    }
    at(0.0).min(at(1.0)).min(fc).min(fd)
}

/// An arbitrary plane: `origin=x,y,z normal=x,y,z [up=x,y,z] [size=w,h]` (keys in any order,
/// separated by spaces or semicolons).
///
/// The image's v axis is `up` projected into the plane (default +y, or +z when the normal is
/// nearly parallel to y), u = v × normal, so (u, v, normal) is right-handed. With `size` the
/// rectangle is centred on `origin`; without it, it covers the scene bounds projected onto the plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneSpec {
    pub origin: DVec3,
    pub normal: DVec3,
    pub up: Option<DVec3>,
    pub size: Option<(f64, f64)>,
}

fn parse_numbers<const N: usize>(key: &str, v: &str, names: &str) -> Result<[f64; N], String> {
    crate::math::parse_floats(v, names).map_err(|e| format!("{key}={v}: {e}"))
}

impl FromStr for PlaneSpec {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (mut origin, mut normal, mut up, mut size) = (None, None, None, None);
        for item in s.split([' ', ';']).filter(|t| !t.is_empty()) {
            let (k, v) = item
                .split_once('=')
                .ok_or_else(|| format!("'{item}': expected KEY=VALUE"))?;
            match k {
                "origin" => origin = Some(DVec3::from(parse_numbers(k, v, "x,y,z")?)),
                "normal" => normal = Some(DVec3::from(parse_numbers(k, v, "x,y,z")?)),
                "up" => up = Some(DVec3::from(parse_numbers(k, v, "x,y,z")?)),
                "size" => {
                    let w: [f64; 2] = parse_numbers(k, v, "w,h")?;
                    if !(w[0] > 0.0 && w[1] > 0.0) {
                        return Err(format!("size={v}: both sides must be > 0"));
                    }
                    size = Some((w[0], w[1]));
                }
                other => {
                    return Err(format!(
                        "unknown key '{other}' (use origin, normal, up, size)"
                    ));
                }
            }
        }
        let origin = origin.ok_or("origin=x,y,z is required")?;
        let normal = normal.ok_or("normal=x,y,z is required")?;
        let normal = normal.try_normalize().ok_or("normal must not be zero")?;
        Ok(PlaneSpec {
            origin,
            normal,
            up,
            size,
        })
    }
}

impl Plane {
    /// An arbitrary plane (see [`PlaneSpec`]) with `res` cells along the longer side.
    pub fn from_spec(bounds: &Aabb, spec: &PlaneSpec, res: usize) -> Result<Plane, DomainError> {
        Plane::from_spec_window(bounds, spec, None, res)
    }

    /// [`from_spec`](Self::from_spec), or the part `window` = (u0, v0, u1, v1) of the plane, in its
    /// own coordinates: u and v along its axes from the spec's `origin` (so that
    /// `-w/2,-h/2,w/2,h/2` is the rectangle of `size=w,h`). A window and a size together are
    /// refused: each sets the rectangle.
    pub fn from_spec_window(
        bounds: &Aabb,
        spec: &PlaneSpec,
        window: Option<[f64; 4]>,
        res: usize,
    ) -> Result<Plane, DomainError> {
        let n = spec.normal;
        let up = spec
            .up
            .unwrap_or(if n.y.abs() > 0.99 { DVec3::Z } else { DVec3::Y });
        let Some(v) = (up - n * up.dot(n)).try_normalize() else {
            return Err(DomainError::UpAlongNormal { up });
        };
        let u = v.cross(n);
        let label = format!(
            "plane origin={},{},{} normal={},{},{}",
            spec.origin.x, spec.origin.y, spec.origin.z, n.x, n.y, n.z
        );
        let (lo, hi) = match (spec.size, window) {
            (Some((w, h)), Some(window)) => {
                return Err(DomainError::WindowAndSize { window, w, h });
            }
            (None, Some([a, b, c, d])) => {
                if !(c > a && d > b) {
                    return Err(DomainError::EmptyWindow {
                        window: [a, b, c, d],
                    });
                }
                ((a, b), (c, d))
            }
            (Some((w, h)), None) => ((-0.5 * w, -0.5 * h), (0.5 * w, 0.5 * h)),
            (None, None) => {
                if bounds.is_empty() {
                    return Err(DomainError::PlaneWithoutBounds);
                }
                let (mut lo, mut hi) = (
                    (f64::INFINITY, f64::INFINITY),
                    (f64::NEG_INFINITY, f64::NEG_INFINITY),
                );
                for corner in bounds.corners() {
                    let c = corner - spec.origin;
                    let (a, b) = (c.dot(u), c.dot(v));
                    lo = (lo.0.min(a), lo.1.min(b));
                    hi = (hi.0.max(a), hi.1.max(b));
                }
                let pad = 0.5 * (hi.0 - lo.0).max(hi.1 - lo.1).max(1e-9);
                if hi.0 - lo.0 <= 0.0 {
                    (lo.0, hi.0) = (lo.0 - pad, hi.0 + pad);
                }
                if hi.1 - lo.1 <= 0.0 {
                    (lo.1, hi.1) = (lo.1 - pad, hi.1 + pad);
                }
                (lo, hi)
            }
        };
        let origin = spec.origin + u * lo.0 + v * lo.1;
        Plane::new(origin, u, v, (hi.0 - lo.0, hi.1 - lo.1), res, label)
    }
}

/// `axis=from:to:count`: `count` evenly spaced axis slices from `from` to `to` (inclusive).
pub fn parse_slice_range(s: &str) -> Result<Vec<SliceSpec>, String> {
    let (axis, range) = s
        .split_once('=')
        .ok_or_else(|| format!("'{s}': expected AXIS=FROM:TO:COUNT"))?;
    let parts: Vec<&str> = range.split(':').collect();
    let [from, to, count] = parts.as_slice() else {
        return Err(format!(
            "'{s}': expected AXIS=FROM:TO:COUNT such as z=0.2:2.0:10"
        ));
    };
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| format!("'{s}': '{t}' is not a number"))
    };
    let (from, to) = (num(from)?, num(to)?);
    let count: usize = count
        .trim()
        .parse()
        .map_err(|_| format!("'{s}': count '{count}' is not a whole number"))?;
    if count == 0 || count > 10_000 {
        return Err(format!("'{s}': count must be between 1 and 10000"));
    }
    (0..count)
        .map(|k| {
            let t = if count == 1 {
                0.0
            } else {
                k as f64 / (count - 1) as f64
            };
            format!("{axis}={}", from + (to - from) * t).parse::<SliceSpec>()
        })
        .collect()
}

/// One plane of a slice run.
#[derive(Clone, Debug)]
pub enum SliceArg {
    /// `AXIS=VALUE` or the name of a slice in the scene file.
    Axis(String),
    /// `origin=… normal=… [up=…] [size=…]`.
    Plane(PlaneSpec),
}

impl SliceArg {
    /// A short name for file names: `z0.5`, `plane2`.
    pub fn file_label(&self, index: usize) -> String {
        match self {
            SliceArg::Axis(a) => a.replace(['=', '/', ' '], ""),
            SliceArg::Plane(_) => format!("plane{index}"),
        }
    }
}

/// Resolves a slice given as `AXIS=VALUE`, or as the name of a slice in the sidecar scene file.
pub fn resolve_slice(arg: &str, scene: &Scene) -> Result<SliceSpec, DomainError> {
    if arg.contains('=') {
        return arg.parse::<SliceSpec>().map_err(DomainError::SliceSyntax);
    }
    match scene.named_slices.iter().find(|(n, _)| n == arg) {
        Some((_, plane)) => {
            plane
                .parse::<SliceSpec>()
                .map_err(|message| DomainError::NamedSliceSyntax {
                    name: arg.to_string(),
                    message,
                })
        }
        None if scene.named_slices.is_empty() => Err(DomainError::NoNamedSlices {
            name: arg.to_string(),
        }),
        None => Err(DomainError::UnknownSlice {
            name: arg.to_string(),
            names: scene
                .named_slices
                .iter()
                .map(|(n, _)| n.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        }),
    }
}

/// The plane of one slice of a run with `res` cells along the longer side, or its part `window`
/// (u0,v0,u1,v1): scene coordinates along the slice's axes for an axis slice, the plane's own
/// coordinates from its origin for a plane ([`Plane::from_spec_window`]).
pub fn resolve_plane(
    arg: &SliceArg,
    scene: &Scene,
    window: Option<[f64; 4]>,
    res: usize,
) -> Result<Plane, DomainError> {
    match arg {
        SliceArg::Axis(a) => {
            Plane::axis_slice(&scene.bounds, resolve_slice(a, scene)?, window, res)
        }
        SliceArg::Plane(spec) => Plane::from_spec_window(&scene.bounds, spec, window, res),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arbitrary_planes_are_right_handed_and_cover_the_bounds() {
        let b = Aabb {
            min: DVec3::new(-1.0, 0.0, -1.0),
            max: DVec3::new(1.0, 2.0, 1.0),
        };
        let spec: PlaneSpec = "origin=0,1,0 normal=1,0,1".parse().unwrap();
        let p = Plane::from_spec(&b, &spec, 64).unwrap();
        assert!((p.u_axis.cross(p.v_axis) - spec.normal).length() < 1e-12);
        assert!((p.v_axis - DVec3::Y).length() < 1e-12, "up projects to +y");
        // Every bounds corner projects inside the rectangle.
        let n = p.normal();
        for k in 0..8 {
            let c = DVec3::new(
                [-1.0, 1.0][k & 1],
                [0.0, 2.0][(k >> 1) & 1],
                [-1.0, 1.0][(k >> 2) & 1],
            );
            let d = c - p.origin;
            let (a, bb) = (d.dot(p.u_axis), d.dot(p.v_axis));
            assert!(a >= -1e-12 && a <= p.size.0 + 1e-12 && bb >= -1e-12 && bb <= p.size.1 + 1e-12);
            let _ = n;
        }
        // The centre of the plane's rectangle lies on the plane through origin.
        let centre = p.point(0, (0.0, 0.0)) + p.u_axis * 0.5 * p.size.0 + p.v_axis * 0.5 * p.size.1;
        assert!((centre - spec.origin).dot(spec.normal).abs() < 1e-12);
        let sized: PlaneSpec = "origin=0,1,0;normal=0,0,1;size=2,1".parse().unwrap();
        let q = Plane::from_spec(&b, &sized, 10).unwrap();
        assert_eq!((q.width, q.height), (10, 5));
        assert!((q.origin - DVec3::new(-1.0, 0.5, 0.0)).length() < 1e-12);
        assert!(
            "origin=0,0,0"
                .parse::<PlaneSpec>()
                .unwrap_err()
                .contains("normal")
        );
        assert!(
            "origin=0,0,0 normal=0,0,0"
                .parse::<PlaneSpec>()
                .unwrap_err()
                .contains("zero")
        );
        assert!(
            "origin=0,0,0 normal=0,1,0 up=0,2,0"
                .parse::<PlaneSpec>()
                .is_ok()
        );
        assert!(
            Plane::from_spec(
                &b,
                &"origin=0,0,0 normal=0,1,0 up=0,2,0".parse().unwrap(),
                8
            )
            .is_err()
        );
    }

    #[test]
    fn slice_ranges() {
        let v = parse_slice_range("z=0.2:2.0:10").unwrap();
        assert_eq!(v.len(), 10);
        assert_eq!(v[0].value, 0.2);
        assert!((v[9].value - 2.0).abs() < 1e-12);
        assert!(parse_slice_range("z=1:2").is_err());
        assert!(
            parse_slice_range("q=1:2:3")
                .unwrap_err()
                .contains("unknown axis")
        );
    }

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
