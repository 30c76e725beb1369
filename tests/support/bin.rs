//! Runs of the `ftpd3d` binary.

use std::path::Path;
use std::process::Command;

/// What a run of the binary gave: exit success, stdout, stderr.
pub struct Run {
    pub ok: bool,
    pub out: String,
    pub err: String,
}

/// Runs the ftpd3d binary with `args` in the test process's working directory (the crate root).
pub fn ftpd3d(args: &[&str]) -> Run {
    run(Command::new(env!("CARGO_BIN_EXE_ftpd3d")).args(args))
}

/// Runs the ftpd3d binary with `args` in `dir`.
pub fn ftpd3d_in(dir: &Path, args: &[&str]) -> Run {
    run(Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .current_dir(dir)
        .args(args))
}

fn run(cmd: &mut Command) -> Run {
    let out = cmd.output().expect("binary runs");
    Run {
        ok: out.status.success(),
        out: String::from_utf8_lossy(&out.stdout).into_owned(),
        err: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}
