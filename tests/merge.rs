//! Split runs and `ftpd3d merge`: seeds add their moments exactly, tiles reassemble the full run
//! bit for bit, mismatched or repeated parts are refused, and the Slurm examples work with a
//! stand-in `sbatch` and, where there is one, on a real Slurm cluster.

use crate::support::{Run, VtiImage, cornell_12_in, ftpd3d_in, read_vti, scene_path, temp_dir};
use ftpd3d::field::Field;
use ftpd3d::ftpd::moments::Moments;
use ftpd3d::output::exr::{read_channel, read_exr, write_exr};
use std::path::Path;
use std::process::Command;

fn cornell() -> String {
    scene_path("cornell_mirror.obj")
        .to_str()
        .unwrap()
        .to_string()
}

/// A small slice of the Cornell box, radiance-weighted (fluence sums too), plus `extra` flags.
fn run(dir: &Path, extra: &[&str]) {
    let Run { ok, err, .. } = cornell_12_in(dir, extra);
    assert!(ok, "{extra:?}: {err}");
}

fn assert_same_cells(a: &Field, b: &Field, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    for (k, (x, y)) in a.cells.iter().zip(&b.cells).enumerate() {
        assert_eq!(
            x.bit_pattern(),
            y.bit_pattern(),
            "{what}: cell {k}: {x:?} vs {y:?}"
        );
    }
}

fn f32_bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn merging_two_seeds_adds_their_moments_exactly() {
    let dir = temp_dir("merge", "seeds");
    run(&dir, &["--seed", "1", "-o", "a.exr"]);
    run(&dir, &["--seed", "2", "-o", "b.exr"]);
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.exr", "b.exr", "-o", "ab.exr"]);
    assert!(ok, "{err}");
    assert!(
        err.contains("merged 2 files") && err.contains("seeds 1,2"),
        "{err}"
    );
    assert!(dir.join("ab.png").is_file() && dir.join("ab.grad.png").is_file());

    let (a, b) = (
        read_exr(&dir.join("a.exr")).unwrap(),
        read_exr(&dir.join("b.exr")).unwrap(),
    );
    let merged = read_exr(&dir.join("ab.exr")).unwrap();
    // The same sums added in memory, in the same order.
    let mut sum = a.clone();
    for (c, o) in sum.cells.iter_mut().zip(&b.cells) {
        c.merge(o);
    }
    assert_same_cells(&merged, &sum, "merge(a, b) against a + b in memory");
    assert!(merged.cells.iter().all(|c| c.n == 16));
    assert!(a.cells.iter().zip(&merged.cells).any(|(x, y)| x.s0 != y.s0));
    // σ and its standard error are re-finalised from the summed moments.
    let (_, _, sigma) = read_channel(&dir.join("ab.exr"), "ftpd").unwrap();
    let (_, _, stderr) = read_channel(&dir.join("ab.exr"), "ftpd.stderr").unwrap();
    let expect: Vec<_> = sum.values();
    assert_eq!(
        f32_bits(&sigma),
        f32_bits(&expect.iter().map(|v| v.sigma as f32).collect::<Vec<_>>())
    );
    assert_eq!(
        f32_bits(&stderr),
        f32_bits(&expect.iter().map(|v| v.stderr as f32).collect::<Vec<_>>())
    );
    // 8 batches of 2 samples each now: the standard error shrinks on the whole.
    let mean = |f: &Field| f.values().iter().map(|v| v.stderr).sum::<f64>();
    assert!(
        mean(&merged) < mean(&a),
        "more batches, smaller standard error"
    );
    let m = &merged.meta;
    assert_eq!(m.get("seeds").map(String::as_str), Some("1,2"));
    assert_eq!(m.get("seed"), None, "two seeds: no single seed");
    assert_eq!(m.get("parts").map(String::as_str), Some("1@0-12;2@0-12"));
    assert_eq!(m.get("spp").map(String::as_str), Some("16"));
    assert_eq!(m.get("batches").map(String::as_str), Some("8"));
    assert_eq!(m.get("merged").map(String::as_str), Some("a.exr;b.exr"));
    assert_eq!(m.get("weighting"), a.meta.get("weighting"));
    assert_eq!(m.get("t1"), a.meta.get("t1"));
    // Progress describes the merged field: all samples, both runs' compute time, nothing left.
    assert_eq!(m["samples"], (144 * 16).to_string());
    let secs = |f: &Field| f.meta["elapsed"].parse::<f64>().unwrap();
    assert_eq!(secs(&merged), secs(&a) + secs(&b));
    assert_eq!(m["remaining.samples"], "0");
    assert_eq!(m["partial"], "false");
}

#[test]
fn three_tiles_merge_into_the_full_run_bit_for_bit() {
    let dir = temp_dir("merge", "tiles");
    let scene = cornell();
    let common = [
        "--scene",
        scene.as_str(),
        "--slice",
        "z=0",
        "--res",
        "16",
        "--spp",
        "6",
        "--batches",
        "3",
        "--quiet",
        "--no-png",
    ];
    // Tiles on one thread, under their default names; the full run on all threads.
    for i in 0..3 {
        let tile = format!("{i}/3");
        let mut args = common.to_vec();
        args.extend(["--tile", tile.as_str(), "--threads", "1"]);
        let Run { ok, err, .. } = ftpd3d_in(&dir, &args);
        assert!(ok, "{err}");
    }
    let mut args = common.to_vec();
    args.extend(["-o", "full.exr"]);
    let Run { ok, err, .. } = ftpd3d_in(&dir, &args);
    assert!(ok, "{err}");
    let full = read_exr(&dir.join("full.exr")).unwrap();
    assert_eq!((full.width, full.height), (16, 16));

    let names: Vec<String> = (0..3)
        .map(|i| format!("out/cornell_mirror_z0_tile{i}of3.exr"))
        .collect();
    // 16 rows in 3 stripes: 0..5, 5..10, 10..16 (row 0 at the bottom).
    for (i, rows) in [(0, 0..5), (1, 5..10), (2, 10..16)] {
        let t = read_exr(&dir.join(&names[i])).unwrap();
        assert_eq!(
            t.meta.get("tile").map(String::as_str),
            Some(&*format!("{i}/3"))
        );
        for (k, (c, f)) in t.cells.iter().zip(&full.cells).enumerate() {
            if rows.contains(&(k / 16)) {
                assert_eq!(
                    c.bit_pattern(),
                    f.bit_pattern(),
                    "tile {i}, cell {k}: the full run's streams"
                );
            } else {
                assert_eq!(
                    c.bit_pattern(),
                    Moments::default().bit_pattern(),
                    "tile {i}, cell {k}: empty"
                );
            }
        }
    }

    let mut args = vec!["merge"];
    args.extend(names.iter().map(String::as_str));
    args.extend(["-o", "merged.exr"]);
    let Run { ok, err, .. } = ftpd3d_in(&dir, &args);
    assert!(ok, "{err}");
    let merged = read_exr(&dir.join("merged.exr")).unwrap();
    assert_same_cells(&merged, &full, "3 tiles merged against the full run");
    for ch in [
        "ftpd",
        "ftpd.stderr",
        "samples",
        "valid",
        "fluence.G",
        "grad.x",
    ] {
        let (_, _, m) = read_channel(&dir.join("merged.exr"), ch).unwrap();
        let (_, _, f) = read_channel(&dir.join("full.exr"), ch).unwrap();
        assert_eq!(f32_bits(&m), f32_bits(&f), "channel {ch}");
    }
    let m = &merged.meta;
    assert_eq!(m.get("seed").map(String::as_str), Some("1"));
    assert_eq!(m.get("parts").map(String::as_str), Some("1@0-16"));
    assert_eq!(m.get("tile"), None, "all rows covered: no longer a tile");
    assert_eq!(m.get("spp").map(String::as_str), Some("6"));
    assert_eq!(m.get("batches").map(String::as_str), Some("3"));
    // Each tile says what it took and what its own stripe still lacks (nothing); the merged
    // field the totals of the full run.
    for (i, n) in [(0, 5 * 16 * 6), (2, 6 * 16 * 6)] {
        let t = read_exr(&dir.join(&names[i])).unwrap();
        assert_eq!(t.meta["samples"], n.to_string(), "tile {i}");
        assert_eq!(t.meta["remaining.samples"], "0", "tile {i}");
    }
    assert_eq!(m["samples"], full.meta["samples"]);
    assert_eq!(m["remaining.samples"], "0");
    assert!(m["elapsed"].parse::<f64>().is_ok(), "{}", m["elapsed"]);

    // Two of three tiles: a partial field, said so, that still merges with the third.
    let Run { ok, err, .. } = ftpd3d_in(
        &dir,
        &[
            "merge",
            &names[0],
            &names[2],
            "-o",
            "partial.exr",
            "--no-png",
        ],
    );
    assert!(ok && err.contains("covers 11 of 16 rows"), "{err}");
    let partial = read_exr(&dir.join("partial.exr")).unwrap();
    assert_eq!(
        partial.meta.get("tile").map(String::as_str),
        Some("0/3,2/3")
    );
    let Run { ok, err, .. } = ftpd3d_in(
        &dir,
        &[
            "merge",
            "partial.exr",
            &names[1],
            "-o",
            "again.exr",
            "--no-png",
        ],
    );
    assert!(ok, "{err}");
    assert_same_cells(
        &read_exr(&dir.join("again.exr")).unwrap(),
        &full,
        "in two steps",
    );
}

#[test]
fn mismatched_runs_are_refused_naming_the_file_and_the_key() {
    let dir = temp_dir("merge", "mismatch");
    run(&dir, &["--t1", "1.5", "-o", "a.exr"]);
    run(&dir, &["--t1", "2", "--seed", "2", "-o", "b.exr"]);
    let scene = cornell();
    let Run { ok, err, .. } = ftpd3d_in(
        &dir,
        &[
            "--scene", &scene, "--slice", "z=0", "--res", "10", "--spp", "2", "--t1", "1.5",
            "--seed", "3", "--quiet", "--no-png", "-o", "c.exr",
        ],
    );
    assert!(ok, "{err}");
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.exr", "b.exr", "-o", "x.exr"]);
    assert!(!ok);
    assert!(
        err.contains("b.exr: t1 = 2e0 differs from a.exr's 1.5e0"),
        "{err}"
    );
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.exr", "c.exr", "-o", "x.exr"]);
    assert!(!ok);
    assert!(
        err.contains("c.exr: resolution 10x10 differs from a.exr's 12x12"),
        "{err}"
    );
    // Other keys of the run, edited into copies of a.exr with another seed.
    let a = read_exr(&dir.join("a.exr")).unwrap();
    for (key, value, msg) in [
        (
            "weighting",
            Some("unweighted"),
            "d.exr: weighting = unweighted differs from a.exr's radiance",
        ),
        (
            "plane",
            Some("z=0.5"),
            "d.exr: plane = z=0.5 differs from a.exr's z=0",
        ),
        (
            "angle_deg",
            Some("3"),
            "d.exr: angle_deg = 3 differs from a.exr's 2",
        ),
        (
            "max_bounces",
            None,
            "d.exr: has no max_bounces, while a.exr has max_bounces = 32",
        ),
        (
            "scene",
            Some("other.obj"),
            "d.exr: scene = other.obj differs",
        ),
    ] {
        let mut d = a.clone();
        d.meta.insert("seed".into(), "9".into());
        match value {
            Some(v) => d.meta.insert(key.into(), v.into()),
            None => d.meta.remove(key),
        };
        write_exr(&dir.join("d.exr"), &d, &[]).unwrap();
        let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.exr", "d.exr", "-o", "x.exr"]);
        assert!(!ok && err.contains(msg), "{key}: {err}");
    }
    // A file whose cells contradict its header.
    let mut e = a.clone();
    e.meta.insert("seed".into(), "9".into());
    e.meta.insert("tile".into(), "0/2".into());
    write_exr(&dir.join("e.exr"), &e, &[]).unwrap();
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.exr", "e.exr", "-o", "x.exr"]);
    assert!(
        !ok && err.contains("e.exr: cell") && err.contains("holds samples"),
        "{err}"
    );
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.exr", "nope.exr", "-o", "x.exr"]);
    assert!(!ok && err.contains("nope.exr: no such file"), "{err}");
    assert!(!dir.join("x.exr").exists(), "nothing written on refusal");
}

#[test]
fn the_same_seed_twice_is_refused() {
    let dir = temp_dir("merge", "sameseed");
    run(&dir, &["-o", "a.exr"]);
    std::fs::copy(dir.join("a.exr"), dir.join("copy.exr")).unwrap();
    for files in [["a.exr", "a.exr"], ["a.exr", "copy.exr"]] {
        let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", files[0], files[1], "-o", "x.exr"]);
        assert!(!ok);
        assert!(
            err.contains(&format!("{}: seed 1 is also the seed of a.exr", files[1]))
                && err.contains("same random streams"),
            "{err}"
        );
    }
    // A tile of the same seed overlaps the full run's rows; one of another seed does not.
    run(&dir, &["--tile", "1/2", "-o", "t1.exr"]);
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.exr", "t1.exr", "-o", "x.exr"]);
    assert!(
        !ok && err.contains("t1.exr: seed 1 over rows 6-12 overlaps rows 0-12 of a.exr"),
        "{err}"
    );
    run(&dir, &["--tile", "1/2", "--seed", "2", "-o", "t2.exr"]);
    let Run { ok, err, .. } = ftpd3d_in(
        &dir,
        &["merge", "a.exr", "t2.exr", "-o", "x.exr", "--no-png"],
    );
    assert!(ok, "{err}");
    let x = read_exr(&dir.join("x.exr")).unwrap();
    assert_eq!(x.meta.get("spp").map(String::as_str), Some("8-16"));
    assert_eq!(x.meta.get("batches").map(String::as_str), Some("4-8"));
    assert!(x.cells[..6 * 12].iter().all(|c| c.n == 8));
    assert!(x.cells[6 * 12..].iter().all(|c| c.n == 16));
}

#[test]
fn tile_values_are_checked_and_named() {
    let dir = temp_dir("merge", "tileflag");
    let scene = cornell();
    for (tile, msg) in [
        ("3/3", "numbered 0 to 2"),
        ("0/0", "at least 1"),
        ("1", "expected I/N"),
    ] {
        let Run { ok, err, .. } = ftpd3d_in(
            &dir,
            &[
                "--scene", &scene, "--slice", "z=0", "--tile", tile, "-o", "x.exr",
            ],
        );
        assert!(
            !ok && err.contains("--tile") && err.contains(msg),
            "{tile}: {err}"
        );
    }
    // More tiles than rows: the empty ones are valid (empty) files, with a warning.
    let Run { ok, err, .. } = ftpd3d_in(
        &dir,
        &[
            "--scene", &scene, "--slice", "z=0", "--res", "2", "--spp", "2", "--tile", "0/4",
            "--no-png", "-o", "e.exr",
        ],
    );
    assert!(ok && err.contains("this tile is empty"), "{err}");
    assert!(
        read_exr(&dir.join("e.exr"))
            .unwrap()
            .cells
            .iter()
            .all(|c| c.n == 0)
    );
}

/// A stand-in for `sbatch`: runs an array job's tasks one after the other (and any other job
/// at once), prints a job id, records its arguments.
const FAKE_SBATCH: &str = r#"#!/bin/bash
set -euo pipefail
echo "$*" >> sbatch.log
array=""
script=""
for a in "$@"; do
    case "$a" in
        --array=*) array=${a#--array=} ;;
        --*) ;;
        *) script=$a ;;
    esac
done
if [ -z "$array" ]; then
    array=$(sed -n 's/^#SBATCH --array=//p' "$script")
fi
if [ -n "$array" ]; then
    for ((i = ${array%-*}; i <= ${array#*-}; i++)); do
        SLURM_ARRAY_TASK_ID=$i bash "$script" >&2
    done
else
    bash "$script" >&2
fi
echo "4242;cluster"
"#;

#[test]
fn slurm_examples_split_run_and_merge_without_slurm() {
    let dir = temp_dir("merge", "slurm");
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    std::fs::write(bin.join("sbatch"), FAKE_SBATCH).unwrap();
    let status = Command::new("chmod")
        .arg("+x")
        .arg(bin.join("sbatch"))
        .status()
        .unwrap();
    assert!(status.success());
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/slurm");
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let scene = cornell();
    for mode in ["tiles", "seeds"] {
        let work = dir.join(mode);
        std::fs::create_dir_all(&work).unwrap();
        let mut cmd = Command::new("bash");
        cmd.arg(examples.join("submit.sh"))
            .arg(mode)
            .current_dir(&work)
            .env("PATH", &path)
            .env("FTPD3D", env!("CARGO_BIN_EXE_ftpd3d"))
            .env("SLICE", "z=0")
            .env("RES", "12")
            .env("SPP", "4")
            .env("PARTS", "3")
            .env_remove("SCENE")
            .env_remove("CPUS")
            .env_remove("PARTITION");
        if mode == "tiles" {
            // CPUs and partition from the environment, another option passed through.
            cmd.env("SCENE", &scene)
                .env("CPUS", "2")
                .env("PARTITION", "debug")
                .arg("--qos=short");
        } // seeds: the default scene, found from this other working directory
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{mode}: {err}");
        let log = std::fs::read_to_string(work.join("sbatch.log")).unwrap();
        let lines: Vec<&str> = log.lines().collect();
        assert_eq!(lines.len(), 2, "{log}");
        assert!(lines[0].contains("--array=0-2"), "{log}");
        // The merge runs after every task has ended, failed or not, and reports missing parts.
        assert!(lines[1].contains("--dependency=afterany:4242"), "{log}");
        assert!(
            !log.contains("--cpus-per-task=8"),
            "no hard-coded CPU count: {log}"
        );
        if mode == "tiles" {
            assert!(lines[0].contains("--cpus-per-task=2"), "{log}");
            for l in &lines {
                assert!(
                    l.contains("--partition=debug") && l.contains("--qos=short"),
                    "{log}"
                );
            }
        }
        let all = read_exr(&work.join("all.exr")).unwrap();
        if mode == "tiles" {
            // The same as one full run of 4 samples per cell.
            let Run { ok, err, .. } = ftpd3d_in(
                &work,
                &[
                    "--scene", &scene, "--slice", "z=0", "--res", "12", "--spp", "4", "--no-png",
                    "--quiet", "-o", "full.exr",
                ],
            );
            assert!(ok, "{err}");
            let full = read_exr(&work.join("full.exr")).unwrap();
            assert_same_cells(&all, &full, "Slurm tiles merged");
        } else {
            assert_eq!(all.meta.get("seeds").map(String::as_str), Some("1,2,3"));
            assert!(all.cells.iter().all(|c| c.n == 12));
        }
    }
    // A task that failed: the merge job names the missing part and how to rerun it.
    let work = dir.join("tiles");
    std::fs::remove_file(work.join("part_1.exr")).unwrap();
    let out = Command::new("bash")
        .arg(examples.join("ftpd3d-merge.sbatch"))
        .current_dir(&work)
        .env("FTPD3D", env!("CARGO_BIN_EXE_ftpd3d"))
        .env("PARTS", "3")
        .env("OUT", "again.exr")
        .env("ARRAY_SCRIPT", "ftpd3d-array.sbatch")
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stderr),
        "missing parts: 1 of 3 (tasks 1); see their logs, rerun them from this directory with \
         the same settings:\n  sbatch --export=ALL --array=1 ftpd3d-array.sbatch\nthen merge \
         again:  sbatch --export=ALL ftpd3d-merge.sbatch\n"
    );
    assert!(!work.join("again.exr").exists());
    // A relative scene path that does not exist is refused before anything is queued.
    let out = Command::new("bash")
        .arg(examples.join("submit.sh"))
        .arg("tiles")
        .current_dir(&work)
        .env("PATH", &path)
        .env("SCENE", "no/such.obj")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no/such.obj: no such scene file"), "{err}");
}

/// Why the real-Slurm test cannot run here, if it cannot: no `sbatch` on PATH, or no controller
/// answering `sinfo`, or FTPD3D_SLURM=0 (which skips it anywhere).
fn slurm_missing() -> Option<String> {
    if std::env::var("FTPD3D_SLURM").is_ok_and(|v| v == "0") {
        return Some("FTPD3D_SLURM=0".into());
    }
    match Command::new("sbatch").arg("--version").output() {
        Err(e) => return Some(format!("no sbatch on PATH ({e})")),
        Ok(o) if !o.status.success() => {
            return Some(format!(
                "sbatch --version failed: {}",
                String::from_utf8_lossy(&o.stderr).trim()
            ));
        }
        Ok(_) => {}
    }
    match Command::new("sinfo").args(["-h", "-o", "%P %a"]).output() {
        Ok(o) if o.status.success() && !o.stdout.is_empty() => None,
        Ok(o) => Some(format!(
            "sbatch is on PATH but no Slurm controller answers (sinfo: {}); \
             scripts/slurm-local.sh starts a single-node cluster",
            String::from_utf8_lossy(&o.stderr).trim()
        )),
        Err(e) => Some(format!("sbatch is on PATH but sinfo is not ({e})")),
    }
}

/// Whether this run must have a Slurm cluster: FTPD3D_SLURM=1 (`.ci/run` sets it after
/// `scripts/slurm-local.sh` started one), or CI unless FTPD3D_SLURM=0.
fn slurm_required() -> bool {
    match std::env::var("FTPD3D_SLURM").as_deref() {
        Ok("1") => true,
        Ok("0") => false,
        _ => crate::support::in_ci(),
    }
}

/// One line of `scontrol show job -o` per job (per array task once they have split).
fn scontrol_jobs(id: &str) -> Vec<String> {
    let out = Command::new("scontrol")
        .args(["show", "job", "-o", id])
        .output()
        .expect("scontrol runs");
    assert!(
        out.status.success(),
        "scontrol show job {id}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(String::from)
        .collect()
}

/// The value of `key=` in a line of `scontrol show job -o`.
fn job_field<'a>(line: &'a str, key: &str) -> &'a str {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key).and_then(|w| w.strip_prefix('=')))
        .unwrap_or_else(|| panic!("no {key} in: {line}"))
}

/// Every `*.log` file in `dir`, for failure messages.
fn job_logs(dir: &Path) -> String {
    let mut names: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "log"))
        .collect();
    names.sort();
    names
        .iter()
        .map(|p| {
            format!(
                "--- {}\n{}",
                p.display(),
                std::fs::read_to_string(p).unwrap_or_default()
            )
        })
        .collect()
}

/// The shipped examples on a real Slurm cluster: `submit.sh tiles` and `submit.sh seeds` queue
/// their arrays and merge jobs through the real `sbatch`; once every job has ended, the merged
/// tiles equal one full run bit for bit, and the merged seeds the same runs added in task order.
/// Skipped, saying why, where there is no Slurm; CI starts one (`scripts/slurm-local.sh`), sets
/// FTPD3D_SLURM=1 and fails here without it.
#[test]
fn slurm_examples_run_on_a_real_cluster() {
    let test = "slurm_examples_run_on_a_real_cluster";
    if crate::support::skip_without(test, slurm_missing(), slurm_required()) {
        return;
    }
    let dir = temp_dir("merge", "realslurm");
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/slurm");
    let (res, spp, parts) = ("12", "4", 3);
    // Both modes queued at once, then waited for together.
    let mut jobs = Vec::new();
    for mode in ["tiles", "seeds"] {
        let work = dir.join(mode);
        std::fs::create_dir_all(&work).unwrap();
        let out = Command::new("bash")
            .arg(examples.join("submit.sh"))
            .arg(mode)
            .current_dir(&work)
            .env("FTPD3D", env!("CARGO_BIN_EXE_ftpd3d"))
            .env("SLICE", "z=0")
            .env("RES", res)
            .env("SPP", spp)
            .env("SEED", "1")
            .env("PARTS", parts.to_string())
            .env_remove("SCENE") // the default scene, found from this other directory
            .env_remove("CPUS")
            .env_remove("PARTITION")
            .env_remove("OUT")
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "{mode}: {stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // "array job N: 3 tasks (tiles)", then the merge job's id.
        let array = stdout
            .strip_prefix("array job ")
            .and_then(|s| s.split(':').next())
            .unwrap_or_else(|| panic!("{mode}: {stdout}"))
            .to_string();
        let merge = stdout.lines().last().unwrap().trim();
        let merge = merge.split(';').next().unwrap().to_string();
        assert!(
            array.parse::<u64>().is_ok() && merge.parse::<u64>().is_ok(),
            "{mode}: job ids from {stdout:?}"
        );
        jobs.push((mode, work, array, merge));
    }

    // Wait until every task and both merges have ended (2 minutes at most).
    let active = [
        "PENDING",
        "CONFIGURING",
        "RUNNING",
        "COMPLETING",
        "REQUEUED",
        "RESIZING",
    ];
    let start = std::time::Instant::now();
    loop {
        let lines: Vec<String> = jobs
            .iter()
            .flat_map(|(_, _, a, m)| [scontrol_jobs(a), scontrol_jobs(m)].concat())
            .collect();
        if lines
            .iter()
            .all(|l| !active.contains(&job_field(l, "JobState")))
        {
            break;
        }
        if start.elapsed() > std::time::Duration::from_secs(120) {
            let logs: String = jobs.iter().map(|j| job_logs(&j.1)).collect();
            panic!(
                "Slurm jobs still not done after 2 minutes:\n{}\n{logs}",
                lines.join("\n")
            );
        }
        std::thread::sleep(std::time::Duration::from_millis(250));
    }
    eprintln!(
        "real Slurm: both arrays and merges ended in {:.1} s",
        start.elapsed().as_secs_f64()
    );

    let scene = cornell();
    for (mode, work, array, merge) in &jobs {
        let logs = job_logs(work);
        // Every task ran under Slurm (its log is named after the real job id) and succeeded.
        let tasks = scontrol_jobs(array);
        assert_eq!(tasks.len(), parts, "{mode}: {tasks:?}");
        for t in &tasks {
            assert_eq!(
                (job_field(t, "JobState"), job_field(t, "ExitCode")),
                ("COMPLETED", "0:0"),
                "{mode}: {t}\n{logs}"
            );
        }
        for i in 0..parts {
            let log = work.join(format!("ftpd3d-{mode}-{array}_{i}.log"));
            assert!(log.is_file(), "{mode}: no {}\n{logs}", log.display());
        }
        let m = scontrol_jobs(merge);
        assert_eq!(m.len(), 1, "{m:?}");
        assert_eq!(
            (job_field(&m[0], "JobState"), job_field(&m[0], "ExitCode")),
            ("COMPLETED", "0:0"),
            "{mode}: merge job {}\n{logs}",
            m[0]
        );
        // The merge started only once every task had ended (timestamps to the second).
        let last_end = tasks.iter().map(|t| job_field(t, "EndTime")).max().unwrap();
        assert!(
            job_field(&m[0], "StartTime") >= last_end,
            "{mode}: merge started before the last task ended ({last_end}): {}",
            m[0]
        );
        let all = read_exr(&work.join("all.exr")).unwrap_or_else(|e| panic!("{mode}: {e}\n{logs}"));
        // The same field computed here, without Slurm.
        let single = |seed: &str, name: &str| -> Field {
            let Run { ok, err, .. } = ftpd3d_in(
                work,
                &[
                    "--scene", &scene, "--slice", "z=0", "--res", res, "--spp", spp, "--seed",
                    seed, "--no-png", "--quiet", "-o", name,
                ],
            );
            assert!(ok, "{err}");
            read_exr(&work.join(name)).unwrap()
        };
        if *mode == "tiles" {
            assert_eq!(all.meta.get("seed").map(String::as_str), Some("1"));
            assert_eq!(all.meta.get("tile"), None, "{:?}", all.meta);
            assert_same_cells(&all, &single("1", "full.exr"), "Slurm tiles merged");
        } else {
            assert_eq!(all.meta.get("seeds").map(String::as_str), Some("1,2,3"));
            let mut sum = single("1", "s1.exr");
            for seed in ["2", "3"] {
                let f = single(seed, &format!("s{seed}.exr"));
                for (c, o) in sum.cells.iter_mut().zip(&f.cells) {
                    c.merge(o);
                }
            }
            assert_same_cells(&all, &sum, "Slurm seeds merged");
            assert!(all.cells.iter().all(|c| c.n == 12));
        }
    }
}

/// A volume of the Cornell box, unweighted (fast) with 2 samples in 2 batches per voxel, plus
/// `extra` flags; 6³ voxels unless `extra` has a `--volume`.
fn run_volume(dir: &Path, extra: &[&str]) {
    let scene = cornell();
    let mut args = vec!["--scene", scene.as_str()];
    if !extra.contains(&"--volume") {
        args.extend(["--volume", "6"]);
    }
    args.extend([
        "--weight",
        "unweighted",
        "--spp",
        "2",
        "--batches",
        "2",
        "--quiet",
        "--no-png",
    ]);
    args.extend_from_slice(extra);
    let Run { ok, err, .. } = ftpd3d_in(dir, &args);
    assert!(ok, "{extra:?}: {err}");
}

/// The `<!-- ftpd3d key=value -->` comments of a `.vti`, read as text.
fn vti_comments(path: &Path) -> Vec<(String, String)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let kv = l
                .trim()
                .strip_prefix("<!-- ftpd3d ")?
                .strip_suffix(" -->")?;
            let (k, v) = kv.split_once('=')?;
            Some((k.to_string(), v.to_string()))
        })
        .collect()
}

#[test]
fn merging_two_seeds_of_a_volume_adds_their_sums_exactly() {
    let dir = temp_dir("merge", "volume_seeds");
    run_volume(&dir, &["--seed", "1", "-o", "a.vti"]);
    run_volume(&dir, &["--seed", "2", "-o", "b.vti"]);
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.vti", "b.vti", "-o", "ab.vti"]);
    assert!(ok, "{err}");
    assert!(
        err.contains("merged 2 files: 6x6x6 voxels") && err.contains("seeds 1,2"),
        "{err}"
    );
    assert!(dir.join("ab.png").is_file() && dir.join("ab.grad.png").is_file());
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !names.iter().any(|n| n.ends_with(".tmp")),
        "no temporary file left: {names:?}"
    );

    let (a, b, ab) = (
        read_vti(&dir.join("a.vti")),
        read_vti(&dir.join("b.vti")),
        read_vti(&dir.join("ab.vti")),
    );
    assert_eq!(ab.extent, a.extent);
    assert_eq!((ab.origin, ab.spacing), (a.origin, a.spacing));
    let arrays = |v: &VtiImage| v.arrays.iter().map(|x| x.0.clone()).collect::<Vec<_>>();
    assert_eq!(
        arrays(&ab),
        arrays(&a),
        "the same arrays, in the same order"
    );
    let n = 216;
    // Counts and the plain sums add; the weighted sums add with Neumaier compensation, exactly as
    // Moments::merge does, written out here independently.
    for name in ["samples", "batches"] {
        let want: Vec<u32> = (0..n).map(|i| a.u32s(name)[i] + b.u32s(name)[i]).collect();
        assert_eq!(ab.u32s(name), want.as_slice(), "{name}");
    }
    assert!(ab.u32s("samples").iter().all(|&s| s == 4));
    for name in [
        "fluence.R",
        "fluence.G",
        "fluence.B",
        "w.w",
        "w.wd",
        "w.wd2",
        "wd.wd",
        "wd.wd2",
        "wd2.wd2",
    ] {
        let name = format!("exact.sum.{name}");
        for i in 0..n {
            let want = a.f64s(&name)[i] + b.f64s(&name)[i];
            assert_eq!(ab.f64s(&name)[i].to_bits(), want.to_bits(), "{name}[{i}]");
        }
    }
    for name in ["w", "wd", "wd2"] {
        let (s, c) = (
            format!("exact.sum.{name}"),
            format!("exact.sum.{name}.comp"),
        );
        for i in 0..n {
            let (sa, ca, sb, cb) = (a.f64s(&s)[i], a.f64s(&c)[i], b.f64s(&s)[i], b.f64s(&c)[i]);
            let t = sa + sb;
            let err = if sa.abs() >= sb.abs() {
                (sa - t) + sb
            } else {
                (sb - t) + sa
            };
            let comp = (ca + err) + cb;
            assert_eq!(ab.f64s(&s)[i].to_bits(), t.to_bits(), "{s}[{i}]");
            assert_eq!(ab.f64s(&c)[i].to_bits(), comp.to_bits(), "{c}[{i}]");
        }
    }
    assert!(
        (0..n).any(|i| a.f64s("exact.sum.w")[i] != ab.f64s("exact.sum.w")[i]),
        "b added something"
    );
    // σ is re-finalised from the summed sums: the library's own merge of the two files agrees.
    let read = |f: &str| ftpd3d::output::vti::read_vti(&dir.join(f)).unwrap();
    let mut sum = read("a.vti").field;
    for (c, o) in sum.cells.iter_mut().zip(&read("b.vti").field.cells) {
        c.merge(o);
    }
    let sigma: Vec<u32> = sum
        .values()
        .iter()
        .map(|v| (v.sigma as f32).to_bits())
        .collect();
    assert_eq!(f32_bits(ab.f32s("ftpd")), sigma);
    assert!(sum.values().iter().filter(|v| v.valid).count() > n / 2);

    // The header describes the merged volume.
    let meta = vti_comments(&dir.join("ab.vti"));
    let get = |k: &str| meta.iter().find(|m| m.0 == k).map(|m| m.1.as_str());
    assert_eq!(get("parts"), Some("1@0-6;2@0-6"));
    assert_eq!(get("seeds"), Some("1,2"));
    assert_eq!(get("seed"), None, "two seeds: no single seed");
    assert_eq!(get("spp"), Some("4"));
    assert_eq!(get("batches"), Some("4"));
    assert_eq!(get("merged"), Some("a.vti;b.vti"));
    assert_eq!(get("domain"), Some("volume"));
    assert_eq!(get("volume.dims"), Some("6,6,6"));
    let a_meta = vti_comments(&dir.join("a.vti"));
    let a_get = |k: &str| a_meta.iter().find(|m| m.0 == k).map(|m| m.1.as_str());
    for key in ["weighting", "t1", "volume.box", "volume.spacing", "scene"] {
        assert_eq!(get(key), a_get(key), "{key}");
    }
}

#[test]
fn mismatched_volumes_are_refused_naming_the_file_and_the_key() {
    let dir = temp_dir("merge", "volume_mismatch");
    run_volume(&dir, &["--t1", "1.5", "-o", "a.vti"]);
    run_volume(&dir, &["--t1", "2", "--seed", "2", "-o", "b.vti"]);
    run_volume(
        &dir,
        &["--t1", "1.5", "--seed", "3", "--volume", "4", "-o", "c.vti"],
    );
    run_volume(
        &dir,
        &[
            "--t1",
            "1.5",
            "--seed",
            "4",
            "--volume",
            "6,6,6",
            "--box",
            "-1,0,-1,1,1.5,1",
            "-o",
            "d.vti",
        ],
    );
    // The header's grid moved (its description edited to match otherwise, another seed).
    let text = std::fs::read_to_string(dir.join("a.vti")).unwrap();
    let at = text.find("Origin=\"").unwrap() + 8;
    let end = at + text[at..].find('"').unwrap();
    let moved = format!("{}0.5 0.5 0.5{}", &text[..at], &text[end..]).replacen(
        "<!-- ftpd3d seed=1 -->",
        "<!-- ftpd3d seed=5 -->",
        1,
    );
    assert_ne!(moved, text);
    std::fs::write(dir.join("e.vti"), moved).unwrap();
    std::fs::copy(dir.join("a.vti"), dir.join("copy.vti")).unwrap();

    for (other, msg) in [
        ("b.vti", "b.vti: t1 = 2e0 differs from a.vti's 1.5e0"),
        (
            "c.vti",
            "c.vti: resolution 4x4x4 differs from a.vti's 6x6x6",
        ),
        ("d.vti", "d.vti: volume.box = "),
        ("e.vti", "e.vti: Origin 0.5 0.5 0.5 differs from a.vti's"),
        ("copy.vti", "copy.vti: seed 1 is also the seed of a.vti"),
    ] {
        let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.vti", other, "-o", "x.vti"]);
        assert!(!ok && err.contains(msg), "{other}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.vti", "d.vti", "-o", "x.vti"]);
    assert!(!ok && err.contains("differs from a.vti's"), "{err}");
    // A damaged volume is refused by name.
    std::fs::write(dir.join("cut.vti"), &text[..text.len() / 2]).unwrap();
    let Run { ok, err, .. } = ftpd3d_in(&dir, &["merge", "a.vti", "cut.vti", "-o", "x.vti"]);
    assert!(!ok && err.contains("cut.vti: truncated"), "{err}");
    assert!(!dir.join("x.vti").exists(), "nothing written on refusal");
}

#[test]
fn fields_and_volumes_are_not_mixed() {
    let dir = temp_dir("merge", "mixed");
    run(&dir, &["-o", "a.exr"]);
    run_volume(&dir, &["-o", "v.vti"]);
    run_volume(&dir, &["--seed", "2", "-o", "w.vti"]);
    for (args, msg) in [
        (
            ["a.exr", "v.vti", "-o", "x.exr"],
            "v.vti: is a .vti volume, while a.exr is an .exr field",
        ),
        (
            ["v.vti", "a.exr", "-o", "x.vti"],
            "a.exr: is an .exr field, while v.vti is a .vti volume",
        ),
        (
            ["v.vti", "w.vti", "-o", "x.exr"],
            "-o x.exr: the inputs are vti files, so the merged file is one too: name it .vti",
        ),
        (
            ["a.exr", "a.png", "-o", "x.exr"],
            "a.png: merge reads .exr fields and .vti volumes",
        ),
    ] {
        let mut all = vec!["merge"];
        all.extend(args);
        let Run { ok, err, .. } = ftpd3d_in(&dir, &all);
        assert!(!ok && err.contains(msg), "{args:?}: {err}");
    }
    assert!(!dir.join("x.exr").exists() && !dir.join("x.vti").exists());
    // Upper-case extensions are the same formats.
    std::fs::rename(dir.join("w.vti"), dir.join("W.VTI")).unwrap();
    let Run { ok, err, .. } = ftpd3d_in(
        &dir,
        &["merge", "v.vti", "W.VTI", "-o", "x.vti", "--no-png"],
    );
    assert!(ok, "{err}");
}

/// A tile run interrupted part-way (SIGTERM: it saves the partial field, as a checkpoint would)
/// holds samples in its own rows only, so it merges with the other tiles. (Tiles used to run empty
/// samples outside their stripe and clear them only at the end, so a partial tile was refused as
/// holding samples outside its rows.)
#[test]
fn an_interrupted_tile_holds_only_its_rows_and_merges() {
    let dir = temp_dir("merge", "interrupted_tile");
    let scene = cornell();
    let mut child = Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .current_dir(&dir)
        .args([
            "--scene",
            scene.as_str(),
            "--slice",
            "z=0",
            "--res",
            "12",
            "--spp",
            "1000000",
            "--pass-spp",
            "4",
            "--time",
            "60s",
            "--tile",
            "1/3",
            "--no-png",
            "-o",
            "t1.exr",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // A signal during set-up quits without writing: wait for the passes to start (the run prints
    // its budget) under any load, then let it take some.
    let mut err = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut text = String::new();
    while !text.contains("budget") {
        let mut line = String::new();
        let read = std::io::BufRead::read_line(&mut err, &mut line).unwrap();
        assert!(read > 0, "no start line: {text}");
        text += &line;
    }
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let killed = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    child.wait().unwrap();
    std::io::Read::read_to_end(&mut err, &mut Vec::new()).unwrap();
    let t1 = read_exr(&dir.join("t1.exr")).unwrap();
    assert_eq!(t1.meta["partial"], "true");
    let rows = 4..8; // tile 1 of 3 of 12 rows
    for (k, c) in t1.cells.iter().enumerate() {
        let row = k / t1.width;
        if rows.contains(&row) {
            assert!(c.n > 0, "cell {k} (row {row}) of the tile has no samples");
        } else {
            assert_eq!(c.n, 0, "cell {k} (row {row}) is outside the tile");
            assert_eq!(*c, Moments::default());
        }
    }
    run(&dir, &["--tile", "0/3", "-o", "t0.exr"]);
    run(&dir, &["--tile", "2/3", "-o", "t2.exr"]);
    let Run { ok, err, .. } = ftpd3d_in(
        &dir,
        &[
            "merge", "t0.exr", "t1.exr", "t2.exr", "-o", "all.exr", "--no-png",
        ],
    );
    assert!(ok, "{err}");
    let all = read_exr(&dir.join("all.exr")).unwrap();
    assert!(all.cells.iter().all(|c| c.n > 0));
}

/// Part 0 of an EXR holds only f32 channels (what every EXR reader, FreeImage included, opens as an
/// image), with the run's metadata; part 1 the exact u32 sums and counts. Read with the exr crate
/// directly, not with the project's reader.
#[test]
fn exr_part_0_is_all_f32_and_part_1_holds_the_exact_sums() {
    use exr::prelude::*;
    let dir = temp_dir("merge", "parts");
    run(&dir, &["-o", "a.exr"]);
    let parts = &crate::support::exr_parts(&dir.join("a.exr"));
    assert_eq!(parts.len(), 2);
    let name = |l: &Layer<AnyChannels<FlatSamples>>| {
        l.attributes.layer_name.as_ref().map(|t| t.to_string())
    };
    assert_eq!(name(&parts[0]).as_deref(), Some("ftpd"));
    assert_eq!(name(&parts[1]).as_deref(), Some("exact"));
    let names = |l: &Layer<AnyChannels<FlatSamples>>| -> Vec<String> {
        l.channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect()
    };
    for want in [
        "ftpd",
        "R",
        "G",
        "B",
        "ftpd.stderr",
        "valid",
        "samples",
        "fluence.R",
    ] {
        assert!(
            names(&parts[0]).iter().any(|n| n == want),
            "part 0 lacks {want}"
        );
    }
    assert!(
        parts[0]
            .channel_data
            .list
            .iter()
            .all(|c| matches!(c.sample_data, FlatSamples::F32(_))),
        "part 0 must be f32 only: {:?}",
        names(&parts[0])
    );
    assert!(
        parts[1]
            .channel_data
            .list
            .iter()
            .all(|c| matches!(c.sample_data, FlatSamples::U32(_)))
    );
    for want in ["samples", "batches", "exact.sum.w.hi", "exact.sum.w.lo"] {
        assert!(
            names(&parts[1]).iter().any(|n| n == want),
            "part 1 lacks {want}"
        );
    }
    assert!(
        parts[0]
            .attributes
            .other
            .keys()
            .any(|k| k == "ftpd3d.weighting")
    );
}
