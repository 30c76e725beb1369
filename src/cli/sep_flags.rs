//! The separatrix extraction's flags, shared by the main run (with `--separatrices`) and the
//! `separatrices` subcommand.

use crate::analysis::separatrix::SepParams;
use clap::Args;

/// The separatrix extraction's settings, shared by runs (`--separatrices`) and `separatrices`.
#[derive(Args, Debug, Clone)]
pub struct SepFlags {
    /// Scale of the derivative-of-Gaussian filters, in cells (≥ 0.7) [default: the smallest at
    /// which a step of height τ is significant at Z in the median cell].
    #[arg(long, value_name = "CELLS", allow_negative_numbers = true)]
    pub sep_scale: Option<f64>,
    /// Significance Z: mark cells whose largest |∇²_ω σ| is Z standard errors from 0 (a test over
    /// all directions at once).
    #[arg(
        long,
        value_name = "Z",
        default_value_t = SepParams::default().z,
        allow_negative_numbers = true
    )]
    pub sep_threshold: f64,
    /// Strength threshold τ in units of σ (the scale-normalised |∇²_ω σ|; for lines, the height of
    /// a step of σ) [default: 0.1 × the median σ of the cells with σ > 0].
    #[arg(long, value_name = "TAU", allow_negative_numbers = true)]
    pub sep_tau: Option<f64>,
}

impl SepFlags {
    /// The settings as the extraction takes them, checked.
    pub fn params(&self) -> anyhow::Result<SepParams> {
        let p = SepParams {
            scale: self.sep_scale,
            z: self.sep_threshold,
            tau: self.sep_tau,
        };
        p.check()?;
        Ok(p)
    }

    /// Whether any of the flags was given (a value other than its default).
    pub fn given(&self) -> bool {
        self.sep_scale.is_some()
            || self.sep_tau.is_some()
            || self.sep_threshold != SepParams::default().z
    }
}
