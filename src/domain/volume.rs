//! Voxel grids. A volume is an axis-aligned box cut into `nx` × `ny` × `nz` voxels; each voxel is
//! sampled at jittered points inside it (the field is box-filtered over the voxel, as a plane's
//! cell is, see [`crate::domain::Plane::point`]). Voxel `(i, j, k)` is cell `i + nx·(j + ny·k)`,
//! which is also VTK's point order, so a field's cells are written to a `.vti` as they are.
//!
//! In the `.vti`, a voxel's value is stored at the voxel's **centre**: the image's origin is
//! `box.min + spacing / 2` and it has `nx × ny × nz` points, so ParaView shows exactly the sampled
//! values (point data, interpolated between centres) and nothing is resampled.

use super::DomainError;
use crate::scene::Aabb;
use glam::DVec3;
use std::fmt;
use std::str::FromStr;

/// A volume's resolution: `N` voxels along the longest side of the box (the others by aspect),
/// or `NX,NY,NZ`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeRes {
    Longest(usize),
    Dims([usize; 3]),
}

impl FromStr for VolumeRes {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let v: Vec<usize> = s
            .split(',')
            .map(|t| {
                t.trim()
                    .parse::<usize>()
                    .map_err(|_| format!("'{s}': '{}' is not a whole number", t.trim()))
            })
            .collect::<Result<_, _>>()?;
        if v.contains(&0) {
            return Err(format!("'{s}': every axis needs at least 1 voxel"));
        }
        match v.as_slice() {
            [n] => Ok(VolumeRes::Longest(*n)),
            [x, y, z] => Ok(VolumeRes::Dims([*x, *y, *z])),
            _ => Err(format!(
                "'{s}': expected N (voxels along the longest side) or NX,NY,NZ"
            )),
        }
    }
}

impl fmt::Display for VolumeRes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VolumeRes::Longest(n) => write!(f, "{n}"),
            VolumeRes::Dims([x, y, z]) => write!(f, "{x},{y},{z}"),
        }
    }
}

/// Parses a box `xmin,ymin,zmin,xmax,ymax,zmax` (finite numbers; checked for emptiness later).
pub fn parse_box(s: &str) -> Result<[f64; 6], String> {
    crate::math::parse_floats(s, "xmin,ymin,zmin,xmax,ymax,zmax")
}

/// A box with a voxel grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    /// The box's minimum corner (the corner of voxel (0, 0, 0), not its centre).
    pub origin: DVec3,
    /// Voxel size along x, y, z.
    pub spacing: DVec3,
    pub nx: usize,
    pub ny: usize,
    pub nz: usize,
}

impl Volume {
    /// The box to cut: `user_box` as given (each side must be > 0), or the scene bounds with flat
    /// directions padded by half the largest extent on each side (as an edge-on slice of a flat
    /// scene is, see [`crate::domain::Plane::axis_slice`]), so the volume shows the space around it.
    pub fn resolve_box(bounds: &Aabb, user_box: Option<[f64; 6]>) -> Result<Aabb, DomainError> {
        match user_box {
            Some(b) => {
                let (min, max) = (DVec3::new(b[0], b[1], b[2]), DVec3::new(b[3], b[4], b[5]));
                if !(max.x > min.x && max.y > min.y && max.z > min.z) {
                    return Err(DomainError::EmptyBox { bbox: b });
                }
                Ok(Aabb { min, max })
            }
            None => {
                if bounds.is_empty() {
                    return Err(DomainError::VolumeWithoutBounds);
                }
                let (mut min, mut max) = (bounds.min, bounds.max);
                let pad = 0.5 * (max - min).max_element().max(1e-9);
                for a in 0..3 {
                    if max[a] - min[a] <= 0.0 {
                        min[a] -= pad;
                        max[a] += pad;
                    }
                }
                Ok(Aabb { min, max })
            }
        }
    }

    /// Voxel counts for `res` over a box of size `size` (each ≥ 1; `Longest(n)` puts n along the
    /// longest side and rounds the others by aspect). Pure arithmetic, no allocation: the memory
    /// check runs on it before anything is allocated.
    pub fn dims_for(res: VolumeRes, size: DVec3) -> [usize; 3] {
        match res {
            VolumeRes::Dims(d) => d,
            VolumeRes::Longest(n) => {
                let l = size.max_element();
                [size.x, size.y, size.z].map(|s| {
                    if s >= l {
                        n
                    } else {
                        ((n as f64 * s / l).round() as usize).max(1)
                    }
                })
            }
        }
    }

    /// A grid of `dims` voxels over `bbox` (non-empty).
    pub fn new(bbox: &Aabb, dims: [usize; 3]) -> Result<Volume, DomainError> {
        let size = bbox.max - bbox.min;
        if !(size.min_element() > 0.0 && size.is_finite()) {
            return Err(DomainError::EmptyVolumeBox {
                min: bbox.min,
                max: bbox.max,
            });
        }
        if dims.contains(&0) {
            return Err(DomainError::NoVoxels);
        }
        let [nx, ny, nz] = dims;
        Ok(Volume {
            origin: bbox.min,
            spacing: size / DVec3::new(nx as f64, ny as f64, nz as f64),
            nx,
            ny,
            nz,
        })
    }

    pub fn dims(&self) -> [usize; 3] {
        [self.nx, self.ny, self.nz]
    }

    pub fn voxels(&self) -> usize {
        self.nx * self.ny * self.nz
    }

    /// The box's maximum corner.
    pub fn max_corner(&self) -> DVec3 {
        self.origin + self.spacing * DVec3::new(self.nx as f64, self.ny as f64, self.nz as f64)
    }

    /// Where the `.vti` puts its first point: the centre of voxel (0, 0, 0).
    pub fn vtk_origin(&self) -> DVec3 {
        self.origin + 0.5 * self.spacing
    }

    /// `(i, j, k)` of cell `idx`.
    #[inline]
    pub fn ijk(&self, idx: usize) -> (usize, usize, usize) {
        (
            idx % self.nx,
            (idx / self.nx) % self.ny,
            idx / (self.nx * self.ny),
        )
    }

    /// Point of cell `idx` at offset `jitter` ∈ [0,1)³ inside the voxel.
    #[inline]
    pub fn point(&self, idx: usize, jitter: (f64, f64, f64)) -> DVec3 {
        let (i, j, k) = self.ijk(idx);
        self.origin
            + self.spacing
                * DVec3::new(
                    i as f64 + jitter.0,
                    j as f64 + jitter.1,
                    k as f64 + jitter.2,
                )
    }

    /// Centre of voxel `idx`.
    pub fn centre(&self, idx: usize) -> DVec3 {
        self.point(idx, (0.5, 0.5, 0.5))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_specs() {
        assert_eq!("64".parse::<VolumeRes>(), Ok(VolumeRes::Longest(64)));
        assert_eq!(
            "4, 5,6".parse::<VolumeRes>(),
            Ok(VolumeRes::Dims([4, 5, 6]))
        );
        assert!("0".parse::<VolumeRes>().unwrap_err().contains("at least 1"));
        assert!("1,2".parse::<VolumeRes>().unwrap_err().contains("NX,NY,NZ"));
        assert!("x".parse::<VolumeRes>().is_err());
        assert!(parse_box("0,0,0,1,1").unwrap_err().contains("6 comma"));
        assert_eq!(parse_box("0,0,0,1,1,2"), Ok([0., 0., 0., 1., 1., 2.]));
    }

    #[test]
    fn grid_by_aspect_and_cell_order() {
        let b = Aabb {
            min: DVec3::new(-1.0, 0.0, 0.0),
            max: DVec3::new(1.0, 1.0, 0.5),
        };
        let bx = Volume::resolve_box(&b, None).unwrap();
        let d = Volume::dims_for(VolumeRes::Longest(8), bx.max - bx.min);
        assert_eq!(d, [8, 4, 2]);
        let v = Volume::new(&bx, d).unwrap();
        assert_eq!(v.spacing, DVec3::splat(0.25));
        assert_eq!(v.vtk_origin(), DVec3::new(-0.875, 0.125, 0.125));
        // idx = i + nx (j + ny k)
        let idx = 3 + 8 * (2 + 4);
        assert_eq!(v.ijk(idx), (3, 2, 1));
        assert_eq!(v.centre(idx), DVec3::new(-0.125, 0.625, 0.375));
        assert_eq!(v.point(0, (0.0, 0.0, 0.0)), b.min);
        let last = v.point(v.voxels() - 1, (1.0, 1.0, 1.0));
        assert!((last - b.max).length() < 1e-12);
        assert!((v.max_corner() - b.max).length() < 1e-12);
        // Thin sides keep at least one voxel.
        assert_eq!(
            Volume::dims_for(VolumeRes::Longest(4), DVec3::new(1.0, 1e-3, 1.0)),
            [4, 1, 4]
        );
    }

    #[test]
    fn flat_scenes_are_padded_user_boxes_are_not() {
        let flat = Aabb {
            min: DVec3::new(-1.0, 0.0, -1.0),
            max: DVec3::new(1.0, 0.0, 1.0),
        };
        let bx = Volume::resolve_box(&flat, None).unwrap();
        assert_eq!(bx.min.y, -1.0);
        assert_eq!(bx.max.y, 1.0);
        let e = Volume::resolve_box(&flat, Some([0.0, 0.0, 0.0, 1.0, 0.0, 1.0])).unwrap_err();
        assert_eq!(
            e,
            DomainError::EmptyBox {
                bbox: [0.0, 0.0, 0.0, 1.0, 0.0, 1.0]
            }
        );
        assert!(e.to_string().contains("box 0,0,0,1,0,1"), "{e}");
    }
}
