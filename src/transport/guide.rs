//! Guided radiance: a spatial-directional record of where light arrives from, learned from radiance
//! paths before a run and mixed with BSDF sampling at the scattering vertices of its radiance paths.
//!
//! The method is the one of "Practical Path Guiding for Efficient Light-Transport Simulation"
//! (Müller, Gross and Novák, EGSR 2017) in its simplest form: a uniform spatial grid over the scene's
//! bounds (instead of the adaptive binary tree) and per grid cell a histogram over directions in
//! cylindrical coordinates (cos θ, φ), which map the sphere to the square preserving area, with
//! equal-area bins (instead of the adaptive quadtree). The histogram estimates ∫ L dω over each bin
//! from the radiance that training paths carried back along their sampled directions (each record
//! L / p, p the density with which its direction was drawn), and is trained in iterations, each
//! drawing with the guide of the one before (the paper's doubling iterations).
//!
//! At a vertex the direction is drawn by one-sample MIS from the defensive mixture
//! `p = α p_guide + (1 − α) p_bsdf` ([`GUIDE_FRACTION`] α): the weight f |cos| / p keeps the
//! expectation whatever the guide, and no direction the BSDF can sample loses density. Next-event
//! estimation weighs its light samples against the same mixture density.
//!
//! Determinism: the guide is a function of the scene, the radiance-path cap and the run's seed
//! alone ([`crate::transport::training::train`]): its training paths start from points of the scene's bounds on streams of
//! their own, in chunks whose records are folded in chunk order, so it is the same on any thread
//! count, for every tile of a grid and for a resumed run, which trains it again.

use crate::scene::Scene;
use crate::scene::material::Bsdf;
use crate::transport::sampling::sin_cos_turns;
use glam::DVec3;
use std::f64::consts::PI;

/// Bins of cos θ (world z) and of φ per direction histogram.
pub const BINS_Z: usize = 8;
pub const BINS_PHI: usize = 16;
pub(crate) const BINS: usize = BINS_Z * BINS_PHI;

/// Grid cells along the longest side of the scene's bounds.
pub const GRID_CELLS: f64 = 8.0;

/// Probability of drawing a direction from the guide where a vertex has one (the paper's 1 − the
/// BSDF sampling fraction, 0.5).
pub const GUIDE_FRACTION: f64 = 0.5;

/// Share of a histogram spread uniformly over its bins, so that a direction the training never
/// sampled keeps some density (a histogram is estimated from few records per bin).
const UNIFORM_SHARE: f64 = 0.1;

/// Records a grid cell needs before it guides.
const MIN_RECORDS: u32 = 64;

/// A trained guide: a grid over the scene's bounds and, per grid cell with enough records, the
/// cumulative distribution over its direction bins.
#[derive(Clone, Debug, PartialEq)]
pub struct Guide {
    min: DVec3,
    inv_cell: f64,
    dims: [usize; 3],
    /// Per grid cell, its histogram's index in `cdf`, or `u32::MAX` (no guide there).
    slot: Vec<u32>,
    /// `BINS` cumulative probabilities per guided cell (the last one exactly 1).
    cdf: Vec<f64>,
}

/// The guide at one vertex: its histogram.
#[derive(Clone, Copy, Debug)]
pub struct GuideAt<'a> {
    cdf: &'a [f64],
}

/// The bin of direction `d` (unit).
#[inline]
pub(crate) fn bin_of(d: DVec3) -> usize {
    let iz = (((d.z + 1.0) * 0.5 * BINS_Z as f64) as usize).min(BINS_Z - 1);
    let turns = d.y.atan2(d.x) * (0.5 / PI) + 0.5;
    let ip = ((turns * BINS_PHI as f64) as usize).min(BINS_PHI - 1);
    iz * BINS_PHI + ip
}

/// Whether the guide may draw directions for `bsdf`: only models without a Dirac lobe, whose
/// density the mixture can carry.
#[inline]
pub fn guidable(bsdf: &Bsdf) -> bool {
    matches!(bsdf, Bsdf::Diffuse { .. } | Bsdf::Glossy { .. })
}

impl Guide {
    /// The guide at `p`, if its grid cell has one.
    #[inline]
    pub fn at(&self, p: DVec3) -> Option<GuideAt<'_>> {
        let s = self.slot[self.cell_of(p)?];
        (s != u32::MAX).then(|| GuideAt {
            cdf: &self.cdf[s as usize * BINS..(s as usize + 1) * BINS],
        })
    }

    /// Grid cells, guiding or not.
    pub(crate) fn cells(&self) -> usize {
        self.slot.len()
    }

    /// Grid cells that guide.
    pub fn guided_cells(&self) -> usize {
        self.cdf.len() / BINS
    }

    /// The grid over `scene`'s bounds, with no cell guiding yet.
    pub(crate) fn grid(scene: &Scene) -> Guide {
        let b = &scene.bounds;
        let size = b.max - b.min;
        let side = size.max_element().max(f64::MIN_POSITIVE);
        let pad = 1e-6 * side;
        let cell = (side + 2.0 * pad) / GRID_CELLS;
        let n = |e: f64| (((e + 2.0 * pad) / cell).ceil() as usize).clamp(1, GRID_CELLS as usize);
        let dims = [n(size.x), n(size.y), n(size.z)];
        Guide {
            min: b.min - DVec3::splat(pad),
            inv_cell: 1.0 / cell,
            dims,
            slot: vec![u32::MAX; dims[0] * dims[1] * dims[2]],
            cdf: Vec::new(),
        }
    }

    /// The grid cell of `p`, if it lies in the grid.
    pub(crate) fn cell_of(&self, p: DVec3) -> Option<usize> {
        let q = (p - self.min) * self.inv_cell;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0) {
            return None;
        }
        let (x, y, z) = (q.x as usize, q.y as usize, q.z as usize);
        (x < self.dims[0] && y < self.dims[1] && z < self.dims[2])
            .then(|| (z * self.dims[1] + y) * self.dims[0] + x)
    }

    /// The guide of the grid `self` from per-cell bin sums and record counts.
    pub(crate) fn with_sums(mut self, sums: &[f64], counts: &[u32]) -> Guide {
        self.cdf.clear();
        for (c, slot) in self.slot.iter_mut().enumerate() {
            *slot = u32::MAX;
            let bins = &sums[c * BINS..(c + 1) * BINS];
            let total: f64 = bins.iter().sum();
            if counts[c] < MIN_RECORDS || !(total > 0.0) || !total.is_finite() {
                continue;
            }
            *slot = (self.cdf.len() / BINS) as u32;
            let mut acc = 0.0;
            for &v in bins {
                acc += (1.0 - UNIFORM_SHARE) * v / total + UNIFORM_SHARE / BINS as f64;
                self.cdf.push(acc);
            }
            // Exactly 1 at the end, so that every number in [0, 1) finds a bin.
            let last = self.cdf.len() - 1;
            self.cdf[last] = 1.0;
        }
        self
    }
}

impl GuideAt<'_> {
    /// Probability of bin `b`.
    #[inline]
    fn prob(&self, b: usize) -> f64 {
        let lo = if b == 0 { 0.0 } else { self.cdf[b - 1] };
        self.cdf[b] - lo
    }

    /// Solid-angle density of direction `d` (unit): the bin's probability over its area, 4π/BINS.
    #[inline]
    pub fn pdf(&self, d: DVec3) -> f64 {
        self.prob(bin_of(d)) * (BINS as f64 / (4.0 * PI))
    }

    /// A direction with density [`pdf`](Self::pdf): a bin by `u.0`, then uniform within the bin
    /// (`u.0` rescaled for cos θ, `u.1` for φ; uniform in (cos θ, φ) is uniform in area).
    #[inline]
    pub fn sample(&self, u: (f64, f64)) -> DVec3 {
        let b = self.cdf.partition_point(|&c| c <= u.0).min(BINS - 1);
        let lo = if b == 0 { 0.0 } else { self.cdf[b - 1] };
        let p = self.cdf[b] - lo;
        let fz = if p > 0.0 {
            ((u.0 - lo) / p).clamp(0.0, 1.0)
        } else {
            0.5
        };
        let (iz, ip) = (b / BINS_PHI, b % BINS_PHI);
        let z = (-1.0 + 2.0 * (iz as f64 + fz) / BINS_Z as f64).clamp(-1.0, 1.0);
        let r = crate::math::safe_sqrt(1.0 - z * z);
        // φ = 2π·turns − π: the half-turn shift negates both sine and cosine.
        let (s, c) = sin_cos_turns((ip as f64 + u.1) / BINS_PHI as f64);
        DVec3::new(-r * c, -r * s, z)
    }

    /// The mixture density of one-sample MIS between the guide and a BSDF of density `p_bsdf`.
    #[inline]
    pub fn mixture(&self, p_guide: f64, p_bsdf: f64) -> f64 {
        GUIDE_FRACTION * p_guide + (1.0 - GUIDE_FRACTION) * p_bsdf
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skewed() -> Vec<f64> {
        let mut acc = 0.0;
        let w: Vec<f64> = (0..BINS).map(|b| 1.0 + ((b * 7) % 13) as f64).collect();
        let t: f64 = w.iter().sum();
        w.iter()
            .map(|v| {
                acc += v / t;
                acc
            })
            .collect()
    }

    #[test]
    fn bins_cover_the_sphere_and_sampling_stays_in_its_bin() {
        let cdf = skewed();
        let g = GuideAt { cdf: &cdf };
        for b in 0..BINS {
            let lo = if b == 0 { 0.0 } else { cdf[b - 1] };
            for (a, v) in [(0.01, 0.3), (0.5, 0.99), (0.97, 0.001)] {
                let d = g.sample((lo + a * g.prob(b), v));
                assert!((d.length() - 1.0).abs() < 1e-12);
                assert_eq!(bin_of(d), b, "u = ({a}, {v})");
            }
        }
    }
}
