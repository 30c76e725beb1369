//! Runs of the `ftpd3d` binary, and the rule for tests that need a tool from outside the Rust
//! build: they run wherever the tool is there; where it is not, they are skipped with the reason on
//! a developer's machine and fail in CI, which installs every such tool (`.ci/run`).

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

/// [`ftpd3d`] with the environment variable `var` set to `value`.
pub fn ftpd3d_with_env(args: &[&str], (var, value): (&str, &str)) -> Run {
    run(Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .args(args)
        .env(var, value))
}

/// A small quiet run of the binary on `scene`: the 8² slice z = 0 in passes of 4 samples with
/// seed 3, no previews, then `extra` (the flags a test is about, the output, the budget).
pub fn small_slice(scene: &Path, extra: &[&str]) -> Run {
    let mut a = vec![
        "--scene",
        scene.to_str().unwrap(),
        "--slice",
        "z=0",
        "--res",
        "8",
        "--pass-spp",
        "4",
        "--seed",
        "3",
        "--quiet",
        "--no-png",
    ];
    a.extend_from_slice(extra);
    ftpd3d(&a)
}

/// 8 samples with the flags `setting`, on 1 thread into `paths[0]` and on 2 into `paths[1]` (for a
/// test that compares the two files bit for bit).
pub fn run_on_1_and_2_threads(run: impl Fn(&[&str]) -> Run, setting: &[&str], paths: [&str; 2]) {
    for (path, threads) in paths.into_iter().zip(["1", "2"]) {
        let r = run(&[setting, &["--spp", "8", "--threads", threads, "-o", path]].concat());
        assert!(r.ok, "{}", r.err);
    }
}

/// A run resumed with `--resume`: with its file's `setting` (flags) left out it is refused, naming
/// the attribute `key` and the flags to add; with them, 4 samples resumed to 8 equal `one_go`,
/// the 8-sample run, as `read` gives the resumed file back.
pub fn assert_resume_keeps<T: PartialEq + std::fmt::Debug>(
    run: impl Fn(&[&str]) -> Run,
    setting: &[&str],
    key: &str,
    path: &str,
    read: impl Fn() -> T,
    one_go: &T,
) {
    let r = run(&[setting, &["--spp", "4", "-o", path]].concat());
    assert!(r.ok, "{}", r.err);
    let r = run(&["--spp", "8", "--resume", path]);
    let named = setting.join(" ");
    assert!(
        !r.ok && r.err.contains(&format!("{key} differs")) && r.err.contains(&named),
        "{}",
        r.err
    );
    let r = run(&[setting, &["--spp", "8", "--resume", path]].concat());
    assert!(r.ok, "{}", r.err);
    assert_eq!(&read(), one_go, "resumed equals one go");
}

/// A run in `dir` of the 12² slice z = 0 of the shipped Cornell box, radiance-weighted, 8 samples
/// in 4 passes, quiet and without previews, plus `extra` flags: the small run of the file tests.
pub fn cornell_12_in(dir: &Path, extra: &[&str]) -> Run {
    let scene = crate::support::scene_path("cornell_mirror.obj");
    let mut args = vec![
        "--scene",
        scene.to_str().unwrap(),
        "--slice",
        "z=0",
        "--res",
        "12",
        "--spp",
        "8",
        "--batches",
        "4",
        "--quiet",
        "--no-png",
    ];
    args.extend_from_slice(extra);
    ftpd3d_in(dir, &args)
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

/// Whether this is a CI run: the `CI` variable set (every CI service sets `CI=true`), unless set
/// to `false` or `0`. In CI a test whose tool is missing fails instead of skipping.
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.trim(), "" | "false" | "0"))
}

/// For a test that needs a tool outside the Rust build: `missing` is why the tool cannot be used
/// (`None`: it can). Returns whether the test must stop here: it prints that it skipped, or, when
/// `required` (CI, or a variable that asks for the tool), fails naming the reason.
pub fn skip_without(test: &str, missing: Option<String>, required: bool) -> bool {
    let Some(why) = missing else {
        return false;
    };
    assert!(
        !required,
        "{test}: this run requires the tool, but {why} (.ci/run installs and starts every tool the tests use)"
    );
    eprintln!("skipped {test}: {why}");
    true
}
