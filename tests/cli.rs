//! The command line as a new user meets it: version, bad values with messages that name the flag,
//! and a real run writing its outputs.

use crate::support::{Run, ftpd3d, in_ci, scene_path, skip_without};
use std::path::Path;

#[test]
fn version_names_embree() {
    let Run { ok, out, .. } = ftpd3d(&["--version"]);
    assert!(ok);
    assert_eq!(out.trim(), format!("ftpd3d {}", ftpd3d::version_string()));
    assert!(
        out.contains("(Embree 3.") || out.contains("(Embree 4."),
        "{out}"
    );
}

#[test]
fn bad_values_are_refused_naming_the_flag() {
    let cornell = scene_path("cornell_mirror.obj");
    let cornell = cornell.to_str().unwrap();
    let plane = scene_path("diffuse_plane.obj");
    let cases: &[(&[&str], &str)] = &[
        (
            &["--slice", "z=0", "--t0", "2", "--t1", "1"],
            "--t0 2 is larger than --t1 1",
        ),
        (&["--slice", "z=0", "--t0", "-1"], "--t0 -1"),
        (&["--slice", "z=0", "--spp", "0"], "--spp 0"),
        (&["--slice", "z=0", "--angle", "0"], "--angle 0"),
        (&["--slice", "z=0", "--angle", "90"], "--angle 90"),
        (&["--slice", "z=5"], "--slice z=5: outside the scene bounds"),
        (&["--slice", "w=0"], "unknown axis 'w'"),
        (&["--slice", "z=0", "--res", "0"], "--res 0"),
        (&["--slice", "z=0", "--res", "99999999"], "--res 99999999"),
        (
            &["--slice", "z=0", "--window", "1,2,3"],
            "expected 4 comma-separated numbers",
        ),
        (
            &["--slice", "z=0", "-o", "/proc/ftpd3d/x.exr"],
            "-o /proc/ftpd3d/x.exr",
        ),
    ];
    for (args, msg) in cases {
        let mut all = vec!["--scene", cornell, "--quiet"];
        all.extend_from_slice(args);
        let Run { ok, err, .. } = ftpd3d(&all);
        assert!(!ok, "{args:?} should fail");
        assert!(err.contains(msg), "{args:?}: expected '{msg}' in: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        plane.to_str().unwrap(),
        "--slice",
        "z=0",
        "--quiet",
    ]);
    assert!(!ok);
    assert!(
        err.contains("--weight radiance") && err.contains("has no lights"),
        "{err}"
    );
    let Run { ok, err, .. } = ftpd3d(&["--scene", "no/such/scene.obj", "--slice", "z=0"]);
    assert!(!ok);
    assert!(
        err.contains("no/such/scene.obj: no such scene file"),
        "{err}"
    );
}

#[test]
fn a_run_writes_exr_and_png_and_never_leaves_temporaries() {
    // A directory the run has to make.
    let tmp = crate::support::temp_dir("cli", "run");
    let dir = tmp.join("out");
    let out = dir.join("c.exr");
    let cornell = scene_path("cornell_mirror.obj");
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        cornell.to_str().unwrap(),
        "--slice",
        "z=0",
        "--res",
        "24",
        "--spp",
        "8",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert!(
        err.contains("samples/s") && err.contains("rays/s") && err.contains("relative error"),
        "{err}"
    );
    assert!(out.is_file());
    assert!(dir.join("c.png").is_file(), "PNG preview next to the EXR");
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty());
}

/// A 4x4 unweighted slice of the Cornell box written to `out`, with `extra` arguments.
fn cornell_4x4(out: &Path, extra: &[&str]) -> Run {
    let cornell = scene_path("cornell_mirror.obj");
    let mut args = vec![
        "--scene",
        cornell.to_str().unwrap(),
        "--slice",
        "z=0",
        "--res",
        "4",
        "--weight",
        "unweighted",
        "--no-png",
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    ftpd3d(&args)
}

#[test]
fn without_a_budget_a_run_stops_at_p95_0_05_or_one_minute() {
    // A 4x4 unweighted slice reaches p95 relative error 0.05 in well under a minute: the run
    // stops there, deterministically, with the default budget recorded in the output.
    let dir = crate::support::temp_dir("cli", "default_budget");
    let out = dir.join("d.exr");
    let Run { ok, err, .. } = cornell_4x4(&out, &[]);
    assert!(ok, "{err}");
    assert!(
        err.contains("budget time 1m00s or target error 0.05"),
        "{err}"
    );
    let f = ftpd3d::output::exr::read_exr(&out).unwrap();
    let info = f.info("d.exr").unwrap();
    let target: Option<f64> = info
        .budget_target_error
        .as_deref()
        .and_then(|t| t.parse().ok());
    assert_eq!(target, Some(0.05), "{:?}", f.meta);
    assert_eq!(info.budget_time.as_deref(), Some("1m00s"), "{:?}", f.meta);
    let p95 = ftpd3d::render::error_stats(&f.cells).p95;
    assert!(p95 <= 0.05, "p95 {p95}: {err}");
    // A run that stops at a target error allocates adaptively from the third pass on.
    assert!(info.is_adaptive(), "{:?}", f.meta);
    assert!(
        err.contains("adaptive (at most 4x the uniform share)"),
        "{err}"
    );
    // More than the old default of 64 spp was needed (on the mean over cells: adaptive runs
    // differ per cell), and no spp cap was applied.
    let n: u64 = f.cells.iter().map(|c| c.n).sum();
    assert!(n > 64 * f.cells.len() as u64, "{:?}", f.meta);
}

#[test]
fn adaptive_sampling_is_the_default_of_target_error_runs_only() {
    // Which runs allocate adaptively, as the run's first summary line says (4x4 cells: short runs).
    let dir = crate::support::temp_dir("cli", "adaptive_default");
    let out = dir.join("a.exr");
    let run = |extra: &[&str]| cornell_4x4(&out, extra);
    let adaptive = "adaptive (at most";
    for (extra, want) in [
        (&["--target-error", "0.5"][..], true),
        (&["--target-error", "0.5", "--uniform"][..], false),
        (&["--target-error", "0.5", "--adaptive-cap", "2"][..], true),
        (&["--spp", "16"][..], false),
        (&["--spp", "16", "--adaptive"][..], true),
        (&["--time", "1s", "--pass-spp", "4"][..], false),
        (&["--uniform", "--spp", "16", "--batches", "2"][..], false),
    ] {
        let Run { ok, err, .. } = run(extra);
        assert!(ok, "{extra:?}: {err}");
        assert_eq!(err.contains(adaptive), want, "{extra:?}: {err}");
        if extra.contains(&"2") && want {
            assert!(err.contains("at most 2x"), "{extra:?}: {err}");
        }
    }
    // A cap on a uniform run, and both allocations at once, are refused with the option named.
    let Run { ok, err, .. } = run(&["--spp", "16", "--adaptive-cap", "8"]);
    assert!(
        !ok && err.contains("--adaptive-cap") && err.contains("--adaptive"),
        "{err}"
    );
    let Run { ok, err, .. } = run(&["--adaptive", "--uniform"]);
    assert!(!ok && err.contains("--uniform"), "{err}");
    // A file of uniform passes (as every default run before wrote) resumed by a target-error run
    // is refused, and the message says how to match it.
    let Run { ok, err, .. } = run(&["--target-error", "0.5", "--uniform"]);
    assert!(ok, "{err}");
    let resume = ["--target-error", "0.3", "--resume", out.to_str().unwrap()];
    let Run { ok, err, .. } = run(&resume);
    assert!(
        !ok && err.contains("adaptive differs") && err.contains("add --uniform"),
        "{err}"
    );
    let Run { ok, err, .. } = run(&[&resume[..], &["--uniform"]].concat());
    assert!(ok, "{err}");
}

#[test]
fn camera_runs_write_radiance_and_refuse_wrong_weightings() {
    let dir = crate::support::temp_dir("cli", "camera");
    let out = dir.join("cam.exr");
    let gltf = scene_path("cornell_point.gltf");
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        gltf.to_str().unwrap(),
        "--camera",
        "--size",
        "16,12",
        "--spp",
        "4",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let (w, h, r) = ftpd3d::output::exr::read_channel(&out, "radiance.G").unwrap();
    assert_eq!((w, h), (16, 12));
    assert!(r.iter().all(|x| x.is_finite() && *x >= 0.0));
    let cornell = scene_path("cornell_mirror.obj");
    let c = cornell.to_str().unwrap();
    for (args, msg) in [
        (vec!["--camera"], "defines no camera"),
        (
            vec!["--eye", "0,1,0", "--target", "0,1,0"],
            "target equals eye",
        ),
        (
            vec![
                "--eye", "0,1,0", "--target", "0,1,-1", "--weight", "radiance",
            ],
            "camera images are importance-weighted",
        ),
        (
            vec!["--slice", "z=0", "--weight", "importance"],
            "needs a camera",
        ),
        (
            vec!["--eye", "0,1,0", "--target", "0,1,-1", "--size", "0,10"],
            "--size 0,10",
        ),
    ] {
        let mut all = vec!["--scene", c, "--quiet", "-o", out.to_str().unwrap()];
        all.extend(args.iter().copied());
        let Run { ok, err, .. } = ftpd3d(&all);
        assert!(!ok && err.contains(msg), "{args:?}: {err}");
    }
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        gltf.to_str().unwrap(),
        "--camera",
        "nope",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(
        !ok && err.contains("--camera nope: no such camera (the scene has: inside)"),
        "{err}"
    );
}

#[test]
fn several_slices_and_arbitrary_planes_share_one_run() {
    let dir = crate::support::temp_dir("cli", "planes");
    let out = dir.join("c.exr");
    let cornell = scene_path("cornell_mirror.obj");
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        cornell.to_str().unwrap(),
        "--slices",
        "z=-0.5:0.5:3",
        "--plane",
        "origin=0,1,0 normal=1,0,1 size=1,0.5",
        "--res",
        "8",
        "--spp",
        "2",
        "--quiet",
        "--no-png",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    for name in ["c_z-0.5.exr", "c_z0.exr", "c_z0.5.exr", "c_plane3.exr"] {
        let f = ftpd3d::output::exr::read_exr(&dir.join(name)).unwrap();
        assert_eq!(f.total_samples(), 2 * (f.width * f.height) as u64, "{name}");
    }
    let plane = ftpd3d::output::exr::read_exr(&dir.join("c_plane3.exr")).unwrap();
    assert_eq!((plane.width, plane.height), (8, 4));
    assert!(plane.meta["plane"].starts_with("plane origin=0,1,0"));
    // A bad plane is refused before any work, naming the flag's problem.
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        cornell.to_str().unwrap(),
        "--plane",
        "origin=0,1,0",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("normal=x,y,z is required"), "{err}");
}

/// Every bad value is refused with its exact message before any work: no output file appears, and
/// an existing file at the output path is left as it was, also when the run fails later (a scene
/// that does not load, a weighting the scene cannot support).
#[test]
fn bad_values_write_nothing_and_never_truncate_an_existing_output() {
    let dir = crate::support::temp_dir("cli", "bad_values");
    let out = dir.join("o.exr");
    let o = out.to_str().unwrap();
    let cornell = scene_path("cornell_mirror.obj");
    let c = cornell.to_str().unwrap();
    let plane = scene_path("diffuse_plane.obj");
    let p = plane.to_str().unwrap();
    let broken = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/err_v_not_a_number.obj");
    let b = broken.to_str().unwrap();
    let angle = |a: &str| {
        format!(
            "--angle {a}: the perturbation half-angle must lie strictly between 0 and 90 degrees"
        )
    };
    let cases: Vec<(Vec<&str>, String)> = vec![
        (
            vec!["--scene", c, "--slice", "z=0", "--t0", "2", "--t1", "1"],
            "--t0 2 is larger than --t1 1: the run-length interval [t0, t1] is empty".into(),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--t0", "-1"],
            "--t0 -1: the shortest run length must be finite and ≥ 0".into(),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--t0", "NaN"],
            "--t0 NaN: the shortest run length must be finite and ≥ 0".into(),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--t1", "0"],
            "--t1 0: the longest run length must be finite and > 0".into(),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--t1", "inf"],
            "--t1 inf: the longest run length must be finite and > 0".into(),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--spp", "0"],
            "--spp 0: at least one sample per cell is needed".into(),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--angle", "0"],
            angle("0"),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--angle", "-5"],
            angle("-5"),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--angle", "90"],
            angle("90"),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--angle", "120"],
            angle("120"),
        ),
        (
            vec!["--scene", c, "--slice", "z=5"],
            "--slice z=5: outside the scene bounds, which span -1 to 1 along that axis".into(),
        ),
        (
            vec!["--scene", c, "--slice", "w=0"],
            "--slice 'w=0': unknown axis 'w' (use x, y or z)".into(),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--res", "0"],
            "--res 0: must be between 1 and 16384".into(),
        ),
        (
            vec!["--scene", c, "--slice", "z=0", "--res", "99999999"],
            "--res 99999999: must be between 1 and 16384".into(),
        ),
        (
            vec!["--scene", p, "--slice", "z=0"],
            format!(
                "--weight radiance: {p} has no lights (no emissive material: Ke in the .mtl); add \
                 one with --point-light X,Y,Z:R,G,B (position and radiant intensity), --sun \
                 X,Y,Z:R,G,B (direction and irradiance), --sky R,G,B or --env FILE, or use \
                 --weight unweighted"
            ),
        ),
        (
            vec!["--scene", b, "--slice", "z=0"],
            format!(
                "{b}:3: malformed vertex: expected 'v x y z' (optionally w, or r g b) with \
                 numbers, got 'v 1 0 abc'"
            ),
        ),
    ];
    for precious in [None, Some(b"an earlier result".as_slice())] {
        for (args, msg) in &cases {
            let _ = std::fs::remove_file(&out);
            if let Some(bytes) = precious {
                std::fs::write(&out, bytes).unwrap();
            }
            let mut all = args.clone();
            all.extend(["--quiet", "-o", o]);
            let Run { ok, err, .. } = ftpd3d(&all);
            assert!(!ok, "{args:?} should fail");
            assert_eq!(
                err.trim_end().lines().last(),
                Some(format!("error: {msg}").as_str()),
                "{args:?}"
            );
            match precious {
                None => assert!(!out.exists(), "{args:?} wrote {}", out.display()),
                Some(bytes) => assert_eq!(std::fs::read(&out).unwrap(), bytes, "{args:?}"),
            }
            let leftovers = std::fs::read_dir(&dir).unwrap().count();
            assert_eq!(
                leftovers,
                precious.is_some() as usize,
                "{args:?}: temporaries left"
            );
        }
    }
}

#[test]
fn summary_projects_the_cost_of_the_next_digit() {
    use ftpd3d::cli::report::cost_of_accuracy;
    use ftpd3d::ftpd::Weighting;
    // 1000 samples at 100/s: 4x needs 3000 more (30 s), 100x 99 000 more (16 min 30 s).
    let c = cost_of_accuracy(1000, 100.0, 0.2, Weighting::Unweighted).unwrap();
    assert_eq!(
        c,
        "cost of accuracy (error ∝ samples^-1/2): p95 0.100 needs 4x the samples (about 30s more \
         at this rate), p95 0.0200 100x (about 16m30s more)"
    );
    let r = cost_of_accuracy(1000, 100.0, 0.2, Weighting::Radiance).unwrap();
    assert!(r.starts_with(&c) && r.contains("converge"), "{r}");
    // Nothing to project from: no samples, no rate, no error, or a NaN.
    assert!(cost_of_accuracy(0, 100.0, 0.2, Weighting::Unweighted).is_none());
    assert!(cost_of_accuracy(1000, 0.0, 0.2, Weighting::Unweighted).is_none());
    assert!(cost_of_accuracy(1000, 100.0, 0.0, Weighting::Unweighted).is_none());
    assert!(cost_of_accuracy(1000, 100.0, f64::NAN, Weighting::Unweighted).is_none());
}

/// `--explain` says what each shipped scene's run simulates and skips. The expectations come from
/// the scene files themselves (their materials, lights and normals), not from the code under test.
#[test]
fn explain_lists_what_each_shipped_scene_simulates_and_skips() {
    let all = [
        "lambertian-reflection",
        "phong-lobe",
        "mirror-reflection",
        "fresnel-refraction",
        "shading-normals",
        "radiance-estimate",
        "area-lights",
        "point-lights",
        "spot-lights",
        "sun",
        "sky",
        "textures",
        "light-sampling",
        "mirror-images",
        "flatland",
    ];
    let lit = "radiance-estimate area-lights light-sampling";
    let cases: &[(&str, &[&str], String)] = &[
        (
            "stair_wall.obj",
            &[],
            format!("lambertian-reflection {lit}"),
        ),
        (
            "cornell_mirror.obj",
            &[],
            format!("lambertian-reflection mirror-reflection {lit} mirror-images"),
        ),
        (
            "cornell_mirror.obj",
            &["--weight", "unweighted"],
            "lambertian-reflection mirror-reflection".into(),
        ),
        (
            "glass_sphere.obj",
            &[],
            format!("lambertian-reflection fresnel-refraction {lit}"),
        ),
        (
            "glossy_panels.obj",
            &[],
            format!("lambertian-reflection phong-lobe mirror-reflection {lit} mirror-images"),
        ),
        (
            "smooth_sphere.obj",
            &[],
            format!("lambertian-reflection shading-normals {lit}"),
        ),
        (
            "diffuse_plane.obj",
            &["--weight", "unweighted"],
            "lambertian-reflection".into(),
        ),
        (
            "mirror_plane.obj",
            &["--weight", "unweighted"],
            "mirror-reflection".into(),
        ),
        (
            "plane_point.toml",
            &[],
            "lambertian-reflection radiance-estimate point-lights light-sampling".into(),
        ),
        (
            "cornell_point.gltf",
            &["--camera"],
            "lambertian-reflection radiance-estimate point-lights light-sampling".into(),
        ),
        (
            "flat_stair_wall.obj",
            &["--slice", "z=0", "--flatland"],
            format!("lambertian-reflection {lit} flatland"),
        ),
        (
            "flat_mirrors.obj",
            &["--slice", "z=0", "--flatland", "--weight", "unweighted"],
            "lambertian-reflection mirror-reflection flatland".into(),
        ),
        (
            "diffuse_plane.obj",
            &["--sun", "-0.3,1,0.2:3,3,3", "--sky", "0.2,0.3,0.5"],
            "lambertian-reflection radiance-estimate sun sky light-sampling".into(),
        ),
    ];
    for (scene, extra, simulates) in cases {
        let path = scene_path(scene);
        let mut args = vec!["--scene", path.to_str().unwrap(), "--explain"];
        args.extend(extra.iter());
        let Run { ok, out, err } = ftpd3d(&args);
        assert!(ok, "{scene}: {err}");
        let line = out
            .lines()
            .find_map(|l| l.strip_prefix("simulates  "))
            .unwrap_or_else(|| panic!("{scene}: no 'simulates' line in\n{out}"));
        assert_eq!(line, simulates, "{scene} {extra:?}");
        // Every other effect is listed as skipped, with a reason.
        let on: Vec<&str> = simulates.split(' ').collect();
        for e in all.iter().filter(|e| !on.contains(e)) {
            assert!(
                out.lines().any(|l| l
                    .trim_start_matches("skips")
                    .trim_start()
                    .starts_with(&format!("{e} ("))),
                "{scene}: {e} is neither simulated nor skipped:\n{out}"
            );
        }
    }
}

/// Every flag that takes numbers takes negative ones (they used to fail with "unexpected argument
/// '-0' found").
#[test]
fn flags_take_negative_numbers() {
    let dir = crate::support::temp_dir("cli", "negative_numbers");
    let cornell = scene_path("cornell_mirror.obj");
    let cornell = cornell.to_str().unwrap();
    let runs: &[&[&str]] = &[
        &[
            "--slice",
            "z=0",
            "--point-light",
            "-0.5,1.5,0:1,1,1",
            "--window",
            "-1,0,1,2",
            "-o",
            "a.exr",
        ],
        &[
            "--eye", "-1,1,3", "--target", "-0.2,1,0", "--up", "-0,1,0", "-o", "b.exr",
        ],
        &["--volume", "4", "--box", "-1,0,-1,1,2,1", "-o", "c.vti"],
        &[
            "--slice",
            "z=0",
            "--sun",
            "-0.3,1,-0.2:3,3,3:0",
            "--sky",
            "0.2,0.3,0.5",
            "-o",
            "d.exr",
        ],
    ];
    for args in runs {
        let mut all = vec![
            "--scene", cornell, "--quiet", "--no-png", "--res", "8", "--spp", "2",
        ];
        if args.contains(&"--eye") {
            all.retain(|a| *a != "--res" && *a != "8");
            all.extend(["--size", "8,8"]);
        }
        if args.contains(&"--volume") {
            all.retain(|a| *a != "--res" && *a != "8");
        }
        all.extend_from_slice(args);
        let r = crate::support::ftpd3d_in(&dir, &all);
        assert!(r.ok, "{args:?}: {}", r.err);
    }
    let a = ftpd3d::output::exr::read_exr(&dir.join("a.exr")).unwrap();
    assert_eq!(a.meta["point_lights"], "-0.5,1.5,0:1,1,1");
    let d = ftpd3d::output::exr::read_exr(&dir.join("d.exr")).unwrap();
    // The direction is stored normalised, with the diameter in degrees.
    let sun = &d.meta["sun"];
    assert!(sun.starts_with('-') && sun.ends_with(":3,3,3:0"), "{sun}");
    assert_eq!(d.meta["sky"], "0.2,0.3,0.5");
}

/// A camera far outside the scene: the default run lengths start where the scene starts, so the
/// image is not blank; run lengths given too short for the pairs to reach the scene are warned
/// about, naming --t0/--t1 (the image used to be σ = 0 everywhere without a word).
#[test]
fn far_cameras_reach_the_scene_and_blank_runs_are_warned_about() {
    let dir = crate::support::temp_dir("cli", "far_camera");
    let cornell = scene_path("cornell_mirror.obj");
    let cornell = cornell.to_str().unwrap();
    let common = [
        "--scene", cornell, "--eye", "0,1,40", "--target", "0,1,0", "--fov", "4", "--size", "8,8",
        "--spp", "4", "--no-png",
    ];
    let mut args = common.to_vec();
    args.extend(["-o", "far.exr"]);
    let r = crate::support::ftpd3d_in(&dir, &args);
    assert!(r.ok, "{}", r.err);
    assert!(!r.err.contains("no pair was deflected"), "{}", r.err);
    let f = ftpd3d::output::exr::read_exr(&dir.join("far.exr")).unwrap();
    let t0: f64 = f.meta["t0"].parse().unwrap();
    assert!(t0 > 38.0, "t0 {t0} starts at the scene, about 39 away");
    assert!(f.values().iter().any(|v| v.sigma > 0.0));
    let mut args = common.to_vec();
    args.extend(["--t0", "1", "--t1", "2", "-o", "short.exr"]);
    let r = crate::support::ftpd3d_in(&dir, &args);
    assert!(r.ok, "{}", r.err);
    assert!(
        r.err.contains(
            "warning: no pair was deflected: every walk ran straight for its whole run length (T \
             in [1.0000, 2.0000]) without reaching any geometry, so σ is 0 everywhere; give \
             longer run lengths with --t0/--t1"
        ),
        "{}",
        r.err
    );
}

/// Writes `f.exr` in `dir`: the Cornell box's z = 0 slice, 16 cells, 8 samples per cell.
fn write_small_cornell_field(dir: &std::path::Path) {
    let cornell = scene_path("cornell_mirror.obj");
    let r = crate::support::ftpd3d_in(
        dir,
        &[
            "--scene",
            cornell.to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "16",
            "--spp",
            "8",
            "--quiet",
            "--no-png",
            "-o",
            "f.exr",
        ],
    );
    assert!(r.ok, "{}", r.err);
}

/// Why python3 cannot run `probe` (a script that fails where a package is missing), if it cannot:
/// its last line of stderr.
fn python_missing(probe: &str) -> Option<String> {
    match std::process::Command::new("python3")
        .args(["-c", probe])
        .output()
    {
        Err(e) => Some(format!("python3: {e}")),
        Ok(o) if !o.status.success() => Some(
            String::from_utf8_lossy(&o.stderr)
                .lines()
                .last()
                .unwrap_or("")
                .to_string(),
        ),
        Ok(_) => None,
    }
}

/// The README's Python example (OpenEXR 3, `separate_channels=True`) reads part 0 of a field.
/// Needs python3 with the OpenEXR and numpy packages: CI installs them (`.ci/run`) and the test
/// fails there without them; elsewhere it says it was skipped.
#[test]
fn readme_python_example_reads_part_0() {
    let missing = python_missing("import OpenEXR, numpy");
    if skip_without("readme_python_example_reads_part_0", missing, in_ci()) {
        return;
    }
    let readme = std::fs::read_to_string("README.md").unwrap();
    let start = readme.find("<!-- python-example -->\n```python\n").unwrap();
    let code = &readme[start..];
    let code = &code[code.find("```python\n").unwrap() + 10..];
    let code = &code[..code.find("```").unwrap()];
    let dir = crate::support::temp_dir("cli", "python_example");
    write_small_cornell_field(&dir);
    std::fs::write(dir.join("example.py"), code).unwrap();
    let out = std::process::Command::new("python3")
        .current_dir(&dir)
        .args(["example.py", "f.exr"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}{}",
        stdout,
        String::from_utf8_lossy(&out.stderr)
    );
    // The mean σ it prints is the mean over valid cells that the project's own reader gives.
    let f = ftpd3d::output::exr::read_exr(&dir.join("f.exr")).unwrap();
    let vals: Vec<f64> = f
        .values()
        .iter()
        .filter(|v| v.valid)
        .map(|v| v.sigma as f32 as f64)
        .collect();
    let mean = vals.iter().sum::<f64>() / vals.len() as f64;
    let printed: f64 = stdout
        .split_whitespace()
        .skip_while(|w| *w != "sigma")
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert!(stdout.starts_with("radiance mean sigma"), "{stdout}");
    assert!(
        (printed - mean).abs() <= 1e-5 * mean,
        "{printed} against {mean}"
    );
}

/// FreeImage (through Python imageio, `EXR-FI`) reads part 0 of a field as it is written: an RGB
/// float image whose three channels are σ, bit for bit what the project's own reader gives.
/// FreeImage knows only R/G/B/A/Y channels of one type and reads only the first part, so this fails
/// unless part 0 holds them beside the named f32 channels. Needs python3 with imageio and numpy and
/// the FreeImage library (Debian's libfreeimage3; IMAGEIO_FREEIMAGE_LIB may name another): CI
/// installs them (`.ci/run`) and the test fails there without them; elsewhere it says it was skipped.
#[test]
fn freeimage_reads_part_0_through_imageio() {
    let missing = python_missing(
        "import numpy, imageio.v2\nfrom imageio.plugins._freeimage import fi\n\
         assert fi.has_lib(), 'no FreeImage library'",
    );
    if skip_without("freeimage_reads_part_0_through_imageio", missing, in_ci()) {
        return;
    }
    let dir = crate::support::temp_dir("cli", "freeimage");
    write_small_cornell_field(&dir);
    // Shape, then every pixel's R, G, B as the bits of the f32, rows from the top.
    let script = "import sys, numpy, imageio.v2 as iio\n\
                  im = iio.imread(sys.argv[1], format='EXR-FI')\n\
                  print(im.dtype, *im.shape)\n\
                  print(*numpy.ascontiguousarray(im, dtype=numpy.float32).view(numpy.uint32).ravel())\n";
    let out = std::process::Command::new("python3")
        .current_dir(&dir)
        .args(["-c", script, "f.exr"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "FreeImage refuses the file: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut lines = stdout.lines();
    assert_eq!(lines.next(), Some("float32 16 16 3"), "{stdout}");
    let bits: Vec<u32> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(|w| w.parse().unwrap())
        .collect();
    assert_eq!(bits.len(), 16 * 16 * 3);
    let (w, h, sigma) = ftpd3d::output::exr::read_channel(&dir.join("f.exr"), "ftpd").unwrap();
    assert_eq!((w, h), (16, 16));
    assert!(sigma.iter().any(|&s| s > 0.0), "a field with some σ > 0");
    for r in 0..h {
        for i in 0..w {
            // FreeImage row r from the top is field row h-1-r.
            let want = sigma[(h - 1 - r) * w + i].to_bits();
            let px = &bits[(r * w + i) * 3..][..3];
            assert_eq!(
                px, [want; 3],
                "pixel ({i}, {r}) from the top: FreeImage's R, G, B against σ"
            );
        }
    }
}
