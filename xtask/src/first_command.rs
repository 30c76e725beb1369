//! `cargo xtask first-command`: the README's first command, run as written and timed, and its σ
//! against an independent reference.
//!
//! The command is the first line of the README's first code block (the one a new user pastes).
//! It runs through `bash -c` in the checkout's root, after a release build of that checkout's
//! `ftpd3d` (so the wall time is the run a user waits for once the tool is built; the fresh build
//! is measured on its own in docs/performance.md#build). Reported:
//! - wall and CPU seconds of the command (setup check, cargo's up-to-date check, load and run),
//!   and the compute seconds, samples and stop reason its output stores;
//! - the 95th percentile of its own relative standard error (what its stop rule reads, the
//!   figure the run prints);
//! - the 95th percentile of the actual relative error |σ − σ_ref| / σ_ref over the cells the
//!   reference resolves: valid in both, σ_ref > 0 and the reference's relative standard error
//!   ≤ [`RESOLVED`]. The reference is the same slice with `--spp` samples per cell (uniform) and a
//!   seed the command does not use, computed once and cached. Its own noise is in that figure;
//!   its 95th-percentile relative standard error over the same cells is printed beside it.

use crate::cost::{Cost, run_costed};
use crate::efficiency::quantile;
use anyhow::{Context, bail};
use clap::Args;
use ftpd3d::field::Field;
use ftpd3d::render::field_error_stats;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The reference's relative standard error up to which a cell counts as resolved.
pub const RESOLVED: f64 = 0.05;

/// Seed of the reference (the README's command runs with the default seed, 1).
pub const REFERENCE_SEED: u64 = 1_000_003;

#[derive(Args, Debug, Clone)]
pub struct FirstCommandArgs {
    /// The checkout whose README's first command runs, in that directory [default: this tree].
    #[arg(long, value_name = "DIR")]
    tree: Option<PathBuf>,
    /// Samples per cell of the reference.
    #[arg(long, default_value_t = 6144)]
    ref_spp: u32,
    /// The binary that computes the reference when it is not cached [default: the checkout's
    /// release build].
    #[arg(long, value_name = "BIN")]
    reference_bin: Option<PathBuf>,
    /// Directory of the cached reference [default: <target>/first-command].
    #[arg(long, value_name = "DIR")]
    work_dir: Option<PathBuf>,
    /// Compare the output the command wrote last instead of running it again.
    #[arg(long)]
    no_run: bool,
    /// Instead of the command, its ftpd3d arguments with `--spp N --pass-spp 8 --adaptive` (the
    /// passes of its default budget, stopped at a sample count instead of a minute): a figure that
    /// does not depend on the machine's load. Written to the work directory.
    #[arg(long, value_name = "N", conflicts_with = "no_run")]
    spp: Option<u32>,
}

/// The README's main-job command: the first non-empty line of its first code block.
pub fn first_command(readme: &str) -> Option<String> {
    let mut lines = readme.lines();
    lines.by_ref().find(|l| l.trim_start().starts_with("```"))?;
    lines
        .take_while(|l| !l.trim_start().starts_with("```"))
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .map(str::to_string)
}

/// The arguments the command gives ftpd3d (after `cargo run --release --`) and its output file.
pub fn tool_args(command: &str) -> anyhow::Result<(Vec<String>, PathBuf)> {
    let words: Vec<&str> = command.split_whitespace().collect();
    let start = words
        .windows(4)
        .position(|w| w == ["cargo", "run", "--release", "--"])
        .context("the first command has no `cargo run --release --`")?;
    let args: Vec<String> = words[start + 4..]
        .iter()
        .take_while(|w| !matches!(**w, "&&" | ";" | "||" | "|"))
        .map(|w| w.to_string())
        .collect();
    let out = args
        .iter()
        .position(|a| a == "-o" || a == "--output")
        .and_then(|i| args.get(i + 1))
        .context("the first command names no output (-o)")?;
    let out = PathBuf::from(out);
    Ok((args, out))
}

/// `args` without the output flag and the budget flags (`--time`, `--target-error`) and their
/// values: the reference and the `--spp` runs set their own sample counts.
fn without_output(args: &[String]) -> Vec<String> {
    const DROP: [&str; 4] = ["-o", "--output", "--time", "--target-error"];
    let mut v = Vec::new();
    let mut skip = false;
    for a in args {
        if skip {
            skip = false;
        } else if DROP.contains(&a.as_str()) {
            skip = true;
        } else if !DROP.iter().any(|f| a.starts_with(&format!("{f}="))) {
            v.push(a.clone());
        }
    }
    v
}

/// The command's σ against the reference.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Accuracy {
    /// Cells with σ_ref > 0 valid in both, and of those the resolved ones.
    pub cells: usize,
    pub resolved: usize,
    /// Over the resolved cells: median and 95th percentile of |σ − σ_ref| / σ_ref, and the
    /// reference's own 95th-percentile relative standard error.
    pub median: f64,
    pub p95: f64,
    pub ref_p95_rel_se: f64,
    /// 95th percentile of |σ − σ_ref| / σ_ref over all `cells`.
    pub p95_all: f64,
}

/// `field` against `reference` (see the module documentation).
pub fn accuracy(field: &Field, reference: &Field) -> Accuracy {
    let (mut all, mut rel, mut ref_rel) = (Vec::new(), Vec::new(), Vec::new());
    for (x, r) in field.values().iter().zip(&reference.values()) {
        if !(x.valid && r.valid && r.sigma > 0.0) {
            continue;
        }
        let e = (x.sigma - r.sigma).abs() / r.sigma;
        all.push(e);
        if r.stderr > 0.0 && r.stderr <= RESOLVED * r.sigma {
            rel.push(e);
            ref_rel.push(r.stderr / r.sigma);
        }
    }
    Accuracy {
        cells: all.len(),
        resolved: rel.len(),
        median: quantile(&mut rel, 0.5),
        p95: quantile(&mut rel, 0.95),
        ref_p95_rel_se: quantile(&mut ref_rel, 0.95),
        p95_all: quantile(&mut all, 0.95),
    }
}

/// Runs the measurement and prints it.
pub fn run(args: &FirstCommandArgs) -> anyhow::Result<()> {
    let tree = match &args.tree {
        Some(t) => t.clone(),
        None => crate::workspace_root(),
    };
    let tree = tree
        .canonicalize()
        .with_context(|| format!("--tree {}: no such directory", tree.display()))?;
    let readme_path = tree.join("README.md");
    let readme = std::fs::read_to_string(&readme_path)
        .with_context(|| format!("{}: cannot read it", readme_path.display()))?;
    let command = first_command(&readme)
        .with_context(|| format!("{}: no code block", readme_path.display()))?;
    let (tool, out) = tool_args(&command)?;
    // The reference is named after the command's output, whichever file is compared with it.
    let ref_stem = out
        .file_stem()
        .map_or("first".into(), |s| s.to_string_lossy().into_owned());
    let mut out = tree.join(out);
    // Only a run or a reference made with the tree's own build needs it (a `--no-run` with
    // `--reference-bin` works on a tree that is no cargo checkout).
    let tree_bin = || -> anyhow::Result<PathBuf> {
        Ok(tree_target_dir(&tree)?.join("release").join("ftpd3d"))
    };
    let work_dir = match &args.work_dir {
        Some(d) => d.clone(),
        None => crate::target_dir()?.join("first-command"),
    };
    eprintln!("first command ({}): {command}", tree.display());
    let cost = if args.no_run {
        None
    } else if let Some(spp) = args.spp {
        prebuild(&tree)?;
        let tree_bin = tree_bin()?;
        std::fs::create_dir_all(&work_dir)
            .with_context(|| format!("{}: cannot create it", work_dir.display()))?;
        out = work_dir.join(format!("{ref_stem}_spp{spp}.exr"));
        let mut a = without_output(&tool);
        a.extend(["--spp", &spp.to_string(), "--pass-spp", "8", "--adaptive"].map(String::from));
        let mut cmd = Command::new(&tree_bin);
        cmd.args(&a).current_dir(&tree).arg("-o").arg(&out);
        eprintln!(
            "instead: {} {} -o {}",
            tree_bin.display(),
            a.join(" "),
            out.display()
        );
        Some(run_costed(&mut cmd, &tree_bin.display().to_string())?)
    } else {
        prebuild(&tree)?;
        let mut cmd = Command::new("bash");
        cmd.args(["-c", &command]).current_dir(&tree);
        Some(run_costed(&mut cmd, "the README's first command")?)
    };
    let field =
        ftpd3d::output::exr::read_exr(&out).with_context(|| format!("{}", out.display()))?;
    let reference_bin = match &args.reference_bin {
        Some(b) => b.clone(),
        None => tree_bin()?,
    };
    let reference = reference(&work_dir, &ref_stem, &tool, args.ref_spp, &reference_bin)?;
    print!(
        "{}",
        report(&tree, &out, &field, cost, &reference, args.ref_spp)?
    );
    Ok(())
}

/// `cargo build --release --bin ftpd3d` in `tree`, so the timed command does not build.
fn prebuild(tree: &Path) -> anyhow::Result<()> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(cargo)
        .args(["build", "--release", "--quiet", "--bin", "ftpd3d"])
        .current_dir(tree)
        .status()
        .context("cargo: cannot start it")?;
    if !status.success() {
        bail!("the release build in {} failed ({status})", tree.display());
    }
    Ok(())
}

/// Cargo's target directory of the checkout `tree`, as `cargo metadata` gives it: `tree/target`,
/// or `CARGO_TARGET_DIR`, or a configured `build.target-dir` (scripts/target-dir.sh does the same
/// for the scripts).
fn tree_target_dir(tree: &Path) -> anyhow::Result<PathBuf> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = Command::new(cargo)
        .args(["metadata", "--format-version", "1", "--no-deps"])
        .current_dir(tree)
        .output()
        .context("cargo: cannot start it")?;
    if !out.status.success() {
        bail!(
            "cargo metadata in {} failed: {}",
            tree.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    target_directory(&String::from_utf8_lossy(&out.stdout))
        .with_context(|| format!("cargo metadata in {}: no target_directory", tree.display()))
}

/// The `target_directory` string of `cargo metadata`'s JSON (the xtask has no JSON parser; the
/// key is unique in that output), with JSON's escapes of `"` and `\` undone.
fn target_directory(json: &str) -> Option<PathBuf> {
    let key = "\"target_directory\":\"";
    let rest = &json[json.find(key)? + key.len()..];
    let mut path = String::new();
    let mut chars = rest.chars();
    loop {
        match chars.next()? {
            '"' => return Some(PathBuf::from(path)),
            '\\' => path.push(chars.next()?),
            c => path.push(c),
        }
    }
}

/// The cached reference of the command's slice, or computed now with `bin`.
fn reference(
    work_dir: &Path,
    stem: &str,
    tool: &[String],
    spp: u32,
    bin: &Path,
) -> anyhow::Result<Field> {
    let path = work_dir.join(format!("{stem}_ref{spp}.exr"));
    if path.is_file() {
        return ftpd3d::output::exr::read_exr(&path).with_context(|| path.display().to_string());
    }
    std::fs::create_dir_all(work_dir)
        .with_context(|| format!("{}: cannot create it", work_dir.display()))?;
    let mut a = without_output(tool);
    for (flag, value) in [
        ("--spp", spp.to_string()),
        ("--batches", spp.clamp(1, 48).to_string()),
        ("--seed", REFERENCE_SEED.to_string()),
    ] {
        a.push(flag.into());
        a.push(value);
    }
    eprintln!(
        "computing the reference: {} {} -o {}",
        bin.display(),
        a.join(" "),
        path.display()
    );
    let (f, _) = crate::binary::run_costed(bin, &a, &path)?;
    Ok(f)
}

/// The figures as text: a line per measure and a Markdown row.
fn report(
    tree: &Path,
    out: &Path,
    field: &Field,
    cost: Option<Cost>,
    reference: &Field,
    ref_spp: u32,
) -> anyhow::Result<String> {
    let info = field.info(&out.display().to_string())?;
    let spp = crate::equal_time::samples_per_cell(field);
    let reported = field_error_stats(field, 0..field.cells.len());
    let acc = accuracy(field, reference);
    let wall = cost.map_or("n/a".into(), |c| format!("{:.1}", c.wall));
    let cpu = cost
        .and_then(|c| c.cpu)
        .map_or("n/a".into(), |c| format!("{c:.1}"));
    let compute = info.elapsed.map_or("n/a".into(), |e| format!("{e:.1}"));
    let stop = info.stop.unwrap_or_else(|| "n/a".into());
    let commit = Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .current_dir(tree)
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map_or("?".into(), |s| s.trim().to_string());
    Ok(format!(
        "wall {wall} s (CPU {cpu} s), compute {compute} s, {spp:.0} spp ({:.1} M samples), stop: {stop}\n\
         reported p95 relative standard error {:.4} (mean {:.4})\n\
         actual |σ − σ_ref|/σ_ref over the {} of {} cells the reference resolves (its relative \
         standard error ≤ {RESOLVED}): median {:.4}, p95 {:.4} (over all {} cells: p95 {:.4}); \
         the reference's own p95 relative standard error there {:.4} ({ref_spp} spp)\n\n\
         | commit | wall s | CPU s | compute s | spp | stop | reported p95 | actual p95 (median) |\n\
         |---|---|---|---|---|---|---|---|\n\
         | {commit} | {wall} | {cpu} | {compute} | {spp:.0} | {stop} | {:.3} | {:.3} ({:.3}) |\n",
        field.total_samples() as f64 / 1e6,
        reported.p95,
        reported.mean,
        acc.resolved,
        acc.cells,
        acc.median,
        acc.p95,
        acc.cells,
        acc.p95_all,
        acc.ref_p95_rel_se,
        reported.p95,
        acc.p95,
        acc.median,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_line_of_the_first_code_block() {
        let readme = "# x\n\ntext\n\n```sh\nscripts/setup.sh && cargo run --release -- --scene \
                      scenes/cornell_mirror.obj --slice z=0 -o out/cornell_z0.exr\nscripts/setup.sh \
                      && cargo test\n```\n\n```sh\nother\n```\n";
        let c = first_command(readme).unwrap();
        assert!(c.starts_with("scripts/setup.sh && cargo run"), "{c}");
        let (args, out) = tool_args(&c).unwrap();
        assert_eq!(
            args,
            [
                "--scene",
                "scenes/cornell_mirror.obj",
                "--slice",
                "z=0",
                "-o",
                "out/cornell_z0.exr"
            ]
        );
        assert_eq!(out, Path::new("out/cornell_z0.exr"));
        assert_eq!(without_output(&args).len(), 4);
        let budget: Vec<String> = [
            "--slice",
            "z=0",
            "--time",
            "85",
            "--target-error=0.05",
            "-o",
            "x",
        ]
        .map(String::from)
        .into();
        assert_eq!(without_output(&budget), ["--slice", "z=0"]);
        assert!(tool_args("cargo test").is_err());
        assert_eq!(first_command("no code"), None);
    }

    #[test]
    fn the_target_directory_is_cargos_not_always_target() {
        let json = r#"{"packages":[],"target_directory":"/t/a \"b\" \\c","version":1}"#;
        assert_eq!(
            target_directory(json),
            Some(PathBuf::from(r#"/t/a "b" \c"#))
        );
        assert_eq!(target_directory(r#"{"target_directory":"/t"#), None);
        // This test runs from <target>/debug/deps/: the directory cargo built it into, which
        // `cargo metadata` must name too (./target, or CARGO_TARGET_DIR when it is set).
        let exe = std::env::current_exe().unwrap();
        let built_in = exe.ancestors().nth(3).unwrap().canonicalize().unwrap();
        let named = tree_target_dir(&crate::workspace_root()).unwrap();
        assert_eq!(named.canonicalize().unwrap(), built_in);
    }
}
