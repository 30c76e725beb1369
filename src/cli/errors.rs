//! Error messages as the command line prints them: the library's typed errors ([`ParamError`],
//! [`DomainError`], [`OutputError`], [`FlatlandError`], [`RunError`]) say what is wrong in its own
//! terms; here they name the flags that set the values (`--t0`, `--slice`, `--window`, …). Other
//! errors print as they are. A room with a new error enum adds one arm to [`describe`] (and, when
//! it is long, a function like [`param`] beside it).

use crate::domain::{DomainError, commas};
use crate::output::OutputError;
use crate::params::ParamError;
use crate::render::{RunError, StopReason};
use crate::scene::LoadError;
use crate::scene::flat::FlatlandError;
use std::error::Error;
use std::process::ExitCode;

/// The process's exit status for the result of a command (`Some` reason a run stopped): success;
/// [`super::signals::EXIT_INTERRUPTED`] for a run stopped by a signal, its partial result written;
/// failure with the error printed on stderr in command-line words ([`message`]).
pub fn exit_code(result: anyhow::Result<Option<StopReason>>) -> ExitCode {
    match result {
        Ok(Some(StopReason::Interrupted)) => ExitCode::from(super::signals::EXIT_INTERRUPTED),
        Ok(_) => ExitCode::SUCCESS,
        // A closed pipe (`ftpd3d --explain | head`) is not an error of ours.
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {}", message(&e));
            ExitCode::FAILURE
        }
    }
}

/// The whole chain of `e` as `anyhow`'s `{:#}` prints it (`outer: inner: …`), each typed error in
/// its command-line words.
pub fn message(e: &anyhow::Error) -> String {
    e.chain().map(describe).collect::<Vec<_>>().join(": ")
}

/// One error of a chain in command-line words.
pub fn describe(e: &(dyn Error + 'static)) -> String {
    if let Some(p) = e.downcast_ref::<ParamError>() {
        param(p)
    } else if let Some(d) = e.downcast_ref::<DomainError>() {
        domain(d)
    } else if let Some(o) = e.downcast_ref::<OutputError>() {
        // The I/O cause follows as the next link of the chain, as it did with context.
        match o {
            OutputError::CreateDir { path, dir, .. } => format!(
                "-o {}: cannot create directory {}",
                path.display(),
                dir.display()
            ),
            OutputError::IsDirectory { path } => format!("-o {}: is a directory", path.display()),
            OutputError::NotRegular { path, file, kind } => format!(
                "-o {}: {}{kind}, not a regular file (the finished file is renamed into place, \
                 which would replace it): name a regular file or a new one",
                path.display(),
                crate::output::preview_of(path, file)
            ),
            OutputError::NotWritable { path, dir, .. } => format!(
                "-o {}: directory {} is not writable",
                path.display(),
                dir.display()
            ),
        }
    } else if let Some(RunError::AfterPass(inner)) = e.downcast_ref::<RunError>() {
        // The caller's own error (a checkpoint's), in the words it has.
        describe(inner.as_ref())
    } else if let Some(m) = super::analysis_errors::describe(e) {
        m
    } else if let Some(l) = e.downcast_ref::<LoadError>() {
        load(l)
    } else if let Some(f) = e.downcast_ref::<FlatlandError>() {
        match f {
            FlatlandError::NotExtruded { file, detail } => format!(
                "{file}: --flatland needs geometry extruded along the slice normal; {detail}"
            ),
            FlatlandError::LightOffPlane { file, detail } => {
                format!("{file}: --flatland: {detail}")
            }
        }
    } else {
        e.to_string()
    }
}

/// A scene that failed to load: strict loading and reading outside the scene's folder named by
/// their flags.
pub fn load(e: &LoadError) -> String {
    match e {
        LoadError::Strict { file, line, what } => {
            format!("{}:{line}: {what} (--strict)", file.display())
        }
        LoadError::Outside { .. } => e
            .outside_message("--allow-outside-uris")
            .unwrap_or_else(|| e.to_string()),
        LoadError::UnknownLight { name, .. } => format!("--light-scale {name}: {e}"),
        _ => e.to_string(),
    }
}

/// An estimator setting, named by its flag.
pub fn param(e: &ParamError) -> String {
    match e {
        ParamError::RunLengthNegative { t0 } => {
            format!("--t0 {t0}: the shortest run length must be finite and ≥ 0")
        }
        ParamError::RunLengthNotPositive { t1 } => {
            format!("--t1 {t1}: the longest run length must be finite and > 0")
        }
        ParamError::RunLengthsEmpty { t0, t1 } => {
            format!("--t0 {t0} is larger than --t1 {t1}: the run-length interval [t0, t1] is empty")
        }
        ParamError::AngleOutOfRange { angle_deg } => format!(
            "--angle {angle_deg}: the perturbation half-angle must lie strictly between 0 and 90 \
             degrees"
        ),
        ParamError::NoLights { scene, ways } => format!(
            "--weight radiance: {scene} has no lights ({ways}); add one with --point-light \
             X,Y,Z:R,G,B (position and radiant intensity), --sun X,Y,Z:R,G,B (direction and \
             irradiance), --sky R,G,B or --env FILE, or use --weight unweighted"
        ),
        ParamError::RadianceCapUnused { bounces, weighting } => format!(
            "--radiance-bounces {bounces}: caps the radiance paths of radiance weighting and of a \
             camera's beauty image; a --weight {weighting} run traces none (use --max-bounces to \
             cap its walks)"
        ),
        ParamError::Design(d) => format!(
            "--pairs: {} = {} must lie between 1 and {} (--pairs kA,kB,J,M)",
            d.what, d.value, d.max
        ),
        ParamError::GuideUnused { what } => format!(
            "--guide on: guided radiance paths need --weight radiance in 3D; this run is {what}"
        ),
        ParamError::NoLightInPlane { scene, plane } => format!(
            "--flatland --weight radiance: no light of {scene} meets the slice plane {plane} \
             (emissive triangles must cross it, point lights lie in it); use --weight unweighted \
             or another slice"
        ),
    }
}

/// A domain, named by the flags that place it.
pub fn domain(e: &DomainError) -> String {
    use DomainError as D;
    match e {
        D::SliceWithoutBounds { slice } => {
            format!("--slice {slice}: the scene has no geometry to take bounds from; give --window")
        }
        D::SliceOutsideBounds { slice, lo, hi } => format!(
            "--slice {slice}: outside the scene bounds, which span {lo} to {hi} along that axis"
        ),
        D::EmptyWindow { window } => format!(
            "--window {}: needs u0 < u1 and v0 < v1 (an empty rectangle)",
            commas(window)
        ),
        D::WindowAndSize { window, w, h } => format!(
            "--window {} and the --plane's size={w},{h} both set its rectangle: give one of them",
            commas(window)
        ),
        D::NoCells => "--res must be at least 1".into(),
        D::UpAlongNormal { up } => format!(
            "--plane: up ({}, {}, {}) is parallel to the normal",
            up.x, up.y, up.z
        ),
        D::PlaneWithoutBounds => "--plane: the scene has no bounds to cover; give size=w,h".into(),
        D::SliceSyntax(message) => format!("--slice {message}"),
        D::NamedSliceSyntax { name, message } => {
            format!("--slice {name}: the scene file's plane {message}")
        }
        D::NoNamedSlices { name } => {
            format!("--slice {name}: expected AXIS=VALUE such as z=1.2 (the scene names no slices)")
        }
        D::UnknownSlice { name, names } => format!(
            "--slice {name}: not AXIS=VALUE and not a slice of the scene file (it names: {names})"
        ),
        D::EmptyBox { bbox } => format!(
            "--box {}: needs xmin < xmax, ymin < ymax and zmin < zmax (an empty box)",
            commas(bbox)
        ),
        D::VolumeWithoutBounds => {
            "--volume: the scene has no geometry to take bounds from; give --box".into()
        }
        D::NoVoxels => "--volume: every axis needs at least 1 voxel".into(),
        D::EmptyImage { w, h } => {
            format!("--size {w},{h}: the image needs at least one pixel each way")
        }
        // --fov sets the field of view of the camera placed by --eye/--target alone.
        D::FieldOfView { name, fov_deg } if name == crate::app::PLACED_CAMERA => format!(
            "--fov {fov_deg}: the vertical field of view must lie strictly between 0 and 180 \
             degrees"
        ),
        // No flag sets these alone: the library's words are the message.
        D::EmptyPlane { .. }
        | D::EmptyVolumeBox { .. }
        | D::FieldOfView { .. }
        | D::UpAlongView { .. } => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_are_named_through_context() {
        let e = anyhow::Error::from(ParamError::RunLengthNegative { t0: -1.0 }).context("job");
        assert_eq!(
            message(&e),
            "job: --t0 -1: the shortest run length must be finite and ≥ 0"
        );
        assert_eq!(
            format!("{e:#}"),
            "job: the shortest run length t0 = -1 must be finite and ≥ 0"
        );
        let e = anyhow::anyhow!("plain").context("outer");
        assert_eq!(message(&e), format!("{e:#}"));
    }

    #[test]
    fn converge_settings_are_named_by_their_flags() {
        // Here rather than beside `analysis_errors::converge`: the whole chain goes through
        // [`message`], and the analysis messages never look back up at this file.
        use crate::analysis::converge::{ConvergeError, spp_levels};
        let msg = |e: ConvergeError| message(&anyhow::Error::from(e).context("converge"));
        assert_eq!(
            msg(spp_levels(0, 8).unwrap_err()),
            "converge: --start-spp 0: at least one sample per cell is needed"
        );
        assert_eq!(
            msg(spp_levels(8, 4).unwrap_err()),
            "converge: --max-spp 4 is smaller than --start-spp 8"
        );
        // The cause of an unreadable reference follows the flag, as a context did before.
        let e = ConvergeError::ReadReference {
            path: "ref.exr".into(),
            source: anyhow::anyhow!("ref.exr: not an EXR file"),
        };
        assert_eq!(msg(e), "converge: --reference: ref.exr: not an EXR file");
    }
}
