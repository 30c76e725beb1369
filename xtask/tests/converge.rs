//! `cargo xtask converge --baseline`: the report of `ftpd3d converge` with the curves of two
//! builds, here this tree's binary against itself.

use crate::support::{ftpd3d_bin, num, read_csv, scene_path, temp_dir, xtask_in};

#[test]
fn converge_with_a_baseline_draws_both_binaries() {
    // This tree's binary is its own baseline: the two curves are the same estimator on
    // independent seeds, so their slopes must agree within their standard errors.
    let dir = temp_dir("conv", "baseline");
    let scene = scene_path("cornell_mirror.obj");
    let bin = ftpd3d_bin().to_str().unwrap();
    let (ok, out, err) = xtask_in(
        &dir,
        &[
            "converge",
            "--candidate",
            bin,
            "--scene",
            scene.to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "24",
            "--weight",
            "unweighted",
            "--start-spp",
            "4",
            "--max-spp",
            "256",
            "--baseline",
            bin,
            "--out-dir",
            "conv",
        ],
    );
    assert!(ok, "{err}");
    assert!(out.contains("unweighted (baseline) slope vs time"), "{out}");
    let conv = dir.join("conv");
    let (header, rows) = read_csv(&conv.join("converge.csv"));
    assert_eq!(header.last().map(String::as_str), Some("binary"));
    let levels = [4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0];
    let base: Vec<_> = rows.iter().filter(|r| r["binary"] == "baseline").collect();
    let this: Vec<_> = rows.iter().filter(|r| r["binary"] == "this").collect();
    assert_eq!(base.len() + this.len(), rows.len());
    for (curve, first_seed) in [(&base, 1.0), (&this, 8.0)] {
        let spp: Vec<f64> = curve.iter().map(|r| num(r, "spp")).collect();
        assert_eq!(spp, levels);
        // No run of one binary shares a seed with a run of the other.
        let seeds: Vec<f64> = curve.iter().map(|r| num(r, "seed")).collect();
        let want: Vec<f64> = (0..7).map(|k| first_seed + k as f64).collect();
        assert_eq!(seeds, want);
        for r in curve.iter() {
            assert!(num(r, "seconds") > 0.0);
            assert_eq!(num(r, "samples"), num(r, "spp") * 24.0 * 24.0);
        }
    }
    // The baseline's top run is the reference of both curves: its own row is left out, every
    // row of this binary is measured against it.
    let (top, rest) = base.split_last().unwrap();
    assert_eq!((top["rmse"].as_str(), top["in_fit"].as_str()), ("", "0"));
    assert!(rest.iter().all(|r| r["in_fit"] == "1"));
    for r in &this {
        assert_eq!(r["reference"], "baseline's 256 spp run");
        assert_eq!(r["in_fit"], "1");
        assert!(num(r, "net_rmse") > 0.0);
    }
    assert!(conv.join("runs/baseline_unweighted_spp256.exr").is_file());
    assert!(conv.join("unweighted_spp256.exr").is_file());

    let (_, fits) = read_csv(&conv.join("converge_fit.csv"));
    assert_eq!(fits.len(), 2);
    let fit = |b: &str| fits.iter().find(|f| f["binary"] == b).unwrap();
    let (fb, ft) = (fit("baseline"), fit("this"));
    assert_eq!((num(fb, "points"), num(ft, "points")), (6.0, 7.0));
    let (sb, st) = (num(fb, "slope_spp"), num(ft, "slope_spp"));
    let se = num(fb, "slope_spp_se").hypot(num(ft, "slope_spp_se"));
    assert!(
        (sb - st).abs() < 3.0 * se + 0.02,
        "same estimator, slopes {sb} and {st} (± {se})"
    );
    let png = std::fs::read(conv.join("converge.png")).unwrap();
    assert!(png.len() > 10_000, "a plot, not an empty image");

    // Estimator flags reach both binaries; a missing baseline is named.
    let (ok, _, err) = xtask_in(
        &dir,
        &[
            "converge",
            "--candidate",
            bin,
            "--scene",
            scene.to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "8",
            "--weight",
            "unweighted",
            "--t1=1.5",
            "--max-spp",
            "16",
            "--baseline",
            bin,
            "--out-dir",
            "conv2",
            "--quiet",
        ],
    );
    assert!(ok, "{err}");
    for f in ["baseline_unweighted_spp16.exr", "this_unweighted_spp4.exr"] {
        let field = ftpd3d::output::exr::read_exr(&dir.join("conv2/runs").join(f)).unwrap();
        assert_eq!(field.info(f).unwrap().t1, Some(1.5), "{f}");
    }
    let (ok, _, err) = xtask_in(
        &dir,
        &[
            "converge",
            "--candidate",
            bin,
            "--scene",
            scene.to_str().unwrap(),
            "--slice",
            "z=0",
            "--baseline",
            "no/such/ftpd3d",
            "--out-dir",
            "conv3",
        ],
    );
    assert!(
        !ok && err.contains("--baseline no/such/ftpd3d: no such file"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
