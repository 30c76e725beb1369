//! The grid the extraction reads (σ, its standard errors, validity, cell sizes) and which cells
//! have a filter support of valid cells only.

use crate::field::Field;

/// A grid of σ with its standard errors, as the extraction reads it.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Cells along x, y, z (z = 1 for a 2D field).
    pub dims: [usize; 3],
    pub sigma: Vec<f64>,
    pub stderr: Vec<f64>,
    pub valid: Vec<bool>,
    /// Cell size along each axis in scene units (1 for pixels).
    pub cell: [f64; 3],
    /// A gradient-domain field's replicate deviations of σ
    /// ([`crate::gradient_domain::recon::values_and_deviations`]): filter covariances are then
    /// Σᵣ (F_p δᵣ)(F_q δᵣ), with the correlation between cells, instead of Σᵢ F_p(i) F_q(i) seᵢ².
    pub deviations: Option<Vec<Vec<f64>>>,
}

impl Grid {
    /// The grid of a field; `cell` its cell size per axis. A cell whose σ > 0 has no error
    /// estimate (`Moments::has_estimate`: one unit, or its weight in effectively one) takes σ itself
    /// as its standard error, not the 0 its output stores: unknown is not exact, and such cells'
    /// σ can be far off.
    pub fn of_field(field: &Field, cell: [f64; 3]) -> Grid {
        let (vals, deviations) = field.values_and_deviations();
        let ok = |x: f64| x.is_finite();
        Grid {
            dims: [field.width, field.height, field.depth],
            sigma: vals
                .iter()
                .map(|v| if ok(v.sigma) { v.sigma } else { 0.0 })
                .collect(),
            stderr: vals
                .iter()
                .map(|v| match v.estimated {
                    true if ok(v.stderr) => v.stderr.abs(),
                    false if v.valid && ok(v.sigma) => v.sigma.abs(),
                    _ => 0.0,
                })
                .collect(),
            valid: vals
                .iter()
                .map(|v| v.valid && ok(v.sigma) && ok(v.stderr))
                .collect(),
            cell,
            deviations,
        }
    }

    pub(super) fn ndim(&self) -> usize {
        if self.dims[2] > 1 { 3 } else { 2 }
    }

    pub(super) fn len(&self) -> usize {
        self.dims.iter().product()
    }
}

/// Cells whose box of half-width r (per active axis) holds only valid cells.
pub(super) fn defined_cells(grid: &Grid, r: usize) -> Vec<bool> {
    let [nx, ny, nz] = grid.dims;
    let rz = if grid.ndim() == 3 { r } else { 0 };
    // Summed-volume table of invalid cells, (nx+1)(ny+1)(nz+1).
    let (sx, sy) = (nx + 1, (nx + 1) * (ny + 1));
    let mut s = vec![0u32; (nx + 1) * (ny + 1) * (nz + 1)];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let bad = !grid.valid[i + nx * (j + ny * k)] as u32;
                let at = |i: usize, j: usize, k: usize| i + sx * j + sy * k;
                s[at(i + 1, j + 1, k + 1)] =
                    bad + s[at(i, j + 1, k + 1)] + s[at(i + 1, j, k + 1)] + s[at(i + 1, j + 1, k)]
                        - s[at(i, j, k + 1)]
                        - s[at(i, j + 1, k)]
                        - s[at(i + 1, j, k)]
                        + s[at(i, j, k)];
            }
        }
    }
    let at = |i: usize, j: usize, k: usize| s[i + sx * j + sy * k] as i64;
    let mut out = vec![false; grid.len()];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let (i0, i1) = (i.saturating_sub(r), (i + r + 1).min(nx));
                let (j0, j1) = (j.saturating_sub(r), (j + r + 1).min(ny));
                let (k0, k1) = (k.saturating_sub(rz), (k + rz + 1).min(nz));
                let bad = at(i1, j1, k1) - at(i0, j1, k1) - at(i1, j0, k1) - at(i1, j1, k0)
                    + at(i0, j0, k1)
                    + at(i0, j1, k0)
                    + at(i1, j0, k0)
                    - at(i0, j0, k0);
                out[i + nx * (j + ny * k)] = bad == 0;
            }
        }
    }
    out
}
