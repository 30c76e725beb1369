//! What the command line does with absurd flags, signals during set-up and blank results
//! (issue 33, items 4-6): each refused or reported in words that name the flag.

use crate::support::{ftpd3d, ftpd3d_in, scene_path, temp_dir};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// Waits for `child` at most `limit`; kills it (and fails) when it runs longer.
fn wait_at_most(child: &mut Child, limit: Duration, what: &str) -> ExitStatus {
    let t = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if t.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn stderr_of(child: &mut Child) -> String {
    let mut s = String::new();
    use std::io::Read;
    child.stderr.take().unwrap().read_to_string(&mut s).unwrap();
    s
}

/// `--threads 100000` is refused before anything starts, naming the flag and the cores (it used
/// to start threads for minutes).
#[test]
fn absurd_thread_counts_are_refused_at_once() {
    let dir = temp_dir("cli_guards", "threads");
    let cornell = scene_path("cornell_mirror.obj");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .current_dir(&dir)
        .args([
            "--scene",
            cornell.to_str().unwrap(),
            "--slice",
            "z=0",
            "--res",
            "4",
            "--spp",
            "1",
            "--threads",
            "100000",
            "-o",
            "t.exr",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status = wait_at_most(&mut child, Duration::from_secs(20), "--threads 100000");
    let err = stderr_of(&mut child);
    assert!(!status.success(), "{err}");
    assert!(
        err.contains("--threads") && err.contains("cores"),
        "the error names the flag and the cores: {err}"
    );
    assert!(!dir.join("t.exr").exists());
}

/// A grid of `n` × `n` quads at z = 0 with a light above: a scene whose loading takes a while.
fn write_big_obj(path: &Path, n: usize) {
    use std::fmt::Write;
    let mut s = String::with_capacity(n * n * 48);
    for j in 0..=n {
        for i in 0..=n {
            writeln!(s, "v {} {} 0", i as f64 / n as f64, j as f64 / n as f64).unwrap();
        }
    }
    let id = |i: usize, j: usize| j * (n + 1) + i + 1;
    for j in 0..n {
        for i in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            writeln!(s, "f {a} {b} {c} {d}").unwrap();
        }
    }
    std::fs::write(path, s).unwrap();
}

/// Whether the process `pid` has started its signal-handling thread (ctrlc names it `ctrl-c`).
fn handler_installed(pid: u32) -> bool {
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return false;
    };
    tasks
        .flatten()
        .any(|t| std::fs::read_to_string(t.path().join("comm")).is_ok_and(|c| c.trim() == "ctrl-c"))
}

/// A SIGTERM while the scene is still loading ends the run within seconds, says so, and writes
/// nothing (it used to be stored until the passes started, after the whole set-up, which then
/// wrote an empty partial result).
#[test]
fn a_signal_during_set_up_ends_the_run_at_once_writing_nothing() {
    if !Path::new("/proc/self/task").exists() {
        eprintln!("skipped: no /proc to see the signal handler start");
        return;
    }
    let dir = temp_dir("cli_guards", "setup_signal");
    let scene = dir.join("big.obj");
    write_big_obj(&scene, 700);
    let mut child = Command::new(env!("CARGO_BIN_EXE_ftpd3d"))
        .current_dir(&dir)
        .args([
            "--scene",
            "big.obj",
            "--slice",
            "x=0.5",
            "--res",
            "4",
            "--spp",
            "100000",
            "--weight",
            "unweighted",
            "--no-png",
            "-o",
            "big.exr",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t = Instant::now();
    while !handler_installed(child.id()) {
        assert!(t.elapsed() < Duration::from_secs(30), "no signal handler");
        std::thread::sleep(Duration::from_millis(2));
    }
    let sent = Instant::now();
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = wait_at_most(&mut child, Duration::from_secs(10), "SIGTERM during set-up");
    let err = stderr_of(&mut child);
    assert!(
        sent.elapsed() < Duration::from_secs(5),
        "{:?}",
        sent.elapsed()
    );
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(
        err.contains("setting up") && err.contains("without writing"),
        "{err}"
    );
    assert!(
        !err.contains("scene big.obj:"),
        "the signal came during loading: {err}"
    );
    assert!(!dir.join("big.exr").exists(), "nothing is written");
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .filter(|n| n != "big.obj")
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// Negative values of numeric and vector flags reach the flag's own check, whose message names
/// the flag (clap used to answer "unexpected argument '-1' found").
#[test]
fn negative_values_name_their_flag() {
    let cornell = scene_path("cornell_mirror.obj");
    let cases: &[(&[&str], &str)] = &[
        (&["--spp", "-1"], "--spp"),
        (&["--time", "-5s"], "--time"),
        (&["--seed", "-1"], "--seed"),
        (&["--sky", "-1,-1,-1"], "--sky"),
        (&["--threads", "-1"], "--threads"),
        (&["--res", "-1"], "--res"),
        (&["--batches", "-1"], "--batches"),
        (&["--pass-spp", "-1"], "--pass-spp"),
        (&["--target-error", "-1"], "--target-error"),
        (&["--checkpoint-every", "-1m"], "--checkpoint-every"),
        (&["--pairs", "-1,1,1,1"], "--pairs"),
        (&["--tile", "-1/2"], "--tile"),
        (&["--volume", "-2"], "--volume"),
        (&["--size", "-1,2"], "--size"),
        (&["--adaptive", "--adaptive-cap", "-1"], "--adaptive-cap"),
        (&["--fov", "-10"], "--fov"),
    ];
    for (extra, flag) in cases {
        let mut args = vec![
            "--scene",
            cornell.to_str().unwrap(),
            "--slice",
            "z=0",
            "--quiet",
        ];
        if extra.contains(&"--volume") {
            args.truncate(2);
        }
        if extra.contains(&"--size") || extra.contains(&"--fov") {
            args.truncate(2);
            args.extend(["--eye", "0,1,3", "--target", "0,1,0"]);
        }
        args.extend_from_slice(extra);
        let r = ftpd3d(&args);
        assert!(!r.ok, "{extra:?} was taken");
        assert!(
            r.err.contains(flag) && !r.err.contains("unexpected argument"),
            "{extra:?}: {}",
            r.err
        );
    }
    let r = ftpd3d(&["converge", "--seed", "-1", "--threads", "-2"]);
    assert!(
        r.err.contains("--seed") || r.err.contains("--threads"),
        "{}",
        r.err
    );
    assert!(!r.err.contains("unexpected argument"), "{}", r.err);
}

/// `--window` takes part of an arbitrary plane, in the plane's own coordinates from its origin
/// (it used to be ignored); with the plane's size= as well it is refused.
#[test]
fn window_takes_part_of_a_plane() {
    let dir = temp_dir("cli_guards", "plane_window");
    let cornell = scene_path("cornell_mirror.obj");
    let plane = "origin=0,1,0 normal=0,0,1";
    let common = [
        "--scene",
        cornell.to_str().unwrap(),
        "--plane",
        plane,
        "--res",
        "4",
        "--spp",
        "1",
        "--quiet",
        "--no-png",
    ];
    let mut args = common.to_vec();
    args.extend(["--window", "-0.1,-0.1,0.1,0.1", "-o", "w.exr"]);
    let r = ftpd3d_in(&dir, &args);
    assert!(r.ok, "{}", r.err);
    let f = ftpd3d::output::exr::read_exr(&dir.join("w.exr")).unwrap();
    assert_eq!(f.meta["plane.size"], "0.2,0.2");
    assert_eq!(f.meta["plane.origin"], "-0.1,0.9,0");
    let r = ftpd3d_in(
        &dir,
        &[
            "--scene",
            cornell.to_str().unwrap(),
            "--plane",
            "origin=0,1,0 normal=0,0,1 size=1,1",
            "--window",
            "-0.1,-0.1,0.1,0.1",
            "--quiet",
            "-o",
            "both.exr",
        ],
    );
    assert!(!r.ok);
    assert!(
        r.err.contains("--window") && r.err.contains("size="),
        "{}",
        r.err
    );
}

/// A flat model at z = 2.3 (f32 2.2999999523…) takes `--slice z=2.3` (it was refused as outside
/// bounds spanning 2.299999952316284 to 2.299999952316284); a slice well off it is still refused.
#[test]
fn a_slice_at_a_flat_models_coordinate_is_taken() {
    let dir = temp_dir("cli_guards", "flat_slice");
    std::fs::write(
        dir.join("flat.obj"),
        "v 0 0 2.3\nv 1 0 2.3\nv 1 1 2.3\nv 0 1 2.3\nf 1 2 3 4\n",
    )
    .unwrap();
    let run = |z: &str| {
        ftpd3d_in(
            &dir,
            &[
                "--scene",
                "flat.obj",
                "--slice",
                z,
                "--res",
                "4",
                "--spp",
                "1",
                "--weight",
                "unweighted",
                "--quiet",
                "--no-png",
                "-o",
                "f.exr",
            ],
        )
    };
    let r = run("z=2.3");
    assert!(r.ok, "{}", r.err);
    let r = run("z=2.3001");
    assert!(
        !r.ok && r.err.contains("outside the scene bounds"),
        "{}",
        r.err
    );
}

/// A slice through the inside of a closed box gives no valid cell: the run says so in one line,
/// with the cause and the flags that move the slice (it used to end without a word).
#[test]
fn a_slice_inside_a_closed_object_says_so() {
    let dir = temp_dir("cli_guards", "closed_box");
    std::fs::write(
        dir.join("box.obj"),
        "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n",
    )
    .unwrap();
    let r = ftpd3d_in(
        &dir,
        &[
            "--scene",
            "box.obj",
            "--slice",
            "z=0",
            "--point-light",
            "0,3,0:1,1,1",
            "--res",
            "6",
            "--spp",
            "2",
            "--no-png",
            "-o",
            "b.exr",
        ],
    );
    assert!(r.ok, "{}", r.err);
    let f = ftpd3d::output::exr::read_exr(&dir.join("b.exr")).unwrap();
    assert!(
        f.valid().iter().all(|v| !v),
        "the slice is inside: no valid cell"
    );
    let lines: Vec<&str> = r
        .err
        .lines()
        .filter(|l| l.contains("no valid cell"))
        .collect();
    assert_eq!(lines.len(), 1, "{}", r.err);
    assert!(
        lines[0].contains("inside a closed object") && lines[0].contains("--slice"),
        "{}",
        lines[0]
    );
    // Outside the box, with the same light: valid cells, and no such line.
    let r = ftpd3d_in(
        &dir,
        &[
            "--scene",
            "box.obj",
            "--slice",
            "z=0",
            "--window",
            "-3,-3,3,3",
            "--point-light",
            "0,3,0:1,1,1",
            "--res",
            "6",
            "--spp",
            "2",
            "--no-png",
            "-o",
            "c.exr",
        ],
    );
    assert!(r.ok, "{}", r.err);
    assert!(!r.err.contains("no valid cell"), "{}", r.err);
}

/// The shipped glTF room seen from its own camera: the default run lengths reach the walls, so the
/// image shows σ > 0 in valid cells (T ended 0.2 short of the back wall, σ was 0 everywhere).
#[test]
fn the_shipped_gltf_camera_shows_a_field() {
    let dir = temp_dir("cli_guards", "gltf_camera");
    let scene = scene_path("cornell_point.gltf");
    let r = ftpd3d_in(
        &dir,
        &[
            "--scene",
            scene.to_str().unwrap(),
            "--camera",
            "--size",
            "8,8",
            "--spp",
            "4",
            "--no-png",
            "-o",
            "cam.exr",
        ],
    );
    assert!(r.ok, "{}", r.err);
    assert!(!r.err.contains("no pair was deflected"), "{}", r.err);
    let f = ftpd3d::output::exr::read_exr(&dir.join("cam.exr")).unwrap();
    let info = f.info("cam.exr").unwrap();
    // The camera at z = 0.95 sees the back wall (z = -1) 1.95 away, nearest along its centre.
    let t0 = info.t0.unwrap();
    let d = 12f64.sqrt();
    assert!((t0 - (1.95 + 0.1 * d)).abs() < 1e-3, "t0 {t0}");
    assert!(f.values().iter().any(|v| v.valid && v.sigma > 0.0));
}
