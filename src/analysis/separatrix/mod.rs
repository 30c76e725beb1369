//! Separatrices extracted from a finished field: eq. 13 of the paper (Zirr, Ament, Dachsbacher,
//! CGF 34(3), 2015), S_τ = {x | ∃ω: |∇²_ω σ(x)| ≥ τ}, with a threshold that is a significance, so
//! that Monte Carlo noise is not called a separatrix.
//!
//! # What is computed
//!
//! σ is smoothed by a Gaussian of standard deviation `scale` cells, and differentiated by the
//! derivatives of that Gaussian (separable, sampled, each normalised so that it is exact on
//! polynomials of its order: a linear ramp has gradient its slope, a parabola x²/2 has second
//! derivative 1). Per cell:
//!
//! - the Hessian H of σ; the largest |ωᵀHω| over unit ω is the eigenvalue of largest magnitude,
//!   its direction the eigenvector: `separatrix.strength` is that value scale-normalised (× (scale
//!   in scene units)²), so it is in units of σ and does not change with the resolution;
//! - in 2D, the third derivative σ_nnn along the gradient direction n: a step Δ of σ blurred at
//!   scale s has σ_nnn = −Δ/(s³√(2π)) at its centre, and a ramp or any smooth field almost none,
//!   so −σ_nnn × s³ × √(2π) is the *jump strength* (the step's height, in units of σ). The
//!   gradient's magnitude itself would not do: a steep smooth ramp has it everywhere.
//!
//! # Standard errors, and the maximum over directions
//!
//! Every filter is linear in the cells, and the cells use independent random streams (keyed by
//! seed, pass and cell: `crate::rng`), so the covariance of two filter outputs K_p and K_q at a
//! cell is Σ_i K_p(i) K_q(i) se_i², with se_i the cell's standard error of σ. Each product of two
//! separable kernels is separable, so these sums are separable filters of se² as well.
//!
//! The direction ω is chosen *after* looking at the data (the largest |∇²_ω σ|), so the z-score of
//! ωᵀHω in that direction would be optimistic: under pure noise its maximum over ω is not a
//! standard normal. Instead `separatrix.z` is the simultaneous (Scheffé) test: with h the Hessian's
//! k independent components (k = 3 in 2D, 6 in 3D) and Σ their covariance, d² = hᵀΣ⁻¹h is the
//! largest squared z of any linear combination of h, so it bounds the squared z of ωᵀHω for every
//! ω at once; under noise alone (H = 0) it is χ²_k. `separatrix.z` is the normal deviate with the
//! same two-sided tail probability as d², so "z ≥ 3" means the same false-alarm rate (0.27 %) as
//! for one normal variable, whatever the direction. The jump's z is the same test for the four
//! third derivatives (k = 4), since n too is chosen from the data.
//!
//! A cell is marked (`separatrix` = 1) where strength ≥ τ and z ≥ Z. τ (the strength threshold) is
//! in units of σ; its default is a tenth of the median σ of the valid cells with σ > 0, so that
//! smooth but significant curvature (which a field with many samples shows everywhere) is not
//! called a separatrix. The default scale is the smallest of 1, 1.25, 1.5, 2, 2.5, 3, 4, 5, 6
//! cells at which a step of height τ would be significant at Z in the median cell (the noise of a
//! derivative falls with the scale).
//!
//! How the marked cells become lines (2D) is told in [`lines`]; a volume's marked region is
//! enclosed by a surface ([`surface()`]).
//!
//! Cells whose filter support (± ⌈3·scale⌉ cells) holds an invalid cell are left out (strength and
//! z 0, never marked). At the grid's borders σ is continued by point reflection (σ(−k) = 2σ(0) −
//! σ(k)), which keeps linear ramps linear, so borders make no false curvature.

mod extract;
mod files;
mod filters;
mod grid;
mod lines;
mod preview;
mod scale;
mod significance;
mod surface;
mod vtp;

pub use extract::extract;
pub use files::{Placement, Rerun, of_field, rerun, side_paths, write_side_files};
pub use grid::Grid;
pub use lines::{LINE_MIN_SCALES, MIN_LINE_CELLS};
pub use preview::{overlay_colors, write_overlay_png, write_svg};
pub use scale::MIN_SCALE;
pub use significance::{Z_CAP, normal_two_sided_tail, scheffe_z};
pub use surface::{Mesh, surface};
pub use vtp::{SceneLine, write_vtp};

use std::path::PathBuf;

/// The user's settings (`None`: the default described in the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SepParams {
    /// Gaussian scale in cells.
    pub scale: Option<f64>,
    /// Significance threshold Z (standard errors).
    pub z: f64,
    /// Strength threshold τ in units of σ.
    pub tau: Option<f64>,
}

impl Default for SepParams {
    fn default() -> Self {
        SepParams {
            scale: None,
            z: 3.0,
            tau: None,
        }
    }
}

impl SepParams {
    /// Refuses values that cannot be used.
    pub fn check(&self) -> Result<(), SeparatrixError> {
        if let Some(scale) = self.scale
            && !(scale.is_finite() && scale >= MIN_SCALE)
        {
            return Err(SeparatrixError::Scale { scale });
        }
        if !(self.z.is_finite() && self.z >= 0.0) {
            return Err(SeparatrixError::Significance { z: self.z });
        }
        if let Some(tau) = self.tau
            && !(tau.is_finite() && tau >= 0.0)
        {
            return Err(SeparatrixError::Strength { tau });
        }
        Ok(())
    }
}

/// What the extraction refuses, in its own terms (the command line names its flags:
/// `crate::cli::analysis_errors`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SeparatrixError {
    #[error("filter scale {scale}: must be a number of cells ≥ {MIN_SCALE}")]
    Scale { scale: f64 },
    #[error("significance threshold Z = {z}: must be a finite number ≥ 0")]
    Significance { z: f64 },
    #[error("strength threshold τ = {tau}: must be a finite number ≥ 0")]
    Strength { tau: f64 },
    #[error("separatrices: an empty or inconsistent grid")]
    EmptyGrid,
    #[error("{}: not a field: separatrices reads .exr fields and .vti volumes", .path.display())]
    NotAField { path: PathBuf },
    #[error("output {}: must be a .{ext} like the input {}", .output.display(), .input.display())]
    OutputFormat {
        output: PathBuf,
        input: PathBuf,
        ext: String,
    },
}

/// Which detector found a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineKind {
    /// σ steps across the line (zero-order discontinuity).
    Jump,
    /// Height ridge of |∇²_ω σ| (first-order discontinuity, eq. 13).
    Ridge,
}

impl LineKind {
    pub fn name(self) -> &'static str {
        match self {
            LineKind::Jump => "jump",
            LineKind::Ridge => "ridge",
        }
    }
}

/// A polyline in cell coordinates: x = i + 0.5 is the centre of column i, y = j + 0.5 of row j
/// (row 0 at the bottom), each point with the strength and z of its cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Polyline {
    pub kind: LineKind,
    pub points: Vec<[f64; 2]>,
    pub strength: Vec<f64>,
    pub z: Vec<f64>,
}

/// What the extraction found.
#[derive(Clone, Debug)]
pub struct Separatrices {
    pub dims: [usize; 3],
    /// The scale used, in cells; τ and Z used.
    pub scale: f64,
    pub tau: f64,
    pub z_threshold: f64,
    /// Scale-normalised max |∇²_ω σ| (units of σ); 0 where undefined.
    pub strength: Vec<f64>,
    /// Scheffé z of the Hessian (see the module docs); 0 where undefined.
    pub z: Vec<f64>,
    /// Unit direction ω of the largest |∇²_ω σ|, in the grid's axes (x, y, z).
    pub dir: Vec<[f64; 3]>,
    /// Step height across a jump (−σ_nnn · scale³ · √(2π), 2D) and its Scheffé z; 0 in 3D.
    pub jump: Vec<f64>,
    pub jump_z: Vec<f64>,
    /// Cells whose filter support holds only valid cells.
    pub defined: Vec<bool>,
    /// strength ≥ τ and z ≥ Z.
    pub marked: Vec<bool>,
    /// Thinned line cells: 0 none, 1 jump, 2 ridge (2D only; all 0 for volumes).
    pub line: Vec<u8>,
    /// Linked polylines (2D only).
    pub lines: Vec<Polyline>,
}

impl Separatrices {
    pub fn marked_count(&self) -> usize {
        self.marked.iter().filter(|&&m| m).count()
    }

    /// The per-cell arrays, named as the outputs name them (`dir` in the grid's axes: for a slice
    /// x = u, y = v).
    pub fn arrays(&self) -> Vec<(&'static str, Vec<f64>)> {
        let b = |v: &[bool]| v.iter().map(|&m| if m { 1.0 } else { 0.0 }).collect();
        let mut out = vec![
            ("separatrix", b(&self.marked)),
            ("separatrix.strength", self.strength.clone()),
            ("separatrix.z", self.z.clone()),
            ("separatrix.dir.x", self.dir.iter().map(|d| d[0]).collect()),
            ("separatrix.dir.y", self.dir.iter().map(|d| d[1]).collect()),
        ];
        if self.dims[2] > 1 {
            out.push(("separatrix.dir.z", self.dir.iter().map(|d| d[2]).collect()));
        }
        if self.dims[2] == 1 {
            out.push(("separatrix.jump", self.jump.clone()));
            out.push(("separatrix.jump.z", self.jump_z.clone()));
            out.push((
                "separatrix.line",
                self.line.iter().map(|&l| l as f64).collect(),
            ));
        }
        out
    }

    /// One line for a run summary.
    pub fn summary(&self) -> String {
        let n = self.marked.len().max(1);
        let jumps = self.lines.iter().filter(|l| l.kind == LineKind::Jump);
        let ridges = self.lines.iter().filter(|l| l.kind == LineKind::Ridge);
        format!(
            "separatrices (eq. 13, scale {:.3} cells, τ {:.4e}, Z {}): {} of {} cells marked \
             ({:.2} %){}",
            self.scale,
            self.tau,
            self.z_threshold,
            self.marked_count(),
            self.marked.len(),
            100.0 * self.marked_count() as f64 / n as f64,
            if self.dims[2] == 1 {
                format!(
                    ", {} jump lines and {} ridge lines",
                    jumps.count(),
                    ridges.count()
                )
            } else {
                String::new()
            }
        )
    }
}
