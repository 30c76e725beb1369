//! Scaffolding the test modules share: this tree's ftpd3d binary, runs of the xtask, temporary
//! directories and CSV files.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A shipped scene.
pub fn scene_path(name: &str) -> PathBuf {
    root().join("scenes").join(name)
}

/// This tree's ftpd3d, built once per test run in the profile of these tests (the xtask depends
/// on the library only, so cargo does not build the binary for them).
pub fn ftpd3d_bin() -> &'static Path {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        // <target>/<profile>/deps/<this test>
        let exe = std::env::current_exe().unwrap();
        let profile_dir = exe.parent().and_then(Path::parent).unwrap().to_path_buf();
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.args(["build", "--quiet", "-p", "ftpd3d", "--bin", "ftpd3d"])
            .arg("--manifest-path")
            .arg(root().join("Cargo.toml"));
        if profile_dir.file_name().is_some_and(|n| n == "release") {
            cmd.arg("--release");
        }
        let status = cmd.status().expect("cargo runs");
        assert!(status.success(), "building ftpd3d failed: {status}");
        let bin = profile_dir.join("ftpd3d");
        assert!(bin.is_file(), "no ftpd3d at {}", bin.display());
        bin
    })
}

/// A fresh, empty directory for one test.
pub fn temp_dir(module: &str, test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("xtask-{module}-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs the xtask with `args` in `dir`: exit success, stdout, stderr.
pub fn xtask_in(dir: &Path, args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("xtask runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A CSV file as its header and rows of column → value.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<BTreeMap<String, String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            assert_eq!(v.len(), header.len(), "{l}");
            header
                .iter()
                .cloned()
                .zip(v.iter().map(|s| s.to_string()))
                .collect()
        })
        .collect();
    (header, rows)
}

/// A CSV value as a number.
pub fn num(row: &BTreeMap<String, String>, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = '{}'", row[key]))
}
