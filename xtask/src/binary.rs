//! Runs a build of ftpd3d (this tree's, or an older one for comparison) as a separate process on
//! one slice and reads its field back: the common ground of `efficiency` and `converge
//! --baseline`, so both binaries of a comparison see the same plain command line and nothing of
//! one process leaks into the other.

use anyhow::{Context, bail};
use ftpd3d::field::Field;
use ftpd3d::ftpd::Weighting;
use std::path::Path;

/// One slice run of a binary.
#[derive(Clone, Debug)]
pub struct SliceRun<'a> {
    pub scene: &'a Path,
    /// `AXIS=VALUE` or a slice named in the scene file.
    pub slice: &'a str,
    pub res: usize,
    /// Part of the plane, u0,v0,u1,v1.
    pub window: Option<[f64; 4]>,
    pub weighting: Weighting,
    pub spp: u32,
    pub batches: u32,
    pub seed: u64,
    pub threads: usize,
    /// Further flags given to the binary as they are (estimator settings, lights).
    pub extra: &'a [String],
}

/// Runs `bin` for `run`, writing its EXR (no PNG) to `out`, and reads the field back.
pub fn run_slice(bin: &Path, run: &SliceRun, out: &Path) -> anyhow::Result<Field> {
    let mut cmd = std::process::Command::new(bin);
    cmd.arg("--scene")
        .arg(run.scene)
        .args(["--slice", run.slice])
        .args(["--res", &run.res.to_string()])
        .args(["--spp", &run.spp.to_string()])
        .args([
            "--batches",
            &run.batches.clamp(1, run.spp.max(1)).to_string(),
        ])
        .args(["--seed", &run.seed.to_string()])
        .args(["--weight", &run.weighting.to_string()])
        .args(["--threads", &run.threads.to_string()]);
    if let Some([u0, v0, u1, v1]) = run.window {
        cmd.arg(format!("--window={u0},{v0},{u1},{v1}"));
    }
    cmd.args(run.extra)
        .args(["--quiet", "--no-png", "-o"])
        .arg(out);
    let status = cmd
        .status()
        .with_context(|| format!("{}: cannot start it", bin.display()))?;
    if !status.success() {
        bail!("{} failed ({status}): {cmd:?}", bin.display());
    }
    ftpd3d::output::exr::read_exr(out).with_context(|| format!("{}", out.display()))
}

/// The compute seconds a run stored in its output (the scene load left out).
pub fn seconds(field: &Field, path: &Path) -> anyhow::Result<f64> {
    field
        .info(&path.display().to_string())?
        .elapsed
        .with_context(|| format!("{}: no elapsed time stored", path.display()))
}

/// Runs `bin` with `args` (the slice, estimator and budget flags), writing its EXR (no PNG) to
/// `out`; returns the field read back and what the process cost.
pub fn run_costed(
    bin: &Path,
    args: &[String],
    out: &Path,
) -> anyhow::Result<(Field, crate::cost::Cost)> {
    let mut cmd = std::process::Command::new(bin);
    cmd.args(args).args(["--quiet", "--no-png", "-o"]).arg(out);
    let cost = crate::cost::run_costed(&mut cmd, &bin.display().to_string())?;
    let field = ftpd3d::output::exr::read_exr(out).with_context(|| format!("{}", out.display()))?;
    Ok((field, cost))
}
