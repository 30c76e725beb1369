//! Loading benchmark: loads one scene (parse, then the BVH build) and prints the times and the
//! memory it takes.
//!
//!     cargo run --release --example load_bench -- SCENE.obj
//!     cargo run --release --example load_bench -- FOREST.glb --flatten-instances
//!
//! `--flatten-instances` loads EXT_mesh_gpu_instancing as one copy of the mesh per instance
//! instead of Embree instances of one prototype (`LoadOptions::flatten_instances`).
//!
//! Prints the parse and BVH seconds, the CPU seconds of the load split into serial work and work
//! that could use both cores (with the wall time that gives on two free cores), the process's
//! resident memory after loading (`VmRSS`) and at its peak (`VmHWM`), the bytes Embree holds (BVH, its copies of vertices and indices) now and
//! at its peak, counted by Embree's memory monitor, and per triangle what stays resident besides
//! Embree. One load per process, so that the peak is this load's: run it again for another sample.
//! The 10 M-triangle scene of `docs/performance.md#loading-10-m-triangles` is
//! `python3 scripts/heavy_scene.py OUT.obj 20 3 --attributes --materials 300`.

use std::time::Instant;

/// A `/proc/self/status` field in bytes (Linux; 0 elsewhere).
fn status_bytes(key: &str) -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix(key)?.strip_prefix(':'))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// Samples the process's threads every few milliseconds while it loads (Linux `/proc`): the CPU
/// time they used in each interval (`schedstat`, nanoseconds) and how many wanted to run at its
/// end (state `R`: running, or waiting for a core the machine's other processes hold). CPU time
/// of intervals in which at most one thread wanted to run is serial work; the rest could use both
/// cores. So on two free cores the load would take about serial + rest / 2, whatever the
/// machine's load was while it was measured. The sampling thread's own CPU time (its reads of
/// `/proc`, about 1.3 s over a 10 M-triangle load on a busy machine) is not counted.
struct Sampler {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    handle: std::thread::JoinHandle<(f64, f64)>,
}

impl Sampler {
    fn start() -> Sampler {
        use std::sync::atomic::{AtomicBool, Ordering};
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let handle = std::thread::spawn(move || {
            let me = std::fs::read_link("/proc/thread-self")
                .ok()
                .and_then(|p| p.file_name().map(|s| s.to_owned()));
            // (CPU ns, runnable) of every thread but this one.
            let sample = || {
                let (mut ns, mut running) = (0u64, 0usize);
                let Ok(dir) = std::fs::read_dir("/proc/self/task") else {
                    return (0, 0);
                };
                for t in dir.flatten() {
                    if Some(t.file_name()) == me {
                        continue;
                    }
                    let p = t.path();
                    if let Ok(s) = std::fs::read_to_string(p.join("schedstat")) {
                        ns += s
                            .split_whitespace()
                            .next()
                            .and_then(|x| x.parse().ok())
                            .unwrap_or(0);
                    }
                    if let Ok(s) = std::fs::read_to_string(p.join("stat"))
                        && s.rsplit_once(')')
                            .is_some_and(|(_, r)| r.trim_start().starts_with('R'))
                    {
                        running += 1;
                    }
                }
                (ns, running)
            };
            let (mut serial, mut parallel) = (0u64, 0u64);
            let mut last = sample().0;
            while !flag.load(Ordering::Relaxed) {
                std::thread::sleep(std::time::Duration::from_millis(5));
                let (ns, running) = sample();
                let used = ns.saturating_sub(last);
                last = ns;
                if running <= 1 {
                    serial += used;
                } else {
                    parallel += used;
                }
            }
            (serial as f64 * 1e-9, parallel as f64 * 1e-9)
        });
        Sampler { stop, handle }
    }

    /// CPU seconds of serial and of parallel work.
    fn finish(self) -> (f64, f64) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        self.handle.join().unwrap_or((0.0, 0.0))
    }
}

fn main() -> anyhow::Result<()> {
    let Some(path) = std::env::args().nth(1) else {
        anyhow::bail!("usage: load_bench SCENE [--flatten-instances]");
    };
    let options = ftpd3d::scene::load::LoadOptions {
        flatten_instances: std::env::args().any(|a| a == "--flatten-instances"),
        ..Default::default()
    };
    let rss_before = status_bytes("VmRSS");
    let sampler = Sampler::start();
    let start = Instant::now();
    let scene = ftpd3d::scene::load::load_scene_with(std::path::Path::new(&path), &[], &options)?;
    let seconds = start.elapsed().as_secs_f64();
    let (serial, parallel) = sampler.finish();
    let (embree, embree_peak) = ftpd3d::accel::embree_memory();
    let (rss, hwm) = (status_bytes("VmRSS"), status_bytes("VmHWM"));
    for w in &scene.report.warnings {
        eprintln!("warning: {w}");
    }
    let n = scene.triangles.len().max(1) as f64;
    let mb = |b: u64| b as f64 / 1e6;
    println!("scene            {path}");
    println!(
        "triangles        {} ({} vertices{})",
        scene.triangles.len(),
        scene.positions.len(),
        if scene.has_shading_normals() {
            ", shading normals"
        } else {
            ""
        }
    );
    if scene.is_instanced() {
        let inst = scene.instancing();
        println!(
            "instances        {} of {} prototype(s), placing {} triangles",
            inst.instances.len(),
            inst.prototypes.len(),
            inst.instanced_triangles()
        );
    }
    println!(
        "load             {seconds:.2} s: parse {:.2} s, BVH {:.2} s",
        scene.report.parse_seconds, scene.report.bvh_seconds
    );
    println!(
        "CPU              {:.2} s: {serial:.2} s serial, {parallel:.2} s with two or more threads \
         wanting to run; on two free cores about {:.2} s",
        serial + parallel,
        serial + parallel / 2.0
    );
    println!(
        "resident         {:.0} MB after loading, {:.0} MB at the peak (process before: {:.0} MB)",
        mb(rss),
        mb(hwm),
        mb(rss_before)
    );
    println!(
        "Embree           {:.0} MB after loading, {:.0} MB at its peak",
        mb(embree),
        mb(embree_peak)
    );
    println!(
        "per triangle     {:.0} B resident besides Embree after loading; peak {:.0} B besides \
         Embree's peak; Embree {:.0} B",
        (rss.saturating_sub(rss_before + embree)) as f64 / n,
        (hwm.saturating_sub(rss_before + embree_peak)) as f64 / n,
        embree as f64 / n
    );
    Ok(())
}
