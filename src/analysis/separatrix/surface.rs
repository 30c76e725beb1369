//! Surfaces (3D): marching tetrahedra around the marked voxels.

use super::Separatrices;
use std::collections::HashMap;

/// A triangle mesh in grid coordinates (voxel centre (i, j, k) at (i, j, k)).
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub points: Vec<[f64; 3]>,
    pub triangles: Vec<[usize; 3]>,
}

/// Cube corners 0..8 (bit 0: +x, bit 1: +y, bit 2: +z); six tetrahedra around the 0–7 diagonal.
const TETS: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 3, 2, 7],
    [0, 2, 6, 7],
    [0, 6, 4, 7],
    [0, 4, 5, 7],
    [0, 5, 1, 7],
];

/// The surface where min(strength/τ, z/Z) = 1 (τ = 0 or Z = 0: that term left out), by marching
/// tetrahedra over the voxel centres (six tetrahedra per cube): it encloses the marked voxels.
pub fn surface(sep: &Separatrices) -> Mesh {
    let [nx, ny, nz] = sep.dims;
    let f = level(sep);
    let mut mesh = Mesh::default();
    if nx < 2 || ny < 2 || nz < 2 {
        return mesh;
    }
    let idx = |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
    let mut edges = EdgePoints {
        dims: sep.dims,
        f: &f,
        at: HashMap::new(),
    };
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let corner = |c: usize| idx(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                for tet in TETS {
                    edges.march(tet.map(corner), &mut mesh);
                }
            }
        }
    }
    mesh
}

/// Per voxel, min(strength/τ, z/Z): ≥ 1 inside the marked region (2 where both thresholds are 0
/// and the strength is not, 0 where the voxel is not defined).
fn level(sep: &Separatrices) -> Vec<f64> {
    (0..sep.strength.len())
        .map(|i| {
            if !sep.defined[i] {
                return 0.0;
            }
            let a = if sep.tau > 0.0 {
                sep.strength[i] / sep.tau
            } else {
                f64::INFINITY
            };
            let b = if sep.z_threshold > 0.0 {
                sep.z[i] / sep.z_threshold
            } else {
                f64::INFINITY
            };
            let v = a.min(b);
            if v.is_finite() {
                v
            } else if sep.strength[i] > 0.0 {
                2.0
            } else {
                0.0
            }
        })
        .collect()
}

/// The mesh points on the grid's edges where the level crosses 1, one per edge, shared by the
/// triangles that meet there.
struct EdgePoints<'a> {
    dims: [usize; 3],
    f: &'a [f64],
    at: HashMap<(usize, usize), usize>,
}

impl EdgePoints<'_> {
    /// The triangles of one tetrahedron with corners `v` (voxel indices).
    fn march(&mut self, v: [usize; 4], mesh: &mut Mesh) {
        let f = self.f;
        let inside: Vec<usize> = (0..4).filter(|&t| f[v[t]] >= 1.0).collect();
        let outside: Vec<usize> = (0..4).filter(|&t| f[v[t]] < 1.0).collect();
        match inside.len() {
            1 | 3 => {
                let (lone, others) = if inside.len() == 1 {
                    (inside[0], outside)
                } else {
                    (outside[0], inside)
                };
                let p: Vec<usize> = others
                    .iter()
                    .map(|&o| self.point_on(v[lone], v[o], mesh))
                    .collect();
                mesh.triangles.push([p[0], p[1], p[2]]);
            }
            2 => {
                let (a, b) = (inside[0], inside[1]);
                let (c, d) = (outside[0], outside[1]);
                let p1 = self.point_on(v[a], v[c], mesh);
                let p2 = self.point_on(v[a], v[d], mesh);
                let p3 = self.point_on(v[b], v[d], mesh);
                let p4 = self.point_on(v[b], v[c], mesh);
                mesh.triangles.push([p1, p2, p3]);
                mesh.triangles.push([p1, p3, p4]);
            }
            _ => {}
        }
    }

    /// The point where the level crosses 1 on the edge between voxels `a` and `b` (linear
    /// interpolation), added to `mesh` the first time the edge is met.
    fn point_on(&mut self, a: usize, b: usize, mesh: &mut Mesh) -> usize {
        let [nx, ny, _] = self.dims;
        let f = self.f;
        let key = (a.min(b), a.max(b));
        *self.at.entry(key).or_insert_with(|| {
            let pos = |c: usize| {
                [
                    (c % nx) as f64,
                    ((c / nx) % ny) as f64,
                    (c / (nx * ny)) as f64,
                ]
            };
            let (fa, fb) = (f[key.0] - 1.0, f[key.1] - 1.0);
            let t = if fa != fb {
                (fa / (fa - fb)).clamp(0.0, 1.0)
            } else {
                0.5
            };
            let (pa, pb) = (pos(key.0), pos(key.1));
            mesh.points.push([
                pa[0] + t * (pb[0] - pa[0]),
                pa[1] + t * (pb[1] - pa[1]),
                pa[2] + t * (pb[2] - pa[2]),
            ]);
            mesh.points.len() - 1
        })
    }
}
