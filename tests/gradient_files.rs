//! Gradient-domain runs (`--gradient-domain`) in files: the replayed neighbours' sums survive an
//! EXR or VTI round trip bit for bit, so tiles merge into the full run, seeds add their sums,
//! resumed runs (also from a pass cut part-way) equal the run in one go, thread counts agree, and
//! mixing gradient-domain with ordinary fields (or another α) is refused naming the files or the
//! flag.

use crate::driver::{Setup, cornell};
use crate::support::{
    Run, assert_resume_keeps, cornell_12_in, exr_parts, ftpd3d_in, run_on_1_and_2_threads,
    scene_path, small_slice, temp_dir,
};
use ftpd3d::app;
use ftpd3d::field::Field;
use ftpd3d::gradient_domain::{DEFAULT_ALPHA, REPLICATES, Shift};
use ftpd3d::output::exr::{read_exr, write_exr};
use ftpd3d::output::vti::{read_vti, write_vti};
use ftpd3d::render::{self, Hooks, Progress, RenderOptions, RunStats, StopReason};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

fn cornell_path() -> String {
    scene_path("cornell_mirror.obj")
        .to_str()
        .unwrap()
        .to_string()
}

/// A gradient-domain run of the 12² slice z = 0 of the Cornell box, radiance-weighted, 8 samples
/// in 4 passes, plus `extra` flags, in `dir` ([`cornell_12_in`]).
fn run(dir: &Path, extra: &[&str]) -> Run {
    cornell_12_in(dir, extra)
}

fn run_ok(dir: &Path, extra: &[&str]) {
    let r = run(dir, &[&["--gradient-domain"], extra].concat());
    assert!(r.ok, "{extra:?}: {}", r.err);
}

/// A field's sums as bits: each cell's accumulator, then its replayed sums with α and axes.
type Bits = (Vec<[u64; 28]>, Option<(u64, usize, Vec<u64>)>);

/// Every sum of a field as bits.
fn bits(f: &Field) -> Bits {
    (
        f.cells.iter().map(|c| c.bit_pattern()).collect(),
        f.shift.as_ref().map(|s| {
            (
                s.alpha.to_bits(),
                s.axes,
                s.data.iter().map(|x| x.to_bits()).collect(),
            )
        }),
    )
}

/// Fails, naming `what` and the first cell that differs, unless `a` and `b` hold the same sums,
/// bit for bit.
fn assert_same(a: &Field, b: &Field, what: &str) {
    let ((ca, sa), (cb, sb)) = (bits(a), bits(b));
    assert_eq!(ca.len(), cb.len(), "{what}: cell counts");
    if let Some(k) = (0..ca.len()).find(|&k| ca[k] != cb[k]) {
        panic!("{what}: cell {k}: {:?} vs {:?}", a.cells[k], b.cells[k]);
    }
    match (sa, sb) {
        (Some((aa, xa, da)), Some((ab, xb, db))) => {
            assert_eq!((aa, xa), (ab, xb), "{what}: α and axes");
            if let Some(k) = (0..da.len().max(db.len())).find(|&k| da.get(k) != db.get(k)) {
                panic!("{what}: replayed sum {k} differs (of {})", da.len());
            }
        }
        (x, y) => assert_eq!(x.is_some(), y.is_some(), "{what}: gradient-domain or not"),
    }
}

/// The replayed sums of a field, which must be a gradient-domain one.
fn shift(f: &Field) -> &Shift {
    f.shift.as_ref().expect("a gradient-domain field")
}

fn read(dir: &Path, name: &str) -> Field {
    read_exr(&dir.join(name)).unwrap()
}

#[test]
fn exr_round_trip_keeps_every_replayed_sum() {
    let dir = temp_dir("gradient_files", "exr");
    let s = cornell(12);
    let o = RenderOptions {
        spp: 8,
        batches: 2,
        seed: 5,
        threads: 2,
        gradient_domain: Some(0.35),
        ..Default::default()
    };
    let (field, _) = render::run_plane(&s.scene, &s.plane, &s.params, &o).unwrap();
    let sh = shift(&field);
    assert_eq!((sh.alpha, sh.axes), (0.35, 2));
    // The samples went to more than one replicate, and replays crossed both axes.
    let block = sh.block();
    let cell0 = &sh.data[..sh.stride()];
    let filled = (0..REPLICATES).filter(|r| cell0[r * block] > 0.0).count();
    assert!(filled >= 2, "{cell0:?}");
    assert!(cell0[4..7].iter().any(|&x| x != 0.0) && cell0[7..10].iter().any(|&x| x != 0.0));
    let path = dir.join("g.exr");
    write_exr(&path, &field, &[]).unwrap();
    let back = read_exr(&path).unwrap();
    assert_same(&back, &field, "read back");
    assert_eq!(back.meta, field.meta);
    assert_eq!(back.meta["gradient.alpha"], "0.35");
    assert_eq!(back.meta["gradient.replicates"], REPLICATES.to_string());
    // The reconstructed values come back too, and a file written from what was read holds it all
    // again.
    assert!(back.values() == field.values());
    let again = dir.join("again.exr");
    write_exr(&again, &back, &[]).unwrap();
    assert_same(&read_exr(&again).unwrap(), &field, "written again");
    // The sums sit in part 1 as hi/lo pairs: 16 replicates × (1 + 3·(1 + 2)) values per cell.
    let parts = exr_parts(&path);
    let shifted = |i: usize| {
        parts[i]
            .channel_data
            .list
            .iter()
            .filter(|c| c.name.to_string().starts_with("exact.shift."))
            .count()
    };
    assert_eq!((shifted(0), shifted(1)), (0, 2 * REPLICATES * 10));
    // An ordinary run's file has none, and no gradient attribute.
    let plain = RenderOptions {
        gradient_domain: None,
        ..o
    };
    let (ordinary, _) = render::run_plane(&s.scene, &s.plane, &s.params, &plain).unwrap();
    let p = dir.join("plain.exr");
    write_exr(&p, &ordinary, &[]).unwrap();
    let ordinary_back = read_exr(&p).unwrap();
    assert!(ordinary_back.shift.is_none());
    assert!(!ordinary_back.meta.keys().any(|k| k.starts_with("gradient")));
    assert!(exr_parts(&p).iter().all(|l| {
        l.channel_data
            .list
            .iter()
            .all(|c| !c.name.to_string().contains("shift"))
    }));
    // A description that says gradient-domain over a file without the sums is refused, naming
    // the file and the missing channel.
    let mut stripped = field.clone();
    stripped.shift = None;
    let bad = dir.join("stripped.exr");
    write_exr(&bad, &stripped, &[]).unwrap();
    let e = read_exr(&bad).unwrap_err().to_string();
    assert!(
        e.contains("stripped.exr") && e.contains("exact.shift.r00.n.hi"),
        "{e}"
    );
}

#[test]
fn tiles_merge_into_the_full_gradient_domain_run_bit_for_bit() {
    let dir = temp_dir("gradient_files", "tiles");
    run_ok(&dir, &["--threads", "2", "-o", "full.exr"]);
    let mut names = Vec::new();
    for i in 0..3 {
        let (tile, name) = (format!("{i}/3"), format!("t{i}.exr"));
        run_ok(&dir, &["--tile", &tile, "--threads", "1", "-o", &name]);
        names.push(name);
    }
    // A tile's replayed sums sit in the cells its samples started from: its own rows only.
    let t1 = read(&dir, "t1.exr");
    let stride = shift(&t1).stride();
    for (k, c) in t1.cells.iter().enumerate() {
        let row = k / 12;
        let own = (4..8).contains(&row);
        assert_eq!(c.n > 0, own, "cell {k}");
        let sums = &shift(&t1).data[k * stride..(k + 1) * stride];
        assert_eq!(sums.iter().any(|&x| x != 0.0), own, "cell {k}");
    }
    let mut args = vec!["merge"];
    args.extend(names.iter().map(String::as_str));
    args.extend(["-o", "merged.exr"]);
    let r = ftpd3d_in(&dir, &args);
    assert!(r.ok, "{}", r.err);
    assert!(r.err.contains("gradient-domain (α 0.5)"), "{}", r.err);
    let (full, merged) = (read(&dir, "full.exr"), read(&dir, "merged.exr"));
    assert_same(&merged, &full, "tiles merged = the full run");
    assert_eq!(merged.meta["gradient.alpha"], DEFAULT_ALPHA.to_string());
    assert_eq!(merged.values(), full.values());
}

#[test]
fn two_seeds_merge_by_adding_their_replayed_sums() {
    let dir = temp_dir("gradient_files", "seeds");
    run_ok(&dir, &["--seed", "1", "-o", "a.exr"]);
    run_ok(&dir, &["--seed", "2", "-o", "b.exr"]);
    let r = ftpd3d_in(&dir, &["merge", "a.exr", "b.exr", "-o", "ab.exr"]);
    assert!(r.ok, "{}", r.err);
    let (a, b, ab) = (
        read(&dir, "a.exr"),
        read(&dir, "b.exr"),
        read(&dir, "ab.exr"),
    );
    // Written out here, not by Shift::merge: every replayed sum of a plus that of b.
    let want: Vec<u64> = shift(&a)
        .data
        .iter()
        .zip(&shift(&b).data)
        .map(|(x, y)| (x + y).to_bits())
        .collect();
    let got: Vec<u64> = shift(&ab).data.iter().map(|x| x.to_bits()).collect();
    assert_eq!(got, want);
    assert_ne!(shift(&a).data, shift(&b).data, "two seeds, other samples");
    let mut cells = a.cells.clone();
    for (c, o) in cells.iter_mut().zip(&b.cells) {
        c.merge(o);
    }
    assert_eq!(ab.cells, cells);
    // Each replicate's sample count doubled.
    let n = |f: &Field| shift(f).data[0];
    assert_eq!(n(&ab), n(&a) + n(&b));
}

#[test]
fn thread_counts_and_resumed_runs_give_the_same_field() {
    let dir = temp_dir("gradient_files", "resume");
    let scene = scene_path("cornell_mirror.obj");
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let run = |extra: &[&str]| -> Run { small_slice(&scene, extra) };
    let setting = ["--gradient-domain", "--gradient-alpha", "0.3"];
    run_on_1_and_2_threads(run, &setting, [&out("t1.exr"), &out("t2.exr")]);
    let (t1, t2) = (read(&dir, "t1.exr"), read(&dir, "t2.exr"));
    assert_same(&t1, &t2, "1 and 2 threads");
    assert_eq!(shift(&t1).alpha, 0.3);
    // 4 samples, resumed to 8: the 8-sample run, bit for bit; resumed without the flags (or with
    // another α) it is refused, naming them.
    let resumed = out("resumed.exr");
    let back = || bits(&read(&dir, "resumed.exr"));
    let one_go = bits(&t1);
    assert_resume_keeps(run, &setting, "gradient.alpha", &resumed, back, &one_go);
    let r = run(&["--gradient-domain", "--spp", "12", "--resume", &resumed]);
    assert!(
        !r.ok && r.err.contains("gradient.alpha differs") && r.err.contains("--gradient-alpha 0.3"),
        "{}",
        r.err
    );
    // An ordinary file resumed as a gradient-domain run: refused, naming the flag to leave out.
    let plain = out("plain.exr");
    assert!(run(&["--spp", "4", "-o", &plain]).ok);
    let r = run(&["--gradient-domain", "--spp", "8", "--resume", &plain]);
    assert!(
        !r.ok && r.err.contains("leave out --gradient-domain"),
        "{}",
        r.err
    );
}

/// A run cut a quarter into its second pass, written with its progress, read back and resumed,
/// equals the run in one go: the replayed sums of the cells that finished the cut pass are in the
/// file, and the others are sampled again from the same streams.
#[test]
fn a_run_cut_mid_pass_resumes_to_the_uninterrupted_run() {
    let dir = temp_dir("gradient_files", "mid_pass");
    let s = cornell(12);
    let o = RenderOptions {
        spp: 12,
        batches: 3,
        seed: 7,
        threads: 2,
        gradient_domain: Some(DEFAULT_ALPHA),
        ..Default::default()
    };
    // Kernel calls (samples and their replays) after each pass of the uninterrupted run.
    let calls = AtomicU64::new(0);
    let mut whole = s.field(&o);
    let mut per_pass = vec![0u64];
    let mut record = |_: &mut Field, _: &Progress, _: &RunStats| {
        per_pass.push(calls.load(Ordering::SeqCst));
        Ok(())
    };
    let ws = drive(
        &s,
        &o,
        &calls,
        &mut whole,
        &mut Progress::default(),
        None,
        Some(&mut record),
    );
    assert_eq!(ws.passes, 3, "{per_pass:?}");
    let mut field = s.field(&o);
    let mut progress = Progress::default();
    let flag = AtomicBool::new(false);
    let trip = per_pass[1] + (per_pass[2] - per_pass[1]) / 4;
    let st = drive(
        &s,
        &o,
        &calls,
        &mut field,
        &mut progress,
        Some((&flag, trip)),
        None,
    );
    assert_eq!(st.stop, StopReason::Interrupted);
    assert_eq!(progress.passes, 1);
    let inflight = progress.inflight.as_ref().expect("a pass cut part-way");
    let done = inflight.done.iter().filter(|&&d| d).count();
    assert!(done > 0 && done < inflight.done.len(), "{done} done");
    let path = dir.join("partial.exr");
    app::mark_progress(
        &mut field,
        &mut s.info(&o),
        &progress,
        &o,
        true,
        Some(st.stop),
    );
    app::write_progress(&field, &progress, &path, false).unwrap();
    let (mut back, mut p) = app::read_progress(&path).unwrap();
    app::check_resume(&path, &back, &s.info(&o), (12, 12, 1)).unwrap();
    assert_same(&back, &field, "the partial file");
    back.meta = s.field(&o).meta;
    let rs = drive(&s, &o, &calls, &mut back, &mut p, None, None);
    assert!(rs.stop.is_complete());
    assert_same(&back, &whole, "resumed = uninterrupted");
}

/// Runs `o` over the slice of `s` from `field` and `progress` on 2 threads, counting kernel calls
/// (samples and their replays) in `calls` from 0; with `stop`, sets its flag at call `trip`.
fn drive<'a>(
    s: &Setup,
    o: &RenderOptions,
    calls: &AtomicU64,
    field: &mut Field,
    progress: &mut Progress,
    stop: Option<(&'a AtomicBool, u64)>,
    after_pass: Option<&'a mut render::AfterPass<'a>>,
) -> RunStats {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    calls.store(0, Ordering::SeqCst);
    render::run_progressive(
        &pool,
        field,
        o,
        progress,
        Hooks {
            stop: stop.map(|(f, _)| f),
            after_pass,
            samples: None,
        },
        |cell, smp: &mut ftpd3d::rng::Sampler| {
            let k = calls.fetch_add(1, Ordering::SeqCst) + 1;
            if let Some((flag, trip)) = stop
                && k == trip
            {
                flag.store(true, Ordering::SeqCst);
            }
            let x = s.plane.point(cell, smp.next_2d());
            ftpd3d::ftpd::sample_point(&s.scene, x, &s.params, smp)
        },
    )
    .unwrap()
}

#[test]
fn mixing_with_ordinary_runs_or_another_alpha_is_refused() {
    let dir = temp_dir("gradient_files", "mismatch");
    run_ok(&dir, &["--seed", "1", "-o", "g.exr"]);
    run_ok(
        &dir,
        &["--seed", "2", "--gradient-alpha", "0.3", "-o", "g03.exr"],
    );
    let r = run(&dir, &["--seed", "3", "-o", "plain.exr"]);
    assert!(r.ok, "{}", r.err);
    for (inputs, want) in [
        (
            ["g.exr", "plain.exr"],
            "plain.exr: has no gradient.alpha, while g.exr has gradient.alpha = 0.5",
        ),
        (
            ["plain.exr", "g.exr"],
            "g.exr: gradient.alpha = 0.5, while plain.exr has no gradient.alpha",
        ),
        (
            ["g.exr", "g03.exr"],
            "g03.exr: gradient.alpha = 0.3 differs from g.exr's 0.5",
        ),
    ] {
        let r = ftpd3d_in(&dir, &["merge", inputs[0], inputs[1], "-o", "m.exr"]);
        assert!(!r.ok && r.err.contains(want), "{inputs:?}: {}", r.err);
    }
    assert!(!dir.join("m.exr").exists());
    // Fields built in memory are checked by their sums too.
    let (g, mut plain) = (read(&dir, "g.exr"), read(&dir, "plain.exr"));
    plain.meta = g.meta.clone();
    plain.meta.insert("seed".into(), "3".into());
    let e = ftpd3d::merge::merge_fields(vec![("g".into(), g), ("p".into(), plain)]).unwrap_err();
    assert!(e.to_string().contains("p: has no gradient.alpha"), "{e}");
    // The run's first line says what it is.
    let scene = cornell_path();
    let r = ftpd3d_in(
        &dir,
        &[
            "--scene",
            &scene,
            "--slice",
            "z=0",
            "--res",
            "4",
            "--spp",
            "2",
            "--gradient-domain",
            "--no-png",
            "-o",
            "said.exr",
        ],
    );
    assert!(
        r.ok && r.err.contains("gradient-domain (α 0.5, 16 replicates)"),
        "{}",
        r.err
    );
    // α must be a number > 0.
    for alpha in ["0", "-1", "NaN"] {
        let r = run(
            &dir,
            &[
                "--gradient-domain",
                "--gradient-alpha",
                alpha,
                "-o",
                "x.exr",
            ],
        );
        assert!(
            !r.ok && r.err.contains(&format!("--gradient-alpha {alpha}")),
            "{alpha}: {}",
            r.err
        );
    }
}

#[test]
fn volumes_keep_merge_and_round_trip_their_replayed_sums() {
    let dir = temp_dir("gradient_files", "volume");
    let scene = cornell_path();
    for (seed, name) in [("1", "a.vti"), ("2", "b.vti")] {
        let r = ftpd3d_in(
            &dir,
            &[
                "--scene",
                &scene,
                "--volume",
                "4",
                "--weight",
                "unweighted",
                "--spp",
                "2",
                "--batches",
                "2",
                "--gradient-domain",
                "--seed",
                seed,
                "--quiet",
                "--no-png",
                "-o",
                name,
            ],
        );
        assert!(r.ok, "{}", r.err);
    }
    let r = ftpd3d_in(&dir, &["merge", "a.vti", "b.vti", "-o", "ab.vti"]);
    assert!(r.ok, "{}", r.err);
    let vol = |name: &str| read_vti(&dir.join(name)).unwrap();
    let (a, b, ab) = (vol("a.vti"), vol("b.vti"), vol("ab.vti"));
    assert_eq!(shift(&a.field).axes, 3);
    // Replays along z happened (the z sums of some cell are not all zero).
    let sa = shift(&a.field);
    assert!(
        sa.data
            .chunks(sa.block())
            .any(|b| b[10..13].iter().any(|&x| x != 0.0))
    );
    let want: Vec<u64> = sa
        .data
        .iter()
        .zip(&shift(&b.field).data)
        .map(|(x, y)| (x + y).to_bits())
        .collect();
    let got: Vec<u64> = shift(&ab.field).data.iter().map(|x| x.to_bits()).collect();
    assert_eq!(got, want);
    // Written again from what was read: the same sums.
    let again = dir.join("again.vti");
    write_vti(&again, &ab.field, ab.origin, ab.spacing).unwrap();
    assert_same(
        &read_vti(&again).unwrap().field,
        &ab.field,
        "volume written again",
    );
}

/// The memory a volume needs is checked before the run with the gradient-domain sums and their
/// reconstruction counted, and the run's volume line says so.
#[test]
fn gradient_domain_volumes_count_their_memory() {
    let dir = temp_dir("gradient_files", "memory");
    let (ordinary, gradient) = (app::bytes_per_voxel(false), app::bytes_per_voxel(true));
    assert_eq!(ordinary, ftpd3d::output::vti::bytes_per_voxel());
    // The stored sums alone: 16 replicates × 13 f64.
    assert!(gradient >= ordinary + REPLICATES * 13 * 8, "{gradient}");
    // As docs/guide.md (Volumes) states it.
    assert_eq!(gradient - ordinary, 6051);
    // A grid that fits as an ordinary volume and not as a gradient-domain one is refused, with
    // the bytes each voxel needs.
    let size = glam::DVec3::splat(2.0);
    let res = ftpd3d::domain::VolumeRes::Longest(100);
    let avail = 1_000_000 * ordinary as u64 * 2;
    assert!(app::check_volume_memory_at(res, size, avail, true, ordinary).is_ok());
    let e = app::check_volume_memory_at(res, size, avail, true, gradient)
        .unwrap_err()
        .to_string();
    assert!(e.contains(&format!("({gradient} bytes each)")), "{e}");
    let scene = cornell_path();
    let r = ftpd3d_in(
        &dir,
        &[
            "--scene",
            &scene,
            "--volume",
            "4",
            "--weight",
            "unweighted",
            "--spp",
            "1",
            "--gradient-domain",
            "--no-png",
            "-o",
            "v.vti",
        ],
    );
    assert!(r.ok, "{}", r.err);
    let need = app::report::human_bytes(app::volume_bytes_at([4, 4, 4], gradient) as f64);
    assert!(
        r.err.contains("volume 4x4x4 voxels") && r.err.contains(&format!("; memory {need} of")),
        "{}",
        r.err
    );
}
