//! Small numeric helpers shared by every module: guarded square roots, orthonormal frames, colour
//! luminance, comma-separated numbers. Geometry handed to Embree is f32; everything here is f64.

use glam::DVec3;

/// RGB triple in linear scene units. f64 so that weights and throughputs never lose precision.
pub type Rgb = DVec3;

/// `sqrt(max(x, 0))`: rounding can push a mathematically non-negative value slightly below zero.
#[inline]
pub fn safe_sqrt(x: f64) -> f64 {
    debug_assert!(!x.is_nan(), "safe_sqrt(NaN)");
    x.max(0.0).sqrt()
}

/// Rec. 709 luminance of a linear RGB value.
#[inline]
pub fn luminance(c: Rgb) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Exactly `N` comma-separated finite numbers, e.g. `1,2.5,-3`; `names` says what they are
/// (`x,y,z`) in the error, which callers prefix with the flag or key.
pub fn parse_floats<const N: usize>(s: &str, names: &str) -> Result<[f64; N], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{}' is not a number", t.trim()))
        })
        .collect::<Result<_, _>>()?;
    let a: [f64; N] = v.as_slice().try_into().map_err(|_| {
        format!(
            "expected {N} comma-separated numbers {names}, got {}",
            v.len()
        )
    })?;
    if !a.iter().all(|x| x.is_finite()) {
        return Err("values must be finite".into());
    }
    Ok(a)
}

/// True when every component is finite.
#[inline]
pub fn is_finite3(v: DVec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

/// Orthonormal frame whose `z` axis is a given unit vector (Duff et al. 2017, branchless).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub x: DVec3,
    pub y: DVec3,
    pub z: DVec3,
}

impl Frame {
    pub fn from_z(z: DVec3) -> Self {
        let sign = 1.0f64.copysign(z.z);
        let a = -1.0 / (sign + z.z);
        let b = z.x * z.y * a;
        let x = DVec3::new(1.0 + sign * z.x * z.x * a, sign * b, -sign * z.x);
        let y = DVec3::new(b, sign + z.y * z.y * a, -z.y);
        Frame { x, y, z }
    }
    /// Local (x, y, z) coordinates to world.
    #[inline]
    pub fn to_world(&self, v: DVec3) -> DVec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
    /// World to local coordinates.
    #[inline]
    pub fn to_local(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }
}

/// Mirror reflection of `wo` (pointing away from the surface) about the unit normal `n`.
#[inline]
pub fn reflect(wo: DVec3, n: DVec3) -> DVec3 {
    2.0 * wo.dot(n) * n - wo
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_for_awkward_axes() {
        for z in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::X,
            DVec3::new(1e-9, -1e-9, -1.0).normalize(),
            DVec3::new(0.3, -0.4, 0.5).normalize(),
        ] {
            let f = Frame::from_z(z);
            for (a, b) in [(f.x, f.y), (f.y, f.z), (f.x, f.z)] {
                assert!(a.dot(b).abs() < 1e-12);
            }
            for a in [f.x, f.y, f.z] {
                assert!((a.length() - 1.0).abs() < 1e-12);
            }
            assert!((f.x.cross(f.y) - f.z).length() < 1e-12, "right-handed");
            let v = DVec3::new(0.1, 0.2, 0.3);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-12);
        }
    }
}
