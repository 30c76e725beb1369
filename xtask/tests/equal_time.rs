//! `cargo xtask equal-time` and `cargo xtask first-command`, with this tree's binary in every role
//! on small slices.

use crate::support::{ftpd3d_bin, num, read_csv, scene_path, temp_dir, xtask_in};

#[test]
fn equal_time_runs_rounds_interleaved_against_one_cached_reference() {
    let dir = temp_dir("equal_time", "self");
    let scene = scene_path("cornell_mirror.obj");
    let bin = ftpd3d_bin().to_str().unwrap();
    let cand = format!("same={bin}");
    let args = [
        "equal-time",
        "--baseline",
        bin,
        "--candidate",
        &cand,
        "--scene",
        scene.to_str().unwrap(),
        "--res",
        "12",
        "--weight",
        "unweighted",
        "--seconds",
        "1",
        "--rounds",
        "2",
        "--ref-factor",
        "2",
        "--threads",
        "1",
        "--work-dir",
        "et",
    ];
    let (ok, out, err) = xtask_in(&dir, &args);
    assert!(ok, "{err}");
    assert!(
        err.contains("cornell_mirror unweighted: reference computed"),
        "{err}"
    );
    // A row per binary, the baseline's efficiency 1 and the candidate's a ratio with its range.
    let row = |label: &str| {
        out.lines()
            .find(|l| l.starts_with(&format!("| cornell_mirror | unweighted | {label} |")))
            .unwrap_or_else(|| panic!("no row {label}: {out}"))
            .to_string()
    };
    assert!(row("ftpd3d").ends_with("| 1 | 1 | 1 |"), "{out}");
    assert!(row("same").contains("x ("), "{out}");
    // Rounds interleaved (baseline, candidate, baseline, candidate), each run its own seed.
    let (_, rows) = read_csv(&dir.join("et/equal-time.csv"));
    let order: Vec<(&str, f64)> = rows
        .iter()
        .map(|r| (r["binary"].as_str(), num(r, "seed")))
        .collect();
    assert_eq!(
        order,
        [
            ("ftpd3d", 1.0),
            ("same", 2.0),
            ("ftpd3d", 3.0),
            ("same", 4.0)
        ]
    );
    for r in &rows {
        assert!(num(r, "spp") > 0.0 && num(r, "mse") > 0.0, "{r:?}");
        assert!(num(r, "net_mse") < num(r, "mse"), "{r:?}");
        assert!(num(r, "ref_spp") > 0.0, "{r:?}");
    }
    // A second invocation reuses the reference.
    let (ok, _, err) = xtask_in(&dir, &args);
    assert!(ok && err.contains("reference cached"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn first_command_compares_the_readme_command_output_with_a_reference() {
    // A checkout whose README's first command wrote out/plane.exr (made here; --no-run).
    let dir = temp_dir("equal_time", "first_command");
    let scene = scene_path("cornell_mirror.obj");
    let scene = scene.to_str().unwrap();
    std::fs::write(
        dir.join("README.md"),
        format!(
            "# t\n\n```sh\nscripts/setup.sh && cargo run --release -- --scene {scene} --slice z=0 \
             --res 12 --weight unweighted -o out/plane.exr\n```\n"
        ),
    )
    .unwrap();
    let status = std::process::Command::new(ftpd3d_bin())
        .current_dir(&dir)
        .args(["--scene", scene, "--slice", "z=0", "--res", "12"])
        .args([
            "--weight",
            "unweighted",
            "--spp",
            "32",
            "--quiet",
            "--no-png",
        ])
        .args(["-o", "out/plane.exr"])
        .status()
        .unwrap();
    assert!(status.success());
    let (ok, out, err) = xtask_in(
        &dir,
        &[
            "first-command",
            "--tree",
            ".",
            "--no-run",
            "--ref-spp",
            "256",
            "--reference-bin",
            ftpd3d_bin().to_str().unwrap(),
            "--work-dir",
            "fc",
        ],
    );
    assert!(ok, "{err}");
    assert!(dir.join("fc/plane_ref256.exr").is_file());
    assert!(out.contains("32 spp"), "{out}");
    assert!(
        out.contains("reported p95 relative standard error"),
        "{out}"
    );
    // The resolved cells are at most the cells with σ_ref > 0.
    let counts: Vec<usize> = out
        .split("over the ")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .take(2)
        .collect();
    assert!(counts[0] <= counts[1] && counts[1] > 0, "{out}");
    std::fs::remove_dir_all(&dir).ok();
}
