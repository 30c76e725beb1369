//! Volumes: the `.vti` as an independent VTK reader sees it, its exact header, agreement with a
//! slice through the same points, and the memory check that refuses impossible grids.

use crate::support::{Run, ftpd3d, read_vti, scene_path, temp_dir};
use ftpd3d::app::{DomainArg, Job, run_job};
use ftpd3d::domain::VolumeRes;
use ftpd3d::domain::slice::SliceArg;
use ftpd3d::field::Field;
use ftpd3d::ftpd::Weighting;
use ftpd3d::params::EstimatorArgs;
use ftpd3d::render::RenderOptions;
use std::path::Path;

fn volume_job(res: VolumeRes, bbox: Option<[f64; 6]>, spp: u32, out: &Path) -> Job {
    Job {
        scene: scene_path("cornell_mirror.obj"),
        domain: DomainArg::Volume { res, bbox },
        lights: vec![],
        flatland: false,
        checkpoint_every: None,
        resume: None,
        command: None,
        separatrices: None,
        load: Default::default(),
        estimator: EstimatorArgs {
            weighting: Weighting::Radiance,
            t0: None,
            t1: None,
            angle_deg: 2.0,
            max_bounces: 32,
            radiance_bounces: None,
            design: Default::default(),
            guide: false,
        },
        render: RenderOptions {
            spp,
            batches: 4,
            seed: 7,
            threads: 0,
            progress: false,
            ..Default::default()
        },
        output: out.to_path_buf(),
        png: false,
        quiet: true,
    }
}

#[test]
fn vti_read_by_vtkio_equals_the_field() {
    let dir = temp_dir("volume", "vtkio");
    let out = dir.join("c.vti");
    let field = run_job(&volume_job(VolumeRes::Dims([6, 5, 4]), None, 8, &out))
        .unwrap()
        .remove(0)
        .field;
    let vti = read_vti(&out);
    assert_eq!(
        vti.extent,
        vtkio::model::Extent::Ranges([0..=5, 0..=4, 0..=3])
    );
    // Cornell box: [-1,1] x [0,2] x [-1,1]; point data at voxel centres.
    let sp = [2.0 / 6.0, 2.0 / 5.0, 2.0 / 4.0];
    let or = [-1.0 + sp[0] / 2.0, sp[1] / 2.0, -1.0 + sp[2] / 2.0];
    for a in 0..3 {
        assert!(
            (vti.spacing[a] as f64 - sp[a]).abs() < 1e-6,
            "{:?}",
            vti.spacing
        );
        assert!(
            (vti.origin[a] as f64 - or[a]).abs() < 1e-6,
            "{:?}",
            vti.origin
        );
    }
    // vtkio drops arrays it cannot read, so the full list proves every one was readable.
    assert_eq!(
        vti.names(),
        [
            "ftpd",
            "ftpd.stderr",
            "ftpd.relerr",
            "ftpd.mean",
            "ftpd.m2",
            "weight",
            "fluence",
            "grad.mag",
            "valid",
            "samples",
            "batches",
            "groups",
            "exact.sum.w",
            "exact.sum.wd",
            "exact.sum.wd2",
            "exact.sum.fluence.R",
            "exact.sum.fluence.G",
            "exact.sum.fluence.B",
            "exact.sum.w.w",
            "exact.sum.w.wd",
            "exact.sum.w.wd2",
            "exact.sum.wd.wd",
            "exact.sum.wd.wd2",
            "exact.sum.wd2.wd2",
            "exact.sum3.w.w.w",
            "exact.sum3.w.w.wd",
            "exact.sum3.w.w.wd2",
            "exact.sum3.w.wd.wd",
            "exact.sum3.w.wd.wd2",
            "exact.sum3.w.wd2.wd2",
            "exact.sum3.wd.wd.wd",
            "exact.sum3.wd.wd.wd2",
            "exact.sum3.wd.wd2.wd2",
            "exact.sum3.wd2.wd2.wd2",
            "exact.sum.w.comp",
            "exact.sum.wd.comp",
            "exact.sum.wd2.comp",
        ]
    );
    let vals = field.values();
    let n = vals.len();
    assert_eq!(n, 120);
    let (sigma, se, valid) = (vti.f32s("ftpd"), vti.f32s("ftpd.stderr"), vti.u8s("valid"));
    let (samples, fluence) = (vti.u32s("samples"), vti.f32s("fluence"));
    let (s0, s2) = (vti.f64s("exact.sum.w"), vti.f64s("exact.sum.wd2"));
    let grad = vti.f32s("grad.mag");
    assert_eq!(fluence.len(), 3 * n);
    let spacing64 = glam::DVec3::new(sp[0], sp[1], sp[2]);
    let want_grad = ftpd3d::output::vti::gradient_magnitude(&vals, [6, 5, 4], spacing64);
    for i in 0..n {
        assert_eq!(sigma[i], vals[i].sigma as f32, "voxel {i}");
        assert_eq!(se[i], vals[i].stderr as f32);
        assert_eq!(valid[i], vals[i].valid as u8);
        assert_eq!(samples[i] as u64, field.cells[i].n);
        assert_eq!(s0[i].to_bits(), field.cells[i].s0.to_bits());
        assert_eq!(s2[i].to_bits(), field.cells[i].s2.to_bits());
        let f = field.cells[i].fluence();
        assert_eq!(
            &fluence[3 * i..3 * i + 3],
            &[f.x as f32, f.y as f32, f.z as f32]
        );
        assert!(grad[i].is_finite());
        assert!((grad[i] - want_grad[i]).abs() <= 1e-6 * want_grad[i].abs());
    }
    assert!(valid.iter().filter(|&&v| v == 1).count() > n / 2);
    assert!(
        fluence.iter().any(|&f| f > 0.0),
        "radiance weighting has fluence"
    );

    // Our own reader gives the field back exactly: volumes merge like EXR fields.
    let back = ftpd3d::output::vti::read_vti(&out).unwrap();
    assert_eq!(back.field, field);
}

#[test]
fn vti_header_of_a_2x2x2_volume_is_exactly_this() {
    let dir = temp_dir("volume", "golden");
    let out = dir.join("g.vti");
    let mut field = Field::new(2, 2, 2);
    field.meta.insert("scene".into(), "a--b.obj".into());
    field.meta.insert("weighting".into(), "unweighted".into());
    ftpd3d::output::vti::write_vti(
        &out,
        &field,
        glam::DVec3::splat(0.25),
        glam::DVec3::new(0.5, 0.5, 1.5),
    )
    .unwrap();
    let bytes = std::fs::read(&out).unwrap();
    let text = String::from_utf8(bytes).unwrap();
    let appended = text.find("<AppendedData").unwrap();
    let header = &text[..appended + text[appended..].find('_').unwrap() + 1];
    // Offsets count base64 characters: a Float32 array of 8 values is 8 + 32 bytes = 56 chars,
    // 3 components 8 + 96 bytes = 140, UInt8 24, UInt32 56, Float64 96.
    let expected = r#"<?xml version="1.0"?>
<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt64">
  <!-- ftpd3d scene=a-%2Db.obj -->
  <!-- ftpd3d weighting=unweighted -->
  <ImageData WholeExtent="0 1 0 1 0 1" Origin="0.25 0.25 0.25" Spacing="0.5 0.5 1.5">
    <Piece Extent="0 1 0 1 0 1">
      <PointData Scalars="ftpd">
        <DataArray type="Float32" Name="ftpd" format="appended" offset="0"></DataArray>
        <DataArray type="Float32" Name="ftpd.stderr" format="appended" offset="56"></DataArray>
        <DataArray type="Float32" Name="ftpd.relerr" format="appended" offset="112"></DataArray>
        <DataArray type="Float32" Name="ftpd.mean" format="appended" offset="168"></DataArray>
        <DataArray type="Float32" Name="ftpd.m2" format="appended" offset="224"></DataArray>
        <DataArray type="Float32" Name="weight" format="appended" offset="280"></DataArray>
        <DataArray type="Float32" Name="fluence" NumberOfComponents="3" format="appended" offset="336"></DataArray>
        <DataArray type="Float32" Name="grad.mag" format="appended" offset="476"></DataArray>
        <DataArray type="UInt8" Name="valid" format="appended" offset="532"></DataArray>
        <DataArray type="UInt32" Name="samples" format="appended" offset="556"></DataArray>
        <DataArray type="UInt32" Name="batches" format="appended" offset="612"></DataArray>
        <DataArray type="UInt32" Name="groups" format="appended" offset="668"></DataArray>
        <DataArray type="Float64" Name="exact.sum.w" format="appended" offset="724"></DataArray>
        <DataArray type="Float64" Name="exact.sum.wd" format="appended" offset="820"></DataArray>
        <DataArray type="Float64" Name="exact.sum.wd2" format="appended" offset="916"></DataArray>
        <DataArray type="Float64" Name="exact.sum.fluence.R" format="appended" offset="1012"></DataArray>
        <DataArray type="Float64" Name="exact.sum.fluence.G" format="appended" offset="1108"></DataArray>
        <DataArray type="Float64" Name="exact.sum.fluence.B" format="appended" offset="1204"></DataArray>
        <DataArray type="Float64" Name="exact.sum.w.w" format="appended" offset="1300"></DataArray>
        <DataArray type="Float64" Name="exact.sum.w.wd" format="appended" offset="1396"></DataArray>
        <DataArray type="Float64" Name="exact.sum.w.wd2" format="appended" offset="1492"></DataArray>
        <DataArray type="Float64" Name="exact.sum.wd.wd" format="appended" offset="1588"></DataArray>
        <DataArray type="Float64" Name="exact.sum.wd.wd2" format="appended" offset="1684"></DataArray>
        <DataArray type="Float64" Name="exact.sum.wd2.wd2" format="appended" offset="1780"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.w.w.w" format="appended" offset="1876"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.w.w.wd" format="appended" offset="1972"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.w.w.wd2" format="appended" offset="2068"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.w.wd.wd" format="appended" offset="2164"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.w.wd.wd2" format="appended" offset="2260"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.w.wd2.wd2" format="appended" offset="2356"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.wd.wd.wd" format="appended" offset="2452"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.wd.wd.wd2" format="appended" offset="2548"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.wd.wd2.wd2" format="appended" offset="2644"></DataArray>
        <DataArray type="Float64" Name="exact.sum3.wd2.wd2.wd2" format="appended" offset="2740"></DataArray>
        <DataArray type="Float64" Name="exact.sum.w.comp" format="appended" offset="2836"></DataArray>
        <DataArray type="Float64" Name="exact.sum.wd.comp" format="appended" offset="2932"></DataArray>
        <DataArray type="Float64" Name="exact.sum.wd2.comp" format="appended" offset="3028"></DataArray>
      </PointData>
    </Piece>
  </ImageData>
  <AppendedData encoding="base64">
   _"#;
    assert_eq!(header, expected);
    // The appended block holds exactly the announced characters, then closes the document.
    let tail = &text[header.len()..];
    assert_eq!(tail.find('\n'), Some(3028 + 96));
    assert_eq!(&tail[3028 + 96..], "\n  </AppendedData>\n</VTKFile>\n");
    // An empty voxel: byte count 32 (UInt64 LE) then 8 zero floats.
    assert_eq!(
        &tail[..56],
        "IAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA=="
    );
    let back = ftpd3d::output::vti::read_vti(&out).unwrap();
    assert_eq!(back.field, field);
    assert_eq!(back.origin, glam::DVec3::splat(0.25));
}

/// A volume one voxel thick around z = c samples the same points (up to the z jitter) as a slice
/// z = c over the same x-y window at the same resolution, so both estimate the same σ per cell.
///
/// Unweighted: the test is about where the points lie, and with radiance weighting the batch
/// standard error itself is too small in a few percent of cells (rare bright paths that most
/// 16-sample batches miss), so two independent slices disagree by more than 4 standard errors in
/// about 5% of cells too. Judged as `support::assert_consistent` judges z-scores (a false failure
/// with probability under 1e-4), and the mean difference within its standard errors: a volume
/// whose points lay elsewhere than the slice's (the fault this guards against) differs in many
/// cells, by many standard errors where σ changes fast.
#[test]
fn a_thin_volume_agrees_with_the_slice_through_it() {
    let dir = temp_dir("volume", "slice");
    let (c, eps, n, spp) = (-0.4, 1e-4, 24, 256);
    let mut vjob = volume_job(
        VolumeRes::Dims([n, n, 1]),
        Some([-1.0, 0.0, c - eps, 1.0, 2.0, c + eps]),
        spp,
        &dir.join("v.vti"),
    );
    vjob.render.batches = 16;
    vjob.estimator.weighting = Weighting::Unweighted;
    let vol = run_job(&vjob).unwrap().remove(0).field;
    let sjob = Job {
        scene: vjob.scene.clone(),
        domain: DomainArg::Slice {
            slices: vec![SliceArg::Axis(format!("z={c}"))],
            window: Some([-1.0, 0.0, 1.0, 2.0]),
            res: n,
        },
        lights: vec![],
        flatland: false,
        checkpoint_every: None,
        resume: None,
        command: None,
        separatrices: None,
        load: Default::default(),
        estimator: vjob.estimator.clone(),
        // Another seed: independent estimates, so their difference is pure noise.
        render: RenderOptions {
            seed: 8,
            ..vjob.render.clone()
        },
        output: dir.join("s.exr"),
        png: false,
        quiet: true,
    };
    let slice = run_job(&sjob).unwrap().remove(0).field;
    assert_eq!((slice.width, slice.height, slice.depth), (n, n, 1));
    assert_eq!((vol.width, vol.height, vol.depth), (n, n, 1));
    let (a, b) = (vol.values(), slice.values());
    let same_validity = a.iter().zip(&b).filter(|(x, y)| x.valid == y.valid).count();
    assert!(
        same_validity as f64 >= 0.99 * (n * n) as f64,
        "{same_validity}"
    );
    let (mut z, mut diff, mut var) = (Vec::new(), 0.0, 0.0);
    for (k, (x, y)) in a.iter().zip(&b).enumerate() {
        if x.valid && y.valid {
            let se2 = x.stderr * x.stderr + y.stderr * y.stderr;
            z.push((format!("cell {k}"), (x.sigma - y.sigma) / se2.sqrt()));
            diff += x.sigma - y.sigma;
            var += se2;
        }
    }
    let cells = z.len();
    assert!(cells > (n * n) / 2, "{cells} valid cells");
    crate::support::assert_consistent("thin volume against the slice", &z);
    // The mean difference over all cells, against its own standard error.
    let (mean, se) = (diff / cells as f64, var.sqrt() / cells as f64);
    assert!(
        mean.abs() < crate::support::z_limit(1) * se,
        "mean σ difference {mean:e} vs its standard error {se:e}"
    );
}

#[test]
fn impossible_grids_are_refused_before_allocating() {
    let dir = temp_dir("volume", "memory");
    let cornell = scene_path("cornell_mirror.obj");
    let out = dir.join("x.vti");
    let (cornell, out_s) = (cornell.to_str().unwrap(), out.to_str().unwrap());
    for (spec, fit) in [
        ("100000", "--volume "),
        ("100000,100000,100000", "--volume "),
    ] {
        let Run { ok, err, .. } = ftpd3d(&["--scene", cornell, "--volume", spec, "-o", out_s]);
        assert!(!ok);
        assert!(
            err.contains(&format!("--volume {spec}: "))
                && err.contains("of memory")
                && err.contains("available")
                && err.contains(fit)
                && err.contains("would fit"),
            "{err}"
        );
        assert!(
            !err.contains("panicked") && !err.contains("memory allocation"),
            "{err}"
        );
    }
    assert!(!out.exists(), "nothing written");
    // The suggested grid is the largest that fits: one more voxel along the side does not.
    let size = glam::DVec3::new(2.0, 2.0, 2.0);
    let avail = 23_000_000_000u64;
    let e = ftpd3d::app::check_volume_memory(VolumeRes::Longest(2000), size, avail, true)
        .unwrap_err()
        .to_string();
    let per = ftpd3d::output::vti::bytes_per_voxel() as f64;
    let m = (avail as f64 / per).cbrt().floor() as usize;
    assert!(e.contains(&format!("--volume {m} would fit")), "{e}");
    assert!(
        e.starts_with("--volume 2000: 2000x2000x2000 = 8.0e9 voxels need "),
        "{e}"
    );
    assert!(ftpd3d::app::check_volume_memory(VolumeRes::Longest(m), size, avail, true).is_ok());
    assert!(
        ftpd3d::app::check_volume_memory(VolumeRes::Longest(m + 1), size, avail, true).is_err()
    );
    let e =
        ftpd3d::app::check_volume_memory(VolumeRes::Dims([4000, 2000, 1000]), size, avail, true)
            .unwrap_err()
            .to_string();
    let fit = e.rsplit("--volume ").next().unwrap();
    let dims: Vec<usize> = fit
        .trim_end_matches(" would fit")
        .split(',')
        .map(|x| x.parse().unwrap())
        .collect();
    assert!(
        ftpd3d::app::volume_bytes([dims[0], dims[1], dims[2]]) <= avail as u128,
        "{e}"
    );
    assert!(dims[0] > dims[1] && dims[1] > dims[2], "same shape: {e}");
}

#[test]
fn volume_flags_are_checked_naming_the_flag() {
    let cornell = scene_path("cornell_mirror.obj");
    let cornell = cornell.to_str().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["--volume", "4", "--slice", "z=0"], "--slice"),
        (&["--volume", "4", "--res", "8"], "--res"),
        (&["--volume", "0"], "at least 1 voxel"),
        (&["--volume", "4,4"], "NX,NY,NZ"),
        (
            &["--box", "0,0,0,1,1,1", "--slice", "z=0"],
            "--box 0,0,0,1,1,1: a box bounds a volume; add --volume",
        ),
        (
            &["--volume", "4", "--box", "-1,0,0,1,0,1"],
            "--box -1,0,0,1,0,1: needs",
        ),
        (&["--volume", "4", "--box", "1,2,3"], "expected 6"),
        (&["--volume", "4", "-o", "/tmp/x.exr"], "name the file .vti"),
    ];
    for (args, msg) in cases {
        let mut all = vec!["--scene", cornell, "--quiet"];
        all.extend_from_slice(args);
        let Run { ok, err, .. } = ftpd3d(&all);
        assert!(!ok, "{args:?} should fail");
        assert!(err.contains(msg), "{args:?}: expected '{msg}' in: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn a_volume_run_writes_vti_and_middle_slice_previews() {
    let dir = temp_dir("volume", "cli");
    let out = dir.join("v.vti");
    let cornell = scene_path("cornell_mirror.obj");
    let Run { ok, err, .. } = ftpd3d(&[
        "--scene",
        cornell.to_str().unwrap(),
        "--volume",
        "10",
        "--spp",
        "4",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    assert!(
        err.contains("ETA") && err.contains("volume 10x10x10"),
        "{err}"
    );
    assert!(out.is_file() && dir.join("v.png").is_file() && dir.join("v.grad.png").is_file());
    let back = ftpd3d::output::vti::read_vti(&out).unwrap();
    assert_eq!(back.field.meta.get("volume.dims").unwrap(), "10,10,10");
    assert_eq!(back.field.total_samples(), 4000);
}

/// A 6³ unweighted volume of the Cornell box, 8 samples per voxel in 4 passes (fast, fixed seed).
fn small_volume(out: &Path) -> Job {
    let mut job = volume_job(VolumeRes::Longest(6), None, 8, out);
    job.estimator.weighting = Weighting::Unweighted;
    job
}

fn bits(field: &Field) -> Vec<[u64; 28]> {
    field.cells.iter().map(|m| m.bit_pattern()).collect()
}

/// The binary on a 6³ unweighted volume of the Cornell box written to `out`, with `extra` flags.
fn small_volume_cli(out: &Path, extra: &[&str]) -> crate::support::Run {
    let cornell = scene_path("cornell_mirror.obj");
    let mut args = vec![
        "--scene",
        cornell.to_str().unwrap(),
        "--volume",
        "6",
        "--weight",
        "unweighted",
        "--no-png",
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    crate::support::ftpd3d(&args)
}

#[test]
fn a_volume_takes_a_time_budget() {
    let dir = temp_dir("volume", "time");
    let out = dir.join("t.vti");
    let r = small_volume_cli(&out, &["--time", "1s", "--pass-spp", "2"]);
    assert!(r.ok, "{}", r.err);
    assert!(r.err.contains("budget time 1s"), "{}", r.err);
    let back = ftpd3d::output::vti::read_vti(&out).unwrap();
    assert_eq!(back.field.meta.get("budget.time").unwrap(), "1s");
    assert_eq!(back.field.meta.get("spp").unwrap(), "none");
    assert!(back.field.total_samples() >= 2 * 216);
}

#[test]
fn an_interrupted_volume_resumes_to_the_uninterrupted_run_bit_for_bit() {
    let dir = temp_dir("volume", "resume");
    let whole = run_job(&small_volume(&dir.join("whole.vti")))
        .unwrap()
        .remove(0);
    assert!(whole.stats.stop.is_complete());
    // Stopped after 2 of 4 passes: written partial, with its progress.
    let part = dir.join("part.vti");
    let mut first = small_volume(&part);
    first.render.budget.max_passes = Some(2);
    let cut = run_job(&first).unwrap().remove(0);
    assert!(!cut.stats.stop.is_complete());
    let back = ftpd3d::output::vti::read_vti(&part).unwrap();
    assert_eq!(back.field.meta.get("partial").unwrap(), "true");
    assert_eq!(back.field.meta.get("passes").unwrap(), "2");
    assert_eq!(
        bits(&back.field),
        bits(&cut.field),
        "the .vti keeps the sums"
    );
    // Resumed into the same file.
    let mut again = small_volume(&part);
    again.resume = Some(part.clone());
    let done = run_job(&again).unwrap().remove(0);
    assert!(done.stats.stop.is_complete());
    assert_eq!(done.progress.passes, 4);
    assert_eq!(bits(&done.field), bits(&whole.field));
    let file = ftpd3d::output::vti::read_vti(&part).unwrap();
    assert_eq!(bits(&file.field), bits(&whole.field));
    assert_eq!(file.field.meta.get("partial").unwrap(), "false");
    // Another grid is refused, naming the flag.
    let mut other = small_volume(&part);
    other.domain = DomainArg::Volume {
        res: VolumeRes::Longest(5),
        bbox: None,
    };
    other.resume = Some(part.clone());
    let e = format!("{:#}", run_job(&other).unwrap_err());
    assert!(e.contains("--resume") && e.contains("6x6x6"), "{e}");
}

#[test]
fn a_pass_cut_part_way_survives_the_vti() {
    use ftpd3d::render::{InFlight, Progress};
    let dir = temp_dir("volume", "inflight");
    let path = dir.join("p.vti");
    let volume = ftpd3d::domain::Volume::new(
        &ftpd3d::scene::Aabb {
            min: glam::DVec3::ZERO,
            max: glam::DVec3::ONE,
        },
        [3, 2, 2],
    )
    .unwrap();
    let mut field = Field::new(3, 2, 2);
    let mut info = ftpd3d::run_info::RunInfo {
        adaptive: Some("max 4x".into()),
        ..Default::default()
    };
    let progress = Progress {
        passes: 3,
        inflight: Some(InFlight {
            done: (0..12).map(|k| k % 3 == 0).collect(),
            units: Some((0..12).map(|k| k * 7 + 1).collect()),
        }),
        elapsed: 1.25,
    };
    let opts = RenderOptions::default();
    ftpd3d::app::mark_progress(&mut field, &mut info, &progress, &opts, true, None);
    ftpd3d::app::write_volume_progress(&field, &progress, &volume, &path, false).unwrap();
    let (back, p) = ftpd3d::app::read_progress(&path).unwrap();
    assert_eq!(p, progress);
    assert_eq!(bits(&back), bits(&field));
}

#[test]
fn three_volume_tiles_merge_into_the_full_run_bit_for_bit() {
    let dir = temp_dir("volume", "tiles");
    let whole = run_job(&small_volume(&dir.join("whole.vti")))
        .unwrap()
        .remove(0)
        .field;
    let mut parts = Vec::new();
    for i in 0..3 {
        let out = dir.join(format!("t{i}.vti"));
        let mut job = small_volume(&out);
        job.render.tile = Some(ftpd3d::domain::Tile { index: i, count: 3 });
        let f = run_job(&job).unwrap().remove(0).field;
        // Only its slab of z layers is sampled.
        let layer = 6 * 6;
        for (k, c) in f.cells.iter().enumerate() {
            assert_eq!(c.n > 0, k / layer / 2 == i, "tile {i}, cell {k}");
        }
        parts.push(out);
    }
    let merged = ftpd3d::merge::merge_files(&parts, &dir.join("all.vti"), false).unwrap();
    assert!(merged.warnings.is_empty(), "{:?}", merged.warnings);
    assert_eq!(bits(&merged.field), bits(&whole));
    let back = ftpd3d::output::vti::read_vti(&dir.join("all.vti")).unwrap();
    assert_eq!(bits(&back.field), bits(&whole));
    // Two tiles of three cover two thirds of the layers, and say so.
    let two = ftpd3d::merge::merge_files(&parts[..2], &dir.join("two.vti"), false).unwrap();
    assert!(
        two.warnings.iter().any(|w| w.contains("4 of 6 rows")),
        "{:?}",
        two.warnings
    );
}

#[test]
fn a_volume_checkpoint_resumes() {
    let dir = temp_dir("volume", "checkpoint");
    let out = dir.join("c.vti");
    let run = |extra: &[&str]| {
        let mut a = vec!["--spp", "8", "--batches", "4", "--seed", "7"];
        a.extend_from_slice(extra);
        small_volume_cli(&out, &a)
    };
    let r = run(&["--checkpoint-every", "1ms"]);
    assert!(r.ok, "{}", r.err);
    assert!(
        r.err.contains("checkpoint: ") && r.err.contains("passes written to"),
        "{}",
        r.err
    );
    let whole = ftpd3d::output::vti::read_vti(&out).unwrap().field;
    // Checkpointed after each pass and stopped after pass 2 (as a killed run would have left it
    // at its last checkpoint), then resumed from the command line.
    let mut job = small_volume(&out);
    job.render.budget.max_passes = Some(2);
    job.checkpoint_every = Some(std::time::Duration::from_nanos(1));
    run_job(&job).unwrap();
    let r = run(&["--resume", out.to_str().unwrap()]);
    assert!(r.ok, "{}", r.err);
    assert!(
        r.err.contains("resuming") && r.err.contains("2 passes done"),
        "{}",
        r.err
    );
    let resumed = ftpd3d::output::vti::read_vti(&out).unwrap().field;
    assert_eq!(bits(&resumed), bits(&whole));
}

#[test]
fn a_tile_resumes_only_as_the_same_tile() {
    let dir = temp_dir("volume", "tile_resume");
    let out = dir.join("t.vti");
    let mut job = small_volume(&out);
    job.render.tile = Some(ftpd3d::domain::Tile { index: 1, count: 3 });
    job.render.budget.max_passes = Some(1);
    run_job(&job).unwrap();
    let mut whole = small_volume(&out);
    whole.resume = Some(out.clone());
    let e = format!("{:#}", run_job(&whole).unwrap_err());
    assert!(e.contains("tile differs"), "{e}");
    job.render.budget.max_passes = None;
    job.resume = Some(out.clone());
    let done = run_job(&job).unwrap().remove(0);
    assert!(done.stats.stop.is_complete());
}
