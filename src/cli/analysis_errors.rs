//! Error messages of the analysis subcommands as the command line prints them: the typed errors
//! of separatrix extraction, convergence reports and merging say what is wrong in the library's
//! terms; here they name the flags that set the values (`--sep-scale`, `--max-spp`, `-o`, …).
//! [`crate::cli::errors::describe`] dispatches here.

use crate::analysis::converge::ConvergeError;
use crate::analysis::separatrix::{MIN_SCALE, SeparatrixError};
use crate::merge::MergeError;
use std::error::Error;

/// One error of a chain in command-line words, if it is one of the analysis rooms'.
pub fn describe(e: &(dyn Error + 'static)) -> Option<String> {
    if let Some(s) = e.downcast_ref::<SeparatrixError>() {
        return Some(separatrix(s));
    }
    if let Some(m) = e.downcast_ref::<MergeError>() {
        return Some(merge(m));
    }
    if let Some(c) = e.downcast_ref::<ConvergeError>() {
        return Some(converge(c));
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

/// A convergence report's setting, named by its flag. The cause of a directory that cannot be
/// created or a reference that cannot be read follows as the next link of the chain.
pub fn converge(e: &ConvergeError) -> String {
    use ConvergeError as C;
    match e {
        C::NoSamples => "--start-spp 0: at least one sample per cell is needed".into(),
        C::LevelsReversed { start, max } => {
            format!("--max-spp {max} is smaller than --start-spp {start}")
        }
        C::TooFewLevels { max, needed } => format!(
            "--max-spp {max}: a self-referenced report needs at least 3 levels (start, 2x, 4x); \
             raise --max-spp to {needed} or give --reference"
        ),
        C::Resolution { res, max } => format!("--res {res}: must be between 1 and {max}"),
        C::CreateDir { dir, .. } => format!("--out-dir {}: cannot create it", dir.display()),
        C::NoReference { path } => format!("--reference {}: no such file", path.display()),
        C::ReadReference { .. } => "--reference".into(),
        C::ReferenceWeighting { weighting } => format!(
            "--reference: weighting {} cannot be compared on a slice",
            weighting.map_or("(none)".into(), |w| w.to_string())
        ),
        C::ImportanceOnSlice => {
            "--weight importance needs a camera; converge runs on a slice".into()
        }
        // No flag sets this alone: the library's words are the message.
        C::NoLevels => e.to_string(),
    }
}

/// A merge refusal, naming the flag that would fix it (`--seed` of the part to run again, `-o`).
pub fn merge(e: &MergeError) -> String {
    use MergeError as M;
    let twice = "the same seed repeats the same random streams, so merging would count the same \
                 samples twice (run the extra part with another --seed)";
    match e {
        M::SeedRepeated { file, seed, other } => {
            format!("{file}: seed {seed} is also the seed of {other}: {twice}")
        }
        M::SeedOverlap {
            file,
            seed,
            rows,
            other,
            other_rows,
        } => format!(
            "{file}: seed {seed} over rows {}-{} overlaps rows {}-{} of {other} with the same \
             seed: {twice}",
            rows.start, rows.end, other_rows.start, other_rows.end
        ),
        M::OutputFormat { output, ext } => format!(
            "-o {}: the inputs are {ext} files, so the merged file is one too: name it .{ext}",
            output.display()
        ),
        // No flag sets these: the library's words are the message.
        M::NoFields
        | M::NoFiles
        | M::UnknownFormat { .. }
        | M::MixedFormats { .. }
        | M::NoSuchFile { .. }
        | M::Info(_)
        | M::Resolution { .. }
        | M::Differs { .. }
        | M::GridDiffers { .. }
        | M::CellCount { .. }
        | M::NoSeed { .. }
        | M::DamagedTiles { .. }
        | M::PartOutsideRows { .. }
        | M::SamplesOutsideParts { .. } => e.to_string(),
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

    #[test]
    fn merge_refusals_name_the_flag_that_fixes_them() {
        let e = MergeError::SeedOverlap {
            file: "t1.exr".into(),
            seed: 1,
            rows: 6..12,
            other: "a.exr".into(),
            other_rows: 0..12,
        };
        let lib = e.to_string();
        let cli = merge(&e);
        assert!(
            !lib.contains("--seed") && lib.ends_with("another seed)"),
            "{lib}"
        );
        assert_eq!(cli, lib.replace("another seed", "another --seed"));
        let e = MergeError::SeedRepeated {
            file: "b.exr".into(),
            seed: 1,
            other: "a.exr".into(),
        };
        assert_eq!(
            merge(&e),
            e.to_string().replace("another seed", "another --seed")
        );
    }
}
