//! Error messages of the analysis subcommands as the command line prints them: the typed errors
//! of separatrix extraction, convergence reports and merging say what is wrong in the library's
//! terms; here they name the flags that set the values (`--sep-scale`, `--max-spp`, `-o`, …).
//! [`crate::cli::errors::describe`] dispatches here.

use crate::analysis::separatrix::{MIN_SCALE, SeparatrixError};
use std::error::Error;

/// One error of a chain in command-line words, if it is one of the analysis rooms'.
pub fn describe(e: &(dyn Error + 'static)) -> Option<String> {
    if let Some(s) = e.downcast_ref::<SeparatrixError>() {
        return Some(separatrix(s));
    }
    None
}

/// A separatrix setting or file, named by its flag.
pub fn separatrix(e: &SeparatrixError) -> String {
    use SeparatrixError as S;
    match e {
        S::Scale { scale } => {
            format!("--sep-scale {scale}: the scale must be a number of cells ≥ {MIN_SCALE}")
        }
        S::Significance { z } => format!("--sep-threshold {z}: Z must be a finite number ≥ 0"),
        S::Strength { tau } => format!("--sep-tau {tau}: τ must be a finite number ≥ 0"),
        S::OutputFormat { output, input, ext } => format!(
            "-o {}: the output must be a .{ext} like the input {}",
            output.display(),
            input.display()
        ),
        // No flag sets these: the library's words are the message.
        S::EmptyGrid | S::NotAField { .. } => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::separatrix::SepParams;

    #[test]
    fn separatrix_settings_are_named_by_their_flags() {
        let bad = |p: SepParams| separatrix(&p.check().unwrap_err());
        let p = SepParams::default();
        assert_eq!(
            bad(SepParams {
                scale: Some(0.5),
                ..p
            }),
            "--sep-scale 0.5: the scale must be a number of cells ≥ 0.7"
        );
        assert_eq!(
            bad(SepParams { z: -1.0, ..p }),
            "--sep-threshold -1: Z must be a finite number ≥ 0"
        );
        assert_eq!(
            bad(SepParams {
                tau: Some(f64::NAN),
                ..p
            }),
            "--sep-tau NaN: τ must be a finite number ≥ 0"
        );
    }
}
