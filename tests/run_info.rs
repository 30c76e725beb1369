//! The run's typed description ([`ftpd3d::run_info::RunInfo`]): files written by the code before it
//! still read, resume and merge; `flatland` must match; slices and volumes away from the scene get
//! run lengths that reach it.

use crate::support::{ftpd3d, ftpd3d_in, scene_path, temp_dir};
use ftpd3d::output::exr::read_exr;
use ftpd3d::run_info::{CellCount, DomainKind, Remaining};
use std::path::{Path, PathBuf};

/// Files written by ftpd3d at 5c13cb1, before `RunInfo` (see `tests/data/old_format/README.md`).
fn old(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/old_format")
        .join(name)
}

fn bits(f: &ftpd3d::field::Field) -> Vec<[u64; 5]> {
    f.cells
        .iter()
        .map(|c| {
            [
                c.n,
                c.batches,
                c.s0.to_bits(),
                c.s1.to_bits(),
                c.s2.to_bits(),
            ]
        })
        .collect()
}

#[test]
fn files_written_before_run_info_read_merge_and_resume() {
    let dir = temp_dir("run_info", "old_files");
    // A tile of the old code: every attribute reads, typed.
    let t0 = read_exr(&old("tile0.exr")).unwrap();
    let info = t0.info("tile0.exr").unwrap();
    assert_eq!(info.domain, Some(DomainKind::Slice));
    assert_eq!(info.plane.as_ref().unwrap().label, "z=0");
    assert_eq!(info.seed, Some(1));
    assert_eq!(info.tiles.len(), 1);
    assert_eq!(info.spp, Some(CellCount::Each(2)));
    assert_eq!(info.remaining_samples, Some(Remaining::Samples(0)));
    assert!(
        info.extra.is_empty(),
        "unknown attributes: {:?}",
        info.extra
    );
    // Its attributes are written back as they were read.
    assert_eq!(info.to_attributes(), t0.meta);
    // The same run today (from the directory the old files were made in, so that the scene's
    // path reads the same), whole; the old tile merged with today's other tile gives it bit for bit.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let run = |extra: &[&str]| {
        let mut a = vec![
            "--scene",
            "scenes/cornell_mirror.obj",
            "--slice",
            "z=0",
            "--res",
            "4",
            "--pass-spp",
            "1",
            "--quiet",
            "--no-png",
        ];
        a.extend_from_slice(extra);
        let r = ftpd3d_in(root, &a);
        assert!(r.ok, "{extra:?}: {}", r.err);
    };
    let merge = |inputs: &[&Path], output: &str| {
        let mut a: Vec<String> = vec!["merge".into()];
        a.extend(inputs.iter().map(|p| p.to_str().unwrap().to_string()));
        a.extend([
            "-o".into(),
            out(output),
            "--quiet".into(),
            "--no-png".into(),
        ]);
        let a: Vec<&str> = a.iter().map(String::as_str).collect();
        let r = ftpd3d(&a);
        assert!(r.ok, "{}", r.err);
        read_exr(&dir.join(output)).unwrap()
    };
    run(&["--spp", "2", "-o", &out("full.exr")]);
    run(&["--spp", "2", "--tile", "1/2", "-o", &out("tile1.exr")]);
    let m = merge(&[&old("tile0.exr"), &dir.join("tile1.exr")], "m.exr");
    // The estimator has changed since the old files were made (Russian roulette, QMC points), so
    // the merge holds the old tile's cells and today's other tile's cells, each bit for bit.
    let (mb, full, old0) = (
        bits(&m),
        bits(&read_exr(&dir.join("full.exr")).unwrap()),
        bits(&t0),
    );
    for (k, c) in mb.iter().enumerate() {
        let from_old = old0[k][0] > 0;
        assert_eq!(c, if from_old { &old0[k] } else { &full[k] }, "cell {k}");
    }
    assert!(old0.iter().any(|c| c[0] > 0) && old0.iter().any(|c| c[0] == 0));
    // A merged file of the old code (seeds 1 and 2) merges with a third seed of today.
    run(&["--spp", "2", "--seed", "3", "-o", &out("s3.exr")]);
    let m123 = merge(&[&old("merged_seeds.exr"), &dir.join("s3.exr")], "m123.exr");
    assert_eq!(m123.meta["seeds"], "1,2,3");
    assert_eq!(m123.meta["samples"], (3 * 2 * 16).to_string());
    // An old field resumes with more samples (today's estimator adds the last two passes).
    std::fs::copy(old("full_2spp.exr"), dir.join("resumed.exr")).unwrap();
    run(&["--spp", "4", "--resume", &out("resumed.exr")]);
    let resumed = read_exr(&dir.join("resumed.exr")).unwrap();
    assert_eq!(resumed.meta["passes"], "4", "{:?}", resumed.meta);
    assert!(resumed.cells.iter().all(|c| c.n == 4));
    // An old volume reads, typed.
    let v = ftpd3d::output::vti::read_vti(&old("volume.vti")).unwrap();
    let info = v.field.info("volume.vti").unwrap();
    assert_eq!(info.volume.as_ref().unwrap().dims, [3, 3, 3]);
    assert_eq!(info.to_attributes(), v.field.meta);
}

#[test]
fn flatland_must_match_for_merge_and_a_bad_attribute_is_named() {
    let dir = temp_dir("run_info", "flatland");
    let mut a = read_exr(&old("full_2spp.exr")).unwrap();
    ftpd3d::output::exr::write_exr(&dir.join("a.exr"), &a, &[]).unwrap();
    a.meta.insert("seed".into(), "9".into());
    a.meta.insert("flatland".into(), "true".into());
    ftpd3d::output::exr::write_exr(&dir.join("f.exr"), &a, &[]).unwrap();
    let r = ftpd3d_in(&dir, &["merge", "a.exr", "f.exr", "-o", "x.exr"]);
    assert!(
        !r.ok
            && r.err
                .contains("f.exr: flatland = true differs from a.exr's false"),
        "{}",
        r.err
    );
    // A file from before `flatland` was recorded counts as not flatland.
    a.meta.remove("flatland");
    ftpd3d::output::exr::write_exr(&dir.join("n.exr"), &a, &[]).unwrap();
    let r = ftpd3d_in(&dir, &["merge", "a.exr", "n.exr", "-o", "x.exr"]);
    assert!(r.ok, "{}", r.err);
    // A malformed attribute is refused on reading, naming it and the file.
    a.meta.insert("t1".into(), "long".into());
    let e = ftpd3d::output::exr::write_exr(&dir.join("bad.exr"), &a, &[]).unwrap_err();
    assert!(
        format!("{e:#}").contains("bad.exr: attribute 't1' = 'long' is not a number"),
        "{e:#}"
    );
}

/// A slice window (and a volume box) away from the scene: the default run lengths start where the
/// scene starts as seen from it, so pairs reach the scene (on 5c13cb1 every σ was 0); run lengths
/// given too short for that are warned about, naming --t0/--t1.
#[test]
fn windows_and_boxes_away_from_the_scene_reach_it() {
    let dir = temp_dir("run_info", "far_window");
    let cornell = scene_path("cornell_mirror.obj");
    let cornell = cornell.to_str().unwrap();
    // x = 0 spans (z, y): the window lies 2 in front of the room's z = 1 wall.
    let common = [
        "--scene",
        cornell,
        "--slice",
        "x=0",
        "--window",
        "3,0.5,4,1.5",
        "--res",
        "4",
        "--spp",
        "32",
        "--weight",
        "unweighted",
        "--no-png",
    ];
    let mut args = common.to_vec();
    args.extend(["-o", "far.exr"]);
    let r = ftpd3d_in(&dir, &args);
    assert!(r.ok, "{}", r.err);
    assert!(!r.err.contains("no pair was deflected"), "{}", r.err);
    let f = read_exr(&dir.join("far.exr")).unwrap();
    let info = f.info("far.exr").unwrap();
    let d = 12f64.sqrt();
    let near = |x: Option<f64>, y: f64| x.is_some_and(|x| (x - y).abs() < 1e-12);
    assert!(near(info.t0, 2.0 + 0.1 * d), "{:?}", info.t0);
    assert!(near(info.t1, 2.0 + 0.5 * d), "{:?}", info.t1);
    assert!(f.values().iter().any(|v| v.sigma > 0.0));
    // Too short to get there: warned about, naming the flags.
    let mut args = common.to_vec();
    args.extend(["--t0", "0.5", "--t1", "1", "-o", "short.exr"]);
    let r = ftpd3d_in(&dir, &args);
    assert!(r.ok, "{}", r.err);
    assert!(
        r.err.contains("no pair was deflected") && r.err.contains("--t0/--t1"),
        "{}",
        r.err
    );
    // A box beside the room: the same offset.
    let r = ftpd3d_in(
        &dir,
        &[
            "--scene",
            cornell,
            "--volume",
            "2",
            "--box",
            "-0.5,0.5,3,0.5,1.5,4",
            "--spp",
            "32",
            "--weight",
            "unweighted",
            "--no-png",
            "-o",
            "far.vti",
        ],
    );
    assert!(r.ok, "{}", r.err);
    assert!(!r.err.contains("no pair was deflected"), "{}", r.err);
    let v = ftpd3d::output::vti::read_vti(&dir.join("far.vti")).unwrap();
    assert!(near(v.field.info("far.vti").unwrap().t0, 2.0 + 0.1 * d));
    assert!(v.field.values().iter().any(|v| v.sigma > 0.0));
}

/// The offset is the distance between the slice's rectangle and the scene's bounds: exact for
/// axis slices, by search for tilted planes; 0 wherever they meet.
#[test]
fn plane_to_box_distances() {
    use ftpd3d::domain::Plane;
    use ftpd3d::scene::Aabb;
    use glam::DVec3;
    let b = Aabb {
        min: DVec3::new(-1.0, 0.0, -1.0),
        max: DVec3::new(1.0, 2.0, 1.0),
    };
    let axis = |w: [f64; 4]| {
        Plane::axis_slice(&b, "x=0".parse().unwrap(), Some(w), 4)
            .unwrap()
            .distance_to_box(&b)
    };
    assert_eq!(axis([-1.0, 0.0, 1.0, 2.0]), 0.0);
    assert_eq!(axis([0.5, 1.5, 3.0, 4.0]), 0.0, "overlapping a corner");
    assert_eq!(axis([3.0, 0.5, 4.0, 1.5]), 2.0);
    assert_eq!(axis([4.0, 6.0, 5.0, 7.0]), 5.0, "3-4-5 from the corner");
    // A plane tilted 45° about y, centred 3 beyond the box's x = 1 face along the normal.
    let spec = ftpd3d::domain::slice::PlaneSpec {
        origin: DVec3::new(4.0, 1.0, 0.0),
        normal: DVec3::new(1.0, 0.0, 1.0).normalize(),
        up: None,
        size: Some((0.5, 0.5)),
    };
    let p = Plane::from_spec(&b, &spec, 4).unwrap();
    // Against the least distance over a fine grid of the rectangle's points.
    let n = 400;
    let mut best = f64::INFINITY;
    for i in 0..=n {
        for j in 0..=n {
            let (s, t) = (i as f64 / n as f64, j as f64 / n as f64);
            let c = p.origin + p.u_axis * p.size.0 * s + p.v_axis * p.size.1 * t;
            best = best.min(b.distance(c));
        }
    }
    let d = p.distance_to_box(&b);
    assert!(d <= best + 1e-12 && d > best - 1e-3, "{d} against {best}");
    assert!(d > 2.0, "{d}");
    let through = ftpd3d::domain::slice::PlaneSpec {
        origin: DVec3::new(0.0, 1.0, 0.0),
        ..spec
    };
    let p = Plane::from_spec(&b, &through, 4).unwrap();
    assert!(p.distance_to_box(&b) < 1e-12);
}
