//! `cargo xtask efficiency`: time to the same error as a baseline build, here this tree's binary
//! against itself on a small slice.

use crate::support::{ftpd3d_bin, num, read_csv, scene_path, temp_dir, xtask_in};

#[test]
fn efficiency_compares_two_builds_level_by_level() {
    let dir = temp_dir("efficiency", "self");
    let scene = scene_path("cornell_mirror.obj");
    let bin = ftpd3d_bin().to_str().unwrap();
    let (ok, out, err) = xtask_in(
        &dir,
        &[
            "efficiency",
            "--baseline",
            bin,
            "--candidate",
            bin,
            "--scene",
            scene.to_str().unwrap(),
            "--res",
            "16",
            "--weight",
            "unweighted",
            "--start-spp",
            "4",
            "--max-spp",
            "16",
            "--ref-factor",
            "4",
            "--work-dir",
            "eff",
        ],
    );
    assert!(ok, "{err}");
    // The reference and every level of both binaries are said as they finish.
    assert!(
        err.contains("cornell_mirror unweighted: reference 64 spp"),
        "{err}"
    );
    // The table: a header, its rule, and one row per error measure.
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 4, "{out}");
    assert!(
        lines[0].starts_with("| scene | weighting | error |"),
        "{out}"
    );
    assert!(lines[2].starts_with("| cornell_mirror | unweighted | RMSE σ |"));
    assert!(lines[3].starts_with("| cornell_mirror | unweighted | p95 rel |"));
    // Every level of both binaries, with its own seed (1, 2, 3), measured against the reference.
    let (header, rows) = read_csv(&dir.join("eff/efficiency.csv"));
    assert_eq!(header[..4], ["scene", "weighting", "binary", "spp"]);
    for binary in ["base", "new"] {
        let levels: Vec<f64> = rows
            .iter()
            .filter(|r| r["binary"] == binary)
            .map(|r| num(r, "spp"))
            .collect();
        assert_eq!(levels, [4.0, 8.0, 16.0], "{binary}");
    }
    for r in &rows {
        assert!(num(r, "seconds") > 0.0 && num(r, "net_rmse") > 0.0, "{r:?}");
        assert_eq!(num(r, "cells"), 16.0 * 16.0, "{r:?}");
    }
    for f in [
        "cornell_mirror_unweighted_base_spp4.exr",
        "cornell_mirror_unweighted_new_spp16.exr",
    ] {
        assert!(dir.join("eff").join(f).is_file(), "{f}");
    }

    // Importance weighting needs a camera; a missing baseline is named by its flag.
    for (args, msg) in [
        (
            ["--baseline", bin, "--weight", "importance"],
            "--weight importance needs a camera",
        ),
        (
            ["--baseline", "no/such/ftpd3d", "--weight", "unweighted"],
            "--baseline no/such/ftpd3d: no such file",
        ),
    ] {
        let mut all = vec!["efficiency", "--scene", scene.to_str().unwrap()];
        all.extend(args);
        let (ok, _, err) = xtask_in(&dir, &all);
        assert!(!ok && err.contains(msg), "{args:?}: {err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
