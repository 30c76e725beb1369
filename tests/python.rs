//! The Python module (`python/`): its pytest suite (`python/tests/`), run in a virtual environment
//! in `python-venv` of cargo's target directory (./target, or `CARGO_TARGET_DIR`) against this
//! build's binary. The package is installed as a user installs it, `pip install .` through
//! maturin, with the cargo target directory of this build and its dev profile, so the
//! dependencies shared with the command line compile once. Needs python3
//! with venv, and maturin, pytest and numpy importable (the venv sees the system's packages):
//! `.ci/run` installs them and the test fails there without them; elsewhere it says it skipped.

use crate::support::{in_ci, skip_without};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Why the suite cannot run here (`None`: it can).
fn missing(python: &Path) -> Option<String> {
    let probe = Command::new(python)
        .args(["-c", "import maturin, pytest, numpy"])
        .output();
    match probe {
        Err(e) => Some(format!("{}: {e}", python.display())),
        Ok(o) if !o.status.success() => Some(format!(
            "{} (pip install maturin pytest numpy)",
            String::from_utf8_lossy(&o.stderr)
                .lines()
                .last()
                .unwrap_or("")
        )),
        Ok(_) => None,
    }
}

/// Cargo's target directory of this test build (./target, or `CARGO_TARGET_DIR`): the binary
/// under test is `<target>/<profile>/ftpd3d`.
fn target_dir() -> PathBuf {
    let bin = Path::new(env!("CARGO_BIN_EXE_ftpd3d"));
    bin.ancestors().nth(2).unwrap().to_path_buf()
}

/// The environment's interpreter, after making the environment when it is not there (with the
/// system's site packages, so that what `.ci/run` installed is seen).
fn venv(target: &Path) -> Result<PathBuf, String> {
    let dir = target.join("python-venv");
    let python = dir.join("bin/python");
    if !python.is_file() {
        let made = Command::new("python3")
            .args(["-m", "venv", "--system-site-packages"])
            .arg(&dir)
            .output()
            .map_err(|e| format!("python3: {e}"))?;
        if !made.status.success() {
            return Err(format!(
                "python3 -m venv failed (apt install python3-venv): {}",
                String::from_utf8_lossy(&made.stderr).trim()
            ));
        }
    }
    Ok(python)
}

#[test]
fn pytest_suite() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let target = target_dir();
    let python = venv(&target);
    let why = match &python {
        Err(e) => Some(e.clone()),
        Ok(p) => missing(p),
    };
    if skip_without("python::pytest_suite", why, in_ci()) {
        return;
    }
    let python = python.unwrap();
    // maturin's build backend runs the `maturin` on PATH: the environment's first.
    let path = std::env::join_paths(
        std::iter::once(python.parent().unwrap().to_path_buf()).chain(std::env::split_paths(
            &std::env::var_os("PATH").unwrap_or_default(),
        )),
    )
    .unwrap();
    let install = Command::new(&python)
        .current_dir(&root)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-build-isolation",
            "--no-deps",
            "--force-reinstall",
            ".",
        ])
        .env("PATH", path)
        .env("CARGO_TARGET_DIR", &target)
        .env("MATURIN_PEP517_ARGS", "--profile dev")
        .output()
        .unwrap();
    assert!(
        install.status.success(),
        "pip install . failed:\n{}{}",
        String::from_utf8_lossy(&install.stdout),
        String::from_utf8_lossy(&install.stderr)
    );
    let tests = Command::new(&python)
        .current_dir(&root)
        .args([
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "python/tests",
        ])
        .env("FTPD3D_BIN", env!("CARGO_BIN_EXE_ftpd3d"))
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&tests.stdout);
    assert!(
        tests.status.success(),
        "pytest failed:\n{out}{}",
        String::from_utf8_lossy(&tests.stderr)
    );
    eprintln!("{}", out.lines().last().unwrap_or(""));
}
