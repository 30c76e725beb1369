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

#[test]
fn error_time_runs_a_ladder_against_equal_times_reference_and_plots_it() {
    let dir = temp_dir("equal_time", "error_time");
    let scene = scene_path("cornell_mirror.obj");
    let bin = ftpd3d_bin().to_str().unwrap();
    let (a, b) = (format!("a={bin}"), format!("b={bin}"));
    let args = [
        "error-time",
        "--binary",
        &a,
        "--binary",
        &b,
        "--scene",
        scene.to_str().unwrap(),
        "--res",
        "8",
        "--weight",
        "unweighted",
        "--seconds",
        "0.25,0.5",
        "--rounds",
        "2",
        "--ref-seconds",
        "1",
        "--threads",
        "1",
        "--work-dir",
        "et",
        "--plot",
        "img/et.png",
    ];
    let (ok, out, err) = xtask_in(&dir, &args);
    assert!(ok, "{err}");
    // The reference is equal-time's: the same file name for the same slice and budget.
    assert!(
        dir.join("et/ref_cornell_mirror_z0_unweighted_r8_1s.exr")
            .is_file()
    );
    assert!(dir.join("img/et.png").is_file() && dir.join("img/et-compute.png").is_file());
    // Every binary at every budget in every round, the ladder walked down in the second round.
    let (_, rows) = read_csv(&dir.join("et/error-time.csv"));
    let order: Vec<(&str, f64)> = rows
        .iter()
        .map(|r| (r["binary"].as_str(), num(r, "budget_s")))
        .collect();
    assert_eq!(
        order,
        [
            ("a", 0.25),
            ("b", 0.25),
            ("a", 0.5),
            ("b", 0.5),
            ("a", 0.5),
            ("b", 0.5),
            ("a", 0.25),
            ("b", 0.25)
        ]
    );
    assert!(out.contains("| b | 0.5 | 2 |"), "{out}");
    // The same table again from the CSV, without running anything.
    let replot = [
        "error-time",
        "--from-csv",
        "et/error-time.csv",
        "--plot",
        "img/again.png",
    ];
    let (ok, again, err) = xtask_in(&dir, &replot);
    assert!(ok, "{err}");
    let table = |s: &str| s.split("\nplots:").next().unwrap().to_string();
    assert_eq!(table(&again), table(&out));
    assert!(dir.join("img/again.png").is_file());
    std::fs::remove_dir_all(&dir).ok();
}
